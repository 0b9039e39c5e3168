//! `let` bindings: a named value, kept so generated code can name its temporaries after it.

use super::{Ctx, Kind, Lowerer, L};
use crate::error::Span;
use crate::model::Binding;
use crate::parse::ast::*;

impl Lowerer {
    /// `let NAME = …;`: lowered, declared and recorded; a failed definition poisons the name
    /// so that its uses are not reported again.
    pub(super) fn binding(
        &mut self,
        name: &Ident,
        e: &Expr,
        span: &Span,
        lets: &mut Vec<Binding>,
    ) -> L<()> {
        match self.expr(e, Ctx::Model) {
            Ok(v) => {
                lets.push(Binding {
                    name: name.name.clone(),
                    value: v.clone(),
                    span: span.clone(),
                });
                self.declare(name, Kind::Let, v);
                Ok(())
            }
            Err(d) => {
                self.poisoned.insert(name.name.clone());
                Err(d)
            }
        }
    }
}
