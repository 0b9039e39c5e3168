//! Ball arithmetic with a double-double centre: [`Ball`] `= m ± r`, `m = hi + lo` an exact
//! sum of two `f64`, `r ≥ 0` an `f64`, encloses a real number to about 10⁻³² relative where
//! [`Iv`] stops at 10⁻¹⁶.
//!
//! Every operation computes its centre with error-free transformations where they are
//! exact (TwoSum, whose dropped part is known exactly and added to the radius; TwoProd by a
//! fused multiply-add) and ordinary `f64` operations elsewhere, and adds to the radius a
//! bound on everything the centre misses: for each rounded `f64`
//! operation with computed result `t`, `u·|t|` (`u = 2⁻⁵³`; round to nearest is within half
//! an ulp of `t`, and half an ulp of `t` is at most `u·|t|`), plus the subnormal spacing
//! `2⁻¹⁰⁷⁴` when `t` is below the normal range, and the propagated radii of the operands.
//! The radius itself is accumulated rounded up ([`add_up`], [`mul_up`]). Division and square
//! root need no error analysis of an algorithm: a double-double approximation `q` of `a/b`
//! (of `√a`) is computed by a Newton step, and the error is bounded from the residual
//! `a − q·b` (`a − q²`), itself a ball: `|a/b − q| = |a − qb|/|b|`,
//! `|√a − q| = |a − q²|/(√a + q) ≤ |a − q²|/q`. What is not an operation of the four kinds
//! and √ (exp, ln, sin, cos, rational powers other than integers and halves) returns the
//! whole line (sin and cos [−1, 1]): still an enclosure, only useless, so a model with
//! them falls back to the `f64` intervals where the caller needs it.
//!
//! The type implements [`Coeff`] and [`Real`], so jets ([`Jet`](crate::Jet)) run over it:
//! the certified bounds use it for the equilibrium (an interval Newton step) and the linear
//! normalisation ([`certified`](super::certified)).

use super::{add_up, mul_up, Iv};
use crate::scalar::{Coeff, Real};
use std::cmp::Ordering;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// `u = 2⁻⁵³`, the unit roundoff of `f64`.
const U: f64 = f64::EPSILON / 2.0;
/// Below this magnitude a rounded result may be subnormal (absolute error 2⁻¹⁰⁷⁵).
const TINY: f64 = 1e-290;
/// The subnormal spacing 2⁻¹⁰⁷⁴.
const ETA: f64 = f64::from_bits(1);

/// `m ± r` with a double-double centre `m = hi + lo` (exact sum) and a radius `r ≥ 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ball {
    /// Leading word of the centre.
    pub hi: f64,
    /// Trailing word of the centre.
    pub lo: f64,
    /// Radius (rounded up; +∞ for the whole line).
    pub rad: f64,
}

/// TwoSum: `a + b = s + e` exactly.
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// Bound on the rounding error of an `f64` operation whose computed result is `t`.
fn err(t: f64) -> f64 {
    let e = mul_up(U, t.abs());
    if t.abs() < TINY {
        add_up(e, ETA)
    } else {
        e
    }
}

impl Ball {
    /// The exact value x (radius 0).
    pub const fn point(x: f64) -> Ball {
        Ball {
            hi: x,
            lo: 0.0,
            rad: 0.0,
        }
    }
    /// `hi + lo ± rad` (the centre renormalised exactly).
    pub fn new(hi: f64, lo: f64, rad: f64) -> Ball {
        let (h, l) = two_sum(hi, lo);
        Ball { hi: h, lo: l, rad }
    }
    /// The whole real line.
    pub fn whole() -> Ball {
        Ball {
            hi: 0.0,
            lo: 0.0,
            rad: f64::INFINITY,
        }
    }
    /// An `f64` interval enclosing the ball (outward rounded).
    pub fn to_iv(self) -> Iv {
        if !self.rad.is_finite() || !self.hi.is_finite() {
            return Iv::new(f64::NEG_INFINITY, f64::INFINITY);
        }
        Iv::point(self.hi) + Iv::point(self.lo) + Iv::symmetric(self.rad)
    }
    /// The centre rounded to `f64`.
    pub fn mid(self) -> f64 {
        self.hi + self.lo
    }
    /// An upper bound of |x| over the ball.
    pub fn mag(self) -> f64 {
        add_up(add_up(self.hi.abs(), self.lo.abs()), self.rad)
    }
    /// A lower bound of |x| over the ball (0 when it may contain 0).
    pub fn mig(self) -> f64 {
        let c = (Iv::point(self.hi.abs()) - Iv::point(self.lo.abs())).lo;
        let m = (Iv::point(c) - Iv::point(self.rad)).lo;
        m.max(0.0)
    }
    /// The centre alone, as an exact point.
    pub fn centre(self) -> Ball {
        Ball {
            hi: self.hi,
            lo: self.lo,
            rad: 0.0,
        }
    }
    /// The ball with its radius widened to r (r ≥ the present radius).
    pub fn with_radius(self, r: f64) -> Ball {
        Ball {
            rad: self.rad.max(r),
            ..self
        }
    }
    /// 1/x for the centre alone: a double-double approximation (not an enclosure).
    fn recip_approx(self) -> Ball {
        let q1 = 1.0 / self.hi;
        // q = q1 + q1(1 − m·q1), the Newton step, in the centres
        let r = Ball::point(1.0) - self.centre() * Ball::point(q1);
        Ball::new(q1, q1 * r.mid(), 0.0)
    }
    fn sqrt_approx(self) -> Ball {
        let s1 = self.hi.sqrt();
        let r = self.centre() - Ball::point(s1) * Ball::point(s1);
        Ball::new(s1, r.mid() / (2.0 * s1), 0.0)
    }
}

impl From<f64> for Ball {
    fn from(x: f64) -> Ball {
        Ball::point(x)
    }
}

impl Add for Ball {
    type Output = Ball;
    fn add(self, o: Ball) -> Ball {
        // every step is TwoSum: the parts dropped, e1 and e2, are known exactly
        let (s, e) = two_sum(self.hi, o.hi);
        let (t1, e1) = two_sum(self.lo, o.lo);
        let (t2, e2) = two_sum(e, t1);
        let (hi, lo) = two_sum(s, t2);
        let mut rad = add_up(self.rad, o.rad);
        if e1 != 0.0 || e2 != 0.0 {
            rad = add_up(rad, add_up(e1.abs(), e2.abs()));
        }
        if !(hi.is_finite() && lo.is_finite()) {
            return Ball::whole();
        }
        Ball { hi, lo, rad }
    }
}

impl Neg for Ball {
    type Output = Ball;
    fn neg(self) -> Ball {
        Ball {
            hi: -self.hi,
            lo: -self.lo,
            rad: self.rad,
        }
    }
}

impl Sub for Ball {
    type Output = Ball;
    fn sub(self, o: Ball) -> Ball {
        self + (-o)
    }
}

impl Mul for Ball {
    type Output = Ball;
    fn mul(self, o: Ball) -> Ball {
        if self.is_zero() || o.is_zero() {
            return Ball::point(0.0);
        }
        let p = self.hi * o.hi;
        let e = self.hi.mul_add(o.hi, -p);
        let t1 = self.hi * o.lo;
        let t2 = self.lo * o.hi;
        let t3 = self.lo * o.lo;
        let t4 = t1 + t2;
        let t5 = t4 + t3;
        let t6 = e + t5;
        let (hi, lo) = two_sum(p, t6);
        let mut rad = 0.0;
        for t in [t1, t2, t3, t4, t5, t6] {
            rad = add_up(rad, err(t));
        }
        // the fma residual is exact unless the product is near the subnormal range
        if p.abs() < 1e-250 {
            rad = add_up(rad, ETA);
        }
        // (ma ± ra)(mb ± rb) = ma·mb ± (|ma| rb + ra |mb| + ra rb)
        let (ma, mb) = (
            add_up(self.hi.abs(), self.lo.abs()),
            add_up(o.hi.abs(), o.lo.abs()),
        );
        if self.rad > 0.0 || o.rad > 0.0 {
            rad = add_up(rad, mul_up(ma, o.rad));
            rad = add_up(rad, mul_up(self.rad, mb));
            rad = add_up(rad, mul_up(self.rad, o.rad));
        }
        if !(hi.is_finite() && lo.is_finite()) || rad.is_nan() {
            return Ball::whole();
        }
        Ball { hi, lo, rad }
    }
}

impl Ball {
    /// 1/x enclosed: the residual bound for the centre, then the radius.
    fn recip(self) -> Ball {
        let m_lo = self.centre().mig();
        if m_lo == 0.0 || !self.rad.is_finite() || self.rad >= m_lo {
            return Ball::whole();
        }
        let q = self.recip_approx();
        // |1/m − q| = |1 − m q| / |m|
        let res = Ball::point(1.0) - self.centre() * q;
        let e_centre = (Iv::point(res.mag()) / Iv::point(m_lo)).hi;
        // |1/x − 1/m| ≤ r / (|m| (|m| − r)) for |x − m| ≤ r < |m|
        let gap = (Iv::point(m_lo) - Iv::point(self.rad)).lo;
        if gap <= 0.0 {
            return Ball::whole();
        }
        let e_rad = (Iv::point(self.rad) / (Iv::point(m_lo) * Iv::point(gap))).hi;
        Ball {
            rad: add_up(e_centre, e_rad),
            ..q
        }
    }
}

impl Div for Ball {
    type Output = Ball;
    // a/b = a·(1/b), with 1/b enclosed
    #[allow(clippy::suspicious_arithmetic_impl)]
    fn div(self, o: Ball) -> Ball {
        if self.is_zero() {
            return Ball::point(0.0);
        }
        self * o.recip()
    }
}

impl AddAssign for Ball {
    fn add_assign(&mut self, o: Ball) {
        *self = *self + o;
    }
}
impl SubAssign for Ball {
    fn sub_assign(&mut self, o: Ball) {
        *self = *self - o;
    }
}
impl MulAssign for Ball {
    fn mul_assign(&mut self, o: Ball) {
        *self = *self * o;
    }
}

impl PartialOrd for Ball {
    /// Certainly less / greater, or equal points; `None` when the balls overlap.
    fn partial_cmp(&self, o: &Ball) -> Option<Ordering> {
        if self.rad == 0.0 && o.rad == 0.0 && self.hi == o.hi && self.lo == o.lo {
            return Some(Ordering::Equal);
        }
        match self.to_iv().partial_cmp(&o.to_iv()) {
            Some(Ordering::Equal) => None,
            ord => ord,
        }
    }
}

impl Coeff for Ball {
    fn zero() -> Self {
        Ball::point(0.0)
    }
    fn one() -> Self {
        Ball::point(1.0)
    }
    fn from_f64(x: f64) -> Self {
        Ball::point(x)
    }
    fn is_zero(&self) -> bool {
        self.hi == 0.0 && self.lo == 0.0 && self.rad == 0.0
    }
    fn magnitude(&self) -> f64 {
        self.mag()
    }
    fn is_finite(&self) -> bool {
        self.hi.is_finite() && self.lo.is_finite() && self.rad.is_finite()
    }
}

impl Real for Ball {
    const NAME: &'static str = "dd ball";
    const EPSILON: f64 = f64::EPSILON * f64::EPSILON;
    type Wide = Ball;
    fn to_f64(self) -> f64 {
        self.mid()
    }
    fn hi_lo(self) -> (f64, f64) {
        (self.hi, self.lo)
    }
    fn from_hi_lo(hi: f64, lo: f64) -> Self {
        Ball::new(hi, lo, 0.0)
    }
    fn abs(self) -> Self {
        // ||x| − |m|| ≤ |x − m|
        if self.hi < 0.0 || (self.hi == 0.0 && self.lo < 0.0) {
            -self
        } else {
            self
        }
    }
    fn sqrt(self) -> Self {
        if !self.is_finite() {
            return Ball::whole();
        }
        let x = self.to_iv();
        if x.hi < 0.0 {
            return Ball {
                hi: f64::NAN,
                lo: f64::NAN,
                rad: f64::NAN,
            };
        }
        let l = self.mig();
        if l == 0.0 || self.centre().mig() == 0.0 {
            // [0, √hi]: the models' roots are of sums of squares
            let top = x.hi.max(0.0).sqrt().next_up();
            let half = mul_up(0.5, top);
            return Ball {
                hi: 0.5 * top,
                lo: 0.0,
                rad: half,
            };
        }
        let q = self.centre().sqrt_approx();
        if q.hi <= 0.0 {
            return Ball::whole();
        }
        // |√m − q| = |m − q²|/(√m + q) ≤ |m − q²|/q
        let res = self.centre() - q * q;
        let q_lo = q.mig();
        let e_centre = (Iv::point(res.mag()) / Iv::point(q_lo)).hi;
        // |√x − √m| = |x − m|/(√x + √m) ≤ r/(√l + √m), l ≤ min x over the ball and
        // √m ≥ q − |√m − q|
        let e_rad = if self.rad > 0.0 {
            let sl = l.sqrt().next_down();
            let sm = (Iv::point(q_lo) - Iv::point(e_centre)).lo.max(0.0);
            let den = (Iv::point(sl.max(0.0)) + Iv::point(sm)).lo;
            if den <= 0.0 {
                return Ball::whole();
            }
            (Iv::point(self.rad) / Iv::point(den)).hi
        } else {
            0.0
        };
        Ball {
            rad: add_up(e_centre, e_rad),
            ..q
        }
    }
    fn exp(self) -> Self {
        Ball::whole()
    }
    fn ln(self) -> Self {
        Ball::whole()
    }
    fn sin(self) -> Self {
        Ball {
            hi: 0.0,
            lo: 0.0,
            rad: 1.0,
        }
    }
    fn cos(self) -> Self {
        Ball {
            hi: 0.0,
            lo: 0.0,
            rad: 1.0,
        }
    }
    fn pi() -> Self {
        // π = 3.141592653589793 + 1.2246467991473532e-16 to within 10⁻³²
        Ball {
            hi: std::f64::consts::PI,
            lo: 1.2246467991473532e-16,
            rad: 1e-31,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// |x − m| ≤ r, checked in quad-double (64 digits: its own error is far below r).
    fn contains_qd(b: Ball, x: crate::Qd) -> bool {
        let m = crate::Qd::from_words([b.hi, b.lo, 0.0, 0.0]);
        let d = x - m;
        let d = if d < crate::Qd::from_f64(0.0) { -d } else { d };
        d <= crate::Qd::from_f64(b.rad)
    }

    #[test]
    fn quotients_and_roots_enclose_exact_values_to_1e_31() {
        for &(n, d) in &[(1.0, 3.0), (2.0, 7.0), (22.0, 7.0), (1.0, 49.0)] {
            let q = Ball::point(n) / Ball::point(d);
            assert!(q.rad < 1e-31 * (n / d), "{n}/{d}: {q:?}");
            let exact = crate::Qd::from_f64(n) / crate::Qd::from_f64(d);
            assert!(contains_qd(q, exact), "{n}/{d}: {q:?}");
            // the f64 quotient is outside the ball: the ball is tighter than an f64 interval
            assert!((q.hi - n / d).abs() < f64::EPSILON);
        }
        // √2, √3·10⁻⁸, √(1/3) against quad-double
        for x in [
            Ball::point(2.0),
            Ball::point(3e-8),
            Ball::point(1.0) / Ball::point(3.0),
        ] {
            let s = Real::sqrt(x);
            assert!(s.rad < 1e-31 * s.hi, "{x:?}: {s:?}");
            let q = crate::Qd::from_words([x.hi, x.lo, 0.0, 0.0]);
            assert!(contains_qd(s, Real::sqrt(q)), "√{x:?}: {s:?}");
        }
        // a ball of positive radius: √(4 ± 10⁻²⁰) ⊂ 2 ± 2.5·10⁻²¹ (+ rounding)
        let s = Real::sqrt(Ball::point(4.0).with_radius(1e-20));
        assert!(s.rad >= 2.5e-21 && s.rad < 2.6e-21, "{s:?}");
    }

    #[test]
    fn sums_and_products_track_cancellation() {
        // (1 + 2⁻⁶⁰) − 1 = 2⁻⁶⁰ exactly: a double-double centre keeps it
        let a = Ball::new(1.0, 2f64.powi(-60), 0.0);
        let d = a - Ball::point(1.0);
        assert!(d.to_iv().contains(2f64.powi(-60)) && d.rad < 1e-45, "{d:?}");
        // 0.1₆₄ · 10 = 1 + 2⁻⁵⁴ exactly (0.1₆₄ = 3602879701896397/2⁵⁵)
        let p = Ball::point(0.1) * Ball::point(10.0);
        assert_eq!((p.hi, p.lo), (1.0, 2f64.powi(-54)));
        // radii propagate: (1 ± 10⁻²⁰)(2 ± 10⁻²⁰) ∋ 2 + 3·10⁻²⁰
        let x = Ball::point(1.0).with_radius(1e-20) * Ball::point(2.0).with_radius(1e-20);
        assert!(x.rad >= 3e-20 && x.rad < 3.0001e-20, "{x:?}");
        // a ball around 0 cannot be inverted
        assert!(!Ball::point(0.0).with_radius(1e-3).recip().is_finite());
    }

    #[test]
    fn interval_jets_over_balls_enclose_taylor_coefficients() {
        // 1/√(1 + x) = Σ binom(−½, k) xᵏ, exact dyadic rationals, enclosed to 10⁻³⁰
        use crate::jet::Jet;
        use crate::monomial::MonomialTable;
        use crate::poly::Poly;
        use lasalle_model::ir::Scalar;
        use std::sync::Arc;
        let t = Arc::new(MonomialTable::new(1, 10));
        let x = Jet::Series(Poly::variable(t.clone(), 0, Ball::point(1.0)));
        let y = x.powf(lasalle_model::ir::Rational { num: -1, den: 2 });
        let p = y.into_poly(&t);
        for k in 0..=10usize {
            let c = (-1f64).powi(k as i32) * crate::monomial::binomial(2 * k, k) as f64
                / 4f64.powi(k as i32);
            let v = p.coeff(&[k as u8]);
            let diff = v.centre() - Ball::point(c);
            assert!(diff.mag() <= v.rad, "degree {k}: {v:?} vs {c}");
            assert!(v.rad < 1e-29 * c.abs().max(1.0), "degree {k}: {v:?}");
        }
    }
}
