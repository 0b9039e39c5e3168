//! The symbol table: declaring names, and the model's own name.

use super::{Kind, Lowerer, Symbol};
use crate::error::{Diagnostic, DiagnosticKind};
use crate::model::Value;
use crate::parse::ast::*;

impl Lowerer {
    pub(super) fn declare(&mut self, name: &Ident, kind: Kind, value: Value) {
        if crate::vocabulary::is_reserved(&name.name) {
            self.errors.push(
                Diagnostic::new(
                    &name.span,
                    format!(
                        "`{}` is reserved and cannot name a {}",
                        name.name,
                        kind.describe()
                    ),
                )
                .help("choose another name")
                .kind(DiagnosticKind::Reserved),
            );
            return;
        }
        if let Some(prev) = self.symbols.get(&name.name) {
            let (line, _) = prev.span.line_col();
            self.errors.push(
                Diagnostic::new(&name.span, format!("`{}` is already defined", name.name)).help(
                    format!(
                        "it is a {} declared on line {line}; choose another name",
                        prev.kind.describe()
                    ),
                ),
            );
            return;
        }
        self.symbols.insert(
            name.name.clone(),
            Symbol {
                kind,
                value,
                span: name.span.clone(),
            },
        );
    }

    /// The model's name becomes a Rust type: keywords and names the emitted code uses itself
    /// are refused (a renamed struct would surprise whoever imports it).
    pub(super) fn check_model_name(&mut self, name: &Ident) {
        if let Some(why) = crate::names::reserved_type_name(&name.name) {
            self.errors.push(
                Diagnostic::new(
                    &name.span,
                    format!("`{}` cannot name a model: {why}", name.name),
                )
                .help(format!(
                    "the model's name is the generated struct's; choose another, e.g. `{}Model`",
                    name.name.trim_matches('_')
                )),
            );
        }
    }
}
