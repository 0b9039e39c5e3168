//! The result types: [`NormalForm`], [`Value`] and the parts of the report, with their
//! accessors.

use super::normalize;
use super::options::{Options, Point, Precision};
use crate::error::NormalFormError;
use crate::hamiltonian::HamiltonianFn;
use crate::poly::Poly;
use crate::scalar::Real;
use serde::Serialize;

/// A number in the report: `value + lo` (lo ≠ 0 only in double-double) and an error estimate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Value {
    /// The value rounded to f64.
    pub value: f64,
    /// Double-double tail (value + lo is the computed number).
    #[serde(skip_serializing_if = "is_zero")]
    pub lo: f64,
    /// Estimated absolute error (see the crate docs), when an estimate was made.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<f64>,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl Value {
    pub(crate) fn of<R: Real>(x: R) -> Value {
        let (hi, lo) = x.hi_lo();
        Value {
            value: hi,
            lo,
            error: None,
        }
    }
    /// Estimated relative error |error/value|.
    pub fn relative_error(&self) -> Option<f64> {
        self.error.map(|e| {
            if self.value == 0.0 {
                e
            } else {
                e / self.value.abs()
            }
        })
    }
}

/// A coefficient of H̄ = Σ h_a I^a: `exponents` = a, `degree` = 2|a| in the phase-space
/// variables.
#[derive(Clone, Debug, Serialize)]
pub struct ActionTerm {
    /// Exponents a of I₁…I_n.
    pub exponents: Vec<u32>,
    /// Degree 2|a| as a polynomial in (Q, P).
    pub degree: usize,
    /// h_a
    pub coeff: Value,
}

/// A real monomial term `c·Q^α P^β` in the linear normal coordinates (generating function).
#[derive(Clone, Debug, Serialize)]
pub struct Term {
    /// Exponents of (Q₁…Q_n, P₁…P_n).
    pub exponents: Vec<u32>,
    /// Total degree (the index r of the generator G_r it belongs to).
    pub degree: usize,
    /// Coefficient.
    pub coeff: Value,
}

/// A resonant term kept in the normal form, in the complex coordinates `x^a y^b`.
#[derive(Clone, Debug, Serialize)]
pub struct ResonantTerm {
    /// Exponents a of x.
    pub x: Vec<u32>,
    /// Exponents b of y.
    pub y: Vec<u32>,
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

/// A small divisor met: m·ω with m relative to the positive frequencies.
#[derive(Clone, Debug, Serialize)]
pub struct SmallDivisor {
    /// Integer vector m (first nonzero entry positive).
    pub m: Vec<i32>,
    /// m·ω
    pub m_dot_omega: f64,
    /// Degree at which it was first met.
    pub order: usize,
    /// Kept as resonant (resonant mode only).
    pub resonant: bool,
}

/// The Arnold–Moser twist coefficients for two degrees of freedom:
/// `H̄₄ = ½(A I₁² + 2B I₁I₂ + C I₂²)` and `D₄ = −det[[A, B, ν₁], [B, C, ν₂], [ν₁, ν₂, 0]]
/// = A ν₂² − 2B ν₁ν₂ + C ν₁²` with `ν = (σ₁ω₁, σ₂ω₂)`; for `H₂ = ω₁I₁ − ω₂I₂` (L4) this is
/// Deprit's `D₄ = A ω₂² + 2B ω₁ω₂ + C ω₁²`.
#[derive(Clone, Debug, Serialize)]
pub struct ArnoldMoser {
    /// A = ∂²H̄/∂I₁²
    pub a: Value,
    /// B = ∂²H̄/∂I₁∂I₂
    pub b: Value,
    /// C = ∂²H̄/∂I₂²
    pub c: Value,
    /// D₄
    pub d4: Value,
}

/// Wall-clock time per phase, in seconds.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Timings {
    /// Newton + Taylor expansion by jets.
    pub taylor: f64,
    /// Linear normalisation and substitution into the complex diagonal coordinates.
    pub linear: f64,
    /// Lie-series normalisation.
    pub lie: f64,
    /// Coordinate transformations (both directions) and the real forms.
    pub transform: f64,
    /// Total (this precision only).
    pub total: f64,
    /// The error-estimate run in the other precision (0 if none).
    pub error_estimate: f64,
}

/// The coefficients of one degree of H̄ and their estimated errors.
#[derive(Clone, Debug, Serialize)]
pub struct DegreeError {
    /// Degree 2|a| in (Q, P).
    pub degree: usize,
    /// max |h_a| over the degree.
    pub max_coeff: f64,
    /// max |Im h_a| over the degree (H̄ is real: rounding noise of the substitution into the
    /// complex coordinates only, since the brackets are exactly real by construction; it is
    /// no measure of the rounding error of the coefficients).
    pub max_imag: f64,
    /// max over the degree of the estimated error (when estimated).
    pub max_error: Option<f64>,
    /// max over the degree of error(h_a) / max(|h_a|, 1000·u·max_coeff) (u: the unit roundoff
    /// of the precision): the worst relative error of a coefficient. Small coefficients matter
    /// (at Earth–Moon the I₁ᵏ coefficients, the short-period family, are 10⁻¹⁵ of the largest
    /// of degree 20 and lose 6% in f64), so only those below 1000 unit roundoffs of the largest
    /// are measured against that size; exact zeros (0 with error 0) are skipped. A coefficient
    /// that vanishes in exact arithmetic but comes out as amplified rounding noise counts as
    /// lost: turn the check off (`max_relative_error = None`) if that is known to happen.
    pub max_relative_error: Option<f64>,
}

/// Numerical checks made on the way.
#[derive(Clone, Debug, Serialize)]
pub struct Diagnostics {
    /// Newton iterations for the equilibrium.
    pub newton_iterations: usize,
    /// |∇H| at the returned equilibrium.
    pub gradient_norm: f64,
    /// max |AᵀJA − J|
    pub symplectic_residual: f64,
    /// max |AᵀSA − diag(σω)|
    pub diagonal_residual: f64,
    /// max |off-diagonal part of H₂| in the complex coordinates (dropped).
    pub quadratic_residual: f64,
    /// max |Im| of the action coefficients: rounding of the substitution into the complex
    /// coordinates only (the brackets are exactly real), absolute; not an error measure (see
    /// [`DegreeError`] and the error estimates).
    pub hbar_imag_residual: f64,
    /// Per degree of H̄: largest coefficient, imaginary residual and estimated errors.
    pub hbar_degrees: Vec<DegreeError>,
    /// max |Im| of the real-form generating function (rounding noise).
    pub generating_imag_residual: f64,
    /// max |Im| of the real-form transformations (rounding noise).
    pub transform_imag_residual: f64,
    /// How errors were estimated.
    pub error_method: Option<String>,
    /// Set when the precision was changed on the way (`Options::auto_precision`), saying why.
    pub precision_note: Option<String>,
    /// max over H̄ coefficients of |f64 − dd| / (|dd| · 2⁻⁵³): how much rounding is amplified.
    pub amplification: Option<f64>,
    /// Timings.
    pub timings: Timings,
    /// Memory of the monomial tables (bytes).
    pub table_bytes: usize,
}

/// A real polynomial map ℝ²ⁿ → ℝ²ⁿ (one polynomial per output component) between the
/// linear normal coordinates (Q, P) = A⁻¹ δz and the nonlinear ones (Q', P').
#[derive(Clone, Debug)]
pub struct PolyMap {
    /// Output components.
    pub components: Vec<Poly<f64>>,
}

impl PolyMap {
    /// Evaluates the map: the monomials once (one product each), then each component as
    /// their linear combination.
    pub fn eval(&self, x: &[f64]) -> Vec<f64> {
        let Some(first) = self.components.first() else {
            return Vec::new();
        };
        let top = self
            .components
            .iter()
            .map(|p| p.stored_degree())
            .max()
            .unwrap_or(0);
        let monomials = first.table().monomial_values(x, 1.0, top);
        self.components
            .iter()
            .map(|p| p.eval_monomials(&monomials))
            .collect()
    }
}

/// One degree s of the remainder R: the terms `c x^a y^b` of H in the complex normal
/// coordinates with `a ≠ b` (not functions of the actions). With `|x_k| = |y_k| = √I_k` these
/// two sums are what [`crate::bound`] needs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RemainderPart {
    /// The degree s.
    pub degree: usize,
    /// Number of non-zero terms.
    pub terms: usize,
    /// Σ |c_ab|.
    pub sum_abs: f64,
    /// Σ ||a|₁ − |b|₁|·|c_ab| (terms with |a|₁ = |b|₁ exchange action between the modes but
    /// do not change Σ I_k).
    pub radial: f64,
}

/// Everything in H ∘ φ (H in the normal coordinates of order N) that is not a function of the
/// actions, degrees 3…M: resonant terms of degree ≤ N (resonant mode) and all the
/// non-action terms of degrees N+1…M.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Remainder {
    /// M, the highest degree kept.
    pub degree: usize,
    /// The non-zero degrees, increasing.
    pub parts: Vec<RemainderPart>,
}

/// A Birkhoff normal form and everything needed to use it.
///
/// Conventions (see the crate docs): normal coordinates `(Q, P)` with
/// `δz = z − z_eq = A (Q, P)` (A real symplectic) to first order, actions
/// `I_k = (Q_k² + P_k²)/2`, `H̄ = E₀ + Σ σ_k ω_k I_k + Σ_{|a|≥2} h_a I^a`.
#[derive(Clone, Debug, Serialize)]
pub struct NormalForm {
    /// Model name.
    pub model: String,
    /// Degrees of freedom n.
    pub n_dof: usize,
    /// Truncation degree N.
    pub order: usize,
    /// Precision of the reported values.
    pub precision: Precision,
    /// Resonant mode.
    pub resonant: bool,
    /// Names of the phase-space coordinates (q₁…q_n, p₁…p_n).
    pub coordinates: Vec<String>,
    /// The equilibrium z_eq.
    pub equilibrium: Vec<Value>,
    /// H(z_eq) (the constant term of H̄).
    pub energy: Value,
    /// ω_k > 0, decreasing.
    pub omega: Vec<Value>,
    /// σ_k = ±1: H₂ = Σ σ_k ω_k I_k.
    pub signs: Vec<i8>,
    /// The linear symplectic map A (rows: coordinates, columns: Q₁…Q_n, P₁…P_n).
    pub linear_map: Vec<Vec<f64>>,
    /// H̄ as coefficients of action monomials (degree ≥ 2 in (Q, P), i.e. |a| ≥ 1).
    pub hamiltonian: Vec<ActionTerm>,
    /// Resonant terms kept (resonant mode).
    pub resonant_terms: Vec<ResonantTerm>,
    /// Generators G₃…G_N in real form in (Q, P); the transformation is
    /// `φ_{G₃} ∘ φ_{G₄} ∘ … ∘ φ_{G_N}` (time-one flows), old = that map of new.
    pub generating_function: Vec<Term>,
    /// Small divisors met, smallest |m·ω| first.
    pub small_divisors: Vec<SmallDivisor>,
    /// A, B, C and D₄ (two degrees of freedom, N ≥ 4).
    pub d4: Option<ArnoldMoser>,
    /// Checks and timings.
    pub diagnostics: Diagnostics,
    /// The remainder (with [`Options::remainder_degree`]).
    pub remainder: Option<Remainder>,
    /// (Q', P') as polynomials in (Q, P) = A⁻¹(z − z_eq), degree ≤ N−1 (M−1 with
    /// [`Options::remainder_degree`]).
    #[serde(skip)]
    pub to_normal_map: Option<PolyMap>,
    /// (Q, P) as polynomials in (Q', P'), degree ≤ N−1 (M−1 with
    /// [`Options::remainder_degree`]); z = z_eq + A (Q, P).
    #[serde(skip)]
    pub from_normal_map: Option<PolyMap>,
    /// A⁻¹
    #[serde(skip)]
    pub linear_inverse: Vec<Vec<f64>>,
    /// The low parts of A⁻¹ in a double-double or quad-double run: A⁻¹ in the working
    /// precision is `linear_inverse + linear_inverse_lo` to about 10⁻³² (zeros in `f64`).
    #[serde(skip)]
    pub linear_inverse_lo: Vec<Vec<f64>>,
    /// The low parts of A (as [`NormalForm::linear_inverse_lo`]).
    #[serde(skip)]
    pub linear_map_lo: Vec<Vec<f64>>,
    /// The low parts of the coefficients of [`NormalForm::to_normal_map`] (same tables: a
    /// coefficient is `hi + lo`; zeros in `f64`).
    #[serde(skip)]
    pub to_normal_map_lo: Option<PolyMap>,
}

impl NormalForm {
    /// Computes the normal form (see [`normalize`]).
    pub fn compute<H: HamiltonianFn + ?Sized>(
        h: &H,
        point: &Point,
        options: &Options,
    ) -> Result<NormalForm, NormalFormError> {
        normalize(h, point, options)
    }
    /// ω as f64.
    pub fn frequencies_linear(&self) -> Vec<f64> {
        self.omega.iter().map(|v| v.value).collect()
    }
    /// The equilibrium as f64.
    pub fn equilibrium_f64(&self) -> Vec<f64> {
        self.equilibrium.iter().map(|v| v.value + v.lo).collect()
    }
    /// The coefficient h_a of I^a (0 if absent).
    pub fn coefficient(&self, a: &[u32]) -> f64 {
        self.hamiltonian
            .iter()
            .find(|t| t.exponents == a)
            .map_or(0.0, |t| t.coeff.value)
    }
    /// H̄(I) (including the constant E₀).
    pub fn energy_at(&self, actions: &[f64]) -> f64 {
        self.energy.value
            + self
                .hamiltonian
                .iter()
                .map(|t| {
                    t.coeff.value
                        * t.exponents
                            .iter()
                            .zip(actions)
                            .map(|(&e, &i)| i.powi(e as i32))
                            .product::<f64>()
                })
                .sum::<f64>()
    }
    /// The frequency map ν = ∂H̄/∂I at the actions I (ν_k = σ_k ω_k + …).
    pub fn frequencies(&self, actions: &[f64]) -> Vec<f64> {
        let n = self.n_dof;
        (0..n)
            .map(|k| {
                self.hamiltonian
                    .iter()
                    .filter(|t| t.exponents[k] > 0)
                    .map(|t| {
                        let mut m = t.coeff.value * t.exponents[k] as f64;
                        for (j, (&e, &i)) in t.exponents.iter().zip(actions).enumerate() {
                            let e = if j == k { e - 1 } else { e };
                            m *= i.powi(e as i32);
                        }
                        m
                    })
                    .sum()
            })
            .collect()
    }
    /// Linear normal coordinates (Q, P) = A⁻¹(z − z_eq).
    pub fn to_linear_normal(&self, z: &[f64]) -> Vec<f64> {
        let eq = self.equilibrium_f64();
        let dz: Vec<f64> = z.iter().zip(&eq).map(|(a, b)| a - b).collect();
        self.linear_inverse
            .iter()
            .map(|r| r.iter().zip(&dz).map(|(a, b)| a * b).sum())
            .collect()
    }
    /// The phase-space point z = z_eq + A (Q, P).
    pub fn from_linear_normal(&self, w: &[f64]) -> Vec<f64> {
        let eq = self.equilibrium_f64();
        self.linear_map
            .iter()
            .zip(&eq)
            .map(|(r, e)| e + r.iter().zip(w).map(|(a, b)| a * b).sum::<f64>())
            .collect()
    }
    /// Normal coordinates (Q', P') of a phase-space point z (needs the transformation).
    pub fn to_normal(&self, z: &[f64]) -> Option<Vec<f64>> {
        let w = self.to_linear_normal(z);
        self.to_normal_map.as_ref().map(|m| m.eval(&w))
    }
    /// The phase-space point of normal coordinates (Q', P').
    pub fn from_normal(&self, w: &[f64]) -> Option<Vec<f64>> {
        self.from_normal_map
            .as_ref()
            .map(|m| self.from_linear_normal(&m.eval(w)))
    }
    /// Actions I_k = (Q'_k² + P'_k²)/2 of a phase-space point.
    pub fn actions(&self, z: &[f64]) -> Option<Vec<f64>> {
        let n = self.n_dof;
        self.to_normal(z).map(|w| {
            (0..n)
                .map(|k| 0.5 * (w[k] * w[k] + w[n + k] * w[n + k]))
                .collect()
        })
    }
    /// The truncated normal-form flow (seed eq. 5) mapped back: z(t) from z(0). In normal
    /// coordinates each plane rotates, `Q' + iP' ↦ (Q' + iP') e^{−iν_k t}` with ν = ∂H̄/∂I
    /// at the initial actions.
    pub fn flow(&self, z0: &[f64], t: f64) -> Option<Vec<f64>> {
        if !self.resonant_terms.is_empty() {
            return None;
        }
        let n = self.n_dof;
        let w = self.to_normal(z0)?;
        let actions: Vec<f64> = (0..n)
            .map(|k| 0.5 * (w[k] * w[k] + w[n + k] * w[n + k]))
            .collect();
        let nu = self.frequencies(&actions);
        let mut wt = w.clone();
        for k in 0..n {
            let (s, c) = (nu[k] * t).sin_cos();
            wt[k] = w[k] * c + w[n + k] * s;
            wt[n + k] = -w[k] * s + w[n + k] * c;
        }
        self.from_normal(&wt)
    }
    /// The linearised flow about the equilibrium: δz(t) = A R(σω t) A⁻¹ δz(0).
    pub fn linear_flow(&self, z0: &[f64], t: f64) -> Vec<f64> {
        let n = self.n_dof;
        let w = self.to_linear_normal(z0);
        let mut wt = w.clone();
        for k in 0..n {
            let nu = self.omega[k].value * self.signs[k] as f64;
            let (s, c) = (nu * t).sin_cos();
            wt[k] = w[k] * c + w[n + k] * s;
            wt[n + k] = -w[k] * s + w[n + k] * c;
        }
        self.from_linear_normal(&wt)
    }
}
