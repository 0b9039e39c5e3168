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
    let g = |p3: f64| f.energy(&[q2, 0.0, p2, p3]) - h;
    if g(0.0) > 0.0 {
        return None;
    }
    let steps = 400;
    let mut a = 0.0;
    let mut b = None;
    for k in 1..=steps {
        let x = p_max * k as f64 / steps as f64;
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

/// A Poincaré map at reduced energy `h` (H_cm − E₀, model units): `seeds` starts on each of
/// the axes P₂ = 0 and Q₂ = 0 of the section, across the energetically allowed region, each
/// followed for `crossings` returns (100 Runge–Kutta steps per vertical period). None unless
/// the centre manifold has two degrees of freedom.
pub fn poincare_map(
    cm: &CenterManifold,
    h: f64,
    seeds: usize,
    crossings: usize,
) -> Option<Vec<SectionOrbit>> {
    let f = ReducedField::new(&cm.reduced_poly)?;
    let wp = cm.omega[0].value;
    let wv = cm.omega[1].value;
    // linear extent of the section: ω_p (Q₂² + P₂²)/2 ≤ h
    let r = (2.0 * h / wp).sqrt();
    let p_max = 4.0 * (2.0 * h / wv).sqrt();
    let period = 2.0 * std::f64::consts::PI / wv;
    let dt = period / 100.0;
    let mut out = Vec::new();
    for axis in 0..2 {
        for i in 0..seeds {
            let x = r * (2.0 * (i as f64 + 0.5) / seeds as f64 - 1.0);
            let (q2, p2) = if axis == 0 { (x, 0.0) } else { (0.0, x) };
            if let Some(p3) = solve_p3(&f, q2, p2, h, p_max) {
                out.push(section_orbit(
                    &f,
                    [q2, 0.0, p2, p3],
                    crossings,
                    dt,
                    4.0 * period * crossings as f64,
                ));
            }
        }
    }
    Some(out)
}
