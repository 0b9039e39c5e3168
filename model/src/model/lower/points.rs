//! Named points: `point NAME { x = …; … }`, every state variable as parameters' expressions.

use super::{Ctx, Lowerer, L};
use crate::error::{Diagnostic, Span};
use crate::ir::{Id, Input};
use crate::model::{Point, StateVar};
use crate::parse::ast::*;

impl Lowerer {
    /// `point NAME { … }`, refused when its method name would clash with an earlier point's.
    pub(super) fn point_item(
        &mut self,
        name: &Ident,
        values: &[(Ident, Expr)],
        state: &[StateVar],
        span: &Span,
        points: &mut Vec<Point>,
    ) -> L<()> {
        let method = crate::names::snake(&name.name);
        match points
            .iter()
            .find(|p: &&Point| crate::names::snake(&p.name) == method)
        {
            Some(prev) => {
                let (line, _) = prev.span.line_col();
                Err(Diagnostic::new(
                    &name.span,
                    format!(
                        "point `{}` would be the method `point_{method}` of the point `{}` on line {line}",
                        name.name, prev.name
                    ),
                )
                .help("give each point its own name"))
            }
            None => self
                .point(name, values, state, span)
                .map(|p| points.push(p)),
        }
    }

    pub(super) fn point(
        &mut self,
        name: &Ident,
        values: &[(Ident, Expr)],
        state: &[StateVar],
        span: &Span,
    ) -> L<Point> {
        let n: usize = state.iter().map(|s| s.shape.len()).sum();
        let mut out: Vec<Option<Id>> = vec![None; n];
        for (var, e) in values {
            let Some(s) = state.iter().find(|s| s.name == var.name) else {
                return Err(Diagnostic::new(
                    &var.span,
                    format!("`{}` is not a state variable", var.name),
                )
                .help("a point assigns every state variable"));
            };
            let v = self.expr(e, Ctx::Model)?;
            let v = if self.families.contains_key(&s.name) {
                self.family_value(s.shape, e, v)
            } else {
                v
            };
            if v.shape != s.shape {
                return Err(Diagnostic::new(
                    &e.span,
                    format!(
                        "`{}` is a {} but this value is a {}",
                        s.name, s.shape, v.shape
                    ),
                ));
            }
            if v.ids
                .iter()
                .any(|&id| self.g.depends_on(id, |i| matches!(i, Input::State(_))))
            {
                return Err(Diagnostic::new(
                    &e.span,
                    "a point's coordinates may depend on parameters only",
                ));
            }
            for (k, &id) in v.ids.iter().enumerate() {
                out[s.offset + k] = Some(id);
            }
        }
        let missing: Vec<&str> = state
            .iter()
            .filter(|s| out[s.offset].is_none())
            .map(|s| s.name.as_str())
            .collect();
        if !missing.is_empty() {
            return Err(Diagnostic::new(
                &name.span,
                format!("point `{}` does not give {}", name.name, missing.join(", ")),
            )
            .help("assign every state variable, e.g. `x = [1, 0, 0];`"));
        }
        Ok(Point {
            name: name.name.clone(),
            values: out.into_iter().map(Option::unwrap).collect(),
            span: span.clone(),
        })
    }
}
