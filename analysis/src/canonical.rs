//! Stability of an equilibrium of a canonical Hamiltonian model (`structure canonical(q, p)`)
//! from its Birkhoff normal form: the linear (ellipticity) check, the Arnold–Moser verdict in
//! two degrees of freedom, and finite-time tube bounds ([`lasalle_normal_form::bound`]),
//! optionally checked against integration ([`lasalle_normal_form::validate::tube_orbits`]).
//! `lasalle stability <model> [--time-bound d0,d1 …] [--order N] [--validate]` prints it; the
//! derivation is in `docs/stability.md`.

use lasalle_model::Model;
use lasalle_normal_form::bound::{tube_radii, Bound, Metric, Norm, Time};
use lasalle_normal_form::interval::certified::{
    CertifiedOptions, CertifiedRadius, CertifiedSetup, CertifiedTube,
};
use lasalle_normal_form::validate::{tube_orbits, TubeOrbit, TubeRun};
use lasalle_normal_form::{
    normalize_model, ErrorEstimate, ModelHamiltonian, ModelPoint, NormalForm, NormalFormError,
    Options, Precision, Progress,
};
use serde::Serialize;

mod search;
use search::{search_orders, Searched};

/// What to compute.
#[derive(Clone, Debug)]
pub struct CanonicalOptions {
    /// The equilibrium (a named point or a Newton start).
    pub point: ModelPoint,
    /// Tubes (d₀, d₁) to bound; empty: only the verdicts.
    pub tubes: Vec<(f64, f64)>,
    /// The highest order N of the bounds (orders 4, 6, …, N); with `optimal`, the order at
    /// which the search gives up.
    pub max_order: usize,
    /// Search for the optimal order: N = 4, 6, 8, … until the bound of every tube (and the
    /// radius of every `for_time`) stops growing, or `max_order`.
    pub optimal: bool,
    /// Times T for which the largest inner radius d0 with T(d0, k·d0) ≥ T is wanted
    /// (k = `outer_ratio`).
    pub for_time: Vec<f64>,
    /// The ratio k = d1/d0 of the `for_time` tubes.
    pub outer_ratio: f64,
    /// Remainder degree M for order N; `None`: min(2N, N + 8).
    pub remainder_degree: Option<usize>,
    /// How distances are measured.
    pub metric: Metric,
    /// Integrate orbits from every tube's inner sphere (`None`: no validation).
    pub validate: Option<Validation>,
    /// Also compute the certified time of every tube, and the certified radius of every
    /// `for_time` ([`CertifiedSetup`]), at the orders N = 4, 6, … (up to `max_order`) while
    /// the certified time (radius) grows, within [`CERTIFIED_SEARCH_SECONDS`]; each from a
    /// normal form in double-double at least (an order the estimate ran in `f64` is
    /// normalised again for it).
    pub certified: bool,
    /// The time budget of the order search (`optimal`) in seconds: no further order is
    /// started once it is spent, or when the next order, costing at least as much as the last
    /// one, would overrun it; the tubes still growing then end with [`SearchEnd::Budget`].
    /// `None`: no limit. The certified searches have their own
    /// ([`CERTIFIED_SEARCH_SECONDS`]).
    pub budget: Option<f64>,
    /// Told the stages of each normal form (each degree normalised), e.g. for a progress
    /// line.
    pub progress: Option<Progress>,
}

/// The default time budget of the order search ([`CanonicalOptions::budget`]), seconds.
pub const SEARCH_BUDGET_SECONDS: f64 = 300.0;

/// Why the order search stopped for one tube (or one `for_time` radius).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum SearchEnd {
    /// The bound (radius) at order `next` is below the one at `best`: the optimum is
    /// bracketed.
    Peaked {
        /// N_opt.
        best: usize,
        /// The first order past it computed.
        next: usize,
    },
    /// The first order gives no bound (the maps do not separate the spheres, ρ₁ ≤ ρ₀; no
    /// radius for the time): the tube is not searched further ([`Tube::failure`] says why).
    NoBound {
        /// The order tried.
        order: usize,
    },
    /// The time budget was spent while the bound still grew.
    Budget {
        /// The budget, seconds.
        budget: f64,
        /// The last order computed (the bound still growing there).
        last: usize,
    },
    /// The highest order allowed was reached while the bound still grew.
    Ceiling {
        /// That order.
        last: usize,
    },
}

/// What [`analyse_with`] tells as it goes.
#[derive(Debug)]
pub enum SearchEvent<'a> {
    /// The verdict and the linear data, before any order (no tubes yet).
    Start(&'a CanonicalReport),
    /// The normal form of order N is started (`seconds`: since the analysis began).
    Order {
        /// N.
        order: usize,
        /// Seconds since the analysis began.
        seconds: f64,
    },
    /// Tube `tube`'s row at one order.
    Row {
        /// Index of the tube in [`CanonicalOptions::tubes`].
        tube: usize,
        /// The row.
        row: &'a OrderBound,
    },
    /// Radius `index`'s row at one order.
    Radius {
        /// Index in [`CanonicalOptions::for_time`].
        index: usize,
        /// The row.
        row: &'a RadiusAtOrder,
    },
    /// The search stopped for tube `tube`.
    TubeEnd {
        /// Index of the tube.
        tube: usize,
        /// Why.
        end: &'a SearchEnd,
    },
    /// The search stopped for radius `index`.
    RadiusEnd {
        /// Index in [`CanonicalOptions::for_time`].
        index: usize,
        /// Why.
        end: &'a SearchEnd,
    },
}

/// The validation runs of [`CanonicalOptions::validate`].
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Validation {
    /// Integrate to this time at most.
    pub horizon: f64,
    /// Sampling interval.
    pub dt: f64,
    /// DOPRI5 tolerance.
    pub tol: f64,
    /// Action splits (simplex grid step 1/splits) and phases per mode.
    pub splits: usize,
    /// Phases per mode.
    pub phases: usize,
}

impl Default for Validation {
    fn default() -> Self {
        Validation {
            horizon: 200.0,
            dt: 0.05,
            tol: 1e-12,
            splits: 4,
            phases: 4,
        }
    }
}

/// The verdict on the equilibrium.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Verdict {
    /// Not elliptic: eigenvalues off the imaginary axis (or a defective repeated frequency).
    LinearlyUnstable {
        /// Why (the normal-form error).
        why: String,
    },
    /// H₂ definite (all σ_k equal): stable by the Lagrange–Dirichlet theorem.
    StableDirichlet,
    /// Two degrees of freedom, no resonance through order 4, D₄ ≠ 0: stable for all time.
    StableArnoldMoser {
        /// D₄.
        d4: f64,
        /// Its error estimate.
        d4_error: f64,
    },
    /// Elliptic, but nonlinear stability is not decided.
    NotDecided {
        /// Why.
        why: String,
    },
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Verdict::LinearlyUnstable { why } => write!(f, "linearly unstable: {why}"),
            Verdict::StableDirichlet => write!(
                f,
                "stable for all time (Lagrange–Dirichlet: H₂ is definite, H has a strict extremum)"
            ),
            Verdict::StableArnoldMoser { d4, d4_error } => write!(
                f,
                "stable for all time (Arnold–Moser: no resonance through order 4 and \
                 D₄ = {d4:.6} ± {d4_error:.1e} ≠ 0, so invariant tori enclose the equilibrium on \
                 every nearby energy level)"
            ),
            Verdict::NotDecided { why } => {
                write!(f, "linearly stable (elliptic); not decided: {why}")
            }
        }
    }
}

/// The bound of one tube at one order.
#[derive(Clone, Debug, Serialize)]
pub struct OrderBound {
    /// N.
    pub order: usize,
    /// M.
    pub remainder_degree: usize,
    /// The precision the normal form was computed in.
    pub precision: Precision,
    /// max |z'| on the inner sphere.
    pub rho0: f64,
    /// min |z'| on the outer sphere.
    pub rho1: f64,
    /// The lowest degree of the remainder.
    pub lowest_degree: Option<usize>,
    /// T with the gradient norm (`None` if ρ₁ ≤ ρ₀).
    pub gradient: Option<Time>,
    /// T with the radial norm.
    pub radial: Option<Time>,
    /// Seconds spent on this order's normal form (all precisions tried) and its tube radii.
    pub seconds: f64,
}

/// The largest inner radius for a time, at one order.
#[derive(Clone, Debug, Serialize)]
pub struct RadiusAtOrder {
    /// N.
    pub order: usize,
    /// The precision of the normal form.
    pub precision: Precision,
    /// The largest d0 found with T_N(d0, k·d0) ≥ T (`None`: not even at the smallest radius
    /// tried, 1e-7).
    pub d0: Option<f64>,
    /// ρ₀ and ρ₁ of that tube.
    pub rho: Option<(f64, f64)>,
    /// T_N(d0, k·d0) there (≥ T).
    pub time: Option<f64>,
}

/// `--for-time`: the largest inner radius whose tube of ratio k is kept for T.
#[derive(Clone, Debug, Serialize)]
pub struct RadiusForTime {
    /// T.
    pub time: f64,
    /// k = d1/d0.
    pub outer_ratio: f64,
    /// Per order.
    pub orders: Vec<RadiusAtOrder>,
    /// The order giving the largest d0.
    pub best_order: Option<usize>,
    /// The largest d0 over the orders.
    pub d0: Option<f64>,
    /// With `certified`: the certified time of the estimate's tube (d0, k·d0) at
    /// `best_order`.
    pub certified: Option<Result<CertifiedTube, String>>,
    /// With `certified`: the certified radius, per order tried (the certified order search),
    /// and which of them is the largest.
    pub certified_radius: Option<CertifiedSearch<CertifiedRadius>>,
    /// With the order search: why it stopped for this radius.
    pub search_end: Option<SearchEnd>,
}

/// The certified bound of one tube or one radius, per order tried.
#[derive(Clone, Debug, Serialize)]
pub struct CertifiedSearch<T> {
    /// (N, the certified result at order N, or why there is none).
    pub orders: Vec<(usize, Result<T, String>)>,
    /// The order of the best result (the largest certified time or radius).
    pub best_order: Option<usize>,
    /// Why the search stopped: `Decreased` (the result fell below the best), `Budget` (the
    /// time budget was spent while it still grew), `Ceiling` (the highest order allowed).
    pub stop: SearchStop,
    /// Seconds spent (normal forms of orders the estimate did not compute included).
    pub seconds: f64,
}

/// Why a certified order search stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum SearchStop {
    /// The certified result fell below the best one.
    Decreased,
    /// [`CERTIFIED_SEARCH_SECONDS`] were spent while it still grew.
    Budget,
    /// The highest order allowed (`--order`, or the search's ceiling) was reached.
    Ceiling,
}

impl<T> CertifiedSearch<T> {
    /// The result at the best order.
    pub fn best(&self) -> Option<&T> {
        let n = self.best_order?;
        self.orders
            .iter()
            .find(|(m, _)| *m == n)
            .and_then(|(_, r)| r.as_ref().ok())
    }
}

/// The time budget of one certified order search (one tube or one radius), in seconds: no
/// further order is started once it is spent, or when the next order's cost, predicted
/// from the last two (their ratio, at least 2), would overrun it.
pub const CERTIFIED_SEARCH_SECONDS: f64 = 300.0;

/// Per order: what integration measured on one tube.
#[derive(Clone, Debug, Serialize)]
pub struct Measured {
    /// N.
    pub order: usize,
    /// max over the orbits of T⁺(ρ(0), max ρ)/t with the gradient bound (≤ 1: never violated).
    pub worst_ratio: f64,
    /// max over the orbits of |Σ I(t) − Σ I(0)| in the normal coordinates of order N.
    pub action_drift: f64,
    /// What the gradient bound allows for it over the horizon: (ρ⁺² − ρ₀²)/2 with ρ⁺ the
    /// largest ρ reachable from ρ₀ by then ([`Bound::reach`]).
    pub drift_bound: f64,
    /// Whether integration can test the bound here: it allows more drift than the
    /// integration noise ([`TubeValidation::noise`]). Where it does not, `worst_ratio` measures
    /// the noise, not the dynamics.
    pub resolved: bool,
}

/// One tube.
#[derive(Clone, Debug, Serialize)]
pub struct Tube {
    /// Inner radius.
    pub d0: f64,
    /// Outer radius.
    pub d1: f64,
    /// One row per order.
    pub orders: Vec<OrderBound>,
    /// The order with the largest T (gradient norm), if any order gives a bound.
    pub best_order: Option<usize>,
    /// Integration, with `validate`.
    pub validation: Option<TubeValidation>,
    /// Why no order gives a bound (`best_order` is `None`); the other tubes go on.
    pub failure: Option<String>,
    /// With the order search: whether the bound was seen to decrease past `best_order`
    /// (false: it still grew at the last order computed).
    pub optimum_bracketed: Option<bool>,
    /// With the order search: why it stopped for this tube.
    pub search_end: Option<SearchEnd>,
    /// With `certified`: the certified time at the certified search's best order, or (no
    /// order gave one) the first order's result, which says why.
    pub certified: Option<Result<CertifiedTube, String>>,
    /// With `certified`: the certified times per order tried.
    pub certified_orders: Option<CertifiedSearch<CertifiedTube>>,
}

/// Integration from one tube's inner sphere.
#[derive(Clone, Debug, Serialize)]
pub struct TubeValidation {
    /// Orbits integrated.
    pub orbits: usize,
    /// Integrated to (the horizon).
    pub horizon: f64,
    /// The earliest exit from the outer tube among the orbits.
    pub first_exit: Option<f64>,
    /// How many orbits left the outer tube.
    pub exits: usize,
    /// The integration noise on Σ I, max over the orbits ([`TubeOrbit::noise`]): drifts
    /// below it are not resolved.
    pub noise: f64,
    /// Per order.
    pub measured: Vec<Measured>,
}

/// The analysis of one canonical equilibrium.
#[derive(Clone, Debug, Serialize)]
pub struct CanonicalReport {
    /// Model name.
    pub model: String,
    /// The equilibrium.
    pub equilibrium: Vec<f64>,
    /// Frequencies ω_k (empty if not elliptic).
    pub omega: Vec<f64>,
    /// Signs σ_k.
    pub signs: Vec<i8>,
    /// The condition number of A (how much the linear flow stretches Euclidean distances).
    pub condition: Option<f64>,
    /// The verdict.
    pub verdict: Verdict,
    /// How distances were measured.
    pub metric: Metric,
    /// The tubes.
    pub tubes: Vec<Tube>,
    /// `--for-time`: the largest inner radii.
    pub radii: Vec<RadiusForTime>,
    /// Whether the orders were searched (`optimal`) or given.
    pub order_search: bool,
    /// Seconds for the whole analysis.
    pub seconds: f64,
    /// With validation: per order with ≥ 2 radii where the drift is above the integration
    /// noise, the fitted exponent e of drift ∝ d₀ᵉ, the prediction (the lowest remainder
    /// degree, since dI/dt ≤ ρF(ρ) ~ ρ^{N+1}) and the number of radii used.
    pub drift_exponents: Vec<(usize, f64, usize, usize)>,
}

/// The default remainder degree for order N: min(2N, N + 8).
pub fn default_remainder_degree(order: usize) -> usize {
    (2 * order).min(order + 8)
}

fn options(order: usize, remainder: Option<usize>) -> Options {
    Options {
        order,
        remainder_degree: remainder,
        error_estimate: ErrorEstimate::Rotation,
        auto_precision: true,
        ..Options::default()
    }
}

/// The order search gives up here unless `--order` says otherwise.
pub const SEARCH_MAX_ORDER: usize = 60;

/// The normal form of order n with its remainder bounds, starting at precision `start`
/// (the precision grows with the order, so the search starts where the previous order ended).
fn order_form(
    model: &Model,
    params: &[(String, f64)],
    o: &CanonicalOptions,
    n: usize,
    start: Precision,
) -> Result<Form, NormalFormError> {
    let m = o
        .remainder_degree
        .map_or(default_remainder_degree(n), |m| m.max(n + 1));
    let t = std::time::Instant::now();
    let opts = Options {
        // the bounds and the validation use the map to the normal coordinates only
        inverse_transform: false,
        ..options(n, Some(m)).precision(start)
    };
    let nf = normalize_model(model, params, &o.point, &opts)?;
    let rem = nf.remainder.as_ref().expect("remainder requested");
    let bound = Bound::new(rem, Norm::Gradient);
    let radial = Bound::new(rem, Norm::Radial);
    Ok(Form {
        nf,
        bound,
        radial,
        m,
        seconds: t.elapsed().as_secs_f64(),
    })
}

/// One order's normal form and bounds.
struct Form {
    nf: NormalForm,
    bound: Bound,
    radial: Bound,
    m: usize,
    seconds: f64,
}

/// The bound of one tube with one order's normal form.
fn tube_row(f: &Form, d0: f64, d1: f64, metric: Metric) -> Result<OrderBound, NormalFormError> {
    let t = std::time::Instant::now();
    let r = tube_radii(&f.nf, d0, d1, metric)?;
    let ok = r.rho1 > r.rho0;
    Ok(OrderBound {
        order: f.nf.order,
        remainder_degree: f.m,
        precision: f.nf.precision,
        rho0: r.rho0,
        rho1: r.rho1,
        lowest_degree: f.bound.lowest_degree(),
        gradient: ok.then(|| f.bound.time(r.rho0, r.rho1)),
        radial: ok.then(|| f.radial.time(r.rho0, r.rho1)),
        seconds: f.seconds + t.elapsed().as_secs_f64(),
    })
}

/// The largest d0 with T_N(d0, k·d0) ≥ `time` for one order. The sphere extrema are costly
/// (thousands of evaluations of the maps), so the search runs on a model of them: the ratios
/// ρ₀/d0 and ρ₁/d1 measured at a trial radius (they change slowly with the radius), a
/// bisection in log d0 on T_N(c₀d0, c₁k·d0) to 1e-4 relative, and then the extrema are
/// measured again at the result; until the measured tube gives T ≥ `time` (at most 8 rounds)
/// the ratios are updated there and the search repeated. The radius reported is one whose
/// measured tube holds.
fn radius_at_order(
    f: &Form,
    time: f64,
    k: f64,
    metric: Metric,
    start: f64,
) -> Result<RadiusAtOrder, NormalFormError> {
    let none = RadiusAtOrder {
        order: f.nf.order,
        precision: f.nf.precision,
        d0: None,
        rho: None,
        time: None,
    };
    let mut trial = start;
    let mut best: Option<(f64, f64, f64, f64)> = None;
    for _ in 0..8 {
        let r = tube_radii(&f.nf, trial, k * trial, metric)?;
        let measured = (r.rho1 > r.rho0).then(|| f.bound.time(r.rho0, r.rho1).lower);
        if let Some(t) = measured.filter(|&t| t >= time) {
            if best.is_none_or(|b| trial > b.0) {
                best = Some((trial, r.rho0, r.rho1, t));
            }
        }
        if r.rho1 <= r.rho0 {
            // the maps no longer separate the spheres: look smaller
            trial /= 2.0;
            if trial < 1e-7 {
                break;
            }
            continue;
        }
        let (c0, c1) = (r.rho0 / trial, r.rho1 / (k * trial));
        let model = |d: f64| f.bound.time(c0 * d, c1 * k * d).lower;
        // bracket and bisect the model
        let (mut lo, mut hi) = (trial, trial);
        if model(lo) >= time {
            while model(hi) >= time && hi < 0.5 {
                lo = hi;
                hi *= 2.0;
            }
        } else {
            while model(lo) < time && lo > 1e-7 {
                hi = lo;
                lo /= 2.0;
            }
            if model(lo) < time {
                break;
            }
        }
        while hi / lo - 1.0 > 1e-4 {
            let mid = (lo * hi).sqrt();
            if model(mid) >= time {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        if (lo / trial - 1.0).abs() < 1e-3 && best.is_some_and(|b| b.0 == trial) {
            break;
        }
        // the model may be slightly optimistic: aim 1e-4 low, then check by measuring
        trial = lo * (1.0 - 1e-4);
    }
    Ok(match best {
        Some((d0, r0, r1, t)) => RadiusAtOrder {
            d0: Some(d0),
            rho: Some((r0, r1)),
            time: Some(t),
            ..none
        },
        None => none,
    })
}

/// The largest singular value ratio of a square matrix (from the eigenvalues of MᵀM).
fn condition_number(m: &[Vec<f64>]) -> f64 {
    let a = nalgebra::DMatrix::from_fn(m.len(), m.len(), |i, j| m[i][j]);
    let s = a.singular_values();
    s.max() / s.min()
}

impl CanonicalOptions {
    /// Checks the radii (0 < d0 < d1, finite) and the order (4 ≤ N ≤ the normal form's
    /// largest when there are tubes); the messages name the command line's flags.
    pub fn validate(&self) -> Result<(), String> {
        for &(d0, d1) in &self.tubes {
            if !(d0 > 0.0 && d0.is_finite() && d1.is_finite()) || d1 <= d0 {
                return Err(format!(
                    "--time-bound {d0},{d1}: need finite radii 0 < d0 < d1"
                ));
            }
        }
        for &t in &self.for_time {
            if !(t > 0.0 && t.is_finite()) {
                return Err(format!("--for-time {t}: need a finite time > 0"));
            }
        }
        if !(self.outer_ratio > 1.0 && self.outer_ratio.is_finite()) {
            return Err(format!(
                "--outer-ratio {}: need a finite ratio d1/d0 > 1",
                self.outer_ratio
            ));
        }
        let bounds = !self.tubes.is_empty() || !self.for_time.is_empty();
        if bounds && !(4..=lasalle_normal_form::MAX_ORDER).contains(&self.max_order) {
            return Err(format!(
                "--order {}: the bounds need an order between 4 and {}",
                self.max_order,
                lasalle_normal_form::MAX_ORDER
            ));
        }
        Ok(())
    }
}

/// Runs the analysis; errors are located messages.
pub fn analyse(
    model: &Model,
    params: &[(String, f64)],
    o: &CanonicalOptions,
) -> Result<CanonicalReport, String> {
    analyse_with(model, params, o, &mut |_| {})
}

/// [`analyse`], telling `on_event` what it has as it goes: the verdict before any order,
/// then each order's rows as soon as they are computed and each tube's (radius's) end of
/// the order search ([`SearchEvent`]).
pub fn analyse_with(
    model: &Model,
    params: &[(String, f64)],
    o: &CanonicalOptions,
    on_event: &mut dyn FnMut(SearchEvent<'_>),
) -> Result<CanonicalReport, String> {
    o.validate()?;
    let started = std::time::Instant::now();
    let at = |e: NormalFormError| format!("{}: {e}", model.name);
    // order 4: ellipticity, resonances through order 4, D4
    let base = normalize_model(model, params, &o.point, &options(4, None));
    let base = match base {
        Ok(nf) => nf,
        Err(e @ (NormalFormError::NotElliptic { .. } | NormalFormError::Defective { .. })) => {
            if !o.tubes.is_empty() || !o.for_time.is_empty() {
                return Err(format!("{}: no time bound: {e}", model.name));
            }
            return Ok(CanonicalReport {
                model: model.name.clone(),
                equilibrium: Vec::new(),
                omega: Vec::new(),
                signs: Vec::new(),
                condition: None,
                verdict: Verdict::LinearlyUnstable { why: e.to_string() },
                metric: o.metric,
                tubes: Vec::new(),
                radii: Vec::new(),
                order_search: false,
                seconds: 0.0,
                drift_exponents: Vec::new(),
            });
        }
        Err(NormalFormError::Resonance {
            m,
            m_dot_omega,
            order,
            ..
        }) => {
            // the normal form's own message suggests its `--resonant`, which bounds cannot use
            let resonance =
                format!("resonance m = {m:?} at order {order}, m·ω = {m_dot_omega:.3e}");
            if !o.tubes.is_empty() || !o.for_time.is_empty() {
                return Err(format!(
                    "{}: no time bound: {resonance}; the bound needs a normal form without \
                     resonances through order 4 (`lasalle normal-form --resonant` computes the \
                     resonant one)",
                    model.name
                ));
            }
            let nf = normalize_model(model, params, &o.point, &options(4, None).resonant(true))
                .map_err(at)?;
            return Ok(CanonicalReport {
                verdict: Verdict::NotDecided {
                    why: format!("a {resonance}"),
                },
                ..report_of(&nf, o.metric)
            });
        }
        Err(e) => return Err(at(e)),
    };
    let mut report = report_of(&base, o.metric);
    report.verdict = if base.signs.iter().all(|&s| s == base.signs[0]) {
        Verdict::StableDirichlet
    } else if base.n_dof != 2 {
        Verdict::NotDecided {
            why: format!(
                "H₂ is indefinite (σ = {:?}) and Arnold–Moser applies in two degrees of freedom only",
                base.signs
            ),
        }
    } else {
        match &base.d4 {
            Some(am) => {
                let err = am.d4.error.unwrap_or(0.0);
                if am.d4.value.abs() > 10.0 * err.max(1e-12) {
                    Verdict::StableArnoldMoser {
                        d4: am.d4.value,
                        d4_error: err,
                    }
                } else {
                    Verdict::NotDecided {
                        why: format!(
                            "D₄ = {:.3e} is zero within its error {err:.1e}",
                            am.d4.value
                        ),
                    }
                }
            }
            None => Verdict::NotDecided {
                why: "D₄ was not computed".into(),
            },
        }
    };
    if o.tubes.is_empty() && o.for_time.is_empty() {
        report.seconds = started.elapsed().as_secs_f64();
        return Ok(report);
    }
    report.order_search = o.optimal;
    on_event(SearchEvent::Start(&report));
    let Searched {
        orders,
        forms,
        rows_by_tube,
        radii,
        precision,
        candidates,
        tube_ends,
        radius_ends,
    } = search_orders(model, params, o, started, on_event).map_err(at)?;
    let h = ModelHamiltonian::new(model, params).map_err(at)?;
    let mut cert = Certifier {
        model,
        params,
        o,
        h: &h,
        forms: &forms,
        extra: Vec::new(),
        precision,
        setups: Vec::new(),
    };
    // the certified search runs over the orders the estimate may use (4, 6, …, `--order`,
    // or up to the search's ceiling), from the lowest, while its result grows
    let mut report_radii = Vec::new();
    for ((&time, orders), search_end) in o.for_time.iter().zip(radii).zip(radius_ends) {
        let best = orders
            .iter()
            .filter_map(|r| r.d0.map(|d| (r.order, d)))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let k = o.outer_ratio;
        let (certified, certified_radius) = match best.filter(|_| o.certified) {
            None => (None, None),
            Some((nb, db)) => {
                let at_estimate = cert
                    .setup(nb)
                    .0
                    .and_then(|s| s.tube(db, k * db).map_err(|e| e.to_string()));
                let mut previous: Option<f64> = None;
                let search = cert.search(
                    &candidates,
                    |s, n, secs| {
                        let start = orders
                            .iter()
                            .find(|r| r.order == n)
                            .and_then(|r| r.d0)
                            .or(previous)
                            .unwrap_or(db);
                        let first = s.tube(start, k * start).map_err(|e| e.to_string())?;
                        let mut r = s
                            .radius_for_time(time, k, first, CERTIFIED_RADIUS_TOLERANCE, 16)
                            .map_err(|e| e.to_string())?;
                        r.seconds += secs;
                        previous = r.d0().or(previous);
                        Ok(r)
                    },
                    |r| r.d0(),
                );
                (Some(at_estimate), Some(search))
            }
        };
        report_radii.push(RadiusForTime {
            time,
            outer_ratio: k,
            best_order: best.map(|b| b.0),
            d0: best.map(|b| b.1),
            orders,
            certified,
            certified_radius,
            search_end,
        });
    }
    report.radii = report_radii;
    let mut drift: Vec<Vec<(f64, f64)>> = vec![Vec::new(); orders.len()];
    for ((&(d0, d1), rows), search_end) in o.tubes.iter().zip(rows_by_tube).zip(tube_ends) {
        let best_order = rows
            .iter()
            .filter_map(|r| r.gradient.map(|t| (r.order, t.lower)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(n, _)| n);
        let failure = best_order.is_none().then(|| {
            let r = &rows[0];
            format!(
                "--time-bound {d0},{d1}: no bound at any order: the inner sphere reaches ρ₀ = {:.4e} \
                 in normal coordinates, the outer one comes down to ρ₁ = {:.4e} ≤ ρ₀{}",
                r.rho0,
                r.rho1,
                match (o.metric, report.condition) {
                    (Metric::Euclidean, Some(c)) if d1 / d0 <= c => format!(
                        " (the linear map alone stretches distances by up to its condition \
                         number {c:.1}: use d1/d0 > {c:.1}, or `--metric linear-normal`)"
                    ),
                    _ => " (the tube is too wide for the normal-form maps: take smaller radii)".into(),
                }
            )
        });
        let validation = match &o.validate {
            Some(v) if failure.is_none() => {
                // the orders this tube was searched at
                let forms = &forms[..rows.len()];
                let charts: Vec<(&NormalForm, &Bound)> =
                    forms.iter().map(|f| (&f.nf, &f.bound)).collect();
                let run = TubeRun {
                    d0,
                    d1,
                    metric: o.metric,
                    t_end: v.horizon,
                    dt: v.dt,
                    tol: v.tol,
                    splits: v.splits,
                    phases: v.phases,
                };
                let orbits = tube_orbits(&h, &charts, &run).map_err(at)?;
                let allowed: Vec<f64> = forms
                    .iter()
                    .zip(&rows)
                    .map(|(f, r)| {
                        let reach = f.bound.reach(r.rho0, v.horizon);
                        0.5 * (reach * reach - r.rho0 * r.rho0)
                    })
                    .collect();
                let tv = summarize(&orbits, &orders[..rows.len()], &allowed, v.horizon);
                for (k, m) in tv.measured.iter().enumerate() {
                    if m.action_drift > tv.noise {
                        drift[k].push((d0, m.action_drift));
                    }
                }
                Some(tv)
            }
            _ => None,
        };
        let optimum_bracketed = o
            .optimal
            .then_some(matches!(search_end, Some(SearchEnd::Peaked { .. })));
        let certified_orders = (o.certified && best_order.is_some()).then(|| {
            cert.search(
                &candidates,
                |s, _, secs| {
                    let mut t = s.tube(d0, d1).map_err(|e| e.to_string())?;
                    t.seconds += secs;
                    Ok(t)
                },
                |t| t.time,
            )
        });
        // the certified time at the search's best order, or the first result (which says
        // why there is none)
        let certified = certified_orders.as_ref().and_then(|c| {
            c.best_order
                .and_then(|n| c.orders.iter().find(|(m, _)| *m == n))
                .or(c.orders.first())
                .map(|(_, r)| r.clone())
        });
        report.tubes.push(Tube {
            d0,
            d1,
            orders: rows,
            best_order,
            validation,
            failure,
            optimum_bracketed,
            search_end,
            certified,
            certified_orders,
        });
    }
    report.drift_exponents = orders
        .iter()
        .zip(&drift)
        .zip(&forms)
        .filter(|((_, pts), _)| pts.len() >= 2)
        .map(|((&n, pts), f)| {
            (
                n,
                fit_slope(pts),
                f.bound.lowest_degree().unwrap_or(0),
                pts.len(),
            )
        })
        .collect();
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

/// The relative width of the bracket at which the certified radius search stops.
pub const CERTIFIED_RADIUS_TOLERANCE: f64 = 1e-2;

/// The certified bounds, order by order, with the normal forms and setups they need (the
/// estimate's forms, and those of the further orders the certified search reaches).
struct Certifier<'a> {
    model: &'a Model,
    params: &'a [(String, f64)],
    o: &'a CanonicalOptions,
    h: &'a ModelHamiltonian<'a>,
    forms: &'a [Form],
    extra: Vec<Form>,
    precision: Precision,
    setups: Vec<(
        usize,
        Result<CertifiedSetup<'a, ModelHamiltonian<'a>>, String>,
    )>,
}

type Setup<'a> = CertifiedSetup<'a, ModelHamiltonian<'a>>;

impl<'a> Certifier<'a> {
    /// The setup at order n, with the seconds spent building it now (0 when cached).
    fn setup(&mut self, n: usize) -> (Result<&Setup<'a>, String>, f64) {
        let t = std::time::Instant::now();
        let i = match self.setups.iter().position(|(m, _)| *m == n) {
            Some(i) => i,
            None => {
                let built = self.build(n);
                self.setups.push((n, built));
                self.setups.len() - 1
            }
        };
        let secs = t.elapsed().as_secs_f64();
        (self.setups[i].1.as_ref().map_err(|e| e.clone()), secs)
    }
    fn build(&mut self, n: usize) -> Result<Setup<'a>, String> {
        let have =
            |forms: &[Form], extra: &[Form]| forms.iter().chain(extra).any(|f| f.nf.order == n);
        if !have(self.forms, &self.extra) {
            // orders beyond the estimate's serve the certified bound alone: double-double
            let start = match self.precision {
                Precision::F64 => Precision::DoubleDouble,
                p => p,
            };
            let f =
                order_form(self.model, self.params, self.o, n, start).map_err(|e| e.to_string())?;
            self.precision = f.nf.precision;
            self.extra.push(f);
        }
        let f = self
            .forms
            .iter()
            .chain(&self.extra)
            .find(|f| f.nf.order == n)
            .ok_or_else(|| format!("no normal form of order {n}"))?;
        // the certified bound takes T and A⁻¹ in double-double at least: in f64 their
        // rounding leaves Ẇ's low degrees (which cancel for the exact normal form) at 10⁻¹⁶
        // of their terms, a floor on the certified time
        let nf = if f.nf.precision == Precision::F64 {
            let dd = order_form(self.model, self.params, self.o, n, Precision::DoubleDouble)
                .map_err(|e| e.to_string())?;
            std::borrow::Cow::Owned(dd.nf)
        } else {
            std::borrow::Cow::Borrowed(&f.nf)
        };
        CertifiedSetup::new(self.h, &nf, self.o.metric, &CertifiedOptions::default())
            .map_err(|e| e.to_string())
    }
    /// Evaluates `eval` at the orders in turn; stops at the first result below the best (or
    /// without one, once there is a best), or when [`CERTIFIED_SEARCH_SECONDS`] are spent.
    fn search<T>(
        &mut self,
        orders: &[usize],
        mut eval: impl FnMut(&Setup<'a>, usize, f64) -> Result<T, String>,
        value: impl Fn(&T) -> Option<f64>,
    ) -> CertifiedSearch<T> {
        let t0 = std::time::Instant::now();
        let mut out = CertifiedSearch {
            orders: Vec::new(),
            best_order: None,
            stop: SearchStop::Ceiling,
            seconds: 0.0,
        };
        let mut best: Option<f64> = None;
        // the cost of the last two orders: the next one is predicted to cost the last times
        // their ratio (at least 2), and is not started if it would overrun the budget
        let mut costs: Vec<f64> = Vec::new();
        for &n in orders {
            let spent = t0.elapsed().as_secs_f64();
            let predicted = match costs[..] {
                [.., a, b] if a > 0.0 => b * (b / a).max(2.0),
                [.., b] => 2.0 * b,
                [] => 0.0,
            };
            if !out.orders.is_empty() && spent + predicted > CERTIFIED_SEARCH_SECONDS {
                out.stop = SearchStop::Budget;
                break;
            }
            let (setup, secs) = self.setup(n);
            let r = setup.and_then(|s| eval(s, n, secs));
            costs.push(t0.elapsed().as_secs_f64() - spent);
            let v = r.as_ref().ok().and_then(&value);
            out.orders.push((n, r));
            match (v, best) {
                (Some(v), Some(b)) if v > b => {
                    best = Some(v);
                    out.best_order = Some(n);
                }
                (Some(v), None) => {
                    best = Some(v);
                    out.best_order = Some(n);
                }
                (_, Some(_)) => {
                    out.stop = SearchStop::Decreased;
                    break;
                }
                _ => {}
            }
        }
        out.seconds = t0.elapsed().as_secs_f64();
        out
    }
}

fn report_of(nf: &NormalForm, metric: Metric) -> CanonicalReport {
    CanonicalReport {
        model: nf.model.clone(),
        equilibrium: nf.equilibrium_f64(),
        omega: nf.frequencies_linear(),
        signs: nf.signs.clone(),
        condition: Some(condition_number(&nf.linear_map)),
        verdict: Verdict::NotDecided { why: String::new() },
        metric,
        tubes: Vec::new(),
        radii: Vec::new(),
        order_search: false,
        seconds: 0.0,
        drift_exponents: Vec::new(),
    }
}

fn summarize(
    orbits: &[TubeOrbit],
    orders: &[usize],
    allowed: &[f64],
    horizon: f64,
) -> TubeValidation {
    let exits: Vec<f64> = orbits.iter().filter_map(|o| o.exit_time).collect();
    let noise = orbits.iter().map(|o| o.noise).fold(0.0, f64::max);
    TubeValidation {
        orbits: orbits.len(),
        horizon,
        first_exit: exits.iter().copied().reduce(f64::min),
        exits: exits.len(),
        noise,
        measured: orders
            .iter()
            .enumerate()
            .map(|(k, &order)| Measured {
                order,
                worst_ratio: orbits.iter().map(|o| o.worst_ratio[k]).fold(0.0, f64::max),
                action_drift: orbits.iter().map(|o| o.action_drift[k]).fold(0.0, f64::max),
                drift_bound: allowed[k],
                resolved: allowed[k] > noise,
            })
            .collect(),
    }
}

/// Least-squares slope of log y against log x.
pub fn fit_slope(pts: &[(f64, f64)]) -> f64 {
    let v: Vec<(f64, f64)> = pts
        .iter()
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .map(|p| (p.0.ln(), p.1.ln()))
        .collect();
    let m = v.len() as f64;
    let (mx, my) = (
        v.iter().map(|p| p.0).sum::<f64>() / m,
        v.iter().map(|p| p.1).sum::<f64>() / m,
    );
    let num: f64 = v.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let den: f64 = v.iter().map(|p| (p.0 - mx).powi(2)).sum();
    num / den
}

/// One line for a certified time next to the estimate it certifies.
fn certified_line(c: &Result<CertifiedTube, String>, estimate: Option<f64>) -> String {
    match c {
        Err(e) => format!("  certified: none ({e})"),
        Ok(c) => {
            let head = format!(
                "  certified (interval arithmetic, Taylor models of the field to degree {}, branch and bound on the spheres; {:.1} s): ",
                c.field_degree, c.seconds
            );
            match c.time {
                Some(t) => {
                    let ratio = estimate.map_or(String::new(), |e| {
                        if t < 0.1 * e {
                            format!(" — {:.1e} of the estimate {e:.4e}: much weaker", t / e)
                        } else {
                            format!(" ({:.3} of the estimate {e:.4e})", t / e)
                        }
                    });
                    format!(
                        "{head}T ≥ {t:.4e}{ratio}; ρ₀ ≤ {:.5e}, ρ₁ ≥ {:.5e}",
                        c.rho0, c.rho1
                    )
                }
                None => format!(
                    "{head}no certified time: ρ₁ ≥ {:.5e} does not exceed ρ₀ ≤ {:.5e} (take a smaller or thinner tube)",
                    c.rho1, c.rho0
                ),
            }
        }
    }
}

/// Why the certified search stopped, as a sentence.
fn stop_note(stop: SearchStop, best: Option<usize>, what: &str) -> String {
    let n = best.map_or("-".into(), |n| n.to_string());
    match stop {
        SearchStop::Decreased => {
            format!("certified optimal order N = {n}: the certified {what} decreases beyond it")
        }
        SearchStop::Budget => format!(
            "best certified order so far N = {n}: the search stopped when its time budget ({CERTIFIED_SEARCH_SECONDS} s) was spent, the certified {what} still growing"
        ),
        SearchStop::Ceiling => format!(
            "best certified order N = {n}: the highest order allowed (--order) was reached, the certified {what} still growing"
        ),
    }
}

/// The certified order search of one tube, one row per order.
fn certified_tube_table(s: &mut String, c: &CertifiedSearch<CertifiedTube>, est: Option<f64>) {
    use std::fmt::Write;
    let _ = writeln!(
        s,
        "  certified (interval arithmetic, Taylor models of the field to degree K, branch and bound on the spheres), by order:"
    );
    let _ = writeln!(
        s,
        "  {:>3} {:>3} {:>12} {:>12} {:>12} {:>8}",
        "N", "K", "ρ0 ≤", "ρ1 ≥", "T ≥", "s"
    );
    for (n, r) in &c.orders {
        let mark = if Some(*n) == c.best_order {
            "  ← certified N_opt"
        } else {
            ""
        };
        match r {
            Ok(t) => {
                let _ = writeln!(
                    s,
                    "  {:>3} {:>3} {:>12.5e} {:>12.5e} {:>12} {:>8.2}{mark}",
                    n,
                    t.field_degree,
                    t.rho0,
                    t.rho1,
                    t.time.map_or("none".into(), |x| format!("{x:.4e}")),
                    t.seconds
                );
            }
            Err(e) => {
                let _ = writeln!(s, "  {n:>3} none: {e}");
            }
        }
    }
    let what = stop_note(c.stop, c.best_order, "time");
    match c.best().and_then(|t| t.time) {
        Some(t) => {
            let ratio = est.map_or(String::new(), |e| {
                format!(" ({:.3e} of the estimate at its N_opt, {e:.4e})", t / e)
            });
            let _ = writeln!(s, "  {what}: T ≥ {t:.4e}{ratio} ({:.1} s)", c.seconds);
        }
        None => {
            let _ = writeln!(
                s,
                "  no certified time at any order tried ({:.1} s)",
                c.seconds
            );
        }
    }
}

/// The certified radius search of one time, one row per order.
fn certified_radius_table(s: &mut String, c: &CertifiedSearch<CertifiedRadius>, est: Option<f64>) {
    use std::fmt::Write;
    let _ = writeln!(
        s,
        "  certified radius (largest d0 found whose certified time of the tube d0 → k·d0 reaches T; bracket to {CERTIFIED_RADIUS_TOLERANCE:e}):"
    );
    let _ = writeln!(
        s,
        "  {:>3} {:>12} {:>12} {:>12} {:>12} {:>12} {:>5} {:>8}",
        "N", "d0", "ρ0 ≤", "ρ1 ≥", "T ≥", "fails at d0", "evals", "s"
    );
    for (n, r) in &c.orders {
        let mark = if Some(*n) == c.best_order {
            "  ← certified N_opt"
        } else {
            ""
        };
        match r {
            Ok(r) => {
                let t = r.tube.as_ref();
                let _ = writeln!(
                    s,
                    "  {:>3} {:>12} {:>12} {:>12} {:>12} {:>12} {:>5} {:>8.2}{mark}",
                    n,
                    t.map_or("none".into(), |t| format!("{:.5e}", t.d0)),
                    t.map_or(String::new(), |t| format!("{:.5e}", t.rho0)),
                    t.map_or(String::new(), |t| format!("{:.5e}", t.rho1)),
                    t.and_then(|t| t.time)
                        .map_or(String::new(), |x| format!("{x:.4e}")),
                    r.failed.map_or("-".into(), |f| format!("{:.5e}", f.0)),
                    r.evaluations.len(),
                    r.seconds
                );
            }
            Err(e) => {
                let _ = writeln!(s, "  {n:>3} none: {e}");
            }
        }
    }
    let what = stop_note(c.stop, c.best_order, "radius");
    match c.best().and_then(|r| r.d0()) {
        Some(d) => {
            let ratio = est.map_or(String::new(), |e| {
                format!(" ({:.3} of the estimate's radius {e:.5e})", d / e)
            });
            let _ = writeln!(s, "  {what}: d0 = {d:.5e}{ratio} ({:.1} s)", c.seconds);
        }
        None => {
            let _ = writeln!(
                s,
                "  no certified radius at any order tried ({:.1} s)",
                c.seconds
            );
        }
    }
}

/// One row of a tube's table (columns [`CanonicalReport::row_header`]).
pub fn row_line(r: &OrderBound) -> String {
    let gap = r.gradient.map_or(String::new(), |g| {
        format!("{:.1e}", g.upper / g.lower - 1.0)
    });
    format!(
        "  {:>3} {:>3} {:>5} {:>12.5e} {:>12.5e} {:>5} {:>16} {:>16} {:>9} {:>8.2}",
        r.order,
        r.remainder_degree,
        r.precision.to_string(),
        r.rho0,
        r.rho1,
        r.lowest_degree.map_or("-".into(), |d| d.to_string()),
        fmt_time(r.gradient),
        fmt_time(r.radial),
        gap,
        r.seconds,
    )
}

/// Why the order search of a tube ended, as a sentence (`None` without the search).
pub fn search_end_line(
    end: Option<&SearchEnd>,
    best: Option<usize>,
    rows: &[OrderBound],
) -> Option<String> {
    let at = |n: usize| rows.iter().find(|r| r.order == n);
    let time_at = |n: usize| fmt_time(at(n).and_then(|r| r.gradient));
    Some(match end? {
        SearchEnd::Peaked { best, next } => format!(
            "optimal order N_opt = {best} ({}): T = {} (the bound decreases beyond it: {} at N = {next})",
            at(*best).map_or(String::new(), |r| r.precision.to_string()),
            time_at(*best),
            time_at(*next),
        ),
        SearchEnd::NoBound { order } => format!(
            "no bound at N = {order} (ρ₁ ≤ ρ₀): the tube is not searched further"
        ),
        SearchEnd::Budget { budget, last } => format!(
            "the time budget ({budget} s, --budget) was spent: best order so far N = {}, T = {}, still growing at N = {last}",
            best.map_or("-".into(), |n| n.to_string()),
            best.map_or("-".into(), time_at),
        ),
        SearchEnd::Ceiling { last } => format!(
            "the bound still grows at N = {last}, the last order allowed (raise --order to search further)"
        ),
    })
}

fn fmt_time(t: Option<Time>) -> String {
    match t {
        Some(t) => format!("{:.4e}", t.lower),
        None => "none (ρ₁ ≤ ρ₀)".into(),
    }
}

impl CanonicalReport {
    /// Human-readable tables.
    pub fn to_table(&self) -> String {
        let mut s = self.head_table();
        s.push_str(&self.tubes_table());
        s
    }
    /// The model, the linear data and the verdict (the first lines of [`Self::to_table`]).
    pub fn head_table(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        if self.equilibrium.is_empty() {
            // not elliptic: the normal form stopped before it reported the point
            let _ = writeln!(s, "{}: canonical Hamiltonian", self.model);
        } else {
            let _ = writeln!(
                s,
                "{}: canonical Hamiltonian, equilibrium {:?}",
                self.model, self.equilibrium
            );
        }
        if !self.omega.is_empty() {
            let _ = writeln!(
                s,
                "linear: elliptic, ω = {:?}, σ = {:?}; cond(A) = {:.3}",
                self.omega,
                self.signs,
                self.condition.unwrap_or(f64::NAN)
            );
        }
        let _ = writeln!(s, "verdict: {}", self.verdict);
        s
    }
    /// The column names of [`row_line`].
    pub fn row_header() -> String {
        format!(
            "  {:>3} {:>3} {:>5} {:>12} {:>12} {:>5} {:>16} {:>16} {:>9} {:>8}",
            "N", "M", "prec", "ρ0", "ρ1", "R≥", "T (gradient)", "T (radial)", "quad gap", "s"
        )
    }
    /// Everything after [`Self::head_table`]: the tubes, the radii, the drift exponents.
    pub fn tubes_table(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        for t in &self.tubes {
            let _ = writeln!(
                s,
                "\nTube d0 = {:e} → d1 = {:e}, distances {}: T = time before any orbit starting within d0 can reach d1",
                t.d0, t.d1, self.metric
            );
            if let Some(why) = &t.failure {
                let _ = writeln!(s, "  {why}");
                continue;
            }
            let _ = writeln!(s, "{}", Self::row_header());
            for r in &t.orders {
                let mark = match (Some(r.order) == t.best_order, self.order_search) {
                    (true, true) => "  ← N_opt",
                    (true, false) => "  ← best",
                    _ => "",
                };
                let _ = writeln!(s, "{}{mark}", row_line(r));
            }
            if let Some(line) = search_end_line(t.search_end.as_ref(), t.best_order, &t.orders) {
                let _ = writeln!(s, "  {line}");
            } else if let (Some(false), Some(n)) = (t.optimum_bracketed, t.best_order) {
                let _ = writeln!(
                    s,
                    "  the bound still grows at N = {n}, the last order computed (raise --order to search further)"
                );
            }
            let est = t
                .best_order
                .and_then(|n| t.orders.iter().find(|r| r.order == n))
                .and_then(|r| r.gradient)
                .map(|t| t.lower);
            if let Some(search) = &t.certified_orders {
                certified_tube_table(&mut s, search, est);
            }
            if let Some(v) = &t.validation {
                let _ = writeln!(
                    s,
                    "  integration: {} orbits from the inner sphere (all splits and phases), DOPRI5, to t = {}: {}",
                    v.orbits,
                    v.horizon,
                    match v.first_exit {
                        Some(e) => format!("{} left the outer tube, the first at t = {e:.3}", v.exits),
                        None => "none left the outer tube".into(),
                    }
                );
                let _ = writeln!(
                    s,
                    "  integration noise on ΣI (this DOPRI5 run against one at 10× the tolerance): {:.1e}; ratios ≤ 1: the bound held (tested where it allows more drift than the noise)",
                    v.noise
                );
                let _ = writeln!(
                    s,
                    "  {:>3} {:>22} {:>22} {:>22}",
                    "N", "max T(ρ(0),max ρ)/t", "max |ΔΣI| (order N)", "bound on |ΔΣI|"
                );
                for m in &v.measured {
                    let _ = writeln!(
                        s,
                        "  {:>3} {:>22.3e} {:>22.3e} {:>22.3e}{}",
                        m.order,
                        m.worst_ratio,
                        m.action_drift,
                        m.drift_bound,
                        if m.resolved {
                            ""
                        } else {
                            "  (bound below the noise: not tested)"
                        }
                    );
                }
            }
        }
        for r in &self.radii {
            let _ = writeln!(
                s,
                "\nLargest inner radius d0 kept within d1 = {}·d0 for T = {:e}, distances {}:",
                r.outer_ratio, r.time, self.metric
            );
            let _ = writeln!(
                s,
                "  {:>3} {:>5} {:>12} {:>12} {:>12} {:>14}",
                "N", "prec", "d0", "ρ0", "ρ1", "T(d0, k·d0)"
            );
            for a in &r.orders {
                let _ = writeln!(
                    s,
                    "  {:>3} {:>5} {:>12} {:>12} {:>12} {:>14}{}",
                    a.order,
                    a.precision.to_string(),
                    a.d0.map_or("none".into(), |d| format!("{d:.5e}")),
                    a.rho.map_or(String::new(), |p| format!("{:.5e}", p.0)),
                    a.rho.map_or(String::new(), |p| format!("{:.5e}", p.1)),
                    a.time.map_or(String::new(), |t| format!("{t:.4e}")),
                    if Some(a.order) == r.best_order {
                        "  ← best"
                    } else {
                        ""
                    }
                );
            }
            match r.d0 {
                Some(d) => {
                    let _ = writeln!(
                        s,
                        "  d0 = {d:.5e} at N = {} (the tube measured there holds; bisection to 1e-4)",
                        r.best_order.unwrap_or(0)
                    );
                }
                None => {
                    let _ = writeln!(s, "  no radius ≥ 1e-7 is kept for this time at any order");
                }
            }
            if let Some(c) = &r.certified {
                let _ = writeln!(
                    s,
                    "  the estimate's radius, certified:\n  {}",
                    certified_line(c, Some(r.time))
                );
            }
            if let Some(search) = &r.certified_radius {
                certified_radius_table(&mut s, search, r.d0);
            }
        }
        if self.tubes.iter().any(|t| t.failure.is_none()) || !self.radii.is_empty() {
            let _ = writeln!(s, "\n({:.2} s in all)", self.seconds);
        }
        if !self.drift_exponents.is_empty() {
            let _ = writeln!(
                s,
                "\nAction drift |ΔΣI| ∝ d0^e over the radii where it is above the integration noise:"
            );
            for (n, e, low, count) in &self.drift_exponents {
                let _ = writeln!(
                    s,
                    "  N = {n:>2}: fitted e = {e:.2} ({count} radii), predicted {low} (ΔI ≤ ρ F(ρ) t ~ ρ^{low})"
                );
            }
        }
        s
    }
    /// One row per (tube, order).
    pub fn to_csv(&self) -> String {
        let mut s = String::from(
            "d0,d1,metric,order,remainder_degree,rho0,rho1,t_gradient,t_radial,best,first_exit,worst_ratio,action_drift,drift_bound\n",
        );
        let metric = serde_json::to_value(self.metric)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default();
        for t in &self.tubes {
            for (k, r) in t.orders.iter().enumerate() {
                let m = t.validation.as_ref().map(|v| &v.measured[k]);
                let opt = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x:e}"));
                s.push_str(&format!(
                    "{:e},{:e},{metric},{},{},{:e},{:e},{},{},{},{},{},{},{}\n",
                    t.d0,
                    t.d1,
                    r.order,
                    r.remainder_degree,
                    r.rho0,
                    r.rho1,
                    opt(r.gradient.map(|g| g.lower)),
                    opt(r.radial.map(|g| g.lower)),
                    Some(r.order) == t.best_order,
                    opt(t.validation.as_ref().and_then(|v| v.first_exit)),
                    opt(m.map(|m| m.worst_ratio)),
                    opt(m.map(|m| m.action_drift)),
                    opt(m.map(|m| m.drift_bound)),
                ));
            }
        }
        s
    }
}
