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
//! # impl Field<f64, 2> for Osc { fn field(&self, x: &[f64; 2], dx: &mut [f64; 2]) { dx[0] = x[1]; dx[1] = -x[0]; } }
//! # impl Invariants<f64, 2, 1> for Osc {
//! #     fn invariants(&self, x: &[f64; 2], f: &mut [f64; 1]) { f[0] = 0.5 * (x[0] * x[0] + x[1] * x[1]); }
//! #     fn invariants_jacobian(&self, x: &[f64; 2], j: &mut [[f64; 2]; 1]) { j[0] = [x[0], x[1]]; }
//! # }
//! # impl Lyapunov<f64, 2, 1, 1> for Osc {
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

use std::cell::Cell;

use num_traits::Float;

use crate::field::{Field, Invariants, Lyapunov, ModelInfo};

/// The feedback field ẋ = X(x) − ∇V(x) of a model (Chang et al. 2016, eqs. (3), (11)), with
/// the target f(x₀) and the G gains.
///
/// The gains sit in a [`Cell`] so that a stepper wrapper (e.g. [`crate::AdaptiveGain`]) can
/// change them between steps through a shared reference.
#[derive(Debug)]
pub struct FeedbackField<'a, Mdl: ?Sized, T: Copy, const N: usize, const M: usize, const G: usize> {
    model: &'a Mdl,
    target: [T; M],
    gains: Cell<[T; G]>,
}

impl<'a, Mdl, T, const N: usize, const M: usize, const G: usize> FeedbackField<'a, Mdl, T, N, M, G>
where
    Mdl: Lyapunov<T, N, M, G> + ?Sized,
    T: Float,
{
    /// The feedback field with a given target f(x₀) and gains.
    pub fn new(model: &'a Mdl, target: [T; M], gains: [T; G]) -> Self {
        FeedbackField {
            model,
            target,
            gains: Cell::new(gains),
        }
    }

    /// The feedback field for the initial point `x0`: the target is f(x₀) computed with
    /// [`Invariants::invariants`].
    pub fn from_initial(model: &'a Mdl, x0: &[T; N], gains: [T; G]) -> Self {
        let mut target = [T::zero(); M];
        model.invariants(x0, &mut target);
        Self::new(model, target, gains)
    }

    /// The wrapped model.
    pub fn model(&self) -> &'a Mdl {
        self.model
    }

    /// The target f(x₀).
    pub fn target(&self) -> &[T; M] {
        &self.target
    }

    /// The current gains.
    pub fn gains(&self) -> [T; G] {
        self.gains.get()
    }

    /// Replaces the gains (takes effect at the next field evaluation).
    pub fn set_gains(&self, gains: [T; G]) {
        self.gains.set(gains)
    }

    /// V(x) with the current target and gains.
    pub fn lyapunov(&self, x: &[T; N]) -> T {
        self.model.lyapunov(x, &self.target, &self.gains.get())
    }
}

impl<Mdl, T, const N: usize, const M: usize, const G: usize> Field<T, N>
    for FeedbackField<'_, Mdl, T, N, M, G>
where
    Mdl: Lyapunov<T, N, M, G> + ?Sized,
    T: Float,
{
    /// ẋ = X(x) − ∇V(x) via [`Lyapunov::feedback_field`].
    #[inline]
    fn field(&self, x: &[T; N], dx: &mut [T; N]) {
        self.model
            .feedback_field(x, &self.target, &self.gains.get(), dx)
    }
}

/// The invariants of the wrapped model, so that e.g. a [`crate::Projection`] or a
/// [`crate::Recorder`] can be used with the feedback field directly.
impl<Mdl, T, const N: usize, const M: usize, const G: usize> Invariants<T, N, M>
    for FeedbackField<'_, Mdl, T, N, M, G>
where
    Mdl: Lyapunov<T, N, M, G> + ?Sized,
    T: Float,
{
    fn invariants(&self, x: &[T; N], f: &mut [T; M]) {
        self.model.invariants(x, f)
    }

    fn invariants_jacobian(&self, x: &[T; N], jac: &mut [[T; N]; M]) {
        self.model.invariants_jacobian(x, jac)
    }
}

/// Expands the G gains into the diagonal of K ∈ R^{M×M}: component c of invariant i gets
/// `gains[Mdl::INVARIANTS[i].gain]` (components not covered by a declared invariant get 0).
pub fn expand_gains<Mdl, T, const G: usize, const M: usize>(gains: &[T; G]) -> [T; M]
where
    Mdl: ModelInfo + ?Sized,
    T: Float,
{
    let mut k = [T::zero(); M];
    for info in Mdl::INVARIANTS {
        for c in info.slot.range() {
            if c < M && info.gain < G {
                k[c] = gains[info.gain];
            }
        }
    }
    k
}

/// The gradient of the default Lyapunov function V = ½ ΔfᵀKΔf, ∇V = Df(x)ᵀ K (f(x) − f(x₀))
/// (Chang et al. 2016, eq. (10)), computed from [`Invariants`] and the gain layout of
/// [`ModelInfo`] — a reference to check generated gradients against, or to implement
/// [`Lyapunov`] by hand. Returns V.
pub fn default_lyapunov_gradient<Mdl, T, const N: usize, const M: usize, const G: usize>(
    model: &Mdl,
    x: &[T; N],
    target: &[T; M],
    gains: &[T; G],
    grad: &mut [T; N],
) -> T
where
    Mdl: Invariants<T, N, M> + ModelInfo + ?Sized,
    T: Float,
{
    let k = expand_gains::<Mdl, T, G, M>(gains);
    let mut f = [T::zero(); M];
    let mut jac = [[T::zero(); N]; M];
    model.invariants(x, &mut f);
    model.invariants_jacobian(x, &mut jac);
    *grad = [T::zero(); N];
    let mut v = T::zero();
    let half = T::one() / (T::one() + T::one());
    for i in 0..M {
        let d = f[i] - target[i];
        let kd = k[i] * d;
        v = v + half * kd * d;
        if kd != T::zero() {
            for n in 0..N {
                grad[n] = grad[n] + jac[i][n] * kd;
            }
        }
    }
    v
}
