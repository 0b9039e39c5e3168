//! Double-double arithmetic: an unevaluated sum `hi + lo` of two f64 with |lo| ≤ ½ulp(hi),
//! about 106 bits (≈ 32 decimal digits) of precision.
//!
//! The algorithms are the classical error-free transformations (Dekker 1971, Knuth's TwoSum)
//! as used in Hida, Li & Bailey's QD library: addition is the accurate ("IEEE") variant, so
//! cancellation keeps a relative error of a few 2⁻¹⁰⁶. Products use Dekker's splitting unless
//! the crate is compiled with the `fma` target feature, in which case `f64::mul_add` gives
//! the exact product error in one instruction.

use crate::complex::Complex;
use crate::scalar::{generic_kernel, Coeff, Real};
use std::fmt;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

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
        // SAFETY: as for `complex_kernel`.
        unsafe {
            #[cfg(target_arch = "x86_64")]
            if has_avx2_fma() {
                return avx::real_kernel(out, a, ka, b, kb, lk);
            }
            #[cfg(target_arch = "x86_64")]
            if has_fma() {
                return real_kernel_fma(out, a, ka, b, kb, lk);
            }
            real_kernel_plain(out, a, ka, b, kb, lk)
        }
    }
}

/// `c + a·b + x·y` with one renormalisation: the two exact products (TwoProd) and the two
/// exact sums of the leading parts, all error terms gathered in the tail. The error is a few
/// 2⁻¹⁰⁶ relative to |c| + |a·b| + |x·y| (as for any accumulation).
#[inline(always)]
fn acc2(c: Dd, a: Dd, b: Dd, x: Dd, y: Dd, tp: impl Fn(f64, f64) -> (f64, f64)) -> Dd {
    let (p, e1) = tp(a.hi, b.hi);
    let (q, e2) = tp(x.hi, y.hi);
    let cross = (a.hi * b.lo + a.lo * b.hi) + (x.hi * y.lo + x.lo * y.hi);
    let (s, f) = two_sum(c.hi, p);
    let (s, g) = two_sum(s, q);
    let lo = c.lo + ((e1 + e2) + (cross + (f + g)));
    let (hi, lo) = quick_two_sum(s, lo);
    Dd { hi, lo }
}

/// [`acc2`] with FMA: the cross terms `a.hi·b.lo + a.lo·b.hi + x.hi·y.lo + x.lo·y.hi` by
/// three fused multiply-adds (the lane arithmetic of the AVX2 kernel, bit for bit).
#[inline(always)]
fn acc2_fma(c: Dd, a: Dd, b: Dd, x: Dd, y: Dd) -> Dd {
    let (p, e1) = two_prod_fma(a.hi, b.hi);
    let (q, e2) = two_prod_fma(x.hi, y.hi);
    let cross =
        a.hi.mul_add(b.lo, a.lo.mul_add(b.hi, x.hi.mul_add(y.lo, x.lo * y.hi)));
    let (s, f) = two_sum(c.hi, p);
    let (s, g) = two_sum(s, q);
    let lo = c.lo + ((e1 + e2) + (cross + (f + g)));
    let (hi, lo) = quick_two_sum(s, lo);
    Dd { hi, lo }
}

/// `c + a·b`, same scheme.
#[inline(always)]
fn acc1(c: Dd, a: Dd, b: Dd, tp: impl Fn(f64, f64) -> (f64, f64)) -> Dd {
    let (p, e1) = tp(a.hi, b.hi);
    let cross = a.hi * b.lo + a.lo * b.hi;
    let (s, f) = two_sum(c.hi, p);
    let lo = c.lo + (e1 + (cross + f));
    let (hi, lo) = quick_two_sum(s, lo);
    Dd { hi, lo }
}

/// [`acc1`] with FMA (the cross term `a.hi·b.lo + a.lo·b.hi` fused; the lane arithmetic of
/// the AVX2 kernel, bit for bit).
#[inline(always)]
fn acc1_fma(c: Dd, a: Dd, b: Dd) -> Dd {
    let (p, e1) = two_prod_fma(a.hi, b.hi);
    let cross = a.hi.mul_add(b.lo, a.lo * b.hi);
    let (s, f) = two_sum(c.hi, p);
    let lo = c.lo + (e1 + (cross + f));
    let (hi, lo) = quick_two_sum(s, lo);
    Dd { hi, lo }
}

#[inline(always)]
fn two_prod_dekker(a: f64, b: f64) -> (f64, f64) {
    const SPLITTER: f64 = 134_217_729.0; // 2^27 + 1
    let p = a * b;
    let t = SPLITTER * a;
    let ah = t - (t - a);
    let al = a - ah;
    let t = SPLITTER * b;
    let bh = t - (t - b);
    let bl = b - bh;
    (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
}

#[inline(always)]
fn two_prod_fma(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

macro_rules! kernels {
    ($complex:ident, $real:ident, $acc1:expr, $acc2:expr $(, #[$attr:meta])?) => {
        $(#[$attr])?
        unsafe fn $complex(out: &mut [Complex<Dd>], a: &[Complex<Dd>], ka: &[u32], b: &[Complex<Dd>], kb: &[u32], lk: &[u32]) {
            generic_kernel(out, a, ka, b, kb, lk, |o, x, y| {
                o.re = $acc2(o.re, x.re, y.re, -x.im, y.im);
                o.im = $acc2(o.im, x.re, y.im, x.im, y.re);
            });
        }
        $(#[$attr])?
        unsafe fn $real(out: &mut [Dd], a: &[Dd], ka: &[u32], b: &[Dd], kb: &[u32], lk: &[u32]) {
            generic_kernel(out, a, ka, b, kb, lk, |o, x, y| *o = $acc1(*o, x, y));
        }
    };
}
kernels!(
    complex_kernel_plain,
    real_kernel_plain,
    |c, a, b| acc1(c, a, b, two_prod_dekker),
    |c, a, b, x, y| acc2(c, a, b, x, y, two_prod_dekker)
);
#[cfg(target_arch = "x86_64")]
kernels!(complex_kernel_fma, real_kernel_fma, acc1_fma, acc2_fma, #[target_feature(enable = "fma")]);

#[inline]
fn has_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

#[inline]
fn has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The complex double-double product kernel in AVX2: two products `out[·] += a[i]·b[j]`,
/// `a[i]·b[j+1]` at a time, the four lanes holding (re, im) of both. Per lane it is exactly
/// the scalar `acc2` (two TwoProds, the cross terms by FMA, two TwoSums, one renormalisation),
/// so the results are bit-for-bit those of `complex_kernel_fma` ([`acc2_fma`]).
#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{acc1_fma, acc2_fma, Complex, Dd};
    use std::arch::x86_64::*;

    /// (hi, lo) of two complex dd at `p` and `q` as lanes [re(p), im(p), re(q), im(q)].
    #[inline(always)]
    unsafe fn load2(p: *const f64, q: *const f64) -> (__m256d, __m256d) {
        let u = _mm256_loadu_pd(p); // [rh, rl, ih, il] of p
        let v = _mm256_loadu_pd(q);
        let t0 = _mm256_permute2f128_pd::<0x20>(u, v); // [rh_p, rl_p, rh_q, rl_q]
        let t1 = _mm256_permute2f128_pd::<0x31>(u, v); // [ih_p, il_p, ih_q, il_q]
        (_mm256_unpacklo_pd(t0, t1), _mm256_unpackhi_pd(t0, t1))
    }

    /// Inverse of [`load2`].
    #[inline(always)]
    unsafe fn store2(p: *mut f64, q: *mut f64, hi: __m256d, lo: __m256d) {
        let t0 = _mm256_unpacklo_pd(hi, lo); // [rh_p, rl_p, rh_q, rl_q]
        let t1 = _mm256_unpackhi_pd(hi, lo); // [ih_p, il_p, ih_q, il_q]
        _mm256_storeu_pd(p, _mm256_permute2f128_pd::<0x20>(t0, t1));
        _mm256_storeu_pd(q, _mm256_permute2f128_pd::<0x31>(t0, t1));
    }

    /// The real double-double product kernel, four products `a[i]·b[j..j+4]` at a time (lanes
    /// in the order j, j+2, j+1, j+3 of `unpacklo/hi`); per lane exactly [`acc1_fma`].
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn real_kernel(
        out: &mut [Dd],
        a: &[Dd],
        ka: &[u32],
        b: &[Dd],
        kb: &[u32],
        lk: &[u32],
    ) {
        assert!(ka.len() == a.len() && kb.len() == b.len());
        let o = out.as_mut_ptr() as *mut f64;
        let bp = b.as_ptr() as *const f64;
        let quads = b.len() / 4;
        for (i, &x) in a.iter().enumerate() {
            if x.hi == 0.0 {
                continue;
            }
            let base = ka[i];
            let ah = _mm256_set1_pd(x.hi);
            let al = _mm256_set1_pd(x.lo);
            for jq in 0..quads {
                let j = 4 * jq;
                let mut idx = [0usize; 4];
                for (m, id) in idx.iter_mut().enumerate() {
                    let k = (base + *kb.get_unchecked(j + m)) as usize;
                    debug_assert!(k < lk.len());
                    *id = *lk.get_unchecked(k) as usize;
                    debug_assert!(*id < out.len());
                }
                let u = _mm256_loadu_pd(bp.add(2 * j)); // [h0, l0, h1, l1]
                let v = _mm256_loadu_pd(bp.add(2 * j + 4)); // [h2, l2, h3, l3]
                let bh = _mm256_unpacklo_pd(u, v); // [h0, h2, h1, h3]
                let bl = _mm256_unpackhi_pd(u, v);
                let p = [
                    o.add(2 * idx[0]),
                    o.add(2 * idx[1]),
                    o.add(2 * idx[2]),
                    o.add(2 * idx[3]),
                ];
                let cu = _mm256_insertf128_pd::<1>(
                    _mm256_castpd128_pd256(_mm_loadu_pd(p[0])),
                    _mm_loadu_pd(p[1]),
                );
                let cv = _mm256_insertf128_pd::<1>(
                    _mm256_castpd128_pd256(_mm_loadu_pd(p[2])),
                    _mm_loadu_pd(p[3]),
                );
                let ch = _mm256_unpacklo_pd(cu, cv);
                let cl = _mm256_unpackhi_pd(cu, cv);
                let prod = _mm256_mul_pd(ah, bh);
                let e1 = _mm256_fmsub_pd(ah, bh, prod);
                let cross = _mm256_fmadd_pd(ah, bl, _mm256_mul_pd(al, bh));
                let s = _mm256_add_pd(ch, prod);
                let bb = _mm256_sub_pd(s, ch);
                let f = _mm256_add_pd(
                    _mm256_sub_pd(ch, _mm256_sub_pd(s, bb)),
                    _mm256_sub_pd(prod, bb),
                );
                let lo = _mm256_add_pd(cl, _mm256_add_pd(e1, _mm256_add_pd(cross, f)));
                let hi = _mm256_add_pd(s, lo);
                let lo = _mm256_sub_pd(lo, _mm256_sub_pd(hi, s));
                let ru = _mm256_unpacklo_pd(hi, lo); // [h0, l0, h1, l1]
                let rv = _mm256_unpackhi_pd(hi, lo); // [h2, l2, h3, l3]
                _mm_storeu_pd(p[0], _mm256_castpd256_pd128(ru));
                _mm_storeu_pd(p[1], _mm256_extractf128_pd::<1>(ru));
                _mm_storeu_pd(p[2], _mm256_castpd256_pd128(rv));
                _mm_storeu_pd(p[3], _mm256_extractf128_pd::<1>(rv));
            }
            for j in 4 * quads..b.len() {
                let idx = *lk.get_unchecked((base + kb[j]) as usize) as usize;
                let c = out.get_unchecked_mut(idx);
                *c = acc1_fma(*c, x, b[j]);
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn complex_kernel(
        out: &mut [Complex<Dd>],
        a: &[Complex<Dd>],
        ka: &[u32],
        b: &[Complex<Dd>],
        kb: &[u32],
        lk: &[u32],
    ) {
        assert!(ka.len() == a.len() && kb.len() == b.len());
        let o = out.as_mut_ptr() as *mut f64;
        let bp = b.as_ptr() as *const f64;
        let pairs = b.len() / 2;
        for (i, &x) in a.iter().enumerate() {
            if x.re.hi == 0.0 && x.im.hi == 0.0 {
                continue;
            }
            let base = ka[i];
            // re lane: xr·yr + (−xi)·yi ; im lane: xr·yi + xi·yr
            let ah = _mm256_set1_pd(x.re.hi);
            let al = _mm256_set1_pd(x.re.lo);
            let xh = _mm256_setr_pd(-x.im.hi, x.im.hi, -x.im.hi, x.im.hi);
            let xl = _mm256_setr_pd(-x.im.lo, x.im.lo, -x.im.lo, x.im.lo);
            for jj in 0..pairs {
                let j = 2 * jj;
                let k0 = (base + *kb.get_unchecked(j)) as usize;
                let k1 = (base + *kb.get_unchecked(j + 1)) as usize;
                debug_assert!(k0 < lk.len() && k1 < lk.len());
                let i0 = *lk.get_unchecked(k0) as usize;
                let i1 = *lk.get_unchecked(k1) as usize;
                debug_assert!(i0 < out.len() && i1 < out.len() && i0 != i1);
                let (bh, bl) = load2(bp.add(4 * j), bp.add(4 * j + 4));
                let yh = _mm256_permute_pd::<0b0101>(bh);
                let yl = _mm256_permute_pd::<0b0101>(bl);
                let (p0, p1) = (o.add(4 * i0), o.add(4 * i1));
                let (ch, cl) = load2(p0, p1);
                let p = _mm256_mul_pd(ah, bh);
                let e1 = _mm256_fmsub_pd(ah, bh, p);
                let q = _mm256_mul_pd(xh, yh);
                let e2 = _mm256_fmsub_pd(xh, yh, q);
                let cross = _mm256_fmadd_pd(
                    ah,
                    bl,
                    _mm256_fmadd_pd(al, bh, _mm256_fmadd_pd(xh, yl, _mm256_mul_pd(xl, yh))),
                );
                // (s, f) = TwoSum(c.hi, p)
                let s = _mm256_add_pd(ch, p);
                let bb = _mm256_sub_pd(s, ch);
                let f = _mm256_add_pd(
                    _mm256_sub_pd(ch, _mm256_sub_pd(s, bb)),
                    _mm256_sub_pd(p, bb),
                );
                // (s2, g) = TwoSum(s, q)
                let s2 = _mm256_add_pd(s, q);
                let bb = _mm256_sub_pd(s2, s);
                let g = _mm256_add_pd(
                    _mm256_sub_pd(s, _mm256_sub_pd(s2, bb)),
                    _mm256_sub_pd(q, bb),
                );
                let lo = _mm256_add_pd(
                    cl,
                    _mm256_add_pd(
                        _mm256_add_pd(e1, e2),
                        _mm256_add_pd(cross, _mm256_add_pd(f, g)),
                    ),
                );
                // QuickTwoSum(s2, lo)
                let hi = _mm256_add_pd(s2, lo);
                let lo = _mm256_sub_pd(lo, _mm256_sub_pd(hi, s2));
                store2(p0, p1, hi, lo);
            }
            if b.len() % 2 == 1 {
                let j = b.len() - 1;
                let idx = *lk.get_unchecked((base + kb[j]) as usize) as usize;
                let y = b[j];
                let c = out.get_unchecked_mut(idx);
                c.re = acc2_fma(c.re, x.re, y.re, -x.im, y.im);
                c.im = acc2_fma(c.im, x.re, y.im, x.im, y.re);
            }
        }
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
        // SAFETY: the fma variant runs only when the CPU has FMA, the AVX2 one only with AVX2
        // and FMA; all rely on the key invariant documented on `Coeff::mul_acc_kernel`.
        unsafe {
            #[cfg(target_arch = "x86_64")]
            if has_avx2_fma() {
                return avx::complex_kernel(out, a, ka, b, kb, lk);
            }
            #[cfg(target_arch = "x86_64")]
            if has_fma() {
                return complex_kernel_fma(out, a, ka, b, kb, lk);
            }
            complex_kernel_plain(out, a, ka, b, kb, lk)
        }
    }
    const NAME: &'static str = "dd";
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

    /// The kernels agree bit for bit (AVX2 vs scalar FMA) and with plain dd arithmetic to
    /// ~1e-31.
    #[test]
    fn complex_kernels_agree() {
        use crate::MonomialTable;
        let t = MonomialTable::new(4, 9);
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let x = (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            Dd::new(x) + Dd::new(x * 1e-17)
        };
        let (da, db) = (4, 5);
        let a: Vec<Complex<Dd>> = (0..t.count(da))
            .map(|_| Complex::new(rnd(), rnd()))
            .collect();
        let b: Vec<Complex<Dd>> = (0..t.count(db))
            .map(|_| Complex::new(rnd(), rnd()))
            .collect();
        let (ka, kb, lk) = (
            &t.degree(da).keys,
            &t.degree(db).keys,
            &t.degree(da + db).lookup,
        );
        let zero = vec![Complex::new(Dd::new(0.0), Dd::new(0.0)); t.count(da + db)];
        let mut reference = zero.clone();
        generic_kernel(&mut reference, &a, ka, &b, kb, lk, |o, x, y| *o += x * y);
        let mut plain = zero.clone();
        unsafe { complex_kernel_plain(&mut plain, &a, ka, &b, kb, lk) };
        let close = |u: &[Complex<Dd>]| {
            u.iter().zip(&reference).all(|(x, y)| {
                (x.re - y.re).to_f64().abs() < 1e-30 && (x.im - y.im).to_f64().abs() < 1e-30
            })
        };
        assert!(close(&plain));
        #[cfg(target_arch = "x86_64")]
        if has_avx2_fma() {
            let mut f = zero.clone();
            unsafe { complex_kernel_fma(&mut f, &a, ka, &b, kb, lk) };
            let mut v = zero.clone();
            unsafe { avx::complex_kernel(&mut v, &a, ka, &b, kb, lk) };
            assert!(close(&f));
            assert_eq!(f, v);
            // odd length of b
            let (mut f, mut v) = (zero.clone(), zero.clone());
            let n = b.len() - 1;
            unsafe { complex_kernel_fma(&mut f, &a, ka, &b[..n], &kb[..n], lk) };
            unsafe { avx::complex_kernel(&mut v, &a, ka, &b[..n], &kb[..n], lk) };
            assert_eq!(f, v);
        }
    }

    #[test]
    fn real_kernels_agree() {
        use crate::MonomialTable;
        let t = MonomialTable::new(4, 11);
        let mut seed = 987u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let x = (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            Dd::new(x) + Dd::new(x * 1e-17)
        };
        for (da, db) in [(3, 5), (4, 6), (1, 7), (2, 2)] {
            let a: Vec<Dd> = (0..t.count(da)).map(|_| rnd()).collect();
            let b: Vec<Dd> = (0..t.count(db)).map(|_| rnd()).collect();
            let (ka, kb, lk) = (
                &t.degree(da).keys,
                &t.degree(db).keys,
                &t.degree(da + db).lookup,
            );
            let zero = vec![Dd::new(0.0); t.count(da + db)];
            let mut reference = zero.clone();
            generic_kernel(&mut reference, &a, ka, &b, kb, lk, |o, x, y| *o += x * y);
            let mut plain = zero.clone();
            unsafe { real_kernel_plain(&mut plain, &a, ka, &b, kb, lk) };
            assert!(plain
                .iter()
                .zip(&reference)
                .all(|(x, y)| (*x - *y).to_f64().abs() < 1e-30));
            #[cfg(target_arch = "x86_64")]
            if has_avx2_fma() {
                let (mut f, mut v) = (zero.clone(), zero.clone());
                unsafe { real_kernel_fma(&mut f, &a, ka, &b, kb, lk) };
                unsafe { avx::real_kernel(&mut v, &a, ka, &b, kb, lk) };
                assert_eq!(f, v);
            }
        }
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
            Real::powf(Dd::new(2.0), lasalle_codegen::ir::Rational::new(-3, 2))
                * Dd::new(2.0).sqrt()
                * Dd::new(2.0),
            one,
            1e-31
        ));
    }
}
