//! The stability bound of fixed-step feedback integrators.
//!
//! A fixed-step explicit method of order p with p stages (Euler, Heun, RK4) applied to the
//! feedback term −k∇V sees, near the target set, the linear system ẋ = −H x with
//! H = Dfᵀ K Df (module `gains`). It damps that system only while h·λ stays inside the real
//! interval (−β, 0] where |R(−h·λ)| ≤ 1, R(z) = Σ_{j≤p} zʲ/j! the method's stability
//! polynomial, for every eigenvalue λ of H ([`real_stability_interval`]: β = 2 for Euler and
//! Heun, 2.785 for RK4; Hairer & Wanner, *Solving Ordinary Differential Equations II*,
//! §IV.2, Fig. 2.1). Outside, every step multiplies the error along the stiffest direction by
//! |R(−h·λ)| > 1 and the "feedback" throws the solution off the level set it should pull it
//! back to. L = ‖H‖₂ grows where the field stiffens (close encounters: |∇(1/r)|² ∝ r⁻⁴), so
//! gains that are safe on most of an orbit are not safe everywhere on it.
//!
//! The base method cannot be told to stay inside that interval on the stages themselves: its
//! stages leave the level set by O(h²) (h²·XᵀD²f X where the field stiffens), and the
//! feedback evaluated there turns those stage deviations into errors of the step — the
//! order reduction of explicit methods on stiff terms (Hairer & Wanner II, §IV.15). On
//! Arenstorf's orbit at h = 10⁻⁴, stage-wise feedback with gains scaled to h·k·L ≤ 0.1β
//! still leaves the Jacobi integral's largest error 560 times plain RK4's.
//!
//! [`GainBound`] wraps the stepper of a fixed-step feedback run and either
//!
//! - **steps, then feeds back** ([`BoundMode::Cap`], the default gains of fixed-step
//!   feedback methods, `--gains bounded[:c]`): each step of the base method on X alone is
//!   followed by one explicit Euler step of the feedback field, x ← x − h·∇V(x). Each of the
//!   model's gains k_g is scaled by α_g = min(1, θ_g/(h·k_g·s_g)), s_g = Σ|∇fᵢ|² over its
//!   components, θ_g = θ/(the number of nonzero gains), so that h·tr(Dfᵀ K Df) ≥ h·k·L never
//!   exceeds θ = c·2 (explicit Euler's interval; c = 1/2 by default: the deviation decays
//!   monotonically), and the gain of an integral that does not stiffen keeps its strength
//!   where another one's must give way. It is a Lie splitting of X and −∇V whose commutator
//!   [X, ∇V] = ∇f (∇f·X) vanishes on the level set, so the splitting costs no order there; the
//!   feedback sees the step's local error instead of the stages' O(h²) deviations, or
//! - **watches** ([`BoundMode::Watch`], explicit gains and the other policies: the paper's
//!   feedback integrator, the base method on X − ∇V): leaves the gains alone and records
//!   where h·k·L passed β, estimated before every step by the trace tr(H) = Σᵢ kᵢ|∇fᵢ|² (an
//!   upper bound, cheap) and, only where the trace is not already inside β, the
//!   power-iteration norm [`gauss_newton_norm`].
//!
//! Either way it reports the largest h·k·L of the run, the number of steps past the interval
//! and the time of the first one ([`GainBound::counters`]), which a run's summary shows.

use crate::error::StepError;
use crate::feedback::FeedbackField;
use crate::field::{Lyapunov, ModelInfo};
use crate::gains::{gain_traces, gauss_newton_norm, gauss_newton_trace};
use crate::state::State;
use crate::steppers::{StepOutcome, Stepper};

/// β, the length of the real stability interval (−β, 0] of an explicit Runge–Kutta method
/// with p = `order` ≤ 4 stages (stability polynomial Σ_{j≤p} zʲ/j!, the roots of
/// |R(−β)| = 1): 2 (Euler, p = 1), 2 (Heun, p = 2), 2.5127 (p = 3), 2.7853 (RK4, p = 4).
/// None for other orders, whose stability polynomial depends on the tableau.
pub fn real_stability_interval(order: u32) -> Option<f64> {
    match order {
        1 | 2 => Some(2.0),
        3 => Some(2.512_745_326_618_328_6),
        4 => Some(2.785_293_563_405_282),
        _ => None,
    }
}

/// The default fraction c of explicit Euler's interval β = 2 that the feedback step of the
/// capped mode keeps h·k·L within (`--gains bounded`): h·k·L ≤ 1, where the deviation from the
/// level set decays by the factor 1 − h·k·L ≥ 0 per step, monotonically.
pub const DEFAULT_BOUND_FRACTION: f64 = 0.5;

/// The real stability interval of the feedback step of [`BoundMode::Cap`] (explicit Euler).
pub const FEEDBACK_STEP_INTERVAL: f64 = 2.0;

/// What [`GainBound`] does with the gains.
#[derive(Clone, Debug, PartialEq)]
pub enum BoundMode<K> {
    /// Step the base method on X, then feed back with `model` (the model's gains) scaled down
    /// where h·k·L would pass `theta`.
    Cap {
        /// The gains used where they are inside the bound.
        model: K,
        /// The largest h·k·L allowed, θ = c·[`FEEDBACK_STEP_INTERVAL`].
        theta: f64,
    },
    /// Leave the gains as they are; record where h·k·L passes β.
    Watch,
}

/// A stepper wrapper for fixed-step feedback runs that keeps (or watches) h·k·L inside the
/// real stability interval of the step that feeds back (see the module docs). `F` is the
/// storage of the model's stacked invariants (its Jacobian is kept between steps).
#[derive(Clone)]
pub struct GainBound<S, K, X: State<f64>, F: State<f64>> {
    base: S,
    mode: BoundMode<K>,
    /// β of the step that feeds back: [`FEEDBACK_STEP_INTERVAL`] (cap), the base method's
    /// (watch).
    limit: f64,
    /// ∇V at the end of a step (cap mode).
    grad: Option<X>,
    /// Σ|∇fᵢ|² per gain at the end of a step (cap mode).
    traces: Vec<f64>,
    /// Df at the end of a step (cap mode), the storage of [`gain_traces`].
    jac: Option<F::Rows<X>>,
    /// The largest h·k·L estimate of the run.
    max_hkl: f64,
    /// Steps that started with h·k·L past β.
    exceeded: u64,
    /// The time of the first of them (NaN: none).
    first_exceeded: f64,
    /// Steps with capped gains (α < 1).
    capped: u64,
    /// The smallest α_g of the run.
    min_factor: f64,
}

impl<S: std::fmt::Debug, K: std::fmt::Debug, X: State<f64> + std::fmt::Debug, F: State<f64>>
    std::fmt::Debug for GainBound<S, K, X, F>
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GainBound")
            .field("base", &self.base)
            .field("mode", &self.mode)
            .field("limit", &self.limit)
            .field("max_hkl", &self.max_hkl)
            .field("exceeded", &self.exceeded)
            .field("first_exceeded", &self.first_exceeded)
            .field("capped", &self.capped)
            .field("min_factor", &self.min_factor)
            .finish_non_exhaustive()
    }
}

impl<S, K, X: State<f64>, F: State<f64>> GainBound<S, K, X, F> {
    /// Wraps `base`, a fixed-step method: in [`BoundMode::Watch`], whose real stability
    /// interval is (−`limit`, 0]; in [`BoundMode::Cap`] `limit` is
    /// [`FEEDBACK_STEP_INTERVAL`].
    pub fn new(base: S, mode: BoundMode<K>, limit: f64) -> Self {
        GainBound {
            base,
            mode,
            limit,
            grad: None,
            traces: Vec::new(),
            jac: None,
            max_hkl: 0.0,
            exceeded: 0,
            first_exceeded: f64::NAN,
            capped: 0,
            min_factor: 1.0,
        }
    }

    /// The largest h·k·L estimate so far.
    pub fn max_hkl(&self) -> f64 {
        self.max_hkl
    }

    /// Steps that started outside the stability interval so far.
    pub fn exceeded_steps(&self) -> u64 {
        self.exceeded
    }

    /// Sets the field's gains for the feedback step at `x`: each gain k_g of `unit` scaled by
    /// α_g = min(1, θ_g/(h·k_g·s_g)), s_g = Σ|∇fᵢ|² over its components ([`gain_traces`]) and
    /// θ_g = θ/(the number of nonzero gains), so that the trace h·tr(Dfᵀ K Df) ≥ h·k·L stays
    /// within θ while the gains of the integrals that do not stiffen keep their strength.
    /// Returns the trace.
    fn cap_gains<'a, Mdl>(&mut self, field: &FeedbackField<'a, Mdl, F, K>, x: &X, h: f64) -> f64
    where
        Mdl: Lyapunov<f64, X, F, K> + ModelInfo + ?Sized,
        K: State<f64>,
    {
        let BoundMode::Cap { model: unit, theta } = &self.mode else {
            return 0.0;
        };
        let unit = unit.as_ref();
        self.traces.resize(unit.len(), 0.0);
        gain_traces(field.model(), x, &mut self.jac, &mut self.traces);
        let share = *theta / unit.iter().filter(|k| **k != 0.0).count().max(1) as f64;
        let mut hkl = 0.0;
        let mut step_min = 1.0f64;
        field.update_gains(|gains| {
            for ((k, u), s) in gains.as_mut().iter_mut().zip(unit).zip(&self.traces) {
                let hk = h * u * s;
                // a degenerate estimate (non-finite) leaves the gain out of this step
                let alpha = if hk > share {
                    share / hk
                } else if hk.is_finite() {
                    1.0
                } else {
                    0.0
                };
                *k = u * alpha;
                hkl += hk * alpha;
                step_min = step_min.min(alpha);
            }
        });
        if step_min < 1.0 {
            self.capped += 1;
            self.min_factor = self.min_factor.min(step_min);
        }
        hkl
    }

    /// Records a step's h·k·L estimate, from time `t`.
    fn record(&mut self, t: f64, hkl: f64) {
        self.max_hkl = self.max_hkl.max(hkl);
        if hkl > self.limit {
            self.exceeded += 1;
            if self.first_exceeded.is_nan() {
                self.first_exceeded = t;
            }
        }
    }
}

/// h·L(x) for `gains`: the trace bound h·tr(H) where it is at most `screen`, else the
/// power-iteration norm (at most the trace).
fn h_norm<Mdl, X, F>(model: &Mdl, x: &X, gains: &[f64], h: f64, screen: f64) -> f64
where
    Mdl: crate::field::Invariants<f64, X, F> + ModelInfo + ?Sized,
    X: State<f64>,
    F: State<f64>,
{
    let upper = h * gauss_newton_trace(model, x, gains);
    if upper <= screen || !upper.is_finite() {
        upper
    } else {
        h * gauss_newton_norm(model, x, gains)
    }
}

impl<'a, S, Mdl, X, F, K> Stepper<f64, X, FeedbackField<'a, Mdl, F, K>> for GainBound<S, K, X, F>
where
    S: Stepper<f64, X, FeedbackField<'a, Mdl, F, K>>,
    Mdl: Lyapunov<f64, X, F, K> + ModelInfo + ?Sized,
    X: State<f64>,
    F: State<f64>,
    K: State<f64>,
{
    fn step(
        &mut self,
        field: &FeedbackField<'a, Mdl, F, K>,
        t: f64,
        x: &mut X,
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        let model = field.model();
        if self.mode == BoundMode::Watch {
            if h > 0.0 {
                let hkl = h_norm(model, x, field.gains().as_ref(), h, self.limit);
                self.record(t, hkl);
            }
            return self.base.step(field, t, x, h);
        }
        field.set_in_stages(false);
        let outcome = self.base.step(field, t, x, h)?;
        if h > 0.0 {
            let hkl = self.cap_gains(field, x, h);
            let grad = self.grad.get_or_insert_with(|| x.clone());
            field.lyapunov_gradient(x, grad);
            for (xi, gi) in x.as_mut().iter_mut().zip(grad.as_ref()) {
                *xi -= h * *gi;
            }
            self.record(t, hkl);
        }
        Ok(outcome)
    }

    fn order(&self) -> u32 {
        self.base.order()
    }

    fn name(&self) -> String {
        match self.mode {
            BoundMode::Cap { .. } => format!("{}+feedback-step", self.base.name()),
            BoundMode::Watch => self.base.name(),
        }
    }

    /// The base stepper's (watch mode: the gains change between steps, not within one); none
    /// in cap mode, whose feedback step moves the state after the base step's interpolant.
    fn dense_output(&self) -> Option<&dyn crate::DenseOutput<f64, X>> {
        match self.mode {
            BoundMode::Cap { .. } => None,
            BoundMode::Watch => self.base.dense_output(),
        }
    }

    fn is_adaptive(&self) -> bool {
        self.base.is_adaptive()
    }

    fn checks_guards(&self) -> bool {
        self.base.checks_guards()
    }

    fn reset(&mut self) {
        self.base.reset();
        self.max_hkl = 0.0;
        self.exceeded = 0;
        self.first_exceeded = f64::NAN;
        self.capped = 0;
        self.min_factor = 1.0;
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let mut v = self.base.counters();
        v.push(("stability_interval", self.limit));
        v.push(("max_h_k_L", self.max_hkl));
        v.push(("steps_outside_stability", self.exceeded as f64));
        v.push(("first_outside_stability_t", self.first_exceeded));
        if matches!(self.mode, BoundMode::Cap { .. }) {
            v.push(("capped_steps", self.capped as f64));
            v.push(("min_gain_factor", self.min_factor));
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// β is where |R(−β)| = 1 for R(z) = Σ_{j≤p} zʲ/j!, with |R| ≤ 1 on (−β, 0] and > 1 just
    /// beyond (the table checked against the polynomials themselves).
    #[test]
    fn stability_interval_is_where_the_polynomial_leaves_the_unit_disc() {
        for p in 1..=4u32 {
            let beta = real_stability_interval(p).unwrap();
            let r = |z: f64| {
                (0..=p)
                    .map(|j| z.powi(j as i32) / (1..=j).product::<u32>() as f64)
                    .sum::<f64>()
            };
            assert!(
                (r(-beta).abs() - 1.0).abs() < 1e-12,
                "p = {p}: {}",
                r(-beta)
            );
            for i in 1..1000 {
                let z = -beta * f64::from(i) / 1000.0;
                assert!(r(z).abs() <= 1.0 + 1e-12, "p = {p}, z = {z}");
            }
            assert!(r(-beta * 1.001).abs() > 1.0, "p = {p}");
        }
        assert_eq!(real_stability_interval(5), None);
    }
}
