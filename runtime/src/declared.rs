//! What a model file declares for running it, beyond its field: run presets, domain guards and
//! the structure-specific steppers it admits. Front ends (the command line, a sweep) read these
//! instead of knowing models by name; compiled and loaded models implement [`Declared`] alike.

use num_traits::Float;

use crate::events::EventSpec;
use crate::field::Partitioned;
use crate::state::State;
use crate::steppers::{CompiledStep, FixedMethod, Splitting};
use crate::taylor::{TaylorError, TaylorKernels};

/// A run preset (`run paper { method = feedback_euler; dt = 0.005; … }`): the settings a run uses
/// unless the caller overrides them. Every setting is optional.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Preset {
    /// Name.
    pub name: &'static str,
    /// The method as the command line spells it (`feedback-euler`).
    pub method: Option<&'static str>,
    /// Step size (the initial step of adaptive methods).
    pub dt: Option<f64>,
    /// End time.
    pub t_end: Option<f64>,
    /// Record every n-th step.
    pub every: Option<u64>,
    /// The named point to start from.
    pub init: Option<&'static str>,
    /// Gains of feedback methods.
    pub gains: Option<&'static [f64]>,
    /// Parameter values, each parameter's slots as `Parameters::set_param` takes them.
    pub params: &'static [(&'static str, &'static [f64])],
}

/// A domain guard that failed: a condition the model file requires of every state
/// (`guard collision: norm(x) > 1e-6;`).
#[derive(Clone, Debug, PartialEq)]
pub struct GuardFailure {
    /// The guard's name.
    pub name: &'static str,
    /// Its condition as written in the model file.
    pub condition: &'static str,
    /// The margin (left − right side for `>`, right − left for `<`) at the state: ≤ 0 or NaN.
    pub margin: f64,
}

impl GuardFailure {
    /// The failure of the guard `name` if its `margin` is not positive (`strict`, for `<` and
    /// `>`) or is negative (for `<=` and `>=`), or is NaN; `None` if the guard holds.
    pub fn check<T: Float>(
        name: &'static str,
        condition: &'static str,
        margin: T,
        strict: bool,
    ) -> Option<GuardFailure> {
        let holds = if strict {
            margin > T::zero()
        } else {
            margin >= T::zero()
        };
        (!holds).then(|| GuardFailure {
            name,
            condition,
            margin: margin.to_f64().unwrap_or(f64::NAN),
        })
    }
}

impl std::fmt::Display for GuardFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "guard `{}` violated: {} does not hold (margin {:e})",
            self.name, self.condition, self.margin
        )
    }
}

/// A switching surface g = 0 of a discontinuous field (`sign(g)` in a model file): the state
/// components of its mode s = sign(g) and slide flag σ, and its four `stop` events, from
/// `event` on: the crossing, the ends of a Filippov slide on the + and the − side, the end of
/// a classical slide. A run integrates the field with the modes fixed and decides them anew
/// at each of these events (`lasalle_run`'s switching loop, `docs/switching.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SwitchSpec {
    /// g as written in the model file.
    pub surface: &'static str,
    /// The state component of the mode s.
    pub mode: usize,
    /// The state component of the slide flag σ.
    pub slide: usize,
    /// The index of the crossing event among [`Declared::events`]; the three ends of slides
    /// follow it.
    pub event: usize,
}

/// A delayed state x(t − r) of a delay equation (`delay(x, r)` in a model file): the state
/// component x, the *lag slot* the field reads x(t − r) from, and the *clock* τ (τ̇ = 1) that
/// carries the time into the field. The field of the lag slot is the delay r itself (an
/// expression of the parameters): a run reads r there once, integrates the slot with
/// derivative 0 and fills in x(t − r) before every evaluation (the method of steps,
/// `lasalle_run`'s delay run, `docs/delay.md`). A plain run of such a model is meaningless.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DelaySpec {
    /// The call as written in the model file, e.g. `delay(x, r)`.
    pub text: &'static str,
    /// Where it is: `file:line:column`.
    pub location: &'static str,
    /// The state component x.
    pub component: usize,
    /// The lag slot.
    pub slot: usize,
    /// The clock.
    pub clock: usize,
}

/// The declarations of a model file that a run can use.
///
/// Every method has a default meaning "nothing declared", so hand-written models implement it
/// with an empty `impl`.
pub trait Declared<T: Float, X: State<T>> {
    /// The run presets, the first being the default.
    fn presets(&self) -> &'static [Preset] {
        &[]
    }

    /// Checks the guards at state `x` for step size `dt` (0 for adaptive methods): the first
    /// one that fails, if any.
    fn check_guards(&self, _x: &X, _dt: T) -> Option<GuardFailure> {
        None
    }

    /// The events the model file declares (`event NAME: g = 0 …;`), in order.
    fn events(&self) -> &'static [EventSpec] {
        &[]
    }

    /// The event functions g(x, t), one per [`Declared::events`], into `g`.
    fn event_values(&self, _x: &X, _t: T, _g: &mut [T]) {}

    /// The switching surfaces of a discontinuous field (`sign(g)`), in order.
    fn switches(&self) -> &'static [SwitchSpec] {
        &[]
    }

    /// The delayed states of a delay equation (`delay(x, r)`), in order.
    fn delays(&self) -> &'static [DelaySpec] {
        &[]
    }

    /// The model as a partitioned field, if its field is partitioned (Störmer–Verlet applies).
    fn partitioned(&self) -> Option<&dyn Partitioned<T, X>> {
        None
    }

    /// The structure-specific splitting the model declares (`splitting KIND(ARGS);`), if any,
    /// with its parameters' current values.
    fn splitting(&self) -> Option<Splitting<T>> {
        None
    }

    /// A step of the fixed-step explicit Runge–Kutta `method` compiled whole by the model's
    /// back end, on the model's field or, with `feedback = Some((targets, gains))`, on
    /// X − ∇V with those fixed targets and gains; the guards checked at step size
    /// `guard_step` (see [`CompiledStep`]). `None` (the default) where the back end compiles
    /// none, and [`ExplicitRk`](crate::ExplicitRk) runs.
    fn compiled_step(
        &self,
        _method: &FixedMethod<'_>,
        _feedback: Option<(&[f64], &[f64])>,
        _guard_step: f64,
    ) -> Option<CompiledStep> {
        None
    }

    /// The Taylor-coefficient kernels of the field and of X − ∇V with the model's current
    /// parameters, for orders up to at least `max_order`, to drive with [`crate::Taylor::new`].
    /// Compiled and loaded models have them; the default is an error.
    fn taylor_kernels(&self, max_order: u32) -> Result<TaylorKernels<Self>, TaylorError>
    where
        Self: Sized,
    {
        let _ = max_order;
        Err(TaylorError::Option(
            "the model has no Taylor kernels".into(),
        ))
    }
}
