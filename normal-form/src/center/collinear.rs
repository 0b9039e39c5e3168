//! The collinear Lagrange points of the circular restricted three-body problem, in the
//! conventions of `models/cr3bp.lsl` (primaries m₁ = 1 − μ at (−μ, 0), m₂ = μ at (1 − μ, 0),
//! rotation rate 1): the quintic for the distance γ to the nearest primary, the Legendre
//! coefficients c_n(μ) of the expansion about the point (Richardson 1980; Jorba & Masdemont
//! 1999, eq. 7), and the linear frequencies from c₂ in closed form. They start Newton's method
//! on the model's own ∇H and check its Taylor expansion; the normalisation never uses them.

use crate::scalar::Real;
use crate::Dd;

/// One of the three collinear points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Collinear {
    /// Between the primaries.
    L1,
    /// Beyond the secondary m₂.
    L2,
    /// Beyond the primary m₁, on the side away from m₂.
    L3,
}

impl Collinear {
    /// `L1`, `L2` or `L3` (case-insensitive); anything else is `None`.
    pub fn parse(s: &str) -> Option<Collinear> {
        match s.to_ascii_uppercase().as_str() {
            "L1" => Some(Collinear::L1),
            "L2" => Some(Collinear::L2),
            "L3" => Some(Collinear::L3),
            _ => None,
        }
    }
    /// The name, `L1`…`L3`.
    pub fn name(self) -> &'static str {
        match self {
            Collinear::L1 => "L1",
            Collinear::L2 => "L2",
            Collinear::L3 => "L3",
        }
    }
}

/// The quintic's coefficients (degree 5 first) for γ (Szebehely 1967, §4.5): γ is the distance
/// of L1/L2 to m₂ and of L3 to m₁.
fn quintic(mu: Dd, which: Collinear) -> [Dd; 6] {
    let one = Dd::new(1.0);
    let two = Dd::new(2.0);
    let three = Dd::new(3.0);
    match which {
        Collinear::L1 => [one, -(three - mu), three - two * mu, -mu, two * mu, -mu],
        Collinear::L2 => [one, three - mu, three - two * mu, -mu, -two * mu, -mu],
        Collinear::L3 => {
            let m1 = one - mu;
            [one, two + mu, one + two * mu, -m1, -(two * m1), -m1]
        }
    }
}

/// γ(μ) in double-double: Newton on the quintic from Hill's approximation (L1, L2) or
/// 1 − 7μ/12 (L3). Fails (`None`) unless 0 < μ ≤ 1/2 and the iteration converges.
pub fn gamma(mu: f64, which: Collinear) -> Option<Dd> {
    if !(mu > 0.0 && mu <= 0.5) {
        return None;
    }
    let c = quintic(Dd::new(mu), which);
    let mut g = Dd::new(match which {
        Collinear::L1 | Collinear::L2 => (mu / 3.0).cbrt(),
        Collinear::L3 => 1.0 - 7.0 * mu / 12.0,
    });
    for _ in 0..100 {
        let (mut p, mut dp) = (Dd::new(0.0), Dd::new(0.0));
        for &ck in &c {
            dp = dp * g + p;
            p = p * g + ck;
        }
        let step = p / dp;
        g -= step;
        if step.abs().to_f64() <= 1e-31 * g.abs().to_f64() {
            return (g.to_f64() > 0.0 && g.to_f64() < 1.0).then_some(g);
        }
    }
    None
}

/// The point's x coordinate in the model's frame (y = z = 0, p = (−y, x, 0) there).
pub fn position(mu: f64, which: Collinear, gamma: Dd) -> Dd {
    let mu = Dd::new(mu);
    match which {
        Collinear::L1 => Dd::new(1.0) - mu - gamma,
        Collinear::L2 => Dd::new(1.0) - mu + gamma,
        Collinear::L3 => -mu - gamma,
    }
}

/// c_n(μ), n ≥ 2, of `H = ½p² + y p_x − x p_y − Σ_{n≥2} c_n ρⁿ P_n(x/ρ)` in the coordinates
/// centred at the point with unit length γ (Jorba & Masdemont 1999, eq. 7):
/// L1: `(μ + (−1)ⁿ(1−μ)γⁿ⁺¹/(1−γ)ⁿ⁺¹)/γ³`, L2: `(−1)ⁿ(μ + (1−μ)γⁿ⁺¹/(1+γ)ⁿ⁺¹)/γ³`,
/// L3: `(1 − μ + μγⁿ⁺¹/(1+γ)ⁿ⁺¹)/γ³`.
pub fn c_n(mu: f64, which: Collinear, gamma: Dd, n: u32) -> Dd {
    let mu = Dd::new(mu);
    let one = Dd::new(1.0);
    let sgn = if n.is_multiple_of(2) { one } else { -one };
    let pw = |x: Dd| crate::scalar::powi(x, n as i64 + 1);
    let g3 = gamma * gamma * gamma;
    match which {
        Collinear::L1 => (mu + sgn * (one - mu) * pw(gamma / (one - gamma))) / g3,
        Collinear::L2 => sgn * (mu + (one - mu) * pw(gamma / (one + gamma))) / g3,
        Collinear::L3 => (one - mu + mu * pw(gamma / (one + gamma))) / g3,
    }
}

/// (λ, ω_p, ω_v) from c₂ in closed form (Jorba & Masdemont 1999, eqs. 10–11):
/// `λ² = (c₂ − 2 + √(9c₂² − 8c₂))/2`, `ω_p² = (2 − c₂ + √(9c₂² − 8c₂))/2`, `ω_v² = c₂`.
pub fn linear_frequencies(c2: Dd) -> (Dd, Dd, Dd) {
    let two = Dd::new(2.0);
    let disc = (Dd::new(9.0) * c2 * c2 - Dd::new(8.0) * c2).sqrt();
    let lambda = ((c2 - two + disc) / two).sqrt();
    let wp = ((two - c2 + disc) / two).sqrt();
    (lambda, wp, c2.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    const MU: f64 = 0.01215058560962404;

    #[test]
    fn quintic_roots_are_equilibria_of_the_effective_potential() {
        // ∂Ω/∂x = x − (1−μ)(x+μ)/|x+μ|³ − μ(x−1+μ)/|x−1+μ|³ = 0 on the axis
        for which in [Collinear::L1, Collinear::L2, Collinear::L3] {
            let g = gamma(MU, which).unwrap();
            let x = position(MU, which, g);
            let mu = Dd::new(MU);
            let one = Dd::new(1.0);
            let d1 = x + mu;
            let d2 = x - one + mu;
            let f = x - (one - mu) * d1 / (d1.abs() * d1 * d1) - mu * d2 / (d2.abs() * d2 * d2);
            assert!(f.abs().to_f64() < 1e-28, "{which:?}: {f}");
        }
        // published values (Earth–Moon): γ₁ = 0.1509342, γ₂ = 0.1678331
        assert!((gamma(MU, Collinear::L1).unwrap().to_f64() - 0.150934).abs() < 1e-6);
        assert!((gamma(MU, Collinear::L2).unwrap().to_f64() - 0.167833).abs() < 1e-6);
    }
}
