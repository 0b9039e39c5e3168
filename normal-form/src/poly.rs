//! Truncated multivariate polynomials `Σ_{|α| ≤ N} c_α x^α`, stored as one dense array per
//! total degree (see [`MonomialTable`]); an empty array is a zero homogeneous part.

use crate::monomial::MonomialTable;
use crate::scalar::Coeff;
use std::sync::Arc;

/// A polynomial in `nvars` variables truncated at total degree N, over the coefficient `T`.
///
/// All polynomials that are combined must share the same [`MonomialTable`] (same `Arc`);
/// products drop every term above degree N.
#[derive(Clone, Debug)]
pub struct Poly<T> {
    table: Arc<MonomialTable>,
    parts: Vec<Vec<T>>,
}

/// `out += a·b` for homogeneous parts `a` (degree `da`) and `b` (degree `db`); `out` has
/// degree `da + db`.
#[inline]
pub fn mul_acc_hom<T: Coeff>(
    table: &MonomialTable,
    out: &mut [T],
    a: &[T],
    da: usize,
    b: &[T],
    db: usize,
) {
    let (a, da, b, db) = if a.len() <= b.len() {
        (a, da, b, db)
    } else {
        (b, db, a, da)
    };
    let lk = &table.degree(da + db).lookup[..];
    let ka = &table.degree(da).keys[..];
    let kb = &table.degree(db).keys[..];
    assert!(ka.len() == a.len() && kb.len() == b.len() && out.len() == table.count(da + db));
    T::mul_acc_kernel(out, a, ka, b, kb, lk);
}

/// ∂a/∂x_v of a homogeneous part `a` of degree `k ≥ 1`, as a part of degree k−1.
pub fn deriv_hom<T: Coeff>(table: &MonomialTable, a: &[T], k: usize, v: usize) -> Vec<T> {
    let mut out = vec![T::zero(); table.count(k - 1)];
    for (&c, &(j, e)) in a.iter().zip(&table.degree(k).deriv[v]) {
        if e != 0 && !c.is_zero() {
            out[j as usize] = c.scale(e as f64);
        }
    }
    out
}

/// ∂a/∂x_v of a homogeneous part `a` of degree `k ≥ 1` in sparse form: its nonzero
/// coefficients and their monomial keys (degree k−1), into reusable buffers.
pub fn deriv_hom_sparse<T: Coeff>(
    table: &MonomialTable,
    vals: &mut Vec<T>,
    keys: &mut Vec<u32>,
    a: &[T],
    k: usize,
    v: usize,
) {
    vals.clear();
    keys.clear();
    let prev = &table.degree(k - 1).keys;
    for (&c, &(j, e)) in a.iter().zip(&table.degree(k).deriv[v]) {
        if e != 0 && !c.is_zero() {
            vals.push(c.scale(e as f64));
            keys.push(prev[j as usize]);
        }
    }
}

/// `out += a·b` for a sparse `a` (coefficients and keys, e.g. from [`deriv_hom_sparse`]) and
/// a dense homogeneous part `b` of degree `db`; `out` is the part of degree `deg_out`.
pub fn mul_acc_sparse<T: Coeff>(
    table: &MonomialTable,
    out: &mut [T],
    deg_out: usize,
    a: &[T],
    ka: &[u32],
    b: &[T],
    db: usize,
) {
    let lk = &table.degree(deg_out).lookup[..];
    let kb = &table.degree(db).keys[..];
    assert!(ka.len() == a.len() && kb.len() == b.len() && out.len() == table.count(deg_out));
    // the longer array inside (the kernels vectorise the inner loop)
    if a.len() <= b.len() {
        T::mul_acc_kernel(out, a, ka, b, kb, lk);
    } else {
        T::mul_acc_kernel(out, b, kb, a, ka, lk);
    }
}

fn is_zero_slice<T: Coeff>(a: &[T]) -> bool {
    a.iter().all(|c| c.is_zero())
}

impl<T: Coeff> Poly<T> {
    /// The zero polynomial.
    pub fn zero(table: Arc<MonomialTable>) -> Self {
        let n = table.max_degree() + 1;
        Poly {
            table,
            parts: vec![Vec::new(); n],
        }
    }
    /// The constant `c`.
    pub fn constant(table: Arc<MonomialTable>, c: T) -> Self {
        let mut p = Poly::zero(table);
        if !c.is_zero() {
            p.parts[0] = vec![c];
        }
        p
    }
    /// The linear form `Σ_v coeffs[v]·x_v`.
    pub fn linear(table: Arc<MonomialTable>, coeffs: &[T]) -> Self {
        assert_eq!(coeffs.len(), table.nvars());
        let mut p = Poly::zero(table);
        if p.max_degree() >= 1 {
            let mut part = vec![T::zero(); p.table.count(1)];
            for (v, &c) in coeffs.iter().enumerate() {
                let mut e = vec![0u8; coeffs.len()];
                e[v] = 1;
                let (_, i) = p.table.index(&e).expect("degree-1 monomial");
                part[i] = c;
            }
            p.parts[1] = part;
        }
        p
    }
    /// The variable `x_v` (plus a constant `c0`).
    pub fn variable(table: Arc<MonomialTable>, v: usize, c0: T) -> Self {
        let mut coeffs = vec![T::zero(); table.nvars()];
        coeffs[v] = T::one();
        let mut p = Poly::linear(table, &coeffs);
        if !c0.is_zero() {
            p.parts[0] = vec![c0];
        }
        p
    }
    /// The shared monomial table.
    pub fn table(&self) -> &Arc<MonomialTable> {
        &self.table
    }
    /// Number of variables.
    pub fn nvars(&self) -> usize {
        self.table.nvars()
    }
    /// Truncation degree N.
    pub fn max_degree(&self) -> usize {
        self.table.max_degree()
    }
    /// Homogeneous part of degree k, `None` when it is zero.
    pub fn part(&self, k: usize) -> Option<&[T]> {
        self.parts.get(k).filter(|p| !p.is_empty()).map(|p| &p[..])
    }
    /// Mutable homogeneous part of degree k (allocated as zeros if needed).
    pub fn part_mut(&mut self, k: usize) -> &mut Vec<T> {
        if self.parts[k].is_empty() {
            self.parts[k] = vec![T::zero(); self.table.count(k)];
        }
        &mut self.parts[k]
    }
    /// Replaces the part of degree k (an empty vector means zero).
    pub fn set_part(&mut self, k: usize, part: Vec<T>) {
        assert!(part.is_empty() || part.len() == self.table.count(k));
        self.parts[k] = part;
    }
    /// Takes the part of degree k out, leaving zero.
    pub fn take_part(&mut self, k: usize) -> Vec<T> {
        std::mem::take(&mut self.parts[k])
    }
    /// Drops parts that are identically zero (so that `part` returns `None` for them).
    pub fn prune(&mut self) {
        for p in &mut self.parts {
            if !p.is_empty() && is_zero_slice(p) {
                p.clear();
            }
        }
    }
    /// The coefficient of `x^e`.
    pub fn coeff(&self, e: &[u8]) -> T {
        match self.table.index(e) {
            Some((k, i)) => self.part(k).map_or(T::zero(), |p| p[i]),
            None => T::zero(),
        }
    }
    /// Sets the coefficient of `x^e` (must be within the truncation degree).
    pub fn set_coeff(&mut self, e: &[u8], c: T) {
        let (k, i) = self
            .table
            .index(e)
            .expect("monomial within the truncation degree");
        self.part_mut(k)[i] = c;
    }
    /// The constant term.
    pub fn constant_term(&self) -> T {
        self.part(0).map_or(T::zero(), |p| p[0])
    }
    /// Nonzero terms as (degree, index in degree, coefficient), by increasing degree.
    pub fn terms(&self) -> impl Iterator<Item = (usize, usize, T)> + '_ {
        self.parts.iter().enumerate().flat_map(|(k, p)| {
            p.iter()
                .enumerate()
                .filter(|(_, c)| !c.is_zero())
                .map(move |(i, &c)| (k, i, c))
        })
    }
    /// Exponents of monomial `i` of degree `k`.
    pub fn exponents(&self, k: usize, i: usize) -> &[u8] {
        self.table.exponents(k, i)
    }
    /// Lowest degree with a nonzero part, `None` for the zero polynomial.
    pub fn min_degree(&self) -> Option<usize> {
        (0..self.parts.len()).find(|&k| self.part(k).is_some_and(|p| !is_zero_slice(p)))
    }
    /// Are all coefficients finite?
    pub fn is_finite(&self) -> bool {
        self.parts.iter().all(|p| p.iter().all(|c| c.is_finite()))
    }
    /// Coefficient-wise map to another scalar.
    pub fn map<U: Coeff>(&self, f: impl Fn(T) -> U) -> Poly<U> {
        Poly {
            table: self.table.clone(),
            parts: self
                .parts
                .iter()
                .map(|p| p.iter().map(|&c| f(c)).collect())
                .collect(),
        }
    }
    /// Same polynomial over a table with another truncation degree (terms above it dropped).
    pub fn retabled(&self, table: Arc<MonomialTable>) -> Poly<T> {
        assert_eq!(table.nvars(), self.nvars());
        let mut out = Poly::zero(table);
        for k in 0..=out.max_degree().min(self.max_degree()) {
            if let Some(p) = self.part(k) {
                out.parts[k] = p.to_vec();
            }
        }
        out
    }
    /// Keeps degrees ≤ `deg` only.
    pub fn truncate(&mut self, deg: usize) {
        for p in self.parts.iter_mut().skip(deg + 1) {
            p.clear();
        }
    }
    /// Only the homogeneous part of degree k.
    pub fn homogeneous(&self, k: usize) -> Poly<T> {
        let mut out = Poly::zero(self.table.clone());
        if let Some(p) = self.part(k) {
            out.parts[k] = p.to_vec();
        }
        out
    }
    /// `self += c·o`
    pub fn add_scaled(&mut self, o: &Poly<T>, c: T) {
        debug_assert!(Arc::ptr_eq(&self.table, &o.table) || self.table.nvars() == o.table.nvars());
        for k in 0..self.parts.len().min(o.parts.len()) {
            if let Some(src) = o.part(k) {
                let dst = self.part_mut(k);
                for (d, &s) in dst.iter_mut().zip(src) {
                    d.mul_acc(c, s);
                }
            }
        }
    }
    /// `self + o`
    pub fn add(&self, o: &Poly<T>) -> Poly<T> {
        let mut r = self.clone();
        for k in 0..r.parts.len() {
            if let Some(src) = o.part(k) {
                let dst = r.part_mut(k);
                for (d, &s) in dst.iter_mut().zip(src) {
                    *d += s;
                }
            }
        }
        r
    }
    /// `self − o`
    pub fn sub(&self, o: &Poly<T>) -> Poly<T> {
        let mut r = self.clone();
        r.add_scaled(o, -T::one());
        r
    }
    /// `c·self`
    pub fn scaled(&self, c: T) -> Poly<T> {
        self.map(|x| x * c)
    }
    /// `self + c` (constant)
    pub fn add_constant(&self, c: T) -> Poly<T> {
        let mut r = self.clone();
        let p = r.part_mut(0);
        p[0] += c;
        r
    }
    /// Truncated product `self·o` (degrees above N dropped).
    pub fn mul(&self, o: &Poly<T>) -> Poly<T> {
        let n = self.max_degree();
        let mut r = Poly::zero(self.table.clone());
        let nz_a: Vec<usize> = (0..=n)
            .filter(|&k| self.part(k).is_some_and(|p| !is_zero_slice(p)))
            .collect();
        let nz_b: Vec<usize> = (0..=n)
            .filter(|&k| o.part(k).is_some_and(|p| !is_zero_slice(p)))
            .collect();
        for &i in &nz_a {
            for &j in &nz_b {
                if i + j > n {
                    break;
                }
                let (a, b) = (&self.parts[i], &o.parts[j]);
                if r.parts[i + j].is_empty() {
                    r.parts[i + j] = vec![T::zero(); self.table.count(i + j)];
                }
                mul_acc_hom(&self.table, &mut r.parts[i + j], a, i, b, j);
            }
        }
        r
    }
    /// ∂self/∂x_v (the degree-N part of the result is zero).
    pub fn derivative(&self, v: usize) -> Poly<T> {
        let mut r = Poly::zero(self.table.clone());
        for k in 1..self.parts.len() {
            if let Some(p) = self.part(k) {
                r.parts[k - 1] = deriv_hom(&self.table, p, k, v);
            }
        }
        r
    }
    /// Poisson bracket `{self, o} = Σ_k ∂self/∂q_k ∂o/∂p_k − ∂self/∂p_k ∂o/∂q_k` with the
    /// variables ordered (q₁…q_n, p₁…p_n); truncated at degree N.
    pub fn poisson(&self, o: &Poly<T>) -> Poly<T> {
        let d = self.nvars();
        assert!(
            d & 1 == 0,
            "Poisson bracket needs an even number of variables"
        );
        let n = d / 2;
        let mut r = Poly::zero(self.table.clone());
        for k in 0..n {
            let a = self.derivative(k).mul(&o.derivative(k + n));
            let b = self.derivative(k + n).mul(&o.derivative(k));
            r = r.add(&a).sub(&b);
        }
        r
    }
    /// The highest degree with a stored part (0 if none): the degree at most.
    pub fn stored_degree(&self) -> usize {
        (0..self.parts.len())
            .rev()
            .find(|&k| !self.parts[k].is_empty())
            .unwrap_or(0)
    }
    /// Value from the values of the monomials ([`MonomialTable::monomial_values`], up to at
    /// least [`stored_degree`](Self::stored_degree)).
    pub fn eval_monomials(&self, monomials: &[Vec<T>]) -> T {
        let mut sum = T::zero();
        for (part, m) in self.parts.iter().zip(monomials) {
            for (&c, &v) in part.iter().zip(m) {
                sum += c * v;
            }
        }
        sum
    }
    /// Value at a point.
    pub fn eval(&self, x: &[T]) -> T {
        let d = self.nvars();
        assert_eq!(x.len(), d);
        let n = self.max_degree();
        // powers x_v^e for e ≤ N
        let pw: Vec<Vec<T>> = x
            .iter()
            .map(|&xv| {
                let mut v = Vec::with_capacity(n + 1);
                let mut acc = T::one();
                for _ in 0..=n {
                    v.push(acc);
                    acc *= xv;
                }
                v
            })
            .collect();
        let mut sum = T::zero();
        for (k, part) in self.parts.iter().enumerate() {
            for (i, &c) in part.iter().enumerate() {
                if c.is_zero() {
                    continue;
                }
                let e = self.table.exponents(k, i);
                let mut m = c;
                for v in 0..d {
                    if e[v] > 0 {
                        m *= pw[v][e[v] as usize];
                    }
                }
                sum += m;
            }
        }
        sum
    }
    /// Substitution of a linear map that acts on the variable pairs `(x_k, x_{n+k})` only
    /// (nvars = 2n): `x_k = b₀₀ w_k + b₀₁ w_{n+k}`, `x_{n+k} = b₁₀ w_k + b₁₁ w_{n+k}` with
    /// `blocks[k] = [[b₀₀, b₀₁], [b₁₀, b₁₁]]`. One pass per pair; each monomial
    /// `x_k^a x_{n+k}^b` (m = a + b) expands through a precomputed (m+1)-term row, so the cost
    /// is O(N) products per monomial and pass (the complexification and its inverse are of
    /// this form).
    pub fn substitute_pairs(&self, blocks: &[[[T; 2]; 2]]) -> Poly<T> {
        let d = self.nvars();
        let n = d / 2;
        assert!(
            d == 2 * n && blocks.len() == n,
            "one 2×2 block per variable pair"
        );
        let nmax = self.max_degree();
        let table = self.table.clone();
        let base = table.base() as i64;
        // key weight of variable v (the last variable has none: it is implied by the degree)
        let weight = |v: usize| -> i64 {
            if v + 1 == d {
                0
            } else {
                base.pow(v as u32)
            }
        };
        let mut cur = self.clone();
        for (k, blk) in blocks.iter().enumerate() {
            let (p, q) = (k, n + k);
            let (wp, wq) = (weight(p), weight(q));
            // rows[m][a][j]: coefficient of w_p^{m−j} w_q^j in x_p^a x_q^{m−a}
            let pow = |c0: T, c1: T| -> Vec<Vec<T>> {
                let mut out: Vec<Vec<T>> = vec![vec![T::one()]];
                for a in 1..=nmax {
                    let prev = &out[a - 1];
                    let mut next = vec![T::zero(); a + 1];
                    for (j, &c) in prev.iter().enumerate() {
                        next[j] += c * c0;
                        next[j + 1] += c * c1;
                    }
                    out.push(next);
                }
                out
            };
            let pu = pow(blk[0][0], blk[0][1]);
            let pv = pow(blk[1][0], blk[1][1]);
            let rows: Vec<Vec<Vec<T>>> = (0..=nmax)
                .map(|m| {
                    (0..=m)
                        .map(|a| {
                            let mut r = vec![T::zero(); m + 1];
                            for (j1, &c1) in pu[a].iter().enumerate() {
                                for (j2, &c2) in pv[m - a].iter().enumerate() {
                                    r[j1 + j2] += c1 * c2;
                                }
                            }
                            r
                        })
                        .collect()
                })
                .collect();
            let mut next = Poly::zero(table.clone());
            for deg in 0..=nmax {
                let Some(part) = cur.part(deg) else { continue };
                let dt = table.degree(deg);
                let mut out = vec![T::zero(); part.len()];
                for (i, &c) in part.iter().enumerate() {
                    if c.is_zero() {
                        continue;
                    }
                    let e = table.exponents(deg, i);
                    let (a, b) = (e[p] as usize, e[q] as usize);
                    let m = a + b;
                    let key0 = dt.keys[i] as i64 - a as i64 * wp - b as i64 * wq;
                    for (j, &t) in rows[m][a].iter().enumerate() {
                        if t.is_zero() {
                            continue;
                        }
                        let key = key0 + (m - j) as i64 * wp + j as i64 * wq;
                        let idx = dt.lookup[key as usize] as usize;
                        out[idx].mul_acc(c, t);
                    }
                }
                next.parts[deg] = out;
            }
            cur = next;
        }
        cur
    }
    /// Substitution of a linear map: returns `P(M w)` as a polynomial in `w`, where
    /// `x_j = Σ_k m[j][k]·w_k`. Degrees are preserved. Evaluated by a nested Horner scheme
    /// over the variables, degree by degree, so the cost is a few products per monomial
    /// rather than one expansion per monomial.
    pub fn substitute_linear(&self, m: &[Vec<T>]) -> Poly<T> {
        let d = self.nvars();
        assert_eq!(m.len(), d);
        let table = self.table.clone();
        let forms: Vec<Poly<T>> = m
            .iter()
            .map(|row| Poly::linear(table.clone(), row))
            .collect();
        let mut out = Poly::zero(table.clone());
        if let Some(p) = self.part(0) {
            out.parts[0] = p.to_vec();
        }
        for k in 1..=self.max_degree() {
            let Some(part) = self.part(k) else { continue };
            let terms: Vec<(T, &[u8])> = part
                .iter()
                .enumerate()
                .filter(|(_, c)| !c.is_zero())
                .map(|(i, &c)| (c, table.exponents(k, i)))
                .collect();
            if terms.is_empty() {
                continue;
            }
            out.parts[k] = subst_rec(&table, &forms, &terms, 0, k);
        }
        out
    }
    /// Largest |coefficient| of the degree-k part (0 if zero).
    pub fn max_abs(&self, k: usize) -> f64 {
        self.part(k)
            .map_or(0.0, |p| p.iter().map(|c| c.magnitude()).fold(0.0, f64::max))
    }
    /// Number of nonzero coefficients.
    pub fn nnz(&self) -> usize {
        self.parts
            .iter()
            .map(|p| p.iter().filter(|c| !c.is_zero()).count())
            .sum()
    }
}

/// Homogeneous `Σ_terms c·Π_{v≥var} ℓ_v^{e_v}` of degree `degree` by Horner in ℓ_var.
#[allow(clippy::explicit_counter_loop)]
fn subst_rec<T: Coeff>(
    table: &MonomialTable,
    forms: &[Poly<T>],
    terms: &[(T, &[u8])],
    var: usize,
    degree: usize,
) -> Vec<T> {
    let d = table.nvars();
    let lin = forms[var].part(1).expect("linear form");
    if var + 1 == d {
        // one term c·ℓ^degree
        let mut acc = vec![T::zero(); 1];
        acc[0] = terms.iter().fold(T::zero(), |s, t| s + t.0);
        for deg in 0..degree {
            let mut next = vec![T::zero(); table.count(deg + 1)];
            mul_acc_hom(table, &mut next, &acc, deg, lin, 1);
            acc = next;
        }
        return acc;
    }
    // group by the exponent of x_var
    let mut groups: Vec<Vec<(T, &[u8])>> = vec![Vec::new(); degree + 1];
    for &(c, e) in terms {
        groups[e[var] as usize].push((c, e));
    }
    let top = (0..=degree)
        .rev()
        .find(|&e| !groups[e].is_empty())
        .expect("nonempty");
    let mut acc = subst_rec(table, forms, &groups[top], var + 1, degree - top);
    let mut acc_deg = degree - top;
    for e in (0..top).rev() {
        let mut next = vec![T::zero(); table.count(acc_deg + 1)];
        mul_acc_hom(table, &mut next, &acc, acc_deg, lin, 1);
        acc = next;
        acc_deg += 1;
        if !groups[e].is_empty() {
            let r = subst_rec(table, forms, &groups[e], var + 1, degree - e);
            for (a, b) in acc.iter_mut().zip(r) {
                *a += b;
            }
        }
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(n: usize, deg: usize) -> Arc<MonomialTable> {
        Arc::new(MonomialTable::new(n, deg))
    }

    #[test]
    fn product_matches_evaluation() {
        let tab = t(3, 6);
        let x = Poly::variable(tab.clone(), 0, 1.0);
        let y = Poly::variable(tab.clone(), 1, -0.5);
        let z = Poly::variable(tab.clone(), 2, 0.0);
        let p = x.mul(&y).add(&z.mul(&z).mul(&x));
        let q = p.mul(&p);
        let pt = [0.3, -0.2, 0.7];
        let pv = p.eval(&pt);
        assert!((q.eval(&pt) - pv * pv).abs() < 1e-14);
    }

    #[test]
    fn poisson_bracket_of_canonical_pair() {
        // {q, p} = 1, {q², p²} = 4qp, {H, q} = −∂H/∂p
        let tab = t(2, 6);
        let q = Poly::variable(tab.clone(), 0, 0.0);
        let p = Poly::variable(tab.clone(), 1, 0.0);
        assert_eq!(q.poisson(&p).constant_term(), 1.0);
        let b = q.mul(&q).poisson(&p.mul(&p));
        assert_eq!(b.coeff(&[1, 1]), 4.0);
        let h = p.mul(&p).mul(&q);
        assert_eq!(h.poisson(&q).coeff(&[1, 1]), -2.0);
    }

    #[test]
    fn pair_substitution_is_the_linear_substitution() {
        let tab = t(4, 7);
        let mut rng = lasalle_testkit::Rng::new(3);
        let mut rnd = || rng.uniform(-0.5, 0.5);
        let mut p: Poly<f64> = Poly::zero(tab.clone());
        for k in 0..=7 {
            let part = (0..tab.count(k)).map(|_| rnd()).collect();
            p.set_part(k, part);
        }
        let blocks = [[[0.3, -1.1], [0.7, 0.2]], [[1.3, 0.4], [-0.6, 0.9]]];
        let mut m = vec![vec![0.0; 4]; 4];
        for (k, b) in blocks.iter().enumerate() {
            m[k][k] = b[0][0];
            m[k][2 + k] = b[0][1];
            m[2 + k][k] = b[1][0];
            m[2 + k][2 + k] = b[1][1];
        }
        let a = p.substitute_pairs(&blocks);
        let b = p.substitute_linear(&m);
        for k in 0..=7 {
            for (x, y) in a.part(k).unwrap().iter().zip(b.part(k).unwrap()) {
                assert!((x - y).abs() < 1e-12 * (1.0 + y.abs()), "{x} vs {y}");
            }
        }
    }

    #[test]
    fn linear_substitution_matches_evaluation() {
        let tab = t(3, 7);
        let vars: Vec<Poly<f64>> = (0..3)
            .map(|v| Poly::variable(tab.clone(), v, 0.0))
            .collect();
        let mut p = vars[0].mul(&vars[1]).mul(&vars[2]).add_constant(0.5);
        p = p
            .add(&p.mul(&p))
            .add(&vars[2].mul(&vars[2]).mul(&vars[2]).mul(&vars[0]));
        let m = vec![
            vec![0.3, -1.0, 2.0],
            vec![0.1, 0.2, -0.7],
            vec![1.1, 0.0, 0.4],
        ];
        let s = p.substitute_linear(&m);
        let w = [0.21, -0.33, 0.17];
        let x: Vec<f64> = m
            .iter()
            .map(|r| r.iter().zip(&w).map(|(a, b)| a * b).sum())
            .collect();
        assert!((s.eval(&w) - p.eval(&x)).abs() < 1e-13);
    }
}
