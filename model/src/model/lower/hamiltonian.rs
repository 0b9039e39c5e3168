//! The Hamiltonian route: `hamiltonian H = …` and a `structure` that turns H into equations.

use super::items::Items;
use super::{Ctx, Kind, Lowerer, L};
use crate::error::{Diagnostic, DiagnosticKind, Span};
use crate::ir::{Id, Input, Node, Rational};
use crate::model::{Gain, Hamiltonian, Invariant, InvariantKind, Shape, Structure, Value};
use crate::parse::ast::*;

impl Lowerer {
    /// `hamiltonian H = …;`: H is recorded, and is an automatic integral.
    pub(super) fn hamiltonian_item(
        &mut self,
        name: &Ident,
        e: &Expr,
        span: &Span,
        acc: &mut Items<'_>,
    ) -> L<()> {
        if acc.hamiltonian.is_some() {
            Err(Diagnostic::new(&name.span, "a second `hamiltonian`")
                .help("a model has one Hamiltonian"))
        } else {
            self.expr(e, Ctx::Model).and_then(|v| {
                let h = self.expect_scalar(&v, e, "a Hamiltonian")?;
                self.invariant(
                    name,
                    InvariantKind::Integral,
                    v.clone(),
                    None,
                    true,
                    span,
                    &mut acc.invariants,
                    &mut acc.gains,
                )?;
                acc.hamiltonian = Some((name.clone(), h, span.clone()));
                Ok(())
            })
        }
    }

    /// The Hamiltonian with its structure, from the `hamiltonian` and `structure` items;
    /// the structure's equations go into `field`.
    pub(super) fn hamiltonian_route(
        &mut self,
        hamiltonian: Option<(Ident, Id, Span)>,
        structure: Option<(&StructureDecl, Span)>,
        field: &mut [Option<(Id, Span)>],
        invariants: &mut Vec<Invariant>,
        gains: &mut Vec<Gain>,
    ) -> Option<Hamiltonian> {
        match (hamiltonian, structure) {
            (Some((name, h, _)), Some((s, span))) => {
                let result = self.structure(s, &span, h, field, invariants, gains);
                // The equations are derivatives of H: they can overflow where H did not.
                let result = result.and_then(|s| match self.sweep_constants() {
                    Some(x) => Err(Diagnostic::new(
                        &span,
                        format!("the equations of this structure have a constant that is not finite ({x})"),
                    )
                    .help("they are derivatives of the Hamiltonian: rescale constants near ±1.8e308")
                    .kind(DiagnosticKind::NotFinite)),
                    None => Ok(s),
                });
                match result {
                    Ok(structure) => Some(Hamiltonian {
                        name: name.name,
                        h,
                        structure,
                    }),
                    Err(d) => {
                        self.errors.push(d);
                        None
                    }
                }
            }
            (Some((name, _, span)), None) => {
                self.errors.push(
                    Diagnostic::new(
                        &span,
                        format!("hamiltonian `{}` has no `structure`", name.name),
                    )
                    .help("add `structure canonical(q, p);` or `structure lie_poisson_so3(P);`"),
                );
                None
            }
            (None, Some((_, span))) => {
                self.errors.push(
                    Diagnostic::new(&span, "`structure` without a `hamiltonian`")
                        .help("add `hamiltonian H = …;`"),
                );
                None
            }
            (None, None) => None,
        }
    }

    pub(super) fn structure(
        &mut self,
        s: &StructureDecl,
        span: &Span,
        h: Id,
        field: &mut [Option<(Id, Span)>],
        invariants: &mut Vec<Invariant>,
        gains: &mut Vec<Gain>,
    ) -> L<Structure> {
        let state_indices = |lw: &mut Lowerer, id: &Ident| -> L<(Vec<usize>, Shape)> {
            let sym = lw.lookup(id, Ctx::Model)?;
            if sym.kind != Kind::State {
                return Err(Diagnostic::new(
                    &id.span,
                    format!("`{}` is not a state variable", id.name),
                )
                .help("a structure names state variables"));
            }
            let idx = sym.value.ids.iter().map(|&k| match lw.g.node(k) {
                Node::Input(Input::State(i)) => *i as usize,
                _ => unreachable!("state ids are inputs"),
            });
            Ok((idx.collect(), sym.value.shape))
        };
        let mut assign = |i: usize, value: Id, who: &Ident| -> L<()> {
            if field[i].is_some() {
                return Err(Diagnostic::new(
                    &who.span,
                    format!("`{}` has both a `d/dt` equation and a structure", who.name),
                )
                .help("remove the `d/dt` line: the structure gives its equation"));
            }
            field[i] = Some((value, span.clone()));
            Ok(())
        };
        match s {
            StructureDecl::Canonical(qn, pn) => {
                let (q, qs) = state_indices(self, qn)?;
                let (p, ps) = state_indices(self, pn)?;
                if qs != ps {
                    return Err(Diagnostic::new(
                        &pn.span,
                        format!("`{}` is a {qs} but `{}` is a {ps}", qn.name, pn.name),
                    )
                    .help("canonical pairs q, p have the same shape"));
                }
                let vars: Vec<Input> = q
                    .iter()
                    .chain(&p)
                    .map(|&i| Input::State(i as u32))
                    .collect();
                let grad = crate::ir::gradient(&mut self.g, h, &vars);
                let m = q.len();
                for k in 0..m {
                    assign(q[k], grad[m + k], qn)?;
                    let minus = self.g.neg(grad[k]);
                    assign(p[k], minus, pn)?;
                }
                Ok(Structure::Canonical { q, p })
            }
            StructureDecl::LiePoissonSo3(pn) => {
                let (p, ps) = state_indices(self, pn)?;
                if ps != Shape::Vector(3) {
                    return Err(Diagnostic::new(
                        &pn.span,
                        format!("`{}` is a {ps}, lie_poisson_so3 needs a vec3", pn.name),
                    )
                    .help("declare it `state P: vec3;`"));
                }
                let vars: Vec<Input> = p.iter().map(|&i| Input::State(i as u32)).collect();
                let grad = crate::ir::gradient(&mut self.g, h, &vars);
                let pv: Vec<Id> = p
                    .iter()
                    .map(|&i| self.g.input(Input::State(i as u32)))
                    .collect();
                let rate = self.cross(&pv, &grad);
                for k in 0..3 {
                    assign(p[k], rate[k], pn)?;
                }
                let sq: Vec<Id> = pv
                    .iter()
                    .map(|&x| self.g.pow(x, Rational::int(2)))
                    .collect();
                let casimir = self.g.add(&sq);
                let name = Ident {
                    name: "casimir".into(),
                    span: pn.span.clone(),
                };
                self.invariant(
                    &name,
                    InvariantKind::Integral,
                    Value::scalar(casimir),
                    None,
                    true,
                    span,
                    invariants,
                    gains,
                )?;
                Ok(Structure::LiePoissonSo3 { p })
            }
        }
    }
}
