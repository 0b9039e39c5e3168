//! The two examples of §4 of Infante's paper, derived from the criterion
//! ([`Criterion`]) by numerical optimisation over its free constants, for comparison with the
//! printed results.
//!
//! **Example 1**, ẍ + pẋ + q(t)x = 0 with p > 0 constant and q₁ ≤ q(t) ≤ q₂: the only usable
//! choice is i = 2, C = diag(c, 0) (β₂₁ = 0 for i = 1; c scales w and drops out), so the free
//! constants are α₁, α₂. For each α the criterion holds on an interval of q (w is a concave
//! quadratic in q, [`Criterion::interval`]); the boundary of the region in the plane
//! z₁ = q₁/p², z₂ = q₂/p² is z₂*(z₁) = max over α of the interval's upper end subject to its
//! lower end ≤ z₁ ([`example1_boundary`]). The paper's (4.9) is
//! z₂ = z₁ + 2√(¼ + z₁ + √z₁), reached at α₁ = p/2, α₂ = p²(¼ + z₁ + √z₁) ((4.7), (4.8)).
//!
//! **Example 2**, x⃛ + pẍ + ẋ + r(t)x = 0 with 0 < ξ ≤ r(t) ≤ r₂ − ξ: i = 3 and
//! C = C₁ + λC₂ of Table I (C₁ = diag(2α₃Δ₂, 0, 0), C₂ = diag(0, 2Δ₂, 0), Δ₂ = α₁α₂ − α₃).
//! For r to approach 0 the criterion must hold at r = 0 in the limit: w(0) ≥ 0. lasalle
//! maximises w(0) over α₂, α₃ for each α₁ (the maximum is 0, where the paper's (4.15) and
//! (4.16) hold), then maximises the upper end of the interval of r over α₁
//! ([`example2_bound`]). The paper's (4.20): r₂ = (p² − p⁴/4)/(λ + p) for p ≤ √2 and
//! 1/(λ + p) for p ≥ √2, the region it says Starzinski found.

use super::criterion::Criterion;

/// The golden ratio's conjugate (√5 − 1)/2.
const GOLDEN: f64 = 0.618_033_988_749_894_9;

/// The argument of the largest f on [a, b] by golden sections (f unimodal there), and f there.
fn golden_max(mut a: f64, mut b: f64, f: &mut dyn FnMut(f64) -> f64) -> (f64, f64) {
    let (mut c, mut d) = (b - GOLDEN * (b - a), a + GOLDEN * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..100 {
        if fc >= fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - GOLDEN * (b - a);
            fc = f(c);
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + GOLDEN * (b - a);
            fd = f(d);
        }
        if b - a <= 1e-15 * (a.abs() + b.abs()) {
            break;
        }
    }
    if fc >= fd {
        (c, fc)
    } else {
        (d, fd)
    }
}

/// The largest f over `grid`, refined by golden sections between the best point's neighbours.
fn scan_max(grid: &[f64], f: &mut dyn FnMut(f64) -> f64) -> Option<(f64, f64)> {
    let values: Vec<f64> = grid.iter().map(|&x| f(x)).collect();
    let k = (0..grid.len())
        .filter(|&k| values[k].is_finite())
        .max_by(|&a, &b| values[a].total_cmp(&values[b]))?;
    let (a, b) = (grid[k.saturating_sub(1)], grid[(k + 1).min(grid.len() - 1)]);
    let (x, v) = golden_max(a, b, f);
    Some(if v >= values[k] {
        (x, v)
    } else {
        (grid[k], values[k])
    })
}

/// One point of Example 1's boundary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Example1Point {
    /// z₁ = q₁/p².
    pub z1: f64,
    /// The largest z₂ = q₂/p² the criterion allows with q ≥ q₁.
    pub z2: f64,
    /// The α₁, α₂ that reach it.
    pub alpha: [f64; 2],
}

/// The criterion's interval of q for Example 1 at α = (α₁, α₂), divided by p².
fn example1_interval(p: f64, a1: f64, a2: f64) -> Option<(f64, f64)> {
    let c = Criterion::new(&[a1, a2], &[1.0, 0.0]).ok()?;
    let (lo, hi) = c.interval(&[p, 0.0], 2)?;
    Some((lo / (p * p), hi / (p * p)))
}

/// The largest upper end over α₂ with the lower end ≤ z₁, for fixed α₁: the best feasible
/// point of a logarithmic grid, then the feasibility boundary by bisection (or golden
/// sections if the best point is inside the feasible set).
fn example1_inner(p: f64, z1: f64, a1: f64) -> Option<(f64, f64)> {
    let feasible = |a2: f64| example1_interval(p, a1, a2).filter(|&(lo, _)| lo <= z1);
    let grid: Vec<f64> = (0..=240)
        .map(|m| p * p * 10f64.powf(-4.0 + 6.0 * m as f64 / 240.0))
        .collect();
    let k = (0..grid.len())
        .filter_map(|k| feasible(grid[k]).map(|(_, hi)| (k, hi)))
        .max_by(|a, b| a.1.total_cmp(&b.1))?
        .0;
    let mut up = |a2: f64| feasible(a2).map_or(f64::NEG_INFINITY, |(_, hi)| hi);
    if k + 1 < grid.len() && feasible(grid[k + 1]).is_none() {
        let (mut a, mut b) = (grid[k], grid[k + 1]);
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if m <= a || m >= b {
                break;
            }
            if feasible(m).is_some() {
                a = m;
            } else {
                b = m;
            }
        }
        return Some((a, up(a)));
    }
    let lo = grid[k.saturating_sub(1)];
    let hi = grid[(k + 1).min(grid.len() - 1)];
    Some(golden_max(lo, hi, &mut up))
}

/// Example 1's boundary at z₁ (see the [module docs](self)), for the damping `p`.
pub fn example1_boundary(p: f64, z1: f64) -> Option<Example1Point> {
    let grid: Vec<f64> = (1..120).map(|m| p * m as f64 / 120.0).collect();
    let mut best = |a1: f64| example1_inner(p, z1, a1).map_or(f64::NEG_INFINITY, |(_, z2)| z2);
    let (a1, z2) = scan_max(&grid, &mut best)?;
    let (a2, _) = example1_inner(p, z1, a1)?;
    Some(Example1Point {
        z1,
        z2,
        alpha: [a1, a2],
    })
}

/// The paper's (4.9): z₂ = z₁ + 2√(¼ + z₁ + √z₁).
pub fn example1_printed(z1: f64) -> f64 {
    z1 + 2.0 * (0.25 + z1 + z1.sqrt()).sqrt()
}

/// Example 2's criterion for α = (α₁, α₂, α₃) and λ: C = C₁ + λC₂.
fn example2_criterion(alpha: [f64; 3], lambda: f64) -> Option<Criterion> {
    let d2 = alpha[0] * alpha[1] - alpha[2];
    Criterion::new(&alpha, &[2.0 * alpha[2] * d2, 2.0 * lambda * d2, 0.0]).ok()
}

/// The largest w(0) over (α₂, α₃) for fixed α₁, by Nelder–Mead from the start `x0`; the
/// maximiser and the maximum.
fn example2_max_w0(p: f64, lambda: f64, a1: f64, x0: [f64; 2]) -> ([f64; 2], f64) {
    let f = |x: [f64; 2]| {
        example2_criterion([a1, x[0], x[1]], lambda).map_or(f64::INFINITY, |c| -c.w(&[p, 1.0, 0.0]))
    };
    let mut s = [x0, [x0[0] * 1.1, x0[1]], [x0[0], x0[1] * 1.1]];
    let mut v = s.map(f);
    for _ in 0..2000 {
        let mut order = [0, 1, 2];
        order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        (s, v) = (order.map(|k| s[k]), order.map(|k| v[k]));
        if (v[2] - v[0]).abs() <= 1e-300
            || (s[2][0] - s[0][0]).abs() + (s[2][1] - s[0][1]).abs() < 1e-16
        {
            break;
        }
        let m = [0.5 * (s[0][0] + s[1][0]), 0.5 * (s[0][1] + s[1][1])];
        let at = |t: f64| [m[0] + t * (s[2][0] - m[0]), m[1] + t * (s[2][1] - m[1])];
        let (r, fr) = (at(-1.0), f(at(-1.0)));
        if fr < v[0] {
            let (e, fe) = (at(-2.0), f(at(-2.0)));
            (s[2], v[2]) = if fe < fr { (e, fe) } else { (r, fr) };
        } else if fr < v[1] {
            (s[2], v[2]) = (r, fr);
        } else {
            let (k, fk) = (at(0.5), f(at(0.5)));
            if fk < v[2] {
                (s[2], v[2]) = (k, fk);
            } else {
                let best = s[0];
                for (sj, vj) in s.iter_mut().zip(v.iter_mut()).skip(1) {
                    *sj = [0.5 * (best[0] + sj[0]), 0.5 * (best[1] + sj[1])];
                    *vj = f(*sj);
                }
            }
        }
    }
    let k = (0..3).min_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap_or(0);
    (s[k], -v[k])
}

/// Example 2's bound for damping `p` and weight `lambda`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Example2Bound {
    /// p.
    pub p: f64,
    /// λ.
    pub lambda: f64,
    /// The largest r₂ with the criterion holding for r ∈ (0, r₂).
    pub r2: f64,
    /// The α's that reach it.
    pub alpha: [f64; 3],
    /// max w(0) at those α's (0 up to rounding).
    pub w0: f64,
    /// The lower end of the criterion's interval of r there (0 up to rounding).
    pub r1: f64,
}

/// The α₂, α₃ maximising w(0) for α₁, and the criterion's interval of r there.
fn example2_at(p: f64, lambda: f64, a1: f64) -> Option<([f64; 3], f64, (f64, f64))> {
    // a start inside the Routh–Hurwitz region
    let a2 = 1.0f64.max(a1 * p);
    let (x, w0) = example2_max_w0(p, lambda, a1, [a2, 0.25 * a1 * a2]);
    let alpha = [a1, x[0], x[1]];
    let interval = example2_criterion(alpha, lambda)?.interval(&[p, 1.0, 0.0], 3)?;
    Some((alpha, w0, interval))
}

/// Example 2's bound (see the [module docs](self)).
pub fn example2_bound(p: f64, lambda: f64) -> Option<Example2Bound> {
    let grid: Vec<f64> = (1..60).map(|m| p * m as f64 / 60.0).collect();
    let mut upper = |a1: f64| {
        example2_at(p, lambda, a1)
            .filter(|(_, _, (lo, _))| *lo <= 1e-7)
            .map_or(f64::NEG_INFINITY, |(_, _, (_, hi))| hi)
    };
    let (a1, r2) = scan_max(&grid, &mut upper)?;
    let (alpha, w0, (r1, _)) = example2_at(p, lambda, a1)?;
    Some(Example2Bound {
        p,
        lambda,
        r2,
        alpha,
        w0,
        r1,
    })
}

/// The paper's (4.20): (p² − p⁴/4)/(λ + p) for p ≤ √2, 1/(λ + p) for p ≥ √2.
pub fn example2_printed(p: f64, lambda: f64) -> f64 {
    if p * p <= 2.0 {
        (p * p - p.powi(4) / 4.0) / (lambda + p)
    } else {
        1.0 / (lambda + p)
    }
}
