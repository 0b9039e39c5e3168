//! Small dense linear algebra generic over the scalar (for 2n×2n matrices, n = degrees of
//! freedom): Gaussian elimination, null vectors, characteristic polynomials and polynomial
//! roots. Everything runs in the working precision, so the double-double path keeps its
//! 32 digits through the linear normalisation.

use crate::complex::Complex;
use crate::scalar::{Coeff, Real};

/// A dense matrix as rows.
pub type Mat<T> = Vec<Vec<T>>;

/// n×n zero matrix.
pub fn zeros<T: Coeff>(n: usize, m: usize) -> Mat<T> {
    vec![vec![T::zero(); m]; n]
}

/// n×n identity.
pub fn identity<T: Coeff>(n: usize) -> Mat<T> {
    let mut a = zeros(n, n);
    for (i, row) in a.iter_mut().enumerate() {
        row[i] = T::one();
    }
    a
}

/// A·B
pub fn matmul<T: Coeff>(a: &Mat<T>, b: &Mat<T>) -> Mat<T> {
    let (n, k, m) = (a.len(), b.len(), b[0].len());
    let mut c: Mat<T> = zeros(n, m);
    for i in 0..n {
        for l in 0..k {
            let x = a[i][l];
            if x.is_zero() {
                continue;
            }
            for j in 0..m {
                c[i][j].mul_acc(x, b[l][j]);
            }
        }
    }
    c
}

/// Aᵀ
pub fn transpose<T: Coeff>(a: &Mat<T>) -> Mat<T> {
    let (n, m) = (a.len(), a[0].len());
    (0..m).map(|j| (0..n).map(|i| a[i][j]).collect()).collect()
}

/// A·x
pub fn matvec<T: Coeff>(a: &Mat<T>, x: &[T]) -> Vec<T> {
    a.iter()
        .map(|row| row.iter().zip(x).fold(T::zero(), |s, (&p, &q)| s + p * q))
        .collect()
}

/// The canonical symplectic matrix J = [[0, I], [−I, 0]] of size 2n.
pub fn symplectic_j<T: Coeff>(n: usize) -> Mat<T> {
    let mut j = zeros(2 * n, 2 * n);
    for k in 0..n {
        j[k][n + k] = T::one();
        j[n + k][k] = -T::one();
    }
    j
}

/// max |A − B| over entries, as f64.
pub fn max_diff<T: Coeff>(a: &Mat<T>, b: &Mat<T>) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(r, s)| r.iter().zip(s).map(|(&x, &y)| (x - y).magnitude()))
        .fold(0.0, f64::max)
}

/// Solves A x = b by Gaussian elimination with partial pivoting; `None` if singular.
#[allow(clippy::needless_range_loop)]
pub fn solve<T: Coeff>(mut a: Mat<T>, mut b: Vec<T>) -> Option<Vec<T>> {
    let n = a.len();
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| a[i][col].magnitude().total_cmp(&a[j][col].magnitude()))?;
        if a[piv][col].magnitude() == 0.0 || !a[piv][col].is_finite() {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for i in col + 1..n {
            let f = a[i][col] / a[col][col];
            if f.is_zero() {
                continue;
            }
            for j in col..n {
                let t = a[col][j];
                a[i][j] -= f * t;
            }
            let t = b[col];
            b[i] -= f * t;
        }
    }
    let mut x = vec![T::zero(); n];
    for i in (0..n).rev() {
        let mut s = b[i];
        for j in i + 1..n {
            s -= a[i][j] * x[j];
        }
        x[i] = s / a[i][i];
    }
    Some(x)
}

/// Inverse by Gaussian elimination; `None` if singular.
pub fn inverse<T: Coeff>(a: &Mat<T>) -> Option<Mat<T>> {
    let n = a.len();
    let cols: Option<Vec<Vec<T>>> = (0..n)
        .map(|j| {
            let mut e = vec![T::zero(); n];
            e[j] = T::one();
            solve(a.clone(), e)
        })
        .collect();
    cols.map(|c| transpose(&c))
}

/// A nonzero x with A x ≈ 0 for a matrix of corank one: Gaussian elimination with complete
/// pivoting, the last (smallest) pivot taken as zero.
#[allow(clippy::needless_range_loop)]
pub fn null_vector<T: Coeff>(mut a: Mat<T>) -> Vec<T> {
    let n = a.len();
    let mut perm: Vec<usize> = (0..n).collect(); // column permutation
    for k in 0..n - 1 {
        let (mut pi, mut pj, mut best) = (k, k, -1.0);
        for (i, row) in a.iter().enumerate().skip(k) {
            for (j, x) in row.iter().enumerate().skip(k) {
                let m = x.magnitude();
                if m > best {
                    (pi, pj, best) = (i, j, m);
                }
            }
        }
        a.swap(k, pi);
        for row in a.iter_mut() {
            row.swap(k, pj);
        }
        perm.swap(k, pj);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            for j in k..n {
                let t = a[k][j];
                a[i][j] -= f * t;
            }
        }
    }
    // U y = 0 with y_{n−1} = 1
    let mut y = vec![T::zero(); n];
    y[n - 1] = T::one();
    for i in (0..n - 1).rev() {
        let mut s = T::zero();
        for j in i + 1..n {
            s -= a[i][j] * y[j];
        }
        y[i] = s / a[i][i];
    }
    let mut x = vec![T::zero(); n];
    for (k, &p) in perm.iter().enumerate() {
        x[p] = y[k];
    }
    x
}

/// A basis of the numerical null space of the square matrix A: Gaussian elimination with
/// complete pivoting, stopped when the largest remaining entry is ≤ `rel_tol` times the first
/// pivot; each remaining (free) column gives one basis vector by back substitution. For a
/// corank-one matrix this is [`null_vector`]'s vector.
#[allow(clippy::needless_range_loop)]
pub fn null_space<T: Coeff>(mut a: Mat<T>, rel_tol: f64) -> Vec<Vec<T>> {
    let n = a.len();
    let mut perm: Vec<usize> = (0..n).collect();
    let mut rank = 0;
    let mut first = 0.0;
    for k in 0..n {
        let (mut pi, mut pj, mut best) = (k, k, -1.0);
        for (i, row) in a.iter().enumerate().skip(k) {
            for (j, x) in row.iter().enumerate().skip(k) {
                let m = x.magnitude();
                if m > best {
                    (pi, pj, best) = (i, j, m);
                }
            }
        }
        if k == 0 {
            first = best;
        }
        if best <= rel_tol * first || best == 0.0 {
            break;
        }
        a.swap(k, pi);
        for row in a.iter_mut() {
            row.swap(k, pj);
        }
        perm.swap(k, pj);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            for j in k..n {
                let t = a[k][j];
                a[i][j] -= f * t;
            }
        }
        rank = k + 1;
    }
    (rank..n)
        .map(|free| {
            let mut y = vec![T::zero(); n];
            y[free] = T::one();
            for i in (0..rank).rev() {
                let mut s = T::zero();
                for j in i + 1..n {
                    s -= a[i][j] * y[j];
                }
                y[i] = s / a[i][i];
            }
            let mut x = vec![T::zero(); n];
            for (k, &p) in perm.iter().enumerate() {
                x[p] = y[k];
            }
            x
        })
        .collect()
}

/// Eigenvalues and unitary eigenvectors (columns of V, `Vᴴ G V = diag`) of a small Hermitian
/// matrix by cyclic complex Jacobi rotations.
#[allow(clippy::needless_range_loop)]
pub fn hermitian_eigen<R: Real>(mut g: Mat<Complex<R>>) -> (Vec<R>, Mat<Complex<R>>) {
    let m = g.len();
    let mut v: Mat<Complex<R>> = identity(m);
    let scale = g
        .iter()
        .flat_map(|r| r.iter().map(|c| c.magnitude()))
        .fold(0.0, f64::max)
        .max(1e-300);
    for _sweep in 0..60 {
        let off = (0..m)
            .flat_map(|p| (p + 1..m).map(move |q| (p, q)))
            .map(|(p, q)| g[p][q].magnitude())
            .fold(0.0, f64::max);
        if off <= 4.0 * R::EPSILON * scale {
            break;
        }
        for p in 0..m {
            for q in p + 1..m {
                let a = g[p][q].abs();
                if a.to_f64() <= R::EPSILON * scale * 1e-3 {
                    continue;
                }
                // D = diag(1, d) with d = conj(g_pq)/|g_pq| makes the (p, q) entry real, then
                // the real rotation [[c, s], [−s, c]] annihilates it: U = D·R on (p, q)
                let d = g[p][q].conj().scale_r(R::one() / a);
                let theta = (g[q][q].re - g[p][p].re) / (a + a);
                let t = R::from_f64(theta.to_f64().signum())
                    / (theta.abs() + (theta * theta + R::one()).sqrt());
                let c = R::one() / (t * t + R::one()).sqrt();
                let s = t * c;
                let upp = Complex::real(c);
                let upq = Complex::real(s);
                let uqp = d.scale_r(-s);
                let uqq = d.scale_r(c);
                // G ← G U (columns p, q), then G ← Uᴴ G (rows p, q); V ← V U
                for row in g.iter_mut().chain(v.iter_mut()) {
                    let (x, y) = (row[p], row[q]);
                    row[p] = x * upp + y * uqp;
                    row[q] = x * upq + y * uqq;
                }
                for j in 0..m {
                    let (x, y) = (g[p][j], g[q][j]);
                    g[p][j] = upp.conj() * x + uqp.conj() * y;
                    g[q][j] = upq.conj() * x + uqq.conj() * y;
                }
            }
        }
    }
    ((0..m).map(|k| g[k][k].re).collect(), v)
}

/// Coefficients c₀…c_n of det(λI − M) = Σ c_k λᵏ (c_n = 1), by Faddeev–LeVerrier.
pub fn char_poly<R: Real>(m: &Mat<R>) -> Vec<R> {
    let n = m.len();
    let mut c = vec![R::zero(); n + 1];
    c[n] = R::one();
    let mut mk: Mat<R> = zeros(n, n);
    for k in 1..=n {
        // M_k = M·M_{k−1} + c_{n−k+1} I
        let mut next = matmul(m, &mk);
        for (i, row) in next.iter_mut().enumerate() {
            row[i] += c[n - k + 1];
        }
        mk = next;
        let amk = matmul(m, &mk);
        let tr = (0..n).fold(R::zero(), |s, i| s + amk[i][i]);
        c[n - k] = -tr / R::from_f64(k as f64);
    }
    c
}

fn horner<R: Real>(c: &[Complex<R>], z: Complex<R>) -> (Complex<R>, Complex<R>) {
    // value and derivative
    let mut p = Complex::zero();
    let mut dp = Complex::zero();
    for &ck in c.iter().rev() {
        dp = dp * z + p;
        p = p * z + ck;
    }
    (p, dp)
}

/// All complex roots of Σ c_k zᵏ (c_n ≠ 0) by the Aberth–Ehrlich iteration.
pub fn poly_roots<R: Real>(c: &[R]) -> Vec<Complex<R>> {
    let n = c.len() - 1;
    let cc: Vec<Complex<R>> = c.iter().map(|&x| Complex::real(x)).collect();
    if n == 0 {
        return vec![];
    }
    if n == 1 {
        return vec![Complex::real(-c[0] / c[1])];
    }
    // initial guesses on a circle of the Cauchy radius
    let lead = c[n].to_f64();
    let radius = 1.0
        + c[..n]
            .iter()
            .map(|x| (x.to_f64() / lead).abs())
            .fold(0.0, f64::max);
    let r0 = radius.min(1e3) * 0.5;
    let mut z: Vec<Complex<R>> = (0..n)
        .map(|k| {
            let th = 2.0 * std::f64::consts::PI * k as f64 / n as f64 + 0.4;
            Complex::new(R::from_f64(r0 * th.cos()), R::from_f64(r0 * th.sin()))
        })
        .collect();
    for _ in 0..500 {
        let mut max_step: f64 = 0.0;
        for k in 0..n {
            let (p, dp) = horner(&cc, z[k]);
            if p.is_zero() {
                continue;
            }
            let w = p / dp;
            let mut s = Complex::zero();
            for (j, &zj) in z.iter().enumerate() {
                if j != k {
                    s += Complex::one() / (z[k] - zj);
                }
            }
            let step = w / (Complex::one() - w * s);
            z[k] -= step;
            max_step = max_step.max(step.magnitude() / z[k].magnitude().max(1e-300));
        }
        if max_step < R::EPSILON * 4.0 {
            break;
        }
    }
    // Newton polish
    for zk in z.iter_mut() {
        for _ in 0..3 {
            let (p, dp) = horner(&cc, *zk);
            if dp.is_zero() {
                break;
            }
            *zk -= p / dp;
        }
    }
    z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_of_cubic() {
        // (z − 1)(z + 2)(z − 3) = z³ − 2z² − 5z + 6
        let mut r = poly_roots(&[6.0, -5.0, -2.0, 1.0]);
        r.sort_by(|a, b| a.re.total_cmp(&b.re));
        for (z, e) in r.iter().zip([-2.0, 1.0, 3.0]) {
            assert!((z.re - e).abs() < 1e-14 && z.im.abs() < 1e-14);
        }
    }

    #[test]
    fn null_space_of_rank_two_and_hermitian_eigen() {
        // rank 2 in ℝ⁴: two null vectors
        let a = vec![
            vec![1.0, 2.0, 0.0, 1.0],
            vec![0.0, 1.0, 1.0, 0.0],
            vec![1.0, 3.0, 1.0, 1.0],
            vec![2.0, 4.0, 0.0, 2.0],
        ];
        let ns = null_space(a.clone(), 1e-12);
        assert_eq!(ns.len(), 2);
        for x in &ns {
            assert!(matvec(&a, x).iter().all(|v| v.abs() < 1e-13), "{x:?}");
        }
        // an indefinite Hermitian 3×3
        let c = |re: f64, im: f64| Complex::new(re, im);
        let g = vec![
            vec![c(0.0, 0.0), c(1.0, 2.0), c(0.5, 0.0)],
            vec![c(1.0, -2.0), c(0.0, 0.0), c(0.0, -1.0)],
            vec![c(0.5, 0.0), c(0.0, 1.0), c(-1.0, 0.0)],
        ];
        let (ev, v) = hermitian_eigen(g.clone());
        let vh: Mat<Complex<f64>> = transpose(&v)
            .into_iter()
            .map(|r| r.into_iter().map(|z| z.conj()).collect())
            .collect();
        let d = matmul(&matmul(&vh, &g), &v);
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { ev[i] } else { 0.0 };
                assert!((d[i][j] - Complex::real(want)).magnitude() < 1e-13, "{d:?}");
            }
        }
        let trace: f64 = ev.iter().sum();
        assert!((trace + 1.0).abs() < 1e-13);
        assert!(ev.iter().any(|&x| x > 0.5) && ev.iter().any(|&x| x < -0.5));
    }

    #[test]
    fn char_poly_and_null_vector() {
        let m = vec![vec![2.0, 1.0], vec![1.0, 3.0]];
        let c = char_poly(&m);
        assert!((c[0] - 5.0).abs() < 1e-14 && (c[1] + 5.0).abs() < 1e-14);
        let a = vec![vec![1.0, 2.0], vec![2.0, 4.0]];
        let x = null_vector(a.clone());
        assert!(matvec(&a, &x).iter().all(|v| v.abs() < 1e-14));
    }
}
