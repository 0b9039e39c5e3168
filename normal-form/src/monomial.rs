//! Dense monomial indexing per total degree.
//!
//! A homogeneous polynomial of degree k in d variables is a dense array over the
//! C(k+d−1, d−1) exponent vectors of degree k, in a fixed order (descending lexicographic:
//! `x₁ᵏ` first, `x_dᵏ` last). Every exponent vector also has an additive **key**
//! `Σ_{i<d−1} eᵢ·Bⁱ` with base B = N+1 (the last exponent is implied by the degree), so the
//! key of a product monomial is the sum of the keys and one table lookup per degree turns it
//! back into a dense index: products and Poisson brackets need no hashing.

/// Tables for one total degree.
#[derive(Debug, Clone)]
pub struct DegreeTable {
    /// Exponent vectors, `nvars` bytes per monomial.
    pub exps: Vec<u8>,
    /// Additive keys.
    pub keys: Vec<u32>,
    /// key → dense index (`u32::MAX` for keys of other degrees).
    pub lookup: Vec<u32>,
    /// For each variable v: for each monomial, (index of ∂/∂x_v in degree k−1, exponent of v).
    pub deriv: Vec<Vec<(u32, u32)>>,
    /// For an even number of variables 2n: for each monomial `x^a y^b` (x the first n
    /// variables, y the last n) the index of `x^b y^a`; empty for an odd number.
    pub mirror: Vec<u32>,
    /// For each monomial: (index in degree k−1 of it divided by its first variable, that
    /// variable); `(u32::MAX, 0)` at degree 0. Evaluating all monomials at a point is then
    /// one product each ([`MonomialTable::monomial_values`]).
    pub parent: Vec<(u32, u8)>,
}

/// Monomial tables for `nvars` variables up to total degree `max_degree`.
#[derive(Debug, Clone)]
pub struct MonomialTable {
    nvars: usize,
    max_degree: usize,
    base: u32,
    degrees: Vec<DegreeTable>,
}

fn for_each_exponent(nvars: usize, degree: usize, f: &mut dyn FnMut(&[u8])) {
    fn rec(e: &mut Vec<u8>, var: usize, left: usize, nvars: usize, f: &mut dyn FnMut(&[u8])) {
        if var + 1 == nvars {
            e[var] = left as u8;
            f(e);
            return;
        }
        for k in (0..=left).rev() {
            e[var] = k as u8;
            rec(e, var + 1, left - k, nvars, f);
        }
    }
    if nvars == 0 {
        if degree == 0 {
            f(&[]);
        }
        return;
    }
    let mut e = vec![0u8; nvars];
    rec(&mut e, 0, degree, nvars, f);
}

/// Binomial coefficient C(n, k) as usize.
pub fn binomial(n: usize, k: usize) -> usize {
    if k > n {
        return 0;
    }
    let k = k.min(n - k);
    let mut r: u128 = 1;
    for i in 0..k {
        r = r * (n - i) as u128 / (i + 1) as u128;
    }
    r as usize
}

impl MonomialTable {
    /// Builds the tables. Exponents are stored as bytes, so `max_degree ≤ 255`.
    ///
    /// # Panics
    /// If `nvars == 0`, `max_degree > 255` or the key space exceeds 2³² entries.
    pub fn new(nvars: usize, max_degree: usize) -> MonomialTable {
        assert!(nvars > 0, "at least one variable");
        assert!(max_degree <= 255, "degree above 255");
        let base = (max_degree + 1) as u32;
        let key_of = |e: &[u8]| -> u32 {
            let mut k: u64 = 0;
            let mut b: u64 = 1;
            for &x in &e[..nvars - 1] {
                k += x as u64 * b;
                b *= base as u64;
            }
            u32::try_from(k).expect("monomial key space too large")
        };
        let mut degrees: Vec<DegreeTable> = Vec::with_capacity(max_degree + 1);
        for k in 0..=max_degree {
            let mut exps = Vec::new();
            let mut keys = Vec::new();
            for_each_exponent(nvars, k, &mut |e| {
                exps.extend_from_slice(e);
                keys.push(key_of(e));
            });
            let max_key = keys.iter().copied().max().unwrap_or(0) as usize;
            let mut lookup = vec![u32::MAX; max_key + 1];
            for (i, &key) in keys.iter().enumerate() {
                lookup[key as usize] = i as u32;
            }
            let count = keys.len();
            let mut deriv = vec![Vec::with_capacity(count); nvars];
            for i in 0..count {
                let e = &exps[i * nvars..(i + 1) * nvars];
                for (v, dv) in deriv.iter_mut().enumerate() {
                    if e[v] == 0 {
                        dv.push((u32::MAX, 0));
                    } else {
                        let mut f = e.to_vec();
                        f[v] -= 1;
                        let prev: &DegreeTable = &degrees[k - 1];
                        let j = prev.lookup[key_of(&f) as usize];
                        dv.push((j, e[v] as u32));
                    }
                }
            }
            let mirror = if nvars.is_multiple_of(2) {
                let h = nvars / 2;
                (0..count)
                    .map(|i| {
                        let e = &exps[i * nvars..(i + 1) * nvars];
                        let f: Vec<u8> = e[h..].iter().chain(&e[..h]).copied().collect();
                        lookup[key_of(&f) as usize]
                    })
                    .collect()
            } else {
                Vec::new()
            };
            let parent = (0..count)
                .map(|i| {
                    let e = &exps[i * nvars..(i + 1) * nvars];
                    match e.iter().position(|&x| x > 0) {
                        Some(v) => (deriv[v][i].0, v as u8),
                        None => (u32::MAX, 0),
                    }
                })
                .collect();
            degrees.push(DegreeTable {
                exps,
                keys,
                lookup,
                deriv,
                mirror,
                parent,
            });
        }
        MonomialTable {
            nvars,
            max_degree,
            base,
            degrees,
        }
    }
    /// Number of variables.
    pub fn nvars(&self) -> usize {
        self.nvars
    }
    /// Truncation degree N.
    pub fn max_degree(&self) -> usize {
        self.max_degree
    }
    /// Key base B = N+1.
    pub fn base(&self) -> u32 {
        self.base
    }
    /// Number of monomials of degree k.
    pub fn count(&self, k: usize) -> usize {
        self.degrees[k].keys.len()
    }
    /// Tables of degree k.
    pub fn degree(&self, k: usize) -> &DegreeTable {
        &self.degrees[k]
    }
    /// Exponent vector of monomial `i` of degree `k`.
    pub fn exponents(&self, k: usize, i: usize) -> &[u8] {
        &self.degrees[k].exps[i * self.nvars..(i + 1) * self.nvars]
    }
    /// Dense index of an exponent vector (its degree is the sum).
    pub fn index(&self, e: &[u8]) -> Option<(usize, usize)> {
        let k: usize = e.iter().map(|&x| x as usize).sum();
        if k > self.max_degree || e.len() != self.nvars {
            return None;
        }
        let mut key: usize = 0;
        let mut b: usize = 1;
        for &x in &e[..self.nvars - 1] {
            key += x as usize * b;
            b *= self.base as usize;
        }
        let t = &self.degrees[k];
        t.lookup
            .get(key)
            .copied()
            .filter(|&i| i != u32::MAX)
            .map(|i| (k, i as usize))
    }
    /// The values at `x` of every monomial of degree ≤ `degree` (≤ the table's), by degree:
    /// one product per monomial.
    pub fn monomial_values<T: Copy + std::ops::Mul<Output = T>>(
        &self,
        x: &[T],
        one: T,
        degree: usize,
    ) -> Vec<Vec<T>> {
        assert_eq!(x.len(), self.nvars);
        let top = degree.min(self.max_degree);
        let mut out: Vec<Vec<T>> = Vec::with_capacity(top + 1);
        out.push(vec![one]);
        for k in 1..=top {
            let prev = &out[k - 1];
            let vals = self.degrees[k]
                .parent
                .iter()
                .map(|&(j, v)| prev[j as usize] * x[v as usize])
                .collect();
            out.push(vals);
        }
        out
    }
    /// Approximate memory used by the tables, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.degrees
            .iter()
            .map(|t| {
                t.exps.len()
                    + 4 * t.keys.len()
                    + 4 * t.lookup.len()
                    + t.deriv.iter().map(|d| 8 * d.len()).sum::<usize>()
                    + 4 * t.mirror.len()
                    + 8 * t.parent.len()
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_keys() {
        let t = MonomialTable::new(4, 10);
        for k in 0..=10 {
            assert_eq!(t.count(k), binomial(k + 3, 3));
        }
        // x1^2 x3 is found again by its exponents
        let (k, i) = t.index(&[2, 0, 1, 0]).unwrap();
        assert_eq!(k, 3);
        assert_eq!(t.exponents(3, i), &[2, 0, 1, 0]);
        // keys add under multiplication
        let (_, a) = t.index(&[1, 2, 0, 1]).unwrap();
        let (_, b) = t.index(&[0, 1, 3, 0]).unwrap();
        let key = t.degree(4).keys[a] + t.degree(4).keys[b];
        let (_, c) = t.index(&[1, 3, 3, 1]).unwrap();
        assert_eq!(t.degree(8).lookup[key as usize] as usize, c);
        // x₁x₂³ y₁³y₂ ↔ x₁³x₂ y₁y₂³
        let (_, m) = t.index(&[3, 1, 1, 3]).unwrap();
        assert_eq!(t.degree(8).mirror[c] as usize, m);
        assert_eq!(t.degree(8).mirror[m] as usize, c);
    }

    #[test]
    fn one_variable() {
        let t = MonomialTable::new(1, 5);
        assert_eq!(t.count(5), 1);
        assert_eq!(t.index(&[3]), Some((3, 0)));
    }
}
