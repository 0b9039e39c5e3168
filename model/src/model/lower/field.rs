//! The field X(x): `d/dt` equations, and the check that every state component has one.

use super::{Ctx, Kind, Lowerer, L};
use crate::error::{Diagnostic, Span};
use crate::ir::{Id, Input, Node};
use crate::model::StateVar;
use crate::parse::ast::*;

impl Lowerer {
    pub(super) fn derivative(
        &mut self,
        name: &Ident,
        e: &Expr,
        span: &Span,
        field: &mut [Option<(Id, Span)>],
    ) -> L<()> {
        let sym = self.lookup(name, Ctx::Model)?;
        if sym.kind != Kind::State {
            return Err(Diagnostic::new(
                &name.span,
                format!(
                    "`{}` is a {}, not a state variable",
                    name.name,
                    sym.kind.describe()
                ),
            )
            .help("`d/dt` takes a variable declared with `state`"));
        }
        let v = self.expr(e, Ctx::Model)?;
        if v.shape != sym.value.shape {
            return Err(Diagnostic::new(
                &e.span,
                format!(
                    "d/dt {} is a {} but `{}` is a {}",
                    name.name, v.shape, name.name, sym.value.shape
                ),
            )
            .help("the right-hand side must have the state variable's shape"));
        }
        for (k, &state_id) in sym.value.ids.iter().enumerate() {
            let Node::Input(Input::State(i)) = *self.g.node(state_id) else {
                unreachable!("state ids are inputs")
            };
            let slot = &mut field[i as usize];
            if let Some((_, prev)) = slot {
                let (line, _) = prev.line_col();
                return Err(Diagnostic::new(
                    &name.span,
                    format!("`{}` already has an equation", name.name),
                )
                .help(format!("see line {line}; keep one")));
            }
            *slot = Some((v.ids[k], span.clone()));
        }
        Ok(())
    }

    /// `d/dt q[i] = …;`: the equation of member i of a family (or of one component).
    pub(super) fn element_derivative(
        &mut self,
        name: &Ident,
        idx: &[Expr],
        e: &Expr,
        span: &Span,
        field: &mut [Option<(Id, Span)>],
    ) -> L<()> {
        let sym = self.lookup(name, Ctx::Model)?;
        if sym.kind != Kind::State {
            return Err(Diagnostic::new(
                &name.span,
                format!(
                    "`{}` is a {}, not a state variable",
                    name.name,
                    sym.kind.describe()
                ),
            )
            .help("`d/dt` takes a variable declared with `state`"));
        }
        // The target is lowered as the expression `name[idx…]` would be.
        let target_expr = Expr {
            kind: ExprKind::Index(
                Box::new(Expr {
                    kind: ExprKind::Name(name.clone()),
                    span: name.span.clone(),
                }),
                idx.to_vec(),
            ),
            span: {
                // through the closing `]` after the last index
                let last = &idx[idx.len() - 1].span;
                let rest = &last.source.text[last.end..];
                let close = rest.find(']').map_or(last.end, |k| last.end + k + 1);
                Span {
                    end: close,
                    ..name.span.clone()
                }
            },
        };
        let target = self.expr(&target_expr, Ctx::Model)?;
        let v = self.expr(e, Ctx::Model)?;
        if v.shape != target.shape {
            return Err(Diagnostic::new(
                &e.span,
                format!(
                    "d/dt {} is a {} but this is a {}",
                    target_expr.span.text(),
                    target.shape,
                    v.shape
                ),
            )
            .help("the right-hand side must have the shape of the member"));
        }
        for (k, &state_id) in target.ids.iter().enumerate() {
            let Node::Input(Input::State(i)) = *self.g.node(state_id) else {
                unreachable!("state ids are inputs")
            };
            let slot = &mut field[i as usize];
            if let Some((_, prev)) = slot {
                let (line, _) = prev.line_col();
                return Err(Diagnostic::new(
                    &target_expr.span,
                    format!("`{}` already has an equation", target_expr.span.text()),
                )
                .help(format!("see line {line}; keep one")));
            }
            *slot = Some((v.ids[k], span.clone()));
        }
        Ok(())
    }

    /// Every state component needs exactly one equation.
    pub(super) fn check_equations(&mut self, state: &[StateVar], field: &[Option<(Id, Span)>]) {
        for s in state {
            if field[s.offset..s.offset + s.shape.len()]
                .iter()
                .any(Option::is_none)
                && self.errors.is_empty()
            {
                self.errors.push(
                    Diagnostic::new(&s.span, format!("state `{}` has no equation", s.name)).help(
                        format!(
                            "add `d/dt {} = …;` or a Hamiltonian with a structure that covers it",
                            s.name
                        ),
                    ),
                );
            }
        }
    }
}
