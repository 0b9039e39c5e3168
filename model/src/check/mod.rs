//! Stage 4: checks that need the derivatives: every declared integral is conserved by the field,
//! every constraint's manifold is invariant, an explicit V vanishes on the invariant set.
//!
//! A Lie derivative ∇f · X is first simplified and expanded (square roots of a sum reduced
//! with ρ² = s, see `prove.rs`); if it becomes the number 0 the integral is *proved*. Otherwise it is evaluated at random states (deterministic seed) and
//! must be zero up to rounding relative to the size of its terms at each of them.

pub(crate) mod prove;
pub(crate) mod sampling;

use crate::derive::{Derivatives, Derived};
use crate::error::{Diagnostic, DiagnosticKind, Error};
use crate::ir::Input;
use crate::model::{InvariantKind, Model};
use crate::Rng;
use sampling::project_onto;

/// Number of random states each invariant is checked at.
pub const SAMPLES: usize = 128;
/// A residual counts as zero when |residual| ≤ TOLERANCE · (size of the terms).
pub const TOLERANCE: f64 = 1e-9;
/// Expansion budget (terms) for the symbolic proof.
pub const EXPAND_LIMIT: usize = 20_000;

/// How an invariant was shown to be conserved.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// ∇f · X simplified to 0.
    Proved,
    /// Zero up to rounding at this many random states (on the constraints' manifold for a
    /// constraint); the worst relative residual.
    Sampled {
        /// Number of states checked.
        samples: usize,
        /// max |∇f·X| / (size of its terms) over the samples.
        worst_relative: f64,
    },
    /// An integral conserved only on the manifold of the model's constraints, zero up to
    /// rounding at this many random states on it.
    OnConstraints {
        /// Number of states checked.
        samples: usize,
        /// max |∇f·X| / (size of its terms) over the samples.
        worst_relative: f64,
    },
}

/// The result of the conservation check of one invariant.
#[derive(Clone, Debug)]
pub struct Conservation {
    /// The invariant's name.
    pub name: String,
    /// How it was established.
    pub verdict: Verdict,
}

/// What sampling ∇f·X at random states found.
struct Sampled {
    samples: usize,
    attempts: usize,
    worst: f64,
    /// The first state where a component was not zero: (component, value, scale, state).
    failure: Option<(usize, f64, f64, Vec<f64>)>,
}

/// The constraint manifold {f₀ = 0} of all constraints together: their stacked components and
/// Jacobian rows.
struct Manifold {
    ids: Vec<crate::ir::Id>,
    jacobian: Vec<Vec<crate::ir::Id>>,
}

/// Samples the Lie derivatives `lie` at random states (projected onto `manifold` if given).
fn sample(
    model: &Model,
    lie: &[crate::ir::Id],
    manifold: Option<&Manifold>,
    params: &[f64],
    seed: u64,
) -> Sampled {
    let n = model.dim();
    let mut rng = Rng::new(seed);
    let mut out = Sampled {
        samples: 0,
        attempts: 0,
        worst: 0.0,
        failure: None,
    };
    while out.samples < SAMPLES && out.attempts < 20 * SAMPLES && out.failure.is_none() {
        out.attempts += 1;
        let mut x: Vec<f64> = (0..n).map(|_| rng.uniform(-1.5, 1.5)).collect();
        if let Some(m) = manifold {
            match project_onto(&model.graph, &m.jacobian, &m.ids, params, &x) {
                Some(on) => x = on,
                None => continue,
            }
        }
        let mut input = |i: Input| match i {
            Input::State(k) => x[k as usize],
            Input::Param(k) => params[k as usize],
            _ => f64::NAN,
        };
        let mut ok = true;
        let mut this_worst = 0.0f64;
        for (c, &l) in lie.iter().enumerate() {
            let (v, scale) = model.graph.eval_with_scale(l, &mut input);
            if !v.is_finite() || !scale.is_finite() {
                ok = false;
                break;
            }
            let rel = if scale > 0.0 { v.abs() / scale } else { 0.0 };
            this_worst = this_worst.max(rel);
            if rel > TOLERANCE && v.abs() > 1e-300 {
                out.failure = Some((c, v, scale, x.clone()));
                break;
            }
        }
        if ok {
            out.samples += 1;
            out.worst = out.worst.max(this_worst);
        }
    }
    out
}

/// The output of stage 4: a derived model whose every declared invariant is shown to be
/// conserved (how, per invariant, in [`Checked::conservation`]), with no non-finite constant.
/// The input of emission (`lasalle_codegen::emit`).
#[derive(Clone)]
pub struct Checked<'d> {
    derived: &'d Derived,
    conservation: Vec<Conservation>,
}

impl<'d> Checked<'d> {
    /// The derived model.
    pub fn derived(&self) -> &'d Derived {
        self.derived
    }

    /// The model.
    pub fn model(&self) -> &'d Model {
        &self.derived.model
    }

    /// Its derivatives.
    pub fn derivatives(&self) -> &'d Derivatives {
        &self.derived.derivatives
    }

    /// How each invariant was shown to be conserved, in declaration order.
    pub fn conservation(&self) -> &[Conservation] {
        &self.conservation
    }

    /// The verdicts, owned.
    pub fn into_conservation(self) -> Vec<Conservation> {
        self.conservation
    }
}

/// Checks every invariant (and an explicit V); reports all failures at once.
///
/// Constraints are checked together, on their common manifold (so `|x|² − 1` and `x · v` of a
/// spherical pendulum hold each on the other's manifold). An integral that is not conserved
/// everywhere but is on that manifold is accepted as conserved on the constraint manifold
/// ([`Verdict::OnConstraints`]): the feedback integrator keeps the motion near the manifold,
/// where the integral is then kept too.
pub fn check(derived: &Derived) -> Result<Checked<'_>, Error> {
    let (model, d) = (&derived.model, &derived.derivatives);
    check_finite(model, d)?;
    let params = model.default_params();
    let mut out = Vec::new();
    let mut errors = Vec::new();
    let rows: Vec<usize> = model
        .invariants
        .iter()
        .filter(|f| f.kind == InvariantKind::Constraint)
        .flat_map(|f| f.offset..f.offset + f.value.shape.len())
        .collect();
    let all_ids = model.invariant_ids();
    let manifold = (!rows.is_empty()).then(|| Manifold {
        ids: rows.iter().map(|&r| all_ids[r]).collect(),
        jacobian: rows.iter().map(|&r| d.jacobian[r].clone()).collect(),
    });
    for f in model.invariants.clone() {
        let range = f.offset..f.offset + f.value.shape.len();
        let lie: Vec<_> = d.lie_derivatives[range.clone()].to_vec();
        // Proofs work on a scratch copy, so the model's graph (and the emitted code) does not
        // depend on what the proof tried.
        let mut scratch = model.graph.clone();
        let proved = lie
            .iter()
            .all(|&l| prove::vanishes(&mut scratch, l, EXPAND_LIMIT));
        if proved {
            out.push(Conservation {
                name: f.name.clone(),
                verdict: Verdict::Proved,
            });
            continue;
        }
        let seed = 0x1a5a11e ^ f.offset as u64;
        let constraint = f.kind == InvariantKind::Constraint;
        let mut result = sample(
            model,
            &lie,
            manifold.as_ref().filter(|_| constraint),
            &params,
            seed,
        );
        let mut on_constraints = constraint;
        if result.failure.is_some() && !constraint && manifold.is_some() {
            let on = sample(model, &lie, manifold.as_ref(), &params, seed);
            if on.failure.is_none() && on.samples >= SAMPLES / 2 {
                result = on;
                on_constraints = true;
            }
        }
        let Sampled {
            samples,
            attempts,
            worst,
            failure,
        } = result;
        if let Some((c, v, scale, x)) = failure {
            let component = if f.value.shape.len() > 1 {
                format!(" (component {c})")
            } else {
                String::new()
            };
            let what = if constraint { "constraint" } else { "integral" };
            let help = if constraint {
                "the field must be tangent to the constraints' manifold {f₀ = 0}; check the formula"
                    .to_string()
            } else if manifold.is_some() {
                "it is not conserved on the constraints' manifold either; check the formula"
                    .to_string()
            } else {
                "check the formula; if it holds only on a manifold, declare it as a `constraint` (written so that the manifold is {f = 0})".to_string()
            };
            errors.push(
                Diagnostic::new(
                    &f.span,
                    format!(
                        "{what} `{}` is not conserved by the field: d/dt {}{component} = ∇f·X = {v:.3e} at x = {}, where its terms are of size {scale:.3e}",
                        f.name,
                        f.name,
                        state_string(model, &x)
                    ),
                )
                .help(help)
                .kind(DiagnosticKind::FailedCheck),
            );
        } else if samples < SAMPLES / 2 {
            errors.push(Diagnostic::new(&f.span, format!(
                "cannot check `{}`: it or the field is not finite at {} of {attempts} random states", f.name, attempts - samples
            )).help("the check samples states with components in [−1.5, 1.5]; avoid singular formulas there"));
        } else {
            out.push(Conservation {
                name: f.name.clone(),
                verdict: if on_constraints && !constraint {
                    Verdict::OnConstraints {
                        samples,
                        worst_relative: worst,
                    }
                } else {
                    Verdict::Sampled {
                        samples,
                        worst_relative: worst,
                    }
                },
            });
        }
    }
    if let Some(span) = model.lyapunov_span.clone() {
        if let Err(e) = check_lyapunov(model, d, &params, &span) {
            errors.push(e);
        }
    }
    if errors.is_empty() {
        Ok(Checked {
            derived,
            conservation: out,
        })
    } else {
        Err(Error::Model(errors))
    }
}

/// An explicit V must vanish where f(x) = f(x₀) on the constraint manifold, and be ≥ 0.
fn check_lyapunov(
    model: &Model,
    d: &Derivatives,
    params: &[f64],
    span: &crate::Span,
) -> Result<(), Diagnostic> {
    let n = model.dim();
    let f = model.invariant_ids();
    // The constraint rows of f and Df, to sample the manifold {f₀ = 0}.
    let rows: Vec<usize> = model
        .invariants
        .iter()
        .filter(|f| f.kind == InvariantKind::Constraint)
        .flat_map(|f| f.offset..f.offset + f.value.shape.len())
        .collect();
    let constraint_ids: Vec<_> = rows.iter().map(|&r| f[r]).collect();
    let constraint_jac: Vec<Vec<_>> = rows.iter().map(|&r| d.jacobian[r].clone()).collect();
    let gains: Vec<f64> = model.gains.iter().map(|g| g.default.max(1.0)).collect();
    let mut rng = Rng::new(0x5eed);
    for _ in 0..SAMPLES {
        let mut x: Vec<f64> = (0..n).map(|_| rng.uniform(-1.5, 1.5)).collect();
        let y: Vec<f64> = (0..n).map(|_| rng.uniform(-1.5, 1.5)).collect();
        if !rows.is_empty() {
            match project_onto(&model.graph, &constraint_jac, &constraint_ids, params, &x) {
                Some(on) => x = on,
                None => continue,
            }
        }
        let at = |s: &[f64]| {
            model.graph.eval_f64(&f, &mut |i| match i {
                Input::State(k) => s[k as usize],
                Input::Param(k) => params[k as usize],
                _ => f64::NAN,
            })
        };
        let (fx, fy) = (at(&x), at(&y));
        let v = |target: &[f64]| {
            model
                .graph
                .eval_with_scale(model.lyapunov, &mut |i| match i {
                    Input::State(k) => x[k as usize],
                    Input::Param(k) => params[k as usize],
                    Input::Target(k) => target[k as usize],
                    Input::Gain(k) => gains[k as usize],
                    Input::Symbol(_) => f64::NAN,
                })
        };
        let (v0, scale0) = v(&fx);
        let (v1, scale1) = v(&fy);
        if !(v0.is_finite() && v1.is_finite()) {
            continue;
        }
        if v0.abs() > 1e-7 * scale0 && v0.abs() > 1e-300 {
            return Err(Diagnostic::new(span, format!(
                "V does not vanish on the invariant set: V = {v0:.3e} at x = {} with f(x₀) = f(x)",
                state_string(model, &x)
            )).help("V must vanish exactly where f(x) = f(x₀) (and the constraints hold), e.g. k/2 * norm(f - target(f))^2").kind(DiagnosticKind::FailedCheck));
        }
        if v1 < -TOLERANCE * scale1 {
            return Err(Diagnostic::new(
                span,
                format!(
                    "V is negative: V = {v1:.3e} at x = {}",
                    state_string(model, &x)
                ),
            )
            .help("V must be ≥ 0, e.g. a sum of k/2 * norm(f - target(f))^2 with k ≥ 0")
            .kind(DiagnosticKind::FailedCheck));
        }
    }
    Ok(())
}

fn state_string(model: &Model, x: &[f64]) -> String {
    let parts: Vec<String> = model
        .state
        .iter()
        .map(|s| {
            let vals: Vec<String> = x[s.offset..s.offset + s.shape.len()]
                .iter()
                .map(|v| format!("{v:.4}"))
                .collect();
            if vals.len() == 1 {
                format!("{} = {}", s.name, vals[0])
            } else {
                format!("{} = [{}]", s.name, vals.join(", "))
            }
        })
        .collect();
    format!("({})", parts.join(", "))
}

/// Fails with a located error if a number the emitted code would contain is ±∞ or NaN: a
/// derivative can overflow where the model's own constants did not (`d/dx 1e308·x² = 2e308·x`).
/// [`check`] calls it first, so the message names the overflow rather than the conservation
/// check that would trip on it.
fn check_finite(model: &Model, d: &Derivatives) -> crate::Result<()> {
    let g = &model.graph;
    // Almost always there is no such number at all: one pass over the graph says so.
    if (0..g.len()).all(|k| g.as_num(crate::ir::Id(k as u32)).is_none_or(f64::is_finite)) {
        return Ok(());
    }
    let non_finite = |roots: &[crate::ir::Id]| {
        g.reachable(roots)
            .into_iter()
            .find_map(|id| g.as_num(id).filter(|x| !x.is_finite()))
    };
    let mut groups: Vec<(Vec<crate::ir::Id>, &crate::Span)> = Vec::new();
    for (k, span) in model.field_spans.iter().enumerate() {
        groups.push((vec![model.field[k]], span));
    }
    for f in &model.invariants {
        let rows = f.offset..f.offset + f.value.shape.len();
        let mut ids = f.value.ids.clone();
        ids.extend(d.jacobian[rows].iter().flatten());
        groups.push((ids, &f.span));
    }
    let v_span = model
        .lyapunov_span
        .as_ref()
        .or(model.invariants.first().map(|f| &f.span));
    if let Some(span) = v_span {
        let mut ids = vec![model.lyapunov];
        ids.extend(&d.lyapunov_gradient);
        ids.extend(&d.feedback);
        groups.push((ids, span));
    }
    for p in &model.points {
        groups.push((p.values.clone(), &p.span));
    }
    for (ids, span) in groups {
        if let Some(x) = non_finite(&ids) {
            return Err(crate::Diagnostic::new(
                span,
                format!("this item, or its derivative, has a constant that is not finite ({x})"),
            )
            .help("rescale the model: constants near ±1.8e308 overflow when combined or differentiated")
            .into());
        }
    }
    Ok(())
}
