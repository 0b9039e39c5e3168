//! # lasalle-model
//!
//! The lasalle front end: a model file (`.lsl`) is parsed, lowered into one hash-consed
//! expression DAG, differentiated and simplified symbolically, checked (shapes, names,
//! conservation of every declared integral) and lowered to tapes, the execution IR the back
//! ends run. Emission — plain, formatted Rust implementing the traits of `lasalle-runtime` —
//! is `lasalle-codegen`'s, which re-exports this crate's pipeline; the back ends that run a
//! model without emitting it (`lasalle-exec`'s interpreter and JIT, `lasalle-normal-form`, the
//! stability analyses) depend on this crate only, so none of them builds syn, quote or
//! prettyplease.
//!
//! Pipeline: parse → lower (onto [`ir`]) → derive → check here, then emit in
//! `lasalle-codegen`, each stage a function of the previous stage's output type:
//!
//! ```text
//! lasalle-model    lower_source(path, text) -> Model        parse and lower onto one hash-consed graph
//!                  derive(Model)            -> Derived      Df, ∇f·X, ∇V, X − ∇V, the partition
//!                  check(&Derived)          -> Checked<'_>  every invariant conserved, every constant finite
//!                  ModelTapes::new(&Derived)                the tapes: field, Jacobian, V, ∇V, …
//!                  TaylorProgram::new(&Tape)                a field tape's Taylor recurrences
//! lasalle-codegen  emit(&Checked)           -> Emitted      Rust items, statistics, the tape kernels
//! ```
//! ([`lower_source`], [`derive()`], [`check()`], [`tape::ModelTapes::new`],
//! [`tape::taylor::TaylorProgram::new`]; `lasalle_codegen::generate_source` runs the whole
//! pipeline.)
//!
//! # What is public
//!
//! The stages are private modules; what they hand over is re-exported here, in one list: the
//! stage functions and their output types, the lowered [`Model`] with the types of its
//! fields, the conservation verdicts and the errors. Four modules are public because other
//! crates build on them: [`ir`], the expression graph (evaluated generically over a
//! [`Scalar`](ir::Scalar) by the normal forms and the stability analysis, and the home of the
//! pure graph operations [`ir::diff`] and [`ir::gradient`], so lowering — Hamilton's equations
//! need ∇H — never calls a later stage); [`tape`], the execution IR the JIT, the interpreter
//! and the Taylor kernels run ([`tape::ModelTapes::new`] takes a [`Derived`] model), with
//! [`tape::taylor`], the Taylor program every Taylor back end runs; [`vocabulary`], the DSL's
//! built-in functions and keywords, declared once; [`splitting`], the structure-specific
//! splittings, a module and a table row per kind; [`variational`], the variational equations
//! and chaos indicators as a transformation of the lowered model; and [`names`], the Rust
//! identifiers of model
//! names (lowering refuses a model name the emitted code cannot use, the emitter names its
//! items with the same rules). What the field's structure is (partitioned or not) is asked of
//! the model ([`Model::partition`]).
//!
//! ```
//! let text = "model Osc { state q: scalar, p: scalar; param w = 2;
//!             d/dt q = p; d/dt p = -w^2 * q; integral E = p^2/2 + w^2 * q^2/2; }";
//! let derived = lasalle_model::derive(lasalle_model::lower_source("osc.lsl", text)?);
//! let checked = lasalle_model::check(&derived)?;
//! assert_eq!(checked.conservation().len(), 1);
//! let tapes = lasalle_model::tape::ModelTapes::new(&derived)?;
//! assert_eq!(tapes.field.outputs.len(), 2);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

mod check;
mod derive;
mod error;
pub mod ir;
pub mod loops;
mod model;
pub mod names;
mod parse;
mod rng;
pub mod splitting;
pub mod tape;
pub mod variational;
pub mod vocabulary;

pub use check::{check, Checked, Conservation, Verdict};
pub use derive::{derive, Derivatives, Derived};
pub use error::{Diagnostic, DiagnosticKind, Error, Result, Source, Span};
pub use model::{
    Binding, CanonicalHamiltonian, Delay, Direction, Event, Gain, Guard, Hamiltonian, Invariant,
    InvariantKind, Model, NotCanonical, Param, Point, Preset, Shape, StateVar, Structure, Value,
    EVENT_TIME, GUARD_STEP, MAX_DELAYS,
};
pub use rng::Rng;
pub use splitting::{Splitting, SplittingKind, SPLITTINGS};

use std::path::Path;
use std::sync::Arc;

/// Parses and lowers model text (no conservation check, no emission).
pub fn lower_source(path: &str, text: &str) -> Result<Model> {
    let source = Arc::new(Source {
        path: path.to_string(),
        text: text.to_string(),
    });
    let ast = parse::parse(&source)?;
    model::lower(&ast, source)
}

/// Reads, parses and lowers a model file.
pub fn load_model(path: impl AsRef<Path>) -> Result<Model> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| Error::Io {
        path: path.display().to_string(),
        source: e,
    })?;
    lower_source(&path.display().to_string(), &text)
}
