//! Stability of an equilibrium of a canonical Hamiltonian model (`structure canonical(q, p)`)
//! from its Birkhoff normal form: the linear (ellipticity) check, the Arnold–Moser verdict in
//! two degrees of freedom, and finite-time tube bounds ([`lasalle_normal_form::bound`]),
//! optionally checked against integration ([`lasalle_normal_form::validate::tube_orbits`]).
//! `lasalle stability <model> [--time-bound d0,d1 …] [--order N] [--validate]` prints it; the
//! derivation is in `docs/stability.md`.

use lasalle_model::Model;
use lasalle_normal_form::bound::{tube_radii, Bound, Metric, Norm, Time};
use lasalle_normal_form::validate::{tube_orbits, TubeOrbit, TubeRun};
use lasalle_normal_form::{
    normalize_model, ErrorEstimate, ModelHamiltonian, ModelPoint, NormalForm, NormalFormError,
    Options, Precision,
};
use serde::Serialize;

/// What to compute.
#[derive(Clone, Debug)]
pub struct CanonicalOptions {
    /// The equilibrium (a named point or a Newton start).
    pub point: ModelPoint,
    /// Tubes (d₀, d₁) to bound; empty: only the verdicts.
    pub tubes: Vec<(f64, f64)>,
    /// The highest order N of the bounds (orders 4, 6, …, N).
    pub max_order: usize,
    /// Remainder degree M for order N; `None`: min(2N, N + 8).
    pub remainder_degree: Option<usize>,
    /// How distances are measured.
    pub metric: Metric,
    /// Integrate orbits from every tube's inner sphere (`None`: no validation).
    pub validate: Option<Validation>,
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
}

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
        if !self.tubes.is_empty() && !(4..=lasalle_normal_form::MAX_ORDER).contains(&self.max_order)
        {
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
    o.validate()?;
    let at = |e: NormalFormError| format!("{}: {e}", model.name);
    // order 4: ellipticity, resonances through order 4, D4
    let base = normalize_model(model, params, &o.point, &options(4, None));
    let base = match base {
        Ok(nf) => nf,
        Err(e @ (NormalFormError::NotElliptic { .. } | NormalFormError::Defective { .. })) => {
            if !o.tubes.is_empty() {
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
            if !o.tubes.is_empty() {
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
    if o.tubes.is_empty() {
        return Ok(report);
    }
    let mut orders: Vec<usize> = (4..=o.max_order).step_by(2).collect();
    if o.max_order % 2 == 1 {
        orders.push(o.max_order);
    }
    let mut forms = Vec::new();
    for &n in &orders {
        let m = o
            .remainder_degree
            .map_or(default_remainder_degree(n), |m| m.max(n + 1));
        let nf = normalize_model(model, params, &o.point, &options(n, Some(m))).map_err(at)?;
        let bound = Bound::new(
            nf.remainder.as_ref().expect("remainder requested"),
            Norm::Gradient,
        );
        let radial = Bound::new(
            nf.remainder.as_ref().expect("remainder requested"),
            Norm::Radial,
        );
        forms.push((nf, bound, radial, m));
    }
    let h = ModelHamiltonian::new(model, params).map_err(at)?;
    let mut drift: Vec<Vec<(f64, f64)>> = vec![Vec::new(); orders.len()];
    for &(d0, d1) in &o.tubes {
        let mut rows = Vec::new();
        for (nf, bound, radial, m) in &forms {
            let r = tube_radii(nf, d0, d1, o.metric).map_err(at)?;
            let ok = r.rho1 > r.rho0;
            rows.push(OrderBound {
                order: nf.order,
                remainder_degree: *m,
                precision: nf.precision,
                rho0: r.rho0,
                rho1: r.rho1,
                lowest_degree: bound.lowest_degree(),
                gradient: ok.then(|| bound.time(r.rho0, r.rho1)),
                radial: ok.then(|| radial.time(r.rho0, r.rho1)),
            });
        }
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
                let charts: Vec<(&NormalForm, &Bound)> =
                    forms.iter().map(|(nf, b, _, _)| (nf, b)).collect();
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
                    .map(|((_, b, _, _), r)| {
                        let reach = b.reach(r.rho0, v.horizon);
                        0.5 * (reach * reach - r.rho0 * r.rho0)
                    })
                    .collect();
                let tv = summarize(&orbits, &orders, &allowed, v.horizon);
                for (k, m) in tv.measured.iter().enumerate() {
                    if m.action_drift > tv.noise {
                        drift[k].push((d0, m.action_drift));
                    }
                }
                Some(tv)
            }
            _ => None,
        };
        report.tubes.push(Tube {
            d0,
            d1,
            orders: rows,
            best_order,
            validation,
            failure,
        });
    }
    report.drift_exponents = orders
        .iter()
        .zip(&drift)
        .zip(&forms)
        .filter(|((_, pts), _)| pts.len() >= 2)
        .map(|((&n, pts), (_, b, _, _))| {
            (n, fit_slope(pts), b.lowest_degree().unwrap_or(0), pts.len())
        })
        .collect();
    Ok(report)
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

fn fmt_time(t: Option<Time>) -> String {
    match t {
        Some(t) => format!("{:.4e}", t.lower),
        None => "none (ρ₁ ≤ ρ₀)".into(),
    }
}

impl CanonicalReport {
    /// Human-readable tables.
    pub fn to_table(&self) -> String {
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
            let _ = writeln!(
                s,
                "  {:>3} {:>3} {:>5} {:>12} {:>12} {:>5} {:>16} {:>16} {:>9}",
                "N", "M", "prec", "ρ0", "ρ1", "R≥", "T (gradient)", "T (radial)", "quad gap"
            );
            for r in &t.orders {
                let gap = r.gradient.map_or(String::new(), |g| {
                    format!("{:.1e}", g.upper / g.lower - 1.0)
                });
                let _ = writeln!(
                    s,
                    "  {:>3} {:>3} {:>5} {:>12.5e} {:>12.5e} {:>5} {:>16} {:>16} {:>9}{}",
                    r.order,
                    r.remainder_degree,
                    r.precision.to_string(),
                    r.rho0,
                    r.rho1,
                    r.lowest_degree.map_or("-".into(), |d| d.to_string()),
                    fmt_time(r.gradient),
                    fmt_time(r.radial),
                    gap,
                    if Some(r.order) == t.best_order {
                        "  ← best"
                    } else {
                        ""
                    }
                );
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
