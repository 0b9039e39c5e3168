//! Linear normalisation at a saddle × centre × … equilibrium: one real pair ±λ and n − 1
//! imaginary pairs ±iω_k of `M = J S`. A real symplectic `A` (`δz = A (Q, P)`, `AᵀJA = J`
//! checked) brings `H₂` to `λ Q₁P₁ + Σ_{k≥2} σ_k ω_k (Q_k² + P_k²)/2`.
//!
//! Columns: `a₁ = u₊` (the eigenvector of +λ, scaled to unit length) and `b₁ = u₋/(u₊ᵀJu₋)`
//! for the hyperbolic pair, so Q₁ is the unstable and P₁ the stable direction; for a centre,
//! from `f = u + iv` with `M f = iω f`, `a_k = u/√|β|`, `b_k = σ_k v/√|β|`, `β = uᵀJv`,
//! `σ_k = sign β`, after rotating the plane so that `a_k` vanishes on the momentum where the
//! eigenvector is largest, with that component of `b_k` positive (this fixes
//! the plane's orientation; Jorba & Masdemont's closed-form matrix has the same zero
//! pattern). With three degrees of freedom the centre whose eigenvector lies most in the last
//! canonical pair (the vertical one of the spatial three-body problem) comes last.

use crate::complex::Complex;
use crate::error::{Eigenvalue, NormalFormError};
use crate::linalg::{
    char_poly, matmul, max_diff, null_vector, poly_roots, symplectic_j, transpose, zeros, Mat,
};
use crate::linear::hamiltonian_matrix;
use crate::scalar::{Coeff, Real};
use crate::Dd;

/// The linear normalisation at a saddle × centre equilibrium.
#[derive(Clone, Debug)]
pub(crate) struct SaddleCentre<R> {
    /// λ > 0.
    pub lambda: R,
    /// ω_k > 0 of the centres (index 0 ↔ the pair (Q₂, P₂)).
    pub omega: Vec<R>,
    /// σ_k of the centres.
    pub sigma: Vec<i8>,
    /// δz = A (Q, P).
    pub a: Mat<R>,
    /// max |AᵀJA − J|.
    pub symplectic_residual: f64,
    /// max |AᵀSA − diag form|.
    pub diagonal_residual: f64,
}

fn eigenvalue_list(roots: &[Complex<Dd>]) -> Vec<Eigenvalue> {
    roots
        .iter()
        .flat_map(|&r| {
            let l = r.sqrt();
            let (re, im) = l.to_f64();
            [Eigenvalue { re, im }, Eigenvalue { re: -re, im: -im }]
        })
        .collect()
}

/// Null vector of (M − μI) for a complex μ.
fn eigenvector(m: &Mat<Dd>, mu: Complex<Dd>) -> Vec<Complex<Dd>> {
    let d = m.len();
    let mc: Mat<Complex<Dd>> = (0..d)
        .map(|i| {
            (0..d)
                .map(|l| {
                    let x = Complex::real(m[i][l]);
                    if i == l {
                        x - mu
                    } else {
                        x
                    }
                })
                .collect()
        })
        .collect();
    null_vector(mc)
}

/// A real eigenvector of a real eigenvalue: the null vector divided by its largest component,
/// then scaled to unit Euclidean length.
fn real_eigenvector(m: &Mat<Dd>, lam: Dd) -> Vec<Dd> {
    let f = eigenvector(m, Complex::real(lam));
    let big = f
        .iter()
        .copied()
        .max_by(|a, b| a.magnitude().total_cmp(&b.magnitude()))
        .expect("nonempty");
    let v: Vec<Dd> = f.iter().map(|&x| (x / big).re).collect();
    let norm = v.iter().fold(Dd::new(0.0), |s, &x| s + x * x).sqrt();
    v.into_iter().map(|x| x / norm).collect()
}

pub(crate) fn saddle_centre(s: &Mat<Dd>) -> Result<SaddleCentre<Dd>, NormalFormError> {
    let d = s.len();
    let n = d / 2;
    let m = hamiltonian_matrix(s);
    let c = char_poly(&m);
    let q: Vec<Dd> = (0..=n).map(|j| c[2 * j]).collect();
    let roots = poly_roots(&q);
    let scale = roots
        .iter()
        .map(|r| r.magnitude())
        .fold(0.0, f64::max)
        .max(1e-300);
    let tol = 1e-9 * scale;
    let not_saddle = || NormalFormError::NotSaddleCentre {
        eigenvalues: eigenvalue_list(&roots),
    };
    if roots.iter().any(|r| r.im.abs().to_f64() > tol) {
        return Err(not_saddle());
    }
    let positive: Vec<Dd> = roots
        .iter()
        .filter(|r| r.re.to_f64() > tol)
        .map(|r| r.re)
        .collect();
    let negative: Vec<Dd> = roots
        .iter()
        .filter(|r| r.re.to_f64() < -tol)
        .map(|r| r.re)
        .collect();
    if positive.len() != 1 || negative.len() != n - 1 {
        return Err(not_saddle());
    }
    let lambda = positive[0].sqrt();
    let mut omega: Vec<Dd> = negative.iter().map(|&r| (-r).sqrt()).collect();
    omega.sort_by(|a, b| b.to_f64().total_cmp(&a.to_f64()));
    for w in omega.windows(2) {
        if (w[0] - w[1]).to_f64() <= 1e-9 * w[0].to_f64() {
            return Err(NormalFormError::Invalid(format!(
                "the centre frequencies {} and {} coincide: the centre manifold reduction needs distinct ones",
                w[0].to_f64(),
                w[1].to_f64()
            )));
        }
    }
    let mut a: Mat<Dd> = zeros(d, d);
    // hyperbolic pair
    let up = real_eigenvector(&m, lambda);
    let um = real_eigenvector(&m, -lambda);
    let mut beta = Dd::new(0.0);
    for i in 0..n {
        beta += up[i] * um[n + i] - up[n + i] * um[i];
    }
    for i in 0..d {
        a[i][0] = up[i];
        a[i][n] = um[i] / beta;
    }
    // centres, with the weight of their eigenvector on the last canonical pair
    let mut modes: Vec<(Dd, Vec<Complex<Dd>>, f64)> = omega
        .iter()
        .map(|&w| {
            let f = eigenvector(&m, Complex::new(Dd::new(0.0), w));
            let total: f64 = f.iter().map(|x| x.magnitude().powi(2)).sum();
            let last = f[n - 1].magnitude().powi(2) + f[d - 1].magnitude().powi(2);
            (w, f, last / total)
        })
        .collect();
    if n == 3 {
        modes.sort_by(|x, y| x.2.total_cmp(&y.2));
    }
    let mut sigma = vec![0i8; n - 1];
    let mut omega_out = Vec::with_capacity(n - 1);
    for (k, (w, f, _)) in modes.into_iter().enumerate() {
        let col = k + 1;
        let u: Vec<Dd> = f.iter().map(|c| c.re).collect();
        let v: Vec<Dd> = f.iter().map(|c| c.im).collect();
        let mut beta = Dd::new(0.0);
        for i in 0..n {
            beta += u[i] * v[n + i] - u[n + i] * v[i];
        }
        let sg: i8 = if beta.to_f64() > 0.0 { 1 } else { -1 };
        let sc = Dd::new(1.0) / beta.abs().sqrt();
        let ak: Vec<Dd> = u.iter().map(|&x| x * sc).collect();
        let bk: Vec<Dd> = v.iter().map(|&x| x * sc * Dd::new(sg as f64)).collect();
        // gauge: rotate (a, b) → (a cos θ − b sin θ, a sin θ + b cos θ) so that the new a
        // vanishes on the momentum j where b is largest and the new b is positive there
        let size = |i: usize| ak[i].to_f64().powi(2) + bk[i].to_f64().powi(2);
        let j = (n..d)
            .max_by(|&x, &y| size(x).total_cmp(&size(y)).then(y.cmp(&x)))
            .expect("n ≥ 1");
        let r = (ak[j] * ak[j] + bk[j] * bk[j]).sqrt();
        let (ct, st) = (bk[j] / r, ak[j] / r);
        for i in 0..d {
            a[i][col] = ak[i] * ct - bk[i] * st;
            a[i][n + col] = ak[i] * st + bk[i] * ct;
        }
        sigma[k] = sg;
        omega_out.push(w);
    }
    let (symplectic_residual, diagonal_residual) = residuals(&a, s, lambda, &omega_out, &sigma);
    Ok(SaddleCentre {
        lambda,
        omega: omega_out,
        sigma,
        a,
        symplectic_residual,
        diagonal_residual,
    })
}

/// (max |AᵀJA − J|, max |AᵀSA − D|), D the Hessian of λQ₁P₁ + Σ σω(Q² + P²)/2.
fn residuals<R: Real>(a: &Mat<R>, s: &Mat<R>, lambda: R, omega: &[R], sigma: &[i8]) -> (f64, f64) {
    let d = a.len();
    let n = d / 2;
    let j: Mat<R> = symplectic_j(n);
    let at = transpose(a);
    let symplectic = max_diff(&matmul(&matmul(&at, &j), a), &j);
    let mut dg: Mat<R> = zeros(d, d);
    dg[0][n] = lambda;
    dg[n][0] = lambda;
    for k in 1..n {
        let w = omega[k - 1].scale(sigma[k - 1] as f64);
        dg[k][k] = w;
        dg[n + k][n + k] = w;
    }
    (symplectic, max_diff(&matmul(&matmul(&at, s), a), &dg))
}

impl SaddleCentre<Dd> {
    /// Rounded to R, residuals recomputed there.
    pub(crate) fn rounded<R: Real>(&self, s: &Mat<R>) -> SaddleCentre<R> {
        let r = |x: &Dd| R::from_hi_lo(x.hi, x.lo);
        let a: Mat<R> = self
            .a
            .iter()
            .map(|row| row.iter().map(r).collect())
            .collect();
        let omega: Vec<R> = self.omega.iter().map(r).collect();
        let lambda = r(&self.lambda);
        let (symplectic_residual, diagonal_residual) =
            residuals(&a, s, lambda, &omega, &self.sigma);
        SaddleCentre {
            lambda,
            omega,
            sigma: self.sigma.clone(),
            a,
            symplectic_residual,
            diagonal_residual,
        }
    }
}
