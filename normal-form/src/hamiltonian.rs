//! Hamiltonians as expressions evaluated over any [`Scalar`], their Taylor expansion by jet
//! arithmetic, and Newton's method for equilibria.

use crate::error::NormalFormError;
use crate::jet::Jet;
use crate::linalg::{solve, Mat};
use crate::monomial::MonomialTable;
use crate::poly::Poly;
use crate::scalar::Real;
use lasalle_model::ir::Scalar;
use std::sync::Arc;

/// A Hamiltonian with `n` degrees of freedom in canonical coordinates
/// `z = (q₁…q_n, p₁…p_n)`, evaluated generically so that the same expression gives numbers,
/// jets (Taylor series) and double-double values: `S` is the front end's
/// `lasalle_model::ir::Scalar` (re-exported as [`Scalar`](crate::Scalar)).
///
/// Parameters are part of the implementing value. DSL models are [`ModelHamiltonian`]s;
/// writing one in Rust is mainly for independent checks (see [`PolynomialHamiltonian`]).
///
/// [`ModelHamiltonian`]: crate::ModelHamiltonian
/// [`PolynomialHamiltonian`]: crate::models::PolynomialHamiltonian
pub trait HamiltonianFn {
    /// Degrees of freedom n.
    fn n_dof(&self) -> usize;
    /// H(z).
    fn eval<S: Scalar>(&self, z: &[S]) -> S;
    /// A short name for reports.
    fn name(&self) -> String {
        "hamiltonian".into()
    }
    /// Names of the 2n coordinates for reports (default q1…qn, p1…pn).
    fn coordinate_names(&self) -> Vec<String> {
        let n = self.n_dof();
        (1..=n)
            .map(|k| format!("q{k}"))
            .chain((1..=n).map(|k| format!("p{k}")))
            .collect()
    }
}

/// Taylor expansion of H about `point` to the table's degree: H(point + δz) as a polynomial
/// in δz, by evaluating H once over jets.
pub fn taylor<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &[R],
    table: &Arc<MonomialTable>,
) -> Poly<R> {
    let z: Vec<Jet<R>> = point
        .iter()
        .enumerate()
        .map(|(i, &x)| Jet::Series(Poly::variable(table.clone(), i, x)))
        .collect();
    h.eval(&z).into_poly(table)
}

/// Result of the equilibrium search.
#[derive(Clone, Debug)]
pub struct Equilibrium<R> {
    /// The point.
    pub z: Vec<R>,
    /// |∇H| at the starting point.
    pub initial_gradient: f64,
    /// |∇H| at the returned point.
    pub gradient: f64,
    /// Newton iterations done.
    pub iterations: usize,
}

/// Gradient and Hessian from a degree-2 Taylor polynomial.
pub fn gradient_hessian<R: Real>(p: &Poly<R>) -> (Vec<R>, Mat<R>) {
    let d = p.nvars();
    let mut g = vec![R::zero(); d];
    let mut s = vec![vec![R::zero(); d]; d];
    let mut e = vec![0u8; d];
    for i in 0..d {
        e[i] = 1;
        g[i] = p.coeff(&e);
        e[i] = 0;
    }
    for i in 0..d {
        for j in i..d {
            e[i] += 1;
            e[j] += 1;
            let c = p.coeff(&e);
            e[i] -= 1;
            e[j] -= 1;
            if i == j {
                s[i][i] = c + c;
            } else {
                s[i][j] = c;
                s[j][i] = c;
            }
        }
    }
    (g, s)
}

fn norm<R: Real>(v: &[R]) -> f64 {
    v.iter()
        .map(|x| x.to_f64() * x.to_f64())
        .sum::<f64>()
        .sqrt()
}

/// Newton's method for ∇H = 0 from `start`, in the working precision R.
pub fn find_equilibrium<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    start: &[R],
    max_iter: usize,
) -> Result<Equilibrium<R>, NormalFormError> {
    let d = 2 * h.n_dof();
    let table = Arc::new(MonomialTable::new(d, 2));
    let mut z = start.to_vec();
    let mut initial = f64::NAN;
    let scale = 1.0 + norm(start);
    let mut best: Option<(f64, Vec<R>, usize)> = None;
    for it in 0..=max_iter {
        let p = taylor(h, &z, &table);
        let (g, s) = gradient_hessian(&p);
        let gn = norm(&g);
        if !gn.is_finite() {
            return Err(NormalFormError::NonFinite(
                "the gradient at the equilibrium guess",
            ));
        }
        if it == 0 {
            initial = gn;
        }
        // |∇H| at rounding level: ε·|S|·|z| (the gradient cannot be resolved below this)
        let s_norm = s
            .iter()
            .flatten()
            .map(|x| x.to_f64().abs())
            .fold(0.0, f64::max);
        let floor = 16.0 * R::EPSILON * s_norm.max(1.0) * scale;
        if best.as_ref().is_none_or(|b| gn < b.0) {
            best = Some((gn, z.clone(), it));
        }
        // a gradient at rounding level is an equilibrium, whatever the Hessian (a singular
        // one is reported by the expansion as degenerate, with its directions)
        if gn <= floor {
            return Ok(Equilibrium {
                z,
                initial_gradient: initial,
                gradient: gn,
                iterations: it,
            });
        }
        let rhs: Vec<R> = g.iter().map(|&x| -x).collect();
        let Some(dz) = solve(s, rhs) else {
            return Err(NormalFormError::NewtonFailed {
                iterations: it,
                residual: gn,
                singular_hessian: true,
            });
        };
        let step = norm(&dz);
        if step <= 16.0 * R::EPSILON * scale {
            return Ok(Equilibrium {
                z,
                initial_gradient: initial,
                gradient: gn,
                iterations: it,
            });
        }
        for (zi, di) in z.iter_mut().zip(&dz) {
            *zi += *di;
        }
        if it == max_iter {
            // stagnation at rounding level is convergence
            if let Some((bg, bz, bit)) = best {
                if bg <= 1e3 * floor {
                    return Ok(Equilibrium {
                        z: bz,
                        initial_gradient: initial,
                        gradient: bg,
                        iterations: bit,
                    });
                }
            }
            return Err(NormalFormError::NewtonFailed {
                iterations: it,
                residual: gn,
                singular_hessian: false,
            });
        }
    }
    unreachable!()
}

/// Hessian eigenvalues at most this times max(1, ‖S‖) count as zero: H₂ vanishes in their
/// directions (zero frequencies), and no Birkhoff normal form exists at the equilibrium.
pub const DEGENERATE_HESSIAN: f64 = 1e-8;

/// Where H₂ = ½ δzᵀ S δz vanishes at the equilibrium `z`: the unit eigenvectors of the
/// Hessian `s` with eigenvalues at most [`DEGENERATE_HESSIAN`]·max(1, ‖S‖), each marked
/// when H does not change along it at all (a translation symmetry: its conjugate momentum is
/// conserved and the equilibria are not isolated).
pub fn null_directions<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    z: &[R],
    s: &Mat<R>,
) -> Vec<NullDirection> {
    use crate::complex::Complex;
    let g: Mat<Complex<R>> = s
        .iter()
        .map(|row| row.iter().map(|&x| Complex::real(x)).collect())
        .collect();
    let (values, vectors) = crate::linalg::hermitian_eigen(g);
    let size = values.iter().map(|v| v.to_f64().abs()).fold(0.0, f64::max);
    let z: Vec<f64> = z.iter().map(|x| x.to_f64()).collect();
    let h0 = h.eval(&z);
    values
        .iter()
        .enumerate()
        .filter(|(_, v)| v.to_f64().abs() <= DEGENERATE_HESSIAN * size.max(1.0))
        .map(|(k, v)| {
            let mut direction: Vec<f64> = vectors.iter().map(|row| row[k].re.to_f64()).collect();
            // the sign that makes the largest component positive
            let largest = direction
                .iter()
                .fold(0.0, |m: f64, c| if c.abs() > m.abs() { *c } else { m });
            if largest < 0.0 {
                direction.iter_mut().for_each(|c| *c = -*c);
            }
            // H along the line z + t·v, far beyond the quadratic part's reach
            let symmetry = [-1.0, -0.25, 0.5, 2.0].iter().all(|t| {
                let moved: Vec<f64> = z.iter().zip(&direction).map(|(a, b)| a + t * b).collect();
                (h.eval(&moved) - h0).abs() <= 1e-12 * h0.abs().max(1.0)
            });
            NullDirection {
                eigenvalue: v.to_f64(),
                direction,
                symmetry,
            }
        })
        .collect()
}

/// A direction in which the Hessian of H vanishes ([`null_directions`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct NullDirection {
    /// The Hessian's eigenvalue (zero up to [`DEGENERATE_HESSIAN`]).
    pub eigenvalue: f64,
    /// Its unit eigenvector, in the flat coordinates (q, p).
    pub direction: Vec<f64>,
    /// H is unchanged along the whole line through the equilibrium: a translation symmetry.
    pub symmetry: bool,
}
