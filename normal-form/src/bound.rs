//! Finite-time stability from the normal form: a lower bound on the time an orbit needs to
//! leave a tube about an elliptic equilibrium (NASA TM X-53478, 1966, first paper: "which tube
//! of initial conditions keeps solutions inside a prescribed tube over a prescribed time").
//!
//! ## The estimate
//!
//! Let `z = (Q', P') ∈ ℝ²ⁿ` be the normal coordinates of order N ([`NormalForm::to_normal`])
//! and `ρ = |z|`, so `ρ² = Σ_k (Q'_k² + P'_k²) = 2 Σ_k I_k`. In these coordinates the
//! Hamiltonian is `H ∘ φ = Z(I) + R`, with Z the normal form (a function of the actions) and R
//! everything else: the non-action terms of degrees N+1…M, plus the resonant ones of degree
//! ≤ N in resonant mode ([`Remainder`], computed with
//! [`Options::remainder_degree`](crate::Options::remainder_degree)).
//!
//! **Only R moves ρ.** Along `ż = J∇H`, `d(ρ²/2)/dt = z·J∇Z + z·J∇R`. Z depends on z through
//! the actions, `∇Z = Σ_k ∂Z/∂I_k ∇I_k`, and `∇I_k = (Q'_k, P'_k)` in the plane k, so
//! `z·J∇I_k = Q'_k P'_k − P'_k Q'_k = 0` whatever the signs σ_k of the frequencies (at L4
//! σ = (+1, −1): Z is not a definite function, the energy does not confine the orbit, and
//! this is the only mechanism that does). Hence `dρ/dt = z·J∇R/ρ`, and
//!
//! * (gradient form, the seed's) `|dρ/dt| ≤ |J∇R| = |∇R|`;
//! * (radial form, sharper) in the complex coordinates `x_k = (Q'_k − iP'_k)/√2`,
//!   `y_k = (P'_k − iQ'_k)/√2` (`{x_k, y_k} = 1`, `I_k = i x_k y_k`), `{I_k, xᵃyᵇ} =
//!   i(b_k − a_k) xᵃyᵇ`, so `d(ρ²)/dt = 2 Σ_k {I_k, R} = 2i Σ_{ab} (|b|₁ − |a|₁) c_ab xᵃyᵇ`.
//!
//! **Norms.** On real points `|x_k| = |y_k| = √I_k ≤ ρ/√2`. For `R_s = Σ c_ab xᵃyᵇ`
//! (|a|₁ + |b|₁ = s) let `‖R_s‖ = 2^{−(s−1)/2} Σ |c_ab|`. Then `|∇R_s(z)| ≤ s ‖R_s‖ ρ^{s−1}`:
//! the Euclidean gradient in (Q', P') satisfies `|∇R|² = Σ_k |∂R/∂x_k|² + |∂R/∂y_k|²` (from
//! `∂_Q = (∂_x − i∂_y)/√2`, `∂_P = (−i∂_x + ∂_y)/√2`, the cross terms cancel), so
//! `|∇R| ≤ Σ_k |∂R/∂x_k| + |∂R/∂y_k|` (ℓ² ≤ ℓ¹), and for one monomial
//! `Σ_k (a_k + b_k)|xᵃyᵇ|/|x_k| ≤ s (ρ/√2)^{s−1}` since every factor is at most ρ/√2. Summing
//! over the monomials (triangle inequality):
//!
//! `dρ/dt ≤ F(ρ) = Σ_s s ‖R_s‖ ρ^{s−1}` ([`Norm::Gradient`]).
//!
//! The radial form gives, by the same factor bound, `|d(ρ²)/dt| ≤ 2 Σ ||b|−|a|| |c_ab| (ρ/√2)^s`,
//! i.e. `dρ/dt ≤ F_r(ρ) = Σ_s 2^{−s/2} Σ ||a|₁ − |b|₁| |c_ab| ρ^{s−1}` ([`Norm::Radial`]); it
//! is at least √2 smaller than F term by term (`||a| − |b|| ≤ s`) and drops the terms that
//! only exchange action between the modes (`|a|₁ = |b|₁`).
//!
//! **Time.** F has nonnegative coefficients, so it is positive and increasing for ρ > 0, and
//! by comparison an orbit with ρ(0) ≤ ρ₀ cannot reach ρ₁ > ρ₀ before
//! `T(ρ₀, ρ₁) = ∫_{ρ₀}^{ρ₁} dρ / F(ρ)`. 1/F is decreasing, so on any partition the right
//! Riemann sum is below the integral and the left one above it: [`Bound::time`] returns both
//! (4096 geometric intervals; the gap is printed), and the lower one is the bound. For F ~ cρᴺ
//! (the lowest remainder degree is N+1), `T ≈ ρ₀^{1−N}(1 − (ρ₀/ρ₁)^{N−1}) / (c(N−1))`: the
//! optimal order grows as the radius shrinks (Nekhoroshev-like), and at fixed ρ₀ the
//! coefficients c, which grow with N, eventually win.
//!
//! **Physical tubes.** The user gives distances in the model's coordinates
//! ([`Metric::Euclidean`]: `|x − x_eq|`) or in the linear normal coordinates
//! ([`Metric::LinearNormal`]: `|A⁻¹(x − x_eq)|`, the metric the linear flow preserves).
//! [`tube_radii`] computes ρ₀ = max ρ over the sphere of radius d₀ and ρ₁ = min ρ over the
//! sphere of radius d₁, through the normalising maps. Then an orbit starting within d₀ has
//! ρ(0) ≤ ρ₀, and when it first reaches distance d₁ it is on that sphere, where ρ ≥ ρ₁: it
//! cannot leave the d₁-tube before T(ρ₀, ρ₁). The linear map alone distorts distances by
//! up to its condition number (29.6 at Earth–Moon L4 in the model's coordinates), so
//! Euclidean tubes need d₁/d₀ above it; in the linear normal metric ρ₁/ρ₀ ≈ d₁/d₀.
//!
//! ## What is rigorous and what is not
//!
//! Rigorous, given exact coefficients: the comparison argument, the norm inequalities, and the
//! quadrature bracket. Not rigorous: (i) H ∘ φ is truncated at degree M (the terms of degree
//! above M are dropped; they are O(ρ^M) against O(ρᴺ), but no bound on them is computed);
//! (ii) the coordinates used are the maps truncated at degree M−1, not the exact conjugacy
//! (the series need not converge; the difference is O(ρ^M)); (iii) the extrema ρ₀, ρ₁ over
//! the spheres are found by sampling (1000 directions) and local refinement (40 projected
//! gradient steps from the best 4), not by a
//! certified global optimisation; (iv) the coefficients carry rounding errors (f64 or
//! double-double, see the precision checks). Integration (`tests/stability_time.rs` of the
//! `lasalle` crate, `lasalle stability --time-bound … --validate`) checks the result.

use crate::error::NormalFormError;
use crate::normal_form::{NormalForm, Remainder};
use serde::Serialize;

/// Which bound on dρ/dt.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Norm {
    /// `F(ρ) = Σ s‖R_s‖ρ^{s−1}`, `‖R_s‖ = 2^{−(s−1)/2} Σ|c_ab|`: the bound |∇R| of the seed.
    #[serde(rename = "gradient")]
    Gradient,
    /// `F_r(ρ) = Σ 2^{−s/2} Σ ||a|₁−|b|₁| |c_ab| ρ^{s−1}`: d(ρ²)/dt itself, at least √2 sharper.
    #[serde(rename = "radial")]
    Radial,
}

/// dρ/dt ≤ F(ρ) = Σ_s f_s ρ^{s−1}.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Bound {
    /// The norm the coefficients come from.
    pub norm: Norm,
    /// (s, f_s), f_s ≥ 0, increasing s.
    pub coefficients: Vec<(usize, f64)>,
}

/// A time from the quadrature: the true integral lies in `[lower, upper]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Time {
    /// Right Riemann sum of 1/F: ≤ the integral (the bound).
    pub lower: f64,
    /// Left Riemann sum: ≥ the integral.
    pub upper: f64,
}

/// Intervals of the quadrature.
const QUADRATURE_INTERVALS: usize = 4096;

impl Bound {
    /// The bound of `remainder` in the given norm.
    pub fn new(remainder: &Remainder, norm: Norm) -> Bound {
        let coefficients = remainder
            .parts
            .iter()
            .map(|p| {
                let s = p.degree as f64;
                let f = match norm {
                    Norm::Gradient => s * 2f64.powf(-(s - 1.0) / 2.0) * p.sum_abs,
                    Norm::Radial => 2f64.powf(-s / 2.0) * p.radial,
                };
                (p.degree, f)
            })
            .filter(|&(_, f)| f > 0.0)
            .collect();
        Bound { norm, coefficients }
    }
    /// F(ρ).
    pub fn eval(&self, rho: f64) -> f64 {
        self.coefficients
            .iter()
            .map(|&(s, f)| f * rho.powi(s as i32 - 1))
            .sum()
    }
    /// The lowest degree with a non-zero coefficient (F ~ ρ^{s−1} near 0).
    pub fn lowest_degree(&self) -> Option<usize> {
        self.coefficients.first().map(|&(s, _)| s)
    }
    /// `∫_{ρ₀}^{ρ₁} dρ/F` bracketed by Riemann sums on `intervals` geometric intervals
    /// (0 < ρ₀ < ρ₁); infinite when F ≡ 0.
    pub fn time_with(&self, rho0: f64, rho1: f64, intervals: usize) -> Time {
        if self.coefficients.is_empty() {
            return Time {
                lower: f64::INFINITY,
                upper: f64::INFINITY,
            };
        }
        let q = (rho1 / rho0).powf(1.0 / intervals as f64);
        let (mut lower, mut upper) = (0.0, 0.0);
        let mut a = rho0;
        let mut fa = self.eval(a);
        for i in 1..=intervals {
            let b = if i == intervals { rho1 } else { a * q };
            let fb = self.eval(b);
            lower += (b - a) / fb;
            upper += (b - a) / fa;
            a = b;
            fa = fb;
        }
        Time { lower, upper }
    }
    /// [`Bound::time_with`] on 4096 intervals.
    pub fn time(&self, rho0: f64, rho1: f64) -> Time {
        self.time_with(rho0, rho1, QUADRATURE_INTERVALS)
    }
    /// An upper bound on ρ(t) for ρ(0) ≤ ρ₀: the ρ where the lower quadrature sum of
    /// T(ρ₀, ρ) reaches t (bisection in log ρ to 1e-10 relative, rounded up), infinite if F
    /// blows up first (T(ρ₀, 1e6·ρ₀) < t).
    pub fn reach(&self, rho0: f64, t: f64) -> f64 {
        let lower = |rho: f64| self.time(rho0, rho).lower;
        let mut hi = 2.0 * rho0;
        while lower(hi) < t {
            hi *= 2.0;
            if hi > 1e6 * rho0 {
                return f64::INFINITY;
            }
        }
        let mut lo = rho0;
        while hi / lo - 1.0 > 1e-10 {
            let mid = (lo * hi).sqrt();
            if lower(mid) < t {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }
}

/// How distances from the equilibrium are measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Metric {
    /// `|x − x_eq|` in the model's coordinates.
    #[serde(rename = "euclidean")]
    Euclidean,
    /// `|A⁻¹(x − x_eq)|`: the linear normal coordinates (preserved by the linear flow).
    #[serde(rename = "linear-normal")]
    LinearNormal,
}

impl std::fmt::Display for Metric {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Metric::Euclidean => "|x − x_eq| (model coordinates)",
            Metric::LinearNormal => "|A⁻¹(x − x_eq)| (linear normal coordinates)",
        })
    }
}

/// The distance of a phase-space point from the equilibrium in `metric`.
pub fn distance(nf: &NormalForm, x: &[f64], metric: Metric) -> f64 {
    let v: Vec<f64> = match metric {
        Metric::Euclidean => x
            .iter()
            .zip(nf.equilibrium_f64())
            .map(|(a, b)| a - b)
            .collect(),
        Metric::LinearNormal => nf.to_linear_normal(x),
    };
    norm(&v)
}

/// The phase-space point at distance `d` from the equilibrium in direction `u` (a unit
/// vector: of δx for [`Metric::Euclidean`], of (Q, P) for [`Metric::LinearNormal`]).
pub fn point_at(nf: &NormalForm, u: &[f64], d: f64, metric: Metric) -> Vec<f64> {
    match metric {
        Metric::Euclidean => nf
            .equilibrium_f64()
            .iter()
            .zip(u)
            .map(|(e, v)| e + d * v)
            .collect(),
        Metric::LinearNormal => {
            let w: Vec<f64> = u.iter().map(|v| d * v).collect();
            nf.from_linear_normal(&w)
        }
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn normalized(mut v: Vec<f64>) -> Vec<f64> {
    let r = norm(&v);
    v.iter_mut().for_each(|x| *x /= r);
    v
}

/// ρ₀ and ρ₁ of a tube, with the directions where they are attained.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TubeRadii {
    /// max |z'| over the sphere of radius d₀.
    pub rho0: f64,
    /// min |z'| over the sphere of radius d₁.
    pub rho1: f64,
    /// The direction of the maximum (a unit vector in the metric's coordinates).
    pub at_rho0: Vec<f64>,
    /// The direction of the minimum.
    pub at_rho1: Vec<f64>,
    /// Directions sampled on each sphere before the local refinement.
    pub samples: usize,
}

/// Directions sampled on each sphere.
const SPHERE_SAMPLES: usize = 1000;

/// Gradient steps of the local refinement.
const REFINE_ITERATIONS: usize = 40;

/// Deterministic directions on S^{d−1}: Gaussian vectors (Box–Muller on the seeded
/// [`Rng`](lasalle_model::Rng)), normalised, plus the ± coordinate axes.
fn sphere_directions(d: usize, count: usize) -> Vec<Vec<f64>> {
    let mut rng = lasalle_model::Rng::new(0x2545_f491_4f6c_dd1d);
    let mut out: Vec<Vec<f64>> = Vec::with_capacity(count + 2 * d);
    for k in 0..d {
        for s in [1.0, -1.0] {
            let mut e = vec![0.0; d];
            e[k] = s;
            out.push(e);
        }
    }
    while out.len() < count + 2 * d {
        let v: Vec<f64> = (0..d)
            .map(|_| {
                let (u1, u2) = (rng.unit_positive(), rng.unit());
                (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
            })
            .collect();
        out.push(normalized(v));
    }
    out
}

/// Maximises `f` on the unit sphere from `u` by projected gradient ascent (central
/// differences, step halving); returns the best point and value.
fn refine_on_sphere(f: &dyn Fn(&[f64]) -> f64, u: &[f64]) -> (Vec<f64>, f64) {
    let d = u.len();
    let mut u = u.to_vec();
    let mut fu = f(&u);
    let mut step = 0.1;
    let h = 1e-6;
    for _ in 0..REFINE_ITERATIONS {
        let mut g = vec![0.0; d];
        for k in 0..d {
            let mut a = u.clone();
            let mut b = u.clone();
            a[k] += h;
            b[k] -= h;
            g[k] = (f(&normalized(a)) - f(&normalized(b))) / (2.0 * h);
        }
        let radial: f64 = g.iter().zip(&u).map(|(a, b)| a * b).sum();
        g.iter_mut().zip(&u).for_each(|(gk, uk)| *gk -= radial * uk);
        let gn = norm(&g);
        if gn == 0.0 {
            break;
        }
        loop {
            let cand = normalized(u.iter().zip(&g).map(|(a, b)| a + step * b / gn).collect());
            let fc = f(&cand);
            if fc > fu {
                u = cand;
                fu = fc;
                step *= 1.5;
                break;
            }
            step /= 2.0;
            if step < 1e-12 {
                return (u, fu);
            }
        }
    }
    (u, fu)
}

/// ρ₀ = max |z'| over {dist = d₀} and ρ₁ = min |z'| over {dist = d₁} (see the module docs):
/// 1000 sampled directions, then the best 4 refined by projected gradient ascent. Needs the
/// transformation ([`Options::transform`](crate::Options::transform)).
pub fn tube_radii(
    nf: &NormalForm,
    d0: f64,
    d1: f64,
    metric: Metric,
) -> Result<TubeRadii, NormalFormError> {
    let map = nf.to_normal_map.as_ref().ok_or_else(|| {
        NormalFormError::Invalid(
            "the normal form has no transformation to normal coordinates".into(),
        )
    })?;
    let d = 2 * nf.n_dof;
    let rho = |u: &[f64], dist: f64| -> f64 {
        let w: Vec<f64> = match metric {
            Metric::LinearNormal => u.iter().map(|v| dist * v).collect(),
            Metric::Euclidean => nf
                .linear_inverse
                .iter()
                .map(|row| row.iter().zip(u).map(|(a, b)| dist * a * b).sum())
                .collect(),
        };
        norm(&map.eval(&w))
    };
    let dirs = sphere_directions(d, SPHERE_SAMPLES);
    let extreme = |dist: f64, sign: f64| -> (Vec<f64>, f64) {
        let f = |u: &[f64]| sign * rho(u, dist);
        let mut scored: Vec<(f64, usize)> =
            dirs.iter().enumerate().map(|(i, u)| (f(u), i)).collect();
        scored.sort_by(|a, b| b.0.total_cmp(&a.0));
        scored
            .iter()
            .take(4)
            .map(|&(_, i)| refine_on_sphere(&f, &dirs[i]))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("directions sampled")
    };
    let (at_rho0, rho0) = extreme(d0, 1.0);
    let (at_rho1, rho1) = extreme(d1, -1.0);
    Ok(TubeRadii {
        rho0,
        rho1: -rho1,
        at_rho0,
        at_rho1,
        samples: dirs.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::normal_form::RemainderPart;

    fn bound(parts: &[(usize, f64)]) -> Bound {
        let rem = Remainder {
            degree: 12,
            parts: parts
                .iter()
                .map(|&(degree, sum_abs)| RemainderPart {
                    degree,
                    terms: 1,
                    sum_abs,
                    radial: degree as f64 * sum_abs,
                })
                .collect(),
        };
        Bound::new(&rem, Norm::Gradient)
    }

    #[test]
    fn quadrature_brackets_the_integral() {
        // F = f ρ⁴ (s = 5): ∫ dρ/F = (ρ₀⁻³ − ρ₁⁻³)/(3f)
        let b = bound(&[(5, 2.0)]);
        let f = 5.0 * 2f64.powf(-2.0) * 2.0;
        assert!((b.eval(0.1) - f * 1e-4).abs() < 1e-18);
        let exact = (0.1f64.powi(-3) - 0.2f64.powi(-3)) / (3.0 * f);
        let t = b.time(0.1, 0.2);
        assert!(t.lower <= exact && exact <= t.upper, "{t:?} {exact}");
        assert!(t.upper - t.lower < 1e-3 * exact);
        // reach inverts it, from above
        let rho = b.reach(0.1, exact);
        assert!((0.2..0.2 * (1.0 + 1e-3)).contains(&rho), "{rho}");
        // two terms: positive and increasing, so still bracketed against a fine midpoint rule
        let b = bound(&[(5, 2.0), (6, 30.0)]);
        let t = b.time(0.01, 0.05);
        let k = 200_000;
        let h = 0.04 / k as f64;
        let mid: f64 = (0..k)
            .map(|i| h / b.eval(0.01 + (i as f64 + 0.5) * h))
            .sum();
        assert!(t.lower <= mid && mid <= t.upper, "{t:?} {mid}");
        assert_eq!(bound(&[]).time(0.1, 0.2).lower, f64::INFINITY);
    }

    #[test]
    fn radial_norm_is_at_least_root_two_sharper() {
        let parts = [(5, 1.0), (6, 3.0), (7, 10.0)];
        let rem = Remainder {
            degree: 7,
            parts: parts
                .iter()
                .map(|&(degree, sum_abs)| RemainderPart {
                    degree,
                    terms: 1,
                    sum_abs,
                    // worst case ||a| − |b|| = s
                    radial: degree as f64 * sum_abs,
                })
                .collect(),
        };
        let (g, r) = (
            Bound::new(&rem, Norm::Gradient),
            Bound::new(&rem, Norm::Radial),
        );
        for rho in [1e-3, 0.1, 1.0] {
            let ratio = g.eval(rho) / r.eval(rho);
            assert!((ratio - std::f64::consts::SQRT_2).abs() < 1e-12, "{ratio}");
        }
    }
}
