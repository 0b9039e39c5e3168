//! Invariants and the Lyapunov function: constraints and integrals with their gains, and V,
//! explicit or Σ kᵢ/2 |fᵢ − fᵢ(x₀)|².

use super::{Ctx, Kind, Lowerer, Symbol, L};
use crate::error::{Diagnostic, Span};
use crate::ir::{Id, Input, Rational};
use crate::model::{Gain, Invariant, InvariantKind, Value};
use crate::parse::ast::*;

impl Lowerer {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn invariant(
        &mut self,
        name: &Ident,
        kind: InvariantKind,
        value: Value,
        gain: Option<&GainDecl>,
        automatic: bool,
        span: &Span,
        invariants: &mut Vec<Invariant>,
        gains: &mut Vec<Gain>,
    ) -> L<()> {
        let (gain_name, default) = match gain {
            Some(GainDecl { name: gname, value }) => {
                let v = self.expr(value, Ctx::Constant)?;
                let k = self.expect_scalar(&v, value, "a gain")?;
                let Some(k) = self.g.as_num(k) else {
                    unreachable!("constant context folds")
                };
                if !(k >= 0.0 && k.is_finite()) {
                    return Err(Diagnostic::new(
                        &value.span,
                        format!("gain {k} is not a non-negative number"),
                    )
                    .help("gains weigh |f − f(x₀)|² in V and must be ≥ 0"));
                }
                (
                    gname
                        .as_ref()
                        .map_or_else(|| format!("k_{}", name.name), |n| n.name.clone()),
                    k,
                )
            }
            None => (format!("k_{}", name.name), 1.0),
        };
        if let Some(g) = gain.and_then(|g| g.name.as_ref()) {
            if gains.iter().any(|x| x.name == g.name) || self.symbols.contains_key(&g.name) {
                return Err(
                    Diagnostic::new(&g.span, format!("`{}` is already defined", g.name))
                        .help("give each gain its own name"),
                );
            }
        }
        let offset = invariants.iter().map(|f| f.value.shape.len()).sum();
        self.invariant_offsets
            .insert(name.name.clone(), (offset, value.shape));
        invariants.push(Invariant {
            name: name.name.clone(),
            kind,
            value: value.clone(),
            offset,
            gain: gains.len(),
            automatic,
            span: span.clone(),
        });
        let gain_id = self.g.input(Input::Gain(gains.len() as u32));
        self.symbols.insert(
            gain_name.clone(),
            Symbol {
                kind: Kind::Gain,
                value: Value::scalar(gain_id),
                span: span.clone(),
            },
        );
        gains.push(Gain {
            name: gain_name,
            default,
        });
        self.declare(
            name,
            if automatic {
                Kind::Hamiltonian
            } else {
                Kind::Invariant
            },
            value,
        );
        Ok(())
    }

    /// V: the explicit `lyapunov` item, or Σ kᵢ/2 |fᵢ − fᵢ(x₀)|²; with the item's span.
    pub(super) fn lyapunov(
        &mut self,
        lyapunov: Option<(Ident, &Expr, Span)>,
        invariants: &[Invariant],
    ) -> (Id, Option<Span>) {
        match lyapunov {
            Some((_, e, span)) => match self
                .expr(e, Ctx::Lyapunov)
                .and_then(|v| self.expect_scalar(&v, e, "V"))
            {
                Ok(v) => (v, Some(span)),
                Err(d) => {
                    self.errors.push(d);
                    (self.g.num(0.0), None)
                }
            },
            None => (self.default_lyapunov(invariants), None),
        }
    }

    pub(super) fn default_lyapunov(&mut self, invariants: &[Invariant]) -> Id {
        let mut terms = Vec::new();
        for f in invariants {
            let mut squares = Vec::new();
            for (k, &id) in f.value.ids.iter().enumerate() {
                let t = self.g.input(Input::Target((f.offset + k) as u32));
                let d = self.g.sub(id, t);
                squares.push(self.g.pow(d, Rational::int(2)));
            }
            let sum = self.g.add(&squares);
            let k = self.g.input(Input::Gain(f.gain as u32));
            let half = self.g.num(0.5);
            terms.push(self.g.mul(&[half, k, sum]));
        }
        self.g.add(&terms)
    }
}
