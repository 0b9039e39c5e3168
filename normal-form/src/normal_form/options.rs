//! The options of [`normalize`](super::normalize): precision, progress stages, error
//! estimate, point, and their validation.

#[cfg(doc)]
use super::{normalize, DegreeError, Diagnostics, NormalForm};
use crate::error::NormalFormError;
use serde::Serialize;
use std::sync::Arc;

/// Working precision of the series algebra.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Precision {
    /// IEEE double.
    #[serde(rename = "f64")]
    F64,
    /// Double-double (≈ 32 digits), 1.2–3.3× the f64 time (see the crate docs).
    #[serde(rename = "dd")]
    DoubleDouble,
    /// Quad-double (≈ 64 digits, [`Qd`](crate::Qd)), for orders where double-double loses
    /// the high coefficients.
    #[serde(rename = "qd")]
    QuadDouble,
}

impl Precision {
    /// The precision of the scalar `R`.
    pub fn of<R: crate::Real>() -> Precision {
        match R::NAME {
            "f64" => Precision::F64,
            "dd" => Precision::DoubleDouble,
            _ => Precision::QuadDouble,
        }
    }
    /// Unit roundoff.
    pub fn epsilon(self) -> f64 {
        use crate::Real;
        match self {
            Precision::F64 => f64::EPSILON / 2.0,
            Precision::DoubleDouble => crate::Dd::EPSILON,
            Precision::QuadDouble => crate::Qd::EPSILON,
        }
    }
    /// The next wider precision, if any.
    pub fn wider(self) -> Option<Precision> {
        match self {
            Precision::F64 => Some(Precision::DoubleDouble),
            Precision::DoubleDouble => Some(Precision::QuadDouble),
            Precision::QuadDouble => None,
        }
    }
}

impl std::str::FromStr for Precision {
    type Err = NormalFormError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "f64" | "double" => Ok(Precision::F64),
            "dd" | "double-double" => Ok(Precision::DoubleDouble),
            "qd" | "quad-double" => Ok(Precision::QuadDouble),
            _ => Err(NormalFormError::Invalid(format!(
                "unknown precision `{s}` (expected `f64`, `dd` or `qd`)"
            ))),
        }
    }
}

impl std::fmt::Display for Precision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Precision::F64 => "f64",
            Precision::DoubleDouble => "dd",
            Precision::QuadDouble => "qd",
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
    pub(super) fn report(p: &Option<Progress>, stage: Stage) {
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
    /// With `transform`: also the map from the normal coordinates back
    /// ([`NormalForm::from_normal_map`]); the tube bounds need only the forward one, and each
    /// costs as much as the normalisation at high order. Default: true.
    pub inverse_transform: bool,
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
            inverse_transform: true,
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

/// Checks the numeric options (ranges, finiteness), naming the field.
pub(super) fn validate_options(o: &Options) -> Result<(), NormalFormError> {
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

/// `Options::max_relative_error` by default: three correct digits in every coefficient.
pub const DEFAULT_MAX_RELATIVE_ERROR: f64 = 1e-3;
