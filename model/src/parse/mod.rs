//! Stage 1: text → tokens → syntax tree.

pub mod ast;
mod lexer;
mod parser;

use crate::error::{Diagnostic, Source};
use std::sync::Arc;

/// Parses a model file's text.
pub fn parse(source: &Arc<Source>) -> Result<ast::ModelAst, Diagnostic> {
    let syntax = |d: Diagnostic| d.kind(crate::DiagnosticKind::Syntax);
    let tokens = lexer::lex(source).map_err(syntax)?;
    parser::Parser::new(tokens).model().map_err(syntax)
}
