//! One-step methods: the [`Stepper`] trait and its implementations.
//!
//! A stepper advances a state `x ∈ Rᴺ` of an autonomous field from `t` to `t + h`
//! (Hairer–Nørsett–Wanner, *Solving ODEs I* (HNW I), §II.1: a one-step method
//! `x_{n+1} = x_n + h Φ(x_n, h)`). Fixed-step methods always take the requested `h`; adaptive
//! ones ([`DormandPrince`]) may take a smaller step and propose the next one. The outcome of a
//! step is a [`StepOutcome`] (diffsol's `OdeSolverStopReason` habit); failures are
//! [`StepError`]s carrying `t`, `h` and the state.
//!
//! | stepper | file | order | needs |
//! | --- | --- | --- | --- |
//! | [`ExplicitRk`] over a [`Tableau`] (Euler, Heun, RK4, DOPRI5 fixed) | `explicit_rk.rs` | 1, 2, 4, 5 | [`Field`](crate::Field) |
//! | [`DormandPrince`] adaptive 5(4) with dense output | `dormand_prince.rs` | 5 | [`Field`](crate::Field) |
//! | [`StormerVerlet`] A (kick–drift–kick) / B (drift–kick–drift) | `stormer_verlet.rs` | 2 | [`Partitioned`](crate::Partitioned) |
//! | [`Composition`] of Störmer–Verlet (Yoshida, Suzuki) | `composition.rs` | 4, 6, 8 | [`Partitioned`](crate::Partitioned) |
//! | [`Projection`] of any base stepper onto f(x) = f(x₀) | `projection.rs` | base | [`Invariants`](crate::Invariants) |
//! | [`RigidBodySplitting`] into three rotations | `rigid_body_splitting.rs` | 2 | the free rigid body (N = 12) |
//! | [`Splitting`]: the splitting a model declares | `splitting.rs` | its kind's | [`Declared::splitting`](crate::Declared::splitting) |

use num_traits::Float;

use crate::error::StepError;
use crate::state::State;

mod compiled;
mod composition;
mod dormand_prince;
mod explicit_rk;
mod projection;
mod rigid_body_splitting;
mod splitting;
mod stormer_verlet;
mod tableau;

pub use compiled::{CompiledStep, FixedMethod, RawBatch, RawStep};
pub use composition::Composition;
pub use dormand_prince::{rtol_floor, DormandPrince, DormandPrinceOptions};
pub use explicit_rk::{Euler, ExplicitRk, Heun, Rk4};
pub use projection::{pivoted_cholesky_solve, Projection};
pub use rigid_body_splitting::RigidBodySplitting;
pub use splitting::Splitting;
pub use stormer_verlet::{StormerVerlet, VerletVariant};
pub use tableau::Tableau;

/// What one call to [`Stepper::fixed_steps`] did: the steps it took and their evaluations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Batch {
    /// Steps taken, each of the requested size, each with a finite new state on which the
    /// model's guards hold.
    pub steps: u64,
    /// Field evaluations spent on them.
    pub evaluations: u64,
}

/// What one successful call to [`Stepper::step`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepOutcome<T> {
    /// The step actually taken (x now approximates the solution at `t + h_taken`).
    pub h_taken: T,
    /// The step size proposed for the next step (equal to the requested `h` for fixed-step
    /// methods).
    pub h_next: T,
    /// Trial steps rejected before this one was accepted (0 for fixed-step methods).
    pub rejections: u32,
    /// Field evaluations spent on this step (including rejected trials).
    pub evaluations: u32,
}

impl<T: Copy> StepOutcome<T> {
    /// The outcome of a fixed step of size `h` that cost `evaluations` field evaluations.
    pub fn fixed(h: T, evaluations: u32) -> Self {
        StepOutcome {
            h_taken: h,
            h_next: h,
            rejections: 0,
            evaluations,
        }
    }
}

/// A one-step method for the field `F` on Rᴺ, with states stored as `X` ([`State`]).
///
/// `step` advances `x` in place from time `t` by (at most) `h` and must not allocate (scratch
/// storage for run-time-sized states is allocated at the first step and kept). The
/// field type is a trait parameter so each method can ask for exactly the capability it uses
/// (diffsol's habit of splitting traits by capability): explicit Runge–Kutta needs
/// [`Field`](crate::Field), Störmer–Verlet [`Partitioned`](crate::Partitioned), projection
/// [`Invariants`](crate::Invariants).
///
/// Use a stepper directly in a loop, or through [`integrate`](crate::integrate) /
/// [`Driver`](crate::Driver), which handles the end time, observers, blow-up checks and guards.
pub trait Stepper<T: Float, X: State<T>, F: ?Sized> {
    /// Advances `x` from `t` by a step of (at most) `h > 0`.
    ///
    /// On error `x` is left unchanged for adaptive methods and may hold the failed iterate for
    /// fixed-step ones; the error itself carries the relevant state.
    fn step(&mut self, field: &F, t: T, x: &mut X, h: T) -> Result<StepOutcome<T>, StepError>;

    /// The classical order of the method.
    fn order(&self) -> u32;

    /// A short name for reports, e.g. `"rk4"` or `"projection(euler)"`.
    fn name(&self) -> String;

    /// True for methods that choose their own step size (the driver then follows
    /// [`StepOutcome::h_next`] instead of a constant `h`).
    fn is_adaptive(&self) -> bool {
        false
    }

    /// An initial step size for adaptive methods (HNW I, §II.4 "Starting step size"), given
    /// the initial state and the end time. Fixed-step methods return `None`.
    fn initial_step(&mut self, _field: &F, _t0: T, _x0: &X, _t_end: T) -> Option<T> {
        None
    }

    /// Forgets cached information about the previous step (e.g. a first-same-as-last stage).
    /// Call it when the state is changed outside the stepper.
    fn reset(&mut self) {}

    /// The continuous extension of the last accepted step, for steppers that have their own
    /// (DOPRI5's interpolant, the Taylor polynomial); `None` by default, and for wrappers
    /// that change the state after the base step. Events and output times use it, and a
    /// Hermite cubic otherwise ([`crate::events`]).
    fn dense_output(&self) -> Option<&dyn DenseOutput<T, X>> {
        None
    }

    /// True for steppers that check the model's guards on every new state themselves
    /// ([`CompiledStep`]), so that the driver need not; false by default.
    fn checks_guards(&self) -> bool {
        false
    }

    /// Takes up to `k` fixed steps of size `h` in one call, where the stepper can do so
    /// cheaper than `k` calls of [`step`](Self::step) ([`CompiledStep`]): the steps are those
    /// `step` would take, and the batch ends before the first one whose new state is not
    /// finite or fails a guard, leaving `x` at the last good state, so that the caller's next
    /// [`step`](Self::step) meets the failure and reports it as usual. `None` (the default) if
    /// the stepper takes no batches; the [`Driver`](crate::Driver) then calls `step` each time.
    fn fixed_steps(&mut self, _field: &F, _x: &mut X, _h: T, _k: u64) -> Option<Batch> {
        None
    }

    /// Named counters of the work done so far beyond steps and evaluations, for reports:
    /// [`Projection`] adds `newton_iterations` and `projected_steps`,
    /// [`AdaptiveGain`](crate::AdaptiveGain) `last_gauss_newton_norm`; a wrapper lists its
    /// base stepper's counters first. None by default.
    fn counters(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
}

/// Continuous extension of the last accepted step (HNW I, §II.6 "Dense output").
pub trait DenseOutput<T: Float, X: State<T>> {
    /// The interval `[t_old, t_new]` covered by the last accepted step, if any.
    fn dense_interval(&self) -> Option<(T, T)>;

    /// Writes the interpolated state at time `t` (within [`dense_interval`](Self::dense_interval))
    /// into `out`. Returns `false` if there is no step yet or `t` lies outside the interval
    /// (beyond a relative slack of a few ulps).
    fn interpolate(&self, t: T, out: &mut X) -> bool;

    /// The interpolated states at the times `ts` into `outs` (as many): bitwise what
    /// [`interpolate`](Self::interpolate) writes at each time; `false` if any time lies
    /// outside the interval. Steppers override it where several times cost less together
    /// (the Taylor polynomial's Horner recurrences, interleaved); by default one
    /// `interpolate` per time.
    fn interpolate_many(&self, ts: &[T], outs: &mut [X]) -> bool {
        ts.iter()
            .zip(outs)
            .fold(true, |ok, (&t, out)| self.interpolate(t, out) && ok)
    }
}

impl<T: Float, X: State<T>, F: ?Sized, S: Stepper<T, X, F> + ?Sized> Stepper<T, X, F> for &mut S {
    fn step(&mut self, field: &F, t: T, x: &mut X, h: T) -> Result<StepOutcome<T>, StepError> {
        (**self).step(field, t, x, h)
    }
    fn order(&self) -> u32 {
        (**self).order()
    }
    fn name(&self) -> String {
        (**self).name()
    }
    fn is_adaptive(&self) -> bool {
        (**self).is_adaptive()
    }
    fn initial_step(&mut self, field: &F, t0: T, x0: &X, t_end: T) -> Option<T> {
        (**self).initial_step(field, t0, x0, t_end)
    }
    fn reset(&mut self) {
        (**self).reset()
    }
    fn dense_output(&self) -> Option<&dyn DenseOutput<T, X>> {
        (**self).dense_output()
    }
    fn checks_guards(&self) -> bool {
        (**self).checks_guards()
    }
    fn fixed_steps(&mut self, field: &F, x: &mut X, h: T, k: u64) -> Option<Batch> {
        (**self).fixed_steps(field, x, h, k)
    }
    fn counters(&self) -> Vec<(&'static str, f64)> {
        (**self).counters()
    }
}
