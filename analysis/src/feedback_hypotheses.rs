//! The hypotheses of Chang, Jiménez & Perlmutter, "Feedback Integrators" (J. Nonlinear Sci.
//! 26, 2016), computed for the paper's §4 systems rather than assumed:
//!
//! - **Lemma 2.4**: Df(x) has rank r + ℓ at every x ∈ V⁻¹(0) — [`rank_check`] takes the
//!   model's Jacobians at points of the level set (sampled exactly by [`rigid_body_level_set`],
//!   [`kepler_level_set`], [`central_force_level_set`]) and reports the singular values;
//! - **Lemma 3.3** (c < min{k₀/4, k₁|E₀|/2, k₂|π₀|²/2}) and **Lemma 3.6** (36)
//!   (c < min{k₁|L₀|²/2, k₂(μ − |A₀|)²/2}): [`lemma_3_3_bound`], [`lemma_3_6_bound`];
//! - **Theorem 3.9 / Remark 3.10**: no common root r > 0 of (57) and (58) —
//!   [`theorem_3_9`], from the positive roots of (58) and the residual of (57) there;
//! - **§4.1**: the period T_Ω = 6.4227 of Ω(t) — [`euler_top_period`] in closed form (complete
//!   elliptic integral), [`period_from_crossings`] for a measured one.

use nalgebra::{DMatrix, Matrix3, Rotation3, Unit, Vector3};
use std::f64::consts::PI;

/// Singular values of Df at sampled points of V⁻¹(0), against the rank Lemma 2.4 needs.
#[derive(Clone, Debug, PartialEq)]
pub struct RankCheck {
    /// Rows (stacked invariants) and columns (state dimension) of Df.
    pub shape: (usize, usize),
    /// r + ℓ: the rank the lemma needs.
    pub required: usize,
    /// Points sampled.
    pub samples: usize,
    /// The smallest, over the samples, of the (r + ℓ)-th singular value σ_{r+ℓ}.
    pub smallest_required: f64,
    /// The index of the sample where it is attained.
    pub worst_sample: usize,
    /// The largest σ₁ over the samples.
    pub largest: f64,
    /// The largest σ_{r+ℓ+1} over the samples (0 when Df has only r + ℓ rows and columns).
    pub largest_beyond: f64,
    /// The smallest and largest numerical rank (σ > [`RANK_TOLERANCE`]·σ₁) over the samples.
    pub rank: (usize, usize),
    /// max ‖f(x) − f(x₀)‖∞ over the samples: how exactly they lie on V⁻¹(0).
    pub level_set_residual: f64,
}

/// Relative threshold of the numerical rank: σ counts when above this times σ₁.
pub const RANK_TOLERANCE: f64 = 1e-10;

impl RankCheck {
    /// Whether Df has rank ≥ r + ℓ at every sample.
    pub fn holds(&self) -> bool {
        self.rank.0 >= self.required
    }
}

/// The rank check of Lemma 2.4 from the Jacobians `jacobians` (row i = ∇fᵢ) at points of the
/// level set and each point's ‖f(x) − f(x₀)‖∞ in `residuals`.
///
/// # Panics
/// If `jacobians` is empty or the lengths differ.
pub fn rank_check(jacobians: &[DMatrix<f64>], residuals: &[f64], required: usize) -> RankCheck {
    assert!(!jacobians.is_empty() && jacobians.len() == residuals.len());
    let shape = jacobians[0].shape();
    let mut check = RankCheck {
        shape,
        required,
        samples: jacobians.len(),
        smallest_required: f64::INFINITY,
        worst_sample: 0,
        largest: 0.0,
        largest_beyond: 0.0,
        rank: (usize::MAX, 0),
        level_set_residual: residuals.iter().fold(0.0, |a, &r| a.max(r)),
    };
    for (i, j) in jacobians.iter().enumerate() {
        let mut s: Vec<f64> = j.singular_values().iter().copied().collect();
        s.sort_by(|a, b| b.total_cmp(a));
        let at = |k: usize| s.get(k).copied().unwrap_or(0.0);
        let rank = s.iter().filter(|&&x| x > RANK_TOLERANCE * at(0)).count();
        check.rank = (check.rank.0.min(rank), check.rank.1.max(rank));
        check.largest = check.largest.max(at(0));
        check.largest_beyond = check.largest_beyond.max(at(required));
        let need = if required == 0 {
            f64::INFINITY
        } else {
            at(required - 1)
        };
        if need < check.smallest_required {
            check.smallest_required = need;
            check.worst_sample = i;
        }
    }
    check
}

/// Lemma 3.3's bound on c, min{k₀/4, k₁|E₀|/2, k₂|π₀|²/2}, and the term that attains it
/// (0, 1 or 2).
pub fn lemma_3_3_bound(gains: [f64; 3], e0: f64, pi0: [f64; 3]) -> (f64, usize) {
    let pi2: f64 = pi0.iter().map(|x| x * x).sum();
    smallest([
        gains[0] / 4.0,
        gains[1] * e0.abs() / 2.0,
        gains[2] * pi2 / 2.0,
    ])
}

/// Lemma 3.6's bound (36) on c, min{k₁|L₀|²/2, k₂(μ − |A₀|)²/2}, and the term that attains it
/// (0 or 1); c = 0 (no admissible c) unless |A₀| < μ and L₀ ≠ 0.
pub fn lemma_3_6_bound(gains: [f64; 2], mu: f64, l0: [f64; 3], a0: [f64; 3]) -> (f64, usize) {
    let l2: f64 = l0.iter().map(|x| x * x).sum();
    let a = a0.iter().map(|x| x * x).sum::<f64>().sqrt();
    let (c, which) = smallest([
        gains[0] * l2 / 2.0,
        gains[1] * (mu - a).powi(2) / 2.0,
        f64::MAX,
    ]);
    if a < mu {
        (c, which)
    } else {
        (0.0, 1)
    }
}

fn smallest(v: [f64; 3]) -> (f64, usize) {
    (0..3).fold((f64::INFINITY, 0), |(m, k), i| {
        if v[i] < m {
            (v[i], i)
        } else {
            (m, k)
        }
    })
}

/// The positive real roots of Σ cᵢ rⁱ (`coeffs[i]` the coefficient of rⁱ), increasing: the
/// eigenvalues of the companion matrix, polished by Newton.
pub fn positive_roots(coeffs: &[f64]) -> Vec<f64> {
    let mut c = coeffs.to_vec();
    while c.len() > 1 && c[c.len() - 1] == 0.0 {
        c.pop();
    }
    let n = c.len() - 1;
    if n == 0 {
        return Vec::new();
    }
    let lead = c[n];
    let comp = DMatrix::from_fn(n, n, |i, j| {
        if j == n - 1 {
            -c[i] / lead
        } else if i == j + 1 {
            1.0
        } else {
            0.0
        }
    });
    let p = |r: f64| c.iter().rev().fold(0.0, |a, &x| a * r + x);
    let dp = |r: f64| (1..=n).rev().fold(0.0, |a, i| a * r + i as f64 * c[i]);
    let mut roots: Vec<f64> = comp
        .complex_eigenvalues()
        .iter()
        .filter(|z| z.re > 0.0 && z.im.abs() <= 1e-9 * z.re.abs().max(1e-300))
        .map(|z| {
            let mut r = z.re;
            for _ in 0..8 {
                let d = dp(r);
                if d == 0.0 {
                    break;
                }
                let next = r - p(r) / d;
                if !next.is_finite() || next <= 0.0 {
                    break;
                }
                r = next;
            }
            r
        })
        .collect();
    roots.sort_by(f64::total_cmp);
    roots
}

/// Remark 3.10 for U(r) = −μ/r − δ/r³ (56): the positive roots of (58),
/// |L₀|² = μr + 3δ/r, and at each the relative residual of (57), E₀ = −μ/(2r) + δ/(2r³).
#[derive(Clone, Debug, PartialEq)]
pub struct Theorem39 {
    /// The positive roots of (58), with the relative residual of (57) at each:
    /// |E₀ + μ/(2r) − δ/(2r³)| / (|E₀| + μ/(2r) + δ/(2r³)).
    pub roots_58: Vec<(f64, f64)>,
    /// The positive roots of (57).
    pub roots_57: Vec<f64>,
}

/// Relative residual below which a root of (58) counts as a root of (57) too.
pub const COMMON_ROOT_TOLERANCE: f64 = 1e-10;

impl Theorem39 {
    /// A common root r > 0 of (57) and (58) (Theorem 3.9's hypothesis fails), if any.
    pub fn common_root(&self) -> Option<f64> {
        self.roots_58
            .iter()
            .find(|(_, res)| *res < COMMON_ROOT_TOLERANCE)
            .map(|&(r, _)| r)
    }
    /// The smallest relative residual of (57) at a root of (58) (∞ when (58) has none).
    pub fn margin(&self) -> f64 {
        self.roots_58
            .iter()
            .fold(f64::INFINITY, |a, &(_, r)| a.min(r))
    }
}

/// Theorem 3.9's condition for U(r) = −μ/r − δ/r³ at energy `e0` and |L₀|² = `l0_sq`.
pub fn theorem_3_9(mu: f64, delta: f64, e0: f64, l0_sq: f64) -> Theorem39 {
    // (58)·r: μr² − |L₀|²r + 3δ = 0;  (57)·2r³: 2E₀r³ + μr² − δ = 0
    let roots_58 = positive_roots(&[3.0 * delta, -l0_sq, mu])
        .into_iter()
        .map(|r| {
            let terms = [e0, mu / (2.0 * r), -delta / (2.0 * r.powi(3))];
            let scale: f64 = terms.iter().map(|t| t.abs()).sum();
            (r, terms.iter().sum::<f64>().abs() / scale)
        })
        .collect();
    Theorem39 {
        roots_58,
        roots_57: positive_roots(&[-delta, 0.0, mu, 2.0 * e0]),
    }
}

/// The radii r > 0 where an orbit of U(r) = −μ/r − δ/r³ at energy `e0` and |L₀|² = `l0_sq`
/// turns: the positive roots of 2E₀r³ + 2μr² − |L₀|²r + 2δ = 0 (the radial kinetic energy
/// r³v_r² vanishes), increasing. Between consecutive roots v_r² has one sign; it is positive
/// below the first root (orbits that fall into the centre when δ > 0).
pub fn turning_radii(mu: f64, delta: f64, e0: f64, l0_sq: f64) -> Vec<f64> {
    positive_roots(&[2.0 * delta, -l0_sq, 2.0 * mu, 2.0 * e0])
}

/// The period of Ω(t) of the free rigid body with principal moments `inertia` (distinct),
/// energy E = ½Ω·𝕀Ω and |π|² = |𝕀Ω|²: 4K(m)/λ (Landau & Lifshitz, Mechanics §37), K the
/// complete elliptic integral of the first kind. `None` on the separatrix (|π|² = 2E·I_mid)
/// or outside the admissible region.
pub fn euler_top_period(inertia: [f64; 3], e: f64, pi_sq: f64) -> Option<f64> {
    let mut i = inertia;
    i.sort_by(f64::total_cmp);
    let [i1, i2, i3] = i;
    let (m2, two_e) = (pi_sq, 2.0 * e);
    let (lambda_sq, m) = if m2 > two_e * i2 {
        (
            (i3 - i2) * (m2 - two_e * i1) / (i1 * i2 * i3),
            (i2 - i1) * (two_e * i3 - m2) / ((i3 - i2) * (m2 - two_e * i1)),
        )
    } else if m2 < two_e * i2 {
        (
            (i2 - i1) * (two_e * i3 - m2) / (i1 * i2 * i3),
            (i3 - i2) * (m2 - two_e * i1) / ((i2 - i1) * (two_e * i3 - m2)),
        )
    } else {
        return None;
    };
    if !(lambda_sq > 0.0 && (0.0..1.0).contains(&m)) {
        return None;
    }
    Some(4.0 * lasalle_elliptic::ellipk(m) / lambda_sq.sqrt())
}

/// The mean spacing of the upward zero crossings of the samples `y` at times `t` (linear
/// interpolation between samples) and the number of periods averaged; `None` with fewer than
/// two crossings.
pub fn period_from_crossings(t: &[f64], y: &[f64]) -> Option<(f64, usize)> {
    let crossings: Vec<f64> = (1..t.len().min(y.len()))
        .filter(|&k| y[k - 1] < 0.0 && y[k] >= 0.0)
        .map(|k| t[k - 1] + (t[k] - t[k - 1]) * y[k - 1] / (y[k - 1] - y[k]))
        .collect();
    let n = crossings.len().checked_sub(1).filter(|&n| n > 0)?;
    Some(((crossings[n] - crossings[0]) / n as f64, n))
}

/// Points (R, Ω) of the rigid body's V⁻¹(0) = {R ∈ SO(3), E(Ω) = E₀, R𝕀Ω = π₀} for
/// 𝕀 = diag(`inertia`) (distinct moments), as flat states (R column-major, then Ω): Ω on the
/// polhodes E(Ω) = E₀, |𝕀Ω| = |π₀| (parametrised by Ω² about the middle axis, `n_curve`
/// values, every sign), R the rotation taking 𝕀Ω to π₀ followed by `n_angle` rotations about
/// π₀.
pub fn rigid_body_level_set(
    inertia: [f64; 3],
    e0: f64,
    pi0: [f64; 3],
    n_curve: usize,
    n_angle: usize,
) -> Vec<[f64; 12]> {
    let mut order = [0, 1, 2];
    order.sort_by(|&a, &b| inertia[a].total_cmp(&inertia[b]));
    let (a, b, c) = (order[0], order[1], order[2]);
    let (ia, ib, ic) = (inertia[a], inertia[b], inertia[c]);
    let pi0v = Vector3::from(pi0);
    let m2 = pi0v.norm_squared();
    // Ia xa + Ic xc = 2E − Ib s, Ia² xa + Ic² xc = M² − Ib² s (x = Ω² about each axis)
    let det = ia * ic * (ic - ia);
    let solve = |s: f64| {
        let (r1, r2) = (2.0 * e0 - ib * s, m2 - ib * ib * s);
        (
            (r1 * ic * ic - r2 * ic) / det,
            (r2 * ia - r1 * ia * ia) / det,
        )
    };
    // both squares are linear in s: the admissible s form an interval from 0
    let (xa0, xc0) = solve(0.0);
    let (xa1, xc1) = solve(1.0);
    let mut s_hi = f64::INFINITY;
    for (x0, x1) in [(xa0, xa1), (xc0, xc1)] {
        let slope = x1 - x0;
        if slope < 0.0 {
            s_hi = s_hi.min(-x0 / slope);
        }
    }
    if !(s_hi.is_finite() && s_hi > 0.0 && xa0 >= 0.0 && xc0 >= 0.0) {
        return Vec::new();
    }
    let axis = Unit::new_normalize(pi0v);
    let mut out = Vec::new();
    for k in 0..n_curve {
        let s = s_hi * (k as f64 + 0.5) / n_curve as f64;
        let (xa, xc) = solve(s);
        for signs in 0..8u32 {
            let sg = |bit: u32| if signs & (1 << bit) == 0 { 1.0 } else { -1.0 };
            let mut w = [0.0; 3];
            w[a] = sg(0) * xa.max(0.0).sqrt();
            w[b] = sg(1) * s.sqrt();
            w[c] = sg(2) * xc.max(0.0).sqrt();
            let iw = Vector3::new(inertia[0] * w[0], inertia[1] * w[1], inertia[2] * w[2]);
            let base = Rotation3::rotation_between(&iw, &pi0v).unwrap_or_else(|| {
                let perp = iw.cross(&Vector3::x()).try_normalize(1e-3);
                let perp = perp.unwrap_or_else(|| iw.cross(&Vector3::y()).normalize());
                Rotation3::from_axis_angle(&Unit::new_normalize(perp), PI)
            });
            for j in 0..n_angle {
                let psi = 2.0 * PI * j as f64 / n_angle as f64;
                let r: Matrix3<f64> = (Rotation3::from_axis_angle(&axis, psi) * base).into();
                let mut x = [0.0; 12];
                x[..9].copy_from_slice(r.as_slice());
                x[9..].copy_from_slice(&w);
                out.push(x);
            }
        }
    }
    out
}

/// Points (x, v) of the Kepler orbit with angular momentum `l0` and Laplace–Runge–Lenz vector
/// `a0` (|A₀| < μ, L₀ ≠ 0): V⁻¹(0) of (35), at `n` true anomalies.
pub fn kepler_level_set(mu: f64, l0: [f64; 3], a0: [f64; 3], n: usize) -> Vec<[f64; 6]> {
    let l = Vector3::from(l0);
    let a = Vector3::from(a0);
    let h = l.normalize();
    let e = a.norm() / mu;
    let ex = if a.norm() > 0.0 {
        a / a.norm()
    } else {
        h.cross(&Vector3::x())
            .try_normalize(1e-3)
            .unwrap_or_else(|| h.cross(&Vector3::y()).normalize())
    };
    let ey = h.cross(&ex);
    let p = l.norm_squared() / mu;
    (0..n)
        .map(|k| {
            let f = 2.0 * PI * k as f64 / n as f64;
            let r = p / (1.0 + e * f.cos());
            let x = r * (f.cos() * ex + f.sin() * ey);
            let v = mu / l.norm() * (-f.sin() * ex + (e + f.cos()) * ey);
            [x[0], x[1], x[2], v[0], v[1], v[2]]
        })
        .collect()
}

/// Points (x, v) of {E = E₀, x × v = L₀} for U(r) = −μ/r − δ/r³ with r in [`r_lo`, `r_hi`]
/// (a component of the level set between turning radii): `n_r` radii, `n_angle` directions in
/// the plane ⊥ L₀, both signs of the radial velocity.
#[allow(clippy::too_many_arguments)]
pub fn central_force_level_set(
    mu: f64,
    delta: f64,
    e0: f64,
    l0: [f64; 3],
    (r_lo, r_hi): (f64, f64),
    n_r: usize,
    n_angle: usize,
) -> Vec<[f64; 6]> {
    let l = Vector3::from(l0);
    let h = l.normalize();
    let e1 = h
        .cross(&Vector3::z())
        .try_normalize(1e-3)
        .unwrap_or_else(|| h.cross(&Vector3::x()).normalize());
    let e2 = h.cross(&e1);
    let mut out = Vec::new();
    for i in 0..n_r {
        let r = r_lo + (r_hi - r_lo) * (i as f64 + 0.5) / n_r as f64;
        let u = -mu / r - delta / r.powi(3);
        let vr2 = 2.0 * (e0 - u) - l.norm_squared() / (r * r);
        let vr = vr2.max(0.0).sqrt();
        for j in 0..n_angle {
            let th = 2.0 * PI * j as f64 / n_angle as f64;
            let xh = th.cos() * e1 + th.sin() * e2;
            for sign in [1.0, -1.0] {
                let x = r * xh;
                let v = sign * vr * xh + l.norm() / r * h.cross(&xh);
                out.push([x[0], x[1], x[2], v[0], v[1], v[2]]);
            }
        }
    }
    out
}
