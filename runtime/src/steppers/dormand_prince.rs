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

/// Tolerances and controller parameters of [`DormandPrince`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DormandPrinceOptions<T> {
    /// Relative tolerance (default `1e-6`).
    pub rtol: T,
    /// Absolute tolerance (default `1e-9`).
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
    /// limit `10·ε·|t|` applies).
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
/// impl Field<f64, 1> for Decay {
///     fn field(&self, x: &[f64; 1], dx: &mut [f64; 1]) { dx[0] = -x[0]; }
/// }
/// let mut dp = DormandPrince::<f64, 1>::new(DormandPrinceOptions { rtol: 1e-10, atol: 1e-12, ..Default::default() });
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
pub struct DormandPrince<T, const N: usize> {
    opts: DormandPrinceOptions<T>,
    a: [[T; 7]; 7],
    b: [T; 7],
    /// `b − b̂`: the error estimate is `h Σ e_i k_i`.
    e: [T; 7],
    d: [T; 7],
    /// `k₁ = X(x)` for `x == x_last` when `fsal_valid`.
    k1: [T; N],
    x_last: [T; N],
    fsal_valid: bool,
    fac_old: T,
    last_rejected: bool,
    dense: [[T; N]; 5],
    t_old: T,
    h_old: T,
    has_dense: bool,
}

impl<T: Float, const N: usize> DormandPrince<T, N> {
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
            k1: [T::zero(); N],
            x_last: [T::zero(); N],
            fsal_valid: false,
            fac_old: lit(1e-4),
            last_rejected: false,
            dense: [[T::zero(); N]; 5],
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

    /// RMS norm of `v` scaled by `atol + rtol·|x|` (HNW I, eq. (4.11) with one state).
    fn scaled_norm(&self, v: &[T; N], x: &[T; N]) -> T {
        let mut s = T::zero();
        for i in 0..N {
            let sk = self.opts.atol + self.opts.rtol * x[i].abs();
            let r = v[i] / sk;
            s = s + r * r;
        }
        (s / lit(N.max(1) as f64)).sqrt()
    }

    fn ensure_k1<F: Field<T, N> + ?Sized>(
        &mut self,
        field: &F,
        t: T,
        x: &[T; N],
        h: T,
    ) -> Result<u32, StepError> {
        if self.fsal_valid && self.x_last == *x {
            return Ok(0);
        }
        field.field(x, &mut self.k1);
        if !all_finite(&self.k1) {
            self.fsal_valid = false;
            return Err(StepError::non_finite("field", t, h, x));
        }
        self.x_last = *x;
        self.fsal_valid = true;
        Ok(1)
    }
}

impl<T: Float, const N: usize> Default for DormandPrince<T, N> {
    fn default() -> Self {
        Self::new(DormandPrinceOptions::default())
    }
}

impl<T: Float, const N: usize, F: Field<T, N> + ?Sized> Stepper<T, N, F> for DormandPrince<T, N> {
    fn step(&mut self, field: &F, t: T, x: &mut [T; N], h: T) -> Result<StepOutcome<T>, StepError> {
        if !(h > T::zero() && h.is_finite()) {
            return Err(StepError::InvalidInput(format!(
                "dopri5: step size must be positive and finite, got h = {}",
                to_f64(h)
            )));
        }
        let mut evaluations = self.ensure_k1(field, t, x, h)?;
        let o = self.opts;
        let mut h = h.min(o.h_max);
        let mut rejections = 0u32;
        let ten = lit::<T>(10.0);
        let expo1 = lit::<T>(0.2) - lit::<T>(0.75) * o.beta;
        let mut k = [[T::zero(); N]; 7];
        k[0] = self.k1;
        loop {
            let h_min = o.h_min.max(ten * T::epsilon() * t.abs());
            if h < h_min {
                return Err(StepError::StepSizeTooSmall {
                    t: to_f64(t),
                    h: to_f64(h),
                    h_min: to_f64(h_min),
                    state: state_to_vec(x),
                });
            }
            // stages 2..6
            for i in 1..6 {
                let mut y = *x;
                for j in 0..i {
                    let hc = h * self.a[i][j];
                    for n in 0..N {
                        y[n] = y[n] + hc * k[j][n];
                    }
                }
                field.field(&y, &mut k[i]);
            }
            // 5th-order solution (a₇ⱼ = bⱼ, b₇ = 0) and the FSAL stage k₇ = X(x_{n+1})
            let mut y_new = *x;
            for j in 0..6 {
                let hc = h * self.b[j];
                for n in 0..N {
                    y_new[n] = y_new[n] + hc * k[j][n];
                }
            }
            field.field(&y_new, &mut k[6]);
            evaluations += 6;
            // error estimate h Σ (bᵢ − b̂ᵢ) kᵢ in the norm (4.11)
            let mut s = T::zero();
            for n in 0..N {
                let mut en = T::zero();
                for j in 0..7 {
                    en = en + self.e[j] * k[j][n];
                }
                en = en * h;
                let sk = o.atol + o.rtol * x[n].abs().max(y_new[n].abs());
                let r = en / sk;
                s = s + r * r;
            }
            let err = (s / lit(N.max(1) as f64)).sqrt();
            let accepted = err.is_finite() && err <= T::one() && all_finite(&y_new);
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
                for n in 0..N {
                    let ydiff = y_new[n] - x[n];
                    let bspl = h * k[0][n] - ydiff;
                    self.dense[0][n] = x[n];
                    self.dense[1][n] = ydiff;
                    self.dense[2][n] = bspl;
                    self.dense[3][n] = ydiff - h * k[6][n] - bspl;
                    let mut dk = T::zero();
                    for j in 0..7 {
                        dk = dk + self.d[j] * k[j][n];
                    }
                    self.dense[4][n] = h * dk;
                }
                self.t_old = t;
                self.h_old = h;
                self.has_dense = true;
                *x = y_new;
                self.k1 = k[6];
                self.x_last = y_new;
                self.fsal_valid = all_finite(&self.k1);
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
                    state: state_to_vec(x),
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

    fn is_adaptive(&self) -> bool {
        true
    }

    /// HNW I, §II.4, "Starting step size" (a)–(f) with p = 4 (exponent 1/(p+1) = 1/5).
    fn initial_step(&mut self, field: &F, t0: T, x0: &[T; N], t_end: T) -> Option<T> {
        let mut f0 = [T::zero(); N];
        field.field(x0, &mut f0);
        let d0 = self.scaled_norm(x0, x0);
        let d1 = self.scaled_norm(&f0, x0);
        let small = lit::<T>(1e-5);
        let mut h0 = if d0 < small || d1 < small {
            lit(1e-6)
        } else {
            lit::<T>(0.01) * d0 / d1
        };
        let span = (t_end - t0).abs();
        if span > T::zero() {
            h0 = h0.min(span);
        }
        h0 = h0.min(self.opts.h_max);
        let mut x1 = *x0;
        for n in 0..N {
            x1[n] = x1[n] + h0 * f0[n];
        }
        let mut f1 = [T::zero(); N];
        field.field(&x1, &mut f1);
        let mut diff = [T::zero(); N];
        for n in 0..N {
            diff[n] = f1[n] - f0[n];
        }
        let d2 = self.scaled_norm(&diff, x0) / h0;
        let dmax = d1.max(d2);
        let h1 = if !(dmax > lit(1e-15)) {
            lit::<T>(1e-6).max(h0 * lit(1e-3))
        } else {
            (lit::<T>(0.01) / dmax).powf(lit(0.2))
        };
        let mut h = (lit::<T>(100.0) * h0).min(h1).min(self.opts.h_max);
        if span > T::zero() {
            h = h.min(span);
        }
        if all_finite(&f0) {
            self.k1 = f0;
            self.x_last = *x0;
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

impl<T: Float, const N: usize> DenseOutput<T, N> for DormandPrince<T, N> {
    fn dense_interval(&self) -> Option<(T, T)> {
        self.has_dense
            .then(|| (self.t_old, self.t_old + self.h_old))
    }

    /// `x(t_old + θh) ≈ r₁ + θ(r₂ + (1−θ)(r₃ + θ(r₄ + (1−θ) r₅)))` (`dopri5.f`, `CONTD5`).
    fn interpolate(&self, t: T, out: &mut [T; N]) -> bool {
        if !self.has_dense {
            return false;
        }
        let theta = (t - self.t_old) / self.h_old;
        let slack = lit::<T>(1e-9);
        if !(theta >= -slack && theta <= T::one() + slack) {
            return false;
        }
        let theta1 = T::one() - theta;
        let r = &self.dense;
        for n in 0..N {
            out[n] = r[0][n]
                + theta * (r[1][n] + theta1 * (r[2][n] + theta * (r[3][n] + theta1 * r[4][n])));
        }
        true
    }
}
