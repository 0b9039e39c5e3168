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
//! [`GainBound`] wraps the stepper of a fixed-step feedback run. Before every step of size h
//! it estimates h·L at the current state for the gains about to be used — the trace
//! tr(H) = Σᵢ kᵢ|∇fᵢ|² first (an upper bound, cheap), the power-iteration norm
//! [`gauss_newton_norm`] only where the trace is not already inside the bound — and either
//!
//! - **caps** ([`BoundMode::Cap`]): uses the model's gains scaled by
//!   α = min(1, θ/(h·L(x))), so h·k·L never exceeds θ = c·β (the default gains of fixed-step
//!   feedback methods, `--gains bounded[:c]`); where the model's gains are inside the bound
//!   they are used unchanged (α = 1, the same run bit for bit), or
//! - **watches** ([`BoundMode::Watch`]): leaves the gains alone (the model's, explicit or the
//!   other policies') and records where h·k·L passed β.
//!
//! Either way it reports the largest h·k·L estimate of the run, the number of steps past β
//! and the time of the first one ([`GainBound::counters`]), which a run's summary shows.

use crate::error::StepError;
use crate::feedback::FeedbackField;
use crate::field::{Lyapunov, ModelInfo};
use crate::gains::{gauss_newton_norm, gauss_newton_trace};
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

/// The default fraction c of β that the capped gains keep h·k·L within (`--gains bounded`).
///
/// The bound is about accuracy as much as stability: RK4's stages leave the level set by
/// O(h²), and the feedback's share of the local error grows with h·k·L (the order reduction
/// of explicit methods on stiff terms, Hairer & Wanner II, §IV.15). Measured on the Pleiades
/// and Arenstorf's orbit (docs/performance.md, "Gains for fixed-step methods"): with c = 0.1
/// feedback-RK4's largest invariant errors stay within a small factor of plain RK4's.
pub const DEFAULT_BOUND_FRACTION: f64 = 0.1;

/// What [`GainBound`] does with the gains.
#[derive(Clone, Debug, PartialEq)]
pub enum BoundMode<K> {
    /// Use `model` (the model's gains) scaled down where h·k·L would pass `theta`.
    Cap {
        /// The gains used where they are inside the bound.
        model: K,
        /// The largest h·k·L allowed, θ = c·β.
        theta: f64,
    },
    /// Leave the gains as they are; record where h·k·L passes β.
    Watch,
}

/// A stepper wrapper for fixed-step feedback runs that keeps (or watches) h·k·L inside the
/// base method's real stability interval (see the module docs).
#[derive(Clone, Debug)]
pub struct GainBound<S, K> {
    base: S,
    mode: BoundMode<K>,
    /// β of the base method.
    limit: f64,
    /// The factor the model's gains are scaled by now (cap mode).
    factor: f64,
    /// The largest h·k·L estimate of the run.
    max_hkl: f64,
    /// Steps that started with h·k·L past β.
    exceeded: u64,
    /// The time of the first of them (NaN: none).
    first_exceeded: f64,
    /// Steps with capped gains (α < 1).
    capped: u64,
    /// The smallest α of the run.
    min_factor: f64,
}

impl<S, K> GainBound<S, K> {
    /// Wraps `base`, a fixed-step method whose real stability interval is (−`limit`, 0].
    pub fn new(base: S, mode: BoundMode<K>, limit: f64) -> Self {
        GainBound {
            base,
            mode,
            limit,
            factor: f64::NAN,
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

impl<'a, S, Mdl, X, F, K> Stepper<f64, X, FeedbackField<'a, Mdl, F, K>> for GainBound<S, K>
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
        if h > 0.0 {
            let model = field.model();
            let hkl = match &self.mode {
                BoundMode::Cap { model: unit, theta } => {
                    let hl = h_norm(model, x, unit.as_ref(), h, *theta);
                    let factor = if hl > *theta { *theta / hl } else { 1.0 };
                    // a degenerate estimate (non-finite) keeps the last factor
                    if factor.is_finite() && factor.to_bits() != self.factor.to_bits() {
                        field.set_scaled_gains(unit, factor);
                        self.factor = factor;
                    }
                    if self.factor < 1.0 {
                        self.capped += 1;
                        self.min_factor = self.min_factor.min(self.factor);
                    }
                    hl * self.factor
                }
                BoundMode::Watch => {
                    let gains = field.gains();
                    h_norm(model, x, gains.as_ref(), h, self.limit)
                }
            };
            self.max_hkl = self.max_hkl.max(hkl);
            if hkl > self.limit {
                self.exceeded += 1;
                if self.first_exceeded.is_nan() {
                    self.first_exceeded = t;
                }
            }
        }
        self.base.step(field, t, x, h)
    }

    fn order(&self) -> u32 {
        self.base.order()
    }

    fn name(&self) -> String {
        match self.mode {
            BoundMode::Cap { .. } => format!("bounded-gain({})", self.base.name()),
            BoundMode::Watch => self.base.name(),
        }
    }

    /// The base stepper's: the gains change between steps, not within one.
    fn dense_output(&self) -> Option<&dyn crate::DenseOutput<f64, X>> {
        self.base.dense_output()
    }

    fn is_adaptive(&self) -> bool {
        self.base.is_adaptive()
    }

    fn checks_guards(&self) -> bool {
        self.base.checks_guards()
    }

    fn reset(&mut self) {
        self.base.reset();
        self.factor = f64::NAN;
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
