//! Poincaré sections of the reduced Hamiltonian on a two-degree-of-freedom centre manifold
//! (the spatial three-body problem at a collinear point): the section `Q₃ = 0`, `Q̇₃ > 0`
//! (the vertical pair), plotted in `(Q₂, P₂)` (the planar pair), as in Jorba & Masdemont
//! (1999). The planar Lyapunov orbit is the boundary of the section, the vertical Lyapunov
//! orbit a fixed point at its centre, the halo orbits the two fixed points born from it,
//! and the quasi-halo tori the curves around them.
//!
//! The flow is integrated by classical Runge–Kutta 4 at a fixed step (the reduced field is a
//! polynomial, smooth and cheap), and each crossing is located by Newton's method in time
//! on the Runge–Kutta step from the last point before it.
//!
//! The landmarks are computed, not guessed: the boundary is the planar Lyapunov orbit
//! ([`planar_orbit`], the invariant plane Q₃ = P₃ = 0); the vertical and halo orbits are
//! fixed points of the section map ([`section_map`], [`fixed_point`]); and the halo
//! bifurcation is the energy at which the planar orbit's vertical monodromy trace passes 2
//! ([`halo_bifurcation`]), where the two halo fixed points leave the boundary.

use super::CenterManifold;
use crate::poly::Poly;

/// The reduced field of a 2-DOF polynomial Hamiltonian in (q₁, q₂, p₁, p₂), from flat term
/// lists of its gradient.
pub struct ReducedField {
    /// For each of the 4 partial derivatives: (coefficient, exponents).
    grad: Vec<Vec<(f64, [u8; 4])>>,
    /// Highest exponent + 1.
    top: usize,
    /// H as (coefficient, exponents).
    h: Vec<(f64, [u8; 4])>,
}

impl ReducedField {
    /// The field of the polynomial `h` in four variables (None otherwise).
    pub fn new(h: &Poly<f64>) -> Option<ReducedField> {
        if h.nvars() != 4 {
            return None;
        }
        let mut terms = Vec::new();
        for (k, i, c) in h.terms() {
            let e = h.exponents(k, i);
            terms.push((c, [e[0], e[1], e[2], e[3]]));
        }
        let grad = (0..4)
            .map(|v| {
                terms
                    .iter()
                    .filter(|(_, e)| e[v] > 0)
                    .map(|&(c, e)| {
                        let mut e2 = e;
                        e2[v] -= 1;
                        (c * e[v] as f64, e2)
                    })
                    .collect()
            })
            .collect();
        Some(ReducedField {
            grad,
            top: h.max_degree() + 1,
            h: terms,
        })
    }

    fn powers(&self, w: &[f64; 4]) -> Vec<[f64; 4]> {
        let mut p = vec![[1.0; 4]; self.top];
        for k in 1..self.top {
            for v in 0..4 {
                p[k][v] = p[k - 1][v] * w[v];
            }
        }
        p
    }

    fn sum(terms: &[(f64, [u8; 4])], p: &[[f64; 4]]) -> f64 {
        terms
            .iter()
            .map(|(c, e)| {
                c * p[e[0] as usize][0]
                    * p[e[1] as usize][1]
                    * p[e[2] as usize][2]
                    * p[e[3] as usize][3]
            })
            .sum()
    }

    /// H(w).
    pub fn energy(&self, w: &[f64; 4]) -> f64 {
        Self::sum(&self.h, &self.powers(w))
    }

    /// ẇ = J∇H(w).
    pub fn field(&self, w: &[f64; 4]) -> [f64; 4] {
        let p = self.powers(w);
        let g: Vec<f64> = self.grad.iter().map(|t| Self::sum(t, &p)).collect();
        [g[2], g[3], -g[0], -g[1]]
    }

    /// One Runge–Kutta 4 step.
    pub fn rk4(&self, w: &[f64; 4], h: f64) -> [f64; 4] {
        let add = |a: &[f64; 4], b: &[f64; 4], s: f64| {
            [
                a[0] + s * b[0],
                a[1] + s * b[1],
                a[2] + s * b[2],
                a[3] + s * b[3],
            ]
        };
        let k1 = self.field(w);
        let k2 = self.field(&add(w, &k1, h / 2.0));
        let k3 = self.field(&add(w, &k2, h / 2.0));
        let k4 = self.field(&add(w, &k3, h));
        let mut out = *w;
        for v in 0..4 {
            out[v] += h / 6.0 * (k1[v] + 2.0 * k2[v] + 2.0 * k3[v] + k4[v]);
        }
        out
    }
}

/// One orbit's section points.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SectionOrbit {
    /// The starting point (Q₂, Q₃, P₂, P₃) on the section.
    pub start: [f64; 4],
    /// (Q₂, P₂) at each crossing.
    pub points: Vec<[f64; 2]>,
    /// max |H − h| over the crossings (the integration's energy error).
    pub energy_error: f64,
}

/// The smallest P₃ > 0 with H(q₂, 0, p₂, P₃) = h, if any below `p_max`: a scan from 0 in
/// steps of p_max/400 to the first sign change, then bisection (far out the truncated series
/// turns over, so the first root is the one on the manifold's energy level).
pub fn solve_p3(f: &ReducedField, q2: f64, p2: f64, h: f64, p_max: f64) -> Option<f64> {
    first_root(&|p3| f.energy(&[q2, 0.0, p2, p3]) - h, p_max, 400)
}

/// Integrates from `start` (on the section, Q₃ = 0) for `crossings` returns to Q₃ = 0 with
/// Q̇₃ > 0, at step `dt`, stopping early after `t_max`.
pub fn section_orbit(
    f: &ReducedField,
    start: [f64; 4],
    crossings: usize,
    dt: f64,
    t_max: f64,
) -> SectionOrbit {
    let h0 = f.energy(&start);
    let mut w = start;
    let mut t = 0.0;
    let mut points = Vec::with_capacity(crossings);
    let mut energy_error: f64 = 0.0;
    while points.len() < crossings && t < t_max {
        let next = f.rk4(&w, dt);
        if w[1] < 0.0 && next[1] >= 0.0 {
            // Newton in τ on Q₃(RK4 step of length τ from w) = 0
            let mut tau = dt * (-w[1]) / (next[1] - w[1]);
            for _ in 0..8 {
                let x = f.rk4(&w, tau);
                let dq3 = f.field(&x)[1];
                if dq3 == 0.0 {
                    break;
                }
                let step = x[1] / dq3;
                tau -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            let x = f.rk4(&w, tau);
            energy_error = energy_error.max((f.energy(&x) - h0).abs());
            points.push([x[0], x[2]]);
        }
        w = next;
        t += dt;
    }
    SectionOrbit {
        start,
        points,
        energy_error,
    }
}

/// Integrates from `w0` by Runge–Kutta 4 at step `dt` until coordinate `coord` crosses zero
/// (upward if `upward`, else downward; a start exactly on zero does not count), for at most
/// `t_max`; the crossing is located by Newton's method in time on the last step. Returns the
/// state there and the time.
pub fn crossing(
    f: &ReducedField,
    w0: [f64; 4],
    coord: usize,
    upward: bool,
    dt: f64,
    t_max: f64,
) -> Option<([f64; 4], f64)> {
    let s = if upward { 1.0 } else { -1.0 };
    let mut w = w0;
    let mut t = 0.0;
    while t < t_max {
        let next = f.rk4(&w, dt);
        if s * w[coord] < 0.0 && s * next[coord] >= 0.0 {
            let mut tau = dt * (-w[coord]) / (next[coord] - w[coord]);
            for _ in 0..8 {
                let x = f.rk4(&w, tau);
                let d = f.field(&x)[coord];
                if d == 0.0 {
                    break;
                }
                let step = x[coord] / d;
                tau -= step;
                if step.abs() < 1e-16 * dt.max(1.0) {
                    break;
                }
            }
            return Some((f.rk4(&w, tau), t + tau));
        }
        if !next.iter().all(|x| x.is_finite()) {
            return None;
        }
        w = next;
        t += dt;
    }
    None
}

/// Integrates from `w0` for exactly `t` in `steps` Runge–Kutta 4 steps.
pub fn flow(f: &ReducedField, w0: [f64; 4], t: f64, steps: usize) -> [f64; 4] {
    let dt = t / steps as f64;
    (0..steps).fold(w0, |w, _| f.rk4(&w, dt))
}

/// The first root of `g` on (0, x_max]: a scan in `steps` steps to the first sign change
/// from g(0) < 0, then bisection. None if g(0) > 0 or no sign change.
fn first_root(g: &dyn Fn(f64) -> f64, x_max: f64, steps: usize) -> Option<f64> {
    if g(0.0) > 0.0 {
        return None;
    }
    let mut a = 0.0;
    let mut b = None;
    for k in 1..=steps {
        let x = x_max * k as f64 / steps as f64;
        if g(x) >= 0.0 {
            b = Some(x);
            break;
        }
        a = x;
    }
    let mut b = b?;
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if g(m) > 0.0 {
            b = m;
        } else {
            a = m;
        }
    }
    Some(0.5 * (a + b))
}

/// The Poincaré map of the section `Q₃ = 0`, `Q̇₃ > 0` at reduced energy `h`: the point
/// (Q₂, P₂) of the section is lifted to the energy level (P₃ > 0 from [`solve_p3`]) and
/// followed to its next crossing. None where the lift or the return fails.
pub fn section_map(f: &ReducedField, h: f64, x: [f64; 2], dt: f64, p_max: f64) -> Option<[f64; 2]> {
    let p3 = solve_p3(f, x[0], x[1], h, p_max)?;
    let (w, _) = crossing(f, [x[0], 0.0, x[1], p3], 1, true, dt, 400.0 * dt)?;
    Some([w[0], w[2]])
}

/// The planar Lyapunov orbit at reduced energy `h` (the boundary of the section) and its
/// vertical stability.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PlanarOrbit {
    /// Reduced energy H_cm − E₀.
    pub h: f64,
    /// Its start (Q₂ > 0, P₂ = 0).
    pub q2: f64,
    /// Its period.
    pub period: f64,
    /// The trace of its monodromy matrix in the vertical pair (Q₃, P₃): 2 cos(2π ω_v/ω_p)
    /// at small amplitude, 2 at the halo bifurcation.
    pub vertical_trace: f64,
    /// Points (Q₂, P₂) along it (the boundary curve of the section).
    pub curve: Vec<[f64; 2]>,
}

/// The planar Lyapunov orbit (Q₃ = P₃ = 0, invariant) at reduced energy `h`, found from the
/// first root Q₂ > 0 of H(Q₂, 0, 0, 0) = h, integrated over one period (`steps` Runge–Kutta
/// steps), with its vertical monodromy by central differences in (Q₃, P₃) (the reduced
/// Hamiltonian is even in them, so the vertical block is decoupled at first order). None if
/// the energy level does not cross the Q₂ axis within the search range `q_max`.
pub fn planar_orbit(f: &ReducedField, h: f64, q_max: f64, steps: usize) -> Option<PlanarOrbit> {
    let q2 = first_root(&|q| f.energy(&[q, 0.0, 0.0, 0.0]) - h, q_max, 400)?;
    let start = [q2, 0.0, 0.0, 0.0];
    // the linear period bounds the step of the search for the return
    let g = f.field(&start);
    let omega = (-g[2] / q2).abs().max(1e-3);
    let guess = 2.0 * std::f64::consts::PI / omega;
    let dt = guess / steps as f64;
    // Ṗ₂ < 0 at Q₂ > 0: the orbit first leaves downward and returns downward after a period
    let (_, period) = crossing(f, start, 2, false, dt, 4.0 * guess)?;
    let n = steps.max(8);
    let h_step = period / n as f64;
    let mut curve = Vec::with_capacity(n + 1);
    let mut w = start;
    curve.push([w[0], w[2]]);
    for _ in 0..n {
        w = f.rk4(&w, h_step);
        curve.push([w[0], w[2]]);
    }
    let eps = 1e-5 * q2.max(1e-3);
    let column = |k: usize| {
        let mut a = start;
        let mut b = start;
        a[k] += eps;
        b[k] -= eps;
        let fa = flow(f, a, period, n);
        let fb = flow(f, b, period, n);
        [(fa[1] - fb[1]) / (2.0 * eps), (fa[3] - fb[3]) / (2.0 * eps)]
    };
    let c1 = column(1);
    let c3 = column(3);
    Some(PlanarOrbit {
        h,
        q2,
        period,
        vertical_trace: c1[0] + c3[1],
        curve,
    })
}

/// The halo bifurcation of the reduced flow: the reduced energy at which the vertical trace of
/// the planar Lyapunov orbit crosses 2 (bisection between `h_lo`, where it is below 2, and
/// `h_hi`, where it is above), to relative tolerance `rtol`. None if there is no sign change.
pub fn halo_bifurcation(
    f: &ReducedField,
    h_lo: f64,
    h_hi: f64,
    q_max: f64,
    rtol: f64,
) -> Option<f64> {
    let g = |h: f64| planar_orbit(f, h, q_max, 400).map(|o| o.vertical_trace - 2.0);
    let (mut a, mut b) = (h_lo, h_hi);
    let (ga, gb) = (g(a)?, g(b)?);
    if ga.signum() == gb.signum() {
        return None;
    }
    while (b - a) > rtol * b.abs() {
        let m = 0.5 * (a + b);
        let gm = g(m)?;
        if gm.signum() == ga.signum() {
            a = m;
        } else {
            b = m;
        }
    }
    Some(0.5 * (a + b))
}

/// A fixed point of the section map found by Newton's method.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FixedPoint {
    /// (Q₂, P₂).
    pub point: [f64; 2],
    /// |P(x) − x| at the end.
    pub residual: f64,
    /// The trace of the map's Jacobian there (|tr| < 2: elliptic, surrounded by tori).
    pub trace: f64,
}

/// Newton's method on P(x) − x from `seed` (Jacobian by central differences of step `eps`),
/// at most 30 iterations, accepted when |P(x) − x| < `tol`.
pub fn fixed_point(
    f: &ReducedField,
    h: f64,
    seed: [f64; 2],
    dt: f64,
    p_max: f64,
    eps: f64,
    tol: f64,
) -> Option<FixedPoint> {
    let map = |x: [f64; 2]| section_map(f, h, x, dt, p_max);
    let mut x = seed;
    for _ in 0..30 {
        let px = map(x)?;
        let r = [px[0] - x[0], px[1] - x[1]];
        let mut j = [[0.0; 2]; 2];
        for k in 0..2 {
            let mut a = x;
            let mut b = x;
            a[k] += eps;
            b[k] -= eps;
            let (pa, pb) = (map(a)?, map(b)?);
            for i in 0..2 {
                j[i][k] = (pa[i] - pb[i]) / (2.0 * eps);
            }
        }
        let trace = j[0][0] + j[1][1];
        let residual = r[0].hypot(r[1]);
        if residual < tol {
            return Some(FixedPoint {
                point: x,
                residual,
                trace,
            });
        }
        // (J − I) δ = −r
        let a = [[j[0][0] - 1.0, j[0][1]], [j[1][0], j[1][1] - 1.0]];
        let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let d0 = (-r[0] * a[1][1] + r[1] * a[0][1]) / det;
        let d1 = (-a[0][0] * r[1] + a[1][0] * r[0]) / det;
        x = [x[0] + d0, x[1] + d1];
    }
    None
}

/// A Poincaré section of the reduced flow at one energy, with its landmarks.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Section {
    /// Reduced energy H_cm − E₀ (model units).
    pub h: f64,
    /// The planar Lyapunov orbit: the boundary of the section.
    pub boundary: PlanarOrbit,
    /// The vertical Lyapunov orbit: the fixed point inside, if Newton's method found it.
    pub vertical: Option<FixedPoint>,
    /// The halo orbits: the other fixed points found (none below the bifurcation energy).
    pub halos: Vec<FixedPoint>,
    /// The orbits followed.
    pub orbits: Vec<SectionOrbit>,
    /// Seeds inside the boundary that could not be lifted to the energy level (H increasing
    /// in P₃ up to h fails there: the truncated series is used outside its domain).
    pub unlifted: usize,
}

/// A Poincaré map at reduced energy `h` (H_cm − E₀, model units): the planar Lyapunov orbit
/// bounding the section ([`planar_orbit`]); the vertical Lyapunov orbit (Newton's method from
/// the centre) and the halo orbits (Newton's method from points on the lines P₂ = 0 and
/// P₂ = P₂(vertical) at 60…99.5 % of the way to the boundary); and orbits seeded on that line from boundary to
/// boundary (`seeds` of them), on the perpendicular line (`seeds`/2), and between each halo
/// point and the vertical one (8 each, for the quasi-halo tori: at 0.5, 1, 2, 4, 10, 25, 45
/// and 70 % of the way, so that the thin islands just above the bifurcation get some), each
/// followed for
/// `crossings` returns (Runge–Kutta 4 at 100 steps per vertical period). An error if the
/// centre manifold has not two degrees of freedom, or if the energy level of the truncated
/// series does not close around the origin (the energy is outside its domain).
pub fn poincare_map(
    cm: &CenterManifold,
    h: f64,
    seeds: usize,
    crossings: usize,
) -> Result<Section, String> {
    let f = ReducedField::new(&cm.reduced_poly).ok_or_else(|| {
        format!(
            "the section Q3 = 0 needs a two-degree-of-freedom centre manifold (a spatial model); this one has {}",
            cm.n_dof - 1
        )
    })?;
    let wp = cm.omega[0].value;
    let wv = cm.omega[1].value;
    // linear extent of the section: ω_p (Q₂² + P₂²)/2 ≤ h
    let r = (2.0 * h / wp).sqrt();
    let p_max = 4.0 * (2.0 * h / wv).sqrt();
    let period = 2.0 * std::f64::consts::PI / wv;
    let dt = period / 100.0;
    let boundary = planar_orbit(&f, h, 3.0 * r, 400).ok_or_else(|| {
        format!(
            "at h = {h:e} the truncated reduced Hamiltonian does not reach h along Q2 > 0 within 3 linear radii, or its level curve does not close: the energy is outside the series' domain"
        )
    })?;
    let q_right = boundary.curve.iter().map(|p| p[0]).fold(f64::MIN, f64::max);
    let q_left = boundary.curve.iter().map(|p| p[0]).fold(f64::MAX, f64::min);
    let p_top = boundary.curve.iter().map(|p| p[1]).fold(f64::MIN, f64::max);
    let p_bottom = boundary.curve.iter().map(|p| p[1]).fold(f64::MAX, f64::min);
    let scale = q_right - q_left;
    let fine = period / 200.0;
    let newton = |x: [f64; 2]| fixed_point(&f, h, x, fine, p_max, 1e-7 * scale, 1e-11 * scale);
    let vertical = newton([0.0, 0.0]);
    let c = vertical.as_ref().map_or([0.0, 0.0], |v| v.point);
    let mut halos: Vec<FixedPoint> = Vec::new();
    for (edge, p2) in [
        (q_right, 0.0),
        (q_left, 0.0),
        (q_right, c[1]),
        (q_left, c[1]),
    ] {
        for s in [0.6, 0.75, 0.85, 0.92, 0.97, 0.985, 0.995] {
            let x = [c[0] + s * (edge - c[0]), p2];
            if let Some(fp) = newton(x) {
                let d = |p: &[f64; 2], q: &[f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
                if d(&fp.point, &c) > 0.05 * scale
                    && !halos.iter().any(|o| d(&o.point, &fp.point) < 1e-6 * scale)
                {
                    halos.push(fp);
                }
            }
        }
    }
    let mut starts: Vec<[f64; 2]> = Vec::new();
    for i in 0..seeds {
        let s = (i as f64 + 0.5) / seeds as f64;
        starts.push([q_left + s * (q_right - q_left), c[1]]);
    }
    let half = (seeds / 2).max(1);
    for i in 0..half {
        let s = (i as f64 + 0.5) / half as f64;
        starts.push([c[0], p_bottom + s * (p_top - p_bottom)]);
    }
    // the quasi-halo seeds: geometric near the halo point (just above the bifurcation its
    // island is a few per cent of the way to the vertical point wide), then across
    for halo in &halos {
        for s in [0.005, 0.01, 0.02, 0.04, 0.1, 0.25, 0.45, 0.7] {
            starts.push([
                halo.point[0] + s * (c[0] - halo.point[0]),
                halo.point[1] + s * (c[1] - halo.point[1]),
            ]);
        }
    }
    let mut orbits = Vec::new();
    let mut unlifted = 0;
    for x in starts {
        match solve_p3(&f, x[0], x[1], h, p_max) {
            Some(p3) => orbits.push(section_orbit(
                &f,
                [x[0], 0.0, x[1], p3],
                crossings,
                dt,
                4.0 * period * crossings as f64,
            )),
            None => {
                if f.energy(&[x[0], 0.0, x[1], 0.0]) <= h {
                    unlifted += 1;
                }
            }
        }
    }
    Ok(Section {
        h,
        boundary,
        vertical,
        halos,
        orbits,
        unlifted,
    })
}
