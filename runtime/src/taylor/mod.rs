//! The adaptive Taylor integrator (Jorba & Zou 2005; as heyoka's `taylor_adaptive`), generic
//! over where the Taylor coefficients come from.
//!
//! # Split: a driver and coefficient kernels
//!
//! A Taylor step has two parts:
//! - the **coefficients** x^\[0..=p\] of the solution through the current state, by the
//!   automatic-differentiation recurrences of the field's operations ([`TaylorKernel`]);
//! - the **driver** ([`Taylor`]): the order from the tolerance, Jorba & Zou's step from the
//!   last two coefficients, the new state by Horner's scheme, the dense output from the same
//!   polynomial, the choice between the field X and the feedback field X − ∇V, and the
//!   [`Stepper`] and [`DenseOutput`] implementations.
//!
//! The driver is written once, here; a kernel exists per kind of model:
//! - `lasalle_exec::jit::taylor::JitTaylor` compiles the recurrences of a loaded model's tape
//!   with Cranelift for the order p, unrolled (the default for models loaded with the JIT
//!   back end), and `lasalle_exec::TaylorTape` interprets them (the interpreter back end, and
//!   programs too large to unroll);
//! - the emitted Rust of a compiled model has the recurrences of each field as straight-line
//!   code per tape instruction inside a loop over the order ([`Recurrences`], implemented by
//!   `kernels::FieldRecurrences` and `kernels::FeedbackRecurrences` of the model's module),
//!   and one generic kernel, [`Emitted`], holds their table and inputs, allocated once
//!   (`kernels::TaylorField` is `Emitted<FieldRecurrences>`); the parameter-only values are
//!   the prepared model's (`kernels::Prelude`), copied at every [`TaylorKernel::sync`].
//!
//! All run the same lowering of the tape into recurrences (`lasalle_model::tape::taylor`)
//! and the same recurrence functions ([`rec`]; the JIT emits their operations), in the same
//! order, so they agree bitwise.
//!
//! One name per thing, across the crates: the **program** is `TaylorProgram`
//! (`lasalle_model::tape::taylor`, the recurrences of one field tape); the **driver**
//! [`Taylor`], its [`TaylorOptions`], the kernel interface [`TaylorKernel`] and the one
//! **error** [`TaylorError`] (an invalid option, or kernels a back end cannot build) are this
//! module's, and every back end returns them; each **back end** is a module of its own:
//! `lasalle_codegen`'s `emit::taylor` (the emitted [`Recurrences`]), `lasalle_exec::taylor`
//! (the interpreter, `TaylorTape`) and `lasalle_exec::jit::taylor` (`JitTaylor`,
//! `DeferredJit`).
//! The kernel behind a driver is a `Box<dyn TaylorKernel<M>>`: one virtual call per step
//! (the step itself costs about p²/2 field evaluations), and one driver type per model type.
//!
//! # Taylor coefficients by automatic differentiation
//!
//! For ẋ = X(x), the normalised Taylor coefficients x^\[k\] = x⁽ᵏ⁾(t₀)/k! of the solution through
//! x(t₀) = x₀ follow from x^\[0\] = x₀ and
//!
//! ```text
//! x^[k+1] = X(x)^[k] / (k + 1),
//! ```
//!
//! where X(x)^\[k\] is the k-th coefficient of the composite function t ↦ X(x(t)), computed
//! instruction by instruction along the field's tape from the coefficients 0..=k of the
//! instruction's operands (Moore 1966; Griewank & Walther, *Evaluating Derivatives*, 2nd ed.,
//! ch. 13; Jorba & Zou 2005). With a, b the operands and u the result of an instruction (all
//! normalised coefficients, k ≥ 1; the order-0 value is the instruction's own f64 operation,
//! so order 0 is the tape's value):
//!
//! | op | recurrence |
//! | --- | --- |
//! | u = a ± b | u^\[k\] = a^\[k\] ± b^\[k\] |
//! | u = a·b | u^\[k\] = Σ_{j=0}^{k} a^\[j\] b^\[k−j\] (Cauchy product; a·c for a constant c is a scaling; summed with the newest terms last, see [`rec::mul`]) |
//! | u = a/b | u^\[k\] = (a^\[k\] − Σ_{j=1}^{k} b^\[j\] u^\[k−j\]) / b^\[0\] |
//! | u = aⁿ, n ∈ ℕ | binary exponentiation by Cauchy products (squares and products, as `f64::powi`), so a^\[0\] = 0 is fine |
//! | u = a⁻ⁿ | the chain for aⁿ, then 1/aⁿ by the division recurrence |
//! | u = a^α (Powf, ∛) | u^\[k\] = 1/(k a^\[0\]) Σ_{j=0}^{k−1} (α(k−j) − j) a^\[k−j\] u^\[j\] (from a u' = α a' u) |
//! | u = C·s^β from √s, `powi` and c/· (μ/r³ with r = √s) | above order 0 by the power recurrence on s alone, where cheaper than the chain's own recurrences (*fused powers*, `lasalle_model::tape::taylor`); order 0 is the chain's |
//! | u = √a | u^\[k\] = (a^\[k\] − Σ_{j=1}^{k−1} u^\[j\] u^\[k−j\]) / (2 u^\[0\]) (from u² = a) |
//! | u = eᵃ | u^\[k\] = (1/k) Σ_{j=1}^{k} j a^\[j\] u^\[k−j\] (from u' = a' u) |
//! | u = ln a | u^\[k\] = (a^\[k\] − (1/k) Σ_{j=1}^{k−1} j u^\[j\] a^\[k−j\]) / a^\[0\] (from a u' = a') |
//! | s = sin a, c = cos a | s^\[k\] = (1/k) Σ_{j=1}^{k} j a^\[j\] c^\[k−j\], c^\[k\] = −(1/k) Σ_{j=1}^{k} j a^\[j\] s^\[k−j\] |
//! | s, c, d = sn, cn, dn (a \| m), m constant | s^\[k\] = (1/k) Σ_{j=1}^{k} j a^\[j\] (cd)^\[k−j\], c^\[k\] = −(1/k) Σ j a^\[j\] (sd)^\[k−j\], d^\[k\] = −(m/k) Σ j a^\[j\] (sc)^\[k−j\]; the products cd, sd, sc by Cauchy products (from s′ = c d a′, c′ = −s d a′, d′ = −m s c a′) |
//! | u = F(a \| m), m constant | u^\[k\] = (1/k) Σ_{j=1}^{k} j a^\[j\] w^\[k−j\], w = (1 − m sin²a)^(−1/2) by the rows above |
//!
//! Leaves other than the state (constants, hoisted parameter values, targets, gains) and every
//! instruction whose operands are all such leaves are constant along the solution: only their
//! order-0 value is computed, their higher coefficients stay 0. Sine and cosine are always
//! computed together. A step to order p costs Σ_{k<p} O(k) per nonlinear instruction, i.e.
//! about p²/2 times a field evaluation.
//!
//! # Order and step size (Jorba & Zou 2005)
//!
//! Following Jorba & Zou, *A software package for the numerical integration of ODEs by means of
//! high-order Taylor methods*, Experimental Mathematics 14(1) (2005) 99–117 (their step size
//! and order control), with equal absolute and relative tolerances ε (as heyoka's
//! `taylor_adaptive` does):
//! - the order is p = ⌈−½ ln ε + 1⌉ (fixed for a given ε; 19 for ε = 10⁻¹⁵, 20 for the double
//!   precision ε ≈ 2.2·10⁻¹⁶), see [`order_for_tolerance`];
//! - with m = ‖x₀‖∞, the tolerance is absolute when m ≤ 1 and relative otherwise
//!   (ε_r m > ε_a ⇔ m > 1): the radius estimates are
//!   ρ_j = (c / ‖x^\[j\]‖∞)^{1/j}, c = 1 (absolute) or m (relative), for j = p − 1 and j = p,
//!   ρ = min(ρ_{p−1}, ρ_p);
//! - the step is h = ρ / e² · exp(−0.7/(p − 1)) (the `exp(−0.7/(p−1))` safety factor of
//!   Jorba & Zou, also used by heyoka).
//!
//! The last two terms of the series are then about ε c in size (for ρ the radius of
//! convergence of an analytic solution, ‖x^\[j\]‖ h^j ≈ (h/ρ)^j ≤ e^{−2j}): this is a heuristic
//! error control, not a bound. Steps are never rejected. The new state is the Taylor
//! polynomial evaluated at h by Horner's scheme, and the same polynomial is the dense output on
//! [t, t + h] ([`DenseOutput`]).
//!
//! Measured on Kepler (e = 0.8, 1000 periods), the drift of the invariants at ε = 10⁻¹⁵ is
//! truncation, not rounding: |ΔL| is 9.4·10⁻¹³ at ε = 10⁻¹⁵ (p = 19), 7.5·10⁻¹⁴ at 10⁻¹⁶
//! (p = 20) and 2·10⁻¹⁵ at 10⁻¹⁷ (p = 21) with almost the same steps, each order dividing it
//! by about e² as the step rule predicts ((h/ρ)^{p+1}). The step rule is heyoka's, whose error
//! on the same run is 1.8·10⁻¹². To keep invariants to 10⁻¹³ and below, take ε = 10⁻¹⁶, or the
//! split step ([`Taylor::set_split`]).
//!
//! The state update is compensated (Kahan): the increment Σ_{k≥1} x^\[k\] h^k is added to x
//! by an error-free transformation and the rounding carried to the next step. What the
//! invariants do not show, the phase does: without it the half ulp of rounding per step
//! random-walks the energy of a Kepler orbit by 2·10⁻¹⁴ over 1000 orbits, and the period with
//! it, so that the 1000th pericentre passage lands 1.4·10⁻¹⁰ off 2000π (e = 0.5, 40 steps an
//! orbit, whatever ε ≤ 10⁻¹⁵); with it, see `docs/events.md`.

use crate::error::StepError;
use crate::feedback::FeedbackField;
use crate::field::Lyapunov;
use crate::state::State;
use crate::steppers::{DenseOutput, StepOutcome, Stepper};

pub mod lanes;
pub use lanes::{LaneEnd, LaneRuns, TaylorBatch, TaylorLanes};

/// The largest order of the emitted kernels of compiled models (their coefficient table has
/// this many + 1 columns). Jorba & Zou's order is 20 at the f64 precision, so this bounds the
/// tolerance only far below what f64 can reach.
pub const EMITTED_MAX_ORDER: usize = 32;

/// The recurrences of one field of a compiled model, emitted as straight-line Rust by the
/// generator (`kernels::FieldRecurrences`, `kernels::FeedbackRecurrences` of the model's
/// module): the sizes, the parameter-only values and the coefficient recurrences. [`Emitted`]
/// turns them into a [`TaylorKernel`]; the emitted code holds only what differs per field.
pub trait Recurrences<M: ?Sized> {
    /// The kernel's name, for messages.
    const NAME: &'static str;
    /// The state dimension N.
    const DIM: usize;
    /// Rows of the coefficient table (the tape's registers).
    const ROWS: usize;
    /// Parameter-only values the recurrences read.
    const HOISTED: usize;
    /// Targets f(x₀) (0 for the plain field).
    const TARGETS: usize;
    /// Gains (0 for the plain field).
    const GAINS: usize;

    /// The parameter-only values (`HOISTED`, the tape's prelude), as the prepared model holds
    /// them.
    fn hoisted(model: &M) -> &[f64];

    /// Fills the coefficients of orders 0..=`order` (≤ [`EMITTED_MAX_ORDER`]) of every row
    /// (`ROWS` rows) for the state `x`; row i < N is component i of the solution.
    fn compute(
        t: &mut [[f64; EMITTED_MAX_ORDER + 1]],
        hoisted: &[f64],
        target: &[f64],
        gains: &[f64],
        x: &[f64],
        order: usize,
    );
}

/// The [`TaylorKernel`] of emitted [`Recurrences`]: the coefficient table and the inputs,
/// allocated once (`Emitted::<FieldRecurrences>::new(&prepared)`; the generator names it
/// `kernels::TaylorField` and `kernels::TaylorFeedback`).
pub struct Emitted<R> {
    hoisted: Box<[f64]>,
    target: Box<[f64]>,
    gains: Box<[f64]>,
    t: Box<[[f64; EMITTED_MAX_ORDER + 1]]>,
    order: usize,
    recurrences: std::marker::PhantomData<fn() -> R>,
}

impl<R> Emitted<R> {
    /// The kernel with the parameter-only values of `model`; targets and gains 0.
    pub fn new<M: ?Sized>(model: &M) -> Self
    where
        R: Recurrences<M>,
    {
        Emitted {
            hoisted: R::hoisted(model).into(),
            target: vec![0.0; R::TARGETS].into_boxed_slice(),
            gains: vec![0.0; R::GAINS].into_boxed_slice(),
            t: vec![[0.0; EMITTED_MAX_ORDER + 1]; R::ROWS].into_boxed_slice(),
            order: 0,
            recurrences: std::marker::PhantomData,
        }
    }
}

impl<M: ?Sized, R: Recurrences<M>> TaylorKernel<M> for Emitted<R> {
    fn dim(&self) -> usize {
        R::DIM
    }

    fn max_order(&self) -> usize {
        EMITTED_MAX_ORDER
    }

    fn sync(&mut self, model: &M) -> Result<(), StepError> {
        self.hoisted.copy_from_slice(R::hoisted(model));
        Ok(())
    }

    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        if target.len() != R::TARGETS || gains.len() != R::GAINS {
            return Err(StepError::InvalidInput(format!(
                "{} takes {} targets and {} gains, got {} and {}",
                R::NAME,
                R::TARGETS,
                R::GAINS,
                target.len(),
                gains.len()
            )));
        }
        self.target.copy_from_slice(target);
        self.gains.copy_from_slice(gains);
        Ok(())
    }

    fn compute(&mut self, x: &[f64], order: usize) {
        self.order = order.min(EMITTED_MAX_ORDER);
        R::compute(
            &mut self.t,
            &self.hoisted,
            &self.target,
            &self.gains,
            x,
            self.order,
        );
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        &self.t[i][..=self.order]
    }
}

/// What can go wrong setting up a Taylor integrator, whatever its kernels (emitted,
/// interpreted or compiled at run time): the one error type of the Taylor method.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TaylorError {
    /// An invalid option (tolerance, order or largest step), or one the kernels cannot serve
    /// (an order above theirs, a model without kernels).
    #[error("invalid Taylor option: {0}")]
    Option(String),
    /// The kernels could not be built: the back end's error as it is (a malformed tape, a
    /// program the JIT could not compile).
    #[error(transparent)]
    Kernels(Box<dyn std::error::Error + Send + Sync>),
}

impl TaylorError {
    /// [`TaylorError::Kernels`] from a back end's error.
    pub fn kernels(e: impl Into<Box<dyn std::error::Error + Send + Sync>>) -> TaylorError {
        TaylorError::Kernels(e.into())
    }
}

/// The Taylor coefficients of the solution of one field, for [`Taylor`].
///
/// `compute` fills, for a state x, the normalised coefficients x^\[0..=order\] of the solution
/// through x (x^\[0\] = x); `coefficients(i)` reads component i's. A kernel allocates nothing
/// after construction. `M` is the model the kernel belongs to: [`TaylorKernel::sync`] reads
/// its parameters.
pub trait TaylorKernel<M: ?Sized>: Send {
    /// The state dimension N.
    fn dim(&self) -> usize;

    /// The largest order [`TaylorKernel::compute`] accepts.
    fn max_order(&self) -> usize;

    /// Brings the parameter-dependent values (the tape's prelude) up to date with `model`'s
    /// parameters; cheap when they did not change. Called before every step.
    fn sync(&mut self, model: &M) -> Result<(), StepError>;

    /// Sets the targets f(x₀) and the gains of a feedback field X − ∇V (a plain field reads
    /// none and accepts empty slices). No allocation.
    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError>;

    /// Computes x^\[0..=order\] of the solution through `x` (`x.len() == dim()`,
    /// `order ≤ max_order()`).
    fn compute(&mut self, x: &[f64], order: usize);

    /// Component i's coefficients x_i^\[0..=order\] from the last [`TaylorKernel::compute`].
    fn coefficients(&self, i: usize) -> &[f64];
}

/// Jorba & Zou's order for a tolerance ε: p = ⌈−½ ln ε + 1⌉ (at least 2).
///
/// 19 for ε = 10⁻¹⁵, 20 for `f64::EPSILON`, 11 for 10⁻⁸.
pub fn order_for_tolerance(tol: f64) -> u32 {
    let p = (-0.5 * tol.ln() + 1.0).ceil();
    if p.is_finite() {
        p.clamp(2.0, 1000.0) as u32
    } else {
        2
    }
}

/// Jorba & Zou's step size (see the [module docs](self)) from the state norm m = ‖x^\[0\]‖∞ and
/// the norms of the last two coefficients, ‖x^\[p−1\]‖∞ and ‖x^\[p\]‖∞. `+∞` if both norms are 0
/// (a polynomial solution of degree < p − 1: any step is exact). [`JorbaZou`] keeps the
/// order's constants for repeated use.
pub fn jorba_zou_step(order: u32, state_norm: f64, norm_pm1: f64, norm_p: f64) -> f64 {
    JorbaZou::new(order).step(state_norm, norm_pm1, norm_p)
}

/// Jorba & Zou's step size for one order p, with its constants 1/(p − 1), 1/p and the
/// safety factor exp(−0.7/(p − 1))/e² computed once (the driver calls [`JorbaZou::step`]
/// every step: two `powf` remain).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JorbaZou {
    inv_pm1: f64,
    inv_p: f64,
    factor: f64,
}

impl JorbaZou {
    /// The constants of order `order` (at least 2).
    pub fn new(order: u32) -> JorbaZou {
        let p = f64::from(order.max(2));
        let e2 = std::f64::consts::E * std::f64::consts::E;
        JorbaZou {
            inv_pm1: 1.0 / (p - 1.0),
            inv_p: 1.0 / p,
            factor: (-0.7 / (p - 1.0)).exp() / e2,
        }
    }

    /// The step from m = ‖x^\[0\]‖∞, ‖x^\[p−1\]‖∞ and ‖x^\[p\]‖∞ (see [`jorba_zou_step`]).
    #[inline]
    pub fn step(&self, state_norm: f64, norm_pm1: f64, norm_p: f64) -> f64 {
        let c = if state_norm > 1.0 { state_norm } else { 1.0 };
        let rho_pm1 = (c / norm_pm1).powf(self.inv_pm1);
        let rho_p = (c / norm_p).powf(self.inv_p);
        rho_pm1.min(rho_p) * self.factor
    }
}

/// The recurrences of the table in the [module docs](self), one function per operation: the
/// coefficient of order k ≥ 1 of the result, from rows of normalised coefficients (`a`, `b`
/// the operands, `u` the result's row with orders 0..k already filled).
///
/// Every kernel calls these, so that interpreted and emitted kernels round alike.
pub mod rec {
    /// Σ_{j=lo}^{hi} a^\[j\] b^\[k−j\].
    #[inline(always)]
    pub fn cauchy(a: &[f64], b: &[f64], k: usize, lo: usize, hi: usize) -> f64 {
        if lo > hi {
            return 0.0;
        }
        let ra = &a[lo..=hi];
        let rb = &b[k - hi..=k - lo];
        ra.iter().zip(rb.iter().rev()).map(|(x, y)| x * y).sum()
    }

    /// [`cauchy`] of G pairs of rows (a, b) of an emitted kernel's table `t` at once: the sums
    /// Σ_{j=lo}^{hi} t\[a\]\[j\] t\[b\]\[k−j\], each accumulated alone in the order of
    /// [`cauchy`] (so bitwise its results), in one loop over j (the early sums of
    /// `lasalle_model::tape::taylor`).
    ///
    /// # Panics
    /// If k > [`EMITTED_MAX_ORDER`](super::EMITTED_MAX_ORDER), hi ≥ k or a row is not in `t`.
    #[inline(always)]
    pub fn cauchy_many<const R: usize, const G: usize>(
        t: &[[f64; super::EMITTED_MAX_ORDER + 1]; R],
        rows: [(usize, usize); G],
        k: usize,
        lo: usize,
        hi: usize,
    ) -> [f64; G] {
        assert!(
            k <= super::EMITTED_MAX_ORDER && hi < k.max(1),
            "order {k}, terms {lo}..={hi}"
        );
        // `Sum` of f64 starts from −0.0 (−0.0 + t = t exactly); no terms: 0.0 as in `cauchy`
        let mut acc = [if lo > hi { 0.0 } else { -0.0 }; G];
        for j in lo..=hi {
            for (s, &(a, b)) in acc.iter_mut().zip(&rows) {
                *s += t[a][j] * t[b][k - j];
            }
        }
        acc
    }

    /// Σ_{j=1}^{k} j a^\[j\] b^\[k−j\] (the weighted product of the exp and sin/cos recurrences).
    #[inline(always)]
    fn weighted(a: &[f64], b: &[f64], k: usize) -> f64 {
        let ra = &a[1..=k];
        let rb = &b[..k];
        ra.iter()
            .zip(rb.iter().rev())
            .enumerate()
            .map(|(j, (x, y))| (j + 1) as f64 * x * y)
            .sum()
    }

    /// (a·b)^\[k\]: the Cauchy product, summed as
    /// (Σ_{j=1}^{k−1} a^\[j\] b^\[k−j\] + a^\[0\] b^\[k\]) + a^\[k\] b^\[0\].
    ///
    /// The order of summation puts the two terms with the newest coefficients (a^\[k\], b^\[k\],
    /// computed just before at this order) last: the k − 1 older terms do not wait for them,
    /// so the latency a step adds to the chain of dependent instructions is two additions,
    /// not k (the same holds for [`square`] and [`pow`]; [`div`], [`sqrt`] and the weighted
    /// sums already end with their newest term).
    #[inline(always)]
    pub fn mul(a: &[f64], b: &[f64], k: usize) -> f64 {
        if k == 0 {
            return a[0] * b[0];
        }
        mul_after(cauchy(a, b, k, 1, k - 1), a, b, k)
    }

    /// [`mul`] at k ≥ 1 from its early sum s = Σ_{j=1}^{k−1} a^\[j\] b^\[k−j\].
    #[inline(always)]
    pub fn mul_after(s: f64, a: &[f64], b: &[f64], k: usize) -> f64 {
        s + a[0] * b[k] + a[k] * b[0]
    }

    /// (a²)^\[k\] = 2 (Σ_{j=1}^{(k−1)/2} a^\[j\] a^\[k−j\] + a^\[0\] a^\[k\]) (+ a^\[k/2\]² for even
    /// k), the newest term last as in [`mul`].
    #[inline(always)]
    pub fn square(a: &[f64], k: usize) -> f64 {
        let half = (k - 1) / 2; // the largest j < k/2
        square_after(cauchy(a, a, k, 1, half), a, k)
    }

    /// [`square`] from its early sum s = Σ_{j=1}^{(k−1)/2} a^\[j\] a^\[k−j\].
    #[inline(always)]
    pub fn square_after(s: f64, a: &[f64], k: usize) -> f64 {
        let mut s = 2.0 * (s + a[0] * a[k]);
        if k % 2 == 0 {
            s += a[k / 2] * a[k / 2];
        }
        s
    }

    /// (a/b)^\[k\] = (a^\[k\] − Σ_{j=1}^{k} b^\[j\] u^\[k−j\]) / b^\[0\].
    #[inline(always)]
    pub fn div(a: &[f64], b: &[f64], u: &[f64], k: usize) -> f64 {
        (a[k] - cauchy(b, u, k, 1, k)) / b[0]
    }

    /// (a^α)^\[k\] = 1/(k a^\[0\]) Σ_{j=0}^{k−1} (α(k−j) − j) a^\[k−j\] u^\[j\], summed over
    /// j = 1..k−1 first and the term j = 0 (with the newest a^\[k\]) last, as in [`mul`].
    #[inline(always)]
    pub fn pow(a: &[f64], u: &[f64], alpha: f64, k: usize) -> f64 {
        let kf = k as f64;
        let s: f64 = (1..k)
            .map(|j| (alpha * (kf - j as f64) - j as f64) * a[k - j] * u[j])
            .sum();
        (s + alpha * kf * a[k] * u[0]) / (kf * a[0])
    }

    /// (√a)^\[k\] = (a^\[k\] − Σ_{j=1}^{k−1} u^\[j\] u^\[k−j\]) / (2 u^\[0\]), the sum folded in half.
    #[inline(always)]
    pub fn sqrt(a: &[f64], u: &[f64], k: usize) -> f64 {
        let half = (k - 1) / 2; // the largest j < k/2
        sqrt_after(cauchy(u, u, k, 1, half), a, u, k)
    }

    /// [`sqrt`] from its early sum s = Σ_{j=1}^{(k−1)/2} u^\[j\] u^\[k−j\] (unused for k = 1).
    #[inline(always)]
    pub fn sqrt_after(s: f64, a: &[f64], u: &[f64], k: usize) -> f64 {
        let mut s2 = 0.0;
        if k >= 2 {
            s2 = 2.0 * s;
            if k % 2 == 0 {
                s2 += u[k / 2] * u[k / 2];
            }
        }
        (a[k] - s2) / (2.0 * u[0])
    }

    /// (eᵃ)^\[k\] = (1/k) Σ_{j=1}^{k} j a^\[j\] u^\[k−j\].
    #[inline(always)]
    pub fn exp(a: &[f64], u: &[f64], k: usize) -> f64 {
        weighted(a, u, k) / k as f64
    }

    /// (ln a)^\[k\] = (a^\[k\] − (1/k) Σ_{j=1}^{k−1} j u^\[j\] a^\[k−j\]) / a^\[0\].
    #[inline(always)]
    pub fn ln(a: &[f64], u: &[f64], k: usize) -> f64 {
        let s = if k >= 2 {
            let ru = &u[1..k];
            let ra = &a[1..k];
            ru.iter()
                .zip(ra.iter().rev())
                .enumerate()
                .map(|(j, (u, x))| (j + 1) as f64 * u * x)
                .sum()
        } else {
            0.0
        };
        (a[k] - s / k as f64) / a[0]
    }

    /// ((sin a)^\[k\], (cos a)^\[k\]) from the rows `s`, `c` of sin a and cos a.
    #[inline(always)]
    pub fn sin_cos(a: &[f64], s: &[f64], c: &[f64], k: usize) -> (f64, f64) {
        let kf = k as f64;
        (weighted(a, c, k) / kf, -weighted(a, s, k) / kf)
    }

    /// u^\[k\] for u′ = w a′: (1/k) Σ_{j=1}^{k} j a^\[j\] w^\[k−j\] (F(φ | m) with w its
    /// derivative 1/√(1 − m sin²φ)).
    #[inline(always)]
    pub fn chain(a: &[f64], w: &[f64], k: usize) -> f64 {
        weighted(a, w, k) / k as f64
    }

    /// ((sn a)^\[k\], (cn a)^\[k\], (dn a)^\[k\]) for the parameter m (constant), from the rows
    /// of the products cn·dn, sn·dn, sn·cn: s′ = c d a′, c′ = −s d a′, d′ = −m s c a′.
    #[inline(always)]
    pub fn jacobi(
        a: &[f64],
        cd: &[f64],
        sd: &[f64],
        sc: &[f64],
        m: f64,
        k: usize,
    ) -> (f64, f64, f64) {
        let kf = k as f64;
        (
            weighted(a, cd, k) / kf,
            -weighted(a, sd, k) / kf,
            -m * weighted(a, sc, k) / kf,
        )
    }
}

/// The smallest tolerance ε [`Taylor`] accepts: u² = 2⁻¹⁰⁶ ≈ 1.2·10⁻³², u = 2⁻⁵³ the unit
/// roundoff (Jorba & Zou's order for it is 38).
///
/// Unlike an embedded Runge–Kutta pair, the Taylor method's tolerance is not compared with a
/// rounded error estimate: it sets the order and the step (the last two terms of the series
/// about ε), so tolerances below u are meaningful — the compensated update carries the state
/// as the pair x + (its rounding error), about u² of it, and ε = 10⁻¹⁷ still removes
/// truncation error (module docs). Below u² the extra orders buy nothing that pair can hold,
/// and far below it (p beyond about 170 for an entire solution, whose coefficients
/// 1/k! underflow) the step rule sees vanishing coefficients and takes unbounded steps.
pub const TOL_FLOOR: f64 = f64::EPSILON * f64::EPSILON / 4.0;

/// Jorba & Zou's three norms of an expansion of order p: the largest |x^\[0\]|, |x^\[p−1\]|
/// and |x^\[p\]| over the `dim` components, `coefficients(i)` those of component i.
fn norms<'a>(dim: usize, p: usize, coefficients: impl Fn(usize) -> &'a [f64]) -> (f64, f64, f64) {
    let (mut n0, mut n1, mut n2) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..dim {
        let c = coefficients(i);
        n0 = n0.max(c[0].abs());
        n1 = n1.max(c[p - 1].abs());
        n2 = n2.max(c[p].abs());
    }
    (n0, n1, n2)
}

/// x ← x + Σ_{k≥1} x^\[k\] h^k by Horner's scheme, eight components at a time (their
/// multiply-add chains interleaved), added by a two-sum whose rounding error `low` carries to
/// the next step (see [`Taylor`]'s compensated update); `coefficients(i)` are component i's.
fn horner_update<'a>(
    coefficients: impl Fn(usize) -> &'a [f64],
    h: f64,
    x: &mut [f64],
    low: &mut [f64],
) {
    const LANES: usize = 8;
    for (chunk, (outs, lows)) in x.chunks_mut(LANES).zip(low.chunks_mut(LANES)).enumerate() {
        let mut c: [&[f64]; LANES] = [&[]; LANES];
        for (l, cl) in c.iter_mut().enumerate().take(outs.len()) {
            *cl = coefficients(chunk * LANES + l);
        }
        let mut acc = [0.0; LANES];
        for k in (1..c[0].len()).rev() {
            for (a, cl) in acc.iter_mut().zip(&c).take(outs.len()) {
                *a = *a * h + cl[k];
            }
        }
        for ((xi, lo), a) in outs.iter_mut().zip(lows.iter_mut()).zip(acc) {
            // two-sum of x and (increment + carried error)
            let y = a * h + *lo;
            let s = *xi + y;
            let b = s - *xi;
            *lo = (*xi - (s - b)) + (y - b);
            *xi = s;
        }
    }
}

/// The smallest step [`Taylor`] takes at time t: ten ulps of t (ten machine epsilons times
/// |t|, as DOPRI5's), at t = 0 the smallest normal number. A Jorba–Zou step below it (the
/// radius of convergence shrinking to zero: a collision, a finite escape time) ends the run
/// with [`StepError::StepSizeTooSmall`].
pub fn min_step(t: f64) -> f64 {
    (10.0 * f64::EPSILON * t.abs()).max(f64::MIN_POSITIVE)
}

/// Options of [`Taylor`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaylorOptions {
    /// The tolerance ε, absolute for ‖x‖∞ ≤ 1 and relative above (default `1e-15`; in
    /// [[`TOL_FLOOR`], 1)).
    pub tol: f64,
    /// The order p; `None` (default) for Jorba & Zou's ⌈−½ ln ε + 1⌉.
    pub order: Option<u32>,
    /// The largest step (default `+∞`).
    pub h_max: f64,
}

impl Default for TaylorOptions {
    fn default() -> Self {
        TaylorOptions {
            tol: 1e-15,
            order: None,
            h_max: f64::INFINITY,
        }
    }
}

impl TaylorOptions {
    /// The defaults with tolerance `tol`.
    pub fn with_tol(tol: f64) -> Self {
        TaylorOptions {
            tol,
            ..Default::default()
        }
    }

    /// The order these options ask for, after checking them.
    pub fn checked_order(&self) -> Result<u32, TaylorError> {
        if !(self.tol >= TOL_FLOOR && self.tol < 1.0) {
            return Err(TaylorError::Option(format!(
                "the tolerance must lie in [{TOL_FLOOR:.2e}, 1), got {:e} (the floor is u², u the \
                 unit roundoff: the compensated state holds no more)",
                self.tol
            )));
        }
        if self.h_max.is_nan() || self.h_max <= 0.0 {
            return Err(TaylorError::Option(format!(
                "h_max must be positive, got {}",
                self.h_max
            )));
        }
        let order = self.order.unwrap_or_else(|| order_for_tolerance(self.tol));
        if !(2..=1000).contains(&order) {
            return Err(TaylorError::Option(format!(
                "the order must lie in 2..=1000, got {order}"
            )));
        }
        Ok(order)
    }
}

/// Which field [`Taylor`] integrates as a `Stepper<f64, X, M>` (with the model itself as the
/// field argument).
#[derive(Clone, Debug, PartialEq)]
pub enum TaylorField {
    /// The model's field X.
    Plain,
    /// The feedback field X − ∇V with the target f(x₀) (M values) and the gains.
    Feedback {
        /// f(x₀).
        target: Vec<f64>,
        /// The gains, one per declared gain.
        gains: Vec<f64>,
    },
}

/// Which kernel holds the last step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Which {
    Field,
    Feedback,
}

/// A model's two Taylor kernels: its field X and its feedback field X − ∇V.
pub struct TaylorKernels<M: ?Sized> {
    /// The kernel of X.
    pub field: Box<dyn TaylorKernel<M>>,
    /// The kernel of X − ∇V (reads targets and gains).
    pub feedback: Box<dyn TaylorKernel<M>>,
}

/// Adaptive Taylor integrator (Jorba & Zou 2005; heyoka) of a model's field X and feedback
/// field X − ∇V, over the model's [`TaylorKernel`]s; see the [module docs](self).
///
/// - `Stepper<f64, X, M>`: integrates X, or X − ∇V with the stepper's own target and gains
///   ([`Taylor::set_field`]); never allocates in a step.
/// - `Stepper<f64, X, FeedbackField<M, FV, G>>`: integrates X − ∇V with the feedback field's
///   target and current gains (read every step; [`FeedbackField::gains`] hands out a copy,
///   an allocation per step for `Vec` gains, none for arrays).
///
/// The model passed to `step` must be the one the kernels were made for; a change of its
/// parameters is picked up at the next step ([`TaylorKernel::sync`]).
pub struct Taylor<M: ?Sized> {
    opts: TaylorOptions,
    order: u32,
    control: JorbaZou,
    field: Box<dyn TaylorKernel<M>>,
    feedback: Box<dyn TaylorKernel<M>>,
    mode: TaylorField,
    /// With a [`FeedbackField`]: the split step (a step of X, then a gradient step on V)
    /// instead of the Taylor step of X − ∇V; see [`Taylor::set_split`].
    split: bool,
    /// −1 where the stepper integrates the time-reversed field −X of its kernels' X
    /// ([`Taylor::set_reversed`]), else 1.
    direction: f64,
    /// The last accepted step (t, h) and the kernel holding its expansion.
    last: Option<(f64, f64, Which)>,
    /// The compensated state update: the first half holds what rounding took off each
    /// component of the state the last step returned, the second half that state (to
    /// recognise it at the next step).
    carry: Vec<f64>,
}

impl<M: ?Sized> std::fmt::Debug for Taylor<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Taylor")
            .field("opts", &self.opts)
            .field("order", &self.order)
            .field("mode", &self.mode)
            .field("last", &self.last)
            .finish_non_exhaustive()
    }
}

impl<M: ?Sized> Taylor<M> {
    /// The integrator over `kernels` (mode [`TaylorField::Plain`]); fails on invalid options,
    /// an order above the kernels' largest, or kernels of different dimensions.
    pub fn new(kernels: TaylorKernels<M>, opts: TaylorOptions) -> Result<Taylor<M>, TaylorError> {
        let order = opts.checked_order()?;
        let TaylorKernels { field, feedback } = kernels;
        let max = field.max_order().min(feedback.max_order());
        if order as usize > max {
            return Err(TaylorError::Option(format!(
                "order {order} exceeds the kernels' largest order {max}"
            )));
        }
        if field.dim() != feedback.dim() {
            return Err(TaylorError::Option(
                "the field and feedback kernels have different state dimensions".into(),
            ));
        }
        Ok(Taylor {
            opts,
            order,
            control: JorbaZou::new(order),
            mode: TaylorField::Plain,
            split: false,
            direction: 1.0,
            last: None,
            carry: [vec![0.0; field.dim()], vec![f64::NAN; field.dim()]].concat(),
            field,
            feedback,
        })
    }

    /// Chooses the field of the `Stepper<f64, X, M>` implementation.
    pub fn set_field(&mut self, mode: TaylorField) -> Result<(), StepError> {
        if let TaylorField::Feedback { target, gains } = &mode {
            self.feedback.set_inputs(target, gains)?;
        }
        self.mode = mode;
        self.last = None;
        Ok(())
    }

    /// [`Taylor::set_field`] returning `self`.
    pub fn with_field(mut self, mode: TaylorField) -> Result<Taylor<M>, StepError> {
        self.set_field(mode)?;
        Ok(self)
    }

    /// Chooses the step of the `Stepper<f64, X, FeedbackField<M, FV, G>>` implementation:
    /// `false` (default) the Taylor step of X − ∇V; `true` the **split step**, the Lie
    /// splitting of ẋ = X − ∇V into ẋ = X and ẋ = −∇V:
    ///
    /// ```text
    /// x̃ = Taylor step of X from x over h (the plain kernel, Jorba–Zou's h),
    /// x⁺ = x̃ − h ∇V(x̃)            (one explicit Euler step of the gradient flow)
    /// ```
    ///
    /// with the feedback field's target and current gains K. Near the invariant set
    /// ∇V(x) = Df(x)ᵀ K (f(x) − f(x₀)) is O(drift), so the gradient step costs one gradient
    /// evaluation and perturbs the solution only by the drift it removes; its Jacobian is
    /// I − h H, H = Dfᵀ K Df there, whose eigenvalues lie in [1 − θ, 1] for θ = h ‖H‖₂: a
    /// contraction for 0 < θ < 2. The gains of `--gains auto` (adaptive methods: h k L = θ
    /// with θ = 2·tol^(1/p)·… ≈ 0.3, `lasalle_runtime::gains::step_gain_target`) keep θ there
    /// at every step. The splitting error is O(h²)·[X, ∇V], and [X, ∇V] = H X vanishes on the
    /// invariant set (Df X = 0), so it is O(h² · drift). The dense output on a step is the
    /// Taylor polynomial of X (without the gradient step, which moves the end point by
    /// h ∇V = O(h · drift)). The gradient is computed into a fresh `X` per step (no allocation
    /// for arrays; one for `Vec` states).
    pub fn set_split(&mut self, split: bool) {
        self.split = split;
        self.last = None;
    }

    /// Integrates the time-reversed field −X instead of X, from the same kernels: the
    /// solution of −X through x is x(−s), whose Taylor coefficients are (−1)ᵏ x⁽ᵏ⁾, so each
    /// step and each dense output evaluates the kernels' polynomial at −s. A backward run
    /// (t₁ < t₀) is a forward run of −X in s = t₀ − t.
    pub fn set_reversed(&mut self, reversed: bool) {
        self.direction = if reversed { -1.0 } else { 1.0 };
        self.last = None;
    }

    /// [`Taylor::set_split`] returning `self`.
    pub fn with_split(mut self, split: bool) -> Taylor<M> {
        self.set_split(split);
        self
    }

    /// The field integrated as a `Stepper<f64, X, M>`.
    pub fn field(&self) -> &TaylorField {
        &self.mode
    }

    /// The options.
    pub fn options(&self) -> TaylorOptions {
        self.opts
    }

    /// The kernel of the field X.
    pub fn field_kernel(&mut self) -> &mut dyn TaylorKernel<M> {
        &mut *self.field
    }

    /// The kernel of the feedback field X − ∇V.
    pub fn feedback_kernel(&mut self) -> &mut dyn TaylorKernel<M> {
        &mut *self.feedback
    }

    /// The coefficients x^\[0..=p\] of component `i` of the last accepted step's expansion
    /// (about its initial point), if there was one.
    pub fn last_coefficients(&self, i: usize) -> Option<&[f64]> {
        let (_, _, which) = self.last?;
        Some(self.kernel(which).coefficients(i))
    }

    fn kernel(&self, which: Which) -> &dyn TaylorKernel<M> {
        match which {
            Which::Field => &*self.field,
            Which::Feedback => &*self.feedback,
        }
    }

    fn which(&self) -> Which {
        match self.mode {
            TaylorField::Plain => Which::Field,
            TaylorField::Feedback { .. } => Which::Feedback,
        }
    }

    /// Coefficients at `x` in kernel `which`, and Jorba–Zou's step.
    fn expand(&mut self, which: Which, x: &[f64]) -> f64 {
        let p = self.order as usize;
        let kernel = match which {
            Which::Field => &mut *self.field,
            Which::Feedback => &mut *self.feedback,
        };
        kernel.compute(x, p);
        let (n0, n1, n2) = norms(kernel.dim(), p, |i| kernel.coefficients(i));
        self.control.step(n0, n1, n2)
    }

    /// Horner's scheme for the polynomial of the last expansion in `which` at `s`, eight
    /// components at a time (their multiply-add chains interleaved: each is p dependent steps).
    fn evaluate(&self, which: Which, s: f64, out: &mut [f64]) {
        const LANES: usize = 8;
        let kernel = self.kernel(which);
        for (chunk, outs) in out.chunks_mut(LANES).enumerate() {
            let mut c: [&[f64]; LANES] = [&[]; LANES];
            for (l, cl) in c.iter_mut().enumerate().take(outs.len()) {
                *cl = kernel.coefficients(chunk * LANES + l);
            }
            let mut acc = [0.0; LANES];
            for k in (0..c[0].len()).rev() {
                for (a, cl) in acc.iter_mut().zip(&c).take(outs.len()) {
                    *a = *a * s + cl[k];
                }
            }
            outs.copy_from_slice(&acc[..outs.len()]);
        }
    }

    /// x ← x + Σ_{k≥1} x^[k] h^k with compensated summation: the increment by Horner's
    /// scheme (without the constant term), added to x by an error-free transformation whose
    /// rounding error is carried to the next step (Kahan). Without it the state's rounding,
    /// half an ulp per step, accumulates as a random walk that a Kepler orbit turns into a
    /// drift of its phase (1.4·10⁻¹⁰ after 1000 orbits at 40 steps an orbit); with it the
    /// state is the exact sum of the increments to about an ulp. The carried error applies
    /// only if x is the state the last step returned (bitwise); a state changed in between
    /// starts afresh.
    fn compensated_update(&mut self, which: Which, h: f64, x: &mut [f64]) {
        let n = x.len();
        if self.carry.len() != 2 * n || self.carry[n..] != *x {
            self.carry.clear();
            self.carry.resize(2 * n, 0.0);
        }
        let kernel = match which {
            Which::Field => &*self.field,
            Which::Feedback => &*self.feedback,
        };
        let (low, returned) = self.carry.split_at_mut(n);
        horner_update(|i| kernel.coefficients(i), h, x, low);
        returned.copy_from_slice(x);
    }

    fn check_dim(&self, x: &[f64]) -> Result<(), StepError> {
        let n = self.field.dim();
        if x.len() != n {
            return Err(StepError::InvalidInput(format!(
                "the state has {} components, the model {n}",
                x.len()
            )));
        }
        Ok(())
    }

    /// One step of at most `h` in kernel `which`.
    fn advance(
        &mut self,
        which: Which,
        t: f64,
        x: &mut [f64],
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        self.check_dim(x)?;
        if h.is_nan() || h <= 0.0 {
            return Err(StepError::InvalidInput(format!(
                "step size must be positive, got {h}"
            )));
        }
        let h_jz = self.expand(which, x);
        if h_jz.is_nan() {
            return Err(StepError::NonFinite {
                what: "field",
                t,
                step: 0,
                h,
                state: x.to_vec(),
            });
        }
        let h_own = h_jz.min(self.opts.h_max);
        let h_min = min_step(t);
        if h_own < h_min && h > h_own {
            return Err(StepError::StepSizeTooSmall {
                t,
                h: h_own,
                h_min,
                state: x.to_vec(),
            });
        }
        let h_taken = h.min(h_own);
        // Horner into x; the coefficients stay in the kernel for the dense output
        self.compensated_update(which, self.direction * h_taken, x);
        self.last = Some((t, h_taken, which));
        let h_next = if h_own.is_finite() { h_own } else { h };
        Ok(StepOutcome {
            h_taken,
            h_next,
            rejections: 0,
            evaluations: self.order,
        })
    }

    fn initial(&mut self, which: Which, t0: f64, x0: &[f64], t_end: f64) -> Option<f64> {
        self.check_dim(x0).ok()?;
        let h = self.expand(which, x0).min(self.opts.h_max);
        let span = t_end - t0;
        let h = if span > 0.0 { h.min(span) } else { h };
        (h > 0.0 && h.is_finite()).then_some(h)
    }

    /// Syncs both kernels with the model's parameters.
    fn sync(&mut self, model: &M) -> Result<(), StepError> {
        self.field.sync(model)?;
        self.feedback.sync(model)
    }
}

impl<M: ?Sized, X: State<f64>> Stepper<f64, X, M> for Taylor<M> {
    /// A Taylor step of the field chosen by [`Taylor::set_field`]: the Jorba–Zou step, or `h`
    /// if smaller. Never rejects; `evaluations` reports the order p (each order is one sweep
    /// of the recurrences).
    fn step(
        &mut self,
        model: &M,
        t: f64,
        x: &mut X,
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        self.sync(model)?;
        let which = self.which();
        self.advance(which, t, x.as_mut(), h)
    }

    fn order(&self) -> u32 {
        self.order
    }

    fn name(&self) -> String {
        format!("taylor({})", self.order)
    }

    fn dense_output(&self) -> Option<&dyn DenseOutput<f64, X>> {
        Some(self)
    }

    fn is_adaptive(&self) -> bool {
        true
    }

    fn initial_step(&mut self, model: &M, t0: f64, x0: &X, t_end: f64) -> Option<f64> {
        self.sync(model).ok()?;
        let which = self.which();
        self.initial(which, t0, x0.as_ref(), t_end)
    }

    fn reset(&mut self) {
        self.last = None;
        let n = self.carry.len() / 2;
        self.carry[n..].fill(f64::NAN);
    }
}

impl<M, X, FV, G> Stepper<f64, X, FeedbackField<'_, M, FV, G>> for Taylor<M>
where
    M: Lyapunov<f64, X, FV, G> + ?Sized,
    X: State<f64>,
    FV: State<f64>,
    G: State<f64>,
{
    /// A Taylor step of X − ∇V with the feedback field's target and current gains, or the
    /// split step ([`Taylor::set_split`]).
    fn step(
        &mut self,
        fb: &FeedbackField<'_, M, FV, G>,
        t: f64,
        x: &mut X,
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        self.sync(fb.model())?;
        if self.split {
            let out = self.advance(Which::Field, t, x.as_mut(), h)?;
            let mut grad = X::filled(X::len_for(x.len()), 0.0);
            fb.model()
                .lyapunov_gradient(x, fb.target(), &fb.gains(), &mut grad);
            for (xi, gi) in x.as_mut().iter_mut().zip(grad.as_ref()) {
                *xi -= out.h_taken * gi;
            }
            if !x.as_ref().iter().all(|v| v.is_finite()) {
                return Err(StepError::NonFinite {
                    what: "state",
                    t,
                    step: 0,
                    h: out.h_taken,
                    state: x.as_ref().to_vec(),
                });
            }
            return Ok(out);
        }
        self.feedback
            .set_inputs(fb.target().as_ref(), fb.gains().as_ref())?;
        self.advance(Which::Feedback, t, x.as_mut(), h)
    }

    fn order(&self) -> u32 {
        self.order
    }

    fn name(&self) -> String {
        format!("taylor({})", self.order)
    }

    fn dense_output(&self) -> Option<&dyn DenseOutput<f64, X>> {
        Some(self)
    }

    fn is_adaptive(&self) -> bool {
        true
    }

    fn initial_step(
        &mut self,
        fb: &FeedbackField<'_, M, FV, G>,
        t0: f64,
        x0: &X,
        t_end: f64,
    ) -> Option<f64> {
        self.sync(fb.model()).ok()?;
        if self.split {
            return self.initial(Which::Field, t0, x0.as_ref(), t_end);
        }
        self.feedback
            .set_inputs(fb.target().as_ref(), fb.gains().as_ref())
            .ok()?;
        self.initial(Which::Feedback, t0, x0.as_ref(), t_end)
    }

    fn reset(&mut self) {
        self.last = None;
        let n = self.carry.len() / 2;
        self.carry[n..].fill(f64::NAN);
    }
}

impl<M: ?Sized, X: State<f64>> DenseOutput<f64, X> for Taylor<M> {
    fn dense_interval(&self) -> Option<(f64, f64)> {
        self.last.map(|(t, h, _)| (t, t + h))
    }

    /// The Taylor polynomial of the last step at t − t_old, by Horner's scheme.
    fn interpolate(&self, t: f64, out: &mut X) -> bool {
        let Some((t0, h, which)) = self.last else {
            return false;
        };
        let s = t - t0;
        let slack = 1e-9 * h.abs().max(f64::MIN_POSITIVE);
        if !(s >= -slack && s <= h + slack) || out.len() != self.field.dim() {
            return false;
        }
        self.evaluate(which, self.direction * s, out.as_mut());
        true
    }

    /// The Taylor polynomial at up to four times per pass over its coefficients: the Horner
    /// recurrences of the times are independent, so they run interleaved, each rounding as
    /// [`interpolate`](DenseOutput::interpolate)'s.
    fn interpolate_many(&self, ts: &[f64], outs: &mut [X]) -> bool {
        let Some((t0, h, which)) = self.last else {
            return false;
        };
        let slack = 1e-9 * h.abs().max(f64::MIN_POSITIVE);
        let mut ok = true;
        for (ts, outs) in ts.chunks(TIMES).zip(outs.chunks_mut(TIMES)) {
            let mut s = [0.0; TIMES];
            for (sk, &t) in s.iter_mut().zip(ts) {
                *sk = t - t0;
            }
            let fits = |(sk, out): (&f64, &X)| {
                *sk >= -slack && *sk <= h + slack && out.len() == self.field.dim()
            };
            if !s.iter().zip(outs.iter()).all(fits) {
                ok = false;
                continue;
            }
            s.iter_mut().for_each(|sk| *sk *= self.direction);
            self.evaluate_many(which, &s[..ts.len()], outs);
        }
        ok
    }
}

/// The times [`Taylor`]'s `interpolate_many` evaluates together.
const TIMES: usize = 4;

impl<M: ?Sized> Taylor<M> {
    /// [`Taylor::evaluate`] at up to [`TIMES`] offsets `s` from the step's start, each into
    /// its `outs`: four components at a time, so that 16 independent Horner recurrences stay
    /// in registers (a missing component repeats the last row, its values dropped).
    fn evaluate_many<X: State<f64>>(&self, which: Which, s: &[f64], outs: &mut [X]) {
        const GROUP: usize = 4;
        let kernel = self.kernel(which);
        let n = self.field.dim();
        let mut times = [0.0; TIMES];
        times[..s.len()].copy_from_slice(s);
        for base in (0..n).step_by(GROUP) {
            let width = GROUP.min(n - base);
            let c: [&[f64]; GROUP] =
                std::array::from_fn(|l| kernel.coefficients(base + l.min(width - 1)));
            let len = c[0].len();
            if c.iter().any(|cl| cl.len() != len) {
                // rows of one length, as every kernel has them; else one time at a time
                for (out, &sr) in outs.iter_mut().zip(s) {
                    self.evaluate(which, sr, out.as_mut());
                }
                return;
            }
            let c = c.map(|cl| &cl[..len]);
            let mut acc = [[0.0; TIMES]; GROUP];
            for k in (0..len).rev() {
                for (accl, cl) in acc.iter_mut().zip(&c) {
                    let ck = cl[k];
                    for (a, &sr) in accl.iter_mut().zip(&times) {
                        *a = *a * sr + ck;
                    }
                }
            }
            for (r, out) in outs.iter_mut().enumerate().take(s.len()) {
                for (l, accl) in acc.iter().enumerate().take(width) {
                    out.as_mut()[base + l] = accl[r];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{rec, EMITTED_MAX_ORDER};

    /// `rec::cauchy_many` is `rec::cauchy` of each pair, bitwise, for every range of every
    /// order (empty ones included: +0.0, as `cauchy`).
    #[test]
    fn cauchy_many_is_cauchy_of_each_pair() {
        let mut t = [[0.0; EMITTED_MAX_ORDER + 1]; 3];
        for (r, row) in t.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                // values of mixed signs and magnitudes, so that the order of summation shows
                *c = ((r * 31 + j * 17) as f64).sin() * 10f64.powi((j % 7) as i32 - 3);
            }
        }
        let pairs = [(0, 1), (2, 2), (1, 0)];
        for k in 1..=EMITTED_MAX_ORDER {
            for (lo, hi) in [(1, k - 1), (1, (k - 1) / 2), (0, k - 1), (3, 2)] {
                if hi >= k {
                    continue;
                }
                let many = rec::cauchy_many(&t, pairs, k, lo, hi);
                for (&(a, b), s) in pairs.iter().zip(many) {
                    let one = rec::cauchy(&t[a], &t[b], k, lo, hi);
                    assert_eq!(
                        s.to_bits(),
                        one.to_bits(),
                        "k = {k}, {lo}..={hi}, ({a}, {b})"
                    );
                }
            }
        }
    }
}
