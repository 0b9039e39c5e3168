//! Interval arithmetic over `f64` with outward rounding, ball arithmetic with double-double
//! centres ([`ball`]), and the certified tube bounds built on them ([`certified`]).
//!
//! # The interval type
//!
//! [`Iv`] `= [lo, hi]` encloses a real number. Every operation computes its endpoints in the
//! default rounding mode (round to nearest) and then widens them by one unit in the last
//! place (`f64::next_down` / `f64::next_up`). IEEE 754 guarantees that `+`, `−`, `·`, `/` and
//! `√` are correctly rounded (the result is within half an ulp of the exact value), so the
//! widened endpoints enclose the exact result: this emulates directed rounding without
//! changing the FPU's rounding mode and without C dependencies. The transcendental functions
//! of the platform's libm are not correctly rounded; they are widened by [`LIBM_ULPS`] ulps on
//! each side (glibc documents errors of at most 1–2 ulps for `exp`, `ln`, `sin`, `cos`,
//! `pow`): the one assumption of the type not guaranteed by IEEE 754. `sin` and `cos` use
//! the Lipschitz enclosure `f(m) ± r` (|f′| ≤ 1) intersected with [−1, 1].
//!
//! [`Iv`] implements [`Coeff`] and [`Real`], so the crate's polynomials ([`Poly`](crate::Poly))
//! and jets ([`Jet`](crate::Jet)) run over it unchanged: a model's Hamiltonian expanded with
//! interval jets gives enclosures of its Taylor coefficients, and evaluated at an interval
//! base point, enclosures of its derivatives over a whole box. The order of [`Real`]
//! (`PartialOrd`) is the certain one: `a < b` iff every point of a is below every point of
//! b; overlapping intervals are unordered. [`Real::hi_lo`] and [`Real::to_f64`] return the
//! midpoint (intervals have no exact two-word split); the certified code does not use them.

pub mod ball;
pub mod certified;

use crate::scalar::{Coeff, Real};
use std::cmp::Ordering;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// Ulps added on each side of the platform's transcendental functions.
pub const LIBM_ULPS: u32 = 4;

/// A closed interval `[lo, hi]` of reals, `lo ≤ hi` (or NaN endpoints when undefined).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Iv {
    /// Lower endpoint.
    pub lo: f64,
    /// Upper endpoint.
    pub hi: f64,
}

fn down(x: f64) -> f64 {
    if x == 0.0 {
        // next_down(0) is the smallest negative subnormal; keep exact zeros exact when they
        // come from exact operations is not possible to know here, so widen.
        -f64::from_bits(1)
    } else {
        x.next_down()
    }
}

fn up(x: f64) -> f64 {
    if x == 0.0 {
        f64::from_bits(1)
    } else {
        x.next_up()
    }
}

fn down_n(mut x: f64, n: u32) -> f64 {
    for _ in 0..n {
        x = down(x);
    }
    x
}

fn up_n(mut x: f64, n: u32) -> f64 {
    for _ in 0..n {
        x = up(x);
    }
    x
}

/// `a + b` rounded up (an upper bound of the exact sum).
pub fn add_up(a: f64, b: f64) -> f64 {
    let s = a + b;
    if s.is_finite() {
        up(s)
    } else {
        s
    }
}

/// `a · b` rounded up (an upper bound of the exact product).
pub fn mul_up(a: f64, b: f64) -> f64 {
    let p = a * b;
    if p == 0.0 && (a == 0.0 || b == 0.0) {
        0.0
    } else if p.is_finite() {
        up(p)
    } else {
        p
    }
}

impl Iv {
    /// The point interval [x, x] (exact).
    pub const fn point(x: f64) -> Iv {
        Iv { lo: x, hi: x }
    }
    /// [lo, hi]; panics in debug builds if lo > hi.
    pub fn new(lo: f64, hi: f64) -> Iv {
        debug_assert!(lo <= hi || lo.is_nan() || hi.is_nan(), "[{lo}, {hi}]");
        Iv { lo, hi }
    }
    /// [−r, r] for r ≥ 0.
    pub fn symmetric(r: f64) -> Iv {
        Iv { lo: -r, hi: r }
    }
    /// Midpoint (rounded).
    pub fn mid(&self) -> f64 {
        0.5 * self.lo + 0.5 * self.hi
    }
    /// Width `hi − lo` rounded up.
    pub fn width(&self) -> f64 {
        add_up(self.hi, -self.lo)
    }
    /// max |x| over the interval.
    pub fn mag(&self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }
    /// min |x| over the interval.
    pub fn mig(&self) -> f64 {
        if self.lo > 0.0 {
            self.lo
        } else if self.hi < 0.0 {
            -self.hi
        } else {
            0.0
        }
    }
    /// Does the interval contain x?
    pub fn contains(&self, x: f64) -> bool {
        self.lo <= x && x <= self.hi
    }
    /// The smallest interval containing both.
    pub fn hull(&self, o: &Iv) -> Iv {
        Iv {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }
    /// x² (tighter than x·x when the interval contains 0).
    pub fn sqr(&self) -> Iv {
        let (a, b) = (self.mig(), self.mag());
        let lo = if a == 0.0 { 0.0 } else { down(a * a).max(0.0) };
        Iv { lo, hi: up(b * b) }
    }
    fn widened(lo: f64, hi: f64) -> Iv {
        Iv {
            lo: down(lo),
            hi: up(hi),
        }
    }
    fn monotone(self, f: impl Fn(f64) -> f64, increasing: bool) -> Iv {
        let (a, b) = if increasing {
            (f(self.lo), f(self.hi))
        } else {
            (f(self.hi), f(self.lo))
        };
        Iv {
            lo: down_n(a, LIBM_ULPS),
            hi: up_n(b, LIBM_ULPS),
        }
    }
    fn lipschitz_unit(self, f: impl Fn(f64) -> f64) -> Iv {
        let m = self.mid();
        let r = add_up(self.hi - m, 0.0).max(add_up(m - self.lo, 0.0));
        let c = f(m);
        let lo = down_n(c - r, LIBM_ULPS + 1).max(-1.0);
        let hi = up_n(c + r, LIBM_ULPS + 1).min(1.0);
        Iv { lo, hi }
    }
}

impl From<f64> for Iv {
    fn from(x: f64) -> Iv {
        Iv::point(x)
    }
}

/// Error-free sum: `a + b = s + e` exactly (Knuth's TwoSum).
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// The rounded value `s` of an exact `s + e` as the lower end of an enclosure: `s` itself
/// when the exact value is not below it.
fn lower_of(s: f64, e: f64) -> f64 {
    if !s.is_finite() {
        s
    } else if e < 0.0 || e.is_nan() {
        down(s)
    } else {
        s
    }
}

/// The rounded value `s` of an exact `s + e` as the upper end.
fn upper_of(s: f64, e: f64) -> f64 {
    if !s.is_finite() {
        s
    } else if e > 0.0 || e.is_nan() {
        up(s)
    } else {
        s
    }
}

/// `a·b` rounded down and up (the exact error from a fused multiply-add).
fn mul_bounds(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let e = a.mul_add(b, -p);
    // below the subnormal range the fma residual is not exact: widen unconditionally
    if p != 0.0 && p.abs() < 1e-290 {
        return (down(p), up(p));
    }
    if p == 0.0 && a != 0.0 && b != 0.0 {
        return (down(p), up(p));
    }
    (lower_of(p, e), upper_of(p, e))
}

impl Add for Iv {
    type Output = Iv;
    fn add(self, o: Iv) -> Iv {
        let (s, e) = two_sum(self.lo, o.lo);
        let (t, f) = two_sum(self.hi, o.hi);
        Iv {
            lo: lower_of(s, e),
            hi: upper_of(t, f),
        }
    }
}

impl Sub for Iv {
    type Output = Iv;
    fn sub(self, o: Iv) -> Iv {
        self + (-o)
    }
}

impl Neg for Iv {
    type Output = Iv;
    fn neg(self) -> Iv {
        Iv {
            lo: -self.hi,
            hi: -self.lo,
        }
    }
}

impl Mul for Iv {
    type Output = Iv;
    fn mul(self, o: Iv) -> Iv {
        // exact zeros stay exact: the product of a point 0 with anything finite is 0
        if (self.lo == 0.0 && self.hi == 0.0) || (o.lo == 0.0 && o.hi == 0.0) {
            return Iv::point(0.0);
        }
        let p = [
            mul_bounds(self.lo, o.lo),
            mul_bounds(self.lo, o.hi),
            mul_bounds(self.hi, o.lo),
            mul_bounds(self.hi, o.hi),
        ];
        if p.iter().any(|x| x.0.is_nan() || x.1.is_nan()) {
            return Iv::point(f64::NAN);
        }
        let lo = p.iter().map(|x| x.0).fold(f64::INFINITY, f64::min);
        let hi = p.iter().map(|x| x.1).fold(f64::NEG_INFINITY, f64::max);
        Iv { lo, hi }
    }
}

impl Div for Iv {
    type Output = Iv;
    fn div(self, o: Iv) -> Iv {
        if o.lo <= 0.0 && o.hi >= 0.0 {
            // division by an interval containing 0: unbounded
            return Iv {
                lo: f64::NEG_INFINITY,
                hi: f64::INFINITY,
            };
        }
        if self.lo == 0.0 && self.hi == 0.0 {
            return Iv::point(0.0);
        }
        let q = [
            self.lo / o.lo,
            self.lo / o.hi,
            self.hi / o.lo,
            self.hi / o.hi,
        ];
        let lo = q.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = q.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Iv::widened(lo, hi)
    }
}

impl AddAssign for Iv {
    fn add_assign(&mut self, o: Iv) {
        *self = *self + o;
    }
}

impl SubAssign for Iv {
    fn sub_assign(&mut self, o: Iv) {
        *self = *self - o;
    }
}

impl MulAssign for Iv {
    fn mul_assign(&mut self, o: Iv) {
        *self = *self * o;
    }
}

impl PartialOrd for Iv {
    /// Certainly less / greater, or equal points; `None` when the intervals overlap.
    fn partial_cmp(&self, o: &Iv) -> Option<Ordering> {
        if self.hi < o.lo {
            Some(Ordering::Less)
        } else if self.lo > o.hi {
            Some(Ordering::Greater)
        } else if self.lo == self.hi && o.lo == o.hi && self.lo == o.lo {
            Some(Ordering::Equal)
        } else {
            None
        }
    }
}

impl Coeff for Iv {
    fn zero() -> Self {
        Iv::point(0.0)
    }
    fn one() -> Self {
        Iv::point(1.0)
    }
    fn from_f64(x: f64) -> Self {
        Iv::point(x)
    }
    fn is_zero(&self) -> bool {
        self.lo == 0.0 && self.hi == 0.0
    }
    fn magnitude(&self) -> f64 {
        self.mag()
    }
    fn is_finite(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite()
    }
    /// The products of polynomials (the bulk of the certified bound's work), widened by one
    /// ulp unconditionally instead of by the exact error: each term's four endpoint
    /// products in round to nearest, their minimum moved one ulp down and their maximum one
    /// ulp up (the exact product of two intervals is attained at a pair of endpoints, and
    /// `down(min RN(pᵢ)) ≤ down(RN(p*)) < p*` for the exact minimum p\*), then added to the
    /// accumulator and moved one more ulp outwards. Four multiplications and no fused
    /// multiply-add per term, where `Mul` and `Add` take eight of each.
    #[inline]
    fn mul_acc_kernel(
        out: &mut [Self],
        a: &[Self],
        ka: &[u32],
        b: &[Self],
        kb: &[u32],
        lk: &[u32],
    ) {
        crate::scalar::generic_kernel(out, a, ka, b, kb, lk, |o, x, y| {
            if y.lo == 0.0 && y.hi == 0.0 {
                return;
            }
            let (p1, p2, p3, p4) = (x.lo * y.lo, x.lo * y.hi, x.hi * y.lo, x.hi * y.hi);
            if p1.is_nan() || p2.is_nan() || p3.is_nan() || p4.is_nan() {
                *o = Iv::point(f64::NAN);
                return;
            }
            let lo = down(p1.min(p2).min(p3.min(p4)));
            let hi = up(p1.max(p2).max(p3.max(p4)));
            *o = Iv {
                lo: down(o.lo + lo),
                hi: up(o.hi + hi),
            };
        });
    }
}

impl Real for Iv {
    const NAME: &'static str = "interval";
    const EPSILON: f64 = f64::EPSILON / 2.0;
    type Wide = Iv;
    fn to_f64(self) -> f64 {
        self.mid()
    }
    fn hi_lo(self) -> (f64, f64) {
        (self.mid(), 0.0)
    }
    fn from_hi_lo(hi: f64, lo: f64) -> Self {
        Iv::point(hi) + Iv::point(lo)
    }
    fn abs(self) -> Self {
        Iv {
            lo: self.mig(),
            hi: self.mag(),
        }
    }
    fn sqrt(self) -> Self {
        if self.hi < 0.0 || self.lo.is_nan() || self.hi.is_nan() {
            return Iv::point(f64::NAN);
        }
        // √ is correctly rounded (IEEE 754); a lower end below 0 is clamped (√ of the
        // nonnegative part: the models' square roots are of sums of squares)
        let lo = if self.lo <= 0.0 {
            0.0
        } else {
            down(self.lo.sqrt()).max(0.0)
        };
        Iv {
            lo,
            hi: up(self.hi.sqrt()),
        }
    }
    fn exp(self) -> Self {
        let r = self.monotone(f64::exp, true);
        Iv {
            lo: r.lo.max(0.0),
            hi: r.hi,
        }
    }
    fn ln(self) -> Self {
        if self.lo <= 0.0 {
            return Iv {
                lo: f64::NEG_INFINITY,
                hi: if self.hi <= 0.0 {
                    f64::NAN
                } else {
                    up_n(self.hi.ln(), LIBM_ULPS)
                },
            };
        }
        self.monotone(f64::ln, true)
    }
    fn sin(self) -> Self {
        self.lipschitz_unit(f64::sin)
    }
    fn cos(self) -> Self {
        self.lipschitz_unit(f64::cos)
    }
    fn pi() -> Self {
        // the f64 nearest to π is below it
        Iv {
            lo: std::f64::consts::PI,
            hi: std::f64::consts::PI.next_up(),
        }
    }
    fn powf(self, p: lasalle_model::ir::Rational) -> Self {
        match p.den {
            1 => crate::scalar::powi(self, p.num as i64),
            2 => crate::scalar::powi(Real::sqrt(self), p.num as i64),
            _ => {
                let e = Iv::point(p.num as f64) / Iv::point(p.den as f64);
                Real::exp(Real::ln(self) * e)
            }
        }
    }
}

// Interval values in expression evaluation (any [`HamiltonianFn`](crate::HamiltonianFn)): H
// enclosed at a point or over a box.
crate::scalar::scalar_by_real!(Iv);

#[cfg(test)]
mod tests {
    use super::*;

    /// The sign of the exact value a·b − c (fma rounds the exact value once, and rounding
    /// to nearest preserves the sign).
    fn sign_ab_minus_c(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, -c).signum()
    }

    #[test]
    fn division_encloses_exact_rationals() {
        // 1/3, 2/7, 22/7, 1e-300/3: lo·d ≤ n ≤ hi·d exactly
        for &(n, d) in &[
            (1.0, 3.0),
            (2.0, 7.0),
            (22.0, 7.0),
            (1e-300, 3.0),
            (5.0, 1e10),
        ] {
            let q = Iv::point(n) / Iv::point(d);
            assert!(q.lo < q.hi);
            assert!(sign_ab_minus_c(q.lo, d, n) <= 0.0, "{n}/{d}: {q:?}");
            assert!(sign_ab_minus_c(q.hi, d, n) >= 0.0, "{n}/{d}: {q:?}");
        }
    }

    #[test]
    fn square_roots_enclose_exact_values() {
        for &x in &[2.0, 3.0, 0.1, 1e-20, 12345.678] {
            let r = Real::sqrt(Iv::point(x));
            assert!(sign_ab_minus_c(r.lo, r.lo, x) <= 0.0, "√{x}: {r:?}");
            assert!(sign_ab_minus_c(r.hi, r.hi, x) >= 0.0, "√{x}: {r:?}");
            assert!(r.width() < 4.0 * f64::EPSILON * x.sqrt());
        }
    }

    #[test]
    fn sums_enclose_the_exact_sum() {
        // Σ_{k=1}^{1000} 0.1 in interval arithmetic contains 1000 · 0.1₆₄ exactly:
        // 0.1₆₄ = 3602879701896397 / 2⁵⁵, so the exact sum is 3602879701896397000 / 2⁵⁵.
        let mut s = Iv::point(0.0);
        for _ in 0..1000 {
            s += Iv::point(0.1);
        }
        let exact_num: i128 = 3602879701896397 * 1000;
        let scale = 2f64.powi(55);
        // lo·2⁵⁵ and hi·2⁵⁵ are exact (power-of-two scaling); compare as integers
        let lo = (s.lo * scale) as i128;
        let hi = (s.hi * scale).ceil() as i128;
        assert!(lo <= exact_num && exact_num <= hi, "{s:?}");
        assert!(s.width() < 1e-10); // about 1000 ulps of 100
                                    // the f64 sum alone misses it (the reason for the intervals)
        let f: f64 = (0..1000).map(|_| 0.1).sum();
        assert_ne!((f * scale) as i128, exact_num);
    }

    #[test]
    fn products_and_signs() {
        let a = Iv::new(-1.0, 2.0);
        let b = Iv::new(-3.0, 0.5);
        let p = a * b;
        assert!(p.lo <= -6.0 && p.hi >= 3.0 && p.lo > -6.0 - 1e-12 && p.hi < 3.0 + 1e-12);
        assert_eq!(a.sqr().lo, 0.0);
        assert!(a.sqr().hi >= 4.0);
        assert!(Iv::point(1.0) / Iv::new(-1.0, 1.0) == Iv::new(f64::NEG_INFINITY, f64::INFINITY));
        assert_eq!(Iv::point(0.0) * Iv::new(-5.0, 5.0), Iv::point(0.0));
        assert!(Iv::new(0.0, 1.0) < Iv::new(1.5, 2.0));
        assert!(Iv::new(0.0, 1.0).partial_cmp(&Iv::new(0.5, 2.0)).is_none());
    }

    #[test]
    fn transcendental_functions_enclose_closed_forms() {
        // e¹ = e, ln 2, sin(π/6) = ½, cos(π/3) = ½, π
        let e = Real::exp(Iv::point(1.0));
        assert!(e.contains(std::f64::consts::E));
        let l = Real::ln(Iv::point(2.0));
        assert!(l.contains(std::f64::consts::LN_2));
        let pi = <Iv as Real>::pi();
        assert!(pi.lo < pi.hi);
        let s = Real::sin(pi / Iv::point(6.0));
        assert!(s.contains(0.5), "{s:?}");
        let c = Real::cos(pi / Iv::point(3.0));
        assert!(c.contains(0.5), "{c:?}");
        // a wide argument: sin over [0, 4] is [−0.7568…, 1]
        let w = Real::sin(Iv::new(0.0, 4.0));
        assert!(w.lo <= -0.7568 && w.hi >= 1.0 - 1e-15);
        // x^{3/2} at 4 is 8; x^{1/3} at 8 is 2
        let r = Real::powf(
            Iv::point(4.0),
            lasalle_model::ir::Rational { num: 3, den: 2 },
        );
        assert!(r.contains(8.0));
        let r = Real::powf(
            Iv::point(8.0),
            lasalle_model::ir::Rational { num: 1, den: 3 },
        );
        assert!(r.contains(2.0) && r.width() < 1e-14);
    }

    #[test]
    fn interval_jets_enclose_taylor_coefficients() {
        // 1/√(1 + x) = Σ binom(−½, k) xᵏ: the interval jet encloses every coefficient
        use crate::jet::Jet;
        use crate::monomial::MonomialTable;
        use crate::poly::Poly;
        use lasalle_model::ir::Scalar;
        use std::sync::Arc;
        let t = Arc::new(MonomialTable::new(1, 12));
        let x = Jet::Series(Poly::variable(t.clone(), 0, Iv::point(1.0)));
        let y = x.powf(lasalle_model::ir::Rational { num: -1, den: 2 });
        let p = y.into_poly(&t);
        for k in 0..=12usize {
            // binom(−½, k) = (−1)ᵏ binom(2k, k)/4ᵏ, an exact dyadic rational in f64
            let c = (-1f64).powi(k as i32) * crate::monomial::binomial(2 * k, k) as f64
                / 4f64.powi(k as i32);
            let v = p.coeff(&[k as u8]);
            assert!(v.contains(c), "degree {k}: {v:?} vs {c}");
            assert!(v.width() < 1e-13 * c.abs());
        }
    }
}
