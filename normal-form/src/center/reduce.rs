//! The Lie-series step shared by the centre-manifold reduction and the Birkhoff normal form
//! at a saddle × centre point: in the coordinates `u = (x₁…x_n, y₁…y_n)` where
//! `H₂ = λ x₁y₁ + Σ_{k≥2} iσ_kω_k x_k y_k` (x₁ = Q₁, y₁ = P₁ real; the centres complex as in
//! the elliptic normal form), each monomial `xᵃyᵇ` that `kill` selects is removed at its degree
//! by the generator term `h/⟨ν, a − b⟩`, `ν = (λ, iσ₂ω₂, …)`; the rest is kept. With
//! `kill = a₁ ≠ b₁` this is Jorba & Masdemont's (1999) reduction: every term left has equal
//! exponents in the hyperbolic pair, so `x₁ = y₁ = 0` is invariant (the centre manifold);
//! with `kill = a ≠ b` it is the Birkhoff normal form (a function of x₁y₁ and the x_k y_k).

use crate::complex::Complex;
use crate::lie::lie_transform;
use crate::poly::Poly;
use crate::scalar::{Coeff, Real};
use crate::Dd;

/// Normalises `h` (degrees ≥ 2, H₂ diagonal as above) degree by degree from `from` to `order`,
/// transforming the whole of it to the table's degree; returns the generators by degree.
/// `on_degree(r)` is called before degree r.
pub(crate) fn normalize<R: Real>(
    h: &mut Poly<Complex<R>>,
    from: usize,
    order: usize,
    lambda: Dd,
    omega: &[Dd],
    sigma: &[i8],
    kill: &dyn Fn(&[u8]) -> bool,
    on_degree: &dyn Fn(usize),
) -> Vec<Vec<Complex<R>>> {
    let table = h.table().clone();
    let nmax = table.max_degree();
    let n = table.nvars() / 2;
    let mut generators = vec![Vec::new(); nmax + 1];
    for r in from.max(3)..=order.min(nmax) {
        on_degree(r);
        let Some(hr) = h.part(r) else { continue };
        let hr = hr.to_vec();
        let mut g = vec![Complex::zero(); hr.len()];
        let mut zr = hr.clone();
        let mut any = false;
        for (i, &c) in hr.iter().enumerate() {
            if c.is_zero() {
                continue;
            }
            let e = table.exponents(r, i);
            if !kill(e) {
                continue;
            }
            // ⟨ν, a − b⟩ in double-double, the quotient rounded once
            let m1 = e[0] as f64 - e[n] as f64;
            let mut im = Dd::new(0.0);
            for k in 1..n {
                let mk = e[k] as f64 - e[n + k] as f64;
                im += omega[k - 1].scale(mk * sigma[k - 1] as f64);
            }
            let d = Complex::new(lambda.scale(m1), im);
            let (a, b) = c.re.hi_lo();
            let (x, y) = c.im.hi_lo();
            let q = Complex::new(Dd::from_parts(a, b), Dd::from_parts(x, y)) / d;
            g[i] = Complex::new(R::from_hi_lo(q.re.hi, q.re.lo), R::from_hi_lo(q.im.hi, q.im.lo));
            zr[i] = Complex::zero();
            any = true;
        }
        if any {
            let first: Vec<Complex<R>> = zr.iter().zip(&hr).map(|(&z, &x)| z - x).collect();
            lie_transform(h, &g, r, nmax, Some(first));
            h.set_part(r, zr);
            generators[r] = g;
        }
    }
    generators
}
