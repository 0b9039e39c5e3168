//! A minimal complex number over any [`Real`].

use crate::scalar::{Coeff, Real};
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// `re + i·im` over a real scalar `R` (f64 or [`Dd`](crate::Dd)); `repr(C)`, so a
/// `Complex<Dd>` is `[re.hi, re.lo, im.hi, im.lo]` (the SIMD kernels rely on it).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[repr(C)]
pub struct Complex<R> {
    /// Real part.
    pub re: R,
    /// Imaginary part.
    pub im: R,
}

impl<R: Real> Complex<R> {
    /// `re + i·im`
    #[inline(always)]
    pub fn new(re: R, im: R) -> Self {
        Complex { re, im }
    }
    /// A real number.
    #[inline(always)]
    pub fn real(re: R) -> Self {
        Complex { re, im: R::zero() }
    }
    /// i
    pub fn i() -> Self {
        Complex {
            re: R::zero(),
            im: R::one(),
        }
    }
    /// Complex conjugate.
    #[inline(always)]
    pub fn conj(self) -> Self {
        Complex {
            re: self.re,
            im: -self.im,
        }
    }
    /// |z|² in R.
    #[inline(always)]
    pub fn norm_sqr(self) -> R {
        self.re * self.re + self.im * self.im
    }
    /// |z| in R.
    pub fn abs(self) -> R {
        self.norm_sqr().sqrt()
    }
    /// i·self
    #[inline(always)]
    pub fn mul_i(self) -> Self {
        Complex {
            re: -self.im,
            im: self.re,
        }
    }
    /// self · r for real r.
    #[inline(always)]
    pub fn scale_r(self, r: R) -> Self {
        Complex {
            re: self.re * r,
            im: self.im * r,
        }
    }
    /// Principal square root.
    pub fn sqrt(self) -> Self {
        let r = self.abs();
        if r.is_zero() {
            return self;
        }
        let half = R::from_f64(0.5);
        let a = ((r + self.re.abs()) * half).sqrt();
        if self.re >= R::zero() {
            Complex::new(a, self.im / (a + a))
        } else {
            let b = if self.im >= R::zero() { a } else { -a };
            Complex::new(self.im.abs() / (a + a), b)
        }
    }
    /// (re, im) rounded to f64.
    pub fn to_f64(self) -> (f64, f64) {
        (self.re.to_f64(), self.im.to_f64())
    }
}

impl<R: Real> Add for Complex<R> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Complex {
            re: self.re + o.re,
            im: self.im + o.im,
        }
    }
}
impl<R: Real> Sub for Complex<R> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Complex {
            re: self.re - o.re,
            im: self.im - o.im,
        }
    }
}
impl<R: Real> Mul for Complex<R> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Complex {
            re: self.re * o.re - self.im * o.im,
            im: self.re * o.im + self.im * o.re,
        }
    }
}
impl<R: Real> Div for Complex<R> {
    type Output = Self;
    fn div(self, o: Self) -> Self {
        let d = o.norm_sqr();
        let n = self * o.conj();
        Complex {
            re: n.re / d,
            im: n.im / d,
        }
    }
}
impl<R: Real> Neg for Complex<R> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Complex {
            re: -self.re,
            im: -self.im,
        }
    }
}
impl<R: Real> AddAssign for Complex<R> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        self.re += o.re;
        self.im += o.im;
    }
}
impl<R: Real> SubAssign for Complex<R> {
    #[inline(always)]
    fn sub_assign(&mut self, o: Self) {
        self.re -= o.re;
        self.im -= o.im;
    }
}
impl<R: Real> MulAssign for Complex<R> {
    #[inline(always)]
    fn mul_assign(&mut self, o: Self) {
        *self = *self * o;
    }
}

impl<R: Real> Coeff for Complex<R> {
    #[inline(always)]
    fn zero() -> Self {
        Complex {
            re: R::zero(),
            im: R::zero(),
        }
    }
    #[inline(always)]
    fn one() -> Self {
        Complex {
            re: R::one(),
            im: R::zero(),
        }
    }
    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        Complex {
            re: R::from_f64(x),
            im: R::zero(),
        }
    }
    #[inline(always)]
    fn is_zero(&self) -> bool {
        self.re.is_zero() && self.im.is_zero()
    }
    fn magnitude(&self) -> f64 {
        self.re.to_f64().hypot(self.im.to_f64())
    }
    fn is_finite(&self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
    #[inline(always)]
    fn mul_acc(&mut self, a: Self, b: Self) {
        self.re.mul_acc(a.re, b.re);
        self.re.mul_acc(-a.im, b.im);
        self.im.mul_acc(a.re, b.im);
        self.im.mul_acc(a.im, b.re);
    }
    #[inline(always)]
    fn scale(self, s: f64) -> Self {
        Complex {
            re: self.re.scale(s),
            im: self.im.scale(s),
        }
    }
    #[inline]
    fn mul_acc_kernel(
        out: &mut [Self],
        a: &[Self],
        ka: &[u32],
        b: &[Self],
        kb: &[u32],
        lk: &[u32],
    ) {
        R::complex_kernel(out, a, ka, b, kb, lk);
    }
}
