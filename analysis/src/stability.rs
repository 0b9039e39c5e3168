//! `lasalle stability` as one library call: the analysis chosen by the model's structure, its
//! result typed ([`StabilityReport`]) and as the JSON the command prints
//! ([`StabilityReport::to_json`]).
//!
//! - a Lie–Poisson model on so(3)* ([`lie_poisson`](mod@crate::lie_poisson)): the equilibria on a
//!   Casimir level (or one given point) and the verdict ranges of every branch of equilibria
//!   over a range of levels ([`LiePoissonReport`]);
//! - a canonical Hamiltonian model ([`canonical`](mod@crate::canonical)): the normal-form verdicts
//!   and the time bounds of tubes ([`CanonicalReport`]);
//! - a model without Hamiltonian structure ([`attraction`](mod@crate::attraction)): the domain of
//!   attraction of a planar equilibrium ([`AttractionReport`]).
//!
//! Each analysis takes the model with its current parameter values. Settings that name a
//! front end's flags (`--at` on the command line, `at=` in Python) are named neutrally here;
//! the errors a front end may phrase its own way are variants of [`ReportError`].

use std::fmt;

use lasalle_exec::LoadedModel;
use lasalle_model::Structure;
use lasalle_normal_form::bound::Metric;
use lasalle_normal_form::ModelPoint;
use lasalle_runtime::{ModelInfo, Parameters};
use serde_json::{json, Value};

use crate::attraction::{
    self, Analysis, AttractionError, Estimate, LyapunovFunction, Mat2, PlanarSystem, Saddle,
};
use crate::canonical::{self, CanonicalOptions, CanonicalReport, SEARCH_MAX_ORDER};
use crate::lie_poisson::{self, Equilibrium, Level, StabilityError, Sweep};

/// The analysis a model gets, by its structure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StabilityKind {
    /// `hamiltonian … structure lie_poisson_so3(P)`: energy–Casimir.
    LiePoisson,
    /// `hamiltonian … structure canonical(q, p)`: Birkhoff normal form and tube bounds.
    Canonical,
    /// No Hamiltonian structure: domains of attraction of a planar dissipative field.
    Attraction,
}

impl StabilityKind {
    /// The analysis of `model`.
    pub fn of(model: &LoadedModel) -> Result<StabilityKind, ReportError> {
        Ok(
            match lowered(model)?.hamiltonian.as_ref().map(|h| &h.structure) {
                Some(Structure::LiePoissonSo3 { .. }) => StabilityKind::LiePoisson,
                Some(Structure::Canonical { .. }) => StabilityKind::Canonical,
                None => StabilityKind::Attraction,
            },
        )
    }
}

/// What to compute; each analysis reads its own settings.
#[derive(Clone, Debug)]
pub struct StabilityOptions {
    /// Lie–Poisson: the Casimir level |P| = ρ whose equilibria are listed (default: |P| of the
    /// model's first named point, else 1). Excludes `at`.
    pub casimir: Option<f64>,
    /// Lie–Poisson (P₁, P₂, P₃) and planar (x₁, x₂) models: analyse this point (an
    /// equilibrium) instead; planar default: the first named point that is an asymptotically
    /// stable equilibrium.
    pub at: Option<Vec<f64>>,
    /// Lie–Poisson: the range of Casimir levels of the family summary (default: up to three
    /// times the largest of 1, |parameters| and the level).
    pub range: Option<(f64, f64)>,
    /// Lie–Poisson: the number of levels of the family summary.
    pub levels: usize,
    /// Planar models: a scalar `let` of the model to use as a Lyapunov function too (default:
    /// `energy`, if the model has it).
    pub lyapunov: Option<String>,
    /// Planar models: the search radius (default: chosen from the Lyapunov-equation
    /// estimate).
    pub radius: Option<f64>,
    /// Canonical models: the equilibrium, tubes, orders, metric and validation.
    pub canonical: CanonicalOptions,
}

impl Default for StabilityOptions {
    /// The command's defaults: 121 levels, the verdicts of a canonical model at its first
    /// point with the order search, Euclidean distances.
    fn default() -> Self {
        StabilityOptions {
            casimir: None,
            at: None,
            range: None,
            levels: 121,
            lyapunov: None,
            radius: None,
            canonical: CanonicalOptions {
                point: ModelPoint::Auto,
                tubes: Vec::new(),
                max_order: SEARCH_MAX_ORDER,
                optimal: true,
                for_time: Vec::new(),
                outer_ratio: 2.0,
                remainder_degree: None,
                metric: Metric::Euclidean,
                validate: None,
                certified: false,
                budget: Some(canonical::SEARCH_BUDGET_SECONDS),
                progress: None,
            },
        }
    }
}

/// Why an analysis could not run.
#[derive(Clone, Debug, PartialEq)]
pub enum ReportError {
    /// A setting out of range, or one the model's analysis does not take.
    Options(String),
    /// No named point of a planar model is an asymptotically stable equilibrium (each entry
    /// says why a point is not); the front end asks for the point its own way.
    NoEquilibrium {
        /// Why each named point was passed over.
        tried: Vec<String>,
    },
    /// The Lie–Poisson analysis failed.
    LiePoisson(StabilityError),
    /// The domain-of-attraction analysis failed.
    Attraction(AttractionError),
    /// The canonical analysis failed, or the integration of a saddle's stable manifold.
    Failed(String),
}

impl ReportError {
    /// The message, with `how` telling how to give the equilibrium of a planar model (the
    /// command line: "with --at x1,x2").
    pub fn message(&self, how: &str) -> String {
        match self {
            ReportError::NoEquilibrium { tried } => format!(
                "no named point of the model is an asymptotically stable equilibrium ({}); give \
                 one {how}",
                if tried.is_empty() {
                    "it has none".to_string()
                } else {
                    tried.join(", ")
                }
            ),
            other => other.to_string(),
        }
    }
}

impl fmt::Display for ReportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReportError::Options(m) | ReportError::Failed(m) => f.write_str(m),
            ReportError::NoEquilibrium { .. } => {
                f.write_str(&self.message("as the point to analyse"))
            }
            ReportError::LiePoisson(e) => write!(f, "{e}"),
            ReportError::Attraction(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for ReportError {}

impl From<StabilityError> for ReportError {
    fn from(e: StabilityError) -> Self {
        ReportError::LiePoisson(e)
    }
}

impl From<AttractionError> for ReportError {
    fn from(e: AttractionError) -> Self {
        ReportError::Attraction(e)
    }
}

/// The result of the analysis a model's structure chooses ([`analyse`]).
#[derive(Clone, Debug)]
pub enum StabilityReport {
    /// A Lie–Poisson model.
    LiePoisson(LiePoissonReport),
    /// A canonical Hamiltonian model.
    Canonical(CanonicalReport),
    /// A model without Hamiltonian structure.
    Attraction(AttractionReport),
}

impl StabilityReport {
    /// What `lasalle stability --format json` prints.
    pub fn to_json(&self) -> Value {
        match self {
            StabilityReport::LiePoisson(r) => r.to_json(),
            // the report's own serialisation (it derives it) cannot fail
            StabilityReport::Canonical(r) => serde_json::to_value(r).unwrap_or(Value::Null),
            StabilityReport::Attraction(r) => r.to_json(),
        }
    }
}

/// Runs the analysis of `model` (with its current parameters) that its structure chooses;
/// `file` names the model file in the report.
pub fn analyse(
    model: &LoadedModel,
    file: &str,
    opts: &StabilityOptions,
) -> Result<StabilityReport, ReportError> {
    Ok(match StabilityKind::of(model)? {
        StabilityKind::LiePoisson => StabilityReport::LiePoisson(lie_poisson(model, file, opts)?),
        StabilityKind::Canonical => StabilityReport::Canonical(canonical(model, opts)?),
        StabilityKind::Attraction => StabilityReport::Attraction(attraction(model, file, opts)?),
    })
}

/// The lowered model the analyses read (for a model loaded with families kept as loops, the
/// unrolled one).
fn lowered(model: &LoadedModel) -> Result<&lasalle_model::Model, ReportError> {
    model
        .model()
        .map_err(|e| ReportError::Failed(e.to_string()))
}

/// A model's parameters with their current values, in declaration order.
fn parameters(model: &LoadedModel) -> Vec<(String, Vec<f64>)> {
    model
        .param_slots()
        .iter()
        .map(|p| (p.name.to_string(), model.param(p.name).unwrap_or_default()))
        .collect()
}

/// The Lie–Poisson analysis: the equilibria on a Casimir level or at a point, and the
/// branches of equilibria over a range of levels.
#[derive(Clone, Debug)]
pub struct LiePoissonReport {
    /// The model's name.
    pub model: String,
    /// The model file.
    pub file: String,
    /// The parameters, in declaration order.
    pub params: Vec<(String, Vec<f64>)>,
    /// The equilibrium at the given point ([`StabilityOptions::at`]).
    pub point: Option<Equilibrium>,
    /// The equilibria on the Casimir level (without a given point).
    pub level: Option<Level>,
    /// The branches over the range of levels.
    pub sweep: Sweep,
}

impl LiePoissonReport {
    /// What `lasalle stability --format json` prints for a Lie–Poisson model.
    pub fn to_json(&self) -> Value {
        json!({
            "model": self.model,
            "file": self.file,
            "params": self.params.iter().map(|(n, v)| (n.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
            "casimir": "C = |P|^2/2; lambda: grad H + lambda P = 0",
            "point": self.point,
            "level": self.level,
            "sweep": self.sweep,
        })
    }
}

/// The Lie–Poisson analysis of `model` ([`LiePoissonReport`]).
pub fn lie_poisson(
    model: &LoadedModel,
    file: &str,
    opts: &StabilityOptions,
) -> Result<LiePoissonReport, ReportError> {
    let p_index = match lowered(model)?.hamiltonian.as_ref().map(|h| &h.structure) {
        Some(Structure::LiePoissonSo3 { p }) => p.clone(),
        _ => {
            return Err(ReportError::Options(format!(
                "`{}` is not a Lie–Poisson model on so(3)*",
                model.model_name()
            )))
        }
    };
    let at = match &opts.at {
        Some(v) if v.len() != 3 => {
            return Err(ReportError::Options(format!(
                "the point needs 3 numbers P1,P2,P3, got {}",
                v.len()
            )))
        }
        Some(v) => Some([v[0], v[1], v[2]]),
        None => None,
    };
    if opts.casimir.is_some() && at.is_some() {
        return Err(ReportError::Options(
            "a Casimir level and a point exclude each other".into(),
        ));
    }
    let sys = lie_poisson::system(model)?;
    let lp = lie_poisson::Options::default();
    let params = parameters(model);
    let level_rho = match (opts.casimir, at) {
        (Some(r), _) => r,
        (None, Some(p)) => (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt(),
        (None, None) => model
            .point_names()
            .first()
            .and_then(|n| model.point(n))
            .map(|x| p_index.iter().map(|&i| x[i] * x[i]).sum::<f64>().sqrt())
            .filter(|r| *r > 0.0)
            .unwrap_or(1.0),
    };
    let (lo, hi) = match opts.range {
        Some((a, b)) if !(a > 0.0 && b > a && b.is_finite()) => {
            return Err(ReportError::Options(format!(
                "the range of Casimir levels must be a:b with 0 < a < b, got {a}:{b}"
            )))
        }
        Some(r) => r,
        None => {
            let big = params
                .iter()
                .flat_map(|(_, v)| v.iter().map(|x| x.abs()))
                .fold(level_rho.max(1.0), f64::max);
            (3.0 * big / 120.0, 3.0 * big)
        }
    };
    let point = match at {
        Some(p) => Some(lie_poisson::analyse_point(&sys, p, &lp)?),
        None => None,
    };
    let level = match point {
        Some(_) => None,
        None => Some(lie_poisson::analyse_level(&sys, level_rho, &lp)?),
    };
    let sweep = lie_poisson::sweep(&sys, lo, hi, opts.levels, &lp)?;
    Ok(LiePoissonReport {
        model: model.model_name().to_string(),
        file: file.to_string(),
        params,
        point,
        level,
        sweep,
    })
}

/// The canonical analysis of `model` with its current scalar parameters
/// ([`canonical::analyse`]).
pub fn canonical(
    model: &LoadedModel,
    opts: &StabilityOptions,
) -> Result<CanonicalReport, ReportError> {
    canonical_with(model, opts, &mut |_| {})
}

/// [`canonical()`] telling `on_event` the verdict and each order's rows as they come
/// ([`canonical::analyse_with`]).
pub fn canonical_with(
    model: &LoadedModel,
    opts: &StabilityOptions,
    on_event: &mut dyn FnMut(canonical::SearchEvent<'_>),
) -> Result<CanonicalReport, ReportError> {
    let params: Vec<(String, f64)> = parameters(model)
        .into_iter()
        .filter(|(_, v)| v.len() == 1)
        .map(|(n, v)| (n, v[0]))
        .collect();
    opts.canonical.validate().map_err(ReportError::Options)?;
    canonical::analyse_with(lowered(model)?, &params, &opts.canonical, on_event)
        .map_err(ReportError::Failed)
}

/// The domain of attraction of a planar equilibrium.
#[derive(Clone, Debug)]
pub enum AttractionReport {
    /// The estimates are bounded (V̇ > 0 somewhere within the search radius).
    Bounded(Box<BoundedAttraction>),
    /// V̇ < 0 at every sample out to the largest search radius: no boundary was found (a
    /// linear field's domain is the whole plane).
    Unbounded {
        /// The model's name.
        model: String,
        /// The model file.
        file: String,
        /// The equilibrium.
        equilibrium: [f64; 2],
        /// The largest search radius.
        radius: f64,
    },
}

/// A bounded domain-of-attraction analysis: the estimates, the saddles and the boundary along
/// the optimal ellipse's axes.
#[derive(Clone, Debug)]
pub struct BoundedAttraction {
    /// The model's name.
    pub model: String,
    /// The model file.
    pub file: String,
    /// The parameters, in declaration order.
    pub params: Vec<(String, Vec<f64>)>,
    /// The field at the equilibrium.
    pub system: PlanarSystem,
    /// The sampling used.
    pub options: attraction::Options,
    /// The quadratic estimates.
    pub analysis: Analysis,
    /// The estimate of the model's `let` Lyapunov function, by its name.
    pub by_let: Option<(String, Estimate)>,
    /// The saddles within the search radius, with their stable manifolds.
    pub saddles: Vec<Saddle>,
    /// Along the optimal ellipse's principal axes (both ways): the direction, the estimate's
    /// radius and the distance to the nearest stable manifold (`None`: beyond the search
    /// radius).
    pub axes: Vec<([f64; 2], f64, Option<f64>)>,
}

impl AttractionReport {
    /// What `lasalle stability --format json` prints for a planar model.
    pub fn to_json(&self) -> Value {
        match self {
            AttractionReport::Unbounded {
                model,
                file,
                equilibrium,
                radius,
            } => json!({
                "model": model,
                "file": file,
                "equilibrium": equilibrium,
                "bounded": false,
                "radius": radius,
            }),
            AttractionReport::Bounded(b) => {
                let params: serde_json::Map<String, Value> = b
                    .params
                    .iter()
                    .map(|(n, v)| {
                        let v = match v.as_slice() {
                            [x] => json!(x),
                            _ => json!(v),
                        };
                        (n.clone(), v)
                    })
                    .collect();
                json!({
                    "model": b.model,
                    "file": b.file,
                    "params": params,
                    "analysis": b.analysis,
                    "lyapunov_let": b.by_let.as_ref().map(|(n, e)| json!({"name": n, "estimate": e})),
                    "saddles": b.saddles.iter().map(|s| json!({"x": s.x, "eigenvalues": s.eigenvalues})).collect::<Vec<_>>(),
                    "axes": b.axes.iter().map(|(u, r, m)| json!({"direction": u, "estimate": r, "stable_manifold": m})).collect::<Vec<_>>(),
                })
            }
        }
    }
}

/// The equilibrium: `at`, else the first named point of the model that is an equilibrium
/// with a Hurwitz linearisation.
fn planar_equilibrium(
    model: &LoadedModel,
    at: Option<&[f64]>,
) -> Result<PlanarSystem, ReportError> {
    if let Some(x) = at {
        if x.len() != model.dim() {
            return Err(ReportError::Options(format!(
                "the point needs {} numbers (the state), got {}",
                model.dim(),
                x.len()
            )));
        }
        return Ok(PlanarSystem::new(lowered(model)?, model.params(), x)?);
    }
    let mut tried = Vec::new();
    let lowered = lowered(model)?;
    for name in model.point_names() {
        let x = model.point(name).unwrap_or_default();
        match PlanarSystem::new(lowered, model.params(), &x) {
            Ok(sys) if sys.linearisation().is_ok() => return Ok(sys),
            Ok(_) => tried.push(format!("`{name}` is not asymptotically stable")),
            Err(e @ AttractionError::NotPlanar { .. }) => return Err(e.into()),
            Err(_) => tried.push(format!("`{name}` is not an equilibrium")),
        }
    }
    Err(ReportError::NoEquilibrium { tried })
}

fn quad(p: Mat2, u: [f64; 2]) -> f64 {
    p[0][0] * u[0] * u[0] + 2.0 * p[0][1] * u[0] * u[1] + p[1][1] * u[1] * u[1]
}

/// Unit eigenvectors of a symmetric 2×2 P with the values uᵀPu (its eigenvalues).
pub fn principal_axes(p: Mat2) -> [([f64; 2], f64); 2] {
    let (a, b, c) = (p[0][0], p[0][1], p[1][1]);
    let t = 0.5 * (2.0 * b).atan2(a - c);
    let (u, v) = ([t.cos(), t.sin()], [-t.sin(), t.cos()]);
    [(u, quad(p, u)), (v, quad(p, v))]
}

/// The domain-of-attraction analysis of a planar `model` ([`AttractionReport`]).
pub fn attraction(
    model: &LoadedModel,
    file: &str,
    opts: &StabilityOptions,
) -> Result<AttractionReport, ReportError> {
    let sys = planar_equilibrium(model, opts.at.as_deref())?;
    let options = attraction::Options {
        radius: opts.radius,
        ..attraction::Options::default()
    };
    let analysis = match sys.analyse(&options) {
        Err(AttractionError::Unbounded { radius }) => {
            return Ok(AttractionReport::Unbounded {
                model: sys.name().to_string(),
                file: file.to_string(),
                equilibrium: sys.equilibrium(),
                radius,
            })
        }
        other => other?,
    };
    let radius = analysis.radius;
    let let_name = match &opts.lyapunov {
        Some(n) => Some(n.clone()),
        None => sys.scalar_lets().into_iter().find(|n| n == "energy"),
    };
    let by_let = match let_name {
        Some(n) => {
            let e = sys.estimate(LyapunovFunction::Let(&n), radius, &options)?;
            Some((n, e))
        }
        None => None,
    };
    let saddles =
        attraction::saddles_with_manifolds(&sys, model, radius).map_err(ReportError::Failed)?;
    let xe = analysis.equilibrium;
    // the true boundary along the optimal ellipse's principal axes
    let axes = principal_axes(analysis.optimal.p)
        .into_iter()
        .flat_map(|(u, lambda)| [(u, lambda), ([-u[0], -u[1]], lambda)])
        .map(|(u, lambda)| {
            let r = (analysis.optimal.estimate.level / lambda).sqrt();
            (u, r, attraction::manifold_distance(&saddles, xe, u))
        })
        .collect();
    Ok(AttractionReport::Bounded(Box::new(BoundedAttraction {
        model: model.model_name().to_string(),
        file: file.to_string(),
        params: parameters(model),
        system: sys,
        options,
        analysis,
        by_let,
        saddles,
        axes,
    })))
}
