//! Variational equations and chaos indicators, as a transformation of the lowered model.
//!
//! From a lowered [`Model`] with field ẋ = X(x), [`Extension::apply`] builds a new model
//! whose state carries, after x, what the linearised flow transports, and whose field is
//! derived here symbolically (A = DX by [`ir::diff`](crate::ir::diff)):
//!
//! - [`Extension::Variational`] with k tangent vectors: the state (x, Φ) with Φ an N×k matrix
//!   (column-major, a state variable named `Phi`), the field (X, DX·Φ). With k = N and
//!   Φ(0) = I, Φ(t) = ∂φₜ(x₀)/∂x₀ is the state-transition matrix;
//! - [`Extension::Indicators`]: the state (x, u, ℓ, τ, a, b), with u the tangent vector kept
//!   at unit length, λ = u·Au/(u·u) its instantaneous growth rate and
//!
//!   ```text
//!   u̇ = Au − λu,   ℓ̇ = λ,   τ̇ = 1,   ȧ = τλ,   ḃ = 2aτ/(τ² + ε),   ε = 10⁻²⁰
//!   ```
//!
//!   so that, for a tangent vector w with w(0) = u(0) of unit length, ℓ(t) = ln‖w(t)‖, ℓ(t)/t the finite-time maximal
//!   Lyapunov exponent, 2a(t)/t the MEGNO Y(t) = (2/t)∫₀ᵗ s λ(s) ds and b(t)/t its mean ⟨Y⟩(t)
//!   (Cincotta & Simó 2000). The tangent vector never overflows however fast it grows. The
//!   floor ε ([`CLOCK_FLOOR`]) makes the rate of b, 2a/τ, defined at τ = 0 (where a = 0) and
//!   analytic within √ε = 10⁻¹⁰ of it, so the Taylor method's first step is about 10⁻¹⁰ long
//!   and its steps then grow geometrically; since a = O(τ²), it moves b by at most
//!   max|λ|·ε·ln(τ/√ε) ≈ 10⁻¹⁸ max|λ| (time units in which the run is much longer than 10⁻¹⁰
//!   are assumed).
//!
//!   The fast Lyapunov indicator of Froeschlé, Lega & Gonczi (1997) is the supremum of ℓ over
//!   [0, t], not ℓ(t): ℓ peaks where λ crosses zero downwards, so the extended model declares
//!   that crossing as its last event ([`PEAK_EVENT`], `λ = 0 falling`), which every method
//!   locates on its continuous extension; the FLI is the largest of ℓ(0) = 0, ℓ(t) and ℓ at
//!   those crossings ([`Indicators::with_peaks`]).
//!
//! The new model is an ordinary [`Model`]: every back end (emitted Rust, the JIT, the
//! interpreter, lanes, the Taylor method) runs it without code of its own. It keeps the
//! invariants, guards, Lyapunov function and Hamiltonian of x (they do not depend on the new
//! components); its points are the original points with the tangent part's initial value
//! ([`Extension::extend_state`]). It declares no splitting.
//!
//! ```
//! use lasalle_model::variational::Extension;
//! let text = "model Osc { state q: scalar, p: scalar; param w = 2;
//!             d/dt q = p; d/dt p = -w^2 * q; point start { q = 1; p = 0; } }";
//! let model = lasalle_model::lower_source("osc.lsl", text)?;
//! let stm = Extension::Variational { tangents: 2 }.apply(&model)?;
//! assert_eq!(stm.dim(), 2 + 4);
//! assert_eq!(stm.state[2].name, "Phi");
//! // Φ̇ = DX·Φ: d/dt Phi[1,0] = -w² Phi[0,0]
//! let x = [1.0, 0.0, 0.5, 0.25, 0.0, 1.0];
//! let rates = stm.graph.eval_f64(&stm.field, &mut |i| match i {
//!     lasalle_model::ir::Input::State(k) => x[k as usize],
//!     lasalle_model::ir::Input::Param(_) => 2.0,
//!     _ => f64::NAN,
//! });
//! assert_eq!(rates[3], -4.0 * 0.5);
//! # Ok::<(), lasalle_model::Error>(())
//! ```

use std::collections::HashMap;

use crate::ir::{diff, Graph, Id, Input};
use crate::{Diagnostic, Direction, Event, Model, Shape, StateVar};

/// The name of the event `λ = 0 falling` of an [`Extension::Indicators`] model, the peaks of
/// ℓ = ln‖w‖ (suffixed with `_` while the model uses the name); it is the model's last event.
pub const PEAK_EVENT: &str = "log_growth_peak";

/// ε in the rate 2aτ/(τ² + ε) of the MEGNO sum b (see the [module docs](self)).
pub const CLOCK_FLOOR: f64 = 1e-20;

/// What a model is extended with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extension {
    /// k tangent vectors w₁ … w_k transported by ẇ = DX·w, as the columns of the N×k state
    /// variable `Phi`; they start as the first k columns of the identity (k = N: the
    /// state-transition matrix).
    Variational {
        /// The number k of tangent vectors, 1 ≤ k.
        tangents: usize,
    },
    /// A unit tangent vector and the integrals of its growth rate that give the maximal
    /// Lyapunov exponent, the FLI and MEGNO (see the [module docs](self)).
    Indicators,
}

/// Where the indicators' components sit in the state of an [`Extension::Indicators`] model
/// of a model of dimension N.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IndicatorSlots {
    /// The dimension N of the original state.
    pub n: usize,
}

impl IndicatorSlots {
    /// ℓ = ln‖w‖.
    pub fn log_growth(self) -> usize {
        2 * self.n
    }
    /// τ, the time since the start.
    pub fn clock(self) -> usize {
        2 * self.n + 1
    }
    /// a = ∫ sλ(s) ds.
    pub fn megno_sum(self) -> usize {
        2 * self.n + 2
    }
    /// b = ∫ Y(s) ds.
    pub fn megno_mean(self) -> usize {
        2 * self.n + 3
    }
}

/// The chaos indicators read off the final state of an [`Extension::Indicators`] run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Indicators {
    /// The time over which they were accumulated.
    pub t: f64,
    /// The fast Lyapunov indicator: sup over [0, t] of ln‖w‖ with ‖w(0)‖ = 1 once the run's
    /// peaks are in ([`Indicators::with_peaks`]); ln‖w(t)‖ as read off the final state.
    pub fli: f64,
    /// ln‖w(t)‖ / t: the finite-time maximal Lyapunov exponent.
    pub mle: f64,
    /// Y(t) = (2/t)∫₀ᵗ s λ(s) ds, MEGNO.
    pub megno: f64,
    /// ⟨Y⟩(t) = (1/t)∫₀ᵗ Y(s) ds, the mean MEGNO (→ 0 on isochronous periodic orbits, → 2 on
    /// quasi-periodic ones, ~ λ t / 2 on chaotic ones).
    pub megno_mean: f64,
}

impl Indicators {
    /// The FLI as the supremum of ℓ = ln‖w‖ over the run, given ℓ at its peaks (the
    /// crossings of [`PEAK_EVENT`]): the largest of them, of ℓ(0) = 0 and of ℓ(t).
    pub fn with_peaks(mut self, peaks: impl IntoIterator<Item = f64>) -> Indicators {
        self.fli = peaks.into_iter().fold(self.fli.max(0.0), f64::max);
        self
    }
}

impl Extension {
    /// The dimension of the extended state of a model of dimension `n`.
    pub fn extended_dim(self, n: usize) -> usize {
        match self {
            Extension::Variational { tangents } => n * (1 + tangents),
            Extension::Indicators => 2 * n + 4,
        }
    }

    /// The extended initial state of `x0` (a state of the original model): Φ(0) = the first
    /// k columns of the identity; for the indicators u(0) = (1, …, 1)/√N and ℓ = τ = a = b = 0.
    pub fn extend_state(self, x0: &[f64]) -> Vec<f64> {
        let n = x0.len();
        let mut x = x0.to_vec();
        match self {
            Extension::Variational { tangents } => {
                for j in 0..tangents {
                    x.extend((0..n).map(|i| if i == j { 1.0 } else { 0.0 }));
                }
            }
            Extension::Indicators => {
                let u = 1.0 / (n as f64).sqrt();
                x.extend(std::iter::repeat_n(u, n));
                x.extend([0.0; 4]);
            }
        }
        x
    }

    /// The indicators of the final state `x` of an [`Extension::Indicators`] run of a model of
    /// dimension `n` (`None` for the other extensions or a state of another length).
    pub fn indicators(self, n: usize, x: &[f64]) -> Option<Indicators> {
        if self != Extension::Indicators || x.len() != self.extended_dim(n) {
            return None;
        }
        let s = IndicatorSlots { n };
        let t = x[s.clock()];
        let fli = x[s.log_growth()];
        Some(Indicators {
            t,
            fli,
            mle: fli / t,
            megno: 2.0 * x[s.megno_sum()] / t,
            megno_mean: x[s.megno_mean()] / t,
        })
    }

    /// The extended model (see the [module docs](self)). Fails for zero tangent vectors or a
    /// model without state.
    pub fn apply(self, model: &Model) -> crate::Result<Model> {
        let span = self.span_of(model)?;
        let n = model.dim();
        let mut out = model.clone();
        let g = &mut out.graph;
        let a = field_jacobian(g, &model.field);
        let mut lambda = None;
        match self {
            Extension::Variational { tangents } => {
                for j in 0..tangents {
                    let w: Vec<Id> = (0..n).map(|i| g.input(state(n * (1 + j) + i))).collect();
                    let aw = mat_vec(g, &a, &w);
                    out.field.extend(aw);
                }
            }
            Extension::Indicators => {
                let u: Vec<Id> = (0..n).map(|i| g.input(state(n + i))).collect();
                let au = mat_vec(g, &a, &u);
                let (rates, l) = indicator_rates(g, n, &u, &au);
                out.field.extend(rates);
                lambda = Some(l);
            }
        }
        self.declare(&mut out, n, span, lambda);
        Ok(out)
    }

    /// The span the new declarations point at (the first state variable's), or the refusal
    /// of a model without state or of zero tangent vectors.
    pub(crate) fn span_of(self, model: &Model) -> crate::Result<crate::Span> {
        let span = model
            .state
            .first()
            .map(|s| s.span.clone())
            .ok_or_else(|| refuse(model, "the model has no state to linearise"))?;
        if let Extension::Variational { tangents: 0 } = self {
            return Err(refuse(
                model,
                "the variational equations need at least one tangent vector",
            ));
        }
        Ok(span)
    }

    /// The declarations of the extended model on `out`, a copy of a model of dimension `n`
    /// whose field already has the extended rates: the new state variables, the peak event
    /// (value `lambda`, for the indicators), the field's spans and the points' tangent part.
    /// It declares no splitting.
    pub(crate) fn declare(self, out: &mut Model, n: usize, span: crate::Span, lambda: Option<Id>) {
        out.splitting = None;
        let mut fresh = Fresh::new(out);
        let mut add_state = |out_state: &mut Vec<StateVar>, name: &str, shape: Shape| {
            let offset = out_state.last().map_or(0, |s| s.offset + s.shape.len());
            out_state.push(StateVar {
                name: fresh.take(name),
                shape,
                offset,
                span: span.clone(),
            });
        };
        match self {
            Extension::Variational { tangents } => {
                add_state(&mut out.state, "Phi", Shape::Matrix(n, tangents));
            }
            Extension::Indicators => {
                add_state(&mut out.state, "tangent", Shape::Vector(n));
                add_state(&mut out.state, "log_growth", Shape::Scalar);
                add_state(&mut out.state, "clock", Shape::Scalar);
                add_state(&mut out.state, "megno_sum", Shape::Scalar);
                add_state(&mut out.state, "megno_mean", Shape::Scalar);
                let value = lambda.unwrap_or_else(|| out.graph.num(0.0));
                out.events.push(Event {
                    name: fresh.take(PEAK_EVENT),
                    value,
                    direction: Direction::Falling,
                    terminal: false,
                    expr: "u·Au/u·u".to_string(),
                    span: span.clone(),
                });
            }
        }
        let dim = self.extended_dim(n);
        debug_assert_eq!(out.field.len(), dim);
        out.field_spans.resize(dim, span.clone());
        // the tangent part of every point: its initial value, the same for all
        let tail: Vec<f64> = self.extend_state(&vec![0.0; n])[n..].to_vec();
        let tail: Vec<Id> = tail.iter().map(|&v| out.graph.num(v)).collect();
        for p in &mut out.points {
            p.values.extend(&tail);
        }
    }
}

/// The rates of (u, ℓ, τ, a, b) of the indicators and λ, from the tangent vector `u`
/// (state components N..2N) and `au` = A·u, for a model of dimension `n`.
pub(crate) fn indicator_rates(g: &mut Graph, n: usize, u: &[Id], au: &[Id]) -> (Vec<Id>, Id) {
    let uau = dot(g, u, au);
    let uu = dot(g, u, u);
    let lambda = g.div(uau, uu);
    let mut rates = Vec::with_capacity(n + 4);
    for (&aui, &ui) in au.iter().zip(u) {
        let lu = g.mul(&[lambda, ui]);
        rates.push(g.sub(aui, lu));
    }
    let s = IndicatorSlots { n };
    let tau = g.input(state(s.clock()));
    let a_sum = g.input(state(s.megno_sum()));
    let one = g.num(1.0);
    let two = g.num(2.0);
    let floor = g.num(CLOCK_FLOOR);
    let tau_lambda = g.mul(&[tau, lambda]);
    let tau2 = g.mul(&[tau, tau]);
    let den = g.add(&[tau2, floor]);
    let num = g.mul(&[two, a_sum, tau]);
    let mean_rate = g.div(num, den);
    rates.extend([lambda, one, tau_lambda, mean_rate]);
    (rates, lambda)
}

/// DX: `a[i][l] = ∂X_i/∂x_l`.
pub fn field_jacobian(g: &mut Graph, field: &[Id]) -> Vec<Vec<Id>> {
    let n = field.len();
    let mut memos: Vec<HashMap<Id, Id>> = vec![HashMap::new(); n];
    field
        .iter()
        .map(|&xi| {
            (0..n)
                .map(|l| diff(g, xi, state(l), &mut memos[l]))
                .collect()
        })
        .collect()
}

fn state(i: usize) -> Input {
    Input::State(i as u32)
}

fn mat_vec(g: &mut Graph, a: &[Vec<Id>], w: &[Id]) -> Vec<Id> {
    a.iter()
        .map(|row| {
            let nonzero: Vec<(Id, Id)> = row
                .iter()
                .zip(w)
                .filter(|(&d, _)| g.as_num(d) != Some(0.0))
                .map(|(&d, &wl)| (d, wl))
                .collect();
            let terms: Vec<Id> = nonzero.iter().map(|&(d, wl)| g.mul(&[d, wl])).collect();
            g.add(&terms)
        })
        .collect()
}

fn dot(g: &mut Graph, a: &[Id], b: &[Id]) -> Id {
    let terms: Vec<Id> = a.iter().zip(b).map(|(&x, &y)| g.mul(&[x, y])).collect();
    g.add(&terms)
}

fn refuse(model: &Model, why: &str) -> crate::Error {
    let span = crate::Span {
        source: model.source.clone(),
        start: 0,
        end: 0,
    };
    Diagnostic::new(&span, why.to_string()).into()
}

/// Names not used by the model (nor by the language): `Phi`, else `Phi_`, `Phi__`, ….
struct Fresh {
    used: Vec<String>,
}

impl Fresh {
    fn new(model: &Model) -> Fresh {
        let mut used: Vec<String> = model.state.iter().map(|s| s.name.clone()).collect();
        used.extend(model.params.iter().map(|p| p.name.clone()));
        used.extend(model.lets.iter().map(|b| b.name.clone()));
        used.extend(model.invariants.iter().map(|f| f.name.clone()));
        used.extend(model.gains.iter().map(|k| k.name.clone()));
        used.extend(model.events.iter().map(|e| e.name.clone()));
        used.push(model.name.clone());
        Fresh { used }
    }

    fn take(&mut self, base: &str) -> String {
        let mut name = base.to_string();
        while self.used.iter().any(|u| u == &name) || crate::vocabulary::builtin(&name).is_some() {
            name.push('_');
        }
        self.used.push(name.clone());
        name
    }
}
