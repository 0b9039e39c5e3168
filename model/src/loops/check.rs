//! The conservation of the integrals of a [`LoopModel`], on the families' bodies.
//!
//! For an integral `I = c + Σ_A k_A Σ_a φ_A(a)` (a constant plus family sums) whose families
//! read each state component from at most one tuple, the Lie derivative along the loop field
//! `X = X₀ + Σ_B scatter_B` is `Σ_B Σ_b E_B(b)` with, per field family B and tuple b,
//! `E_B(b) = Σ_o v_o(b) · ∂φ_A/∂slot(x[s_o(b)])`: each output v_o of B's body times the partial
//! of φ_A with respect to the component it is added to, the slots of A's tuple expressed as
//! slots of B's tuple (or as fresh symbols where B does not read them). If `E_B` expands to 0
//! as a function of its symbols for every B (and X₀ is 0 where A reads), the integral is
//! proved conserved, from one expression per family whatever N — for momentum, `E_B` is
//! `∂g/∂q[i] + ∂g/∂q[j]` of the pair term g.
//!
//! The Hamiltonian of a canonical structure is conserved because the structure is
//! antisymmetric (`∇H · J∇H = 0`), when H reads only the structure's q and p.
//!
//! Anything else is sampled: `∇I · X` evaluated at random states, exactly up to rounding
//! (each family's partials per tuple, times the field's components they multiply), and
//! accepted when it is zero relative to the size of its terms, as the unrolled check does.

use super::{Builder, LoopModel, Outputs, Source};
use crate::check::{prove, Conservation, Verdict, EXPAND_LIMIT, SAMPLES, TOLERANCE};
use crate::error::{Diagnostic, Error};
use crate::ir::{FxHashMap, Graph, Id, Input};
use crate::model::{InvariantKind, Structure};
use crate::Rng;

/// Fresh symbols of the proofs (above the families' own).
const FRESH: u32 = 1 << 30;

impl LoopModel {
    /// Shows every declared invariant conserved by the loop field: proved on the families'
    /// bodies where the module's argument applies, else sampled. A constraint is refused (it
    /// is checked on its manifold by the unrolled model); an invariant found not conserved is
    /// an error at its declaration.
    pub fn check(&self) -> Result<Vec<Conservation>, Error> {
        let mut b = Builder::new(self);
        let (roots, field) = b.field()?;
        let m = &self.model;
        let params = m.default_params();
        let mut out = Vec::new();
        let mut errors = Vec::new();
        for f in &m.invariants {
            if f.kind == InvariantKind::Constraint {
                errors.push(
                    Diagnostic::new(&f.span, format!("constraint `{}`: constraints of a model with families kept as loops are not checked", f.name))
                        .help("load the model with its families unrolled"),
                );
                continue;
            }
            let mut proved = true;
            let mut parts = Vec::new();
            for (c, &id) in f.value.ids.iter().enumerate() {
                let mut terms = Outputs::default();
                let e0 = b.split(id, c as u32, &f.span, &mut terms)?;
                let by_structure = m.hamiltonian.as_ref().is_some_and(|h| h.h == id)
                    && self.hamiltonian_reads_only_pairs(&b, e0, &terms);
                if !by_structure && !b.prove(e0, &terms, &roots, &field) {
                    proved = false;
                }
                parts.push((e0, terms));
            }
            if proved {
                out.push(Conservation {
                    name: f.name.clone(),
                    verdict: Verdict::Proved,
                });
                continue;
            }
            match b.sample(&parts, &params) {
                Ok((samples, worst)) => out.push(Conservation {
                    name: f.name.clone(),
                    verdict: Verdict::Sampled {
                        samples,
                        worst_relative: worst,
                    },
                }),
                Err((c, v, scale)) => {
                    let component = if f.value.shape.len() > 1 {
                        format!(" (component {c})")
                    } else {
                        String::new()
                    };
                    errors.push(
                        Diagnostic::new(
                            &f.span,
                            format!(
                                "integral `{}`{component} is not conserved by the field: its rate of change is {v:.3e} (terms of size {scale:.3e}) at a random state",
                                f.name
                            ),
                        )
                        .help("check the equations and the integral"),
                    );
                }
            }
        }
        if errors.is_empty() {
            Ok(out)
        } else {
            Err(Error::Model(errors))
        }
    }

    /// Does H (`e0` plus the family `terms`) read only the q and p of its canonical structure?
    fn hamiltonian_reads_only_pairs(&self, b: &Builder<'_>, e0: Id, terms: &Outputs) -> bool {
        let Some(h) = &self.model.hamiltonian else {
            return false;
        };
        let Structure::Canonical { q, p } = &h.structure else {
            return false;
        };
        let mut pair = vec![false; self.model.dim()];
        q.iter().chain(p).for_each(|&s| pair[s] = true);
        let plain =
            !b.g.depends_on(e0, |i| matches!(i, Input::State(s) if !pair[s as usize]));
        plain
            && terms.keys().all(|&a| {
                self.families[a].slots.iter().all(|s| {
                    s.source == Source::Param || s.column.iter().all(|&x| pair[x as usize])
                })
            })
    }
}

impl Builder<'_> {
    /// The argument of the module docs for one component `e0 + terms` of an integral; `false`
    /// is "not proved".
    fn prove(&mut self, e0: Id, terms: &Outputs, x0: &[Id], field: &Outputs) -> bool {
        if self.g.depends_on(e0, |i| matches!(i, Input::State(_))) {
            return false;
        }
        let lm = self.lm;
        // E_B of every field family B, as lists of terms.
        let mut e: std::collections::BTreeMap<usize, Vec<Id>> = Default::default();
        let mut fresh = FRESH;
        let mut symbol_of: FxHashMap<(Source, Vec<u32>), u32> = FxHashMap::default();
        for (&a, outs) in terms {
            let fam = &lm.families[a];
            // Who reads each state component.
            let mut reader: FxHashMap<u32, (usize, usize)> = FxHashMap::default();
            for (k, s) in fam.slots.iter().enumerate() {
                if s.source != Source::State {
                    continue;
                }
                for (t, &x) in s.column.iter().enumerate() {
                    if reader.insert(x, (t, k)).is_some() {
                        return false;
                    }
                    if self.g.as_num(x0[x as usize]) != Some(0.0) {
                        return false;
                    }
                }
            }
            for &(phi, _) in outs {
                let vars: Vec<Input> = fam.slots.iter().map(|s| Input::Symbol(s.symbol)).collect();
                let grad = crate::ir::gradient(&mut self.g, phi, &vars);
                for (&bf, bouts) in field {
                    let bfam = &lm.families[bf];
                    let mine: FxHashMap<(Source, &[u32]), u32> = bfam
                        .slots
                        .iter()
                        .map(|s| ((s.source, &s.column[..]), s.symbol))
                        .collect();
                    for (v, col) in bouts {
                        // The slot of A each tuple's output lands on: one for all tuples, or none.
                        let hits: Vec<Option<(usize, usize)>> =
                            col.iter().map(|x| reader.get(x).copied()).collect();
                        let Some(first) = hits[0] else {
                            if hits.iter().any(Option::is_some) {
                                return false;
                            }
                            continue;
                        };
                        if hits.iter().any(|h| h.map(|(_, k)| k) != Some(first.1)) {
                            return false;
                        }
                        // A's slots at the tuple each output lands on, as symbols of B's tuple.
                        let mut rename: FxHashMap<u32, u32> = FxHashMap::default();
                        for s in &fam.slots {
                            let d: Vec<u32> = hits
                                .iter()
                                .map(|h| s.column[h.expect("checked").0])
                                .collect();
                            let sym = match mine.get(&(s.source, &d[..])) {
                                Some(&sym) => sym,
                                None => *symbol_of.entry((s.source, d)).or_insert_with(|| {
                                    fresh += 1;
                                    fresh - 1
                                }),
                            };
                            rename.insert(s.symbol, sym);
                        }
                        let partial = self.g.rename_inputs(&[grad[first.1]], |i| match i {
                            Input::Symbol(s) => Input::Symbol(rename.get(&s).copied().unwrap_or(s)),
                            i => i,
                        })[0];
                        let term = self.g.mul(&[*v, partial]);
                        e.entry(bf).or_default().push(term);
                    }
                }
            }
        }
        let mut scratch: Graph = self.g.clone();
        e.values().all(|ts| {
            let sum = scratch.add(ts);
            prove::vanishes(&mut scratch, sum, EXPAND_LIMIT)
        })
    }

    /// `∇I · X` of the components `parts` at random states: `Ok((samples, worst relative))`, or
    /// the first component that is not zero, with its value and the size of its terms.
    #[allow(clippy::type_complexity)]
    fn sample(
        &mut self,
        parts: &[(Id, Outputs)],
        params: &[f64],
    ) -> Result<(usize, f64), (usize, f64, f64)> {
        let lm = self.lm;
        let n = lm.model.dim();
        let tapes = lm.tapes().map_err(|_| (0, f64::NAN, f64::NAN))?;
        let vars: Vec<Input> = (0..n as u32).map(Input::State).collect();
        // Per component: the plain part's gradient, and per family the body's partials.
        let mut grads = Vec::new();
        for (e0, terms) in parts {
            let g0 = crate::ir::gradient(&mut self.g, *e0, &vars);
            let mut fams = Vec::new();
            for (&a, outs) in terms {
                let fam = &lm.families[a];
                let slots: Vec<Input> = fam.slots.iter().map(|s| Input::Symbol(s.symbol)).collect();
                for &(phi, _) in outs {
                    fams.push((a, crate::ir::gradient(&mut self.g, phi, &slots)));
                }
            }
            grads.push((g0, fams));
        }
        let mut rng = Rng::new(0x1a5a11e);
        let (mut samples, mut worst) = (0, 0.0f64);
        let mut attempts = 0;
        while samples < SAMPLES && attempts < 20 * SAMPLES {
            attempts += 1;
            let x: Vec<f64> = (0..n).map(|_| rng.uniform(-1.5, 1.5)).collect();
            let Ok(xdot) = tapes.field.eval(params, &x) else {
                continue;
            };
            let mut values = Vec::new();
            for (g0, fams) in &grads {
                let (mut v, mut scale) = (0.0, 0.0);
                let plain = self.g.eval_f64(g0, &mut |i| match i {
                    Input::State(k) => x[k as usize],
                    Input::Param(k) => params[k as usize],
                    _ => f64::NAN,
                });
                for (d, xd) in plain.iter().zip(&xdot) {
                    v += d * xd;
                    scale += (d * xd).abs();
                }
                for (a, partials) in fams {
                    let fam = &lm.families[*a];
                    let at: FxHashMap<u32, usize> = fam
                        .slots
                        .iter()
                        .enumerate()
                        .map(|(k, s)| (s.symbol, k))
                        .collect();
                    for t in 0..fam.count {
                        let d = self.g.eval_f64(partials, &mut |i| match i {
                            Input::Symbol(s) => match at.get(&s) {
                                Some(&k) => {
                                    let slot = &fam.slots[k];
                                    let j = slot.column[t] as usize;
                                    match slot.source {
                                        Source::State => x[j],
                                        Source::Param => params[j],
                                    }
                                }
                                None => f64::NAN,
                            },
                            Input::State(k) => x[k as usize],
                            Input::Param(k) => params[k as usize],
                            _ => f64::NAN,
                        });
                        for (slot, dk) in fam.slots.iter().zip(d) {
                            if slot.source == Source::State {
                                let term = dk * xdot[slot.column[t] as usize];
                                v += term;
                                scale += term.abs();
                            }
                        }
                    }
                }
                values.push((v, scale));
            }
            if values.iter().any(|(v, s)| !v.is_finite() || !s.is_finite()) {
                continue;
            }
            for (c, &(v, scale)) in values.iter().enumerate() {
                let rel = if scale > 0.0 { v.abs() / scale } else { 0.0 };
                if rel > TOLERANCE && v.abs() > 1e-300 {
                    return Err((c, v, scale));
                }
                worst = worst.max(rel);
            }
            samples += 1;
        }
        Ok((samples, worst))
    }
}
