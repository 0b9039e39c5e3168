//! Linear symplectic normalisation of the quadratic part `H₂ = ½ δzᵀ S δz`.
//!
//! The eigenvalues of the Hamiltonian matrix `M = J S` come in pairs ±λ; the characteristic
//! polynomial is even, `det(λI − M) = q(λ²)`, so the n roots `s_k` of q give `λ = ±√s_k`.
//! The equilibrium is elliptic when every `s_k = −ω_k²` is real negative and the ω_k are
//! distinct. For the eigenvector `f = u + iv` of `iω_k`, the columns
//! `a_k = u/√|β|`, `b_k = σ_k v/√|β|` with `β = uᵀJv`, `σ_k = sign β` form a real
//! symplectic matrix `A` (`AᵀJA = J`, checked numerically) in which
//! `H₂ = Σ σ_k ω_k (Q_k² + P_k²)/2`. Frequencies are sorted in decreasing order.

use crate::complex::Complex;
use crate::error::{Eigenvalue, NormalFormError};
use crate::linalg::{
    char_poly, matmul, max_diff, null_vector, poly_roots, symplectic_j, transpose, zeros, Mat,
};
use crate::scalar::{Coeff, Real};
use crate::Dd;

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
            repeated: false,
        });
    }
    let mut omega: Vec<R> = roots.iter().map(|r| (-r.re).sqrt()).collect();
    omega.sort_by(|a, b| b.to_f64().total_cmp(&a.to_f64()));
    for k in 1..n {
        if (omega[k - 1] - omega[k]).to_f64() <= 1e-7 * omega[0].to_f64() {
            return Err(NormalFormError::NotElliptic {
                eigenvalues: eigenvalues(),
                repeated: true,
            });
        }
    }
    // eigenvectors of iω_k, refined by one Newton step on ω is unnecessary: the null vector
    // of (M − iωI) is as accurate as ω itself.
    let mut a: Mat<R> = zeros(d, d);
    let mut sigma = vec![0i8; n];
    for k in 0..n {
        let lam = Complex::new(R::zero(), omega[k]);
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
        let f = null_vector(mc);
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
    let (symplectic_residual, diagonal_residual) = residuals(&a, s, &omega, &sigma);
    Ok(LinearNormalization {
        omega,
        sigma,
        a,
        symplectic_residual,
        diagonal_residual,
    })
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

impl LinearNormalization<Dd> {
    /// A and ω rounded to the working precision R, the residuals recomputed there (`s`: the
    /// Hessian in R).
    pub(crate) fn rounded<R: Real>(&self, s: &Mat<R>) -> LinearNormalization<R> {
        let r = |x: &Dd| R::from_hi_lo(x.hi, x.lo);
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
