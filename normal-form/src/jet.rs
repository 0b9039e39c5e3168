//! Jet (truncated Taylor series) arithmetic.
//!
//! A Hamiltonian is Taylor-expanded about a point by evaluating its expression once over
//! truncated multivariate series instead of numbers: each state variable becomes
//! `z⁰ᵢ + δzᵢ`, and every operation of the expression (sums, products, `1/x`, `x^p`, `exp`,
//! `ln`, `sin`, `cos`) is replaced by its series counterpart. No symbolic derivative is ever
//! formed. The elementary functions use the classical recurrences obtained from the Euler
//! operator `D = Σ xᵢ∂ᵢ` (which multiplies a homogeneous part of degree k by k): for
//! `g = f^p`, `f·Dg = p·g·Df` gives, degree by degree,
//!
//! ```text
//! g₀ = f₀ᵖ,   g_k = 1/(k f₀) Σ_{j=1..k} (p·j − (k−j)) f_j g_{k−j}
//! ```
//!
//! and likewise `k g_k = Σ j f_j g_{k−j}` for `g = eᶠ`, `k f₀ g_k = k f_k − Σ_{j<k} j g_j f_{k−j}`
//! for `g = ln f`, `k s_k = Σ j f_j c_{k−j}`, `k c_k = −Σ j f_j s_{k−j}` for `s, c = sin f, cos f`.
//! Only the nonzero homogeneous parts of `f` enter the sums, so `1/r = (x² + y²)^{−½}` costs
//! two small products per degree. The same code serves univariate series in time (one
//! variable) for a Taylor integrator.
//!
//! Jets implement the front end's `lasalle_model::ir::Scalar` (re-exported as
//! [`Scalar`]), so a model's expression DAG evaluates over them directly
//! (`Graph::eval`), with exact rational exponents.

use crate::poly::{mul_acc_hom, Poly};
use crate::scalar::{Coeff, Real};
use crate::Dd;
use lasalle_model::ir::{Rational, Scalar};

// Double-double values in expression evaluation (any [`HamiltonianFn`](crate::HamiltonianFn));
// `f64` has its implementation in the code generator.
crate::scalar::scalar_by_real!(Dd);

/// A value in a jet evaluation: a constant, or a truncated series.
#[derive(Clone, Debug)]
pub enum Jet<R> {
    /// A number (no table needed, so `from_f64` works without context).
    Const(R),
    /// A truncated multivariate series.
    Series(Poly<R>),
}

impl<R: Real> Jet<R> {
    /// The series, with constants turned into constant series over `like`'s table.
    pub fn into_poly(self, table: &std::sync::Arc<crate::MonomialTable>) -> Poly<R> {
        match self {
            Jet::Const(c) => Poly::constant(table.clone(), c),
            Jet::Series(p) => p,
        }
    }
    fn unary(&self, c: impl Fn(R) -> R, s: impl Fn(&Poly<R>) -> Poly<R>) -> Self {
        match self {
            Jet::Const(x) => Jet::Const(c(*x)),
            Jet::Series(p) => Jet::Series(s(p)),
        }
    }
}

impl<R: Real> Scalar for Jet<R> {
    fn from_f64(c: f64) -> Self {
        Jet::Const(R::from_f64(c))
    }
    fn add(&self, o: &Self) -> Self {
        match (self, o) {
            (Jet::Const(a), Jet::Const(b)) => Jet::Const(*a + *b),
            (Jet::Const(a), Jet::Series(p)) | (Jet::Series(p), Jet::Const(a)) => {
                Jet::Series(p.add_constant(*a))
            }
            (Jet::Series(p), Jet::Series(q)) => Jet::Series(p.add(q)),
        }
    }
    fn mul(&self, o: &Self) -> Self {
        match (self, o) {
            (Jet::Const(a), Jet::Const(b)) => Jet::Const(*a * *b),
            (Jet::Const(a), Jet::Series(p)) | (Jet::Series(p), Jet::Const(a)) => {
                Jet::Series(p.scaled(*a))
            }
            (Jet::Series(p), Jet::Series(q)) => Jet::Series(p.mul(q)),
        }
    }
    fn recip(&self) -> Self {
        self.unary(|x| R::one() / x, series_recip)
    }
    fn powi(&self, n: i32) -> Self {
        self.unary(|x| crate::scalar::powi(x, n as i64), |p| series_powi(p, n))
    }
    fn powf(&self, e: Rational) -> Self {
        self.unary(|x| x.powf(e), |p| series_powf(p, e))
    }
    fn exp(&self) -> Self {
        self.unary(|x| x.exp(), series_exp)
    }
    fn ln(&self) -> Self {
        self.unary(|x| x.ln(), series_ln)
    }
    fn sin(&self) -> Self {
        self.unary(|x| x.sin(), |p| series_sin_cos(p).0)
    }
    fn cos(&self) -> Self {
        self.unary(|x| x.cos(), |p| series_sin_cos(p).1)
    }
    fn neg(&self) -> Self {
        self.unary(|x| -x, |p| p.map(|c| -c))
    }
    fn sub(&self, o: &Self) -> Self {
        self.add(&o.neg())
    }
}

/// Degrees j ≥ 1 where `f` has a nonzero part.
fn nonzero_degrees<T: Coeff>(f: &Poly<T>) -> Vec<usize> {
    (1..=f.max_degree())
        .filter(|&j| f.part(j).is_some_and(|p| p.iter().any(|c| !c.is_zero())))
        .collect()
}

/// out += Σ_{j ∈ js, j ≤ k} w(j)·f_j·g_{k−j}
fn conv_acc<R: Real>(
    out: &mut [R],
    f: &Poly<R>,
    js: &[usize],
    g: &[Vec<R>],
    k: usize,
    w: impl Fn(usize) -> f64,
) {
    let table = f.table();
    for &j in js {
        if j > k {
            break;
        }
        let gk = &g[k - j];
        if gk.is_empty() {
            continue;
        }
        let wj = w(j);
        if wj == 0.0 {
            continue;
        }
        let fj: Vec<R> = f
            .part(j)
            .expect("nonzero part")
            .iter()
            .map(|&c| c.scale(wj))
            .collect();
        mul_acc_hom(table, out, &fj, j, gk, k - j);
    }
}

fn finish<R: Real>(f: &Poly<R>, g: Vec<Vec<R>>) -> Poly<R> {
    let mut out = Poly::zero(f.table().clone());
    for (k, part) in g.into_iter().enumerate() {
        out.set_part(k, part);
    }
    out
}

/// 1/f (needs f₀ ≠ 0): `g_k = −(1/f₀) Σ_{j=1..k} f_j g_{k−j}`.
pub fn series_recip<R: Real>(f: &Poly<R>) -> Poly<R> {
    let f0 = f.constant_term();
    let inv = R::one() / f0;
    let js = nonzero_degrees(f);
    let n = f.max_degree();
    let mut g: Vec<Vec<R>> = vec![vec![inv]];
    for k in 1..=n {
        let mut acc = vec![R::zero(); f.table().count(k)];
        conv_acc(&mut acc, f, &js, &g, k, |_| 1.0);
        let s = -inv;
        acc.iter_mut().for_each(|c| *c *= s);
        g.push(acc);
    }
    finish(f, g)
}

/// f^p for a rational p = num/den (needs f₀ > 0 unless p is an integer): the
/// Euler-operator recurrence `g_k = 1/(k·den·f₀) Σ_j (num·j − den·(k−j)) f_j g_{k−j}`, whose
/// weights are exact integers, so the only roundings are those of the working precision.
pub fn series_powf<R: Real>(f: &Poly<R>, p: Rational) -> Poly<R> {
    let f0 = f.constant_term();
    let js = nonzero_degrees(f);
    let n = f.max_degree();
    let mut g: Vec<Vec<R>> = vec![vec![f0.powf(p)]];
    let inv_f0 = R::one() / f0;
    let (num, den) = (p.num as f64, p.den as f64);
    for k in 1..=n {
        let mut acc = vec![R::zero(); f.table().count(k)];
        conv_acc(&mut acc, f, &js, &g, k, |j| {
            num * j as f64 - den * (k - j) as f64
        });
        let s = inv_f0 / R::from_f64(k as f64 * den);
        acc.iter_mut().for_each(|c| *c *= s);
        g.push(acc);
    }
    finish(f, g)
}

/// fⁿ for an integer n: the power recurrence when f₀ ≠ 0 (cheap for sparse f), binary
/// powering otherwise.
pub fn series_powi<R: Real>(f: &Poly<R>, n: i32) -> Poly<R> {
    match n {
        0 => Poly::constant(f.table().clone(), R::one()),
        1 => f.clone(),
        2 => f.mul(f),
        // the recurrence divides by f₀: only when f₀ is certainly non-zero (an interval
        // containing 0 goes through powering)
        _ if f.constant_term().abs() > R::zero() => series_powf(f, Rational::int(n)),
        _ if n < 0 => series_powi(&series_recip(f), -n),
        _ => {
            let (mut acc, mut base, mut k) = (
                Poly::constant(f.table().clone(), R::one()),
                f.clone(),
                n as u32,
            );
            while k > 0 {
                if k & 1 == 1 {
                    acc = acc.mul(&base);
                }
                k >>= 1;
                if k > 0 {
                    base = base.mul(&base);
                }
            }
            acc
        }
    }
}

/// eᶠ: `k g_k = Σ_{j=1..k} j f_j g_{k−j}`.
pub fn series_exp<R: Real>(f: &Poly<R>) -> Poly<R> {
    let js = nonzero_degrees(f);
    let n = f.max_degree();
    let mut g: Vec<Vec<R>> = vec![vec![f.constant_term().exp()]];
    for k in 1..=n {
        let mut acc = vec![R::zero(); f.table().count(k)];
        conv_acc(&mut acc, f, &js, &g, k, |j| j as f64);
        let s = R::one() / R::from_f64(k as f64);
        acc.iter_mut().for_each(|c| *c *= s);
        g.push(acc);
    }
    finish(f, g)
}

/// ln f: `k f₀ g_k = k f_k − Σ_{j=1..k−1} j g_j f_{k−j}`.
pub fn series_ln<R: Real>(f: &Poly<R>) -> Poly<R> {
    let f0 = f.constant_term();
    let js = nonzero_degrees(f);
    let n = f.max_degree();
    let inv_f0 = R::one() / f0;
    let mut g: Vec<Vec<R>> = vec![vec![f0.ln()]];
    for k in 1..=n {
        let mut acc: Vec<R> = match f.part(k) {
            Some(p) => p.iter().map(|&c| c.scale(k as f64)).collect(),
            None => vec![R::zero(); f.table().count(k)],
        };
        // − Σ_j j g_j f_{k−j} = − Σ_{i} (k−i) f_i g_{k−i}, i = k−j ≥ 1
        conv_acc(&mut acc, f, &js, &g, k, |i| -((k - i) as f64));
        let s = inv_f0 / R::from_f64(k as f64);
        acc.iter_mut().for_each(|c| *c *= s);
        g.push(acc);
    }
    finish(f, g)
}

/// (sin f, cos f): `k s_k = Σ j f_j c_{k−j}`, `k c_k = −Σ j f_j s_{k−j}`.
pub fn series_sin_cos<R: Real>(f: &Poly<R>) -> (Poly<R>, Poly<R>) {
    let js = nonzero_degrees(f);
    let n = f.max_degree();
    let f0 = f.constant_term();
    let mut s: Vec<Vec<R>> = vec![vec![f0.sin()]];
    let mut c: Vec<Vec<R>> = vec![vec![f0.cos()]];
    for k in 1..=n {
        let mut sk = vec![R::zero(); f.table().count(k)];
        conv_acc(&mut sk, f, &js, &c, k, |j| j as f64);
        let mut ck = vec![R::zero(); f.table().count(k)];
        conv_acc(&mut ck, f, &js, &s, k, |j| -(j as f64));
        let inv_k = R::one() / R::from_f64(k as f64);
        sk.iter_mut().chain(ck.iter_mut()).for_each(|x| *x *= inv_k);
        s.push(sk);
        c.push(ck);
    }
    (finish(f, s), finish(f, c))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MonomialTable;
    use std::sync::Arc;

    /// Checks a series against finite values at a nearby point (Taylor remainder ~ h^(N+1)).
    fn check(
        f: impl Fn(f64, f64) -> f64,
        g: impl Fn(&Jet<f64>, &Jet<f64>) -> Jet<f64>,
        x0: f64,
        y0: f64,
    ) {
        let tab = Arc::new(MonomialTable::new(2, 14));
        let x = Jet::Series(Poly::variable(tab.clone(), 0, x0));
        let y = Jet::Series(Poly::variable(tab.clone(), 1, y0));
        let s = g(&x, &y).into_poly(&tab);
        let (dx, dy) = (0.013, -0.021);
        let exact = f(x0 + dx, y0 + dy);
        let approx = s.eval(&[dx, dy]);
        assert!(
            (exact - approx).abs() < 1e-14 * exact.abs().max(1.0),
            "{exact} vs {approx}"
        );
    }

    #[test]
    fn elementary_series() {
        check(
            |x, y| (x * x + y * y).powf(-0.5),
            |x, y| x.mul(x).add(&y.mul(y)).powf(Rational::new(-1, 2)),
            0.4,
            0.8,
        );
        check(
            |x, y| (x * x + y * y).powf(-1.5),
            |x, y| x.mul(x).add(&y.mul(y)).powf(Rational::new(-3, 2)),
            0.4,
            0.8,
        );
        check(
            |x, y| (x * y).exp() + (x / y),
            |x, y| x.mul(y).exp().add(&x.div(y)),
            0.4,
            0.8,
        );
        check(
            |x, y| (x + y).ln() * x.sin() - y.cos(),
            |x, y| x.add(y).ln().mul(&x.sin()).sub(&y.cos()),
            0.4,
            0.8,
        );
        check(
            |x, y| (x - y).powi(-3) + x.powi(5),
            |x, y| x.sub(y).powi(-3).add(&x.powi(5)),
            0.4,
            1.3,
        );
        check(
            |x, y| (x * x + y).powf(2.0 / 7.0),
            |x, y| x.mul(x).add(y).powf(Rational::new(2, 7)),
            0.4,
            0.8,
        );
        check(
            |x, y| (x - 2.0 * y).powi(4),
            |x, y| x.sub(&y.mul(&Jet::from_f64(2.0))).powi(4),
            0.0,
            0.0,
        );
    }

    /// Exponents that are not multiples of ½ keep double-double precision: (f^⅓)³ = f and
    /// (f^(−2/5))^(−5/2) = f coefficient by coefficient to ~1e-30.
    #[test]
    fn rational_exponents_in_double_double() {
        let tab = Arc::new(MonomialTable::new(2, 10));
        let x = Jet::Series(Poly::variable(tab.clone(), 0, Dd::new(0.7)));
        let y = Jet::Series(Poly::variable(tab.clone(), 1, Dd::new(-0.3)));
        let f = x.mul(&x).add(&y).add(&Jet::from_f64(0.25));
        let third = f.powf(Rational::new(1, 3));
        let back = third.mul(&third).mul(&third);
        let g = f.powf(Rational::new(-2, 5)).powf(Rational::new(-5, 2));
        let fp = f.into_poly(&tab);
        for r in [back.into_poly(&tab), g.into_poly(&tab)] {
            for (k, i, c) in fp.terms() {
                let d = r.part(k).map_or(Dd::new(0.0), |p| p[i]) - c;
                assert!(d.to_f64().abs() < 1e-29 * c.to_f64().abs(), "{d}");
            }
        }
        let c = Scalar::powf(&Dd::new(2.0), Rational::new(1, 3));
        assert!((c * c * c - Dd::new(2.0)).to_f64().abs() < 1e-31);
    }

    #[test]
    fn univariate_series() {
        // e^t about t = 0 to degree 20: coefficients 1/k!
        let tab = Arc::new(MonomialTable::new(1, 20));
        let t = Jet::Series(Poly::variable(tab.clone(), 0, 0.0));
        let e = t.exp().into_poly(&tab);
        let mut fact = 1.0;
        for k in 0..=20u8 {
            if k > 0 {
                fact *= k as f64;
            }
            assert!((e.coeff(&[k]) * fact - 1.0).abs() < 1e-14);
        }
    }
}
