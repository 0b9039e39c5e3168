//! The variational equations and the chaos indicators of a [`LoopModel`] in loop form: the
//! extension of [`crate::variational`] built from the families' bodies, without unrolling.
//!
//! A tangent vector w is transported by ẇ = A·w, A = DX. A·w is a Jacobian-vector product:
//! the plain part's directional derivative, plus, per family output `e` (a term of the field
//! scattered to the outputs its column names), the body's directional derivative
//! `Σ_v ∂e/∂v · w_v` over the state the body reads (its state slots and the state it reads
//! directly), taken once symbolically and scattered to the tangent rows of the same outputs.
//! The tangent's components are gathered as slots of a copy of the family: per tangent vector
//! and state slot, a slot reading the same indices shifted to the tangent's block. So A·w is
//! one more loop region per family and tangent, whose code is independent of the tuples.
//!
//! - [`Extension::Variational`] with k tangents: the field (X, A·w₁, …, A·w_k) is one
//!   [`LoopTape`] ([`ExtendedField::Loop`]): the interpreter, the JIT and the loop form of the
//!   Taylor program run it as any loop field.
//! - [`Extension::Indicators`]: the rates u̇ = Au − λu, ℓ̇ = λ, ȧ = τλ read λ = u·Au/(u·u), a
//!   quotient of a sum over the families, which no single pass of a loop tape (a plain tape
//!   plus regions added to its outputs) computes. The field is then staged as V's functions
//!   are ([`LoopFeedback`], [`ExtendedField::Staged`]): stage 1, a loop tape of the extended
//!   state, computes `S = (A·u, 0, 0, 0, 0)` (N + 4 sums); stage 2, a plain tape of `[x, S]`,
//!   computes λ and the rates of (u, ℓ, τ, a, b) ([`crate::variational`]'s expressions on
//!   `A·u = S`); stage 3, a loop tape of `[x, S, w]`, is X (the field's plain part and
//!   regions) followed by the stage-2 rates read back from `w`. The peak event `λ = 0 falling`
//!   is stages 1 and 2 with the time as the one gain ([`LoopExtension::peak`]). The field's
//!   Taylor program is [`LoopFeedback::taylor`] of its stages (stage 1's recurrences, then
//!   stage 2's, then stage 3's, at each order on one table, as for X − ∇V,
//!   [`crate::loops::feedback_taylor`]): the rates read back from `w` give their order k + 1
//!   as X's do.
//!
//! The extended model's declarations ([`LoopExtension::declarations`]) are those of
//! [`Extension::apply`] (state, event, points); its invariants are the model's, as loop tapes
//! of the extended state ([`LoopExtension::invariants`], [`LoopExtension::jacobian`]); its
//! unrolled form is [`Extension::apply`] of the unrolled model ([`LoopExtension::unrolled`]).

use super::derived::Column;
use super::{Builder, LoopFeedback, LoopModel, LoopTape, Outputs, Slot, Source};
use crate::error::Error;
use crate::ir::{gradient, Id, Input, Node};
use crate::model::Model;
use crate::tape::{Dims, Tape, TapeError};
use crate::variational::{indicator_rates, Extension};

/// A [`LoopModel`] extended by the variational equations or the chaos indicators; see the
/// [module docs](self).
#[derive(Clone, Debug)]
pub struct LoopExtension {
    extension: Extension,
    /// The original model's dimension N.
    n: usize,
    /// The extended declarations, with the families followed by their copies with tangent
    /// slots (family `f`, tangent `j` at `F·(1 + j) + f`).
    lm: LoopModel,
    /// Per family: its number F in the original model.
    originals: usize,
    /// `[f][j][k]`: the symbol of tangent `j`'s slot paired with state slot `k` of family `f`.
    tangent_slots: Vec<Vec<Vec<Option<u32>>>>,
}

/// The field of an extended loop model.
#[derive(Clone, Debug)]
pub enum ExtendedField {
    /// One loop tape (the variational equations).
    Loop(LoopTape),
    /// Staged (the indicators): the field is the `feedback` stage of the [`LoopFeedback`],
    /// whose sums and weights are stages 1 and 2 (see the [module docs](self)).
    Staged(Box<LoopFeedback>),
}

impl ExtendedField {
    /// The field at `x` (an extended state) in f64 from the tapes, in the order every back end
    /// runs them.
    pub fn eval(&self, params: &[f64], x: &[f64]) -> Result<Vec<f64>, TapeError> {
        match self {
            ExtendedField::Loop(t) => t.eval(params, x),
            ExtendedField::Staged(s) => s.eval_feedback(params, x, &[], &[]),
        }
    }
}

impl LoopModel {
    /// The model extended by `extension` in loop form (see the
    /// [module docs](crate::loops::variational)). Refused as [`Extension::apply`] refuses,
    /// and for a model with events of its own (the extension's event functions are the peak
    /// alone).
    pub fn extend(&self, extension: Extension) -> Result<LoopExtension, Error> {
        let span = extension.span_of(&self.model)?;
        if let Some(ev) = self.model.events.first() {
            return Err(Error::Model(vec![crate::error::Diagnostic::new(
                &ev.span,
                "the extension of a model with events has no loop form".to_string(),
            )
            .help("load the model with its families unrolled".to_string())]));
        }
        let n = self.model.dim();
        let mut model = self.model.clone();
        let zero = model.graph.num(0.0);
        model.field.resize(extension.extended_dim(n), zero);
        extension.declare(&mut model, n, span, None);
        let tangents = match extension {
            Extension::Variational { tangents } => tangents,
            Extension::Indicators => 1,
        };
        let mut next = self
            .families
            .iter()
            .flat_map(|f| {
                f.slots
                    .iter()
                    .map(|s| s.symbol)
                    .chain(f.placeholders.clone())
            })
            .max()
            .unwrap_or(super::SYMBOL_BASE)
            + 1;
        let mut families = self.families.clone();
        let mut tangent_slots = vec![Vec::with_capacity(tangents); self.families.len()];
        for j in 0..tangents {
            let off = (n * (1 + j)) as u32;
            for (f, fam) in self.families.iter().enumerate() {
                let mut copy = fam.clone();
                copy.placeholders.clear();
                let mut symbols = Vec::with_capacity(fam.slots.len());
                for s in &fam.slots {
                    if s.source != Source::State {
                        symbols.push(None);
                        continue;
                    }
                    copy.slots.push(Slot {
                        symbol: next,
                        source: Source::State,
                        column: s.column.iter().map(|&c| c + off).collect(),
                        index: None,
                    });
                    symbols.push(Some(next));
                    next += 1;
                }
                tangent_slots[f].push(symbols);
                families.push(copy);
            }
        }
        Ok(LoopExtension {
            extension,
            n,
            originals: self.families.len(),
            lm: LoopModel { model, families },
            tangent_slots,
        })
    }
}

impl LoopExtension {
    /// The extension.
    pub fn extension(&self) -> Extension {
        self.extension
    }

    /// The extended model's declarations (state, parameters, invariants, points, events);
    /// its expressions are not to be evaluated (the field is [`LoopExtension::field`]).
    pub fn declarations(&self) -> &Model {
        &self.lm.model
    }

    /// The extended declarations as a loop model (for their names and for the unrolled
    /// source): its own functions ([`LoopModel::tapes`] and kin) are not the extension's.
    pub fn loops(&self) -> &LoopModel {
        &self.lm
    }

    /// The unrolled extended model: [`Extension::apply`] of the unrolled model.
    pub fn unrolled(&self) -> Result<Model, Error> {
        self.extension.apply(&self.lm.unrolled()?)
    }

    /// The extended field; see the [module docs](self).
    pub fn field(&self) -> Result<ExtendedField, Error> {
        let mut b = Builder::new(&self.lm);
        let (roots, x_outs) = b.field()?;
        let n = self.n;
        let e = self.extension.extended_dim(n);
        let plain = |extra: usize| Dims {
            state: e + extra,
            params: self.lm.model.param_slots(),
            targets: 0,
            gains: 0,
        };
        match self.extension {
            Extension::Variational { tangents } => {
                let mut roots = roots;
                let mut outs = x_outs.clone();
                for j in 0..tangents {
                    let off = n * (1 + j);
                    let aw = self.tangent(&mut b, j, &roots[..n], &x_outs, off as u32, &mut outs);
                    roots[off..off + n].copy_from_slice(&aw);
                }
                Ok(ExtendedField::Loop(b.tape(&roots, plain(0), outs)?))
            }
            Extension::Indicators => {
                let (sums, weights) = self.stages(&mut b, &roots[..n], &x_outs, 0)?;
                let k = n + 4;
                // stage 3: X, then the rates read back from w
                let mut last = roots[..n].to_vec();
                last.extend((0..k).map(|i| b.g.input(Input::State((e + k + i) as u32))));
                let feedback = b.tape(&last, plain(2 * k), x_outs)?;
                Ok(ExtendedField::Staged(Box::new(LoopFeedback {
                    pass: sums.clone(),
                    sums,
                    weights,
                    gradient: feedback.clone(),
                    feedback,
                    families: Vec::new(),
                })))
            }
        }
    }

    /// The peak event's value λ of an [`Extension::Indicators`] model as stages 1 and 2 with
    /// the time as the one gain: [`LoopFeedback::eval_lyapunov`] (with the gain) is λ; its
    /// `gradient` and `feedback` are the field's stage 3. `None` for the other extensions.
    pub fn peak(&self) -> Result<Option<LoopFeedback>, Error> {
        if self.extension != Extension::Indicators {
            return Ok(None);
        }
        let mut b = Builder::new(&self.lm);
        let (roots, x_outs) = b.field()?;
        let (sums, weights) = self.stages(&mut b, &roots[..self.n], &x_outs, 1)?;
        let dims = Dims {
            state: self.lm.model.dim() + 2 * (self.n + 4),
            params: self.lm.model.param_slots(),
            targets: 0,
            gains: 1,
        };
        let zero = b.g.num(0.0);
        let last = b.tape(&[zero], dims, Outputs::default())?;
        Ok(Some(LoopFeedback {
            pass: sums.clone(),
            sums,
            weights,
            gradient: last.clone(),
            feedback: last,
            families: Vec::new(),
        }))
    }

    /// Stages 1 and 2 of the indicators: `S = (A·u, 0, 0, 0, 0)` and `[λ, rates of (u, ℓ, τ,
    /// a, b)]` from `[x, S]` (with `gains` gains, unread).
    fn stages(
        &self,
        b: &mut Builder<'_>,
        x_plain: &[Id],
        x_outs: &Outputs,
        gains: usize,
    ) -> Result<(LoopTape, Tape), Error> {
        let n = self.n;
        let e = self.extension.extended_dim(n);
        let k = n + 4;
        let params = self.lm.model.param_slots();
        let mut outs = Outputs::default();
        let mut s_roots = self.tangent(b, 0, x_plain, x_outs, 0, &mut outs);
        let zero = b.g.num(0.0);
        s_roots.resize(k, zero);
        let dims = Dims {
            state: e,
            params,
            targets: 0,
            gains: 0,
        };
        let sums = b.tape(&s_roots, dims, outs)?;
        let u: Vec<Id> = (0..n)
            .map(|i| b.g.input(Input::State((n + i) as u32)))
            .collect();
        let s: Vec<Id> = (0..n)
            .map(|i| b.g.input(Input::State((e + i) as u32)))
            .collect();
        let (rates, lambda) = indicator_rates(&mut b.g, n, &u, &s);
        let mut w = vec![lambda];
        w.extend(rates);
        let wdims = Dims {
            state: e + k,
            params,
            targets: 0,
            gains,
        };
        let weights = Tape::from_graph(&b.g, &w, wdims)
            .map_err(|err| Error::Internal(format!("the indicators' stage 2: {err}")))?;
        Ok((sums, weights))
    }

    /// The plain part of A·w_j (N roots; w_j is the state block at `N·(1 + j)`) from X's
    /// plain roots `x_plain`; adds to `outs` the families' directional derivatives along w_j,
    /// scattered to the outputs of X's terms `x_outs` plus `off`.
    fn tangent(
        &self,
        b: &mut Builder<'_>,
        j: usize,
        x_plain: &[Id],
        x_outs: &Outputs,
        off: u32,
        outs: &mut Outputs,
    ) -> Vec<Id> {
        let n = self.n;
        let w = (n * (1 + j)) as u32;
        let mut roots = Vec::with_capacity(n);
        // the plain part: the directional derivative of each plain root of X
        for &r in x_plain {
            let vars: Vec<(Input, Input)> =
                b.g.reachable(&[r])
                    .into_iter()
                    .filter_map(|id| match b.g.node(id) {
                        Node::Input(Input::State(s)) if (*s as usize) < n => {
                            Some((Input::State(*s), Input::State(w + s)))
                        }
                        _ => None,
                    })
                    .collect();
            roots.push(jvp(b, r, &vars));
        }
        // the families: one copy per tangent, its outputs the bodies' directional derivatives
        for (&f, list) in x_outs {
            let copy = self.originals * (1 + j) + f;
            for (expr, col) in list {
                let vars: Vec<(Input, Input)> = b
                    .state_vars(f, &[*expr])
                    .into_iter()
                    .map(|(v, c)| match c {
                        Column::Slot(k) => {
                            let s = self.tangent_slots[f][j][k].expect("a state slot");
                            (v, Input::Symbol(s))
                        }
                        Column::Fixed(s) => (v, Input::State(w + s)),
                    })
                    .collect();
                let d = jvp(b, *expr, &vars);
                if b.g.as_num(d) == Some(0.0) {
                    continue;
                }
                let column = col.iter().map(|&o| o + off).collect();
                outs.entry(copy).or_default().push((d, column));
            }
        }
        roots
    }

    /// The model's invariants as a loop tape of the extended state.
    pub fn invariants(&self) -> Result<LoopTape, Error> {
        let mut b = Builder::new(&self.lm);
        let m = &self.lm.model;
        let mut inv = Outputs::default();
        let mut roots = Vec::new();
        for f in &m.invariants {
            for (c, &id) in f.value.ids.iter().enumerate() {
                let o = (f.offset + c) as u32;
                roots.push(b.split(id, o, &f.span, &mut inv)?);
            }
        }
        let dims = Dims {
            state: m.dim(),
            params: m.param_slots(),
            targets: 0,
            gains: 0,
        };
        b.tape(&roots, dims, inv)
    }

    /// Df of the invariants by the extended state (M × E, row-major; the tangent columns 0).
    pub fn jacobian(&self) -> Result<LoopTape, Error> {
        self.lm.jacobian()
    }
}

/// `Σ ∂e/∂v · t` over the pairs (v, t) of `vars`.
fn jvp(b: &mut Builder<'_>, e: Id, vars: &[(Input, Input)]) -> Id {
    let inputs: Vec<Input> = vars.iter().map(|v| v.0).collect();
    let grad = gradient(&mut b.g, e, &inputs);
    let mut terms = Vec::with_capacity(vars.len());
    for (&d, &(_, t)) in grad.iter().zip(vars) {
        if b.g.as_num(d) == Some(0.0) {
            continue;
        }
        let t = b.g.input(t);
        terms.push(b.g.mul(&[d, t]));
    }
    b.g.add(&terms)
}
