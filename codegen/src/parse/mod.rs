//! Stage 1: text → tokens → syntax tree.

pub mod ast;
mod lexer;
mod parser;

use crate::error::{Diagnostic, Source};
use std::sync::Arc;

/// Parses a model file's text.
pub fn parse(source: &Arc<Source>) -> Result<ast::ModelAst, Diagnostic> {
    let tokens = lexer::lex(source)?;
    parser::Parser::new(tokens).model()
}
