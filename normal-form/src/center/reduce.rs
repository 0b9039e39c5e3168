//! The Lie-series step shared by the centre-manifold reduction and the Birkhoff normal form
//! at a saddle × centre point: in the coordinates `u = (x₁…x_n, y₁…y_n)` where
//! `H₂ = λ x₁y₁ + Σ_{k≥2} iσ_kω_k x_k y_k` (x₁ = Q₁, y₁ = P₁ real; the centres complex as in
//! the elliptic normal form), each monomial `xᵃyᵇ` that `kill` selects is removed at its degree
//! by the generator term `h/⟨ν, a − b⟩`, `ν = (λ, iσ₂ω₂, …)`; the rest is kept. With
//! `kill = a₁ ≠ b₁` this is Jorba & Masdemont's (1999) reduction: every term left has equal
//! exponents in the hyperbolic pair, so `x₁ = y₁ = 0` is invariant (the centre manifold);
//! with `kill = a ≠ b` it is the Birkhoff normal form (a function of x₁y₁ and the x_k y_k).

use crate::complex::Complex;
use crate::monomial::MonomialTable;
use crate::poly::Poly;
use crate::scalar::{Coeff, Real};
use crate::Dd;

/// Normalises `h` (degrees ≥ 2, H₂ diagonal as above) degree by degree from `from` to `order`,
/// transforming the whole of it to the table's degree; returns the generators by degree.
/// `on_degree(r)` is called before degree r.
#[allow(clippy::needless_range_loop)]
pub(crate) fn normalize<R: Real>(
    h: &mut Poly<Complex<R>>,
    from: usize,
    order: usize,
    lambda: Dd,
    omega: &[Dd],
    sigma: &[i8],
    kill: &dyn Fn(&[u8]) -> bool,
    pruned: bool,
    on_degree: &dyn Fn(usize),
) -> Vec<Vec<Complex<R>>> {
    let table = h.table().clone();
    let nmax = table.max_degree();
    let n = table.nvars() / 2;
    let mut generators = vec![Vec::new(); nmax + 1];
    if pruned {
        prune(h, nmax);
    }
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
            g[i] = Complex::new(
                R::from_hi_lo(q.re.hi, q.re.lo),
                R::from_hi_lo(q.im.hi, q.im.lo),
            );
            zr[i] = Complex::zero();
            any = true;
        }
        if any {
            let first: Vec<Complex<R>> = zr.iter().zip(&hr).map(|(&z, &x)| z - x).collect();
            lie_transform(h, &g, r, nmax, Some(first), pruned);
            h.set_part(r, zr);
            if pruned {
                prune(h, nmax);
            }
            generators[r] = g;
        }
    }
    generators
}

/// Zeroes every term whose degree plus hyperbolic degree (a₁ + b₁) exceeds N.
///
/// They cannot reach a term with a₁ = b₁ = 0 of degree ≤ N, nor any term with
/// degree + a₁ + b₁ ≤ N: in a bracket `{T, G}` of terms of degree s, r and hyperbolic degree
/// t, g, the result has degree s + r − 2 and hyperbolic degree t + g (derivatives in the
/// centres) or t + g − 2 (in the hyperbolic pair, which needs t, g ≥ 1), so its
/// φ = degree + hyperbolic degree is at least max(φ_T, φ_G) whenever φ_G ≥ 4 and, for the
/// hyperbolic derivatives, φ_T ≥ 4 — always the case for generators (r ≥ 3, g ≥ 1 when they
/// touch the hyperbolic pair) and for the terms they meet (the link from H₂ is exact). The
/// reduced Hamiltonian, and every Birkhoff coefficient with 2|a| + 2a₁ ≤ N, are therefore
/// unchanged, at a fraction of the cost (the terms of high hyperbolic degree are most of the
/// monomials of high degree).
fn prune<R: Real>(h: &mut Poly<Complex<R>>, nmax: usize) {
    let table = h.table().clone();
    let n = table.nvars() / 2;
    for k in 3..=nmax {
        if h.part(k).is_none() {
            continue;
        }
        let part = h.part_mut(k);
        for (i, c) in part.iter_mut().enumerate() {
            let e = table.exponents(k, i);
            if k + e[0] as usize + e[n] as usize > nmax {
                *c = Complex::zero();
            }
        }
    }
}

/// A homogeneous polynomial in sparse form: coefficients, monomial keys and the hyperbolic
/// degree a₁ + b₁ of each monomial.
struct Sparse<C> {
    vals: Vec<C>,
    keys: Vec<u32>,
    hdeg: Vec<u8>,
}

/// `sign · ∂a/∂u_v` of a homogeneous part of degree k ≥ 1, in sparse form.
fn sparse_deriv<C: Coeff>(
    table: &MonomialTable,
    a: &[C],
    k: usize,
    v: usize,
    sign: f64,
) -> Sparse<C> {
    let n = table.nvars() / 2;
    let prev = table.degree(k - 1);
    let mut out = Sparse {
        vals: Vec::new(),
        keys: Vec::new(),
        hdeg: Vec::new(),
    };
    for (&c, &(j, e)) in a.iter().zip(&table.degree(k).deriv[v]) {
        if e != 0 && !c.is_zero() {
            let j = j as usize;
            let ex = &prev.exps[j * 2 * n..(j + 1) * 2 * n];
            out.vals.push(c.scale(e as f64 * sign));
            out.keys.push(prev.keys[j]);
            out.hdeg.push(ex[0] + ex[n]);
        }
    }
    out
}

/// `out += {t, G}` (t homogeneous of degree `deg`, out of degree deg + r − 2), both factors
/// sparse; with `pruned`, products landing on a term of degree + hyperbolic degree > N are
/// skipped (see [`prune`]).
fn bracket<C: Coeff>(
    table: &MonomialTable,
    out: &mut [C],
    t: &[C],
    deg: usize,
    gd: &[Sparse<C>],
    r: usize,
    pruned: bool,
) {
    let nmax = table.max_degree();
    let od = deg + r - 2;
    let lk = &table.degree(od).lookup[..];
    let room = if pruned {
        nmax.saturating_sub(od)
    } else {
        usize::MAX
    };
    for (v, g) in gd.iter().enumerate() {
        if g.vals.is_empty() {
            continue;
        }
        // T_{x_k} G_{y_k} − T_{y_k} G_{x_k}: gd[k] = G_{y_k}, gd[n + k] = −G_{x_k}
        let tv = sparse_deriv(table, t, deg, v, 1.0);
        for ((&a, &ka), &ha) in tv.vals.iter().zip(&tv.keys).zip(&tv.hdeg) {
            if ha as usize > room {
                continue;
            }
            let left = room - ha as usize;
            for ((&b, &kb), &hb) in g.vals.iter().zip(&g.keys).zip(&g.hdeg) {
                if hb as usize > left {
                    continue;
                }
                let idx = lk[(ka + kb) as usize] as usize;
                out[idx].mul_acc(a, b);
            }
        }
    }
}

/// H ← exp(L_G) H = Σ_j L_Gʲ H / j! truncated at the table's degree, G homogeneous of degree
/// r ≥ 3, `L_G F = {F, G}`; `first_link_from_h2` is the exact `{H₂, G}` (= Z_r − H_r).
fn lie_transform<C: Coeff>(
    f: &mut Poly<C>,
    g: &[C],
    r: usize,
    cap: usize,
    first_link_from_h2: Option<Vec<C>>,
    pruned: bool,
) {
    let table = f.table().clone();
    let n = table.nvars() / 2;
    let gd: Vec<Sparse<C>> = (0..2 * n)
        .map(|v| {
            if v < n {
                sparse_deriv(&table, g, r, n + v, 1.0)
            } else {
                sparse_deriv(&table, g, r, v - n, -1.0)
            }
        })
        .collect();
    let mut first = first_link_from_h2;
    for s in (1..=cap).rev() {
        let Some(part) = f.part(s) else { continue };
        if part.iter().all(|c| c.is_zero()) {
            continue;
        }
        let mut t: Vec<C> = part.to_vec();
        let mut deg = s;
        let mut j = 1usize;
        while deg + r - 2 <= cap {
            let new_deg = deg + r - 2;
            let next: Vec<C> = match (s, j, first.take()) {
                (2, 1, Some(exact)) => exact,
                (_, _, other) => {
                    first = other;
                    let mut out = vec![C::zero(); table.count(new_deg)];
                    bracket(&table, &mut out, &t, deg, &gd, r, pruned);
                    if j > 1 {
                        let inv = C::one() / C::from_f64(j as f64);
                        out.iter_mut().for_each(|c| *c *= inv);
                    }
                    out
                }
            };
            if next.iter().all(|c| c.is_zero()) {
                break;
            }
            let dst = f.part_mut(new_deg);
            for (d, &x) in dst.iter_mut().zip(&next) {
                *d += x;
            }
            t = next;
            deg = new_deg;
            j += 1;
        }
    }
}
