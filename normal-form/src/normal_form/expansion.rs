//! Helpers of the expansion stage: H in the complex normal coordinates, the real part of a
//! complex polynomial, and the integer vectors checked for resonances.

use crate::complex::Complex;
use crate::linalg::Mat;
use crate::linear::complexification;
use crate::poly::Poly;
use crate::scalar::{Coeff, Real};
use crate::Dd;

pub(super) fn widen<R: Real>(x: R) -> Dd {
    let (hi, lo) = x.hi_lo();
    Dd::from_parts(hi, lo)
}

/// The 2×2 blocks of a matrix acting on the variable pairs (k, n + k) only.
pub(super) fn pair_blocks<T: Coeff>(m: &Mat<T>) -> Vec<[[T; 2]; 2]> {
    let n = m.len() / 2;
    (0..n)
        .map(|k| [[m[k][k], m[k][n + k]], [m[n + k][k], m[n + k][n + k]]])
        .collect()
}

/// H(z_eq + A C u) as a complex polynomial in u (C: the complexification): the real
/// substitution of A, then C pair by pair. The parts of degree ≤ `compensate_to` are
/// substituted in double-double and rounded once (their rounding errors are the ones the
/// small divisors amplify most), the others in R.
pub(super) fn to_complex_coordinates<R: Real>(
    hz: &Poly<R>,
    a: &Mat<R>,
    compensate_to: usize,
) -> Poly<Complex<R>> {
    fn subst<T: Real>(p: &Poly<T>, a: &Mat<T>) -> Poly<Complex<T>> {
        let (c, _) = complexification::<T>(a.len() / 2);
        p.substitute_linear(a)
            .map(Complex::real)
            .substitute_pairs(&pair_blocks(&c))
    }
    let top = compensate_to.min(hz.max_degree());
    let mut high = hz.clone();
    for k in 0..=top {
        high.set_part(k, Vec::new());
    }
    let mut out = subst(&high, a);
    if compensate_to > 0 {
        let mut low = hz.map(widen);
        low.truncate(top);
        let a_dd: Mat<Dd> = a
            .iter()
            .map(|row| row.iter().map(|&x| widen(x)).collect())
            .collect();
        let low = subst(&low, &a_dd);
        let narrow = |x: Dd| R::from_hi_lo(x.hi, x.lo);
        for k in 0..=top {
            if let Some(p) = low.part(k) {
                out.set_part(
                    k,
                    p.iter()
                        .map(|z| Complex::new(narrow(z.re), narrow(z.im)))
                        .collect(),
                );
            }
        }
    }
    out
}

/// (−i)^m
pub(crate) fn minus_i_pow<R: Real>(m: usize) -> Complex<R> {
    match m % 4 {
        0 => Complex::real(R::one()),
        1 => Complex::new(R::zero(), -R::one()),
        2 => Complex::real(-R::one()),
        _ => Complex::new(R::zero(), R::one()),
    }
}

/// All m ∈ ℤⁿ with 0 < |m|₁ ≤ n_max and first nonzero entry positive, by increasing |m|₁.
pub(crate) fn integer_vectors(n: usize, n_max: usize) -> Vec<Vec<i32>> {
    let mut out = Vec::new();
    fn rec(m: &mut Vec<i32>, k: usize, left: i32, out: &mut Vec<Vec<i32>>) {
        if k == m.len() {
            if left == 0 {
                let first = m.iter().find(|&&x| x != 0);
                if first.is_some_and(|&x| x > 0) {
                    out.push(m.clone());
                }
            }
            return;
        }
        for v in -left..=left {
            m[k] = v;
            rec(m, k + 1, left - v.abs(), out);
        }
        m[k] = 0;
    }
    for total in 1..=n_max as i32 {
        let mut m = vec![0; n];
        rec(&mut m, 0, total, &mut out);
    }
    out
}

/// Real parts of a complex polynomial, and the largest imaginary part.
pub(super) fn real_part<R: Real>(p: &Poly<Complex<R>>) -> (Poly<R>, f64) {
    let mut imag: f64 = 0.0;
    for (_, _, c) in p.terms() {
        imag = imag.max(c.im.abs().to_f64());
    }
    (p.map(|c| c.re), imag)
}
