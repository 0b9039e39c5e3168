//! # lasalle-codegen
//!
//! The lasalle generator: a model file (`.lsl`) is parsed, lowered into one hash-consed
//! expression DAG, differentiated and simplified symbolically, checked (shapes, names,
//! conservation of every declared integral) and emitted as plain, formatted Rust.
//!
//! Pipeline: [`parse`] → [`model`] (lowering onto [`ir`]) → [`derive`] → [`check`] → [`emit`].
#![warn(missing_docs)]

pub mod check;
pub mod derive;
pub mod emit;
mod error;
pub mod ir;
pub mod model;
pub mod parse;

pub use error::{Diagnostic, Error, Result, Source, Span};
pub use model::Model;

use std::sync::Arc;

/// Parses and lowers model text (no conservation check, no emission).
pub fn lower_source(path: &str, text: &str) -> Result<Model> {
    let source = Arc::new(Source { path: path.to_string(), text: text.to_string() });
    let ast = parse::parse(&source)?;
    model::lower(&ast, source)
}

/// Reads, parses and lowers a model file.
pub fn load_model(path: impl AsRef<std::path::Path>) -> Result<Model> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.display().to_string(), source: e })?;
    lower_source(&path.display().to_string(), &text)
}
