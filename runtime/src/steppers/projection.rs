//! The standard projection method onto {f(x) = f(x₀)}.
//!
//! GNI (Hairer–Lubich–Wanner, *Geometric Numerical Integration*, 2nd ed.), §IV.4,
//! Algorithm 4.2, pp. 110–111: after a step x̃ = Φ_h(x_n) of any base method, set
//! x_{n+1} = x̃ + Df(x̃)ᵀλ where λ solves f(x̃ + Df(x̃)ᵀλ) = f(x₀), computed by the simplified
//! Newton iteration (Jacobian evaluated once, at x̃)
//!
//! ```text
//! Δλᵢ = −(Df(x̃) Df(x̃)ᵀ)⁻¹ (f(x̃ + Df(x̃)ᵀλᵢ) − f(x₀)),   λᵢ₊₁ = λᵢ + Δλᵢ,   λ₀ = 0.
//! ```
//!
//! The iteration stops as soon as |f(x) − f(x₀)|₂ ≤ `tol` — in particular no correction is made
//! while the base step already satisfies the tolerance (as MATLAB's `fsolve` with `TolFun`
//! behaves in Chang–Jiménez–Perlmutter 2016, §4). The stacked invariants are often dependent
//! (the 9 components of RᵀR − I contain only 6 independent ones; for Kepler, A·L ≡ 0), so
//! Df Dfᵀ is singular; the M×M system is solved by a Cholesky factorisation with complete
//! pivoting truncated at its numerical rank ([`pivoted_cholesky_solve`]). For a consistent
//! system the correction Dfᵀλ is the same for every solution λ, so the truncation is harmless.

use num_traits::Float;

use super::{StepOutcome, Stepper};
use crate::error::{state_to_vec, to_f64, StepError};
use crate::field::{lit, Invariants};

/// Solves `A z = rhs` for a symmetric positive semi-definite `A` by the Cholesky factorisation
/// with complete (diagonal) pivoting, `P A Pᵀ = L Lᵀ` (Higham, *Accuracy and Stability of
/// Numerical Algorithms*, 2nd ed., §10.3), stopped when the largest remaining pivot is at most
/// `rel_tol · max_i A_ii`. The components of `z` outside the numerical rank are set to zero
/// (a "basic" solution). Returns the numerical rank. Allocation free.
pub fn pivoted_cholesky_solve<T: Float, const M: usize>(
    a: &[[T; M]; M],
    rhs: &[T; M],
    rel_tol: T,
    z: &mut [T; M],
) -> usize {
    let mut w = *a;
    let mut perm = [0usize; M];
    for (i, p) in perm.iter_mut().enumerate() {
        *p = i;
    }
    *z = [T::zero(); M];
    let max_diag = (0..M).map(|i| a[i][i]).fold(T::zero(), T::max);
    if !(max_diag > T::zero()) {
        return 0;
    }
    let thresh = rel_tol * max_diag;
    let mut rank = 0;
    for k in 0..M {
        let mut p = k;
        for i in k + 1..M {
            if w[i][i] > w[p][p] {
                p = i;
            }
        }
        if !(w[p][p] > thresh) {
            break;
        }
        if p != k {
            w.swap(k, p);
            for row in w.iter_mut() {
                row.swap(k, p);
            }
            perm.swap(k, p);
        }
        let d = w[k][k].sqrt();
        w[k][k] = d;
        for i in k + 1..M {
            w[i][k] = w[i][k] / d;
            w[k][i] = w[i][k];
        }
        for i in k + 1..M {
            for j in k + 1..M {
                w[i][j] = w[i][j] - w[i][k] * w[j][k];
            }
        }
        rank = k + 1;
    }
    // forward substitution L y = P rhs, then back substitution Lᵀ u = y (leading rank block)
    let mut y = [T::zero(); M];
    for i in 0..rank {
        let mut s = rhs[perm[i]];
        for j in 0..i {
            s = s - w[i][j] * y[j];
        }
        y[i] = s / w[i][i];
    }
    for i in (0..rank).rev() {
        let mut s = y[i];
        for j in i + 1..rank {
            s = s - w[j][i] * y[j];
        }
        y[i] = s / w[i][i];
    }
    for i in 0..rank {
        z[perm[i]] = y[i];
    }
    rank
}

/// A base stepper followed by the standard projection onto {f(x) = f(x₀)} (GNI §IV.4,
/// Algorithm 4.2; see the module docs).
///
/// ```
/// # use lasalle_runtime::*;
/// # struct Osc;
/// # impl Field<f64, 2> for Osc { fn field(&self, x: &[f64; 2], dx: &mut [f64; 2]) { dx[0] = x[1]; dx[1] = -x[0]; } }
/// # impl Invariants<f64, 2, 1> for Osc {
/// #     fn invariants(&self, x: &[f64; 2], f: &mut [f64; 1]) { f[0] = 0.5 * (x[0] * x[0] + x[1] * x[1]); }
/// #     fn invariants_jacobian(&self, x: &[f64; 2], j: &mut [[f64; 2]; 1]) { j[0] = [x[0], x[1]]; }
/// # }
/// let x0 = [1.0, 0.0];
/// let mut proj = Projection::from_initial(ExplicitRk::euler(), &Osc, &x0, 1e-12);
/// let end = integrate(&mut proj, &Osc, &x0, 0.0, 10.0, 0.01, &mut ()).unwrap();
/// let energy = 0.5 * (end.x[0] * end.x[0] + end.x[1] * end.x[1]);
/// assert!((energy - 0.5).abs() <= 1e-12);
/// ```
#[derive(Clone, Debug)]
pub struct Projection<T, const M: usize, S> {
    base: S,
    target: [T; M],
    tol: T,
    max_iterations: u32,
    pivot_tol: T,
    newton_iterations: u64,
    projections: u64,
}

impl<T: Float, const M: usize, S> Projection<T, M, S> {
    /// Projects the steps of `base` onto {f(x) = `target`} with tolerance `tol` on
    /// |f(x) − target|₂. Defaults: at most 50 Newton iterations, relative pivot tolerance
    /// max(10⁴·ε, 1e-12) (2.2e-12 for `f64`).
    pub fn new(base: S, target: [T; M], tol: T) -> Self {
        Projection {
            base,
            target,
            tol,
            max_iterations: 50,
            pivot_tol: (T::epsilon() * lit(1e4)).max(lit(1e-12)),
            newton_iterations: 0,
            projections: 0,
        }
    }

    /// Like [`Projection::new`] with the target f(x₀) computed from the model.
    pub fn from_initial<const N: usize, F: Invariants<T, N, M> + ?Sized>(
        base: S,
        model: &F,
        x0: &[T; N],
        tol: T,
    ) -> Self {
        let mut target = [T::zero(); M];
        model.invariants(x0, &mut target);
        Self::new(base, target, tol)
    }

    /// Sets the maximum number of simplified Newton iterations per step (default 50).
    pub fn max_iterations(mut self, n: u32) -> Self {
        self.max_iterations = n;
        self
    }

    /// Sets the pivot tolerance of the truncated pivoted Cholesky solve, relative to the
    /// largest diagonal entry of Df Dfᵀ (default max(10⁴·ε, 1e-12)).
    pub fn pivot_tol(mut self, tol: T) -> Self {
        self.pivot_tol = tol;
        self
    }

    /// The target f(x₀).
    pub fn target(&self) -> &[T; M] {
        &self.target
    }

    /// The base stepper.
    pub fn base(&self) -> &S {
        &self.base
    }

    /// Total simplified Newton iterations so far (a measure of the projection's cost).
    pub fn newton_iterations(&self) -> u64 {
        self.newton_iterations
    }

    /// Number of steps that needed a correction (the residual exceeded `tol` after the base
    /// step).
    pub fn projections(&self) -> u64 {
        self.projections
    }
}

fn norm2<T: Float, const M: usize>(r: &[T; M]) -> T {
    r.iter().fold(T::zero(), |s, v| s + *v * *v).sqrt()
}

impl<T, const N: usize, const M: usize, F, S> Stepper<T, N, F> for Projection<T, M, S>
where
    T: Float,
    F: Invariants<T, N, M> + ?Sized,
    S: Stepper<T, N, F>,
{
    fn step(&mut self, field: &F, t: T, x: &mut [T; N], h: T) -> Result<StepOutcome<T>, StepError> {
        let outcome = self.base.step(field, t, x, h)?;
        let t_new = t + outcome.h_taken;
        let mut f = [T::zero(); M];
        let mut r = [T::zero(); M];
        let target = self.target;
        let residual = |f: &[T; M], r: &mut [T; M]| {
            for i in 0..M {
                r[i] = f[i] - target[i];
            }
            norm2(r)
        };
        field.invariants(x, &mut f);
        let mut res = residual(&f, &mut r);
        if res <= self.tol {
            return Ok(outcome);
        }
        self.projections += 1;
        let x_tilde = *x;
        let mut jac = [[T::zero(); N]; M];
        field.invariants_jacobian(&x_tilde, &mut jac);
        let mut gram = [[T::zero(); M]; M];
        for i in 0..M {
            for j in 0..=i {
                let mut s = T::zero();
                for n in 0..N {
                    s = s + jac[i][n] * jac[j][n];
                }
                gram[i][j] = s;
                gram[j][i] = s;
            }
        }
        let mut lambda = [T::zero(); M];
        let mut dlambda = [T::zero(); M];
        let mut iterations = 0u32;
        loop {
            if !res.is_finite() || iterations >= self.max_iterations {
                return Err(StepError::ProjectionNotConverged {
                    t: to_f64(t_new),
                    h: to_f64(outcome.h_taken),
                    iterations,
                    residual: to_f64(res),
                    tol: to_f64(self.tol),
                    state: state_to_vec(x),
                });
            }
            let neg_r = r.map(|v| -v);
            pivoted_cholesky_solve(&gram, &neg_r, self.pivot_tol, &mut dlambda);
            for i in 0..M {
                lambda[i] = lambda[i] + dlambda[i];
            }
            // x = x̃ + Dfᵀ λ
            *x = x_tilde;
            for i in 0..M {
                let l = lambda[i];
                if l != T::zero() {
                    for n in 0..N {
                        x[n] = x[n] + jac[i][n] * l;
                    }
                }
            }
            iterations += 1;
            self.newton_iterations += 1;
            field.invariants(x, &mut f);
            res = residual(&f, &mut r);
            if res <= self.tol {
                return Ok(outcome);
            }
        }
    }

    fn order(&self) -> u32 {
        self.base.order()
    }

    fn name(&self) -> String {
        format!("projection({})", self.base.name())
    }

    fn is_adaptive(&self) -> bool {
        self.base.is_adaptive()
    }

    fn initial_step(&mut self, field: &F, t0: T, x0: &[T; N], t_end: T) -> Option<T> {
        self.base.initial_step(field, t0, x0, t_end)
    }

    fn reset(&mut self) {
        self.base.reset()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pivoted_cholesky_full_rank() {
        let a = [[4.0, 2.0, 0.6], [2.0, 5.0, 1.0], [0.6, 1.0, 3.0]];
        let b = [1.0, -2.0, 0.5];
        let mut z = [0.0; 3];
        assert_eq!(pivoted_cholesky_solve(&a, &b, 1e-12, &mut z), 3);
        for i in 0..3 {
            let az: f64 = (0..3).map(|j| a[i][j] * z[j]).sum();
            assert!((az - b[i]).abs() < 1e-14, "row {i}: {az} vs {}", b[i]);
        }
    }

    #[test]
    fn pivoted_cholesky_rank_deficient_consistent() {
        // A = J Jᵀ with duplicated rows of J (like the (i,j) and (j,i) entries of RᵀR − I)
        let j = [
            [1.0, 2.0, 0.0],
            [0.0, 1.0, 1.0],
            [1.0, 2.0, 0.0],
            [3.0, 0.0, -1.0],
        ];
        let mut a = [[0.0; 4]; 4];
        for p in 0..4 {
            for q in 0..4 {
                a[p][q] = (0..3).map(|n| j[p][n] * j[q][n]).sum();
            }
        }
        // consistent right-hand side b = A w
        let w = [0.3, -1.0, 0.7, 2.0];
        let b: [f64; 4] = std::array::from_fn(|p| (0..4).map(|q| a[p][q] * w[q]).sum());
        let mut z = [0.0; 4];
        assert_eq!(pivoted_cholesky_solve(&a, &b, 1e-12, &mut z), 3);
        // same correction Jᵀz = Jᵀw
        for n in 0..3 {
            let jz: f64 = (0..4).map(|p| j[p][n] * z[p]).sum();
            let jw: f64 = (0..4).map(|p| j[p][n] * w[p]).sum();
            assert!((jz - jw).abs() < 1e-12);
        }
    }
}
