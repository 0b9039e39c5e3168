//! Lie-series (Deprit) normalisation in diagonal complex coordinates.
//!
//! Variables `u = (x₁…x_n, y₁…y_n)` with `{x_k, y_k} = 1` and
//! `H₂ = Σ λ_k x_k y_k`, `λ_k = i σ_k ω_k`. For each degree r = 3…N the generator `G_r`
//! solves the homological equation `{H₂, G_r} + H_r = Z_r`: since
//! `{H₂, xᵃyᵇ} = ⟨λ, b − a⟩ xᵃyᵇ`, each monomial with `a ≠ b` (and no resonance) gets
//! `g_{ab} = h_{ab} / ⟨λ, a − b⟩`, the seed's eq. (21), and `Z_r` keeps the terms with
//! `a = b` (plus resonant ones if asked). Then `H ← exp(L_{G_r}) H = Σ_j L_{G_r}ʲ H / j!` with
//! `L_G F = {F, G}`, i.e. `H ← H ∘ φ¹_{G_r}` (time-one flow of G_r), truncated at degree N.
//! Each homogeneous part `H_s` is pushed along the chain `T₀ = H_s`, `T_j = {T_{j−1}, G}/j`
//! into degree `s + j(r−2)`; parts are processed by decreasing degree so that each chain
//! starts from the untransformed part, and the first link of the chain from H₂ is taken as
//! `Z_r − H_r` exactly (Jorba 1999, "A methodology for the numerical computation of normal
//! forms, centre manifolds and first integrals of Hamiltonian systems").
//!
//! H and every G_r are real functions, so on real points `conj(x_k) = i y_k`,
//! `conj(y_k) = i x_k` and their coefficients satisfy `c_{ba} = i^{|a|+|b|} conj(c_{ab})`.
//! Each bracket is then `{T, G} = P + conj(P)` with `P = Σ_k T_{x_k} G_{y_k}` — half the
//! products of the textbook formula, and exactly real. In f64 runs the brackets landing in
//! low degrees are formed in double-double and rounded once ([`bracket_real_compensated`]):
//! P and conj(P) cancel by up to two orders of magnitude there, and those degrees meet every
//! later small divisor.

use crate::complex::Complex;
use crate::monomial::MonomialTable;
use crate::poly::{deriv_hom, deriv_hom_sparse, mul_acc_sparse, Poly};
use crate::scalar::{Coeff, Real};
use crate::Dd;
use std::collections::BTreeMap;

/// Derivatives of a homogeneous generator, arranged for `{T, G} = Σ_k T_{x_k}·G_{y_k} + T_{y_k}·(−G_{x_k})`.
struct GeneratorDerivs<C> {
    degree: usize,
    /// For k < n: ∂G/∂y_k ; for k ≥ n: −∂G/∂x_{k−n}. Empty if zero.
    d: Vec<Vec<C>>,
}

impl<C: Coeff> GeneratorDerivs<C> {
    /// All 2n derivatives, or (`half`) only the n derivatives ∂G/∂y_k.
    fn new(table: &MonomialTable, g: &[C], r: usize, half: bool) -> Self {
        let n = table.nvars() / 2;
        let mut d = Vec::with_capacity(2 * n);
        for k in 0..n {
            d.push(deriv_hom(table, g, r, n + k));
        }
        if !half {
            for k in 0..n {
                d.push(deriv_hom(table, g, r, k).into_iter().map(|c| -c).collect());
            }
        }
        for v in d.iter_mut() {
            if v.iter().all(|c| c.is_zero()) {
                v.clear();
            }
        }
        GeneratorDerivs { degree: r, d }
    }
    fn is_zero(&self) -> bool {
        self.d.iter().all(|v| v.is_empty())
    }
}

/// Reusable buffers of the brackets (no allocation per bracket).
struct Scratch<C> {
    /// ∂T/∂u_v in sparse form
    vals: Vec<C>,
    keys: Vec<u32>,
}

impl<C> Scratch<C> {
    fn new() -> Self {
        Scratch {
            vals: Vec::new(),
            keys: Vec::new(),
        }
    }
}

/// `out += {t, G}` for a homogeneous `t` of degree `deg ≥ 1`: 2n products, each of the
/// sparse derivative of t with a derivative of G.
fn bracket_acc<C: Coeff>(
    table: &MonomialTable,
    out: &mut [C],
    t: &[C],
    deg: usize,
    g: &GeneratorDerivs<C>,
    s: &mut Scratch<C>,
) {
    for (v, gv) in g.d.iter().enumerate() {
        if gv.is_empty() {
            continue;
        }
        // v < n: T_{x_v} G_{y_v}; v = n + k: T_{y_k} (−G_{x_k}), i.e. ∂T/∂u_v · g.d[v]
        deriv_hom_sparse(table, &mut s.vals, &mut s.keys, t, deg, v);
        let od = deg + g.degree - 2;
        mul_acc_sparse(table, out, od, &s.vals, &s.keys, gv, g.degree - 1);
    }
}

/// `i^d · conj(z)`: the coefficient of `x^b y^a` in `conj(F)` when `z` is that of `x^a y^b`
/// in F and d = |a| + |b| (since `conj(x_k) = i y_k`, `conj(y_k) = i x_k` on real points).
#[inline(always)]
fn i_pow_conj<R: Real>(z: Complex<R>, d: usize) -> Complex<R> {
    match d % 4 {
        0 => Complex::new(z.re, -z.im),
        1 => Complex::new(z.im, z.re),
        2 => Complex::new(-z.re, z.im),
        _ => Complex::new(-z.im, -z.re),
    }
}

/// `out = {t, G}` (`out` zero on entry) for **real** t and G (real-valued on real points) in
/// the complex coordinates, with half the products. On real points
/// `conj(∂F/∂x_k) = −i ∂F/∂y_k` for real F, hence `T_{y_k}G_{x_k} = −conj(T_{x_k}G_{y_k})` and
/// `{T, G} = P + conj(P)`, `P = Σ_k T_{x_k} G_{y_k}`: n products instead of 2n, and the
/// result is exactly real (its coefficients satisfy `c_{ba} = i^d conj(c_{ab})`).
fn bracket_real<R: Real>(
    table: &MonomialTable,
    out: &mut [Complex<R>],
    t: &[Complex<R>],
    deg: usize,
    g: &GeneratorDerivs<Complex<R>>,
    s: &mut Scratch<Complex<R>>,
) {
    let n = table.nvars() / 2;
    let od = deg + g.degree - 2;
    for k in 0..n {
        if g.d[k].is_empty() {
            continue;
        }
        deriv_hom_sparse(table, &mut s.vals, &mut s.keys, t, deg, k);
        mul_acc_sparse(table, out, od, &s.vals, &s.keys, &g.d[k], g.degree - 1);
    }
    // out = P + conj(P) in place, pair by pair
    let mirror = &table.degree(od).mirror;
    for i in 0..out.len() {
        let m = mirror[i] as usize;
        if m > i {
            let (p, q) = (out[i], out[m]);
            out[i] = p + i_pow_conj(q, od);
            out[m] = q + i_pow_conj(p, od);
        } else if m == i {
            out[i] += i_pow_conj(out[i], od);
        }
    }
}

/// `bracket(out, t, deg, j)`: `out = {t, G}/j` for a homogeneous t of degree deg, `out` zero
/// on entry.
type BracketFn<'a, C> = dyn FnMut(&mut [C], &[C], usize, usize) + 'a;

/// `F ← exp(L_G) F = Σ_j L_Gʲ F / j!` truncated at degree `cap`, G homogeneous of degree
/// r ≥ 3, with `bracket(out, t, deg)` giving `{t, G}`.
/// `first_link_from_h2`: the exact `{H₂, G}` (= Z_r − H_r) used for the chain from degree 2.
fn lie_chain<C: Coeff>(
    f: &mut Poly<C>,
    r: usize,
    cap: usize,
    first_link_from_h2: Option<Vec<C>>,
    bracket: &mut BracketFn<'_, C>,
) {
    let table = f.table().clone();
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
                    bracket(&mut out, &t, deg, j);
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

/// `out /= j` (as a product with 1/j).
fn divide<C: Coeff>(out: &mut [C], j: usize) {
    if j > 1 {
        let inv = C::one() / C::from_f64(j as f64);
        out.iter_mut().for_each(|c| *c *= inv);
    }
}

/// [`lie_chain`] with the full bracket (any canonical coordinates, any coefficients).
pub(crate) fn lie_transform<C: Coeff>(
    f: &mut Poly<C>,
    g: &[C],
    r: usize,
    cap: usize,
    first_link_from_h2: Option<Vec<C>>,
) {
    let table = f.table().clone();
    let gd = GeneratorDerivs::new(&table, g, r, false);
    if gd.is_zero() {
        return;
    }
    let mut scratch = Scratch::new();
    lie_chain(f, r, cap, first_link_from_h2, &mut |out, t, deg, j| {
        bracket_acc(&table, out, t, deg, &gd, &mut scratch);
        divide(out, j);
    });
}

/// [`lie_chain`] for a real F and a real G in the complex coordinates (half the products,
/// see [`bracket_real`]); brackets with output degree ≤ `compensate_to` are accumulated in
/// double-double and rounded once (see [`bracket_real_compensated`]).
pub(crate) fn lie_transform_real<R: Real>(
    f: &mut Poly<Complex<R>>,
    g: &[Complex<R>],
    r: usize,
    cap: usize,
    first_link_from_h2: Option<Vec<Complex<R>>>,
    compensate_to: usize,
) {
    let table = f.table().clone();
    let gd = GeneratorDerivs::new(&table, g, r, true);
    if gd.is_zero() {
        return;
    }
    let mut scratch = Scratch::new();
    // the lowest bracket output degree is r + 1 (from H₃; the H₂ link is given)
    let wide = (compensate_to > r).then(|| {
        let gw: Vec<Complex<Dd>> = g.iter().map(|&c| widen(c)).collect();
        GeneratorDerivs::new(&table, &gw, r, true)
    });
    let mut sw = Scratch::new();
    lie_chain(
        f,
        r,
        cap,
        first_link_from_h2,
        &mut |out, t, deg, j| match &wide {
            Some(gdw) if deg + r - 2 <= compensate_to => {
                bracket_real_compensated(&table, out, t, deg, j, gdw, &mut sw)
            }
            _ => {
                bracket_real(&table, out, t, deg, &gd, &mut scratch);
                divide(out, j);
            }
        },
    );
}

fn widen<R: Real>(c: Complex<R>) -> Complex<Dd> {
    let (a, b) = c.re.hi_lo();
    let (x, y) = c.im.hi_lo();
    Complex::new(Dd::from_parts(a, b), Dd::from_parts(x, y))
}

/// `{t, G}/j` as [`bracket_real`] but in double-double: the f64 inputs are widened exactly,
/// the products accumulated with error-free transformations, and `P + conj(P)` and the
/// division by j formed before the one rounding into `out`. However much `P` cancels, `out`
/// is the correctly rounded bracket of the rounded inputs.
fn bracket_real_compensated<R: Real>(
    table: &MonomialTable,
    out: &mut [Complex<R>],
    t: &[Complex<R>],
    deg: usize,
    j: usize,
    g: &GeneratorDerivs<Complex<Dd>>,
    s: &mut Scratch<Complex<Dd>>,
) {
    let tw: Vec<Complex<Dd>> = t.iter().map(|&c| widen(c)).collect();
    let mut w = vec![Complex::zero(); out.len()];
    bracket_real(table, &mut w, &tw, deg, g, s);
    let inv = Dd::new(1.0) / Dd::new(j as f64);
    for (o, x) in out.iter_mut().zip(&w) {
        let (re, im) = (x.re * inv, x.im * inv);
        *o = Complex::new(R::from_hi_lo(re.hi, re.lo), R::from_hi_lo(im.hi, im.lo));
    }
}

/// A small divisor met: `m·ω` for an integer vector m relative to the positive frequencies.
#[derive(Clone, Debug)]
pub(crate) struct Divisor<R> {
    pub m: Vec<i32>,
    pub value: R,
    pub order: usize,
}

/// Output of the normalisation.
pub(crate) struct LieOutput<R> {
    /// Normalised Hamiltonian Z (in u), degrees 0 and 2…N, and the transformed but not
    /// normalised degrees N+1…M.
    pub z: Poly<Complex<R>>,
    /// Generators G_r (index r; empty for r < 3 or zero).
    pub generators: Vec<Vec<Complex<R>>>,
    /// Every distinct m met with its divisor, by first order.
    pub divisors: Vec<Divisor<R>>,
}

/// Canonical form of m relative to positive frequencies: mω = Σ σ_k ω_k m_k, sign fixed so
/// that the first nonzero entry is positive.
pub(crate) fn canonical_m(m: &[i32], sigma: &[i8]) -> (Vec<i32>, bool) {
    let mut v: Vec<i32> = m.iter().zip(sigma).map(|(&a, &s)| a * s as i32).collect();
    let flip = v.iter().find(|&&x| x != 0).is_some_and(|&x| x < 0);
    if flip {
        v.iter_mut().for_each(|x| *x = -*x);
    }
    (v, flip)
}

/// The normalisation degree by degree: H (complex, degrees ≥ 2, H₂ = Σ λ_k x_k y_k)
/// transformed by the generators found so far, up to the table's degree M. After
/// [`step`](Self::step)s 3…N its degrees ≤ N are Z and its degrees N+1…M are
/// H ∘ φ_{G₃} ∘ … ∘ φ_{G_N} there, not normalised (the remainder of order N); a further step
/// only adds G_{N+1}: the generators and the transformed terms of the lower degrees are those
/// of every higher order. Truncating at a higher M changes no degree ≤ M (a degree of a Lie
/// series depends on the lower degrees only).
pub(crate) struct Normalizer<'a, R: Real, W: Real> {
    /// H transformed by the generators so far.
    pub h: Poly<Complex<R>>,
    /// Generators G_r (index r; empty for r < 3, zero, or not yet computed).
    pub generators: Vec<Vec<Complex<R>>>,
    divisors: BTreeMap<Vec<i32>, Divisor<R>>,
    omega_w: &'a [W],
    sigma: &'a [i8],
    is_resonant: &'a dyn Fn(&[i32]) -> bool,
    compensate_to: usize,
}

impl<'a, R: Real, W: Real> Normalizer<'a, R, W> {
    /// `omega_w`: the frequencies in double-double or wider (the divisors are formed from
    /// them); `is_resonant(m)` decides whether the term is kept (resonant normal form); it is
    /// only asked about canonical m; brackets with output degree ≤ `compensate_to` are
    /// accumulated in double-double ([`bracket_real_compensated`]).
    pub(crate) fn new(
        mut h: Poly<Complex<R>>,
        omega_w: &'a [W],
        sigma: &'a [i8],
        is_resonant: &'a dyn Fn(&[i32]) -> bool,
        compensate_to: usize,
    ) -> Self {
        let nmax = h.table().max_degree();
        h.set_part(1, Vec::new());
        Normalizer {
            h,
            generators: vec![Vec::new(); nmax + 1],
            divisors: BTreeMap::new(),
            omega_w,
            sigma,
            is_resonant,
            compensate_to,
        }
    }

    /// Every distinct m met so far with its divisor, by increasing |m·ω|.
    pub(crate) fn divisors(&self) -> Vec<Divisor<R>> {
        let mut divisors: Vec<Divisor<R>> = self.divisors.values().cloned().collect();
        divisors.sort_by(|a, b| a.value.abs().to_f64().total_cmp(&b.value.abs().to_f64()));
        divisors
    }

    /// Normalises degree r (the degrees 3…r−1 normalised before): G_r, and H ← H ∘ φ_{G_r}
    /// to the table's degree.
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn step(&mut self, r: usize) {
        let table = self.h.table().clone();
        let nmax = table.max_degree();
        let n = table.nvars() / 2;
        let Some(hr) = self.h.part(r) else { return };
        let hr = hr.to_vec();
        let mut g = vec![Complex::zero(); hr.len()];
        let mut zr = vec![Complex::zero(); hr.len()];
        let mut any = false;
        let mut m = vec![0i32; n];
        for (i, &c) in hr.iter().enumerate() {
            if c.is_zero() {
                continue;
            }
            let e = table.exponents(r, i);
            for k in 0..n {
                m[k] = e[k] as i32 - e[n + k] as i32;
            }
            if m.iter().all(|&x| x == 0) {
                zr[i] = c;
                continue;
            }
            let (cm, _) = canonical_m(&m, self.sigma);
            let omega_w = self.omega_w;
            self.divisors.entry(cm.clone()).or_insert_with(|| {
                let v = cm
                    .iter()
                    .zip(omega_w)
                    .fold(W::zero(), |s, (&a, &w)| s + w.scale(a as f64));
                Divisor {
                    m: cm.clone(),
                    value: R::convert(v),
                    order: r,
                }
            });
            if (self.is_resonant)(&cm) {
                zr[i] = c;
                continue;
            }
            // g = h / ⟨λ, a − b⟩, ⟨λ, a − b⟩ = i Σ σ_k ω_k m_k: the divisor from the
            // double-double frequencies and each part divided once, so that g is the
            // correctly rounded quotient (the small divisors amplify every rounding here)
            let s = m
                .iter()
                .zip(omega_w)
                .zip(self.sigma)
                .fold(W::zero(), |acc, ((&mk, &w), &sg)| {
                    acc + w.scale((mk * sg as i32) as f64)
                });
            let q = |x: R| R::convert(W::convert(x) / s);
            g[i] = Complex::new(q(c.im), q(-c.re));
            any = true;
        }
        if any {
            let first: Vec<Complex<R>> = zr.iter().zip(&hr).map(|(&z, &x)| z - x).collect();
            lie_transform_real(&mut self.h, &g, r, nmax, Some(first), self.compensate_to);
            // the degree-r part is Z_r up to rounding of h + (z − h); set it exactly
            self.h.set_part(r, zr);
            self.generators[r] = g;
        }
    }
}

/// Runs the normalisation of `h` (complex, degrees ≥ 2, H₂ = Σ λ_k x_k y_k) to degree
/// `order` = N ([`Normalizer`] through degree N): generators G₃…G_N, and H transformed up to
/// the table's degree M ≥ N; `on_degree(r)` is called before degree r is normalised.
pub(crate) fn normalize<R: Real, W: Real>(
    h: Poly<Complex<R>>,
    order: usize,
    omega_w: &[W],
    sigma: &[i8],
    is_resonant: &dyn Fn(&[i32]) -> bool,
    compensate_to: usize,
    on_degree: &dyn Fn(usize),
) -> LieOutput<R> {
    let nmax = h.table().max_degree();
    let mut nz = Normalizer::new(h, omega_w, sigma, is_resonant, compensate_to);
    for r in 3..=order.min(nmax) {
        on_degree(r);
        nz.step(r);
    }
    let divisors = nz.divisors();
    let mut h = nz.h;
    h.prune();
    LieOutput {
        z: h,
        generators: nz.generators,
        divisors,
    }
}

/// Extends the coordinate maps of [`coordinate_maps`] (generators 3…`from`, truncated at
/// `cap`) to the generators 3…N (`generators.len() − 1`), reusing them: the forward map
/// (old in terms of new) takes the new flows last, `w ∘ Φ_N = (w ∘ Φ_from) ∘ φ_{from+1} ∘ …`;
/// the inverse map (new in terms of old) takes them first,
/// `w' = E⁻₃⋯E⁻_from (E⁻_{from+1}⋯E⁻_N w)` with `E⁻_r f = f ∘ φ_{−G_r}`, so it gains
/// `E⁻₃⋯E⁻_from (D)` with `D = E⁻_{from+1}⋯E⁻_N w − w`, which starts at degree `from`: its
/// Lie chains are short. Equal to [`coordinate_maps`] of all the generators up to rounding.
pub(crate) fn extend_coordinate_maps<C: Coeff>(
    table: &std::sync::Arc<MonomialTable>,
    generators: &[Vec<C>],
    from: usize,
    maps: &mut [Poly<C>],
    cap: usize,
    forward: bool,
) {
    let nmax = generators.len() - 1;
    let neg = |g: &[C]| -> Vec<C> { g.iter().map(|&c| -c).collect() };
    for (j, map) in maps.iter_mut().enumerate() {
        if forward {
            for (r, g) in generators.iter().enumerate().skip(from + 1) {
                if !g.is_empty() {
                    lie_transform(map, g, r, cap, None);
                }
            }
            continue;
        }
        let w = Poly::variable(table.clone(), j, C::zero());
        let mut f = w.clone();
        for r in (from + 1..=nmax).rev() {
            if !generators[r].is_empty() {
                lie_transform(&mut f, &neg(&generators[r]), r, cap, None);
            }
        }
        if let Some(w1) = w.part(1) {
            for (d, &x) in f.part_mut(1).iter_mut().zip(w1) {
                *d -= x;
            }
        }
        for r in (3..=from.min(nmax)).rev() {
            if !generators[r].is_empty() {
                lie_transform(&mut f, &neg(&generators[r]), r, cap, None);
            }
        }
        for k in 1..=cap {
            if let Some(p) = f.part(k) {
                let p = p.to_vec();
                for (d, x) in map.part_mut(k).iter_mut().zip(p) {
                    *d += x;
                }
            }
        }
    }
}

/// Old coordinates as series in the new ones (`forward = true`: `w = φ_{G₃}∘…∘φ_{G_N}(w')`,
/// computed as `w_j ∘ φ_{G₃} ∘ … = exp(L_{G_N})…exp(L_{G₃}) w_j`, generators applied in the
/// order 3…N), or the new ones in terms of the old (`forward = false`: the flows of −G_r in
/// the order N…3), truncated at degree `cap`. Works in any canonical coordinates in which
/// the generators are given (the real normal coordinates (Q, P) in practice).
pub(crate) fn coordinate_maps<C: Coeff>(
    table: &std::sync::Arc<MonomialTable>,
    generators: &[Vec<C>],
    cap: usize,
    forward: bool,
) -> Vec<Poly<C>> {
    let d = table.nvars();
    let nmax = generators.len() - 1;
    (0..d)
        .map(|j| {
            let mut f = Poly::variable(table.clone(), j, C::zero());
            let order: Vec<usize> = if forward {
                (3..=nmax).collect()
            } else {
                (3..=nmax).rev().collect()
            };
            for r in order {
                let g = &generators[r];
                if g.is_empty() {
                    continue;
                }
                if forward {
                    lie_transform(&mut f, g, r, cap, None);
                } else {
                    let neg: Vec<C> = g.iter().map(|&c| -c).collect();
                    lie_transform(&mut f, &neg, r, cap, None);
                }
            }
            f
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linear::complexification;
    use std::sync::Arc;

    /// A real polynomial of degree `deg` in (Q₁, Q₂, P₁, P₂), in the complex coordinates.
    fn real_poly(table: &Arc<MonomialTable>, deg: usize, seed: u64) -> Vec<Complex<f64>> {
        let mut rng = lasalle_testkit::Rng::new(seed);
        let mut p: Poly<f64> = Poly::zero(table.clone());
        let part = (0..table.count(deg))
            .map(|_| rng.uniform(-0.5, 0.5))
            .collect();
        p.set_part(deg, part);
        // (Q, P) = C u
        let (c, _) = complexification::<f64>(2);
        p.map(Complex::real)
            .substitute_linear(&c)
            .part(deg)
            .unwrap()
            .to_vec()
    }

    #[test]
    fn half_bracket_of_real_functions_is_the_bracket() {
        let table = Arc::new(MonomialTable::new(4, 9));
        for (dt, dg) in [(2, 3), (4, 3), (3, 5), (5, 4)] {
            let t = real_poly(&table, dt, 7 + dt as u64);
            let g = real_poly(&table, dg, 99 + dg as u64);
            let od = dt + dg - 2;
            let mut full = vec![Complex::zero(); table.count(od)];
            let mut half = full.clone();
            let mut s = Scratch::new();
            let gd = GeneratorDerivs::new(&table, &g, dg, false);
            bracket_acc(&table, &mut full, &t, dt, &gd, &mut s);
            let gd = GeneratorDerivs::new(&table, &g, dg, true);
            bracket_real(&table, &mut half, &t, dt, &gd, &mut s);
            let scale = full.iter().map(|c| c.magnitude()).fold(0.0, f64::max);
            assert!(scale > 0.1);
            for (a, b) in full.iter().zip(&half) {
                assert!((*a - *b).magnitude() < 1e-14 * scale, "{a:?} vs {b:?}");
            }
        }
    }
}
