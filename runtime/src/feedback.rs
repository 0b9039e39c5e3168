//! Feedback integrators: the modified field ẋ = X(x) − ∇V(x) as an ordinary [`Field`].
//!
//! Chang, Jiménez & Perlmutter, *Feedback integrators*, J. Nonlinear Sci. 26 (2016), eqs. (3)
//! and (11): with f = (f₀, f₁, …, f_ℓ) the stacked constraints and first integrals and
//! V(x) = ½ (f(x) − f(x₀))ᵀ K (f(x) − f(x₀)) (eq. (10)), the set {f(x) = f(x₀)} attracts the
//! trajectories of X − ∇V, and any one-step method applied to it keeps the numerical solution
//! near that set (their Thm 5.2). [`FeedbackField`] wraps a model implementing [`Lyapunov`]
//! so that every [`Stepper`](crate::Stepper) becomes a feedback integrator:
//!
//! ```
//! # use lasalle_runtime::*;
//! # struct Osc;
//! # impl Field<f64, [f64; 2]> for Osc { fn field(&self, x: &[f64; 2], dx: &mut [f64; 2]) { dx[0] = x[1]; dx[1] = -x[0]; } }
//! # impl Invariants<f64, [f64; 2], [f64; 1]> for Osc {
//! #     fn invariants(&self, x: &[f64; 2], f: &mut [f64; 1]) { f[0] = 0.5 * (x[0] * x[0] + x[1] * x[1]); }
//! #     fn invariants_jacobian(&self, x: &[f64; 2], j: &mut [[f64; 2]; 1]) { j[0] = [x[0], x[1]]; }
//! # }
//! # impl Lyapunov<f64, [f64; 2], [f64; 1], [f64; 1]> for Osc {
//! #     fn lyapunov(&self, x: &[f64; 2], t: &[f64; 1], k: &[f64; 1]) -> f64 { let mut f = [0.0]; self.invariants(x, &mut f); 0.5 * k[0] * (f[0] - t[0]).powi(2) }
//! #     fn lyapunov_gradient(&self, x: &[f64; 2], t: &[f64; 1], k: &[f64; 1], g: &mut [f64; 2]) { let mut f = [0.0]; self.invariants(x, &mut f); let d = k[0] * (f[0] - t[0]); *g = [d * x[0], d * x[1]]; }
//! #     fn feedback_field(&self, x: &[f64; 2], t: &[f64; 1], k: &[f64; 1], dx: &mut [f64; 2]) { let mut g = [0.0; 2]; self.field(x, dx); self.lyapunov_gradient(x, t, k, &mut g); dx[0] -= g[0]; dx[1] -= g[1]; }
//! # }
//! let x0 = [1.0, 0.0];
//! let fb = FeedbackField::from_initial(&Osc, &x0, [10.0]);
//! let end = integrate(&mut ExplicitRk::euler(), &fb, &x0, 0.0, 100.0, 0.01, &mut ()).unwrap();
//! let energy = 0.5 * (end.x[0] * end.x[0] + end.x[1] * end.x[1]);
//! assert!((energy - 0.5).abs() < 1e-3); // plain Euler: energy grows by a factor e^{t h} ≈ 2.7
//! ```

use std::cell::{Cell, RefCell};

use num_traits::Float;

use crate::field::{Field, Invariants, Lyapunov, ModelInfo};
use crate::state::State;

/// The feedback field ẋ = X(x) − ∇V(x) of a model (Chang et al. 2016, eqs. (3), (11)), with
/// the target f(x₀) (storage `F`) and the G gains (storage `K`).
///
/// The gains sit in a [`RefCell`] so that a stepper wrapper (e.g. [`crate::AdaptiveGain`]) can
/// change them between steps through a shared reference. A wrapper that applies the feedback
/// after each step of the base method on X instead ([`crate::GainBound`]'s capped mode) turns
/// it off within the steps with [`FeedbackField::set_in_stages`].
#[derive(Debug)]
pub struct FeedbackField<'a, Mdl: ?Sized, F, K> {
    model: &'a Mdl,
    target: F,
    gains: RefCell<K>,
    in_stages: Cell<bool>,
}

impl<'a, Mdl: ?Sized, F, K: Clone> FeedbackField<'a, Mdl, F, K> {
    /// The feedback field with a given target f(x₀) and gains.
    pub fn new(model: &'a Mdl, target: F, gains: K) -> Self {
        FeedbackField {
            model,
            target,
            gains: RefCell::new(gains),
            in_stages: Cell::new(true),
        }
    }

    /// The feedback field for the initial point `x0`: the target is f(x₀) computed with
    /// [`Invariants::invariants`].
    pub fn from_initial<T: Float, X: State<T>>(model: &'a Mdl, x0: &X, gains: K) -> Self
    where
        Mdl: Lyapunov<T, X, F, K>,
        F: State<T>,
        K: State<T>,
    {
        let mut target = F::filled(F::len_for(model.invariant_dim()), T::zero());
        model.invariants(x0, &mut target);
        Self::new(model, target, gains)
    }

    /// The wrapped model.
    pub fn model(&self) -> &'a Mdl {
        self.model
    }

    /// The target f(x₀).
    pub fn target(&self) -> &F {
        &self.target
    }

    /// The current gains.
    pub fn gains(&self) -> K {
        self.gains.borrow().clone()
    }

    /// Replaces the gains (takes effect at the next field evaluation).
    pub fn set_gains(&self, gains: K) {
        *self.gains.borrow_mut() = gains;
    }

    /// Changes the gains in place (takes effect at the next field evaluation).
    pub fn update_gains<R>(&self, update: impl FnOnce(&mut K) -> R) -> R {
        update(&mut self.gains.borrow_mut())
    }

    /// Sets the gains to `unit · alpha` in place (no allocation; `unit` must have the length of
    /// the gains).
    pub fn set_scaled_gains<T: Float>(&self, unit: &K, alpha: T)
    where
        K: State<T>,
    {
        let mut gains = self.gains.borrow_mut();
        for (k, u) in gains.as_mut().iter_mut().zip(unit.as_ref()) {
            *k = *u * alpha;
        }
    }

    /// Whether [`Field::field`] is X − ∇V (true, the default) or X alone (false: the
    /// feedback is applied between steps by the stepper's wrapper).
    pub fn set_in_stages(&self, on: bool) {
        self.in_stages.set(on);
    }

    /// ∇V(x) with the current target and gains.
    pub fn lyapunov_gradient<T: Float, X: State<T>>(&self, x: &X, grad: &mut X)
    where
        Mdl: Lyapunov<T, X, F, K>,
        F: State<T>,
        K: State<T>,
    {
        self.model
            .lyapunov_gradient(x, &self.target, &self.gains.borrow(), grad)
    }

    /// V(x) with the current target and gains.
    pub fn lyapunov<T: Float, X: State<T>>(&self, x: &X) -> T
    where
        Mdl: Lyapunov<T, X, F, K>,
        F: State<T>,
        K: State<T>,
    {
        self.model.lyapunov(x, &self.target, &self.gains.borrow())
    }
}

impl<Mdl, T, X, F, K> Field<T, X> for FeedbackField<'_, Mdl, F, K>
where
    Mdl: Lyapunov<T, X, F, K> + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
    K: State<T>,
{
    /// ẋ = X(x) − ∇V(x) via [`Lyapunov::feedback_field`] (X(x) alone where the feedback is
    /// not in the stages: [`FeedbackField::set_in_stages`]).
    #[inline]
    fn field(&self, x: &X, dx: &mut X) {
        if self.in_stages.get() {
            self.model
                .feedback_field(x, &self.target, &self.gains.borrow(), dx)
        } else {
            self.model.field(x, dx)
        }
    }
}

/// The invariants of the wrapped model, so that e.g. a [`crate::Projection`] or a
/// [`crate::Recorder`] can be used with the feedback field directly.
impl<Mdl, T, X, F, K> Invariants<T, X, F> for FeedbackField<'_, Mdl, F, K>
where
    Mdl: Lyapunov<T, X, F, K> + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
    K: State<T>,
{
    fn invariant_dim(&self) -> usize {
        self.target.len()
    }

    fn invariants(&self, x: &X, f: &mut F) {
        self.model.invariants(x, f)
    }

    fn invariants_jacobian(&self, x: &X, jac: &mut F::Rows<X>) {
        self.model.invariants_jacobian(x, jac)
    }
}

/// The model's description, so a [`crate::Recorder`] of the feedback field names its blocks.
impl<Mdl: ModelInfo + ?Sized, F, K> ModelInfo for FeedbackField<'_, Mdl, F, K> {
    fn model_name(&self) -> &'static str {
        self.model.model_name()
    }
    fn state_slots(&self) -> &'static [crate::Slot] {
        self.model.state_slots()
    }
    fn invariant_infos(&self) -> &'static [crate::InvariantInfo] {
        self.model.invariant_infos()
    }
    fn gain_names(&self) -> &'static [&'static str] {
        self.model.gain_names()
    }
    fn default_gain_values(&self) -> &'static [f64] {
        self.model.default_gain_values()
    }
    fn param_slots(&self) -> &'static [crate::Slot] {
        self.model.param_slots()
    }
}

/// Expands the gains into the diagonal of K ∈ R^{M×M} (written into `k`, length M):
/// component c of invariant i gets `gains[model.invariant_infos()[i].gain]` (components not
/// covered by a declared invariant get 0).
pub fn expand_gains<Mdl, T>(model: &Mdl, gains: &[T], k: &mut [T])
where
    Mdl: ModelInfo + ?Sized,
    T: Float,
{
    k.iter_mut().for_each(|v| *v = T::zero());
    for info in model.invariant_infos() {
        for c in info.slot.range() {
            if c < k.len() && info.gain < gains.len() {
                k[c] = gains[info.gain];
            }
        }
    }
}

/// The gradient of the default Lyapunov function V = ½ ΔfᵀKΔf, ∇V = Df(x)ᵀ K (f(x) − f(x₀))
/// (Chang et al. 2016, eq. (10)), computed from [`Invariants`] and the gain layout of
/// [`ModelInfo`] — a reference to check generated gradients against, or to implement
/// [`Lyapunov`] by hand. Returns V. (Allocates its scratch: not for hot loops.)
pub fn default_lyapunov_gradient<Mdl, T, X, F>(
    model: &Mdl,
    x: &X,
    target: &F,
    gains: &[T],
    grad: &mut X,
) -> T
where
    Mdl: Invariants<T, X, F> + ModelInfo + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
{
    let (n, m) = (x.len(), target.len());
    let mut k = F::filled(F::len_for(m), T::zero());
    expand_gains(model, gains, k.as_mut());
    let mut f = F::filled(F::len_for(m), T::zero());
    let mut jac = F::rows(F::len_for(m), X::filled(X::len_for(n), T::zero()));
    model.invariants(x, &mut f);
    model.invariants_jacobian(x, &mut jac);
    grad.as_mut().iter_mut().for_each(|g| *g = T::zero());
    let mut v = T::zero();
    let half = T::one() / (T::one() + T::one());
    for i in 0..m {
        let d = f[i] - target[i];
        let kd = k[i] * d;
        v = v + half * kd * d;
        if kd != T::zero() {
            for c in 0..n {
                grad[c] = grad[c] + jac[i][c] * kd;
            }
        }
    }
    v
}
