//! Infante's quadratic Liapunov functions for the n-th order linear equation
//! x⁽ⁿ⁾ + a₁x⁽ⁿ⁻¹⁾ + … + aₙx = 0 ("Stability criteria for n-th order, homogeneous linear
//! differential equations", the fifth paper of NASA TM X-53478): with A the companion matrix
//! (2.4) (ones on the superdiagonal, last row −aₙ … −a₁), the Liapunov equation
//!
//! ```text
//! AᵀB + BA = −C
//! ```
//!
//! solved for B **symbolically in the aᵢ**, for the paper's diagonal right-hand sides (3.1),
//! (3.2): C₁ = 2 diag(Δₙ, 0, …, 0) and, for k ≥ 2, C_k = 2Δₙ₋₁ e_k e_kᵀ, Δⱼ the Hurwitz
//! determinants (3.3) of the aᵢ — the choices that make every B_k a polynomial (Table I).
//!
//! The work is done in the generator's expression IR ([`lasalle_model::ir`]): A, the symmetric
//! unknown B and AᵀB + BA are IR expressions (B's entries are symbols, the aᵢ parameters);
//! the linear system's coefficients are their derivatives ∂(AᵀB + BA)ᵢⱼ/∂b_kl
//! ([`ir::diff`](lasalle_model::ir::diff)); the system (n(n+1)/2 unknowns, coefficients
//! polynomial in the aᵢ) is solved by Cramer's rule with fraction-free (Bareiss) determinants
//! over ℤ[a₁ … aₙ] and one exact polynomial division per unknown; the solution is put back
//! into the IR and AᵀB + BA + C is [expanded](lasalle_model::ir::Graph::expand) to 0 — the
//! proof the generator uses for conservation laws — and checked numerically at a Hurwitz
//! point. [`companion_coefficients`] reads a₁ … aₙ off a matrix of IR expressions and says
//! where a matrix is not a companion matrix.

pub mod criterion;
pub mod equation;
pub mod examples;

use std::collections::BTreeMap;
use std::fmt;

use lasalle_model::ir::{diff, Graph, Id, Input, Node};

/// Why a Table I entry cannot be computed.
#[derive(Clone, Debug, PartialEq)]
pub enum InfanteError {
    /// The matrix is not a companion matrix: the entry at (row, column) (1-based) is not what
    /// the form (2.4) requires.
    NotCompanion {
        /// 1-based row.
        row: usize,
        /// 1-based column.
        column: usize,
        /// What (2.4) has there.
        expected: String,
        /// What the matrix has.
        found: String,
    },
    /// The matrix is not square, or its order is outside 1 ≤ n ≤ [`MAX_ORDER`].
    Shape(String),
    /// An expression is not a polynomial with integer coefficients in the aᵢ.
    NotPolynomial(String),
    /// The Liapunov operator is singular for every aᵢ (never for a companion matrix).
    Singular,
}

impl fmt::Display for InfanteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InfanteError::NotCompanion {
                row,
                column,
                expected,
                found,
            } => write!(
                f,
                "not a companion matrix: entry ({row}, {column}) is {found}, the form \
                 (ones above the diagonal, −aₙ … −a₁ in the last row, zeros elsewhere) has {expected} there"
            ),
            InfanteError::Shape(m) | InfanteError::NotPolynomial(m) => f.write_str(m),
            InfanteError::Singular => f.write_str("the Liapunov operator AᵀB + BA is singular"),
        }
    }
}

impl std::error::Error for InfanteError {}

/// The largest order solved (the system has n(n+1)/2 unknowns and Bareiss' determinants grow
/// fast in the number of symbols).
pub const MAX_ORDER: usize = 4;

/// A polynomial in a₁ … aₙ with integer coefficients: exponent vectors → coefficients, with
/// no zero coefficients; lexicographic order (a₁ > a₂ > …), the leading term last.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Poly {
    terms: BTreeMap<Vec<u16>, i128>,
    vars: usize,
}

impl Poly {
    /// The constant `c`.
    pub fn constant(vars: usize, c: i128) -> Poly {
        let mut p = Poly {
            terms: BTreeMap::new(),
            vars,
        };
        if c != 0 {
            p.terms.insert(vec![0; vars], c);
        }
        p
    }

    /// The variable a_{k+1}.
    pub fn var(vars: usize, k: usize) -> Poly {
        let mut e = vec![0; vars];
        e[k] = 1;
        Poly {
            terms: BTreeMap::from([(e, 1)]),
            vars,
        }
    }

    /// Is this 0?
    pub fn is_zero(&self) -> bool {
        self.terms.is_empty()
    }

    fn insert(&mut self, e: Vec<u16>, c: i128) {
        let v = self.terms.entry(e.clone()).or_insert(0);
        *v += c;
        if *v == 0 {
            self.terms.remove(&e);
        }
    }

    /// self + k·o.
    fn axpy(&self, k: i128, o: &Poly) -> Poly {
        let mut out = self.clone();
        for (e, c) in &o.terms {
            out.insert(e.clone(), k * c);
        }
        out
    }

    /// The sum.
    pub fn add(&self, o: &Poly) -> Poly {
        self.axpy(1, o)
    }

    /// The difference.
    pub fn sub(&self, o: &Poly) -> Poly {
        self.axpy(-1, o)
    }

    /// The product.
    pub fn mul(&self, o: &Poly) -> Poly {
        let mut out = Poly::constant(self.vars, 0);
        for (ea, ca) in &self.terms {
            for (eb, cb) in &o.terms {
                let e = ea.iter().zip(eb).map(|(x, y)| x + y).collect();
                out.insert(e, ca * cb);
            }
        }
        out
    }

    /// The exact quotient self / d, or `None` if d does not divide self (multivariate
    /// division by leading terms: when an exact quotient exists it is found).
    pub fn div_exact(&self, d: &Poly) -> Option<Poly> {
        let (de, dc) = d.terms.iter().next_back()?;
        let mut rem = self.clone();
        let mut q = Poly::constant(self.vars, 0);
        while let Some((re, rc)) = rem.terms.iter().next_back() {
            if rc % dc != 0 || re.iter().zip(de).any(|(r, s)| r < s) {
                return None;
            }
            let e: Vec<u16> = re.iter().zip(de).map(|(r, s)| r - s).collect();
            let mono = Poly {
                terms: BTreeMap::from([(e, rc / dc)]),
                vars: self.vars,
            };
            rem = rem.sub(&mono.mul(d));
            q = q.add(&mono);
        }
        Some(q)
    }

    /// The value at `a`.
    pub fn eval(&self, a: &[f64]) -> f64 {
        self.terms
            .iter()
            .map(|(e, &c)| {
                e.iter()
                    .zip(a)
                    .fold(c as f64, |acc, (&k, &x)| acc * x.powi(k as i32))
            })
            .sum()
    }

    /// The polynomial as an IR expression in the parameters a₁ … aₙ (slots 0 … n−1).
    pub fn to_ir(&self, g: &mut Graph) -> Id {
        let mut terms = Vec::new();
        for (e, &c) in &self.terms {
            let mut factors = vec![g.num(c as f64)];
            for (k, &p) in e.iter().enumerate() {
                if p > 0 {
                    let a = g.input(Input::Param(k as u32));
                    factors.push(g.pow(a, lasalle_model::ir::Rational::int(p as i32)));
                }
            }
            terms.push(g.mul(&factors));
        }
        if terms.is_empty() {
            g.num(0.0)
        } else {
            g.add(&terms)
        }
    }

    /// The polynomial of an IR expression built from integers, the parameters a₁ … aₙ
    /// (slots 0 … n−1), sums, products and non-negative integer powers.
    pub fn from_ir(g: &Graph, id: Id, vars: usize) -> Result<Poly, InfanteError> {
        let bad = || {
            InfanteError::NotPolynomial(format!(
                "{} is not a polynomial with integer coefficients in a₁ … a{vars}",
                g.display(id)
            ))
        };
        Ok(match g.node(id) {
            Node::Num(b) => {
                let x = f64::from_bits(*b);
                if x.fract() != 0.0 || x.abs() > 2f64.powi(53) {
                    return Err(bad());
                }
                Poly::constant(vars, x as i128)
            }
            Node::Input(Input::Param(k)) if (*k as usize) < vars => Poly::var(vars, *k as usize),
            Node::Add(c) => c.iter().try_fold(Poly::constant(vars, 0), |acc, &k| {
                Ok::<_, InfanteError>(acc.add(&Poly::from_ir(g, k, vars)?))
            })?,
            Node::Mul(c) => c.iter().try_fold(Poly::constant(vars, 1), |acc, &k| {
                Ok::<_, InfanteError>(acc.mul(&Poly::from_ir(g, k, vars)?))
            })?,
            Node::Pow(b, e) if e.is_int() && e.num >= 0 => {
                let base = Poly::from_ir(g, *b, vars)?;
                (0..e.num).fold(Poly::constant(vars, 1), |acc, _| acc.mul(&base))
            }
            _ => return Err(bad()),
        })
    }
}

impl fmt::Display for Poly {
    /// Terms by descending degree, a₁ before a₂: `a₁² + a₂`, `2a₁a₂ − a₃`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_zero() {
            return f.write_str("0");
        }
        const SUB: [&str; 10] = ["₀", "₁", "₂", "₃", "₄", "₅", "₆", "₇", "₈", "₉"];
        const SUP: [&str; 10] = ["⁰", "¹", "²", "³", "⁴", "⁵", "⁶", "⁷", "⁸", "⁹"];
        let mut terms: Vec<(&Vec<u16>, &i128)> = self.terms.iter().collect();
        let degree = |e: &Vec<u16>| e.iter().map(|&k| k as u32).sum::<u32>();
        terms.sort_by(|a, b| degree(b.0).cmp(&degree(a.0)).then(b.0.cmp(a.0)));
        for (i, (e, &c)) in terms.iter().enumerate() {
            let sign = if c < 0 { "−" } else { "+" };
            match (i, c < 0) {
                (0, true) => f.write_str("−")?,
                (0, false) => {}
                _ => write!(f, " {sign} ")?,
            }
            let mono: String = e
                .iter()
                .enumerate()
                .filter(|(_, &k)| k > 0)
                .map(|(v, &k)| {
                    let sub: String = (v + 1)
                        .to_string()
                        .chars()
                        .map(|d| SUB[d as usize - 48])
                        .collect();
                    let sup: String = if k == 1 {
                        String::new()
                    } else {
                        k.to_string()
                            .chars()
                            .map(|d| SUP[d as usize - 48])
                            .collect()
                    };
                    format!("a{sub}{sup}")
                })
                .collect();
            if c.abs() != 1 || mono.is_empty() {
                write!(f, "{}", c.abs())?;
            }
            f.write_str(&mono)?;
        }
        Ok(())
    }
}

/// The determinant of a square matrix of polynomials by Bareiss' fraction-free elimination
/// (every division exact).
pub fn determinant(m: &[Vec<Poly>], vars: usize) -> Poly {
    let n = m.len();
    let mut a = m.to_vec();
    let mut sign = 1;
    let mut prev = Poly::constant(vars, 1);
    for k in 0..n {
        let Some(p) = (k..n).find(|&i| !a[i][k].is_zero()) else {
            return Poly::constant(vars, 0);
        };
        if p != k {
            a.swap(p, k);
            sign = -sign;
        }
        for i in k + 1..n {
            for j in k + 1..n {
                let num = a[k][k].mul(&a[i][j]).sub(&a[i][k].mul(&a[k][j]));
                a[i][j] = num.div_exact(&prev).expect("Bareiss' divisions are exact");
            }
        }
        prev = a[k][k].clone();
    }
    prev.mul(&Poly::constant(vars, sign))
}

/// The companion matrix (2.4) of order n in the IR: ones above the diagonal, the last row
/// −aₙ … −a₁ (aᵢ the parameter slot i − 1).
pub fn companion(g: &mut Graph, n: usize) -> Vec<Vec<Id>> {
    let (zero, one) = (g.num(0.0), g.num(1.0));
    (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    if i == n - 1 {
                        let a = g.input(Input::Param((n - 1 - j) as u32));
                        g.neg(a)
                    } else if j == i + 1 {
                        one
                    } else {
                        zero
                    }
                })
                .collect()
        })
        .collect()
}

/// a₁ … aₙ of a companion matrix given as IR expressions (as IR expressions), or where it
/// departs from the form (2.4).
pub fn companion_coefficients(g: &mut Graph, m: &[Vec<Id>]) -> Result<Vec<Id>, InfanteError> {
    let n = m.len();
    if n == 0 || n > MAX_ORDER || m.iter().any(|r| r.len() != n) {
        return Err(InfanteError::Shape(format!(
            "a companion matrix is square of order 1 to {MAX_ORDER}; this one has {n} rows of lengths {:?}",
            m.iter().map(Vec::len).collect::<Vec<_>>()
        )));
    }
    let mut a = vec![g.num(0.0); n];
    for (i, row) in m.iter().enumerate() {
        for (j, &x) in row.iter().enumerate() {
            if i == n - 1 {
                a[n - 1 - j] = g.neg(x);
                continue;
            }
            let expected = if j == i + 1 { 1.0 } else { 0.0 };
            if g.as_num(x) != Some(expected) {
                return Err(InfanteError::NotCompanion {
                    row: i + 1,
                    column: j + 1,
                    expected: format!("{expected}"),
                    found: g.display(x),
                });
            }
        }
    }
    Ok(a)
}

/// The Hurwitz determinants Δ₁ … Δₙ (3.3) of a₁ … aₙ: the leading minors of the matrix with
/// entries a_{2j−i} (a₀ = 1, aₖ = 0 outside 0 … n).
pub fn hurwitz(n: usize) -> Vec<Poly> {
    let a = |k: isize| match k {
        0 => Poly::constant(n, 1),
        k if k >= 1 && k as usize <= n => Poly::var(n, k as usize - 1),
        _ => Poly::constant(n, 0),
    };
    let h: Vec<Vec<Poly>> = (1..=n as isize)
        .map(|i| (1..=n as isize).map(|j| a(2 * j - i)).collect())
        .collect();
    (1..=n)
        .map(|k| {
            let minor: Vec<Vec<Poly>> = h[..k].iter().map(|r| r[..k].to_vec()).collect();
            determinant(&minor, n)
        })
        .collect()
}

/// The paper's C_k (3.1), (3.2) for k = 1 … n, as its diagonal.
pub fn c_diagonal(n: usize, k: usize) -> Vec<Poly> {
    let d = hurwitz(n);
    let two = Poly::constant(n, 2);
    (1..=n)
        .map(|i| match (k, i) {
            (1, 1) => two.mul(&d[n - 1]),
            (k, i) if k > 1 && i == k => two.mul(&d[n - 2]),
            _ => Poly::constant(n, 0),
        })
        .collect()
}

/// The symmetric B solving AᵀB + BA = −C for a diagonal C, by rows (polynomials in the aᵢ).
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// The order n.
    pub n: usize,
    /// C's diagonal.
    pub c: Vec<Poly>,
    /// B, n×n, symmetric.
    pub b: Vec<Vec<Poly>>,
}

/// The index of b_ij (i ≤ j) among the n(n+1)/2 unknowns.
fn unknown(n: usize, i: usize, j: usize) -> usize {
    let (i, j) = (i.min(j), i.max(j));
    i * n - i * (i + 1) / 2 + j
}

/// AᵀB + BA for the companion matrix of order n and the symmetric matrix of unknowns
/// (b_ij the state slot [`unknown`]`(n, i, j)`), as IR expressions by rows.
fn lyapunov_operator(g: &mut Graph, n: usize, b: &[Vec<Id>]) -> Vec<Vec<Id>> {
    let a = companion(g, n);
    let mut out = vec![vec![g.num(0.0); n]; n];
    for i in 0..n {
        for j in 0..n {
            let mut terms = Vec::new();
            for k in 0..n {
                // (AᵀB)ᵢⱼ = Σ A_ki B_kj, (BA)ᵢⱼ = Σ B_ik A_kj
                terms.push(g.mul(&[a[k][i], b[k][j]]));
                terms.push(g.mul(&[b[i][k], a[k][j]]));
            }
            out[i][j] = g.add(&terms);
        }
    }
    out
}

/// Solves AᵀB + BA = −diag(`c`) for the companion matrix of order n = `c.len()`, symbolically
/// in a₁ … aₙ (see the [module docs](self)); B's entries are polynomials when `c` is one of
/// the paper's C_k, otherwise an entry that is not is reported.
pub fn solve(c: &[Poly]) -> Result<Solution, InfanteError> {
    let n = c.len();
    if n == 0 || n > MAX_ORDER {
        return Err(InfanteError::Shape(format!(
            "the order n = {n} must be 1 to {MAX_ORDER}"
        )));
    }
    let m = n * (n + 1) / 2;
    let mut g = Graph::new();
    let b: Vec<Vec<Id>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| g.input(Input::State(unknown(n, i, j) as u32)))
                .collect()
        })
        .collect();
    let op = lyapunov_operator(&mut g, n, &b);
    // one equation per i ≤ j: Σ_u ∂op_ij/∂b_u · b_u = −C_ij
    let mut rows = Vec::with_capacity(m);
    let mut rhs = Vec::with_capacity(m);
    for i in 0..n {
        for (j, &op_ij) in op[i].iter().enumerate().skip(i) {
            let mut row = Vec::with_capacity(m);
            for u in 0..m {
                let d = diff(
                    &mut g,
                    op_ij,
                    Input::State(u as u32),
                    &mut Default::default(),
                );
                row.push(Poly::from_ir(&g, d, n)?);
            }
            rows.push(row);
            rhs.push(if i == j {
                Poly::constant(n, 0).sub(&c[i])
            } else {
                Poly::constant(n, 0)
            });
        }
    }
    let det = determinant(&rows, n);
    if det.is_zero() {
        return Err(InfanteError::Singular);
    }
    let mut x = Vec::with_capacity(m);
    for u in 0..m {
        let mut cramer = rows.clone();
        for (r, v) in cramer.iter_mut().zip(&rhs) {
            r[u] = v.clone();
        }
        let num = determinant(&cramer, n);
        x.push(num.div_exact(&det).ok_or_else(|| {
            InfanteError::NotPolynomial(format!(
                "b{} is ({num}) / ({det}), not a polynomial: C must be one of the paper's C_k (3.1), (3.2) or a combination of them",
                u + 1
            ))
        })?);
    }
    let b = (0..n)
        .map(|i| (0..n).map(|j| x[unknown(n, i, j)].clone()).collect())
        .collect();
    Ok(Solution {
        n,
        c: c.to_vec(),
        b,
    })
}

impl Solution {
    /// AᵀB + BA + C with B put back into the IR, expanded: true when it is identically 0 (the
    /// symbolic proof that B solves the equation).
    pub fn proves(&self) -> bool {
        let n = self.n;
        let mut g = Graph::new();
        let b: Vec<Vec<Id>> = self
            .b
            .iter()
            .map(|r| r.iter().map(|p| p.to_ir(&mut g)).collect())
            .collect();
        let op = lyapunov_operator(&mut g, n, &b);
        let zero = g.num(0.0);
        (0..n).all(|i| {
            (0..n).all(|j| {
                let c = if i == j {
                    self.c[i].to_ir(&mut g)
                } else {
                    zero
                };
                let e = g.add(&[op[i][j], c]);
                g.expand(e, 1 << 16) == Some(zero)
            })
        })
    }

    /// max |AᵀB + BA + C| and the smallest pivot of B's Cholesky factorisation (> 0: B is
    /// positive definite, Lemma 2.1) at the numbers `a`.
    pub fn check_at(&self, a: &[f64]) -> (f64, f64) {
        let n = self.n;
        let bm: Vec<Vec<f64>> = self
            .b
            .iter()
            .map(|r| r.iter().map(|p| p.eval(a)).collect())
            .collect();
        let am = |i: usize, j: usize| {
            if i == n - 1 {
                -a[n - 1 - j]
            } else if j == i + 1 {
                1.0
            } else {
                0.0
            }
        };
        let mut residual: f64 = 0.0;
        for i in 0..n {
            for j in 0..n {
                let c = if i == j { self.c[i].eval(a) } else { 0.0 };
                let s = c
                    + (0..n)
                        .map(|k| am(k, i) * bm[k][j] + bm[i][k] * am(k, j))
                        .sum::<f64>();
                residual = residual.max(s.abs());
            }
        }
        // Cholesky pivots
        let mut l = bm.clone();
        let mut min_pivot = f64::INFINITY;
        for k in 0..n {
            let pivot = l[k][k];
            min_pivot = min_pivot.min(pivot);
            if pivot <= 0.0 {
                break;
            }
            let (upper, lower) = l.split_at_mut(k + 1);
            let row_k = &upper[k];
            for row_i in lower.iter_mut() {
                let f = row_i[k] / pivot;
                for (x, y) in row_i[k + 1..].iter_mut().zip(&row_k[k + 1..]) {
                    *x -= f * y;
                }
            }
        }
        (residual, min_pivot)
    }
}

/// Table I for order n: (B_k, C_k) for k = 1 … n.
pub fn table(n: usize) -> Result<Vec<Solution>, InfanteError> {
    (1..=n).map(|k| solve(&c_diagonal(n, k))).collect()
}
