//! # lasalle-runtime
//!
//! The traits that lasalle-generated models implement ([`Field`], [`Invariants`],
//! [`Lyapunov`], [`Partitioned`], [`ModelInfo`]) and the machinery that integrates them:
//!
//! - [`Stepper`]: one-step methods — [`ExplicitRk`] over a [`Tableau`] (Euler, Heun, RK4,
//!   DOPRI5), adaptive [`DormandPrince`] with dense output, [`StormerVerlet`] A/B,
//!   [`Projection`] onto f(x) = f(x₀), [`RigidBodySplitting`];
//! - [`Driver`] / [`integrate`]: run a stepper to an end time with observers, blow-up checks
//!   and guards, failing loudly with a [`StepError`] that carries t, h and the state;
//!   [`DriftBound`] stops a run whose invariants drift past a bound ([`Driver::divergence`]);
//! - [`FeedbackField`]: the feedback integrator's field X − ∇V, so any stepper becomes a
//!   feedback integrator; [`gains`](crate::scaled_gains) selection ([`GainPolicy`],
//!   [`AdaptiveGain`]);
//! - [`Taylor`]: the adaptive Taylor method (Jorba & Zou), over coefficient
//!   [`TaylorKernel`]s that interpreted and emitted models provide;
//! - [`Observer`]s ([`Recorder`] of states and invariant errors, [`Stride`], [`StopWhen`]) and
//!   CSV ([`Csv`], [`write_csv`]);
//! - [`elliptic`]: Jacobi elliptic functions [`ellipj`] (sn, cn, dn, am; parameter m = k²) and
//!   elliptic integrals of the first kind [`ellipk`], [`ellipf`].
//!
//! A feedback-Euler run of a model `m` with state `x0`, gains `k` and step `h`:
//!
//! ```ignore
//! let fb = FeedbackField::from_initial(&m, &x0, k);
//! let mut rec = Recorder::new(&m, &x0, 100, sample_capacity(n_steps, 100));
//! let end = integrate(&mut ExplicitRk::euler(), &fb, &x0, 0.0, t_end, h, &mut rec)?;
//! ```
#![warn(missing_docs)]
// Numerical kernels index several arrays with the same loop variable.
#![allow(clippy::needless_range_loop)]
// `!(a > b)` is deliberate throughout: it is also true when a comparison involves NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod declared;
mod divergence;
mod driver;
pub use lasalle_elliptic as elliptic;
mod error;
pub mod events;
mod feedback;
mod field;
mod gain_bound;
mod gains;
mod observe;
mod output;
mod params;
pub mod state;
pub mod steppers;
pub mod taylor;

pub use declared::{Declared, DelaySpec, GuardFailure, Preset, SwitchSpec};
pub use divergence::{DriftBound, DEFAULT_MAX_DRIFT};
pub use driver::{integrate, Driver, GuardFn, Summary, INTERRUPT_EVERY};
pub use elliptic::{ellipf, ellipj, ellipj_m1, ellipk, ellipkm1, Jacobi};
pub use error::StepError;
pub use events::{Crossing, EventDirection, EventSpec, Watch};
pub use feedback::{default_lyapunov_gradient, expand_gains, FeedbackField};
pub use field::{
    lit, Field, InvariantInfo, InvariantKind, Invariants, Lyapunov, ModelInfo, Partitioned, Shape,
    Slot,
};
pub use gain_bound::{
    real_stability_interval, BoundMode, GainBound, DEFAULT_BOUND_FRACTION, FEEDBACK_STEP_INTERVAL,
};
pub use gains::{
    gauss_newton_hessian, gauss_newton_norm, gauss_newton_trace, scaled_gains, step_gain_target,
    symmetric_spectral_norm, AdaptiveGain, GainError, GainPolicy,
};
pub use nalgebra;
pub use num_traits;
pub use observe::{sample_capacity, Control, Observer, Recorder, StateRecorder, StopWhen, Stride};
pub use output::{component_names, write_csv, Csv};
pub use params::{ParamError, Parameters};
pub use state::State;
pub use steppers::{
    pivoted_cholesky_solve, rtol_floor, Batch, CompiledStep, Composition, DenseOutput,
    DormandPrince, DormandPrinceOptions, Euler, ExplicitRk, FixedMethod, Heun, Projection,
    RawBatch, RawStep, RigidBodySplitting, Rk4, Splitting, StepOutcome, Stepper, StormerVerlet,
    Tableau, VerletVariant,
};
pub use taylor::{
    LaneEnd, LaneRuns, Taylor, TaylorBatch, TaylorError, TaylorField, TaylorKernel, TaylorKernels,
    TaylorLanes, TaylorOptions,
};
