//! Gain selection for feedback integrators.
//!
//! For the default V = ½ ΔfᵀKΔf (Δf = f(x) − f(x₀), K = diag of the gains expanded per
//! component, [`expand_gains`]) the Hessian of V at the target set is the Gauss–Newton matrix
//! H_GN = Df(x)ᵀ K Df(x) (the term with second derivatives of f vanishes where Δf = 0). An
//! explicit method sees −∇V as a contraction with rates up to L = ‖H_GN‖₂; explicit Euler is
//! stable on it only for h·L < 2 (Chang, Jiménez & Perlmutter 2016, Appendix), and
//! h·L = 1 removes the error along the stiffest direction in one step. Following Bae & Chang,
//! *Feedback integrators revisited* (arXiv:2512.01528), the gains are therefore chosen as
//!
//! ```text
//! gains = α · unit,   α = c / (h · L(unit)),   0 < c < 2 (default 1),
//! ```
//!
//! either once at x₀ ([`scaled_gains`], the "fixed" scaled gain) or re-estimated at the
//! current state every m steps with a safety factor ([`AdaptiveGain`], the periodic adaptive
//! gain). The fixed gain is only safe when L varies little along the solution: on the e = 0.8
//! Kepler orbit L grows ~7× from periapsis to apoapsis (|∂L/∂v| = |x|), so c = 1 at the
//! periapsis gives h·L ≈ 6.8 > 2 at the apoapsis and feedback-Euler loses the integrals
//! (runtime/tests/feedback.rs); the adaptive gain has no such problem. L is computed by power
//! iteration ([`gauss_newton_norm`]); the trace of H_GN is a cheap upper bound
//! ([`gauss_newton_trace`]). These formulas assume the default form of V.
//!
//! Adaptive methods (DOPRI5, Taylor) choose h themselves; [`AdaptiveGain`] then follows the
//! proposed step, and the step-tracking target h·L = c·tol^(1/p) ([`step_gain_target`],
//! `--gains step`, what `auto` picks for them) keeps their step counts within a few per cent of
//! the plain methods' (docs/performance.md).

use std::str::FromStr;

use num_traits::Float;

use crate::error::StepError;
use crate::feedback::{expand_gains, FeedbackField};
use crate::field::{lit, Invariants, Lyapunov, ModelInfo};
use crate::state::State;
use crate::steppers::{StepOutcome, Stepper};

/// The factors of H_GN = Df(x)ᵀ K Df(x): the gains expanded to one per invariant component
/// (the diagonal of K) and the Jacobian Df(x).
fn factors<Mdl, T, X, F>(model: &Mdl, x: &X, gains: &[T]) -> (F, F::Rows<X>)
where
    Mdl: Invariants<T, X, F> + ModelInfo + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
{
    let m = model.invariant_dim();
    let mut k = F::filled(F::len_for(m), T::zero());
    expand_gains(model, gains, k.as_mut());
    let mut jac = F::rows(F::len_for(m), X::filled(X::len_for(x.len()), T::zero()));
    model.invariants_jacobian(x, &mut jac);
    (k, jac)
}

/// The Gauss–Newton Hessian H_GN = Df(x)ᵀ K Df(x) ∈ R^{N×N} of V = ½ΔfᵀKΔf, row by row.
pub fn gauss_newton_hessian<Mdl, T, X, F>(model: &Mdl, x: &X, gains: &[T]) -> X::Rows<X>
where
    Mdl: Invariants<T, X, F> + ModelInfo + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
{
    let (k, jac) = factors(model, x, gains);
    hessian_of::<T, X, F>(&k, &jac, x.len())
}

/// Df(x)ᵀ K Df(x) from its [`factors`], N = `n`.
fn hessian_of<T: Float, X: State<T>, F: State<T>>(k: &F, jac: &F::Rows<X>, n: usize) -> X::Rows<X> {
    let mut h = X::rows(X::len_for(n), X::filled(X::len_for(n), T::zero()));
    for (row, &ki) in jac.as_ref().iter().zip(k.as_ref()) {
        if ki == T::zero() {
            continue;
        }
        for a in 0..n {
            let kr = ki * row[a];
            if kr == T::zero() {
                continue;
            }
            for b in 0..n {
                h[a][b] = h[a][b] + kr * row[b];
            }
        }
    }
    h
}

/// The largest eigenvalue of a symmetric positive semi-definite matrix (given by its rows) by
/// power iteration with Rayleigh quotients (Golub & Van Loan, *Matrix Computations*, 4th ed.,
/// §8.2.1), from a fixed generic start vector, stopping when the estimate changes by less than
/// `rel_tol` (relative) or after `max_iter` iterations. A lower bound that converges to ‖A‖₂.
pub fn symmetric_spectral_norm<T: Float, R: State<T>>(a: &[R], max_iter: u32, rel_tol: T) -> T {
    let n = a.len();
    let mut v = R::filled(R::len_for(n), T::zero());
    for (i, vi) in v.as_mut().iter_mut().enumerate() {
        // a start vector with no special structure (golden-ratio offsets)
        let frac = (i as f64 * 0.618_033_988_749_895).fract();
        *vi = lit(1.0 + frac);
    }
    let mut w = v.clone();
    let norm = |v: &[T]| v.iter().fold(T::zero(), |s, x| s + *x * *x).sqrt();
    let mut lambda = T::zero();
    for _ in 0..max_iter.max(1) {
        let nv = norm(v.as_ref());
        if !(nv > T::zero()) {
            return T::zero();
        }
        for vi in v.as_mut().iter_mut() {
            *vi = *vi / nv;
        }
        for i in 0..n {
            w[i] = T::zero();
            for j in 0..n {
                w[i] = w[i] + a[i][j] * v[j];
            }
        }
        let rayleigh = v
            .as_ref()
            .iter()
            .zip(w.as_ref())
            .fold(T::zero(), |s, (p, q)| s + *p * *q);
        let done = (rayleigh - lambda).abs() <= rel_tol * rayleigh.abs();
        lambda = rayleigh;
        std::mem::swap(&mut v, &mut w);
        if done {
            break;
        }
    }
    lambda
}

/// L = ‖Df(x)ᵀ K Df(x)‖₂ by power iteration (at most 200 iterations, relative tolerance 1e-8).
///
/// With fewer invariant components M than state components N (an N-body model: M = 7, N = 6n)
/// and gains ≥ 0, the iteration runs on the M × M matrix K^½ Df Dfᵀ K^½, which has the same nonzero
/// eigenvalues (those of AᵀA and AAᵀ, A = K^½ Df), at O(M²N) instead of the O(N²) of forming
/// H_GN.
pub fn gauss_newton_norm<Mdl, T, X, F>(model: &Mdl, x: &X, gains: &[T]) -> T
where
    Mdl: Invariants<T, X, F> + ModelInfo + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
{
    let (n, m) = (x.len(), model.invariant_dim());
    let (k, jac) = factors(model, x, gains);
    if m >= n || k.as_ref().iter().any(|&ki| !(ki >= T::zero())) {
        let h = hessian_of::<T, X, F>(&k, &jac, n);
        return symmetric_spectral_norm(h.as_ref(), 200, lit(1e-8));
    }
    let (jac, k) = (jac.as_ref(), k.as_ref());
    let mut g = F::rows(F::len_for(m), F::filled(F::len_for(m), T::zero()));
    for i in 0..m {
        for j in 0..=i {
            let dot = (0..n).fold(T::zero(), |s, a| s + jac[i][a] * jac[j][a]);
            let gij = (k[i] * k[j]).sqrt() * dot;
            g[i][j] = gij;
            g[j][i] = gij;
        }
    }
    symmetric_spectral_norm(g.as_ref(), 200, lit(1e-8))
}

/// tr(Df(x)ᵀ K Df(x)) = Σᵢ kᵢ |∇fᵢ(x)|² — a cheap upper bound on L (H_GN is positive
/// semi-definite).
pub fn gauss_newton_trace<Mdl, T, X, F>(model: &Mdl, x: &X, gains: &[T]) -> T
where
    Mdl: Invariants<T, X, F> + ModelInfo + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
{
    let (k, jac) = factors(model, x, gains);
    jac.as_ref()
        .iter()
        .zip(k.as_ref())
        .fold(T::zero(), |s, (row, &ki)| {
            s + ki * row.as_ref().iter().fold(T::zero(), |r, v| r + *v * *v)
        })
}

/// Σᵢ |∇fᵢ(x)|² over the components fᵢ of each gain, into `traces` (one entry per gain):
/// tr(Df(x)ᵀ K Df(x)) is Σ_g k_g · traces[g]. `jac` is the caller's storage for Df(x), sized
/// at the first call and kept, so that a caller calling at every step allocates only once.
pub fn gain_traces<Mdl, T, X, F>(model: &Mdl, x: &X, jac: &mut Option<F::Rows<X>>, traces: &mut [T])
where
    Mdl: Invariants<T, X, F> + ModelInfo + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
{
    let m = model.invariant_dim();
    let fits = jac
        .as_ref()
        .is_some_and(|j| j.as_ref().len() == m && j.as_ref().iter().all(|r| r.len() == x.len()));
    if !fits {
        *jac = Some(F::rows(
            F::len_for(m),
            X::filled(X::len_for(x.len()), T::zero()),
        ));
    }
    let jac = jac.as_mut().expect("sized above");
    model.invariants_jacobian(x, jac);
    traces.iter_mut().for_each(|t| *t = T::zero());
    let rows = jac.as_ref();
    for info in model.invariant_infos() {
        for c in info.slot.range() {
            if let (Some(row), Some(t)) = (rows.get(c), traces.get_mut(info.gain)) {
                *t = *t + row.as_ref().iter().fold(T::zero(), |r, v| r + *v * *v);
            }
        }
    }
}

/// Why gains could not be chosen.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GainError {
    /// ‖H_GN‖₂ is zero or not finite at the state (e.g. the Jacobian vanishes).
    #[error("cannot scale gains: |Df^T K Df| = {0} at the state")]
    Degenerate(f64),
    /// Explicit gains with the wrong count.
    #[error("expected {expected} gains, got {got}")]
    WrongCount {
        /// The model's number of gains.
        expected: usize,
        /// The number given.
        got: usize,
    },
    /// A gain specification that does not parse.
    #[error("invalid gain specification `{0}`: expected `default`, `model`, `bounded[:c]`, `auto`, `fixed[:c]`, `adaptive[:m[:c]]`, `step[:c[:m]]` or `k1,k2,...`")]
    Parse(String),
    /// A non-positive or non-finite step size, or c outside (0, 2).
    #[error("invalid gain parameter: {0}")]
    Invalid(String),
}

/// The scaled fixed gain: `unit · c/(h·L)` with L = [`gauss_newton_norm`] at `x` for the
/// `unit` gains, so that h·‖∇²V‖₂ ≈ c near x (Bae & Chang; see the module docs).
pub fn scaled_gains<Mdl, T, X, F, K>(
    model: &Mdl,
    x: &X,
    unit: &K,
    h: T,
    c: T,
) -> Result<K, GainError>
where
    Mdl: Invariants<T, X, F> + ModelInfo + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
    K: State<T>,
{
    if !(h > T::zero() && h.is_finite()) {
        return Err(GainError::Invalid(format!(
            "step size h = {}",
            h.to_f64().unwrap_or(f64::NAN)
        )));
    }
    let l = gauss_newton_norm(model, x, unit.as_ref());
    if !(l > T::zero() && l.is_finite()) {
        return Err(GainError::Degenerate(l.to_f64().unwrap_or(f64::NAN)));
    }
    let alpha = c / (h * l);
    let mut gains = unit.clone();
    gains.as_mut().iter_mut().for_each(|k| *k = *k * alpha);
    Ok(gains)
}

/// A stepper wrapper for feedback fields that keeps h·‖∇²V‖₂ at a fixed target: before every
/// step of size h it sets the gains to `unit · safety·c/(h·L)`, where L = ‖H_GN‖₂ for the
/// `unit` gains is re-estimated at the current state every `every` steps (the periodic
/// adaptive gain of Bae & Chang), writing them into the [`FeedbackField`].
///
/// For a fixed-step method h never changes and the gains change only when L is re-estimated.
/// For an adaptive method (DOPRI5, Taylor) h is the step the method proposes, so the gains
/// follow the step: the feedback's stiffest rate k·L stays at safety·c/h, inside the stability
/// region of any explicit method whose real stability interval exceeds safety·c (Euler 2,
/// RK4 2.79, DOPRI5 3.31, Taylor of order p ≥ 4 wider still), and the step is left to the
/// accuracy of the smooth part of the solution — see docs/performance.md for the measured
/// step counts. A step that the method shrinks after rejecting it is stiffer-safe (smaller h).
///
/// If L is degenerate at some state the previous estimate is kept.
#[derive(Clone, Debug)]
pub struct AdaptiveGain<S, T, K> {
    base: S,
    unit: K,
    c: T,
    safety: T,
    every: u64,
    steps: u64,
    last_norm: T,
    /// The step the current gains were set for (NaN: set them at the next step).
    gains_for_h: T,
}

impl<S, T: Float, K> AdaptiveGain<S, T, K> {
    /// Wraps `base`; defaults `c = 1`, `safety = 0.8`, re-estimation every `every` steps
    /// (0 is treated as 1).
    pub fn new(base: S, unit: K, every: u64) -> Self {
        AdaptiveGain {
            base,
            unit,
            c: T::one(),
            safety: lit(0.8),
            every: every.max(1),
            steps: 0,
            last_norm: T::nan(),
            gains_for_h: T::nan(),
        }
    }

    /// Sets c ∈ (0, 2) (default 1).
    pub fn c(mut self, c: T) -> Self {
        self.c = c;
        self
    }

    /// Sets the safety factor (default 0.8).
    pub fn safety(mut self, safety: T) -> Self {
        self.safety = safety;
        self
    }

    /// The last estimate of L = ‖H_GN‖₂ for the unit gains (NaN before the first step).
    pub fn last_norm(&self) -> T {
        self.last_norm
    }

    /// The wrapped stepper.
    pub fn base(&self) -> &S {
        &self.base
    }
}

impl<'a, S, Mdl, T, X, F, K> Stepper<T, X, FeedbackField<'a, Mdl, F, K>> for AdaptiveGain<S, T, K>
where
    S: Stepper<T, X, FeedbackField<'a, Mdl, F, K>>,
    Mdl: Lyapunov<T, X, F, K> + ModelInfo + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
    K: State<T>,
{
    fn step(
        &mut self,
        field: &FeedbackField<'a, Mdl, F, K>,
        t: T,
        x: &mut X,
        h: T,
    ) -> Result<StepOutcome<T>, StepError> {
        if h > T::zero() {
            if self.steps % self.every == 0 {
                let l = gauss_newton_norm(field.model(), x, self.unit.as_ref());
                if l > T::zero() && l.is_finite() {
                    self.last_norm = l;
                    self.gains_for_h = T::nan();
                }
            }
            // NaN never compares equal: the gains are (re)set after a new estimate of L
            if h != self.gains_for_h && self.last_norm > T::zero() {
                field.set_scaled_gains(&self.unit, self.safety * self.c / (h * self.last_norm));
                self.gains_for_h = h;
            }
        }
        self.steps += 1;
        self.base.step(field, t, x, h)
    }

    fn order(&self) -> u32 {
        self.base.order()
    }

    fn name(&self) -> String {
        format!("adaptive-gain({})", self.base.name())
    }

    /// The base stepper's: the gains change between steps, not within one.
    fn dense_output(&self) -> Option<&dyn crate::DenseOutput<T, X>> {
        self.base.dense_output()
    }

    fn is_adaptive(&self) -> bool {
        self.base.is_adaptive()
    }

    fn initial_step(
        &mut self,
        field: &FeedbackField<'a, Mdl, F, K>,
        t0: T,
        x0: &X,
        t_end: T,
    ) -> Option<T> {
        self.base.initial_step(field, t0, x0, t_end)
    }

    fn reset(&mut self) {
        self.steps = 0;
        self.gains_for_h = T::nan();
        self.base.reset()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let mut v = self.base.counters();
        v.push((
            "last_gauss_newton_norm",
            self.last_norm.to_f64().unwrap_or(f64::NAN),
        ));
        v
    }
}

/// The target of h·k·L for the step-tracking gain of an adaptive method of order `order` at
/// tolerance `tol`: `c · tol^(1/order)`.
///
/// An adaptive method picks h ≈ τ·tol^(1/p), where τ is the time over which the solution
/// changes by O(1); the target makes the feedback's stiffest rate k·L = c/τ — the time scale
/// of the solution, not of the step. For Runge–Kutta methods this is what keeps the step
/// count: their internal stages leave the invariant set by O(h²), so the local error picks up
/// terms (h·k·L)^j·h^(p+1−j) that dominate the method's own h^(p+1) unless h·k·L ≲ tol^(1/p)
/// (order reduction on stiff problems, Hairer & Wanner, *Solving ODEs II*, §IV.15). For the
/// Taylor method with Jorba & Zou's order p = ⌈−½ ln ε + 1⌉, tol^(1/p) ≈ e⁻² is the same
/// constant at every tolerance. Measurements (docs/performance.md): c = 2 costs at most a few
/// per cent more steps than the plain method.
pub fn step_gain_target(c: f64, tol: f64, order: u32) -> f64 {
    c * tol.powf(1.0 / f64::from(order.max(1)))
}

/// How to choose the gains of a feedback integrator (the CLI's `--gains`).
///
/// | text | policy |
/// | --- | --- |
/// | `default` | `bounded` for fixed-step methods, `step` for adaptive ones, whose steps the model file's fixed gains cannot follow ([`GainPolicy::resolve`]) |
/// | `model` | the gains written in the model file ([`ModelInfo::default_gain_values`]), unchanged along the run (a fixed-step run reports where h·k·L leaves the stability interval: [`crate::GainBound`]) |
/// | `bounded`, `bounded:c` | fixed-step methods: the model file's gains, scaled down before every step where h·k·L would pass c·β, β the method's real stability interval ([`crate::GainBound`], default c = [`crate::DEFAULT_BOUND_FRACTION`]) |
/// | `auto` | `adaptive` (m = 100, c = 1) for fixed-step methods, `step` (c = 2, m = 10) for adaptive ones ([`GainPolicy::resolve`]) |
/// | `fixed`, `fixed:c` | [`scaled_gains`] at x₀ with unit gains and c (default 1) |
/// | `adaptive`, `adaptive:m`, `adaptive:m:c` | [`AdaptiveGain`] every m steps (default 100), c (default 1) |
/// | `step`, `step:c`, `step:c:m` | adaptive methods: [`AdaptiveGain`] with h·k·L = [`step_gain_target`]`(c, tol, p)` at every step, L every m steps (defaults c = 2, m = 10) |
/// | `k1,k2,…` | these gains |
#[derive(Clone, Debug, PartialEq)]
pub enum GainPolicy {
    /// What applies when nothing is said: `Bounded` or `Step` according to the method
    /// ([`GainPolicy::resolve`]).
    Default,
    /// The model file's gains.
    ModelDefault,
    /// The model file's gains, capped so that h·k·L ≤ c·β along a fixed-step run
    /// ([`crate::GainBound`]).
    Bounded {
        /// The fraction of the base method's real stability interval β, in (0, 1].
        c: f64,
    },
    /// `Adaptive` or `Step` according to the method ([`GainPolicy::resolve`]).
    Auto,
    /// The scaled fixed gain c/(h·L) at x₀ times unit gains.
    Scaled {
        /// The target h·L, in (0, 2).
        c: f64,
    },
    /// The periodic adaptive gain.
    Adaptive {
        /// Re-estimation period in steps.
        every: u64,
        /// The target h·L, in (0, 2).
        c: f64,
    },
    /// The step-tracking gain of adaptive methods: h·k·L = c·tol^(1/p) at every step.
    Step {
        /// The factor c of [`step_gain_target`] (positive).
        c: f64,
        /// Re-estimation period of L in steps.
        every: u64,
    },
    /// Explicit gains.
    Explicit(Vec<f64>),
}

impl FromStr for GainPolicy {
    type Err = GainError;

    fn from_str(s: &str) -> Result<Self, GainError> {
        let bad = || GainError::Parse(s.to_string());
        let num = |p: &str| p.trim().parse::<f64>().map_err(|_| bad());
        let check_c = |c: f64| {
            if c > 0.0 && c < 2.0 {
                Ok(c)
            } else {
                Err(GainError::Invalid(format!("c = {c} is not in (0, 2)")))
            }
        };
        let period = |m: &str| match m.trim().parse::<u64>() {
            Ok(0) => Err(GainError::Invalid(
                "the re-estimation period must be at least 1 step".to_string(),
            )),
            Ok(m) => Ok(m),
            Err(_) => Err(bad()),
        };
        let mut parts = s.trim().split(':');
        let head = parts.next().unwrap_or("");
        let rest: Vec<&str> = parts.collect();
        match head {
            "default" if rest.is_empty() => Ok(GainPolicy::Default),
            "model" if rest.is_empty() => Ok(GainPolicy::ModelDefault),
            "bounded" => match rest.as_slice() {
                [] => Ok(GainPolicy::Bounded {
                    c: crate::DEFAULT_BOUND_FRACTION,
                }),
                [c] => match num(c)? {
                    c if c > 0.0 && c <= 1.0 => Ok(GainPolicy::Bounded { c }),
                    c => Err(GainError::Invalid(format!(
                        "c = {c} is not in (0, 1] (the fraction of the stability interval)"
                    ))),
                },
                _ => Err(bad()),
            },
            "auto" if rest.is_empty() => Ok(GainPolicy::Auto),
            "step" => {
                let c = match rest.first() {
                    None => 2.0,
                    Some(c) => match num(c)? {
                        c if c > 0.0 && c.is_finite() => c,
                        c => return Err(GainError::Invalid(format!("c = {c} is not positive"))),
                    },
                };
                let every = match rest.get(1) {
                    None => 10,
                    Some(m) => period(m)?,
                };
                if rest.len() > 2 {
                    return Err(bad());
                }
                Ok(GainPolicy::Step { c, every })
            }
            "fixed" => match rest.as_slice() {
                [] => Ok(GainPolicy::Scaled { c: 1.0 }),
                [c] => Ok(GainPolicy::Scaled {
                    c: check_c(num(c)?)?,
                }),
                _ => Err(bad()),
            },
            "adaptive" => {
                let every = match rest.first() {
                    None => 100,
                    Some(m) => period(m)?,
                };
                let c = match rest.get(1) {
                    None => 1.0,
                    Some(c) => check_c(num(c)?)?,
                };
                if rest.len() > 2 {
                    return Err(bad());
                }
                Ok(GainPolicy::Adaptive { every, c })
            }
            _ if rest.is_empty() => {
                let gains = head.split(',').map(num).collect::<Result<Vec<_>, _>>()?;
                if let Some(g) = gains.iter().find(|g| !(g.is_finite() && **g >= 0.0)) {
                    return Err(GainError::Invalid(format!(
                        "gains must be finite and ≥ 0 (a negative gain makes V repel), got {g}"
                    )));
                }
                Ok(GainPolicy::Explicit(gains))
            }
            _ => Err(bad()),
        }
    }
}

impl GainPolicy {
    /// `Default` and `Auto` made concrete for a method that does (`adaptive_method`) or does
    /// not choose its own steps; other policies unchanged.
    pub fn resolve(self, adaptive_method: bool) -> GainPolicy {
        match self {
            GainPolicy::Default if adaptive_method => GainPolicy::Step { c: 2.0, every: 10 },
            GainPolicy::Default => GainPolicy::Bounded {
                c: crate::DEFAULT_BOUND_FRACTION,
            },
            GainPolicy::Auto if adaptive_method => GainPolicy::Step { c: 2.0, every: 10 },
            GainPolicy::Auto => GainPolicy::Adaptive { every: 100, c: 1.0 },
            other => other,
        }
    }

    /// The gains to start with at x₀ for step size h (for `Adaptive` and `Auto`, the scaled
    /// gains at x₀; wrap the stepper in [`AdaptiveGain`] to keep adapting them; for `Bounded`
    /// the model's, which [`crate::GainBound`] scales before every step; `Default` as
    /// for a fixed-step method: resolve it first for an adaptive one). `Step` needs
    /// the method's tolerance and order: use [`scaled_gains`] with [`step_gain_target`].
    pub fn initial_gains<Mdl, T, X, F, K>(&self, model: &Mdl, x0: &X, h: T) -> Result<K, GainError>
    where
        Mdl: Lyapunov<T, X, F, K> + ModelInfo + ?Sized,
        T: Float,
        X: State<T>,
        F: State<T>,
        K: State<T>,
    {
        let g = model.gain_names().len();
        let from = |v: &[f64]| -> Result<K, GainError> {
            if v.len() != g {
                return Err(GainError::WrongCount {
                    expected: g,
                    got: v.len(),
                });
            }
            let mut k = K::filled(K::len_for(g), T::zero());
            for (ki, vi) in k.as_mut().iter_mut().zip(v) {
                *ki = lit(*vi);
            }
            Ok(k)
        };
        match self {
            GainPolicy::ModelDefault | GainPolicy::Default | GainPolicy::Bounded { .. } => {
                from(model.default_gain_values())
            }
            GainPolicy::Explicit(v) => from(v),
            GainPolicy::Scaled { c } | GainPolicy::Adaptive { c, .. } => {
                let unit = K::filled(K::len_for(g), T::one());
                scaled_gains(model, x0, &unit, h, lit(*c))
            }
            GainPolicy::Auto => GainPolicy::Auto.resolve(false).initial_gains(model, x0, h),
            GainPolicy::Step { .. } => Err(GainError::Invalid(
                "the step-tracking gain needs the method's tolerance and order (step_gain_target)"
                    .to_string(),
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_iteration_finds_largest_eigenvalue() {
        // eigenvalues 5, 2, 0 (rank deficient, like H_GN)
        let q = [
            [1.0 / 3f64.sqrt(), 1.0 / 2f64.sqrt(), 1.0 / 6f64.sqrt()],
            [1.0 / 3f64.sqrt(), -1.0 / 2f64.sqrt(), 1.0 / 6f64.sqrt()],
            [1.0 / 3f64.sqrt(), 0.0, -2.0 / 6f64.sqrt()],
        ];
        let d = [5.0, 2.0, 0.0];
        let a: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| (0..3).map(|k| q[i][k] * d[k] * q[j][k]).sum())
        });
        let l = symmetric_spectral_norm(&a, 200, 1e-12);
        assert!((l - 5.0).abs() < 1e-9, "{l}");
    }

    #[test]
    fn parse_policies() {
        assert_eq!(
            "default".parse::<GainPolicy>().unwrap(),
            GainPolicy::Default
        );
        assert_eq!(
            "model".parse::<GainPolicy>().unwrap(),
            GainPolicy::ModelDefault
        );
        assert_eq!(
            GainPolicy::Default.resolve(true),
            GainPolicy::Step { c: 2.0, every: 10 }
        );
        assert_eq!(
            GainPolicy::Default.resolve(false),
            GainPolicy::Bounded {
                c: crate::DEFAULT_BOUND_FRACTION
            }
        );
        assert_eq!(
            "bounded:0.5".parse::<GainPolicy>().unwrap(),
            GainPolicy::Bounded { c: 0.5 }
        );
        assert!("bounded:1.5".parse::<GainPolicy>().is_err());
        assert!("bounded:0".parse::<GainPolicy>().is_err());
        assert!("step:2:0".parse::<GainPolicy>().is_err());
        assert!("adaptive:0".parse::<GainPolicy>().is_err());
        assert_eq!("auto".parse::<GainPolicy>().unwrap(), GainPolicy::Auto);
        assert_eq!(
            GainPolicy::Auto.resolve(false),
            GainPolicy::Adaptive { every: 100, c: 1.0 }
        );
        assert_eq!(
            GainPolicy::Auto.resolve(true),
            GainPolicy::Step { c: 2.0, every: 10 }
        );
        assert_eq!(
            "step:0.5:3".parse::<GainPolicy>().unwrap(),
            GainPolicy::Step { c: 0.5, every: 3 }
        );
        assert!("step:-1".parse::<GainPolicy>().is_err());
        assert_eq!(
            "fixed:0.5".parse::<GainPolicy>().unwrap(),
            GainPolicy::Scaled { c: 0.5 }
        );
        assert_eq!(
            "adaptive:10:1.5".parse::<GainPolicy>().unwrap(),
            GainPolicy::Adaptive { every: 10, c: 1.5 }
        );
        assert_eq!(
            "4,2".parse::<GainPolicy>().unwrap(),
            GainPolicy::Explicit(vec![4.0, 2.0])
        );
        assert!("fixed:3".parse::<GainPolicy>().is_err());
        assert!("bogus".parse::<GainPolicy>().is_err());
        assert!("1,x".parse::<GainPolicy>().is_err());
    }
}
