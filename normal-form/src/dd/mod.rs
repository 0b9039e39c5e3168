//! Double-double arithmetic: an unevaluated sum `hi + lo` of two f64 with |lo| ≤ ½ulp(hi),
//! about 106 bits (≈ 32 decimal digits) of precision.
//!
//! The algorithms are the classical error-free transformations (Dekker 1971, Knuth's TwoSum)
//! as used in Hida, Li & Bailey's QD library: addition is the accurate ("IEEE") variant, so
//! cancellation keeps a relative error of a few 2⁻¹⁰⁶. Products use Dekker's splitting unless
//! the crate is compiled with the `fma` target feature, in which case `f64::mul_add` gives
//! the exact product error in one instruction.
//!
//! The arithmetic is here; the series product kernels built on it (scalar, FMA and AVX2,
//! chosen at run time) are in `kernels`.

use crate::complex::Complex;
use crate::scalar::{Coeff, Real};
use std::fmt;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

mod kernels;

/// A double-double number `hi + lo` (`repr(C)`: the SIMD kernels read `[hi, lo]` pairs).
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Default)]
#[repr(C)]
pub struct Dd {
    /// Leading part (the value rounded to f64).
    pub hi: f64,
    /// Trailing part, |lo| ≤ ½ ulp(hi).
    pub lo: f64,
}

#[inline(always)]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

#[inline(always)]
fn quick_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

#[cfg(not(target_feature = "fma"))]
#[inline(always)]
fn split(a: f64) -> (f64, f64) {
    const SPLITTER: f64 = 134_217_729.0; // 2^27 + 1
    let t = SPLITTER * a;
    let hi = t - (t - a);
    (hi, a - hi)
}

#[cfg(not(target_feature = "fma"))]
#[inline(always)]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
}

#[cfg(target_feature = "fma")]
#[inline(always)]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

impl Dd {
    /// An f64 as a double-double (exact).
    #[inline(always)]
    pub const fn new(hi: f64) -> Dd {
        Dd { hi, lo: 0.0 }
    }
    /// From two parts, renormalised.
    #[inline(always)]
    pub fn from_parts(hi: f64, lo: f64) -> Dd {
        let (h, l) = two_sum(hi, lo);
        Dd { hi: h, lo: l }
    }
    /// Product of two f64, exact.
    #[inline(always)]
    pub fn mul_f64(a: f64, b: f64) -> Dd {
        let (p, e) = two_prod(a, b);
        Dd { hi: p, lo: e }
    }
    /// self²
    #[inline(always)]
    pub fn sqr(self) -> Dd {
        self * self
    }
    /// Multiplication by a power of two (exact).
    #[inline(always)]
    pub fn ldexp(self, k: i32) -> Dd {
        let f = 2f64.powi(k);
        Dd {
            hi: self.hi * f,
            lo: self.lo * f,
        }
    }
    /// Nearest integer (as Dd).
    pub fn round(self) -> Dd {
        let hi = self.hi.round();
        if hi == self.hi {
            // hi is an integer: round the low part
            let lo = self.lo.round();
            let (h, l) = quick_two_sum(hi, lo);
            Dd { hi: h, lo: l }
        } else if (hi - self.hi).abs() == 0.5 && self.lo != 0.0 {
            // a tie in hi broken by lo
            let h = if (hi - self.hi) * self.lo > 0.0 {
                hi - (hi - self.hi).signum()
            } else {
                hi
            };
            Dd { hi: h, lo: 0.0 }
        } else {
            Dd { hi, lo: 0.0 }
        }
    }
    /// π
    pub const PI: Dd = Dd {
        hi: std::f64::consts::PI,
        lo: 1.224_646_799_147_353_2e-16,
    };
    /// π/2
    pub const FRAC_PI_2: Dd = Dd {
        hi: std::f64::consts::FRAC_PI_2,
        lo: 6.123_233_995_736_766e-17,
    };
    /// ln 2
    pub const LN_2: Dd = Dd {
        hi: std::f64::consts::LN_2,
        lo: 2.319_046_813_846_299_6e-17,
    };

    fn exp_impl(self) -> Dd {
        if self.hi > 709.0 {
            return Dd::new(f64::INFINITY);
        }
        if self.hi < -745.0 {
            return Dd::new(0.0);
        }
        // x = k ln2 + r, |r| ≤ ln2/2; then e^r = (e^{r/2^10})^{2^10}
        let k = (self.hi / Dd::LN_2.hi).round();
        let r = (self - Dd::LN_2 * Dd::new(k)).ldexp(-10);
        // Taylor series of e^r − 1 for |r| < 4e-4: 11 terms reach 1e-40
        let mut term = r;
        let mut sum = r;
        for i in 2..=12 {
            term = term * r / Dd::new(i as f64);
            sum += term;
            if term.hi.abs() < 1e-36 * sum.hi.abs().max(1e-300) {
                break;
            }
        }
        // (1 + s)² − 1 = 2s + s², ten times
        for _ in 0..10 {
            sum = sum.ldexp(1) + sum.sqr();
        }
        (sum + Dd::new(1.0)).ldexp(k as i32)
    }

    fn ln_impl(self) -> Dd {
        if self.hi <= 0.0 {
            return Dd::new(f64::NAN);
        }
        // Newton on e^y = x: y ← y + x e^{−y} − 1
        let mut y = Dd::new(self.hi.ln());
        for _ in 0..2 {
            y = y + self * (-y).exp_impl() - Dd::new(1.0);
        }
        y
    }

    /// sin and cos of r with |r| ≤ π/4 by their Taylor series.
    fn sin_cos_small(r: Dd) -> (Dd, Dd) {
        let r2 = r.sqr();
        let mut term = r;
        let mut s = r;
        let mut i = 1.0;
        loop {
            term = -(term * r2) / Dd::new((i + 1.0) * (i + 2.0));
            s += term;
            i += 2.0;
            if term.hi.abs() < 1e-34 || i > 60.0 {
                break;
            }
        }
        let mut term = Dd::new(1.0);
        let mut c = Dd::new(1.0);
        let mut i = 0.0;
        loop {
            term = -(term * r2) / Dd::new((i + 1.0) * (i + 2.0));
            c += term;
            i += 2.0;
            if term.hi.abs() < 1e-34 || i > 60.0 {
                break;
            }
        }
        (s, c)
    }

    fn sin_cos(self) -> (Dd, Dd) {
        // x = k π/2 + r
        let k = (self / Dd::FRAC_PI_2).round();
        let r = self - Dd::FRAC_PI_2 * k;
        let (s, c) = Dd::sin_cos_small(r);
        let q = (k.hi.rem_euclid(4.0) + k.lo.rem_euclid(4.0)).rem_euclid(4.0) as i64;
        match q {
            0 => (s, c),
            1 => (c, -s),
            2 => (-s, -c),
            _ => (-c, s),
        }
    }
}

impl fmt::Display for Dd {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // hi with 17 digits, then the correction
        write!(f, "{:e}{:+e}", self.hi, self.lo)
    }
}

impl Add for Dd {
    type Output = Dd;
    #[inline(always)]
    fn add(self, b: Dd) -> Dd {
        let (s1, s2) = two_sum(self.hi, b.hi);
        let (t1, t2) = two_sum(self.lo, b.lo);
        let s2 = s2 + t1;
        let (s1, s2) = quick_two_sum(s1, s2);
        let s2 = s2 + t2;
        let (hi, lo) = quick_two_sum(s1, s2);
        Dd { hi, lo }
    }
}
impl Sub for Dd {
    type Output = Dd;
    #[inline(always)]
    fn sub(self, b: Dd) -> Dd {
        self + (-b)
    }
}
impl Neg for Dd {
    type Output = Dd;
    #[inline(always)]
    fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}
impl Mul for Dd {
    type Output = Dd;
    #[inline(always)]
    fn mul(self, b: Dd) -> Dd {
        let (p1, p2) = two_prod(self.hi, b.hi);
        let p2 = p2 + (self.hi * b.lo + self.lo * b.hi);
        let (hi, lo) = quick_two_sum(p1, p2);
        Dd { hi, lo }
    }
}
impl Div for Dd {
    type Output = Dd;
    fn div(self, b: Dd) -> Dd {
        let q1 = self.hi / b.hi;
        let r = self - b * Dd::new(q1);
        let q2 = r.hi / b.hi;
        let r = r - b * Dd::new(q2);
        let q3 = r.hi / b.hi;
        let (q1, q2) = quick_two_sum(q1, q2);
        Dd { hi: q1, lo: q2 } + Dd::new(q3)
    }
}
impl AddAssign for Dd {
    #[inline(always)]
    fn add_assign(&mut self, o: Dd) {
        *self = *self + o;
    }
}
impl SubAssign for Dd {
    #[inline(always)]
    fn sub_assign(&mut self, o: Dd) {
        *self = *self - o;
    }
}
impl MulAssign for Dd {
    #[inline(always)]
    fn mul_assign(&mut self, o: Dd) {
        *self = *self * o;
    }
}

impl Coeff for Dd {
    #[inline(always)]
    fn zero() -> Self {
        Dd::new(0.0)
    }
    #[inline(always)]
    fn one() -> Self {
        Dd::new(1.0)
    }
    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        Dd::new(x)
    }
    #[inline(always)]
    fn is_zero(&self) -> bool {
        self.hi == 0.0
    }
    fn magnitude(&self) -> f64 {
        self.hi.abs()
    }
    fn is_finite(&self) -> bool {
        self.hi.is_finite() && self.lo.is_finite()
    }
    #[inline(always)]
    fn scale(self, s: f64) -> Self {
        let (p1, p2) = two_prod(self.hi, s);
        let p2 = p2 + self.lo * s;
        let (hi, lo) = quick_two_sum(p1, p2);
        Dd { hi, lo }
    }
    fn mul_acc_kernel(out: &mut [Dd], a: &[Dd], ka: &[u32], b: &[Dd], kb: &[u32], lk: &[u32]) {
        kernels::real(out, a, ka, b, kb, lk)
    }
}

impl Real for Dd {
    fn complex_kernel(
        out: &mut [Complex<Dd>],
        a: &[Complex<Dd>],
        ka: &[u32],
        b: &[Complex<Dd>],
        kb: &[u32],
        lk: &[u32],
    ) {
        kernels::complex(out, a, ka, b, kb, lk)
    }
    const NAME: &'static str = "dd";
    type Wide = Dd;
    const EPSILON: f64 = 4.930_380_657_631_324e-32; // 2^-104
    fn to_f64(self) -> f64 {
        self.hi + self.lo
    }
    fn hi_lo(self) -> (f64, f64) {
        (self.hi, self.lo)
    }
    fn from_hi_lo(hi: f64, lo: f64) -> Self {
        Dd::from_parts(hi, lo)
    }
    fn abs(self) -> Self {
        if self.hi < 0.0 || (self.hi == 0.0 && self.lo < 0.0) {
            -self
        } else {
            self
        }
    }
    fn sqrt(self) -> Self {
        if self.hi <= 0.0 {
            return if self.hi == 0.0 {
                Dd::new(0.0)
            } else {
                Dd::new(f64::NAN)
            };
        }
        // Karp's trick: one Newton correction of the f64 root
        let x = 1.0 / self.hi.sqrt();
        let ax = self.hi * x;
        Dd::new(ax) + Dd::new((self - Dd::mul_f64(ax, ax)).hi * (x * 0.5))
    }
    fn exp(self) -> Self {
        self.exp_impl()
    }
    fn ln(self) -> Self {
        self.ln_impl()
    }
    fn sin(self) -> Self {
        self.sin_cos().0
    }
    fn cos(self) -> Self {
        self.sin_cos().1
    }
    fn pi() -> Self {
        Dd::PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Dd, b: Dd, tol: f64) -> bool {
        ((a - b).to_f64()).abs() <= tol * b.to_f64().abs().max(1e-300)
    }

    #[test]
    fn arithmetic_identities() {
        let third = Dd::new(1.0) / Dd::new(3.0);
        assert!(close(third * Dd::new(3.0), Dd::new(1.0), 1e-31));
        let s2 = Dd::new(2.0).sqrt();
        assert!(close(s2 * s2, Dd::new(2.0), 1e-31));
        // 0.1 + 0.2 − 0.3 in dd is the f64 representation error, not 0
        let x = Dd::new(0.1) + Dd::new(0.2) - Dd::new(0.3);
        assert!((x.to_f64() - 2.7755575615628914e-17).abs() < 1e-32);
    }

    #[test]
    fn elementary_functions() {
        let one = Dd::new(1.0);
        // e from the known double-double value
        let e = Dd {
            hi: std::f64::consts::E,
            lo: 1.4456468917292502e-16,
        };
        assert!(close(one.exp(), e, 1e-31));
        assert!(close(e.ln(), one, 1e-31));
        assert!(close(Dd::new(0.5).ln().exp(), Dd::new(0.5), 1e-31));
        // sin²+cos² = 1, sin(π/6) = ½
        for &x in &[0.3, 1.0, 2.5, -4.0, 10.0] {
            let x = Dd::new(x);
            let (s, c) = (x.sin(), x.cos());
            assert!(close(s * s + c * c, one, 1e-30));
        }
        assert!(close((Dd::PI / Dd::new(6.0)).sin(), Dd::new(0.5), 1e-31));
        assert!(close(
            Real::powf(Dd::new(2.0), lasalle_model::ir::Rational::new(-3, 2))
                * Dd::new(2.0).sqrt()
                * Dd::new(2.0),
            one,
            1e-31
        ));
    }
}
