//! [`StepError`]: why a step or an integration stopped early, with the time, step and state.
//!
//! Every variant carries the time `t`, the step size `h` being attempted and the state at
//! which the failure was detected (converted to `f64`), so a caller can always report *where*
//! an integration went wrong (diffsol's `StepSizeTooSmall { time }` habit). The state vector is
//! only built on the error path; the stepping loop itself does not allocate.

use num_traits::Float;

/// Converts a state into the `Vec<f64>` stored in a [`StepError`].
pub(crate) fn state_to_vec<T: Float>(x: &[T]) -> Vec<f64> {
    x.iter().map(|v| v.to_f64().unwrap_or(f64::NAN)).collect()
}

/// Converts a scalar into `f64` for an error message.
pub(crate) fn to_f64<T: Float>(v: T) -> f64 {
    v.to_f64().unwrap_or(f64::NAN)
}

/// An integration failed: the error says why, at which time and step, and in which state.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StepError {
    /// The state (or the field evaluated at it) contains NaN or ±∞: the solution blew up.
    #[error("blow-up: non-finite {what} at step {step}, t = {t} (h = {h:e}); state = {state:?}")]
    NonFinite {
        /// What was non-finite: `"state"` or `"field"`.
        what: &'static str,
        /// Time at which the non-finite value was detected.
        t: f64,
        /// The step that produced it (counted from 1; set by the [`crate::Driver`]).
        step: u64,
        /// Step size of the step that produced it.
        h: f64,
        /// The state (after the step for `"state"`, before it for `"field"`).
        state: Vec<f64>,
    },
    /// An adaptive stepper needed a step below the smallest admissible one: the larger of
    /// its own `h_min` and ten ulps of t (ten times the machine epsilon times |t|, below which
    /// t + h hardly moves), or the smallest normal number at t = 0. The solution cannot be
    /// resolved there at the requested tolerance — a singularity ahead (a collision, a finite
    /// escape time), a discontinuity of the field, or a tolerance below what f64 delivers.
    #[error(
        "step size underflow at t = {t}: the method needs h = {h:e}, below the smallest step \
         h_min = {h_min:e} (ten ulps of t); a singularity or a discontinuity ahead, or a \
         tolerance beyond f64; state = {state:?}"
    )]
    StepSizeTooSmall {
        /// Time at the start of the failed step.
        t: f64,
        /// The rejected step size.
        h: f64,
        /// The smallest admissible step at this time.
        h_min: f64,
        /// The state at the start of the failed step.
        state: Vec<f64>,
    },
    /// An adaptive stepper rejected too many consecutive trial steps.
    #[error("too many rejected steps at t = {t}: {rejections} in a row (last h = {h:e}); state = {state:?}")]
    TooManyRejections {
        /// Time at the start of the failed step.
        t: f64,
        /// The last trial step size.
        h: f64,
        /// Number of consecutive rejections.
        rejections: u32,
        /// The state at the start of the failed step.
        state: Vec<f64>,
    },
    /// The driver reached its step budget before the end time. Accepted and rejected steps
    /// both count against the budget ([`crate::Driver::max_steps`]).
    #[error(
        "step budget of {steps} steps spent at t = {t} ({rejected} of them rejected, h = {h:e}); \
         state = {state:?}"
    )]
    MaxSteps {
        /// Time reached.
        t: f64,
        /// The current step size.
        h: f64,
        /// The step budget.
        steps: u64,
        /// How many of the steps spent were rejected trial steps of an adaptive method.
        rejected: u64,
        /// The state reached.
        state: Vec<f64>,
    },
    /// The simplified Newton iteration of the projection method did not reach its tolerance.
    #[error(
        "projection did not converge at t = {t} (h = {h:e}): |f(x) - f(x0)| = {residual:e} > tol = {tol:e} \
         after {iterations} iterations; state = {state:?}"
    )]
    ProjectionNotConverged {
        /// Time at the end of the step being projected.
        t: f64,
        /// Step size of the base step.
        h: f64,
        /// Newton iterations performed.
        iterations: u32,
        /// Euclidean norm of the last residual f(x̃) − f(x₀).
        residual: f64,
        /// The requested tolerance.
        tol: f64,
        /// The last iterate x̃.
        state: Vec<f64>,
    },
    /// A caller-supplied validity check (a guard, see [`crate::Driver::guard`]) failed.
    #[error("guard failed at step {step}, t = {t} (h = {h:e}): {message}; state = {state:?}")]
    Guard {
        /// Time of the offending state.
        t: f64,
        /// The step that produced it (0: the initial state).
        step: u64,
        /// Step size of the step that produced it.
        h: f64,
        /// The guard's message.
        message: String,
        /// The offending state.
        state: Vec<f64>,
    },
    /// The run diverged: a monitored quantity (an invariant's drift, see
    /// [`crate::DriftBound`]) left its bound or became non-finite.
    #[error("diverged at step {step}, t = {t}: {message}; state = {state:?}")]
    Diverged {
        /// Time of the offending state.
        t: f64,
        /// The step that produced it.
        step: u64,
        /// What diverged, with its value and bound.
        message: String,
        /// The offending state.
        state: Vec<f64>,
    },
    /// The caller asked the run to stop ([`crate::Driver::interrupt`]): a Ctrl-C, a cancelled
    /// job.
    #[error("interrupted at step {step}, t = {t}")]
    Interrupted {
        /// Time reached.
        t: f64,
        /// Steps taken.
        step: u64,
        /// The state reached.
        state: Vec<f64>,
    },
    /// The arguments of a stepper or of the driver are inconsistent (e.g. h ≤ 0, t_end < t₀).
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

impl StepError {
    /// The time at which the error occurred, if it has one.
    pub fn time(&self) -> Option<f64> {
        match self {
            StepError::NonFinite { t, .. }
            | StepError::StepSizeTooSmall { t, .. }
            | StepError::TooManyRejections { t, .. }
            | StepError::MaxSteps { t, .. }
            | StepError::ProjectionNotConverged { t, .. }
            | StepError::Guard { t, .. }
            | StepError::Diverged { t, .. }
            | StepError::Interrupted { t, .. } => Some(*t),
            StepError::InvalidInput(_) => None,
        }
    }

    /// The state at which the error occurred, if it has one.
    pub fn state(&self) -> Option<&[f64]> {
        match self {
            StepError::NonFinite { state, .. }
            | StepError::StepSizeTooSmall { state, .. }
            | StepError::TooManyRejections { state, .. }
            | StepError::MaxSteps { state, .. }
            | StepError::ProjectionNotConverged { state, .. }
            | StepError::Guard { state, .. }
            | StepError::Diverged { state, .. }
            | StepError::Interrupted { state, .. } => Some(state),
            StepError::InvalidInput(_) => None,
        }
    }

    /// The step at which the run failed, where the error knows it (blow-ups, guards,
    /// divergence and the step budget: the accepted steps when it ran out).
    pub fn step(&self) -> Option<u64> {
        match self {
            StepError::NonFinite { step, .. }
            | StepError::Guard { step, .. }
            | StepError::Diverged { step, .. }
            | StepError::Interrupted { step, .. } => Some(*step),
            StepError::MaxSteps {
                steps, rejected, ..
            } => Some(steps - rejected),
            _ => None,
        }
    }

    /// The error of a run of the time-reversed field as the model's own time tells it: the
    /// time and step size negated (a backward run, t = −s).
    pub fn reversed_in_time(mut self) -> Self {
        match &mut self {
            StepError::NonFinite { t, h, .. }
            | StepError::StepSizeTooSmall { t, h, .. }
            | StepError::TooManyRejections { t, h, .. }
            | StepError::MaxSteps { t, h, .. }
            | StepError::ProjectionNotConverged { t, h, .. }
            | StepError::Guard { t, h, .. } => {
                *t = -*t;
                *h = -*h;
            }
            StepError::Diverged { t, .. } | StepError::Interrupted { t, .. } => *t = -*t,
            StepError::InvalidInput(_) => {}
        }
        self
    }

    /// The error with its step number set (the driver knows it; a stepper does not).
    pub(crate) fn at_step(mut self, n: u64) -> Self {
        if let StepError::NonFinite { step, .. } = &mut self {
            *step = n;
        }
        self
    }

    /// A guard's failure reported by a stepper ([`crate::CompiledStep`]) with the step number
    /// and the time of the new state as the driver counts them.
    pub(crate) fn guard_at(mut self, n: u64, time: f64) -> Self {
        if let StepError::Guard { step, t, .. } = &mut self {
            *step = n;
            *t = time;
        }
        self
    }

    /// A [`StepError::NonFinite`] for a state or field value.
    pub(crate) fn non_finite<T: Float>(what: &'static str, t: T, h: T, x: &[T]) -> Self {
        StepError::NonFinite {
            what,
            t: to_f64(t),
            step: 0,
            h: to_f64(h),
            state: state_to_vec(x),
        }
    }
}

/// True when every component is finite.
#[inline]
pub(crate) fn all_finite<T: Float>(x: &[T]) -> bool {
    // without an early exit: the compiler vectorises the fold, and a state is finite nearly
    // always (every step checks its state and its first stage)
    x.iter().fold(true, |ok, v| ok & v.is_finite())
}
