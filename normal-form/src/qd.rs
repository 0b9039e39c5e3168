//! Quad-double arithmetic: an unevaluated sum `x₀ + x₁ + x₂ + x₃` of four non-overlapping
//! f64, about 212 bits (≈ 64 decimal digits) of precision.
//!
//! The algorithms are those of Hida, Li & Bailey, "Algorithms for quad-double precision
//! floating point arithmetic" (ARITH-15, 2001): addition is their IEEE-style merge of the
//! eight components with a two-word running accumulator (`quick_three_accum`), so
//! cancellation keeps a relative error of a few 2⁻²¹²; multiplication forms the products
//! `a_i b_j` with i + j ≤ 2 exactly (TwoProd, by FMA), the i + j = 3 ones in f64, and
//! renormalises; division is long division with exact residuals; √ is Newton on 1/√x. The
//! elementary functions (exp, ln, sin, cos) use argument reduction and Taylor series as in
//! [`Dd`](crate::Dd), to 2⁻²¹⁰.
//!
//! It is the third precision of the normal form ([`Precision::QuadDouble`](crate::Precision)),
//! chosen when double-double loses the high-order coefficients (Sun–Jupiter L4 beyond
//! order 23). Plain `Copy` data, so the whole series algebra runs over it unchanged.

use crate::scalar::{Coeff, Real};
use crate::Dd;
use std::fmt;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A quad-double number `x[0] + x[1] + x[2] + x[3]`, with `|x[k+1]| ≤ ½ ulp(x[k])`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[repr(C)]
pub struct Qd {
    /// The components, largest first.
    pub x: [f64; 4],
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

#[inline(always)]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// (a, b, c) ← a three-term sum with the same value, a largest.
#[inline(always)]
fn three_sum(a: &mut f64, b: &mut f64, c: &mut f64) {
    let (t1, t2) = two_sum(*a, *b);
    let (s, t3) = two_sum(*c, t1);
    *a = s;
    let (u, v) = two_sum(t2, t3);
    *b = u;
    *c = v;
}

/// Adds c to the two-word accumulator (a, b); returns the word that no longer fits (or 0).
#[inline(always)]
fn quick_three_accum(a: &mut f64, b: &mut f64, c: f64) -> f64 {
    let (s, bb) = two_sum(*b, c);
    *b = bb;
    let (s, aa) = two_sum(*a, s);
    *a = aa;
    let (za, zb) = (*a != 0.0, *b != 0.0);
    if za && zb {
        return s;
    }
    if !zb {
        *b = *a;
        *a = s;
    } else {
        *a = s;
    }
    0.0
}

/// Renormalises five roughly decreasing words into a quad-double.
#[inline(always)]
fn renorm5(c0: f64, c1: f64, c2: f64, c3: f64, c4: f64) -> Qd {
    let (s, c4) = quick_two_sum(c3, c4);
    let (s, c3) = quick_two_sum(c2, s);
    let (s, c2) = quick_two_sum(c1, s);
    let (c0, c1) = quick_two_sum(c0, s);
    let (mut s2, mut s3) = (0.0, 0.0);
    let (mut s0, mut s1) = quick_two_sum(c0, c1);
    if s1 != 0.0 {
        (s1, s2) = quick_two_sum(s1, c2);
        if s2 != 0.0 {
            (s2, s3) = quick_two_sum(s2, c3);
            if s3 != 0.0 {
                s3 += c4;
            } else {
                s2 += c4;
            }
        } else {
            (s1, s2) = quick_two_sum(s1, c3);
            if s2 != 0.0 {
                (s2, s3) = quick_two_sum(s2, c4);
            } else {
                (s1, s2) = quick_two_sum(s1, c4);
            }
        }
    } else {
        (s0, s1) = quick_two_sum(s0, c2);
        if s1 != 0.0 {
            (s1, s2) = quick_two_sum(s1, c3);
            if s2 != 0.0 {
                (s2, s3) = quick_two_sum(s2, c4);
            } else {
                (s1, s2) = quick_two_sum(s1, c4);
            }
        } else {
            (s0, s1) = quick_two_sum(s0, c3);
            if s1 != 0.0 {
                (s1, s2) = quick_two_sum(s1, c4);
            } else {
                (s0, s1) = quick_two_sum(s0, c4);
            }
        }
    }
    Qd {
        x: [s0, s1, s2, s3],
    }
}

// the trailing words of the constants are written with 19 digits, as published
#[allow(clippy::excessive_precision)]
impl Qd {
    /// An f64 as a quad-double (exact).
    #[inline(always)]
    pub const fn new(x: f64) -> Qd {
        Qd {
            x: [x, 0.0, 0.0, 0.0],
        }
    }
    /// A double-double as a quad-double (exact).
    pub fn from_dd(d: Dd) -> Qd {
        renorm5(d.hi, d.lo, 0.0, 0.0, 0.0)
    }
    /// Rounded to double-double.
    pub fn to_dd(self) -> Dd {
        Dd::from_parts(self.x[0], self.x[1] + (self.x[2] + self.x[3]))
    }
    /// Four words, renormalised.
    pub fn from_words(w: [f64; 4]) -> Qd {
        renorm5(w[0], w[1], w[2], w[3], 0.0)
    }
    /// self · f for an f64 f.
    pub fn mul_f64(self, b: f64) -> Qd {
        let a = &self.x;
        let (p0, q0) = two_prod(a[0], b);
        let (p1, mut q1) = two_prod(a[1], b);
        let (mut p2, mut q2) = two_prod(a[2], b);
        let mut p3 = a[3] * b;
        let (s1, mut s2) = two_sum(q0, p1);
        three_sum(&mut s2, &mut q1, &mut p2);
        // three_sum2(q1, q2, p3)
        let (t1, t2) = two_sum(q1, q2);
        let (a1, t3) = two_sum(p3, t1);
        q1 = a1;
        q2 = t2 + t3;
        p3 = q1;
        let s4 = q2 + p2;
        renorm5(p0, s1, s2, p3, s4)
    }
    /// Multiplication by a power of two (exact).
    pub fn ldexp(self, k: i32) -> Qd {
        let f = 2f64.powi(k);
        Qd {
            x: self.x.map(|v| v * f),
        }
    }
    /// The largest integer ≤ self.
    pub fn floor(self) -> Qd {
        let mut r = [self.x[0].floor(), 0.0, 0.0, 0.0];
        if r[0] == self.x[0] {
            r[1] = self.x[1].floor();
            if r[1] == self.x[1] {
                r[2] = self.x[2].floor();
                if r[2] == self.x[2] {
                    r[3] = self.x[3].floor();
                }
            }
        }
        renorm5(r[0], r[1], r[2], r[3], 0.0)
    }
    /// Nearest integer (halves rounded up).
    pub fn round(self) -> Qd {
        (self + Qd::new(0.5)).floor()
    }
    /// π
    pub const PI: Qd = Qd {
        x: [
            std::f64::consts::PI,
            1.224_646_799_147_353_207e-16,
            -2.994_769_809_718_339_666e-33,
            1.112_454_220_863_365_282e-49,
        ],
    };
    /// π/2
    pub const FRAC_PI_2: Qd = Qd {
        x: [
            std::f64::consts::FRAC_PI_2,
            6.123_233_995_736_766_036e-17,
            -1.497_384_904_859_169_833e-33,
            5.562_271_104_316_826_408e-50,
        ],
    };
    /// ln 2
    pub const LN_2: Qd = Qd {
        x: [
            std::f64::consts::LN_2,
            2.319_046_813_846_299_558e-17,
            5.707_708_438_416_212_066e-34,
            -3.582_432_210_601_811_423e-50,
        ],
    };
    /// e
    pub const E: Qd = Qd {
        x: [
            std::f64::consts::E,
            1.445_646_891_729_250_158e-16,
            -2.127_717_108_038_176_765e-33,
            1.515_630_159_841_218_954e-49,
        ],
    };

    fn exp_impl(self) -> Qd {
        if self.x[0] > 709.0 {
            return Qd::new(f64::INFINITY);
        }
        if self.x[0] < -745.0 {
            return Qd::new(0.0);
        }
        // x = k ln2 + r, then e^r = (e^{r/2^16})^{2^16}
        let k = (self.x[0] / Qd::LN_2.x[0]).round();
        let r = (self - Qd::LN_2.mul_f64(k)).ldexp(-16);
        // |r| < 6e-6: e^r − 1 to 1e-70 takes 13 terms
        let mut term = r;
        let mut sum = r;
        for i in 2..=20 {
            term = term * r / Qd::new(i as f64);
            sum += term;
            if term.x[0].abs() < 1e-70 * sum.x[0].abs().max(1e-300) {
                break;
            }
        }
        for _ in 0..16 {
            sum = sum.ldexp(1) + sum * sum;
        }
        (sum + Qd::new(1.0)).ldexp(k as i32)
    }

    fn ln_impl(self) -> Qd {
        if self.x[0] <= 0.0 {
            return Qd::new(f64::NAN);
        }
        // Newton on e^y = x: y ← y + x e^{−y} − 1 (quadratic: 53 → 106 → 212 bits)
        let mut y = Qd::new(self.x[0].ln());
        for _ in 0..3 {
            y = y + self * (-y).exp_impl() - Qd::new(1.0);
        }
        y
    }

    fn sin_cos_small(r: Qd) -> (Qd, Qd) {
        let r2 = r * r;
        let mut term = r;
        let mut s = r;
        let mut i = 1.0;
        loop {
            term = -(term * r2) / Qd::new((i + 1.0) * (i + 2.0));
            s += term;
            i += 2.0;
            if term.x[0].abs() < 1e-68 || i > 120.0 {
                break;
            }
        }
        let mut term = Qd::new(1.0);
        let mut c = Qd::new(1.0);
        let mut i = 0.0;
        loop {
            term = -(term * r2) / Qd::new((i + 1.0) * (i + 2.0));
            c += term;
            i += 2.0;
            if term.x[0].abs() < 1e-68 || i > 120.0 {
                break;
            }
        }
        (s, c)
    }

    fn sin_cos(self) -> (Qd, Qd) {
        let k = (self / Qd::FRAC_PI_2).round();
        let r = self - Qd::FRAC_PI_2 * k;
        // |r| ≤ π/4; halve it three times and use the double-angle formulas
        let (s, c) = Qd::sin_cos_small(r.ldexp(-3));
        let (mut s, mut c) = (s, c);
        for _ in 0..3 {
            let s2 = (s * c).ldexp(1);
            c = c * c - s * s;
            s = s2;
        }
        let q =
            k.x.iter()
                .map(|v| v.rem_euclid(4.0))
                .sum::<f64>()
                .rem_euclid(4.0) as i64;
        match q {
            0 => (s, c),
            1 => (c, -s),
            2 => (-s, -c),
            _ => (-c, s),
        }
    }
}

impl fmt::Display for Qd {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:e}{:+e}{:+e}{:+e}",
            self.x[0], self.x[1], self.x[2], self.x[3]
        )
    }
}

impl Add for Qd {
    type Output = Qd;
    #[inline]
    fn add(self, b: Qd) -> Qd {
        // Hida–Li–Bailey's IEEE-style addition: merge by magnitude, two-word accumulator
        let (a, b) = (&self.x, &b.x);
        let (mut i, mut j, mut k) = (0usize, 0usize, 0usize);
        let mut x = [0.0f64; 4];
        let pick = |i: &mut usize, j: &mut usize| -> f64 {
            if *i >= 4 {
                *j += 1;
                b[*j - 1]
            } else if *j >= 4 || a[*i].abs() > b[*j].abs() {
                *i += 1;
                a[*i - 1]
            } else {
                *j += 1;
                b[*j - 1]
            }
        };
        let u0 = pick(&mut i, &mut j);
        let v0 = pick(&mut i, &mut j);
        let (mut u, mut v) = quick_two_sum(u0, v0);
        while k < 4 {
            if i >= 4 && j >= 4 {
                x[k] = u;
                if k < 3 {
                    k += 1;
                    x[k] = v;
                }
                break;
            }
            let t = pick(&mut i, &mut j);
            let s = quick_three_accum(&mut u, &mut v, t);
            if s != 0.0 {
                x[k] = s;
                k += 1;
            }
        }
        for &w in &a[i.min(4)..] {
            x[3] += w;
        }
        for &w in &b[j.min(4)..] {
            x[3] += w;
        }
        renorm5(x[0], x[1], x[2], x[3], 0.0)
    }
}
impl Sub for Qd {
    type Output = Qd;
    #[inline]
    fn sub(self, b: Qd) -> Qd {
        self + (-b)
    }
}
impl Neg for Qd {
    type Output = Qd;
    #[inline(always)]
    fn neg(self) -> Qd {
        Qd {
            x: self.x.map(|v| -v),
        }
    }
}
impl Mul for Qd {
    type Output = Qd;
    #[inline]
    fn mul(self, b: Qd) -> Qd {
        let (a, b) = (&self.x, &b.x);
        let (p0, mut q0) = two_prod(a[0], b[0]);
        let (mut p1, mut q1) = two_prod(a[0], b[1]);
        let (mut p2, mut q2) = two_prod(a[1], b[0]);
        let (mut p3, q3) = two_prod(a[0], b[2]);
        let (mut p4, q4) = two_prod(a[1], b[1]);
        let (mut p5, q5) = two_prod(a[2], b[0]);
        three_sum(&mut p1, &mut p2, &mut q0);
        // six-three sum of p2, q1, q2, p3, p4, p5
        three_sum(&mut p2, &mut q1, &mut q2);
        three_sum(&mut p3, &mut p4, &mut p5);
        let (s0, t0) = two_sum(p2, p3);
        let (s1, t1) = two_sum(q1, p4);
        let mut s2 = q2 + p5;
        let (mut s1, t0) = two_sum(s1, t0);
        s2 += t0 + t1;
        // O(ε³) terms
        s1 += a[0] * b[3] + a[1] * b[2] + a[2] * b[1] + a[3] * b[0] + q0 + q3 + q4 + q5;
        renorm5(p0, p1, s0, s1, s2)
    }
}
impl Div for Qd {
    type Output = Qd;
    fn div(self, b: Qd) -> Qd {
        // long division: each quotient word from the exact-enough residual
        let q0 = self.x[0] / b.x[0];
        let r = self - b.mul_f64(q0);
        let q1 = r.x[0] / b.x[0];
        let r = r - b.mul_f64(q1);
        let q2 = r.x[0] / b.x[0];
        let r = r - b.mul_f64(q2);
        let q3 = r.x[0] / b.x[0];
        let r = r - b.mul_f64(q3);
        let q4 = r.x[0] / b.x[0];
        renorm5(q0, q1, q2, q3, q4)
    }
}
impl AddAssign for Qd {
    #[inline(always)]
    fn add_assign(&mut self, o: Qd) {
        *self = *self + o;
    }
}
impl SubAssign for Qd {
    #[inline(always)]
    fn sub_assign(&mut self, o: Qd) {
        *self = *self - o;
    }
}
impl MulAssign for Qd {
    #[inline(always)]
    fn mul_assign(&mut self, o: Qd) {
        *self = *self * o;
    }
}
impl PartialOrd for Qd {
    fn partial_cmp(&self, o: &Qd) -> Option<std::cmp::Ordering> {
        let d = *self - *o;
        d.x[0].partial_cmp(&0.0)
    }
}

impl Coeff for Qd {
    #[inline(always)]
    fn zero() -> Self {
        Qd::new(0.0)
    }
    #[inline(always)]
    fn one() -> Self {
        Qd::new(1.0)
    }
    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        Qd::new(x)
    }
    #[inline(always)]
    fn is_zero(&self) -> bool {
        self.x[0] == 0.0
    }
    fn magnitude(&self) -> f64 {
        self.x[0].abs()
    }
    fn is_finite(&self) -> bool {
        self.x.iter().all(|v| v.is_finite())
    }
    #[inline(always)]
    fn scale(self, s: f64) -> Self {
        self.mul_f64(s)
    }
}

impl Real for Qd {
    const NAME: &'static str = "qd";
    const EPSILON: f64 = 1.215_432_671_457_254_2e-63; // 2^-209
    type Wide = Qd;
    fn to_f64(self) -> f64 {
        self.x[0] + (self.x[1] + (self.x[2] + self.x[3]))
    }
    fn hi_lo(self) -> (f64, f64) {
        let d = self.to_dd();
        (d.hi, d.lo)
    }
    fn from_hi_lo(hi: f64, lo: f64) -> Self {
        renorm5(hi, lo, 0.0, 0.0, 0.0)
    }
    fn words(self) -> [f64; 4] {
        self.x
    }
    fn from_words(w: [f64; 4]) -> Self {
        Qd::from_words(w)
    }
    fn abs(self) -> Self {
        if self.x[0] < 0.0 {
            -self
        } else {
            self
        }
    }
    fn sqrt(self) -> Self {
        if self.x[0] <= 0.0 {
            return if self.x[0] == 0.0 {
                Qd::new(0.0)
            } else {
                Qd::new(f64::NAN)
            };
        }
        // Newton on 1/√a: x ← x + x(1 − a x²)/2, three times (53 → 212 bits), then a·x
        let mut r = Qd::new(1.0 / self.x[0].sqrt());
        let h = self.ldexp(-1);
        for _ in 0..3 {
            r += r * (Qd::new(0.5) - h * (r * r));
        }
        // one last correction on the root itself: s + (a − s²)/(2s)
        let s = self * r;
        s + (self - s * s) * r.ldexp(-1)
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
        Qd::PI
    }
}

// Quad-double values in expression evaluation.
crate::scalar::scalar_by_real!(Qd);

#[cfg(test)]
mod tests {
    use super::*;
    use lasalle_model::ir::Rational;

    /// |a − b| ≤ tol·|b|, measured in quad-double.
    fn close(a: Qd, b: Qd, tol: f64) -> bool {
        (a - b).abs().to_f64() <= tol * b.abs().to_f64().max(1e-300)
    }

    /// An exact oracle for sums: Shewchuk's expansion arithmetic (every two_sum is exact, so
    /// the expansion is the exact sum of its inputs).
    fn exact_sum(terms: &[f64]) -> Vec<f64> {
        let mut e: Vec<f64> = Vec::new();
        for &t in terms {
            let mut q = t;
            let mut out = Vec::with_capacity(e.len() + 1);
            for &c in &e {
                let (s, h) = two_sum(q, c);
                if h != 0.0 {
                    out.push(h);
                }
                q = s;
            }
            if q != 0.0 {
                out.push(q);
            }
            e = out;
        }
        e
    }

    /// a − b exactly (as an expansion), rounded to f64 at the end, relative to |b|.
    fn exact_rel_diff(a: Qd, b_terms: &[f64]) -> f64 {
        let mut all: Vec<f64> = a.x.to_vec();
        all.extend(b_terms.iter().map(|v| -v));
        let d: f64 = exact_sum(&all).iter().sum();
        let b: f64 = exact_sum(b_terms).iter().sum();
        (d / b).abs()
    }

    fn random_qd(rng: &mut lasalle_testkit::Rng) -> Qd {
        let x0 = (rng.unit() - 0.5) * 2f64.powi((rng.unit() * 20.0) as i32 - 10);
        let w = [
            x0,
            x0 * (rng.unit() - 0.5) * 2f64.powi(-53),
            x0 * (rng.unit() - 0.5) * 2f64.powi(-106),
            x0 * (rng.unit() - 0.5) * 2f64.powi(-159),
        ];
        Qd::from_words(w)
    }

    #[test]
    fn addition_and_products_against_exact_expansions() {
        let mut rng = lasalle_testkit::Rng::new(7);
        for _ in 0..2000 {
            let (a, b) = (random_qd(&mut rng), random_qd(&mut rng));
            // a + b with the exact sum of the eight words (including heavy cancellation)
            let c = Qd::from_words([-b.x[0], -b.x[1], b.x[2], 0.0]);
            for (x, y) in [(a, b), (a, c), (a, -a + Qd::new(a.x[0] * 1e-30))] {
                let mut t = x.x.to_vec();
                t.extend_from_slice(&y.x);
                let exact: f64 = exact_sum(&t).iter().sum();
                if exact != 0.0 {
                    assert!(exact_rel_diff(x + y, &t) < 4.0 * Qd::EPSILON, "{x} + {y}");
                }
            }
            // a · b against the exact sum of all 32 partial products
            let mut t = Vec::new();
            for i in 0..4 {
                for j in 0..4 {
                    let (p, e) = two_prod(a.x[i], b.x[j]);
                    t.push(p);
                    t.push(e);
                }
            }
            assert!(exact_rel_diff(a * b, &t) < 16.0 * Qd::EPSILON, "{a} * {b}");
        }
    }

    #[test]
    fn identities_and_constants() {
        let one = Qd::new(1.0);
        let third = one / Qd::new(3.0);
        assert!(close(third * Qd::new(3.0), one, 1e-62));
        let s2 = Qd::new(2.0).sqrt();
        assert!(close(s2 * s2, Qd::new(2.0), 1e-62));
        let x = Qd::new(7.25e-3).sqrt();
        assert!(close(x * x, Qd::new(7.25e-3), 1e-62));
        assert!(close(one.exp(), Qd::E, 1e-62));
        assert!(close(Qd::E.ln(), one, 1e-62));
        assert!(close(Qd::new(0.37).ln().exp(), Qd::new(0.37), 1e-62));
        assert!(close(Qd::new(2.0).ln(), Qd::LN_2, 1e-62));
        assert!(close((Qd::PI / Qd::new(6.0)).sin(), Qd::new(0.5), 1e-62));
        assert!(close((Qd::PI / Qd::new(3.0)).cos(), Qd::new(0.5), 1e-62));
        for &v in &[0.3, 1.0, 2.5, -4.0, 10.0] {
            let v = Qd::new(v);
            let (s, c) = (v.sin(), v.cos());
            assert!(close(s * s + c * c, one, 1e-61));
        }
        // agrees with double-double to its precision
        for &v in &[0.3, 1.7, 12.0] {
            let (q, d) = (Qd::new(v), Dd::new(v));
            for (a, b) in [
                (q.exp(), d.exp()),
                (q.ln(), d.ln()),
                (q.sin(), d.sin()),
                (q.sqrt(), d.sqrt()),
            ] {
                assert!(close(a, Qd::from_dd(b), 1e-30), "{a} {b}");
            }
        }
        assert!(close(
            Real::powf(Qd::new(2.0), Rational::new(1, 3)).powi_check(3),
            Qd::new(2.0),
            1e-61
        ));
        assert!(Qd::new(1.0) > Qd::new(1.0) - Qd::new(1e-60));
        assert_eq!(Qd::new(2.5).round(), Qd::new(3.0));
        assert_eq!(
            (Qd::new(2.0) + Qd::new(0.5) - Qd::new(1e-40)).round(),
            Qd::new(2.0)
        );
    }

    trait PowiCheck {
        fn powi_check(self, n: i64) -> Self;
    }
    impl PowiCheck for Qd {
        fn powi_check(self, n: i64) -> Self {
            crate::scalar::powi(self, n)
        }
    }
}
