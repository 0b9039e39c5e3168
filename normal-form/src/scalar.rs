//! Coefficient scalars: the ring the series algebra works over ([`Coeff`]) and the real
//! fields with elementary functions ([`Real`]): `f64` and [`Dd`](crate::Dd).
//!
//! # Why these traits and not one
//!
//! Three numeric trait families meet in lasalle, each for what its users need and the others
//! cannot give:
//! - `num_traits::Float`, in the emitted Rust: the standard trait that user code, nalgebra
//!   and dual-number crates already implement, so a compiled model runs over `f32`, `f64` or
//!   a user's type. It demands what series cannot give (ordering, classification, `NaN`,
//!   `max`, a total set of elementary functions).
//! - [`Scalar`](crate::Scalar) (the generator's `ir::Scalar`), to evaluate a model's graph:
//!   the minimum a DAG evaluation needs (constants, +, ·, 1/x, integer and *exact rational*
//!   powers, exp, ln, sin, cos, optionally the elliptic functions), implemented by `f64`, by
//!   [`Dd`](crate::Dd) and by the truncated series ([`Jet`](crate::Jet)) — no ordering, no
//!   classification, which jets do not have.
//! - [`Coeff`] and [`Real`], for the series algebra itself: [`Coeff`] is a field with exact
//!   `f64` literals and a fused multiply-accumulate product kernel (complex coefficients of
//!   either precision implement it, and are not [`Scalar`](crate::Scalar): they have no
//!   `powf` with a real rational exponent that the graph could need); [`Real`] adds what the
//!   linear algebra and the bounds need — ordering, |x|, √, π, the precision's unit roundoff
//!   and the exact `hi + lo` split of double-double.
//!
//! [`Scalar`](crate::Scalar) and [`Coeff`] are re-exported/defined here because they appear in
//! this crate's API (`HamiltonianFn::eval` is generic over [`Scalar`](crate::Scalar), whose
//! `powf` takes a [`Rational`](crate::Rational)).

use lasalle_model::ir::Rational;
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
    /// The product kernel: `out[lk[ka[i] + kb[j]]] += a[i]·b[j]` for all i, j.
    ///
    /// The keys must be those of a [`MonomialTable`](crate::MonomialTable) (so every sum of
    /// keys is a valid entry of `lk` pointing into `out`); this is checked in debug builds
    /// only. Scalars may override it with a faster loop (double-double does).
    #[inline]
    fn mul_acc_kernel(
        out: &mut [Self],
        a: &[Self],
        ka: &[u32],
        b: &[Self],
        kb: &[u32],
        lk: &[u32],
    ) {
        generic_kernel(out, a, ka, b, kb, lk, |o, x, y| o.mul_acc(x, y));
    }
}

/// The product loop with a custom multiply-accumulate.
#[inline(always)]
pub(crate) fn generic_kernel<T: Copy + Coeff>(
    out: &mut [T],
    a: &[T],
    ka: &[u32],
    b: &[T],
    kb: &[u32],
    lk: &[u32],
    acc: impl Fn(&mut T, T, T),
) {
    assert!(ka.len() == a.len() && kb.len() == b.len());
    for (i, &ca) in a.iter().enumerate() {
        if ca.is_zero() {
            continue;
        }
        let base = ka[i];
        for (&cb, &k) in b.iter().zip(kb) {
            let key = (base + k) as usize;
            debug_assert!(key < lk.len() && (lk[key] as usize) < out.len());
            // SAFETY: keys of two monomial tables add to a key of the product degree, which
            // the lookup table maps to a valid index of `out` (see MonomialTable).
            unsafe {
                let idx = *lk.get_unchecked(key) as usize;
                acc(out.get_unchecked_mut(idx), ca, cb);
            }
        }
    }
}

/// A real scalar with the elementary functions: `f64`, [`Dd`](crate::Dd) or
/// [`Qd`](crate::Qd).
pub trait Real: Coeff + PartialOrd {
    /// Name of the precision, for reports ("f64", "dd", "qd").
    const NAME: &'static str;
    /// Unit roundoff of the arithmetic (2⁻⁵³ for f64, about 2⁻¹⁰⁴ for double-double, 2⁻²⁰⁹
    /// for quad-double).
    const EPSILON: f64;
    /// The precision of the frequencies, the small divisors and the linear normalisation of
    /// a run in this precision: at least double-double (the divisors amplify every error in
    /// ω), and this precision itself when it is wider.
    type Wide: Real;
    /// The value as four non-overlapping f64 words, largest first (exact for f64, Dd, Qd).
    fn words(self) -> [f64; 4] {
        let (hi, lo) = self.hi_lo();
        [hi, lo, 0.0, 0.0]
    }
    /// The sum of four words in this precision (rounded when narrower).
    fn from_words(w: [f64; 4]) -> Self {
        Self::from_hi_lo(w[0], w[1] + (w[2] + w[3]))
    }
    /// A value of another precision, converted through its words (exact when widening).
    fn convert<S: Real>(x: S) -> Self {
        Self::from_words(x.words())
    }
    /// Rounded to f64.
    fn to_f64(self) -> f64;
    /// The value as an unevaluated sum `hi + lo` of two f64 (lo = 0 for f64).
    fn hi_lo(self) -> (f64, f64);
    /// `hi + lo` in this precision (rounded for f64).
    fn from_hi_lo(hi: f64, lo: f64) -> Self;
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
    /// selfᵖ for an exact rational p (self > 0 unless p is an integer). Integers and
    /// multiples of ½ go through powering and √; any other p = num/den is formed in the
    /// working precision, `exp(ln(self)·num/den)`, so double-double keeps its 32 digits for
    /// exponents like ⅓.
    fn powf(self, p: Rational) -> Self {
        match p.den {
            1 => powi(self, p.num as i64),
            2 => powi(self.sqrt(), p.num as i64),
            _ => (self.ln() * (Self::from_f64(p.num as f64) / Self::from_f64(p.den as f64))).exp(),
        }
    }
    /// [`Coeff::mul_acc_kernel`] for complex coefficients over this real type.
    #[inline]
    fn complex_kernel(
        out: &mut [crate::Complex<Self>],
        a: &[crate::Complex<Self>],
        ka: &[u32],
        b: &[crate::Complex<Self>],
        kb: &[u32],
        lk: &[u32],
    ) {
        generic_kernel(out, a, ka, b, kb, lk, |o, x, y| o.mul_acc(x, y));
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

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
unsafe fn complex_kernel_f64_fma(
    out: &mut [crate::Complex<f64>],
    a: &[crate::Complex<f64>],
    ka: &[u32],
    b: &[crate::Complex<f64>],
    kb: &[u32],
    lk: &[u32],
) {
    generic_kernel(out, a, ka, b, kb, lk, |o, x, y| {
        o.re = x.re.mul_add(y.re, (-x.im).mul_add(y.im, o.re));
        o.im = x.re.mul_add(y.im, x.im.mul_add(y.re, o.im));
    });
}

impl Real for f64 {
    const NAME: &'static str = "f64";
    type Wide = crate::Dd;
    fn complex_kernel(
        out: &mut [crate::Complex<f64>],
        a: &[crate::Complex<f64>],
        ka: &[u32],
        b: &[crate::Complex<f64>],
        kb: &[u32],
        lk: &[u32],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("fma") {
            // SAFETY: FMA is available; keys as documented on `Coeff::mul_acc_kernel`.
            return unsafe { complex_kernel_f64_fma(out, a, ka, b, kb, lk) };
        }
        generic_kernel(out, a, ka, b, kb, lk, |o, x, y| o.mul_acc(x, y));
    }
    const EPSILON: f64 = f64::EPSILON / 2.0;
    fn to_f64(self) -> f64 {
        self
    }
    fn hi_lo(self) -> (f64, f64) {
        (self, 0.0)
    }
    fn from_hi_lo(hi: f64, lo: f64) -> Self {
        hi + lo
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
    fn powf(self, p: Rational) -> Self {
        match (p.num, p.den) {
            (n, 1) => f64::powi(self, n),
            (1, 2) => f64::sqrt(self),
            (-1, 2) => 1.0 / f64::sqrt(self),
            (1, 3) => f64::cbrt(self),
            _ => f64::powf(self, p.num as f64 / p.den as f64),
        }
    }
}

/// The expression evaluator's scalar (`lasalle_model::ir::Scalar`, for `Graph::eval`) of a
/// [`Real`] type, by its arithmetic and elementary functions: one implementation for
/// double-double, quad-double and intervals.
macro_rules! scalar_by_real {
    ($t:ty) => {
        impl lasalle_model::ir::Scalar for $t {
            fn from_f64(c: f64) -> Self {
                <$t as $crate::scalar::Coeff>::from_f64(c)
            }
            fn add(&self, o: &Self) -> Self {
                *self + *o
            }
            fn mul(&self, o: &Self) -> Self {
                *self * *o
            }
            fn recip(&self) -> Self {
                <$t as $crate::scalar::Coeff>::from_f64(1.0) / *self
            }
            fn powi(&self, n: i32) -> Self {
                $crate::scalar::powi(*self, n as i64)
            }
            fn powf(&self, p: lasalle_model::ir::Rational) -> Self {
                $crate::scalar::Real::powf(*self, p)
            }
            fn exp(&self) -> Self {
                $crate::scalar::Real::exp(*self)
            }
            fn ln(&self) -> Self {
                $crate::scalar::Real::ln(*self)
            }
            fn sin(&self) -> Self {
                $crate::scalar::Real::sin(*self)
            }
            fn cos(&self) -> Self {
                $crate::scalar::Real::cos(*self)
            }
            fn neg(&self) -> Self {
                -*self
            }
            fn sub(&self, o: &Self) -> Self {
                *self - *o
            }
            fn div(&self, o: &Self) -> Self {
                *self / *o
            }
            fn sqrt(&self) -> Self {
                $crate::scalar::Real::sqrt(*self)
            }
        }
    };
}
pub(crate) use scalar_by_real;
