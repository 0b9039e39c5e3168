//! The primer vector on a coast arc in closed form: the Lagrange multipliers λ of the
//! minimum-fuel problem along Kepler motion ("Analytical solution of the Euler–Lagrange
//! equations for optimum coast trajectories", the seventh paper of NASA TM X-53478).
//!
//! On a coast arc (no thrust) the multiplier λ of the velocity obeys the paper's (6),
//!
//! ```text
//! λ̈ = −μλ/r³ + 3μ(λ·R)R/r⁵,
//! ```
//!
//! which is the variational equation of the Kepler problem: λ moves as a position
//! perturbation δR does, so a run of the Kepler model with its state-transition matrix
//! integrates it (`lasalle run models/kepler.lsl --variational`). In perifocal axes (x towards
//! perigee, y in the plane, z along the angular momentum) the paper solves it as
//!
//! ```text
//! λ_z = K₁x + K₂y                                                     (8)
//! λ_p = F R + G Ṙ                                                     (9)
//! F = K₄x + K₅y + 2K₃                                                 (16)
//! G = −3K₃t + (μ/2E)·K₄·[(y/h)(r + p) − 3et] + K₅(x/h)p(r + p) + K₆   (17)
//! ```
//!
//! (t the time since perigee, E = −μ/2a the energy, h the angular momentum, p the semi-latus
//! rectum), the same form on hyperbolas, and on the parabola
//!
//! ```text
//! G = −3K₃t + (2/5)K₄(y/h)[r² − p(r + p)] + K₅(x/h)p(r + p) + K₆      (18)
//! ```
//!
//! (17)'s K₄ term is 0/0 at e = 1 (μ/2E → ∞, its bracket → 0). With ε = 1 − e the paper's
//! near-parabolic series (25) is
//!
//! ```text
//! (2/5)K₄(y/h){r² − p(r + p) − (ε/4)[p(r + p) + 4r²]}                 (25)
//! ```
//!
//! which is (18) at ε = 0 but whose ε term is not the first-order term of (17): the paper
//! drops second-order terms of its time series (22)–(24) that the factor μ/2E = O(1/ε) lifts
//! to first order. The first-order expansion of (17)'s K₄ term at a fixed point of the orbit
//! is
//!
//! ```text
//! (2/5)K₄(y/h)[r² − p(r + p)] + (4ε/35)K₄(y/h)[3r³/p − r² − 3p(r + p)] + O(ε²)
//! ```
//!
//! ([`GForm::Series`]); (25) ([`GForm::Printed`]) and (18) are both O(ε) from (17).
//!
//! The derivative, from F and G, is λ̇_p = (K₄ẋ + K₅ẏ − μG/r³)R + (K₃ − F)Ṙ and
//! λ̇_z = K₁ẋ + K₂ẏ. The six constants come from λ and λ̇ at the start of the coast
//! ([`Coast::new`]). The Kepler motion itself is computed with universal variables and
//! Stumpff functions ([`Conic::state`]), one formula for every eccentricity.
//!
//! The derivations and the comparison with integration are in `docs/primer_vector.md`.

use std::fmt;

/// Why a coast arc cannot be set up.
#[derive(Clone, Debug, PartialEq)]
pub enum PrimerError {
    /// μ or the perigee radius is not positive and finite, or e is negative or not finite.
    Orbit(String),
    /// The form of G asked for does not apply to this eccentricity.
    Form(String),
    /// Kepler's equation did not converge at this time.
    Kepler(f64),
}

impl fmt::Display for PrimerError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PrimerError::Orbit(m) | PrimerError::Form(m) => f.write_str(m),
            PrimerError::Kepler(t) => write!(
                f,
                "Kepler's equation (universal variables) did not converge at t = {t} s after perigee"
            ),
        }
    }
}

impl std::error::Error for PrimerError {}

/// A Keplerian orbit by its gravitational parameter, perigee radius and eccentricity, in
/// perifocal axes; time is counted from perigee passage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conic {
    /// μ.
    pub mu: f64,
    /// The perigee radius r_p.
    pub rp: f64,
    /// The eccentricity e ≥ 0 (e = 1: a parabola, e > 1: a hyperbola).
    pub e: f64,
}

/// The Kepler state at a time: position (x, y), velocity (ẋ, ẏ) in perifocal axes, and r.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeplerState {
    /// x, towards perigee.
    pub x: f64,
    /// y, in the plane of motion.
    pub y: f64,
    /// ẋ.
    pub vx: f64,
    /// ẏ.
    pub vy: f64,
    /// r = |R|.
    pub r: f64,
}

/// The Stumpff functions C(z) = (1 − cos√z)/z and S(z) = (√z − sin√z)/√z³ (continued to
/// z ≤ 0), by their series where |z| < 1.
pub fn stumpff(z: f64) -> (f64, f64) {
    if z.abs() < 1.0 {
        // C = Σ (−z)^k/(2k+2)!, S = Σ (−z)^k/(2k+3)!
        let (mut c, mut s) = (0.0, 0.0);
        let (mut tc, mut ts) = (0.5, 1.0 / 6.0);
        for k in 0..30 {
            c += tc;
            s += ts;
            let k = k as f64;
            tc *= -z / ((2.0 * k + 3.0) * (2.0 * k + 4.0));
            ts *= -z / ((2.0 * k + 4.0) * (2.0 * k + 5.0));
        }
        (c, s)
    } else if z > 0.0 {
        let w = z.sqrt();
        ((1.0 - w.cos()) / z, (w - w.sin()) / (w * z))
    } else {
        let w = (-z).sqrt();
        ((w.cosh() - 1.0) / -z, (w.sinh() - w) / (w * -z))
    }
}

impl Conic {
    /// A conic, checked.
    pub fn new(mu: f64, rp: f64, e: f64) -> Result<Conic, PrimerError> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(mu) || !positive(rp) {
            return Err(PrimerError::Orbit(format!(
                "μ = {mu} and the perigee radius r_p = {rp} must be positive and finite"
            )));
        }
        if !(e.is_finite() && e >= 0.0) {
            return Err(PrimerError::Orbit(format!(
                "the eccentricity e = {e} must be finite and ≥ 0"
            )));
        }
        Ok(Conic { mu, rp, e })
    }

    /// The semi-latus rectum p = r_p(1 + e).
    pub fn p(&self) -> f64 {
        self.rp * (1.0 + self.e)
    }

    /// The angular momentum h = √(μp).
    pub fn h(&self) -> f64 {
        (self.mu * self.p()).sqrt()
    }

    /// 1/a = (1 − e)/r_p (0 on the parabola, negative on hyperbolas).
    pub fn alpha(&self) -> f64 {
        (1.0 - self.e) / self.rp
    }

    /// The speed at perigee √(μ(1 + e)/r_p).
    pub fn vp(&self) -> f64 {
        (self.mu * (1.0 + self.e) / self.rp).sqrt()
    }

    /// The state `t` after perigee: Kepler's equation in the universal variable χ,
    /// √μ t = eχ³S(αχ²) + r_pχ, solved by Newton's method kept inside the bracket
    /// [0, √μ t/r_p] (r ≥ r_p), then the Lagrange coefficients f, g, ḟ, ġ.
    pub fn state(&self, t: f64) -> Result<KeplerState, PrimerError> {
        let (mu, rp, e, alpha) = (self.mu, self.rp, self.e, self.alpha());
        let sq = mu.sqrt();
        let target = sq * t;
        let kepler = |chi: f64| {
            let (c, s) = stumpff(alpha * chi * chi);
            let r = e * chi * chi * c + rp;
            (e * chi.powi(3) * s + rp * chi - target, r)
        };
        let (mut lo, mut hi) = if t >= 0.0 {
            (0.0, target / rp)
        } else {
            (target / rp, 0.0)
        };
        let mut chi = 0.5 * (lo + hi);
        let mut converged = false;
        for _ in 0..200 {
            let (f, r) = kepler(chi);
            if f > 0.0 {
                hi = chi;
            } else {
                lo = chi;
            }
            let mut next = chi - f / r;
            if !(next >= lo && next <= hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - chi).abs() <= 4.0 * f64::EPSILON * chi.abs().max(f64::MIN_POSITIVE) {
                chi = next;
                converged = true;
                break;
            }
            chi = next;
        }
        if !converged {
            return Err(PrimerError::Kepler(t));
        }
        let z = alpha * chi * chi;
        let (c, s) = stumpff(z);
        let r = e * chi * chi * c + rp;
        let f = 1.0 - chi * chi * c / rp;
        let g = t - chi.powi(3) * s / sq;
        let fdot = sq * chi * (z * s - 1.0) / (r * rp);
        let gdot = 1.0 - chi * chi * c / r;
        let vp = self.vp();
        Ok(KeplerState {
            x: f * rp,
            y: g * vp,
            vx: fdot * rp,
            vy: gdot * vp,
            r,
        })
    }
}

/// Which expression for G's K₄ term (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GForm {
    /// (17): (μ/2E)[(y/h)(r + p) − 3et], exact on ellipses (e = 0 included) and hyperbolas;
    /// refused at e = 1.
    Exact,
    /// (18): (2/5)(y/h)[r² − p(r + p)], exact on the parabola.
    Parabolic,
    /// (25) as the paper prints it: (18) − (2/5)(y/h)(ε/4)[p(r + p) + 4r²], ε = 1 − e.
    Printed,
    /// (18) + (4ε/35)(y/h)[3r³/p − r² − 3p(r + p)]: the first-order expansion of (17) in
    /// ε = 1 − e, error O(ε²).
    Series,
}

impl GForm {
    /// Every form, in the order of the docs.
    pub const ALL: [GForm; 4] = [
        GForm::Exact,
        GForm::Parabolic,
        GForm::Printed,
        GForm::Series,
    ];

    /// The paper's equation number (or "series").
    pub fn name(self) -> &'static str {
        match self {
            GForm::Exact => "(17)",
            GForm::Parabolic => "(18)",
            GForm::Printed => "(25)",
            GForm::Series => "series",
        }
    }

    /// The K₄ part of G at a point of `conic` `t` after perigee (its time derivative is −2x
    /// for the exact forms).
    pub fn k4_term(self, conic: &Conic, s: &KeplerState, t: f64) -> f64 {
        let (p, h, e) = (conic.p(), conic.h(), conic.e);
        let (r, y) = (s.r, s.y);
        let parabolic = 0.4 * (y / h) * (r * r - p * (r + p));
        let eps = 1.0 - e;
        match self {
            // μ/2E = −a = −1/α
            GForm::Exact => -((y / h) * (r + p) - 3.0 * e * t) / conic.alpha(),
            GForm::Parabolic => parabolic,
            GForm::Printed => parabolic - 0.4 * (y / h) * 0.25 * eps * (p * (r + p) + 4.0 * r * r),
            GForm::Series => {
                parabolic
                    + 4.0 / 35.0 * eps * (y / h) * (3.0 * r * r * r / p - r * r - 3.0 * p * (r + p))
            }
        }
    }

    /// The K₅ part of G, (x/h)p(r + p) (every form).
    pub fn k5_term(conic: &Conic, s: &KeplerState) -> f64 {
        let p = conic.p();
        s.x / conic.h() * p * (s.r + p)
    }
}

/// The primer vector λ and its derivative λ̇ in perifocal axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Primer {
    /// λ.
    pub lambda: [f64; 3],
    /// λ̇ (= −γ, the paper's other multiplier).
    pub dlambda: [f64; 3],
}

/// A coast arc with its primer vector in closed form: the conic, the form of G and the six
/// constants K₁ … K₆ of (8), (16), (17).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coast {
    /// The orbit.
    pub conic: Conic,
    /// The expression used for G.
    pub form: GForm,
    /// K₁ … K₆.
    pub k: [f64; 6],
}

/// Solves [a b; c d]·(u, v) = (e, f).
fn solve2(m: [[f64; 2]; 2], rhs: [f64; 2]) -> [f64; 2] {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    [
        (rhs[0] * m[1][1] - m[0][1] * rhs[1]) / det,
        (m[0][0] * rhs[1] - rhs[0] * m[1][0]) / det,
    ]
}

impl Coast {
    /// The coast arc through λ(t₀) = `lambda`, λ̇(t₀) = `dlambda` (perifocal axes) at `t0`
    /// after perigee. λ_p(t₀) = αR + βṘ and λ̇_p(t₀) = γR + δṘ give F = α, G = β,
    /// K₃ = α + δ (from Ġ = K₃ − 2F) and Ḟ = γ + μβ/r³, whence K₄, K₅ from (16) and its
    /// derivative, and K₆ from (17); K₁, K₂ from (8) and its derivative.
    pub fn new(
        conic: Conic,
        form: GForm,
        t0: f64,
        lambda: [f64; 3],
        dlambda: [f64; 3],
    ) -> Result<Coast, PrimerError> {
        if form == GForm::Exact && conic.e == 1.0 {
            return Err(PrimerError::Form(
                "(17) is 0/0 on the parabola (e = 1): use the parabolic form (18)".into(),
            ));
        }
        let s = conic.state(t0)?;
        // columns R, Ṙ (det = h ≠ 0)
        let basis = [[s.x, s.vx], [s.y, s.vy]];
        let [al, be] = solve2(basis, [lambda[0], lambda[1]]);
        let [ga, de] = solve2(basis, [dlambda[0], dlambda[1]]);
        let k3 = al + de;
        let fdot = ga + conic.mu * be / s.r.powi(3);
        let [k4, k5] = solve2([[s.x, s.y], [s.vx, s.vy]], [al - 2.0 * k3, fdot]);
        let g_free =
            -3.0 * k3 * t0 + k4 * form.k4_term(&conic, &s, t0) + k5 * GForm::k5_term(&conic, &s);
        let k6 = be - g_free;
        let [k1, k2] = solve2([[s.x, s.y], [s.vx, s.vy]], [lambda[2], dlambda[2]]);
        Ok(Coast {
            conic,
            form,
            k: [k1, k2, k3, k4, k5, k6],
        })
    }

    /// F and G at `t` after perigee.
    pub fn f_g(&self, t: f64) -> Result<(f64, f64, KeplerState), PrimerError> {
        let s = self.conic.state(t)?;
        let [_, _, k3, k4, k5, k6] = self.k;
        let f = k4 * s.x + k5 * s.y + 2.0 * k3;
        let g = -3.0 * k3 * t
            + k4 * self.form.k4_term(&self.conic, &s, t)
            + k5 * GForm::k5_term(&self.conic, &s)
            + k6;
        Ok((f, g, s))
    }

    /// λ and λ̇ at `t` after perigee.
    pub fn primer(&self, t: f64) -> Result<Primer, PrimerError> {
        let (f, g, s) = self.f_g(t)?;
        let [k1, k2, k3, k4, k5, _] = self.k;
        let a = k4 * s.vx + k5 * s.vy - self.conic.mu * g / s.r.powi(3);
        let b = k3 - f;
        Ok(Primer {
            lambda: [f * s.x + g * s.vx, f * s.y + g * s.vy, k1 * s.x + k2 * s.y],
            dlambda: [
                a * s.x + b * s.vx,
                a * s.y + b * s.vy,
                k1 * s.vx + k2 * s.vy,
            ],
        })
    }
}

/// The number of significant digits to which `b` agrees with `a`: −log₁₀(|a − b|/|a|) in the
/// Euclidean norm (17 for equal vectors).
pub fn digits(a: &[f64], b: &[f64]) -> f64 {
    let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|x| x * x).sum::<f64>().sqrt();
    let d = norm(&mut a.iter().zip(b).map(|(x, y)| x - y));
    let n = norm(&mut a.iter().copied());
    if d == 0.0 {
        17.0
    } else {
        -(d / n).log10()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stumpff_series_meets_the_closed_forms_at_one() {
        for z in [0.999_999, -0.999_999] {
            let (c0, s0) = stumpff(z);
            let (c1, s1) = stumpff(z * (1.0 + 2e-6));
            assert!((c0 - c1).abs() < 1e-6 && (s0 - s1).abs() < 1e-6);
        }
    }

    #[test]
    fn bad_orbits_are_refused_with_the_reason() {
        let e = Conic::new(1.0, -1.0, 0.5).unwrap_err();
        assert!(e.to_string().contains("perigee radius"));
        let e = Conic::new(1.0, 1.0, f64::NAN).unwrap_err();
        assert!(e.to_string().contains("eccentricity"));
        let c = Conic::new(1.0, 1.0, 1.0).unwrap();
        let e = Coast::new(c, GForm::Exact, 1.0, [1.0; 3], [0.0; 3]).unwrap_err();
        assert!(e.to_string().contains("(18)"));
    }
}
