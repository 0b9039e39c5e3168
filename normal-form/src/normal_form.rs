//! The driver: equilibrium → Taylor expansion → linear normalisation → Lie normalisation →
//! [`NormalForm`], in either precision, with an error estimate from the other precision.

use crate::complex::Complex;
use crate::error::NormalFormError;
use crate::hamiltonian::{find_equilibrium, gradient_hessian, taylor, HamiltonianFn};
use crate::lie;
use crate::linalg::Mat;
use crate::linear::{complexification, linear_normalization, symplectic_inverse};
use crate::monomial::MonomialTable;
use crate::poly::Poly;
use crate::scalar::{Coeff, Real};
use crate::Dd;
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// Working precision of the series algebra.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Precision {
    /// IEEE double.
    #[serde(rename = "f64")]
    F64,
    /// Double-double (≈ 32 digits), 1.2–3.3× the f64 time (see the crate docs).
    #[serde(rename = "dd")]
    DoubleDouble,
}

impl std::str::FromStr for Precision {
    type Err = NormalFormError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "f64" | "double" => Ok(Precision::F64),
            "dd" | "double-double" => Ok(Precision::DoubleDouble),
            _ => Err(NormalFormError::Invalid(format!(
                "unknown precision `{s}` (expected `f64` or `dd`)"
            ))),
        }
    }
}

impl std::fmt::Display for Precision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Precision::F64 => "f64",
            Precision::DoubleDouble => "dd",
        })
    }
}

/// A stage of the computation, reported to [`Options::progress`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Equilibrium, Taylor expansion and linear normalisation (in this precision).
    Start(Precision),
    /// The Lie normalisation of degree `degree` (3…`order`) begins.
    Degree {
        /// The degree being normalised.
        degree: usize,
        /// The truncation order N.
        order: usize,
        /// The precision of this run.
        precision: Precision,
    },
    /// The real forms and the coordinate transformations.
    Transform,
    /// A second run in the other precision (error estimate or precision fallback) begins.
    Rerun(Precision),
    /// Done.
    Done,
}

/// A callback receiving [`Stage`]s (e.g. to drive a progress bar).
#[derive(Clone)]
pub struct Progress(pub Arc<dyn Fn(Stage) + Send + Sync>);

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Progress(..)")
    }
}

impl Progress {
    fn report(p: &Option<Progress>, stage: Stage) {
        if let Some(p) = p {
            (p.0)(stage)
        }
    }
}

/// How [`normalize`] estimates the error of each coefficient.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ErrorEstimate {
    /// No estimate (and no precision check).
    #[serde(rename = "none")]
    None,
    /// Rerun H̄ in the same precision with every normal plane rotated (H̄ does not depend on
    /// the rotation, the rounding does) and take `|c − c_rotated|`. Costs about one run
    /// without the transformation (1×); tracks the real error within a factor ~3 (at
    /// Earth–Moon and μ = 0.001, degrees 4…24: `examples/noise.rs`).
    #[serde(rename = "rotation")]
    Rotation,
    /// Rerun H̄ in the other precision and compare: `|c_f64 − c_dd|` for an f64 run (the real
    /// f64 error; costs 1.2× at order ≤ 12 to 3.3× at order ≥ 24 the f64 run),
    /// `|c_f64 − c_dd|·2⁻⁵¹` for a double-double run (0.3–0.8× the run).
    #[serde(rename = "other-precision")]
    OtherPrecision,
}

/// Where to normalise.
#[derive(Clone, Debug, PartialEq)]
pub enum Point {
    /// An equilibrium given exactly (checked: |∇H| ≤ `Options::equilibrium_tol`), then
    /// polished by Newton in the working precision.
    Given(Vec<f64>),
    /// A starting guess for Newton's method on ∇H = 0.
    Newton(Vec<f64>),
}

/// Options of [`normalize`]. Defaults: order 12, f64, non-resonant, resonance tolerance 1e-6,
/// error estimate in the other precision with the precision check at 1e-3 (no automatic
/// switch), transformation on.
#[derive(Clone, Debug)]
pub struct Options {
    /// Truncation degree N ≥ 2 of the normal form (H̄ contains actions up to degree N/2).
    /// Default: 12.
    pub order: usize,
    /// Working precision. Default: f64.
    pub precision: Precision,
    /// Keep resonant terms (|m·ω| < `resonance_tol`) instead of failing. Default: false.
    pub resonant: bool,
    /// Assumption 1′ tolerance on |m·ω| for 0 < |m|₁ ≤ N. Default: 1e-6.
    pub resonance_tol: f64,
    /// How to estimate the error of each coefficient. Default: [`ErrorEstimate::OtherPrecision`].
    pub error_estimate: ErrorEstimate,
    /// Largest estimated relative error accepted for a coefficient of H̄
    /// ([`DegreeError::max_relative_error`]; needs an error estimate). Above it the run fails
    /// with [`NormalFormError::PrecisionLost`], or, with `auto_precision`, an f64 run is redone
    /// in double-double. `None`: no check. Default: `Some(1e-3)` (three digits).
    pub max_relative_error: Option<f64>,
    /// Redo an f64 run in double-double when its estimated error exceeds
    /// `max_relative_error` (and say so in [`Diagnostics::precision_note`]). Default: false.
    pub auto_precision: bool,
    /// Compute the transformation to and from normal coordinates. Default: true.
    pub transform: bool,
    /// Newton iterations allowed. Default: 50.
    pub max_newton: usize,
    /// |∇H| allowed at a [`Point::Given`]. Default: 1e-8.
    pub equilibrium_tol: f64,
    /// Rotate each normal plane (Q_k, P_k) by these angles (radians) before the nonlinear
    /// normalisation. H̄ does not depend on them, so comparing runs with different angles
    /// measures rounding errors independently of the precision. Default: none.
    pub basis_rotation: Vec<f64>,
    /// f64 runs only: the Poisson brackets of the Lie series and the substitution into the
    /// complex coordinates are accumulated in double-double (error-free transformations of
    /// the f64 values, rounded once) for output degrees ≤ this. The low degrees are where
    /// rounding errors meet the most small divisors afterwards, and they are cheap.
    /// Default: 12; 0 = plain f64 arithmetic throughout.
    pub compensated_degree: usize,
    /// Called at each stage and before each degree of the Lie normalisation. Default: none.
    pub progress: Option<Progress>,
    /// Also transform H to this degree M ≥ N without normalising beyond N, and keep the norms
    /// of every term that is not a function of the actions ([`NormalForm::remainder`], the
    /// input of [`crate::bound`]); the coordinate maps are then computed to degree M − 1.
    /// Default: none.
    pub remainder_degree: Option<usize>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            order: 12,
            precision: Precision::F64,
            resonant: false,
            resonance_tol: 1e-6,
            error_estimate: ErrorEstimate::OtherPrecision,
            max_relative_error: Some(DEFAULT_MAX_RELATIVE_ERROR),
            auto_precision: false,
            transform: true,
            max_newton: 50,
            equilibrium_tol: 1e-8,
            basis_rotation: Vec::new(),
            compensated_degree: 12,
            progress: None,
            remainder_degree: None,
        }
    }
}

impl Options {
    /// Options with the given order and defaults otherwise.
    pub fn with_order(order: usize) -> Self {
        Options {
            order,
            ..Options::default()
        }
    }
    /// Sets the precision.
    pub fn precision(mut self, p: Precision) -> Self {
        self.precision = p;
        self
    }
    /// Sets resonant mode.
    pub fn resonant(mut self, r: bool) -> Self {
        self.resonant = r;
        self
    }
    /// Turns the error estimate on ([`ErrorEstimate::OtherPrecision`]) or off.
    pub fn error_estimate(mut self, e: bool) -> Self {
        self.error_estimate = if e {
            ErrorEstimate::OtherPrecision
        } else {
            ErrorEstimate::None
        };
        self
    }
    /// Sets the error estimate.
    pub fn estimate(mut self, e: ErrorEstimate) -> Self {
        self.error_estimate = e;
        self
    }
    /// Sets the limit on the estimated relative error of the coefficients (`None`: no check).
    pub fn max_relative_error(mut self, limit: Option<f64>) -> Self {
        self.max_relative_error = limit;
        self
    }
    /// Redo an f64 run in double-double when its estimated error exceeds the limit.
    pub fn auto_precision(mut self, a: bool) -> Self {
        self.auto_precision = a;
        self
    }
    /// Turns the coordinate transformation on or off.
    pub fn transform(mut self, t: bool) -> Self {
        self.transform = t;
        self
    }
    /// Keeps the remainder up to degree `m` ([`Options::remainder_degree`]).
    pub fn remainder_degree(mut self, m: usize) -> Self {
        self.remainder_degree = Some(m);
        self
    }
}

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
    fn of<R: Real>(x: R) -> Value {
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
    /// Evaluates the map.
    pub fn eval(&self, x: &[f64]) -> Vec<f64> {
        self.components.iter().map(|p| p.eval(x)).collect()
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
}

/// Internal result in the working precision.
struct Raw<R> {
    eq: crate::hamiltonian::Equilibrium<R>,
    energy: R,
    omega: Vec<R>,
    sigma: Vec<i8>,
    a: Mat<R>,
    ainv: Mat<R>,
    symplectic_residual: f64,
    diagonal_residual: f64,
    quadratic_residual: f64,
    /// dense over action exponents with 1 ≤ |a| ≤ N/2 (in table order of degree 2|a| with a=b)
    hbar: Vec<(Vec<u32>, R)>,
    hbar_imag: f64,
    degrees: Vec<DegreeError>,
    resonant_terms: Vec<ResonantTerm>,
    /// dense over all monomials of degrees 3…N
    generating: Vec<(Vec<u32>, usize, R)>,
    generating_imag: f64,
    divisors: Vec<SmallDivisor>,
    d4: Option<[R; 4]>,
    remainder: Option<Remainder>,
    to_normal: Option<Vec<Poly<R>>>,
    from_normal: Option<Vec<Poly<R>>>,
    transform_imag: f64,
    timings: Timings,
    table_bytes: usize,
}

fn widen<R: Real>(x: R) -> Dd {
    let (hi, lo) = x.hi_lo();
    Dd::from_parts(hi, lo)
}

/// The 2×2 blocks of a matrix acting on the variable pairs (k, n + k) only.
fn pair_blocks<T: Coeff>(m: &Mat<T>) -> Vec<[[T; 2]; 2]> {
    let n = m.len() / 2;
    (0..n)
        .map(|k| [[m[k][k], m[k][n + k]], [m[n + k][k], m[n + k][n + k]]])
        .collect()
}

/// H(z_eq + A C u) as a complex polynomial in u (C: the complexification): the real
/// substitution of A, then C pair by pair. The parts of degree ≤ `compensate_to` are
/// substituted in double-double and rounded once (their rounding errors are the ones the
/// small divisors amplify most), the others in R.
fn to_complex_coordinates<R: Real>(
    hz: &Poly<R>,
    a: &Mat<R>,
    compensate_to: usize,
) -> Poly<Complex<R>> {
    fn subst<T: Real>(p: &Poly<T>, a: &Mat<T>) -> Poly<Complex<T>> {
        let (c, _) = complexification::<T>(a.len() / 2);
        p.substitute_linear(a)
            .map(Complex::real)
            .substitute_pairs(&pair_blocks(&c))
    }
    let top = compensate_to.min(hz.max_degree());
    let mut high = hz.clone();
    for k in 0..=top {
        high.set_part(k, Vec::new());
    }
    let mut out = subst(&high, a);
    if compensate_to > 0 {
        let mut low = hz.map(widen);
        low.truncate(top);
        let a_dd: Mat<Dd> = a
            .iter()
            .map(|row| row.iter().map(|&x| widen(x)).collect())
            .collect();
        let low = subst(&low, &a_dd);
        let narrow = |x: Dd| R::from_hi_lo(x.hi, x.lo);
        for k in 0..=top {
            if let Some(p) = low.part(k) {
                out.set_part(
                    k,
                    p.iter()
                        .map(|z| Complex::new(narrow(z.re), narrow(z.im)))
                        .collect(),
                );
            }
        }
    }
    out
}

/// (−i)^m
fn minus_i_pow<R: Real>(m: usize) -> Complex<R> {
    match m % 4 {
        0 => Complex::real(R::one()),
        1 => Complex::new(R::zero(), -R::one()),
        2 => Complex::real(-R::one()),
        _ => Complex::new(R::zero(), R::one()),
    }
}

/// All m ∈ ℤⁿ with 0 < |m|₁ ≤ n_max and first nonzero entry positive, by increasing |m|₁.
fn integer_vectors(n: usize, n_max: usize) -> Vec<Vec<i32>> {
    let mut out = Vec::new();
    fn rec(m: &mut Vec<i32>, k: usize, left: i32, out: &mut Vec<Vec<i32>>) {
        if k == m.len() {
            if left == 0 {
                let first = m.iter().find(|&&x| x != 0);
                if first.is_some_and(|&x| x > 0) {
                    out.push(m.clone());
                }
            }
            return;
        }
        for v in -left..=left {
            m[k] = v;
            rec(m, k + 1, left - v.abs(), out);
        }
        m[k] = 0;
    }
    for total in 1..=n_max as i32 {
        let mut m = vec![0; n];
        rec(&mut m, 0, total, &mut out);
    }
    out
}

/// Real parts of a complex polynomial, and the largest imaginary part.
fn real_part<R: Real>(p: &Poly<Complex<R>>) -> (Poly<R>, f64) {
    let mut imag: f64 = 0.0;
    for (_, _, c) in p.terms() {
        imag = imag.max(c.im.abs().to_f64());
    }
    (p.map(|c| c.re), imag)
}

fn run<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    o: &Options,
) -> Result<Raw<R>, NormalFormError> {
    let t_start = Instant::now();
    let precision = if R::NAME == "f64" {
        Precision::F64
    } else {
        Precision::DoubleDouble
    };
    Progress::report(&o.progress, Stage::Start(precision));
    let n = h.n_dof();
    let d = 2 * n;
    let nmax = o.order;
    let top = o.remainder_degree.unwrap_or(nmax).max(nmax);
    let (start, given) = match point {
        Point::Given(v) => (v, true),
        Point::Newton(v) => (v, false),
    };
    if start.len() != d {
        return Err(NormalFormError::Invalid(format!(
            "point has {} components, expected {d}",
            start.len()
        )));
    }
    let start: Vec<R> = start.iter().map(|&x| R::from_f64(x)).collect();
    let eq = find_equilibrium(h, &start, o.max_newton)?;
    if given && eq.initial_gradient > o.equilibrium_tol {
        return Err(NormalFormError::NotAnEquilibrium {
            gradient_norm: eq.initial_gradient,
        });
    }
    let table = Arc::new(MonomialTable::new(d, top));
    let hz = taylor(h, &eq.z, &table);
    if !hz.is_finite() {
        return Err(NormalFormError::NonFinite("the Taylor expansion"));
    }
    let energy = hz.constant_term();
    let mut timings = Timings {
        taylor: t_start.elapsed().as_secs_f64(),
        ..Timings::default()
    };

    // linear normalisation
    let t = Instant::now();
    // in double-double whatever the working precision: a 2n×2n problem, and f64 frequencies
    // and A come out correctly rounded (the small divisors amplify every error in ω)
    let (_, s) = gradient_hessian(&hz);
    let s_dd: Mat<Dd> = s
        .iter()
        .map(|row| row.iter().map(|&x| widen(x)).collect())
        .collect();
    let lin_dd = linear_normalization(&s_dd, &o.basis_rotation)?;
    let lin = lin_dd.rounded(&s);
    let ainv = symplectic_inverse(&lin.a);
    let (_, ci) = complexification::<R>(n);
    let compensate_to = if R::NAME == "f64" {
        o.compensated_degree.min(nmax)
    } else {
        0
    };
    let mut hc = to_complex_coordinates(&hz, &lin.a, compensate_to);
    let lambda: Vec<Complex<R>> = lin
        .omega
        .iter()
        .zip(&lin.sigma)
        .map(|(&w, &sg)| Complex::new(R::zero(), w.scale(sg as f64)))
        .collect();
    let mut quadratic_residual: f64 = 0.0;
    let mut h2 = vec![Complex::zero(); table.count(2)];
    for k in 0..n {
        let mut e = vec![0u8; d];
        e[k] = 1;
        e[n + k] = 1;
        let (_, i) = table.index(&e).expect("x_k y_k");
        h2[i] = lambda[k];
    }
    if let Some(p) = hc.part(2) {
        for (x, y) in p.iter().zip(&h2) {
            quadratic_residual = quadratic_residual.max((*x - *y).magnitude());
        }
    }
    hc.set_part(2, h2);
    hc.set_part(1, Vec::new());
    timings.linear = t.elapsed().as_secs_f64();

    // Assumption 1′
    let omega_f: Vec<f64> = lin.omega.iter().map(|w| w.to_f64()).collect();
    let mdot = |m: &[i32]| -> R {
        m.iter()
            .zip(&lin.omega)
            .fold(R::zero(), |s, (&a, &w)| s + w.scale(a as f64))
    };
    if !o.resonant {
        for m in integer_vectors(n, nmax) {
            let v = mdot(&m);
            // a monomial x^a y^b with a − b = m has degree ≥ |m|₁ of the same parity, and the
            // Lie normalisation starts at degree 3: m first matters at this degree
            let norm1: usize = m.iter().map(|x| x.unsigned_abs() as usize).sum();
            let order = if norm1 < 3 { norm1 + 2 } else { norm1 };
            if order <= nmax && v.abs().to_f64() < o.resonance_tol {
                return Err(NormalFormError::Resonance {
                    m,
                    m_dot_omega: v.to_f64(),
                    order,
                    omega: omega_f,
                });
            }
        }
    }
    let tol = o.resonance_tol;
    let resonant_mode = o.resonant;
    let is_res = |m: &[i32]| resonant_mode && mdot(m).abs().to_f64() < tol;

    // Lie normalisation
    let t = Instant::now();
    let out = lie::normalize(
        hc,
        nmax,
        &lin_dd.omega,
        &lin.sigma,
        &is_res,
        compensate_to,
        &|degree| {
            Progress::report(
                &o.progress,
                Stage::Degree {
                    degree,
                    order: nmax,
                    precision,
                },
            )
        },
    );
    Progress::report(&o.progress, Stage::Transform);
    timings.lie = t.elapsed().as_secs_f64();

    // H̄ in actions: x_k y_k = −i I_k
    let mut hbar: Vec<(Vec<u32>, R)> = Vec::new();
    let mut hbar_imag: f64 = 0.0;
    let mut resonant_terms = Vec::new();
    let mut degrees = Vec::new();
    for k in (2..=nmax).step_by(2) {
        let mut dn = DegreeError {
            degree: k,
            max_coeff: 0.0,
            max_imag: 0.0,
            max_error: None,
            max_relative_error: None,
        };
        for i in 0..table.count(k) {
            let e = table.exponents(k, i);
            if e[..n] == e[n..] {
                let z = out.z.part(k).map_or(Complex::zero(), |p| p[i]);
                let v = z * minus_i_pow::<R>(k / 2);
                dn.max_imag = dn.max_imag.max(v.im.abs().to_f64());
                dn.max_coeff = dn.max_coeff.max(v.re.abs().to_f64());
                hbar.push((e[..n].iter().map(|&x| x as u32).collect(), v.re));
            }
        }
        hbar_imag = hbar_imag.max(dn.max_imag);
        degrees.push(dn);
    }
    let mut remainder = o.remainder_degree.map(|_| Remainder {
        degree: top,
        parts: Vec::new(),
    });
    for (k, i, zc) in out.z.terms() {
        let e = table.exponents(k, i);
        if k < 3 || e[..n] == e[n..] {
            continue;
        }
        if let Some(rem) = remainder.as_mut() {
            let c = zc.magnitude();
            if c != 0.0 {
                let split = |s: &[u8]| s.iter().map(|&x| x as i64).sum::<i64>();
                let radial = (split(&e[..n]) - split(&e[n..])).unsigned_abs() as f64 * c;
                match rem.parts.last_mut() {
                    Some(p) if p.degree == k => {
                        p.terms += 1;
                        p.sum_abs += c;
                        p.radial += radial;
                    }
                    _ => rem.parts.push(RemainderPart {
                        degree: k,
                        terms: 1,
                        sum_abs: c,
                        radial,
                    }),
                }
            }
        }
        if k <= nmax {
            let (re, im) = zc.to_f64();
            resonant_terms.push(ResonantTerm {
                x: e[..n].iter().map(|&x| x as u32).collect(),
                y: e[n..].iter().map(|&x| x as u32).collect(),
                re,
                im,
            });
        }
    }
    let divisors = out
        .divisors
        .iter()
        .map(|dv| SmallDivisor {
            m: dv.m.clone(),
            m_dot_omega: dv.value.to_f64(),
            order: dv.order,
            resonant: resonant_mode && dv.value.abs().to_f64() < tol,
        })
        .collect();

    // D4 (meaningless when resonant terms were kept: H̄ is then not a function of I alone)
    let d4 = if n == 2 && nmax >= 4 && resonant_terms.is_empty() {
        let get = |a: [u32; 2]| {
            hbar.iter()
                .find(|(e, _)| e[..] == a)
                .map_or(R::zero(), |(_, v)| *v)
        };
        let (a, b, cc) = (get([2, 0]).scale(2.0), get([1, 1]), get([0, 2]).scale(2.0));
        let nu1 = lin.omega[0].scale(lin.sigma[0] as f64);
        let nu2 = lin.omega[1].scale(lin.sigma[1] as f64);
        let d4 = a * nu2 * nu2 - (b * nu1 * nu2).scale(2.0) + cc * nu1 * nu1;
        Some([a, b, cc, d4])
    } else {
        None
    };

    // generating function in real form: G(u) with u = C⁻¹ w
    let t = Instant::now();
    let mut gsum = Poly::zero(table.clone());
    for (r, g) in out.generators.iter().enumerate() {
        if !g.is_empty() {
            gsum.set_part(r, g.clone());
        }
    }
    let (greal, generating_imag) = real_part(&gsum.substitute_pairs(&pair_blocks(&ci)));
    let greal_parts: Vec<Vec<R>> = (0..=nmax)
        .map(|r| greal.part(r).map_or(Vec::new(), |p| p.to_vec()))
        .collect();
    let mut generating = Vec::new();
    for r in 3..=nmax {
        for i in 0..table.count(r) {
            let v = greal.part(r).map_or(R::zero(), |p| p[i]);
            generating.push((
                table.exponents(r, i).iter().map(|&x| x as u32).collect(),
                r,
                v,
            ));
        }
    }

    // transformations
    let (mut to_normal, mut from_normal, transform_imag) = (None, None, 0.0f64);
    if o.transform && nmax >= 2 {
        let cap = top - 1;
        let fwd = lie::coordinate_maps(&table, &greal_parts, cap, true);
        let inv = lie::coordinate_maps(&table, &greal_parts, cap, false);
        // the generators in real form generate the same maps in (Q, P), since the
        // complexification is symplectic: the coordinate maps are real Lie series
        let from = fwd;
        let to = inv;
        to_normal = Some(to);
        from_normal = Some(from);
    }
    timings.transform = t.elapsed().as_secs_f64();
    timings.total = t_start.elapsed().as_secs_f64();
    Ok(Raw {
        eq,
        energy,
        omega: lin.omega.clone(),
        sigma: lin.sigma.clone(),
        a: lin.a.clone(),
        ainv,
        symplectic_residual: lin.symplectic_residual,
        diagonal_residual: lin.diagonal_residual,
        quadratic_residual,
        hbar,
        hbar_imag,
        degrees,
        resonant_terms,
        generating,
        generating_imag,
        divisors,
        d4,
        remainder,
        to_normal,
        from_normal,
        transform_imag,
        timings,
        table_bytes: table.memory_bytes(),
    })
}

fn to_f64_mat<R: Real>(m: &Mat<R>) -> Vec<Vec<f64>> {
    m.iter()
        .map(|r| r.iter().map(|x| x.to_f64()).collect())
        .collect()
}

fn assemble<R: Real, H: HamiltonianFn + ?Sized>(h: &H, raw: Raw<R>, o: &Options) -> NormalForm {
    let map = |ps: Option<Vec<Poly<R>>>| {
        ps.map(|v| PolyMap {
            components: v.iter().map(|p| p.map(|c| c.to_f64())).collect(),
        })
    };
    let d4 = raw.d4.map(|[a, b, c, d]| ArnoldMoser {
        a: Value::of(a),
        b: Value::of(b),
        c: Value::of(c),
        d4: Value::of(d),
    });
    let generating = raw
        .generating
        .iter()
        .map(|(e, r, v)| Term {
            exponents: e.clone(),
            degree: *r,
            coeff: Value::of(*v),
        })
        .collect();
    NormalForm {
        model: h.name(),
        n_dof: h.n_dof(),
        order: o.order,
        precision: o.precision,
        resonant: o.resonant,
        coordinates: h.coordinate_names(),
        equilibrium: raw.eq.z.iter().map(|&x| Value::of(x)).collect(),
        energy: Value::of(raw.energy),
        omega: raw.omega.iter().map(|&x| Value::of(x)).collect(),
        signs: raw.sigma.clone(),
        linear_map: to_f64_mat(&raw.a),
        hamiltonian: raw
            .hbar
            .iter()
            .map(|(e, v)| ActionTerm {
                exponents: e.clone(),
                degree: 2 * e.iter().sum::<u32>() as usize,
                coeff: Value::of(*v),
            })
            .collect(),
        resonant_terms: raw.resonant_terms,
        generating_function: generating,
        small_divisors: raw.divisors,
        d4,
        diagnostics: Diagnostics {
            newton_iterations: raw.eq.iterations,
            gradient_norm: raw.eq.gradient,
            symplectic_residual: raw.symplectic_residual,
            diagonal_residual: raw.diagonal_residual,
            quadratic_residual: raw.quadratic_residual,
            hbar_imag_residual: raw.hbar_imag,
            hbar_degrees: raw.degrees,
            generating_imag_residual: raw.generating_imag,
            transform_imag_residual: raw.transform_imag,
            error_method: None,
            precision_note: None,
            amplification: None,
            timings: raw.timings,
            table_bytes: raw.table_bytes,
        },
        remainder: raw.remainder,
        to_normal_map: map(raw.to_normal),
        from_normal_map: map(raw.from_normal),
        linear_inverse: to_f64_mat(&raw.ainv),
    }
}

fn run_assembled<H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    o: &Options,
) -> Result<NormalForm, NormalFormError> {
    match o.precision {
        Precision::F64 => run::<f64, H>(h, point, o).map(|r| assemble(h, r, o)),
        Precision::DoubleDouble => run::<Dd, H>(h, point, o).map(|r| assemble(h, r, o)),
    }
}

/// Checks the numeric options (ranges, finiteness), naming the field.
fn validate_options(o: &Options) -> Result<(), NormalFormError> {
    let bad = |msg: String| Err(NormalFormError::Invalid(msg));
    if o.order < 2 || o.order > MAX_ORDER {
        return bad(format!("order {} outside 2…{MAX_ORDER}", o.order));
    }
    if !(o.resonance_tol.is_finite() && o.resonance_tol >= 0.0) {
        return bad(format!(
            "resonance_tol = {}: must be a finite number ≥ 0",
            o.resonance_tol
        ));
    }
    if !(o.equilibrium_tol.is_finite() && o.equilibrium_tol > 0.0) {
        return bad(format!(
            "equilibrium_tol = {}: must be a finite number > 0",
            o.equilibrium_tol
        ));
    }
    if let Some(x) = o.basis_rotation.iter().find(|x| !x.is_finite()) {
        return bad(format!(
            "basis_rotation contains {x}: angles must be finite"
        ));
    }
    if let Some(x) = o.max_relative_error {
        if !(x > 0.0 && x <= 1.0) {
            return bad(format!(
                "max_relative_error = {x}: must be in (0, 1] (or None for no check)"
            ));
        }
    }
    if let Some(m) = o.remainder_degree {
        if m < o.order || m > MAX_ORDER {
            return bad(format!(
                "remainder_degree {m} outside {}…{MAX_ORDER} (at least the order)",
                o.order
            ));
        }
    }
    if o.max_newton == 0 {
        return bad("max_newton = 0: at least one Newton iteration is needed".into());
    }
    Ok(())
}

/// The largest truncation order accepted.
pub const MAX_ORDER: usize = 120;

/// Computes the Birkhoff normal form of `h` at the equilibrium found from `point`.
///
/// Steps: Newton on ∇H = 0 (in the working precision) → Taylor expansion of H to degree N
/// by jet arithmetic → symplectic diagonalisation of H₂ (fails with
/// [`NormalFormError::NotElliptic`]) → Assumption 1′ check (fails with
/// [`NormalFormError::Resonance`] unless `resonant`) → Lie-series normalisation → real
/// forms of H̄, the generators and the transformation. With `error_estimate` the other
/// precision is run too (without the transformation) and each coefficient gets
/// `error = |c_f64 − c_dd|` (f64 run) or `|c_f64 − c_dd|·2⁻⁵¹` (double-double run: the same
/// amplification of rounding errors acting on a unit roundoff 2⁵¹ times smaller).
pub fn normalize<H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    options: &Options,
) -> Result<NormalForm, NormalFormError> {
    validate_options(options)?;
    let mut nf = run_assembled(h, point, options)?;
    estimate_errors(&mut nf, h, point, options);
    if let Some(limit) = options.max_relative_error {
        if let Some((degree, err)) = inaccurate_degree(&nf, limit) {
            if options.auto_precision && options.precision == Precision::F64 {
                Progress::report(&options.progress, Stage::Rerun(Precision::DoubleDouble));
                let f64_time = nf.diagnostics.timings.total + nf.diagnostics.timings.error_estimate;
                let dd_opts = Options {
                    precision: Precision::DoubleDouble,
                    ..options.clone()
                };
                let f64_nf = nf;
                nf = run_assembled(h, point, &dd_opts)?;
                // the f64 run is the other-precision estimate of the dd run, for free
                attach_errors(&mut nf, &f64_nf, 2f64.powi(-51), true);
                nf.diagnostics.error_method = Some("|f64 - dd| * 2^-51".into());
                nf.diagnostics.precision_note = Some(format!(
                    "f64 is not enough here: a coefficient of degree {degree} of Hbar had an \
                     estimated relative error of {err:.1e} in f64 (limit {limit:.0e}), so the \
                     normal form was recomputed in double-double ({f64_time:.3} s spent in f64)"
                ));
                fill_degree_errors(&mut nf);
                if let Some((degree, err)) = inaccurate_degree(&nf, limit) {
                    return Err(precision_lost(Precision::DoubleDouble, degree, err, limit));
                }
            } else {
                return Err(precision_lost(options.precision, degree, err, limit));
            }
        }
    }
    prune_generating(&mut nf);
    Progress::report(&options.progress, Stage::Done);
    Ok(nf)
}

/// Attaches the error estimate `options.error_estimate` to `nf` (computed with `options`).
fn estimate_errors<H: HamiltonianFn + ?Sized>(
    nf: &mut NormalForm,
    h: &H,
    point: &Point,
    options: &Options,
) {
    let t = Instant::now();
    let (other_opts, factor, method) = match options.error_estimate {
        ErrorEstimate::None => return,
        ErrorEstimate::Rotation => {
            // angles far from any symmetry of the problem
            let rotation: Vec<f64> = (0..nf.n_dof)
                .map(|k| 0.7 + 1.3 * k as f64 * if k % 2 == 0 { 1.0 } else { -1.0 })
                .collect();
            (
                Options {
                    basis_rotation: rotation,
                    ..options.clone()
                },
                1.0,
                "|c - c(normal planes rotated)|",
            )
        }
        ErrorEstimate::OtherPrecision => match options.precision {
            Precision::F64 => (
                Options {
                    precision: Precision::DoubleDouble,
                    ..options.clone()
                },
                1.0,
                "|f64 - dd|",
            ),
            Precision::DoubleDouble => (
                Options {
                    precision: Precision::F64,
                    ..options.clone()
                },
                2f64.powi(-51),
                "|f64 - dd| * 2^-51",
            ),
        },
    };
    let other_opts = Options {
        error_estimate: ErrorEstimate::None,
        transform: false,
        remainder_degree: None,
        ..other_opts
    };
    Progress::report(&options.progress, Stage::Rerun(other_opts.precision));
    if let Ok(other) = run_assembled(h, point, &other_opts) {
        attach_errors(
            nf,
            &other,
            factor,
            options.error_estimate != ErrorEstimate::Rotation,
        );
        nf.diagnostics.error_method = Some(method.into());
        fill_degree_errors(nf);
    }
    nf.diagnostics.timings.error_estimate = t.elapsed().as_secs_f64();
}

/// Coefficients smaller than this many unit roundoffs of the largest of their degree are
/// measured against that size in [`DegreeError::max_relative_error`].
const RESOLVABLE: f64 = 1e3;

/// `Options::max_relative_error` by default: three correct digits in every coefficient.
pub const DEFAULT_MAX_RELATIVE_ERROR: f64 = 1e-3;

/// [`DegreeError::max_error`] and [`DegreeError::max_relative_error`] from the estimates.
fn fill_degree_errors(nf: &mut NormalForm) {
    let unit = match nf.precision {
        Precision::F64 => f64::EPSILON / 2.0,
        Precision::DoubleDouble => Dd::EPSILON,
    };
    for d in nf.diagnostics.hbar_degrees.iter_mut() {
        let floor = RESOLVABLE * unit * d.max_coeff;
        let (mut abs, mut rel, mut any) = (0.0f64, 0.0f64, false);
        for t in nf.hamiltonian.iter().filter(|t| t.degree == d.degree) {
            if let Some(e) = t.coeff.error {
                any = true;
                if e == 0.0 && t.coeff.value == 0.0 {
                    continue; // an exact zero
                }
                abs = abs.max(e);
                let m = t.coeff.value.abs().max(floor);
                rel = rel.max(if m > 0.0 { e / m } else { 0.0 });
            }
        }
        if any {
            d.max_error = Some(abs);
            d.max_relative_error = Some(rel);
        }
    }
}

/// The lowest degree of H̄ with an estimated relative error above `limit`, with that error.
fn inaccurate_degree(nf: &NormalForm, limit: f64) -> Option<(usize, f64)> {
    nf.diagnostics
        .hbar_degrees
        .iter()
        .filter_map(|d| d.max_relative_error.map(|e| (d.degree, e)))
        .find(|&(_, e)| e > limit || e.is_nan())
}

fn precision_lost(precision: Precision, degree: usize, err: f64, limit: f64) -> NormalFormError {
    let below = degree.saturating_sub(1);
    NormalFormError::PrecisionLost {
        precision: precision.to_string(),
        degree,
        relative_error: err,
        limit,
        advice: match precision {
            Precision::F64 => {
                format!("use `--precision dd` (or `auto`), or `--order {below}` or lower")
            }
            Precision::DoubleDouble => format!("use `--order {below}` or lower"),
        },
    }
}

/// Drops generator coefficients that are rounding noise (the real form of a complex
/// polynomial has exact zeros that come out as ~ε·max).
fn prune_generating(nf: &mut NormalForm) {
    let eps = match nf.precision {
        Precision::F64 => f64::EPSILON,
        Precision::DoubleDouble => Dd::EPSILON,
    };
    let mut max_by_degree = vec![0.0f64; nf.order + 1];
    for t in &nf.generating_function {
        max_by_degree[t.degree] = max_by_degree[t.degree].max(t.coeff.value.abs());
    }
    nf.generating_function
        .retain(|t| t.coeff.value.abs() > 1e3 * eps * max_by_degree[t.degree]);
}

fn err(a: &Value, b: &Value, factor: f64) -> f64 {
    let diff = ((a.value - b.value) + (a.lo - b.lo)).abs() * factor;
    // never claim better than the working precision
    let floor = if factor < 1.0 {
        4.0 * Dd::EPSILON
    } else {
        f64::EPSILON / 2.0
    } * a.value.abs();
    diff.max(floor)
}

/// Errors from a second run `other`: `|difference|·factor`. With `generators = false` (a run
/// with rotated normal planes) the generating function, which depends on the rotation, gets
/// none.
fn attach_errors(nf: &mut NormalForm, other: &NormalForm, factor: f64, generators: bool) {
    let pairs = |a: &mut [Value], b: &[Value]| {
        for (x, y) in a.iter_mut().zip(b) {
            x.error = Some(err(x, y, factor));
        }
    };
    pairs(&mut nf.equilibrium, &other.equilibrium);
    pairs(&mut nf.omega, &other.omega);
    nf.energy.error = Some(err(&nf.energy, &other.energy, factor));
    let mut amp: f64 = 0.0;
    for (x, y) in nf.hamiltonian.iter_mut().zip(&other.hamiltonian) {
        let e = err(&x.coeff, &y.coeff, factor);
        x.coeff.error = Some(e);
        let (f, dd) = if factor == 1.0 {
            (&x.coeff, &y.coeff)
        } else {
            (&y.coeff, &x.coeff)
        };
        if dd.value != 0.0 {
            amp = amp
                .max(((f.value - dd.value) - dd.lo).abs() / (dd.value.abs() * f64::EPSILON / 2.0));
        }
    }
    nf.diagnostics.amplification = Some(amp);
    if generators {
        for (x, y) in nf
            .generating_function
            .iter_mut()
            .zip(&other.generating_function)
        {
            x.coeff.error = Some(err(&x.coeff, &y.coeff, factor));
        }
    }
    if let (Some(a), Some(b)) = (nf.d4.as_mut(), other.d4.as_ref()) {
        a.a.error = Some(err(&a.a, &b.a, factor));
        a.b.error = Some(err(&a.b, &b.b, factor));
        a.c.error = Some(err(&a.c, &b.c, factor));
        a.d4.error = Some(err(&a.d4, &b.d4, factor));
    }
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
