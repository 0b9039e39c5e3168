//! Reference Hamiltonians written directly in Rust, for tests, benchmarks and examples. The
//! command line goes through DSL models instead (`NormalForm::from_model`-style entry points
//! in the root crate); these give the same expressions without the parser.

use crate::hamiltonian::HamiltonianFn;
use crate::jet::Scalar;
use crate::poly::Poly;

/// The planar circular restricted three-body problem in the rotating frame (seed eq. 6),
/// normalised units, primaries of masses 1−μ at (−μ, 0) and μ at (1−μ, 0):
///
/// ```text
/// H = ½(p₁² + p₂²) + q₂p₁ − q₁p₂ − (1−μ)/r₁ − μ/r₂,
/// r₁² = (q₁ + μ)² + q₂²,  r₂² = (q₁ − 1 + μ)² + q₂².
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Cr3bp {
    /// Mass ratio μ = m₂/(m₁ + m₂).
    pub mu: f64,
}

impl Cr3bp {
    /// Earth–Moon mass ratio.
    pub const EARTH_MOON: f64 = 0.012_150_585_609_624_04;
    /// Routh's critical mass ratio μ_R = (1 − √(23/27))/2: L4 is linearly stable below it.
    pub fn mu_routh() -> f64 {
        (1.0 - (23.0f64 / 27.0).sqrt()) / 2.0
    }
    /// L4 = (½ − μ, √3/2, −√3/2, ½ − μ) in (q₁, q₂, p₁, p₂).
    pub fn l4(&self) -> [f64; 4] {
        let s = 3f64.sqrt() / 2.0;
        [0.5 - self.mu, s, -s, 0.5 - self.mu]
    }
    /// L4 in any precision (√3 evaluated in that precision).
    pub fn l4_in<S: Scalar>(&self) -> Vec<S> {
        let s = S::from_f64(3.0).sqrt().mul(&S::from_f64(0.5));
        let x = S::from_f64(0.5).sub(&S::from_f64(self.mu));
        vec![x.clone(), s.clone(), s.neg(), x]
    }
}

impl HamiltonianFn for Cr3bp {
    fn n_dof(&self) -> usize {
        2
    }
    fn eval<S: Scalar>(&self, z: &[S]) -> S {
        let (q1, q2, p1, p2) = (&z[0], &z[1], &z[2], &z[3]);
        let mu = S::from_f64(self.mu);
        let one_mu = S::from_f64(1.0 - self.mu);
        let half = S::from_f64(0.5);
        let a = q1.add(&mu);
        let b = q1.sub(&one_mu);
        let r1sq = a.mul(&a).add(&q2.mul(q2));
        let r2sq = b.mul(&b).add(&q2.mul(q2));
        let kinetic = half.mul(&p1.mul(p1).add(&p2.mul(p2)));
        let coriolis = q2.mul(p1).sub(&q1.mul(p2));
        kinetic
            .add(&coriolis)
            .sub(&one_mu.mul(&r1sq.powf(-0.5)))
            .sub(&mu.mul(&r2sq.powf(-0.5)))
    }
    fn name(&self) -> String {
        format!("cr3bp(mu={})", self.mu)
    }
    fn coordinate_names(&self) -> Vec<String> {
        ["x", "y", "px", "py"]
            .iter()
            .map(|s| s.to_string())
            .collect()
    }
}

/// Two coupled oscillators with frequencies 1 and √2, cubic and quartic couplings:
///
/// ```text
/// H = ½(p₁² + q₁²) + (√2/2)(p₂² + q₂²) + a q₁²q₂ + b q₁q₂² + c q₁⁴ + d q₁²q₂² + e p₁p₂q₂
/// ```
///
/// (both modes have positive energy: H₂ = ω₁I₁ + ω₂I₂; the equilibrium is the origin).
#[derive(Clone, Copy, Debug)]
pub struct CoupledOscillators {
    /// Couplings (a, b, c, d, e).
    pub couplings: [f64; 5],
}

impl Default for CoupledOscillators {
    fn default() -> Self {
        CoupledOscillators {
            couplings: [0.3, -0.2, 0.1, 0.05, 0.07],
        }
    }
}

impl HamiltonianFn for CoupledOscillators {
    fn n_dof(&self) -> usize {
        2
    }
    fn eval<S: Scalar>(&self, z: &[S]) -> S {
        let (q1, q2, p1, p2) = (&z[0], &z[1], &z[2], &z[3]);
        let [a, b, c, d, e] = self.couplings.map(S::from_f64);
        let half = S::from_f64(0.5);
        let w2 = S::from_f64(2.0).sqrt();
        let h1 = half.mul(&p1.mul(p1).add(&q1.mul(q1)));
        let h2 = half.mul(&w2).mul(&p2.mul(p2).add(&q2.mul(q2)));
        let q1s = q1.mul(q1);
        let cubic = a.mul(&q1s).mul(q2).add(&b.mul(q1).mul(&q2.mul(q2)));
        let quartic = c
            .mul(&q1s.mul(&q1s))
            .add(&d.mul(&q1s).mul(&q2.mul(q2)))
            .add(&e.mul(p1).mul(p2).mul(q2));
        h1.add(&h2).add(&cubic).add(&quartic)
    }
    fn name(&self) -> String {
        "coupled-oscillators".into()
    }
}

/// A one-degree-of-freedom anharmonic oscillator `H = ½(p² + q²) + α q³/3 + β q⁴/4`, whose
/// normal form is known in closed form: `H̄ = I + (3β/8 − 5α²/12) I² + …`.
#[derive(Clone, Copy, Debug)]
pub struct Anharmonic {
    /// Cubic coefficient α.
    pub alpha: f64,
    /// Quartic coefficient β.
    pub beta: f64,
}

impl HamiltonianFn for Anharmonic {
    fn n_dof(&self) -> usize {
        1
    }
    fn eval<S: Scalar>(&self, z: &[S]) -> S {
        let (q, p) = (&z[0], &z[1]);
        let half = S::from_f64(0.5);
        let q2 = q.mul(q);
        half.mul(&p.mul(p).add(&q2))
            .add(
                &S::from_f64(self.alpha)
                    .div(&S::from_f64(3.0))
                    .mul(&q2.mul(q)),
            )
            .add(&S::from_f64(self.beta / 4.0).mul(&q2.mul(&q2)))
    }
    fn name(&self) -> String {
        "anharmonic".into()
    }
}

/// A Hamiltonian given as a real polynomial in z = (q, p) (f64 coefficients).
#[derive(Clone, Debug)]
pub struct PolynomialHamiltonian {
    /// The polynomial; its number of variables must be even.
    pub poly: Poly<f64>,
}

impl HamiltonianFn for PolynomialHamiltonian {
    fn n_dof(&self) -> usize {
        self.poly.nvars() / 2
    }
    fn eval<S: Scalar>(&self, z: &[S]) -> S {
        let mut sum = S::from_f64(0.0);
        for (k, i, c) in self.poly.terms() {
            let e = self.poly.exponents(k, i);
            let mut m = S::from_f64(c);
            for (v, &ev) in e.iter().enumerate() {
                if ev > 0 {
                    m = m.mul(&z[v].powi(ev as i32));
                }
            }
            sum = sum.add(&m);
        }
        sum
    }
}
