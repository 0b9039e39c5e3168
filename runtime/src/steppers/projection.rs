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
use crate::state::State;

/// Solves `A z = rhs` for a symmetric positive semi-definite `A` by the Cholesky factorisation
/// with complete (diagonal) pivoting, `P A Pᵀ = L Lᵀ` (Higham, *Accuracy and Stability of
/// Numerical Algorithms*, 2nd ed., §10.3), stopped when the largest remaining pivot is at most
/// `rel_tol · max_i A_ii`. The components of `z` outside the numerical rank are set to zero
/// (a "basic" solution). Returns the numerical rank.
///
/// Allocation free: `a` (M rows of length M) is overwritten by the factor, `rhs` is used as
/// scratch, and `perm` (length M) holds the pivoting.
pub fn pivoted_cholesky_solve<T: Float, R: AsRef<[T]> + AsMut<[T]>>(
    a: &mut [R],
    rhs: &mut [T],
    rel_tol: T,
    perm: &mut [usize],
    z: &mut [T],
) -> usize {
    let m = a.len();
    for (i, p) in perm.iter_mut().enumerate() {
        *p = i;
    }
    z.iter_mut().for_each(|v| *v = T::zero());
    let max_diag = (0..m).map(|i| a[i].as_ref()[i]).fold(T::zero(), T::max);
    if !(max_diag > T::zero()) {
        return 0;
    }
    let thresh = rel_tol * max_diag;
    let w = a;
    let at = |w: &[R], i: usize, j: usize| w[i].as_ref()[j];
    let mut rank = 0;
    for k in 0..m {
        let mut p = k;
        for i in k + 1..m {
            if at(w, i, i) > at(w, p, p) {
                p = i;
            }
        }
        if !(at(w, p, p) > thresh) {
            break;
        }
        if p != k {
            w.swap(k, p);
            for row in w.iter_mut() {
                row.as_mut().swap(k, p);
            }
            perm.swap(k, p);
        }
        let d = at(w, k, k).sqrt();
        w[k].as_mut()[k] = d;
        for i in k + 1..m {
            let v = at(w, i, k) / d;
            w[i].as_mut()[k] = v;
            w[k].as_mut()[i] = v;
        }
        for i in k + 1..m {
            for j in k + 1..m {
                let v = at(w, i, j) - at(w, i, k) * at(w, j, k);
                w[i].as_mut()[j] = v;
            }
        }
        rank = k + 1;
    }
    // forward substitution L y = P rhs, then back substitution Lᵀ u = y (leading rank block);
    // y overwrites z's first `rank` entries in pivot order, then moves to its place
    for i in 0..rank {
        let mut s = rhs[perm[i]];
        for j in 0..i {
            s = s - at(w, i, j) * z[j];
        }
        z[i] = s / at(w, i, i);
    }
    for i in (0..rank).rev() {
        let mut s = z[i];
        for j in i + 1..rank {
            s = s - at(w, j, i) * z[j];
        }
        z[i] = s / at(w, i, i);
    }
    rhs[..rank].copy_from_slice(&z[..rank]);
    z.iter_mut().for_each(|v| *v = T::zero());
    for i in 0..rank {
        z[perm[i]] = rhs[i];
    }
    rank
}

/// A base stepper followed by the standard projection onto {f(x) = f(x₀)} (GNI §IV.4,
/// Algorithm 4.2; see the module docs).
///
/// ```
/// # use lasalle_runtime::*;
/// # struct Osc;
/// # impl Field<f64, [f64; 2]> for Osc { fn field(&self, x: &[f64; 2], dx: &mut [f64; 2]) { dx[0] = x[1]; dx[1] = -x[0]; } }
/// # impl Invariants<f64, [f64; 2], [f64; 1]> for Osc {
/// #     fn invariants(&self, x: &[f64; 2], f: &mut [f64; 1]) { f[0] = 0.5 * (x[0] * x[0] + x[1] * x[1]); }
/// #     fn invariants_jacobian(&self, x: &[f64; 2], j: &mut [[f64; 2]; 1]) { j[0] = [x[0], x[1]]; }
/// # }
/// let x0 = [1.0, 0.0];
/// let mut proj = Projection::from_initial(ExplicitRk::euler(), &Osc, &x0, 1e-12);
/// let end = integrate(&mut proj, &Osc, &x0, 0.0, 10.0, 0.01, &mut ()).unwrap();
/// let energy = 0.5 * (end.x[0] * end.x[0] + end.x[1] * end.x[1]);
/// assert!((energy - 0.5).abs() <= 1e-12);
/// ```
#[derive(Clone)]
pub struct Projection<T, F: State<T>, S, X: State<T>> {
    base: S,
    target: F,
    tol: T,
    max_iterations: u32,
    pivot_tol: T,
    newton_iterations: u64,
    projections: u64,
    work: Option<Work<T, X, F>>,
}

/// Scratch storage of [`Projection`], sized at the first step.
#[derive(Clone)]
struct Work<T, X: State<T>, F: State<T>> {
    f: F,
    r: F,
    lambda: F,
    dlambda: F,
    x_tilde: X,
    jac: F::Rows<X>,
    /// Df Dfᵀ at x̃, and its copy that each solve overwrites with the factor.
    gram0: F::Rows<F>,
    gram: F::Rows<F>,
    perm: Vec<usize>,
}

impl<T: Float, F: State<T>, S, X: State<T>> Projection<T, F, S, X> {
    /// Projects the steps of `base` onto {f(x) = `target`} with tolerance `tol` on
    /// |f(x) − target|₂. Defaults: at most 50 Newton iterations, relative pivot tolerance
    /// max(10⁴·ε, 1e-12) (2.2e-12 for `f64`).
    pub fn new(base: S, target: F, tol: T) -> Self {
        Projection {
            base,
            target,
            tol,
            max_iterations: 50,
            pivot_tol: (T::epsilon() * lit(1e4)).max(lit(1e-12)),
            newton_iterations: 0,
            projections: 0,
            work: None,
        }
    }

    /// Like [`Projection::new`] with the target f(x₀) computed from the model.
    pub fn from_initial<Mdl: Invariants<T, X, F> + ?Sized>(
        base: S,
        model: &Mdl,
        x0: &X,
        tol: T,
    ) -> Self {
        let mut target = F::filled(F::len_for(model.invariant_dim()), T::zero());
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
    pub fn target(&self) -> &F {
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

impl<T: std::fmt::Debug, F: State<T> + std::fmt::Debug, S: std::fmt::Debug, X: State<T>>
    std::fmt::Debug for Projection<T, F, S, X>
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Projection")
            .field("base", &self.base)
            .field("target", &self.target)
            .field("tol", &self.tol)
            .field("max_iterations", &self.max_iterations)
            .field("newton_iterations", &self.newton_iterations)
            .field("projections", &self.projections)
            .finish_non_exhaustive()
    }
}

/// |f − target|₂, writing the residual f − target into `r`.
fn residual<T: Float>(f: &[T], target: &[T], r: &mut [T]) -> T {
    let mut s = T::zero();
    for ((ri, fi), ti) in r.iter_mut().zip(f).zip(target) {
        *ri = *fi - *ti;
        s = s + *ri * *ri;
    }
    s.sqrt()
}

impl<T, X, F, Mdl, S> Stepper<T, X, Mdl> for Projection<T, F, S, X>
where
    T: Float,
    X: State<T>,
    F: State<T>,
    Mdl: Invariants<T, X, F> + ?Sized,
    S: Stepper<T, X, Mdl>,
{
    fn step(&mut self, field: &Mdl, t: T, x: &mut X, h: T) -> Result<StepOutcome<T>, StepError> {
        let outcome = self.base.step(field, t, x, h)?;
        let t_new = t + outcome.h_taken;
        let (n, m) = (x.len(), self.target.len());
        if !matches!(&self.work, Some(w) if w.x_tilde.len() == n) {
            let zero_f = F::filled(F::len_for(m), T::zero());
            let zero_x = X::filled(X::len_for(n), T::zero());
            self.work = Some(Work {
                jac: F::rows(F::len_for(m), zero_x.clone()),
                gram0: F::rows(F::len_for(m), zero_f.clone()),
                gram: F::rows(F::len_for(m), zero_f.clone()),
                f: zero_f.clone(),
                r: zero_f.clone(),
                lambda: zero_f.clone(),
                dlambda: zero_f,
                x_tilde: zero_x,
                perm: vec![0; m],
            });
        }
        let w = self.work.as_mut().expect("sized above");
        let target = self.target.as_ref();
        field.invariants(x, &mut w.f);
        let mut res = residual(w.f.as_ref(), target, w.r.as_mut());
        if res <= self.tol {
            return Ok(outcome);
        }
        self.projections += 1;
        w.x_tilde.clone_from(x);
        field.invariants_jacobian(&w.x_tilde, &mut w.jac);
        let jac = w.jac.as_ref();
        let gram0 = w.gram0.as_mut();
        for i in 0..m {
            for j in 0..=i {
                let s = jac[i]
                    .as_ref()
                    .iter()
                    .zip(jac[j].as_ref())
                    .fold(T::zero(), |s, (a, b)| s + *a * *b);
                gram0[i].as_mut()[j] = s;
                gram0[j].as_mut()[i] = s;
            }
        }
        let lambda = w.lambda.as_mut();
        lambda.iter_mut().for_each(|l| *l = T::zero());
        let mut iterations = 0u32;
        loop {
            if !res.is_finite() || iterations >= self.max_iterations {
                return Err(StepError::ProjectionNotConverged {
                    t: to_f64(t_new),
                    h: to_f64(outcome.h_taken),
                    iterations,
                    residual: to_f64(res),
                    tol: to_f64(self.tol),
                    state: state_to_vec(x.as_ref()),
                });
            }
            w.gram.clone_from(&w.gram0);
            let gram = w.gram.as_mut();
            w.r.as_mut().iter_mut().for_each(|v| *v = -*v);
            pivoted_cholesky_solve(
                gram,
                w.r.as_mut(),
                self.pivot_tol,
                &mut w.perm,
                w.dlambda.as_mut(),
            );
            for (l, d) in lambda.iter_mut().zip(w.dlambda.as_ref()) {
                *l = *l + *d;
            }
            // x = x̃ + Dfᵀ λ
            x.clone_from(&w.x_tilde);
            for (row, &l) in jac.iter().zip(lambda.iter()) {
                if l != T::zero() {
                    for (xn, jn) in x.as_mut().iter_mut().zip(row.as_ref()) {
                        *xn = *xn + *jn * l;
                    }
                }
            }
            iterations += 1;
            self.newton_iterations += 1;
            field.invariants(x, &mut w.f);
            res = residual(w.f.as_ref(), target, w.r.as_mut());
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

    fn initial_step(&mut self, field: &Mdl, t0: T, x0: &X, t_end: T) -> Option<T> {
        self.base.initial_step(field, t0, x0, t_end)
    }

    fn reset(&mut self) {
        self.base.reset()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        let mut v = self.base.counters();
        v.push(("newton_iterations", self.newton_iterations as f64));
        v.push(("projected_steps", self.projections as f64));
        v
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
        let (mut f, mut rhs, mut perm) = (a, b, [0; 3]);
        assert_eq!(
            pivoted_cholesky_solve(&mut f, &mut rhs, 1e-12, &mut perm, &mut z),
            3
        );
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
        let (mut f, mut rhs, mut perm) = (a, b, [0; 4]);
        assert_eq!(
            pivoted_cholesky_solve(&mut f, &mut rhs, 1e-12, &mut perm, &mut z),
            3
        );
        // same correction Jᵀz = Jᵀw
        for n in 0..3 {
            let jz: f64 = (0..4).map(|p| j[p][n] * z[p]).sum();
            let jw: f64 = (0..4).map(|p| j[p][n] * w[p]).sum();
            assert!((jz - jw).abs() < 1e-12);
        }
    }
}
