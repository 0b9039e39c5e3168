//! Backward integration: a run from t₀ to t₀ + T with T < 0.
//!
//! Models are autonomous, so the solution backwards, x(t₀ − s) for s ∈ [0, |T|], is the
//! forward solution of the time-reversed field ẏ = −X(y). [`Backward`] is that model, built
//! from any model without code of its own; every method runs it forwards:
//!
//! - Runge–Kutta, DOPRI5 and projection steps see −X;
//! - feedback methods see −X − ∇V: the feedback still pulls towards the level set (reversing
//!   time does not reverse the damping term), so feedback integrators keep their meaning;
//! - Störmer–Verlet and the compositions see the partitioned halves −a(p), −b(q) (the flow of
//!   −H);
//! - the Taylor method steps with the model's own kernels, its polynomials evaluated at −s
//!   ([`BackwardTaylor`]): the coefficients of x(t₀ − s) are (−1)ᵏ x⁽ᵏ⁾.
//!
//! What has no time-reversed form is refused ([`refusal`]): the feedback Taylor methods
//! (their kernels compute X − ∇V, whose reversal −X + ∇V is not the backward feedback field)
//! and a model's structure-specific splitting. Events keep their direction in the model's
//! time: a crossing where g rises as t grows is reported as rising ([`Backward`] hands the
//! forward run −g). [`reverse`] turns the forward run's [`Recording`] back into the model's
//! times, s ↦ −s.

use std::cell::RefCell;

use lasalle_runtime::{
    Declared, DenseOutput, Field, GuardFailure, InvariantInfo, Invariants, Lyapunov, ModelInfo,
    Partitioned, Slot, State, StepError, StepOutcome, Stepper, Taylor,
};

use crate::{Method, Recording};

/// The time-reversed model ẏ = −X(y) of `M` (see the [module docs](self)).
pub(crate) struct Backward<'m, M: ?Sized, X> {
    model: &'m M,
    /// X(x) for the feedback field −X − ∇V.
    scratch: RefCell<X>,
}

impl<'m, M: ?Sized, X: State<f64>> Backward<'m, M, X> {
    /// The reversal of `model`, with states like `x0`.
    pub(crate) fn new(model: &'m M, x0: &X) -> Self {
        Backward {
            model,
            scratch: RefCell::new(x0.clone()),
        }
    }
}

/// Why `method` cannot integrate backwards, if it cannot.
pub(crate) fn refusal(method: Method) -> Option<String> {
    let why = match method {
        Method::Taylor { feedback: true } | Method::SplitTaylor => {
            "its kernels compute the feedback field X − ∇V, which has no time-reversed form \
             (use `taylor`, or `feedback-dopri5`)"
        }
        Method::Splitting => {
            "the model's splitting composes exact flows forward in time (use `symplectic4` or \
             another composition)"
        }
        _ => return None,
    };
    Some(format!(
        "method `{method}` cannot integrate backwards: {why}"
    ))
}

/// The forward run of the reversed model as the model's own backward run: times s ↦ −s (the
/// samples, the events, the failure), events and samples in the order the run met them.
pub(crate) fn reverse(mut rec: Recording) -> Recording {
    rec.t.iter_mut().for_each(|t| *t = -*t);
    for hit in rec.events.iter_mut().chain(rec.stopped_by.as_mut()) {
        hit.t = -hit.t;
    }
    rec.failure = rec.failure.map(StepError::reversed_in_time);
    rec
}

fn negate(x: &mut [f64]) {
    x.iter_mut().for_each(|v| *v = -*v);
}

impl<M: Field<f64, X> + ?Sized, X: State<f64>> Field<f64, X> for Backward<'_, M, X> {
    fn field(&self, x: &X, dx: &mut X) {
        self.model.field(x, dx);
        negate(dx.as_mut());
    }
}

impl<M, X, F> Invariants<f64, X, F> for Backward<'_, M, X>
where
    M: Invariants<f64, X, F> + ?Sized,
    X: State<f64>,
    F: State<f64>,
{
    fn invariant_dim(&self) -> usize {
        self.model.invariant_dim()
    }

    fn invariants(&self, x: &X, f: &mut F) {
        self.model.invariants(x, f);
    }

    fn invariants_jacobian(&self, x: &X, jac: &mut F::Rows<X>) {
        self.model.invariants_jacobian(x, jac);
    }
}

impl<M, X, F, K> Lyapunov<f64, X, F, K> for Backward<'_, M, X>
where
    M: Lyapunov<f64, X, F, K> + ?Sized,
    X: State<f64>,
    F: State<f64>,
    K: State<f64>,
{
    fn lyapunov(&self, x: &X, target: &F, gains: &K) -> f64 {
        self.model.lyapunov(x, target, gains)
    }

    fn lyapunov_gradient(&self, x: &X, target: &F, gains: &K, grad: &mut X) {
        self.model.lyapunov_gradient(x, target, gains, grad);
    }

    /// −X − ∇V.
    fn feedback_field(&self, x: &X, target: &F, gains: &K, dx: &mut X) {
        let mut field = self.scratch.borrow_mut();
        self.model.field(x, &mut field);
        self.model.lyapunov_gradient(x, target, gains, dx);
        for (d, f) in dx.as_mut().iter_mut().zip(field.as_ref()) {
            *d = -*f - *d;
        }
    }
}

impl<M: ModelInfo + ?Sized, X> ModelInfo for Backward<'_, M, X> {
    fn model_name(&self) -> &'static str {
        self.model.model_name()
    }

    fn state_slots(&self) -> &'static [Slot] {
        self.model.state_slots()
    }

    fn invariant_infos(&self) -> &'static [InvariantInfo] {
        self.model.invariant_infos()
    }

    fn gain_names(&self) -> &'static [&'static str] {
        self.model.gain_names()
    }

    fn default_gain_values(&self) -> &'static [f64] {
        self.model.default_gain_values()
    }

    fn param_slots(&self) -> &'static [Slot] {
        self.model.param_slots()
    }
}

impl<M, X> Partitioned<f64, X> for Backward<'_, M, X>
where
    M: Declared<f64, X> + Field<f64, X> + ?Sized,
    X: State<f64>,
{
    fn is_q(&self) -> &[bool] {
        self.model.partitioned().map_or(&[], |p| p.is_q())
    }

    fn field_q(&self, x: &X, dx: &mut X) {
        if let Some(p) = self.model.partitioned() {
            p.field_q(x, dx);
            negate(dx.as_mut());
        }
    }

    fn field_p(&self, x: &X, dx: &mut X) {
        if let Some(p) = self.model.partitioned() {
            p.field_p(x, dx);
            negate(dx.as_mut());
        }
    }
}

impl<M, X> Declared<f64, X> for Backward<'_, M, X>
where
    M: Declared<f64, X> + Field<f64, X>,
    X: State<f64>,
{
    fn presets(&self) -> &'static [lasalle_runtime::Preset] {
        self.model.presets()
    }

    fn check_guards(&self, x: &X, dt: f64) -> Option<GuardFailure> {
        self.model.check_guards(x, dt)
    }

    fn events(&self) -> &'static [lasalle_runtime::EventSpec] {
        self.model.events()
    }

    /// −g(x, −s): a crossing's direction as the model's time sees it.
    fn event_values(&self, x: &X, t: f64, g: &mut [f64]) {
        self.model.event_values(x, -t, g);
        negate(g);
    }

    fn partitioned(&self) -> Option<&dyn Partitioned<f64, X>> {
        self.model
            .partitioned()
            .map(|_| self as &dyn Partitioned<f64, X>)
    }
}

/// The Taylor method on the reversed model: the model's own Taylor stepper with its
/// polynomials evaluated at −s ([`Taylor::set_reversed`]), stepping the model itself.
pub(crate) struct BackwardTaylor<M: ?Sized>(pub(crate) Taylor<M>);

impl<M: ?Sized> BackwardTaylor<M> {
    /// `taylor`, reversed.
    pub(crate) fn new(mut taylor: Taylor<M>) -> Self {
        taylor.set_reversed(true);
        BackwardTaylor(taylor)
    }
}

impl<'m, M: ?Sized, X: State<f64>> Stepper<f64, X, Backward<'m, M, X>> for BackwardTaylor<M> {
    fn step(
        &mut self,
        field: &Backward<'m, M, X>,
        t: f64,
        x: &mut X,
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        self.0.step(field.model, t, x, h)
    }

    fn order(&self) -> u32 {
        Stepper::<f64, X, M>::order(&self.0)
    }

    fn name(&self) -> String {
        Stepper::<f64, X, M>::name(&self.0)
    }

    fn is_adaptive(&self) -> bool {
        true
    }

    fn initial_step(
        &mut self,
        field: &Backward<'m, M, X>,
        t0: f64,
        x0: &X,
        t_end: f64,
    ) -> Option<f64> {
        self.0.initial_step(field.model, t0, x0, t_end)
    }

    fn reset(&mut self) {
        Stepper::<f64, X, M>::reset(&mut self.0);
    }

    fn dense_output(&self) -> Option<&dyn DenseOutput<f64, X>> {
        Some(&self.0)
    }
}
