//! Jacobi elliptic functions and elliptic integrals of the first kind, in `f64`
//! (`lasalle_runtime::elliptic` re-exports this crate).
//!
//! # Parameter convention: m = k²
//!
//! **Every function here takes the *parameter* m = k², not the modulus k**, as Abramowitz &
//! Stegun ch. 16–17 (sn(u | m), F(φ | m), K(m)), MATLAB's `ellipj(u, m)`/`ellipke(m)` and
//! SciPy's `ellipj(u, m)`/`ellipk(m)` do. DLMF ch. 19 and 22, Byrd & Friedman, Lawden, much
//! of the mechanics literature and the SO(3) optimal-control thesis this crate serves write
//! the modulus instead: their sn(u, k) is sn(u | m = k²) here — call `ellipj(u, k * k)`.
//! The complementary parameter is m₁ = 1 − m = k′² (A&S 16.1, 17.2).
//!
//! | function | value | method |
//! |---|---|---|
//! | [`ellipj`]`(u, m)` | sn, cn, dn, am of (u \| m) as a [`Jacobi`] | descending Gauss/Landen transformation (Bulirsch) |
//! | [`ellipj_m1`]`(u, m₁)` | the same for m = 1 − m₁ | for parameters within rounding of 1 |
//! | [`Jacobi`]`::{ns, nc, nd, sc, sd, cs, cd, ds, dc}` | Glaisher's quotients pq = pr/qr | — |
//! | [`ellipk`]`(m)` | K(m) = F(π/2 \| m) | arithmetic–geometric mean |
//! | [`ellipkm1`]`(m₁)` | K(1 − m₁) = K′(m₁) | the same, from m₁ directly |
//! | [`ellipf`]`(φ, m)` | F(φ \| m) = ∫₀^φ dθ / √(1 − m sin²θ) | Carlson's R_F |
//!
//! [`generic`] has sn, cn, dn, K and F over any `num_traits::Float` (computed in `f64`), for
//! code generated from models that call them (`sn(u, m)` in a model file, see docs/dsl.md).
//!
//! # Domain and invalid input
//!
//! All functions accept 0 ≤ m ≤ 1 (including both ends exactly) and finite arguments. They
//! are hot-path kernels, so instead of a `Result` they return **NaN** (in every field, for
//! [`ellipj`]) when the parameter is outside [0, 1], or any input is NaN or infinite. K(1) = +∞
//! and F(φ \| 1) = ±∞ (signed like φ) for |φ| > π/2 — every `f64` above `FRAC_PI_2`, which
//! is itself just below π/2 — are the correct values, not errors.
//! Parameters m < 0 or m > 1 are meaningful mathematically (A&S 16.10–16.11, 17.4)
//! but are not needed here and are rejected rather than silently mis-evaluated.
//!
//! # Accuracy
//!
//! Measured by the tests of this module against an independent double-double (≈ 32 digit)
//! Taylor integration of sn′ = cn dn, cn′ = −sn dn, dn′ = −m sn cn, am′ = dn, for
//! m ∈ {0, 10⁻¹², 10⁻⁶, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 1 − 10⁻⁶, 1 − 10⁻¹², 1} and
//! m₁ = 10⁻²⁰ (through [`ellipj_m1`]):
//!
//! | quantity | max error measured | asserted |
//! |---|---|---|
//! | sn, cn, dn, 0 ≤ u ≤ 50 (absolute) | 4.6·10⁻¹⁶ | 1·10⁻¹⁵ |
//! | sn, cn, dn, 500 ≤ u ≤ 1000, m ∈ {½, 0.99, 1 − 10⁻¹²} (absolute) | 4.9·10⁻¹⁶ | 1·10⁻¹⁵ |
//! | am, relative to max(1, \|am\|) | 4.5·10⁻¹⁶ | 1·10⁻¹⁵ |
//! | K(m), relative (m ∈ [0, 1), m₁ down to 5·10⁻³²⁴) | 1.1·10⁻¹⁶ | 2.5·10⁻¹⁶ |
//! | F(φ \| m), relative to max(1, \|F\|) | 7.5·10⁻¹⁶ | 1·10⁻¹⁵ |
//!
//! The error does not grow with |u|: the only argument-dependent step, the scaled argument
//! u·π/(2K) (the reduction by the quarter period), is formed in double-double from an AGM
//! that carries its rounding errors, so sn, cn, dn are accurate to a few ulp of 1 at any
//! |u| — relative to the exact u given; the half-ulp uncertainty of u itself, if u is the
//! result of a computation, passes through with a factor ≤ 1 (|sn′|, |cn′| ≤ 1, |dn′| ≤ m).
//! For |u| ≳ 10⁸ that uncertainty exceeds 10⁻⁸ and the values, though finite and
//! consistent (sn² + cn² = 1 to rounding), carry little information.
//!
//! These are `f64`-only: the compensated (fused multiply–add) steps that give the accuracy
//! above are specific to binary64.

#![warn(missing_docs)]
// `!(a > b)` is the NaN-aware test the kernels mean (stop, or reject, on NaN too).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod generic;

use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Low part of π in double-double: π = `PI` + `PI_LO` to ~32 digits.
const PI_LO: f64 = 1.224_646_799_147_353_2e-16;
/// Low part of π/2 in double-double: π/2 = `FRAC_PI_2` + `FRAC_PI_2_LO` to ~32 digits.
const FRAC_PI_2_LO: f64 = 6.123_233_995_736_766e-17;
/// Maximum number of AGM / Landen levels. AGM(1, b) with b ≥ √(min positive f64) reaches the
/// tolerance in at most ~14 steps; the cap only guards against an infinite loop.
const LEVELS: usize = 24;
/// Stop the AGM when |aₙ − bₙ| ≤ `AGM_TOL`·aₙ. The first neglected Landen parameter is then
/// mₙ₊₁ = ((aₙ − bₙ)/(aₙ + bₙ))² ≤ `AGM_TOL`²/4 ≈ 2.5·10⁻¹⁹, far below rounding.
const AGM_TOL: f64 = 1e-9;
/// Below this |u| the Maclaurin series (A&S 16.22) through u⁵ is exact to rounding.
const SERIES_U: f64 = 1.0 / 1024.0;

/// The Jacobi elliptic functions sn, cn, dn and the amplitude am at one (u | m), as returned
/// by [`ellipj`] and [`ellipj_m1`].
///
/// am = am(u | m) is the continuous, increasing branch with sn = sin am, cn = cos am,
/// am(0) = 0 and am(u + 2K) = am(u) + π (A&S 16.1); dn = √(1 − m sn²) ≥ 0.
///
/// The nine remaining functions are Glaisher's quotients pq = pr/qr with n ≡ 1
/// (A&S 16.3; DLMF 22.2.10): `j.sc()` = sn/cn, `j.ns()` = 1/sn, and so on. They follow IEEE
/// division: a quotient is ±∞ where its denominator vanishes, e.g. `ns` at u = 0 (and `sc`,
/// `dc`, `nc` are huge at odd multiples of K, where cn is K's rounding error). The only 0/0,
/// giving NaN, is `cd` and `dc` at m = 1 for |u| > 745, where sech u underflows to 0 (their
/// value there is 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jacobi {
    /// sn(u | m) = sin am(u | m) (A&S 16.1).
    pub sn: f64,
    /// cn(u | m) = cos am(u | m) (A&S 16.1).
    pub cn: f64,
    /// dn(u | m) = √(1 − m sn²(u | m)) (A&S 16.1).
    pub dn: f64,
    /// The amplitude am(u | m) = φ with F(φ | m) = u (A&S 16.1; DLMF §22.16).
    pub am: f64,
}

impl Jacobi {
    /// A result with every field NaN: what invalid input returns.
    pub const NAN: Jacobi = Jacobi {
        sn: f64::NAN,
        cn: f64::NAN,
        dn: f64::NAN,
        am: f64::NAN,
    };

    /// ns = 1/sn (A&S 16.3).
    #[inline]
    pub fn ns(&self) -> f64 {
        1.0 / self.sn
    }
    /// nc = 1/cn (A&S 16.3).
    #[inline]
    pub fn nc(&self) -> f64 {
        1.0 / self.cn
    }
    /// nd = 1/dn (A&S 16.3).
    #[inline]
    pub fn nd(&self) -> f64 {
        1.0 / self.dn
    }
    /// sc = sn/cn (A&S 16.3).
    #[inline]
    pub fn sc(&self) -> f64 {
        self.sn / self.cn
    }
    /// sd = sn/dn (A&S 16.3).
    #[inline]
    pub fn sd(&self) -> f64 {
        self.sn / self.dn
    }
    /// cs = cn/sn (A&S 16.3).
    #[inline]
    pub fn cs(&self) -> f64 {
        self.cn / self.sn
    }
    /// cd = cn/dn (A&S 16.3).
    #[inline]
    pub fn cd(&self) -> f64 {
        self.cn / self.dn
    }
    /// ds = dn/sn (A&S 16.3).
    #[inline]
    pub fn ds(&self) -> f64 {
        self.dn / self.sn
    }
    /// dc = dn/cn (A&S 16.3).
    #[inline]
    pub fn dc(&self) -> f64 {
        self.dn / self.cn
    }
}

/// Jacobi elliptic functions sn, cn, dn and the amplitude am of (u | m), **parameter m = k²**,
/// 0 ≤ m ≤ 1 (see the [module docs](self) for the convention).
///
/// Definitions (A&S 16.1; DLMF 22.16): with u = F(φ | m) = ∫₀^φ dθ/√(1 − m sin²θ), am(u | m) = φ,
/// sn = sin φ, cn = cos φ, dn = √(1 − m sin²φ). Equivalently sn, cn, dn solve
/// sn′ = cn dn, cn′ = −sn dn, dn′ = −m sn cn with sn(0) = 0, cn(0) = dn(0) = 1.
///
/// Method:
/// - m = 0: sin u, cos u, 1, u; m = 1: tanh u, sech u, sech u, gd u (A&S 16.6).
/// - |u| < 2⁻¹⁰: Maclaurin series through u⁵ (A&S 16.22), exact to rounding there.
/// - otherwise the descending Gauss (Landen) transformation driven by the AGM
///   (A&S 16.4, 16.12; DLMF §22.7, §22.20) in Bulirsch's cotangent form (Bulirsch 1965,
///   Numer. Math. 7, 78–90, as `sncndn` in Numerical Recipes): the AGM of (1, √(1 − m))
///   gives M = π/(2K); sin and cos of the scaled argument u·M are carried back through the
///   transformations with quotients of positive terms only, so no cancellation occurs near
///   u = K (where cn → 0) or near m = 1 (where dn → 0). The scaled argument u·M is the
///   reduction of u by the quarter period, and it is formed in double-double from an AGM
///   with error terms, so accuracy does not degrade for large |u|.
/// - am = atan2(sn, cn) put on the branch nearest u·π/(2K); |am − uπ/(2K)| < π/2 always.
///
/// Accuracy: absolute error of sn, cn, dn ≤ 5·10⁻¹⁶ measured over 0 ≤ m ≤ 1 (including
/// m = 10⁻¹² and 1 − 10⁻¹²) for |u| ≤ 50 and on 500 ≤ |u| ≤ 1000: it does not grow with |u|;
/// see the [module docs](self#accuracy).
///
/// Returns [`Jacobi::NAN`] if m ∉ [0, 1] or u or m is not finite. For m within rounding of 1
/// (1 − m below ~10⁻¹⁶, or not representable as `1.0 - m`) use [`ellipj_m1`].
///
/// ```
/// use lasalle_elliptic::ellipj;
/// let j = ellipj(0.5, 0.3);
/// assert!((j.sn * j.sn + j.cn * j.cn - 1.0).abs() < 1e-15);
/// assert!((j.dn * j.dn + 0.3 * j.sn * j.sn - 1.0).abs() < 1e-15);
/// let t = ellipj(2.0, 1.0); // m = 1: tanh, sech
/// assert!((t.sn - 2.0f64.tanh()).abs() < 1e-15 && (t.cn - 1.0 / 2.0f64.cosh()).abs() < 1e-15);
/// ```
pub fn ellipj(u: f64, m: f64) -> Jacobi {
    if !u.is_finite() || !(0.0..=1.0).contains(&m) {
        return Jacobi::NAN;
    }
    // 1 − m exactly, as a double-double (the low part is nonzero only for m < 1/2).
    let (m1, m1_lo) = two_sum(1.0, -m);
    jacobi(u, m, m1, m1_lo)
}

/// Jacobi elliptic functions of (u | m) with the parameter given through its complement
/// m₁ = 1 − m (A&S 16.1), 0 ≤ m₁ ≤ 1: `ellipj_m1(u, m1)` = `ellipj(u, 1 - m1)`, but exact
/// when m is within rounding of 1 (e.g. m₁ = 10⁻²⁰, where `1.0 - m1 == 1.0`).
///
/// The algorithm depends on m only through m₁ (see [`ellipj`]; the small-|u| series also uses
/// the rounded 1 − m₁, which is harmless there), so nothing is lost.
/// Returns [`Jacobi::NAN`] if m₁ ∉ [0, 1] or u or m₁ is not finite.
///
/// ```
/// use lasalle_elliptic::{ellipj, ellipj_m1};
/// let (a, b) = (ellipj_m1(3.0, 0.25), ellipj(3.0, 0.75));
/// assert!((a.sn - b.sn).abs() < 1e-15 && (a.dn - b.dn).abs() < 1e-15);
/// ```
pub fn ellipj_m1(u: f64, m1: f64) -> Jacobi {
    if !u.is_finite() || !(0.0..=1.0).contains(&m1) {
        return Jacobi::NAN;
    }
    jacobi(u, 1.0 - m1, m1, 0.0)
}

/// Complete elliptic integral of the first kind, **parameter m = k²**:
/// K(m) = F(π/2 | m) = ∫₀^{π/2} dθ / √(1 − m sin²θ) (A&S 17.3; DLMF 19.2.8), 0 ≤ m ≤ 1.
///
/// Computed as K = π / (2 M(1, √(1 − m))) with M the arithmetic–geometric mean
/// (A&S 17.6; DLMF §19.8), run with first-order error terms and a compensated final
/// division, so the relative error is at most about one ulp (measured 1.1·10⁻¹⁶). K(0) = π/2 and K(1) = +∞; near m = 1,
/// K ≈ ½ ln(16/(1 − m)) and 1 − m is exact in `f64` for m ≥ ½, so K is accurate right up to
/// the last `f64` below 1. For parameters closer to 1 than that use [`ellipkm1`].
///
/// Returns NaN if m ∉ [0, 1] or m is NaN.
///
/// ```
/// use lasalle_elliptic::ellipk;
/// assert_eq!(ellipk(0.0), std::f64::consts::FRAC_PI_2);
/// assert!((ellipk(0.5) - 1.854_074_677_301_372).abs() < 1e-15);
/// assert_eq!(ellipk(1.0), f64::INFINITY);
/// ```
pub fn ellipk(m: f64) -> f64 {
    if !(0.0..=1.0).contains(&m) {
        return f64::NAN;
    }
    let (m1, m1_lo) = two_sum(1.0, -m);
    complete_k(m1, m1_lo)
}

/// Complete elliptic integral of the first kind as a function of the complementary parameter:
/// `ellipkm1(m1)` = K(1 − m₁) = K′(m₁) (A&S 17.3; SciPy's `ellipkm1`), 0 ≤ m₁ ≤ 1.
///
/// K(1 − m₁) = π / (2 M(1, √m₁)), evaluated from m₁ itself, so it keeps full relative accuracy
/// as m₁ → 0 (K → ½ ln(16/m₁), A&S 17.3) even where 1 − m₁ rounds to 1. Equally, it is
/// the complementary integral K′(m) = K(1 − m) of a small parameter m. `ellipkm1(0)` = +∞.
///
/// Returns NaN if m₁ ∉ [0, 1] or m₁ is NaN.
///
/// ```
/// use lasalle_elliptic::{ellipk, ellipkm1};
/// assert!((ellipkm1(0.1) - ellipk(0.9)).abs() < 1e-15);
/// // K(1 − 10⁻³⁰) ≈ ½ ln(16·10³⁰), where 1 − 10⁻³⁰ is not representable:
/// assert!((ellipkm1(1e-30) - 0.5 * (16e30f64).ln()).abs() < 1e-13);
/// ```
pub fn ellipkm1(m1: f64) -> f64 {
    if !(0.0..=1.0).contains(&m1) {
        return f64::NAN;
    }
    complete_k(m1, 0.0)
}

/// Incomplete elliptic integral of the first kind, **parameter m = k²**:
/// F(φ | m) = ∫₀^φ dθ / √(1 − m sin²θ) (A&S 17.2; DLMF 19.2.4), 0 ≤ m ≤ 1, any finite φ.
///
/// The inverse of the amplitude: am(F(φ | m) | m) = φ (A&S 16.1). For |φ| ≤ π/2,
/// F(φ | m) = sin φ · R_F(cos²φ, 1 − m sin²φ, 1) (DLMF 19.25.5) with Carlson's symmetric
/// integral R_F computed by duplication (DLMF 19.36.1; Carlson 1995, Numer. Algorithms 10,
/// 13–26); 1 − m sin²φ is formed as cos²φ + (1 − m) sin²φ when m > ½ to avoid cancellation
/// near m = 1, φ = π/2. Other φ are reduced by F(φ + nπ | m) = F(φ | m) + 2nK(m)
/// (A&S 17.4), with φ − nπ in double-double and its low part carried to first order, so
/// the steep regions near odd multiples of π/2 (F′ = 1/√(1 − m sin²φ) ≫ 1 as m → 1) keep
/// full accuracy. For m = 1, F = arsinh(tan φ) directly.
///
/// F is odd in φ; F(φ | 0) = φ; F(φ | 1) = artanh(sin φ) = gd⁻¹ φ for |φ| < π/2 and ±∞
/// beyond (F(`FRAC_PI_2` | 1) ≈ 38.1 is finite: `FRAC_PI_2` < π/2). Relative error is a few ulp (measured ≤ 7.5·10⁻¹⁶ against quadrature and against
/// the inverse of a double-double am).
///
/// Returns NaN if m ∉ [0, 1] or φ or m is not finite.
///
/// ```
/// use lasalle_elliptic::{ellipf, ellipj};
/// let u = ellipf(1.0, 0.7);
/// assert!((ellipj(u, 0.7).am - 1.0).abs() < 1e-15);
/// assert!((ellipf(0.5, 1.0) - 0.5f64.sin().atanh()).abs() < 1e-15);
/// ```
pub fn ellipf(phi: f64, m: f64) -> f64 {
    if !phi.is_finite() || !(0.0..=1.0).contains(&m) {
        return f64::NAN;
    }
    if m == 1.0 {
        // F(φ | 1) = ∫ dθ/cos θ = gd⁻¹ φ = arsinh(tan φ) for |φ| < π/2, infinite beyond.
        // `FRAC_PI_2` itself is just below π/2: finite (≈ 38.1).
        return if phi.abs() <= FRAC_PI_2 {
            phi.tan().asinh()
        } else {
            f64::INFINITY.copysign(phi)
        };
    }
    // φ = nπ + r with |r| ≤ π/2 (A&S 17.4: F(φ + nπ) = F(φ) + 2nK). For n ≠ 0, r is
    // formed in double-double, r = r_hi + r_lo, and F(r) = F(r_hi) + r_lo/Δ(r_hi) to first
    // order; that keeps full accuracy where F′ = 1/Δ is large (m → 1, r → ±π/2).
    // (|φ| ≤ π/2 is kept as is: `FRAC_PI_2` < π/2, and the tie φ/π = ½ would round away.)
    let n = if phi.abs() <= FRAC_PI_2 {
        0.0
    } else {
        (phi / PI).round()
    };
    let (r, r_lo) = if n == 0.0 {
        (phi, 0.0)
    } else {
        let p = n * PI;
        let p_lo = n.mul_add(PI, -p) + n * PI_LO;
        let (d, d_lo) = two_sum(phi, -p);
        two_sum(d, d_lo - p_lo)
    };
    let (s, c) = r.sin_cos();
    let (s2, c2) = (s * s, c * c);
    // Δ² = 1 − m sin²r, as cos²r + (1 − m) sin²r when m > ½ (no cancellation near m = 1).
    let delta2 = if m > 0.5 {
        (1.0 - m).mul_add(s2, c2)
    } else {
        (-m).mul_add(s2, 1.0)
    };
    let f = s * carlson_rf(c2, delta2, 1.0);
    if n == 0.0 {
        f
    } else {
        // K in double-double: 2nK + F(r) then has a single rounding.
        let (m1, m1_lo) = two_sum(1.0, -m);
        let (k, k_lo) = complete_k_dd(m1, m1_lo);
        (2.0 * n).mul_add(k, (2.0 * n).mul_add(k_lo, f + r_lo / delta2.sqrt()))
    }
}

/// sn, cn, dn, am for a validated (u, m) with 1 − m = m1 + m1_lo exactly.
fn jacobi(u: f64, m: f64, m1: f64, m1_lo: f64) -> Jacobi {
    if m == 0.0 && m1_lo == 0.0 && m1 == 1.0 {
        let (sn, cn) = u.sin_cos();
        return Jacobi {
            sn,
            cn,
            dn: 1.0,
            am: u,
        };
    }
    if m1 == 0.0 {
        // m = 1: sn = tanh u, cn = dn = sech u, am = gd u (A&S 16.6).
        let sn = u.tanh();
        // sech u = 2e^{−|u|}/(1 + e^{−2|u|}); past |u| = 20 the denominator is 1 to rounding,
        // and this form stays nonzero (subnormal) up to |u| ≈ 745 where 1/cosh u is already 0.
        let cn = if u.abs() < 20.0 {
            1.0 / u.cosh()
        } else {
            2.0 * (-u.abs()).exp()
        };
        return Jacobi {
            sn,
            cn,
            dn: cn,
            am: sn.atan2(cn),
        };
    }
    if u.abs() < SERIES_U {
        // A&S 16.22; the first neglected terms are below 10⁻¹⁹ relative.
        let u2 = u * u;
        let sn = u * (1.0 - u2 * ((1.0 + m) / 6.0 - u2 * (1.0 + m * (14.0 + m)) / 120.0));
        let cn = 1.0 - u2 * (0.5 - u2 * (1.0 + 4.0 * m) / 24.0);
        let dn = 1.0 - m * u2 * (0.5 - u2 * (4.0 + m) / 24.0);
        let am = u * (1.0 - m * u2 * (1.0 / 6.0 - u2 * (4.0 + m) / 120.0));
        return Jacobi { sn, cn, dn, am };
    }

    let chain = Agm::new(m1, m1_lo);
    let (mean, mean_lo) = (chain.mean, chain.mean_lo);
    // Scaled argument p = u·M = u·π/(2K) in double-double: the quarter-period reduction.
    let p = u * mean;
    let p_lo = u.mul_add(mean, -p) + u * mean_lo;
    let (sp, cp) = p.sin_cos();
    let s0 = p_lo.mul_add(cp, sp);
    let c0 = (-p_lo).mul_add(sp, cp);
    let am_scaled = p + p_lo;
    if s0 == 0.0 {
        // u is (to all digits) a multiple of 2K: sn = 0, cn = ±1, dn = 1.
        let cn = 1.0f64.copysign(c0);
        return Jacobi {
            sn: 0.0,
            cn,
            dn: 1.0,
            am: branch(0.0f64.atan2(cn), am_scaled),
        };
    }
    // Bulirsch's recursion: a, c carry cotangent-like quotients back up the Landen chain; every
    // dn is a quotient of sums of non-negative terms.
    let mut a = c0 / s0;
    let mut c = mean * a;
    let mut dn = 1.0;
    for i in (0..chain.len).rev() {
        let b = chain.a[i];
        a *= c;
        c *= dn;
        dn = (chain.b[i] + a) / (b + a);
        a = c / b;
    }
    // c = cs(u | m) now.
    let sn = (1.0 / c.mul_add(c, 1.0).sqrt()).copysign(s0);
    let cn = c * sn;
    Jacobi {
        sn,
        cn,
        dn,
        am: branch(sn.atan2(cn), am_scaled),
    }
}

/// The branch θ + 2πj of an angle θ ∈ (−π, π] nearest to `near` (|result − near| < π).
#[inline]
fn branch(theta: f64, near: f64) -> f64 {
    let j = ((near - theta) / TAU).round();
    j.mul_add(TAU, theta)
}

/// K(1 − (m1 + m1_lo)) for 0 ≤ m1 ≤ 1.
fn complete_k(m1: f64, m1_lo: f64) -> f64 {
    let (k, k_lo) = complete_k_dd(m1, m1_lo);
    k + k_lo
}

/// K(1 − (m1 + m1_lo)) = k + k_lo (unnormalised double-double) for 0 ≤ m1 ≤ 1.
fn complete_k_dd(m1: f64, m1_lo: f64) -> (f64, f64) {
    if m1 == 0.0 && m1_lo == 0.0 {
        return (f64::INFINITY, 0.0);
    }
    let chain = Agm::new(m1, m1_lo);
    let (mh, ml) = (chain.mean, chain.mean_lo);
    // K = (π/2)/M with π/2 and M in double-double and one correction step.
    let q = FRAC_PI_2 / mh;
    let r = (-q).mul_add(mh, FRAC_PI_2) + FRAC_PI_2_LO - q * ml;
    (q, r / mh)
}

/// The AGM chain a₀ = 1, b₀ = √m₁, aₙ₊₁ = (aₙ + bₙ)/2, bₙ₊₁ = √(aₙbₙ) (A&S 17.6) up to the
/// first level with |aₙ − bₙ| ≤ `AGM_TOL`·aₙ, plus the mean M(1, √m₁) = aₙ₊₁ in double-double
/// (first-order error terms are propagated alongside every step).
struct Agm {
    a: [f64; LEVELS],
    b: [f64; LEVELS],
    len: usize,
    mean: f64,
    mean_lo: f64,
}

impl Agm {
    fn new(m1: f64, m1_lo: f64) -> Agm {
        let mut chain = Agm {
            a: [0.0; LEVELS],
            b: [0.0; LEVELS],
            len: 0,
            mean: 0.0,
            mean_lo: 0.0,
        };
        let (mut a, mut a_lo) = (1.0, 0.0);
        let (mut b, mut b_lo) = sqrt_dd(m1, m1_lo);
        for i in 0..LEVELS {
            chain.a[i] = a;
            chain.b[i] = b;
            chain.len = i + 1;
            let (s, s_lo) = two_sum(a, b);
            chain.mean = 0.5 * s;
            chain.mean_lo = 0.5 * (s_lo + a_lo + b_lo);
            if !((a - b).abs() > AGM_TOL * a) {
                break;
            }
            let p = a * b;
            let p_lo = a.mul_add(b, -p) + a_lo * b + a * b_lo;
            (b, b_lo) = sqrt_dd(p, p_lo);
            (a, a_lo) = (chain.mean, chain.mean_lo);
        }
        chain
    }
}

/// s + e = a + b exactly (Knuth's TwoSum).
#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// √(hi + lo) to double-double accuracy (one Newton correction), for hi + lo ≥ 0.
#[inline]
fn sqrt_dd(hi: f64, lo: f64) -> (f64, f64) {
    let s = hi.sqrt();
    if s == 0.0 {
        return (0.0, 0.0);
    }
    let r = (-s).mul_add(s, hi) + lo;
    (s, r / (2.0 * s))
}

/// (3u)^(−1/6) for u = 2⁻⁵³, rounded up: Carlson's duplication stops when the spread of the
/// arguments, scaled by this, is below their mean; the truncated series is then exact to
/// rounding (Carlson 1995).
const RF_Q: f64 = 380.0;

/// Carlson's symmetric integral R_F(x, y, z) = ½∫₀^∞ dt / √((t+x)(t+y)(t+z)) for
/// x, y ≥ 0 and z > 0 (DLMF 19.16.1), by duplication (DLMF 19.36.1); R_F(0, 0, z) = +∞.
fn carlson_rf(x: f64, y: f64, z: f64) -> f64 {
    if x == 0.0 && y == 0.0 {
        return f64::INFINITY;
    }
    let a0 = (x + y + z) / 3.0;
    let q = RF_Q * (a0 - x).abs().max((a0 - y).abs()).max((a0 - z).abs());
    let (mut xn, mut yn, mut zn, mut an) = (x, y, z, a0);
    let mut scale = 1.0; // 4⁻ⁿ
    for _ in 0..200 {
        if q * scale < an {
            break;
        }
        let (sx, sy, sz) = (xn.sqrt(), yn.sqrt(), zn.sqrt());
        let lambda = sx * (sy + sz) + sy * sz;
        xn = 0.25 * (xn + lambda);
        yn = 0.25 * (yn + lambda);
        zn = 0.25 * (zn + lambda);
        an = 0.25 * (an + lambda);
        scale *= 0.25;
    }
    let xx = (a0 - x) * scale / an;
    let yy = (a0 - y) * scale / an;
    let zz = -(xx + yy);
    let e2 = xx * yy - zz * zz;
    let e3 = xx * yy * zz;
    // DLMF 19.36.1, through the terms of total degree 7 in (X, Y, Z).
    let poly = 1.0 - e2 / 10.0 + e3 / 14.0 + e2 * e2 / 24.0
        - 3.0 * e2 * e3 / 44.0
        - 5.0 * e2 * e2 * e2 / 208.0
        + 3.0 * e3 * e3 / 104.0
        + e2 * e2 * e3 / 16.0;
    poly / an.sqrt()
}

#[cfg(test)]
mod tests;
