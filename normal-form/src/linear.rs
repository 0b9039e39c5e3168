//! Linear symplectic normalisation of the quadratic part `H₂ = ½ δzᵀ S δz`.
//!
//! The eigenvalues of the Hamiltonian matrix `M = J S` come in pairs ±λ; the characteristic
//! polynomial is even, `det(λI − M) = q(λ²)`, so the n roots `s_k` of q give `λ = ±√s_k`.
//! The equilibrium is elliptic when every `s_k = −ω_k²` is real negative. For the eigenvector
//! `f = u + iv` of `iω_k`, the columns
//! `a_k = u/√|β|`, `b_k = σ_k v/√|β|` with `β = uᵀJv`, `σ_k = sign β` form a real
//! symplectic matrix `A` (`AᵀJA = J`, checked numerically) in which
//! `H₂ = Σ σ_k ω_k (Q_k² + P_k²)/2`. Frequencies are sorted in decreasing order.
//!
//! A repeated frequency (e.g. the 1:1 resonance of Hénon–Heiles) is allowed when `M` is
//! diagonalisable on it: its eigenspace is given a basis orthonormal for the Hermitian form
//! `−(i/2) fᴴ J g` (signs = Krein signatures), and each basis vector then gives columns as
//! above. The normal form is then resonant (m·ω = 0 for m = e_j − e_k). A frequency with a
//! nilpotent part (fewer eigenvectors than its multiplicity, e.g. L4 at Routh's mass ratio)
//! is [`NormalFormError::Defective`].

use crate::complex::Complex;
use crate::error::{Eigenvalue, NormalFormError};
use crate::linalg::{
    char_poly, hermitian_eigen, matmul, max_diff, null_space, null_vector, poly_roots,
    symplectic_j, transpose, zeros, Mat,
};
use crate::scalar::{Coeff, Real};

/// Result of the linear normalisation.
#[derive(Clone, Debug)]
pub(crate) struct LinearNormalization<R> {
    /// ω_k > 0, decreasing.
    pub omega: Vec<R>,
    /// σ_k = ±1: H₂ = Σ σ_k ω_k I_k.
    pub sigma: Vec<i8>,
    /// Real symplectic A: δz = A (Q, P).
    pub a: Mat<R>,
    /// max |AᵀJA − J|
    pub symplectic_residual: f64,
    /// max |AᵀSA − diag(σω, σω)|
    pub diagonal_residual: f64,
}

/// The Hamiltonian matrix M = J S.
pub(crate) fn hamiltonian_matrix<R: Real>(s: &Mat<R>) -> Mat<R> {
    let d = s.len();
    let n = d / 2;
    let mut m = zeros(d, d);
    for i in 0..n {
        m[i] = s[n + i].clone();
        m[n + i] = s[i].iter().map(|&x| -x).collect();
    }
    m
}

pub(crate) fn linear_normalization<R: Real>(
    s: &Mat<R>,
    rotation: &[f64],
) -> Result<LinearNormalization<R>, NormalFormError> {
    let d = s.len();
    let n = d / 2;
    let m = hamiltonian_matrix(s);
    let c = char_poly(&m);
    // q(s) = Σ c_{2j} s^j
    let q: Vec<R> = (0..=n).map(|j| c[2 * j]).collect();
    let roots = poly_roots(&q);
    let scale = roots
        .iter()
        .map(|r| r.magnitude())
        .fold(0.0, f64::max)
        .max(1e-300);
    let eigenvalues = || -> Vec<Eigenvalue> {
        roots
            .iter()
            .flat_map(|&r| {
                let l = r.sqrt();
                let (re, im) = l.to_f64();
                [Eigenvalue { re, im }, Eigenvalue { re: -re, im: -im }]
            })
            .collect()
    };
    let tol_im = 1e-9 * scale;
    if roots
        .iter()
        .any(|r| r.im.abs().to_f64() > tol_im || r.re.to_f64() >= 0.0)
    {
        return Err(NormalFormError::NotElliptic {
            eigenvalues: eigenvalues(),
        });
    }
    let mut omega: Vec<R> = roots.iter().map(|r| (-r.re).sqrt()).collect();
    omega.sort_by(|a, b| b.to_f64().total_cmp(&a.to_f64()));
    // Clusters of repeated frequencies. A root of multiplicity m of q comes out of the
    // iteration split by ~ε^(1/m) (1e-16 for a double root in double-double), but the mean of
    // the cluster is as accurate as a simple root; within 1e-9·ω₁ frequencies count as equal.
    let mut clusters: Vec<std::ops::Range<usize>> = Vec::new();
    for k in 0..n {
        match clusters.last_mut() {
            Some(c) if (omega[c.start] - omega[k]).to_f64() <= 1e-9 * omega[0].to_f64() => {
                c.end = k + 1
            }
            _ => clusters.push(k..k + 1),
        }
    }
    for c in &clusters {
        if c.len() > 1 {
            let mean = omega[c.clone()].iter().fold(R::zero(), |s, &w| s + w)
                / R::from_f64(c.len() as f64);
            omega[c.clone()].iter_mut().for_each(|w| *w = mean);
        }
    }
    let mut a: Mat<R> = zeros(d, d);
    let mut sigma = vec![0i8; n];
    for c in &clusters {
        let lam = Complex::new(R::zero(), omega[c.start]);
        let mc: Mat<Complex<R>> = (0..d)
            .map(|i| {
                (0..d)
                    .map(|l| {
                        if i == l {
                            Complex::real(m[i][l]) - lam
                        } else {
                            Complex::real(m[i][l])
                        }
                    })
                    .collect()
            })
            .collect();
        let vectors = if c.len() == 1 {
            // the null vector of (M − iωI) is as accurate as ω itself
            vec![null_vector(mc)]
        } else {
            repeated_eigenvectors(mc, c.len(), &omega, omega[c.start].to_f64())?
        };
        for (k, f) in c.clone().zip(vectors) {
            let u: Vec<R> = f.iter().map(|c| c.re).collect();
            let v: Vec<R> = f.iter().map(|c| c.im).collect();
            // β = uᵀ J v
            let mut beta = R::zero();
            for i in 0..n {
                beta += u[i] * v[n + i] - u[n + i] * v[i];
            }
            let sg: i8 = if beta.to_f64() > 0.0 { 1 } else { -1 };
            let sc = R::one() / beta.abs().sqrt();
            // optional rotation of the (Q_k, P_k) plane: (a, b) → (a cos θ − σ b sin θ, …)
            let th = rotation.get(k).copied().unwrap_or(0.0);
            let (ct, st) = (R::from_f64(th).cos(), R::from_f64(th).sin());
            for i in 0..d {
                let ak = u[i] * sc;
                let bk = v[i] * sc * R::from_f64(sg as f64);
                a[i][k] = ak * ct - bk * st;
                a[i][n + k] = ak * st + bk * ct;
            }
            sigma[k] = sg;
        }
    }
    let (symplectic_residual, diagonal_residual) = residuals(&a, s, &omega, &sigma);
    Ok(LinearNormalization {
        omega,
        sigma,
        a,
        symplectic_residual,
        diagonal_residual,
    })
}

/// A basis f₁…f_m of the eigenspace of iω (M − iωI given) of a frequency of multiplicity m,
/// orthonormal for the Hermitian form `⟨f, g⟩ = −(i/2) fᴴ J g` up to signs: `⟨f_j, f_k⟩ =
/// ±δ_jk` (the sign is the Krein signature, σ_k). Eigenvectors of the same eigenvalue are
/// automatically J-orthogonal (`f_jᵀ J f_k = 0`), so the real and imaginary parts of the f_k
/// give symplectic columns as for a simple frequency. Fails when the eigenspace has fewer
/// than m dimensions (a nilpotent part: no diagonal normal form exists).
fn repeated_eigenvectors<R: Real>(
    mc: Mat<Complex<R>>,
    multiplicity: usize,
    omega: &[R],
    w: f64,
) -> Result<Vec<Vec<Complex<R>>>, NormalFormError> {
    let n = mc.len() / 2;
    let basis = null_space(mc, 1e-7);
    let defective = |eigenvectors: usize| NormalFormError::Defective {
        omega: w,
        multiplicity,
        eigenvectors,
        frequencies: omega.iter().map(|x| x.to_f64()).collect(),
    };
    if basis.len() != multiplicity {
        return Err(defective(basis.len()));
    }
    let form = |f: &[Complex<R>], g: &[Complex<R>]| {
        let mut s = Complex::zero();
        for i in 0..n {
            s += f[i].conj() * g[n + i] - f[n + i].conj() * g[i];
        }
        // −(i/2)·s
        Complex::new(s.im.scale(0.5), -s.re.scale(0.5))
    };
    let gram: Mat<Complex<R>> = basis
        .iter()
        .map(|f| basis.iter().map(|g| form(f, g)).collect())
        .collect();
    let (values, v) = hermitian_eigen(gram);
    let big = values.iter().map(|x| x.to_f64().abs()).fold(0.0, f64::max);
    if values.iter().any(|x| x.to_f64().abs() <= 1e-12 * big) {
        return Err(defective(basis.len()));
    }
    // positive Krein signature first
    let mut order: Vec<usize> = (0..multiplicity).collect();
    order.sort_by_key(|&k| if values[k].to_f64() > 0.0 { 0 } else { 1 });
    Ok(order
        .into_iter()
        .map(|k| {
            (0..2 * n)
                .map(|i| {
                    basis
                        .iter()
                        .enumerate()
                        .fold(Complex::zero(), |s, (j, f)| s + f[i] * v[j][k])
                })
                .collect()
        })
        .collect())
}

/// (max |AᵀJA − J|, max |AᵀSA − diag(σω, σω)|)
fn residuals<R: Real>(a: &Mat<R>, s: &Mat<R>, omega: &[R], sigma: &[i8]) -> (f64, f64) {
    let d = a.len();
    let n = d / 2;
    let j: Mat<R> = symplectic_j(n);
    let at = transpose(a);
    let symplectic = max_diff(&matmul(&matmul(&at, &j), a), &j);
    let mut dgl: Mat<R> = zeros(d, d);
    for k in 0..n {
        let w = omega[k] * R::from_f64(sigma[k] as f64);
        dgl[k][k] = w;
        dgl[n + k][n + k] = w;
    }
    (symplectic, max_diff(&matmul(&matmul(&at, s), a), &dgl))
}

impl<W: Real> LinearNormalization<W> {
    /// A and ω rounded to the working precision R, the residuals recomputed there (`s`: the
    /// Hessian in R).
    pub(crate) fn rounded<R: Real>(&self, s: &Mat<R>) -> LinearNormalization<R> {
        let r = |x: &W| R::convert(*x);
        let a: Mat<R> = self
            .a
            .iter()
            .map(|row| row.iter().map(r).collect())
            .collect();
        let omega: Vec<R> = self.omega.iter().map(r).collect();
        let (symplectic_residual, diagonal_residual) = residuals(&a, s, &omega, &self.sigma);
        LinearNormalization {
            omega,
            sigma: self.sigma.clone(),
            a,
            symplectic_residual,
            diagonal_residual,
        }
    }
}

/// The complexification `Q_k = (x_k + i y_k)/√2`, `P_k = (i x_k + y_k)/√2` (matrix C with
/// (Q, P) = C u) and its inverse `x_k = (Q_k − i P_k)/√2`, `y_k = (P_k − i Q_k)/√2`. It is
/// symplectic (dQ∧dP = dx∧dy) and turns `(Q_k² + P_k²)/2` into `i x_k y_k`.
pub(crate) fn complexification<R: Real>(n: usize) -> (Mat<Complex<R>>, Mat<Complex<R>>) {
    let d = 2 * n;
    let h = R::one() / R::from_f64(2.0).sqrt();
    let re = Complex::real(h);
    let im = Complex::new(R::zero(), h);
    let mut c: Mat<Complex<R>> = zeros(d, d);
    let mut ci: Mat<Complex<R>> = zeros(d, d);
    for k in 0..n {
        c[k][k] = re;
        c[k][n + k] = im;
        c[n + k][k] = im;
        c[n + k][n + k] = re;
        ci[k][k] = re;
        ci[k][n + k] = -im;
        ci[n + k][k] = -im;
        ci[n + k][n + k] = re;
    }
    (c, ci)
}

/// A⁻¹ = −J Aᵀ J for a symplectic A.
pub(crate) fn symplectic_inverse<R: Real>(a: &Mat<R>) -> Mat<R> {
    let n = a.len() / 2;
    let j: Mat<R> = symplectic_j(n);
    let r = matmul(&matmul(&j, &transpose(a)), &j);
    r.into_iter()
        .map(|row| row.into_iter().map(|x| -x).collect())
        .collect()
}
