//! Random states for the numerical checks, and their projection onto a constraint manifold.

use crate::ir::{Graph, Id, Input};

/// Moves `x` onto {c(x) = 0} by Levenberg–Marquardt on ½|c|² (c may have dependent rows,
/// like the nine components of RᵀR − I). `None` if it does not converge to 1e-13.
pub fn project_onto(
    g: &Graph,
    jac: &[Vec<Id>],
    c: &[Id],
    params: &[f64],
    x: &[f64],
) -> Option<Vec<f64>> {
    let n = x.len();
    let mut x = x.to_vec();
    let mut lambda = 1e-3;
    let eval = |ids: &[Id], x: &[f64]| {
        g.eval_f64(ids, &mut |i| match i {
            Input::State(k) => x[k as usize],
            Input::Param(k) => params[k as usize],
            _ => f64::NAN,
        })
    };
    let flat: Vec<Id> = jac.iter().flatten().copied().collect();
    let norm2 = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>();
    let mut r = eval(c, &x);
    for _ in 0..200 {
        let cost = norm2(&r);
        if !cost.is_finite() {
            return None;
        }
        if cost.sqrt() < 1e-13 {
            return Some(x);
        }
        let jv = eval(&flat, &x);
        let j = |a: usize, i: usize| jv[a * n + i];
        // (JᵀJ + λ diag) δ = −Jᵀr
        let mut a = vec![vec![0.0; n]; n];
        let mut b = vec![0.0; n];
        for (i, (a_row, b_i)) in a.iter_mut().zip(b.iter_mut()).enumerate() {
            for (k, a_ik) in a_row.iter_mut().enumerate() {
                *a_ik = (0..c.len()).map(|row| j(row, i) * j(row, k)).sum();
            }
            *b_i = -(0..c.len()).map(|row| j(row, i) * r[row]).sum::<f64>();
        }
        for (i, row) in a.iter_mut().enumerate() {
            row[i] += lambda * (1.0 + row[i]);
        }
        let delta = solve(a, b)?;
        let trial: Vec<f64> = x.iter().zip(&delta).map(|(a, d)| a + d).collect();
        let rt = eval(c, &trial);
        if norm2(&rt) < cost {
            x = trial;
            r = rt;
            lambda = (lambda * 0.3).max(1e-12);
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                return None;
            }
        }
    }
    None
}

/// Gaussian elimination with partial pivoting; `None` for a singular matrix.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let piv = (col..n).max_by(|&i, &k| a[i][col].abs().total_cmp(&a[k][col].abs()))?;
        if a[piv][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        let (top, rest) = a.split_at_mut(col + 1);
        let pivot_row = &top[col];
        for (offset, row) in rest.iter_mut().enumerate() {
            let factor = row[col] / pivot_row[col];
            for (x, p) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= factor * p;
            }
            b[col + 1 + offset] -= factor * b[col];
        }
    }
    for col in (0..n).rev() {
        let s: f64 = (col + 1..n).map(|k| a[col][k] * b[k]).sum();
        b[col] = (b[col] - s) / a[col][col];
    }
    Some(b)
}
