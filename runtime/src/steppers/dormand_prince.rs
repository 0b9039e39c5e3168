//! The adaptive Dormand–Prince 5(4) stepper ("DOPRI5", the analogue of MATLAB's `ode45`).
//!
//! Follows Hairer–Nørsett–Wanner, *Solving ODEs I*, 2nd ed. (HNW I):
//! - the pair of Dormand & Prince (1980), HNW I §II.5 Table 5.2 ([`Tableau::dormand_prince54`]),
//!   propagating the 5th-order solution, with the FSAL property (the last stage of a step is the
//!   first of the next);
//! - the error norm `err = √(1/N Σᵢ (eᵢ/skᵢ)²)`, `skᵢ = atol + rtol·max(|x₀ᵢ|, |x₁ᵢ|)`
//!   (HNW I §II.4, eq. (4.11));
//! - the step size controller `h_new = h·min(facmax, max(facmin, fac·err^{−α}·err_old^{β}))`
//!   with `fac = 0.9`, `α = 1/5 − 0.75β`, `β = 0.04` (the PI / "Lund-stabilised" controller of
//!   Hairer's code `dopri5.f`, HNW I §II.4 eq. (4.13) and §IV.2; `β = 0` gives the standard
//!   controller `h·(1/err)^{1/5}`), and `h_new ≤ h` right after a rejection;
//! - the starting step size algorithm of HNW I §II.4 ("Starting step size", steps (a)–(f));
//! - the 4th-order continuous extension (dense output) of HNW I §II.6, eq. (6.12) and Table
//!   6.2 (coefficients of Shampine 1986 as used in `dopri5.f`'s `CONTD5`).

use num_traits::Float;

use super::{DenseOutput, StepOutcome, Stepper, Tableau};
use crate::error::{all_finite, state_to_vec, to_f64, StepError};
use crate::field::{lit, Field};
use crate::state::State;

/// The smallest relative tolerance [`DormandPrince`] accepts: ten unit roundoffs, 10·u with
/// u = ε/2 the unit roundoff of `T` (1.1·10⁻¹⁵ for f64).
///
/// The error estimate h Σ (bᵢ − b̂ᵢ) kᵢ is a difference of stages each rounded to about u|x|:
/// below a few u the estimate is rounding, not truncation, no step passes it, and the
/// controller shrinks the step until the run crawls (a harmonic oscillator at rtol = 10⁻³⁰
/// takes steps of 10⁻¹⁴). Hairer's codes refuse the same tolerances (`RTOL ≤ 10·UROUND`:
/// "TOLERANCES ARE TOO SMALL", RADAU5 and SEULEX of Hairer & Wanner, *Solving ODEs II*).
pub fn rtol_floor<T: Float>() -> T {
    lit::<T>(5.0) * T::epsilon()
}

/// Tolerances and controller parameters of [`DormandPrince`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DormandPrinceOptions<T> {
    /// Relative tolerance (default `1e-6`); at least [`rtol_floor`] (a smaller one fails the
    /// first step with [`StepError::InvalidInput`]).
    pub rtol: T,
    /// Absolute tolerance (default `1e-9`; positive).
    pub atol: T,
    /// Safety factor `fac` of the controller (default `0.9`).
    pub safety: T,
    /// Smallest step size ratio `h_new/h` (default `0.2`).
    pub fac_min: T,
    /// Largest step size ratio `h_new/h` (default `10`).
    pub fac_max: T,
    /// Exponent `β` of the PI controller (default `0.04`, as in `dopri5.f`; `0` = standard
    /// controller).
    pub beta: T,
    /// Largest step size (default `+∞`).
    pub h_max: T,
    /// Smallest step size; a smaller step is an error (default `0`, i.e. only the round-off
    /// limit `10·ε·|t|`, ten ulps of t, applies — `dopri5.f`'s `0.1|h| ≤ UROUND·|x|` — and at
    /// t = 0 the smallest normal number).
    pub h_min: T,
    /// Consecutive rejections allowed within one step before giving up (default `50`).
    pub max_rejections: u32,
}

impl<T: Float> Default for DormandPrinceOptions<T> {
    fn default() -> Self {
        DormandPrinceOptions {
            rtol: lit(1e-6),
            atol: lit(1e-9),
            safety: lit(0.9),
            fac_min: lit(0.2),
            fac_max: lit(10.0),
            beta: lit(0.04),
            h_max: T::infinity(),
            h_min: T::zero(),
            max_rejections: 50,
        }
    }
}

/// Dense output coefficients `d_i` of DOPRI5 (HNW I, §II.6; `dopri5.f`).
const DENSE: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

/// Adaptive Dormand–Prince 5(4) with error control, FSAL and dense output.
///
/// ```
/// use lasalle_runtime::{Field, DormandPrince, DormandPrinceOptions, DenseOutput, Driver, Control};
/// struct Decay;
/// impl Field<f64, [f64; 1]> for Decay {
///     fn field(&self, x: &[f64; 1], dx: &mut [f64; 1]) { dx[0] = -x[0]; }
/// }
/// let mut dp = DormandPrince::<f64, [f64; 1]>::new(DormandPrinceOptions { rtol: 1e-10, atol: 1e-12, ..Default::default() });
/// let times = [0.5, 1.0, 2.0];
/// let mut out = Vec::new();
/// // h = 0: automatic initial step; the observer sees the interpolated state at each output time
/// Driver::new(0.0, 2.0, 0.0)
///     .run_dense(&mut dp, &Decay, &[1.0], &times, &mut |_i: u64, t: f64, x: &[f64; 1]| {
///         out.push((t, x[0]));
///         Control::Continue
///     })
///     .unwrap();
/// for (t, x) in out { assert!((x - (-t).exp()).abs() < 1e-9); }
/// ```
#[derive(Clone, Debug)]
pub struct DormandPrince<T, X> {
    opts: DormandPrinceOptions<T>,
    a: [[T; 7]; 7],
    b: [T; 7],
    /// `b − b̂`: the error estimate is `h Σ e_i k_i`.
    e: [T; 7],
    d: [T; 7],
    /// State-sized storage, allocated when the stepper first sees a state.
    work: Option<Work<X>>,
    fsal_valid: bool,
    fac_old: T,
    last_rejected: bool,
    t_old: T,
    h_old: T,
    has_dense: bool,
}

/// The state-sized storage of [`DormandPrince`].
#[derive(Clone, Debug)]
struct Work<X> {
    /// `k₁ = X(x)` for `x == x_last` when `fsal_valid`; the stages k₁…k₇.
    k: [X; 7],
    x_last: X,
    y: X,
    y_new: X,
    /// Dense output coefficients r₁…r₅ of the last accepted step.
    dense: [X; 5],
}

impl<X: Clone> Work<X> {
    fn new(zero: X) -> Self {
        Work {
            k: std::array::from_fn(|_| zero.clone()),
            x_last: zero.clone(),
            y: zero.clone(),
            y_new: zero.clone(),
            dense: std::array::from_fn(|_| zero.clone()),
        }
    }
}

impl<T: Float, X: State<T>> DormandPrince<T, X> {
    /// A stepper with the given options.
    pub fn new(opts: DormandPrinceOptions<T>) -> Self {
        let tab = Tableau::dormand_prince54();
        let b_hat = tab.b_hat.expect("DOPRI5 has an embedded method");
        let mut e = [T::zero(); 7];
        for i in 0..7 {
            e[i] = lit(tab.b[i] - b_hat[i]);
        }
        DormandPrince {
            opts,
            a: tab.a.map(|row| row.map(lit)),
            b: tab.b.map(lit),
            e,
            d: DENSE.map(lit),
            work: None,
            fsal_valid: false,
            fac_old: lit(1e-4),
            last_rejected: false,
            t_old: T::zero(),
            h_old: T::zero(),
            has_dense: false,
        }
    }

    /// A stepper with `rtol` and `atol` and default controller parameters.
    pub fn with_tolerances(rtol: T, atol: T) -> Self {
        Self::new(DormandPrinceOptions {
            rtol,
            atol,
            ..Default::default()
        })
    }

    /// The options in use.
    pub fn options(&self) -> &DormandPrinceOptions<T> {
        &self.opts
    }

    /// Checks the tolerances: a relative tolerance at least [`rtol_floor`], a positive
    /// absolute one.
    pub fn check_tolerances(rtol: T, atol: T) -> Result<(), StepError> {
        let floor = rtol_floor::<T>();
        if !(rtol >= floor && rtol.is_finite() && atol > T::zero() && atol.is_finite()) {
            return Err(StepError::InvalidInput(format!(
                "dopri5: need rtol ≥ {:e} (ten unit roundoffs: below it the error estimate \
                 is rounding and no step passes it) and atol > 0, got rtol = {:e}, atol = {:e}",
                to_f64(floor),
                to_f64(rtol),
                to_f64(atol)
            )));
        }
        Ok(())
    }

    /// RMS norm of `v` scaled by `atol + rtol·|x|` (HNW I, eq. (4.11) with one state).
    fn scaled_norm(&self, v: &[T], x: &[T]) -> T {
        let mut s = T::zero();
        for (vi, xi) in v.iter().zip(x) {
            let sk = self.opts.atol + self.opts.rtol * xi.abs();
            let r = *vi / sk;
            s = s + r * r;
        }
        (s / lit(x.len().max(1) as f64)).sqrt()
    }

    /// The work storage, (re)allocated for states of `x`'s length.
    fn work(&mut self, x: &X) -> &mut Work<X> {
        let n = x.len();
        if !matches!(&self.work, Some(w) if w.y.len() == n) {
            self.fsal_valid = false;
            self.work = Some(Work::new(X::filled(X::len_for(n), T::zero())));
        }
        self.work.as_mut().expect("allocated above")
    }

    fn ensure_k1<F: Field<T, X> + ?Sized>(
        &mut self,
        field: &F,
        t: T,
        x: &X,
        h: T,
    ) -> Result<u32, StepError> {
        let fsal_valid = self.fsal_valid;
        let w = self.work(x);
        if fsal_valid && w.x_last == *x {
            return Ok(0);
        }
        field.field(x, &mut w.k[0]);
        if !all_finite(w.k[0].as_ref()) {
            self.fsal_valid = false;
            return Err(StepError::non_finite("field", t, h, x.as_ref()));
        }
        w.x_last.clone_from(x);
        self.fsal_valid = true;
        Ok(1)
    }
}

impl<T: Float, X: State<T>> Default for DormandPrince<T, X> {
    fn default() -> Self {
        Self::new(DormandPrinceOptions::default())
    }
}

impl<T: Float, X: State<T>, F: Field<T, X> + ?Sized> Stepper<T, X, F> for DormandPrince<T, X> {
    fn step(&mut self, field: &F, t: T, x: &mut X, h: T) -> Result<StepOutcome<T>, StepError> {
        if !(h > T::zero() && h.is_finite()) {
            return Err(StepError::InvalidInput(format!(
                "dopri5: step size must be positive and finite, got h = {}",
                to_f64(h)
            )));
        }
        let o = self.opts;
        Self::check_tolerances(o.rtol, o.atol)?;
        let mut evaluations = self.ensure_k1(field, t, x, h)?;
        let mut h = h.min(o.h_max);
        let mut rejections = 0u32;
        let ten = lit::<T>(10.0);
        let expo1 = lit::<T>(0.2) - lit::<T>(0.75) * o.beta;
        let n_dim = x.len();
        let w = self.work.as_mut().expect("allocated by ensure_k1");
        loop {
            let h_min = o
                .h_min
                .max(ten * T::epsilon() * t.abs())
                .max(T::min_positive_value());
            if h < h_min {
                return Err(StepError::StepSizeTooSmall {
                    t: to_f64(t),
                    h: to_f64(h),
                    h_min: to_f64(h_min),
                    state: state_to_vec(x.as_ref()),
                });
            }
            // stages 2..6
            for i in 1..6 {
                w.y.clone_from(x);
                for j in 0..i {
                    let hc = h * self.a[i][j];
                    for (yn, kn) in w.y.as_mut().iter_mut().zip(w.k[j].as_ref()) {
                        *yn = *yn + hc * *kn;
                    }
                }
                field.field(&w.y, &mut w.k[i]);
            }
            // 5th-order solution (a₇ⱼ = bⱼ, b₇ = 0) and the FSAL stage k₇ = X(x_{n+1})
            w.y_new.clone_from(x);
            for j in 0..6 {
                let hc = h * self.b[j];
                for (yn, kn) in w.y_new.as_mut().iter_mut().zip(w.k[j].as_ref()) {
                    *yn = *yn + hc * *kn;
                }
            }
            field.field(&w.y_new, &mut w.k[6]);
            evaluations += 6;
            // error estimate h Σ (bᵢ − b̂ᵢ) kᵢ in the norm (4.11); slices of length n_dim, so
            // the loops below index them without bounds checks
            let k: [&[T]; 7] = std::array::from_fn(|j| &w.k[j].as_ref()[..n_dim]);
            let (x_old, y_new) = (&x.as_ref()[..n_dim], &w.y_new.as_ref()[..n_dim]);
            let mut s = T::zero();
            for n in 0..n_dim {
                let mut en = T::zero();
                for j in 0..7 {
                    en = en + self.e[j] * k[j][n];
                }
                en = en * h;
                let sk = o.atol + o.rtol * x_old[n].abs().max(y_new[n].abs());
                let r = en / sk;
                s = s + r * r;
            }
            let err = (s / lit(n_dim.max(1) as f64)).sqrt();
            let accepted = err.is_finite() && err <= T::one() && all_finite(y_new);
            if accepted {
                let fac11 = err.powf(expo1);
                let fac = (fac11 / self.fac_old.powf(o.beta) / o.safety)
                    .max(T::one() / o.fac_max)
                    .min(T::one() / o.fac_min);
                let mut h_new = h / fac;
                self.fac_old = err.max(lit(1e-4));
                if self.last_rejected {
                    h_new = h_new.min(h);
                }
                self.last_rejected = false;
                // dense output (HNW I §II.6; dopri5.f)
                let [d0, d1, d2, d3, d4] = w.dense.each_mut().map(|d| &mut d.as_mut()[..n_dim]);
                for n in 0..n_dim {
                    let ydiff = y_new[n] - x_old[n];
                    let bspl = h * k[0][n] - ydiff;
                    d0[n] = x_old[n];
                    d1[n] = ydiff;
                    d2[n] = bspl;
                    d3[n] = ydiff - h * k[6][n] - bspl;
                    let mut dk = T::zero();
                    for j in 0..7 {
                        dk = dk + self.d[j] * k[j][n];
                    }
                    d4[n] = h * dk;
                }
                self.t_old = t;
                self.h_old = h;
                self.has_dense = true;
                x.clone_from(&w.y_new);
                w.k.swap(0, 6);
                w.x_last.clone_from(&w.y_new);
                self.fsal_valid = all_finite(w.k[0].as_ref());
                return Ok(StepOutcome {
                    h_taken: h,
                    h_next: h_new.min(o.h_max),
                    rejections,
                    evaluations,
                });
            }
            rejections += 1;
            self.last_rejected = true;
            if rejections > o.max_rejections {
                return Err(StepError::TooManyRejections {
                    t: to_f64(t),
                    h: to_f64(h),
                    rejections,
                    state: state_to_vec(x.as_ref()),
                });
            }
            h = if err.is_finite() {
                h / (T::one() / o.fac_min).min(err.powf(expo1) / o.safety)
            } else {
                h * o.fac_min
            };
        }
    }

    fn order(&self) -> u32 {
        5
    }

    fn name(&self) -> String {
        "dopri5".to_string()
    }

    fn dense_output(&self) -> Option<&dyn DenseOutput<T, X>> {
        Some(self)
    }

    fn is_adaptive(&self) -> bool {
        true
    }

    /// HNW I, §II.4, "Starting step size" (a)–(f) with p = 4 (exponent 1/(p+1) = 1/5).
    fn initial_step(&mut self, field: &F, t0: T, x0: &X, t_end: T) -> Option<T> {
        let n_dim = x0.len();
        let opts = self.opts;
        let span = (t_end - t0).abs();
        if Self::check_tolerances(opts.rtol, opts.atol).is_err() {
            // tolerances the first step refuses (with the reason): any step will do
            return Some(if span > T::zero() { span } else { T::one() });
        }
        let mut f0 = X::filled(X::len_for(n_dim), T::zero());
        field.field(x0, &mut f0);
        let d0 = self.scaled_norm(x0.as_ref(), x0.as_ref());
        let d1 = self.scaled_norm(f0.as_ref(), x0.as_ref());
        let small = lit::<T>(1e-5);
        let mut h0 = if d0 < small || d1 < small {
            lit(1e-6)
        } else {
            lit::<T>(0.01) * d0 / d1
        };
        if span > T::zero() {
            h0 = h0.min(span);
        }
        h0 = h0.min(opts.h_max);
        let mut x1 = x0.clone();
        for n in 0..n_dim {
            x1[n] = x1[n] + h0 * f0[n];
        }
        let mut f1 = X::filled(X::len_for(n_dim), T::zero());
        field.field(&x1, &mut f1);
        for n in 0..n_dim {
            x1[n] = f1[n] - f0[n];
        }
        let d2 = self.scaled_norm(x1.as_ref(), x0.as_ref()) / h0;
        let dmax = d1.max(d2);
        let h1 = if !(dmax > lit(1e-15)) {
            lit::<T>(1e-6).max(h0 * lit(1e-3))
        } else {
            (lit::<T>(0.01) / dmax).powf(lit(0.2))
        };
        let mut h = (lit::<T>(100.0) * h0).min(h1).min(opts.h_max);
        if span > T::zero() {
            h = h.min(span);
        }
        if all_finite(f0.as_ref()) {
            let w = self.work(x0);
            w.k[0] = f0;
            w.x_last.clone_from(x0);
            self.fsal_valid = true;
        }
        (h > T::zero() && h.is_finite()).then_some(h)
    }

    fn reset(&mut self) {
        self.fsal_valid = false;
        self.last_rejected = false;
        self.fac_old = lit(1e-4);
    }
}

impl<T: Float, X: State<T>> DenseOutput<T, X> for DormandPrince<T, X> {
    fn dense_interval(&self) -> Option<(T, T)> {
        self.has_dense
            .then(|| (self.t_old, self.t_old + self.h_old))
    }

    /// `x(t_old + θh) ≈ r₁ + θ(r₂ + (1−θ)(r₃ + θ(r₄ + (1−θ) r₅)))` (`dopri5.f`, `CONTD5`).
    fn interpolate(&self, t: T, out: &mut X) -> bool {
        let Some(w) = self.work.as_ref().filter(|_| self.has_dense) else {
            return false;
        };
        let theta = (t - self.t_old) / self.h_old;
        let slack = lit::<T>(1e-9);
        if !(theta >= -slack && theta <= T::one() + slack) {
            return false;
        }
        let theta1 = T::one() - theta;
        let r = &w.dense;
        for n in 0..out.len() {
            out[n] = r[0][n]
                + theta * (r[1][n] + theta1 * (r[2][n] + theta * (r[3][n] + theta1 * r[4][n])));
        }
        true
    }

    /// [`interpolate`](DenseOutput::interpolate) at each time, the step's data looked up once
    /// and the times' θ computed first (their divisions overlap).
    fn interpolate_many(&self, ts: &[T], outs: &mut [X]) -> bool {
        let Some(w) = self.work.as_ref().filter(|_| self.has_dense) else {
            return false;
        };
        const TIMES: usize = 4;
        let slack = lit::<T>(1e-9);
        let r = &w.dense;
        let mut ok = true;
        for (ts, outs) in ts.chunks(TIMES).zip(outs.chunks_mut(TIMES)) {
            let mut thetas = [T::zero(); TIMES];
            for (theta, &t) in thetas.iter_mut().zip(ts) {
                *theta = (t - self.t_old) / self.h_old;
            }
            for (out, &theta) in outs.iter_mut().zip(&thetas) {
                if !(theta >= -slack && theta <= T::one() + slack) {
                    ok = false;
                    continue;
                }
                let theta1 = T::one() - theta;
                for n in 0..out.len() {
                    out[n] = r[0][n]
                        + theta
                            * (r[1][n] + theta1 * (r[2][n] + theta * (r[3][n] + theta1 * r[4][n])));
                }
            }
        }
        ok
    }
}
