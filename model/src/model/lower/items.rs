//! Pass 2: every item other than state and parameters, in file order (so that names are
//! defined before they are used and problems are reported in the order they occur).

use super::{Ctx, Lowerer, L};
use crate::error::{Diagnostic, DiagnosticKind, Span};
use crate::ir::Id;
use crate::model::{
    Binding, Event, Gain, Guard, Invariant, InvariantKind, Point, Preset, StateVar,
};
use crate::parse::ast::*;

/// What pass 2 collects, item by item.
pub(super) struct Items<'a> {
    /// For each state component, its equation and the span of the item that gives it.
    pub(super) field: Vec<Option<(Id, Span)>>,
    pub(super) invariants: Vec<Invariant>,
    pub(super) gains: Vec<Gain>,
    pub(super) lets: Vec<Binding>,
    /// The `lyapunov` item: its name, expression and span.
    pub(super) lyapunov: Option<(Ident, &'a Expr, Span)>,
    /// The `hamiltonian` item: its name, H and span.
    pub(super) hamiltonian: Option<(Ident, Id, Span)>,
    pub(super) structure: Option<(&'a StructureDecl, Span)>,
    pub(super) points: Vec<Point>,
    pub(super) presets: Vec<Preset>,
    pub(super) guards: Vec<Guard>,
    pub(super) events: Vec<Event>,
    /// The `splitting` item: its kind, arguments and span.
    pub(super) splitting: Option<(&'a Ident, &'a Vec<Ident>, Span)>,
}

impl Lowerer {
    /// Lowers every item but state and parameters, in order; the flat state has `n` components.
    pub(super) fn items<'a>(
        &mut self,
        ast: &'a ModelAst,
        state: &[StateVar],
        n: usize,
    ) -> Items<'a> {
        let mut acc = Items {
            field: vec![None; n],
            invariants: Vec::new(),
            gains: Vec::new(),
            lets: Vec::new(),
            lyapunov: None,
            hamiltonian: None,
            structure: None,
            points: Vec::new(),
            presets: Vec::new(),
            guards: Vec::new(),
            events: Vec::new(),
            splitting: None,
        };
        for it in &ast.items {
            if let Err(d) = self.item(it, state, &mut acc) {
                if d.kind != DiagnosticKind::AlreadyReported {
                    self.errors.push(d);
                }
            }
        }
        acc
    }

    /// One item of pass 2.
    fn item<'a>(&mut self, it: &'a Spanned, state: &[StateVar], acc: &mut Items<'a>) -> L<()> {
        match &it.item {
            Item::State(_) | Item::Param(..) => Ok(()),
            Item::ElementDerivative(name, idx, e) => {
                self.element_derivative(name, idx, e, &it.span, &mut acc.field)
            }
            Item::For(head, inner) => {
                let Item::ElementDerivative(name, idx, e) = &inner.item else {
                    return Err(Diagnostic::new(
                        &inner.span,
                        "`for` takes an equation of a family's member: `for i in 0..n: d/dt q[i] = …;`",
                    )
                    .help("sums, products and lists take their indices themselves: `sum(i in 0..n: …)`, `[i in 0..n: …]`"));
                };
                let mut count = 0;
                self.for_each(head, 0, &mut count, &mut |lw| {
                    lw.element_derivative(name, idx, e, &inner.span, &mut acc.field)
                })
            }
            Item::Let(name, e) => self.binding(name, e, &it.span, &mut acc.lets),
            Item::Derivative(name, e) => self.derivative(name, e, &it.span, &mut acc.field),
            Item::Invariant {
                kind,
                name,
                value,
                gain,
            } => {
                let kind = match kind {
                    InvariantDeclKind::Constraint => InvariantKind::Constraint,
                    InvariantDeclKind::Integral => InvariantKind::Integral,
                };
                self.expr(value, Ctx::Model).and_then(|v| {
                    self.invariant(
                        name,
                        kind,
                        v,
                        gain.as_ref(),
                        false,
                        &it.span,
                        &mut acc.invariants,
                        &mut acc.gains,
                    )
                })
            }
            Item::Lyapunov(name, e) => {
                if let Some((prev, ..)) = &acc.lyapunov {
                    Err(Diagnostic::new(&name.span, "a second `lyapunov` function")
                        .help(format!("V is already defined as `{}`; keep one", prev.name)))
                } else {
                    acc.lyapunov = Some((name.clone(), e, it.span.clone()));
                    Ok(())
                }
            }
            Item::Hamiltonian(name, e) => self.hamiltonian_item(name, e, &it.span, acc),
            Item::Structure(s, span) => {
                if acc.structure.is_some() {
                    Err(Diagnostic::new(span, "a second `structure`")
                        .help("a model has one Poisson structure"))
                } else {
                    acc.structure = Some((s, it.span.clone()));
                    Ok(())
                }
            }
            Item::Point(name, values) => {
                self.point_item(name, values, state, &it.span, &mut acc.points)
            }
            Item::Run(name, values) => self
                .preset(name, values, &it.span)
                .map(|p| acc.presets.push(p)),
            Item::Guard { name, lhs, op, rhs } => self
                .guard(name, lhs, *op, rhs, &it.span)
                .map(|g| acc.guards.push(g)),
            Item::Event {
                name,
                expr,
                zero,
                direction,
                stop,
            } => {
                if let Some(first) = acc.events.iter().find(|e| e.name == name.name) {
                    let line = first.span.line_col().0;
                    Err(
                        Diagnostic::new(&name.span, format!("a second event `{}`", name.name))
                            .help(format!(
                                "the first is declared on line {line}; name each event once"
                            )),
                    )
                } else {
                    self.event(
                        name,
                        expr,
                        zero,
                        direction.as_ref(),
                        stop.is_some(),
                        &it.span,
                    )
                    .map(|e| acc.events.push(e))
                }
            }
            Item::Splitting(kind, args) => {
                if acc.splitting.is_some() {
                    Err(Diagnostic::new(&it.span, "a second `splitting`")
                        .help("a model admits one structure-specific splitting"))
                } else {
                    acc.splitting = Some((kind, args, it.span.clone()));
                    Ok(())
                }
            }
        }
    }
}
