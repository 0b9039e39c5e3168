//! Infante's criterion for time-varying coefficients (Theorem 2.1 of "Stability criteria for
//! n-th order, homogeneous linear differential equations"). For
//!
//! ```text
//! x⁽ⁿ⁾ + p₁(t)x⁽ⁿ⁻¹⁾ + … + pₙ(t)x = 0
//! ```
//!
//! choose n constants α₁ … αₙ satisfying the Routh–Hurwitz inequalities and a diagonal
//! C ≥ 0 with exactly one zero, at (i, i); with A the companion matrix (2.18) of the α's, B
//! solves AᵀB + BA = −C (positive definite by Lemma 2.1), b = Be_n its last column and
//! β = β_ni its i-th entry (must be > 0). With η_k = p_k(t) − α_k and u = (ηₙ, …, η₁), the
//! derivative of V = xᵀBx along the equation is −V̇ = xᵀ(C + ubᵀ + buᵀ)x (2.7), and the
//! substitution x_i = y_i − Σ_{j≠i} b_j y_j / β (2.10) and completing the square (2.13) leave
//! −V̇ = Σ_{j≠i} c_j z_j² + w(t) z_i² with
//!
//! ```text
//! w = 2β η_{n+1−i} − Σ_{j≠i} (β u_j − η_{n+1−i} b_j)² / c_j          (2.15), (2.20)
//! ```
//!
//! If w(t) ≥ δ > 0 for all t ≥ 0 (or all t ≥ τ, Corollary 2.1) the origin is asymptotically
//! stable. In the space of the η's, {w ≥ δ} is the inside of an elliptic paraboloid (2.22), a
//! convex set: w is a concave quadratic of the coefficients. [`Criterion`] evaluates w and its
//! parts at given coefficients.

use std::fmt;

use nalgebra::{DMatrix, DVector};

/// Why a choice of α and C does not define the criterion.
#[derive(Clone, Debug, PartialEq)]
pub enum CriterionError {
    /// α and C have different lengths, or are empty.
    Size {
        /// Length of α.
        alpha: usize,
        /// Length of C's diagonal.
        c: usize,
    },
    /// The α's violate the Routh–Hurwitz inequalities: the Hurwitz determinant Δ_k ≤ 0.
    NotHurwitz {
        /// Which determinant (1-based).
        k: usize,
        /// Its value.
        value: f64,
    },
    /// C's diagonal is not of the theorem's form (finite, ≥ 0, exactly one zero).
    BadC(String),
    /// β_ni ≤ 0: the transformation (2.10) does not exist for this i.
    BetaNotPositive {
        /// The zero's position (1-based).
        i: usize,
        /// β_ni.
        beta: f64,
    },
}

impl fmt::Display for CriterionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CriterionError::Size { alpha, c } => write!(
                f,
                "the criterion needs α₁ … αₙ and C's diagonal c₁ … cₙ for the same n ≥ 1; \
                 {alpha} α's and {c} c's were given"
            ),
            CriterionError::NotHurwitz { k, value } => write!(
                f,
                "the α's violate the Routh–Hurwitz inequalities: Δ{k} = {value} ≤ 0 \
                 (choose α's whose polynomial sⁿ + α₁sⁿ⁻¹ + … + αₙ has all roots in the left half-plane)"
            ),
            CriterionError::BadC(m) => f.write_str(m),
            CriterionError::BetaNotPositive { i, beta } => write!(
                f,
                "β_n{i} = {beta} ≤ 0: with the zero of C at ({i}, {i}) the theorem needs B's entry \
                 (n, {i}) positive; put the zero elsewhere (i = n always works: β_nn > 0)"
            ),
        }
    }
}

impl std::error::Error for CriterionError {}

/// The parts of w at one point of the coefficient space.
#[derive(Clone, Debug, PartialEq)]
pub struct Terms {
    /// η₁ … ηₙ = p_k − α_k.
    pub eta: Vec<f64>,
    /// 2β η_{n+1−i}.
    pub linear: f64,
    /// Σ_{j<i} (β u_j − η_{n+1−i} b_j)² / c_j (the C^u part).
    pub upper: f64,
    /// Σ_{j>i} (β u_j − η_{n+1−i} b_j)² / c_j (the C^ℓ part).
    pub lower: f64,
    /// w = linear − upper − lower.
    pub w: f64,
}

/// Theorem 2.1 for one choice of α and C.
#[derive(Clone, Debug, PartialEq)]
pub struct Criterion {
    /// α₁ … αₙ.
    pub alpha: Vec<f64>,
    /// C's diagonal.
    pub c: Vec<f64>,
    /// The zero's position i (1-based).
    pub i: usize,
    /// B (n×n, symmetric, positive definite).
    pub b: Vec<Vec<f64>>,
}

/// The Hurwitz determinants Δ₁ … Δₙ (3.3) at the numbers `alpha`: the leading minors of the
/// matrix with entries α_{2j−i} (α₀ = 1, α_k = 0 outside 0 … n).
pub fn hurwitz_values(alpha: &[f64]) -> Vec<f64> {
    let n = alpha.len();
    let a = |k: isize| match k {
        0 => 1.0,
        k if k >= 1 && k as usize <= n => alpha[k as usize - 1],
        _ => 0.0,
    };
    let h = DMatrix::from_fn(n, n, |i, j| a(2 * (j as isize + 1) - (i as isize + 1)));
    (1..=n)
        .map(|k| h.view((0, 0), (k, k)).into_owned().determinant())
        .collect()
}

/// The symmetric B solving AᵀB + BA = −diag(c) for the companion matrix of `alpha`, by the
/// n²×n² Kronecker system (LU); `None` if it is singular.
pub fn lyapunov_b(alpha: &[f64], c: &[f64]) -> Option<Vec<Vec<f64>>> {
    let n = alpha.len();
    let a = |r: usize, s: usize| {
        if r == n - 1 {
            -alpha[n - 1 - s]
        } else if s == r + 1 {
            1.0
        } else {
            0.0
        }
    };
    let mut m = DMatrix::<f64>::zeros(n * n, n * n);
    let mut rhs = DVector::<f64>::zeros(n * n);
    for r in 0..n {
        for s in 0..n {
            // (AᵀB + BA)_rs = Σ_k A_kr B_ks + B_rk A_ks
            for k in 0..n {
                m[(r * n + s, k * n + s)] += a(k, r);
                m[(r * n + s, r * n + k)] += a(k, s);
            }
            if r == s {
                rhs[r * n + s] = -c[r];
            }
        }
    }
    let x = m.lu().solve(&rhs)?;
    Some(
        (0..n)
            .map(|r| {
                (0..n)
                    .map(|s| 0.5 * (x[r * n + s] + x[s * n + r]))
                    .collect()
            })
            .collect(),
    )
}

impl Criterion {
    /// Checks α (Routh–Hurwitz) and C (≥ 0, one zero), solves B and checks β_ni > 0.
    pub fn new(alpha: &[f64], c: &[f64]) -> Result<Criterion, CriterionError> {
        let n = alpha.len();
        if n == 0 || c.len() != n {
            return Err(CriterionError::Size {
                alpha: n,
                c: c.len(),
            });
        }
        for (k, value) in hurwitz_values(alpha).into_iter().enumerate() {
            if value.is_nan() || value <= 0.0 {
                return Err(CriterionError::NotHurwitz { k: k + 1, value });
            }
        }
        if let Some(x) = c.iter().find(|x| !x.is_finite() || **x < 0.0) {
            return Err(CriterionError::BadC(format!(
                "C's diagonal must be finite and non-negative; it has {x}"
            )));
        }
        let zeros: Vec<usize> = (0..n).filter(|&k| c[k] == 0.0).map(|k| k + 1).collect();
        let i = match zeros.as_slice() {
            [i] => *i,
            _ => {
                return Err(CriterionError::BadC(format!(
                    "C's diagonal must have exactly one zero (Theorem 2.1: the zero at (i, i) chooses i); \
                     {c:?} has zeros at {zeros:?}"
                )))
            }
        };
        let b = lyapunov_b(alpha, c).ok_or(CriterionError::NotHurwitz { k: n, value: 0.0 })?;
        let beta = b[n - 1][i - 1];
        if beta.is_nan() || beta <= 0.0 {
            return Err(CriterionError::BetaNotPositive { i, beta });
        }
        Ok(Criterion {
            alpha: alpha.to_vec(),
            c: c.to_vec(),
            i,
            b,
        })
    }

    /// The order n.
    pub fn order(&self) -> usize {
        self.alpha.len()
    }

    /// β_ni.
    pub fn beta(&self) -> f64 {
        self.b[self.order() - 1][self.i - 1]
    }

    /// w and its parts at the coefficients p₁ … pₙ.
    pub fn terms(&self, p: &[f64]) -> Terms {
        let n = self.order();
        let i = self.i - 1;
        let eta: Vec<f64> = p.iter().zip(&self.alpha).map(|(p, a)| p - a).collect();
        // u_j = η_{n−j} (0-based j), so u_i = η_{n+1−i} in the paper's 1-based indices
        let u = |j: usize| eta[n - 1 - j];
        let beta = self.beta();
        let (mut upper, mut lower) = (0.0, 0.0);
        for j in (0..n).filter(|&j| j != i) {
            let v = beta * u(j) - u(i) * self.b[j][n - 1];
            if j < i {
                upper += v * v / self.c[j];
            } else {
                lower += v * v / self.c[j];
            }
        }
        let linear = 2.0 * beta * u(i);
        Terms {
            eta,
            linear,
            upper,
            lower,
            w: linear - upper - lower,
        }
    }

    /// w at the coefficients p₁ … pₙ.
    pub fn w(&self, p: &[f64]) -> f64 {
        self.terms(p).w
    }

    /// The interval of one coefficient p_k (1-based k) where w > 0 with the others at `p`:
    /// w is a concave quadratic along any line of the coefficient space, so the interval is
    /// found from three values. `None` if w ≤ 0 on the whole line.
    pub fn interval(&self, p: &[f64], k: usize) -> Option<(f64, f64)> {
        let at = |x: f64| {
            let mut q = p.to_vec();
            q[k - 1] = x;
            self.w(&q)
        };
        let (w0, w1, wm) = (at(0.0), at(1.0), at(-1.0));
        let a = 0.5 * (w1 + wm) - w0;
        let b = 0.5 * (w1 - wm);
        if a.abs() <= 1e-14 * (w0.abs() + w1.abs() + wm.abs()) {
            // linear along this coordinate (it does not enter the squares)
            return match b {
                b if b > 0.0 => Some((-w0 / b, f64::INFINITY)),
                b if b < 0.0 => Some((f64::NEG_INFINITY, -w0 / b)),
                _ if w0 > 0.0 => Some((f64::NEG_INFINITY, f64::INFINITY)),
                _ => None,
            };
        }
        let disc = b * b - 4.0 * a * w0;
        if a > 0.0 || disc <= 0.0 {
            return None;
        }
        // roots of a x² + b x + w0 (a < 0), the cancellation-free pair
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let (r1, r2) = (q / a, w0 / q);
        Some((r1.min(r2), r1.max(r2)))
    }
}
