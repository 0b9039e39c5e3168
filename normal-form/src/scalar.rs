//! Coefficient scalars: the ring the series algebra works over ([`Coeff`]) and the real
//! fields with elementary functions ([`Real`]): `f64` and [`Dd`](crate::Dd).

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A coefficient of a truncated polynomial: a field with `f64` literals.
///
/// Implemented for `f64`, [`Dd`](crate::Dd) and [`Complex`](crate::Complex) of either.
pub trait Coeff:
    Copy
    + Debug
    + PartialEq
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
{
    /// 0
    fn zero() -> Self;
    /// 1
    fn one() -> Self;
    /// The literal `x` (exact).
    fn from_f64(x: f64) -> Self;
    /// Exactly zero?
    fn is_zero(&self) -> bool;
    /// |self| rounded to f64 (the modulus for complex numbers).
    fn magnitude(&self) -> f64;
    /// Are all parts finite?
    fn is_finite(&self) -> bool;
    /// `self += a·b`.
    #[inline(always)]
    fn mul_acc(&mut self, a: Self, b: Self) {
        *self += a * b;
    }
    /// `self · s` for an f64 `s` (exact conversion of `s`).
    #[inline(always)]
    fn scale(self, s: f64) -> Self {
        self * Self::from_f64(s)
    }
}

/// A real scalar with the elementary functions: `f64` or [`Dd`](crate::Dd).
pub trait Real: Coeff + PartialOrd {
    /// Name of the precision, for reports ("f64", "dd").
    const NAME: &'static str;
    /// Unit roundoff of the arithmetic (2⁻⁵³ for f64, about 2⁻¹⁰⁴ for double-double).
    const EPSILON: f64;
    /// Rounded to f64.
    fn to_f64(self) -> f64;
    /// The value as an unevaluated sum `hi + lo` of two f64 (lo = 0 for f64).
    fn hi_lo(self) -> (f64, f64);
    /// |self|
    fn abs(self) -> Self;
    /// √self
    fn sqrt(self) -> Self;
    /// eˢᵉˡᶠ
    fn exp(self) -> Self;
    /// ln self
    fn ln(self) -> Self;
    /// sin self
    fn sin(self) -> Self;
    /// cos self
    fn cos(self) -> Self;
    /// π
    fn pi() -> Self;
    /// selfᵖ for self > 0; exact for p a multiple of ½.
    fn powf(self, p: f64) -> Self {
        let twice = 2.0 * p;
        if twice == twice.round() && twice.abs() < 1e6 {
            let n = twice as i64;
            let base = if n % 2 == 0 { self } else { self.sqrt() };
            let k = if n % 2 == 0 { n / 2 } else { n };
            powi(base, k)
        } else {
            (self.ln() * Self::from_f64(p)).exp()
        }
    }
    /// sign of self as −1, 0, +1
    fn signum_f64(self) -> f64 {
        let x = self.to_f64();
        if x > 0.0 {
            1.0
        } else if x < 0.0 {
            -1.0
        } else {
            0.0
        }
    }
}

/// xⁿ by binary powering (n may be negative).
pub fn powi<T: Coeff>(x: T, n: i64) -> T {
    if n < 0 {
        return T::one() / powi(x, -n);
    }
    let (mut acc, mut base, mut k) = (T::one(), x, n as u64);
    while k > 0 {
        if k & 1 == 1 {
            acc *= base;
        }
        base *= base;
        k >>= 1;
    }
    acc
}

impl Coeff for f64 {
    #[inline(always)]
    fn zero() -> Self {
        0.0
    }
    #[inline(always)]
    fn one() -> Self {
        1.0
    }
    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn is_zero(&self) -> bool {
        *self == 0.0
    }
    #[inline(always)]
    fn magnitude(&self) -> f64 {
        f64::abs(*self)
    }
    #[inline(always)]
    fn is_finite(&self) -> bool {
        f64::is_finite(*self)
    }
    #[inline(always)]
    fn scale(self, s: f64) -> Self {
        self * s
    }
}

impl Real for f64 {
    const NAME: &'static str = "f64";
    const EPSILON: f64 = f64::EPSILON / 2.0;
    fn to_f64(self) -> f64 {
        self
    }
    fn hi_lo(self) -> (f64, f64) {
        (self, 0.0)
    }
    fn abs(self) -> Self {
        f64::abs(self)
    }
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    fn exp(self) -> Self {
        f64::exp(self)
    }
    fn ln(self) -> Self {
        f64::ln(self)
    }
    fn sin(self) -> Self {
        f64::sin(self)
    }
    fn cos(self) -> Self {
        f64::cos(self)
    }
    fn pi() -> Self {
        std::f64::consts::PI
    }
    fn powf(self, p: f64) -> Self {
        if p == 0.5 {
            f64::sqrt(self)
        } else if p == -0.5 {
            1.0 / f64::sqrt(self)
        } else if p == p.round() && p.abs() < 1e9 {
            f64::powi(self, p as i32)
        } else {
            f64::powf(self, p)
        }
    }
}
