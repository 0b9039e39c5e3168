//! The gain study (beyond the paper; Bae & Chang, *Feedback integrators revisited*,
//! arXiv:2512.01528): invariant error against step size for feedback-Euler with the paper's
//! gains, unity gains, the scaled fixed gain α = c/(hL) (c = 1) and the periodic adaptive gain
//! (every 100 steps, c = 1, safety 0.8), next to the structure-preserving method of each system
//! (splitting / Störmer–Verlet), RK4 and Euler. L = ‖DfᵀKDf‖₂ is the Gauss–Newton Hessian of V
//! (exact at the target set), computed from the generated Jacobian by power iteration;
//! explicit Euler on −∇V is stable only for h·L < 2.

use std::fmt::Write as _;
use std::path::Path;

use lasalle::models::{
    kepler::Kepler,
    perturbed_kepler::{PerturbedKepler, PerturbedKeplerPrepared},
    rigid_body::RigidBody,
};
use lasalle::{gauss_newton_norm, GainPolicy, VerletVariant};
use serde_json::json;

use lasalle::{json_number, Base, Method, Recording, RunModel, RunSpec};

use super::super::progress::simulate;
use super::{command_line, sci, ExperimentArgs, Table};
use crate::cli::CliResult;

/// One row of the study: a label, a method and its gains.
struct Row {
    label: &'static str,
    method: Method,
    gains: GainPolicy,
}

fn rows<const G: usize>(structure: (Method, &'static str)) -> Vec<Row> {
    let fb = Method::Feedback(Base::Euler);
    vec![
        Row {
            label: "feedback-Euler, paper gains",
            method: fb,
            gains: GainPolicy::ModelDefault,
        },
        Row {
            label: "feedback-Euler, unity gains",
            method: fb,
            gains: GainPolicy::Explicit(vec![1.0; G]),
        },
        Row {
            label: "feedback-Euler, fixed c/(hL), c = 1",
            method: fb,
            gains: GainPolicy::Scaled { c: 1.0 },
        },
        Row {
            label: "feedback-Euler, adaptive (m = 100, c = 1)",
            method: fb,
            gains: GainPolicy::Adaptive { every: 100, c: 1.0 },
        },
        Row {
            label: "feedback-Euler, adaptive (m = 10, c = 1)",
            method: fb,
            gains: GainPolicy::Adaptive { every: 10, c: 1.0 },
        },
        Row {
            label: structure.1,
            method: structure.0,
            gains: GainPolicy::Default,
        },
        Row {
            label: "RK4",
            method: Method::Plain(Base::Rk4),
            gains: GainPolicy::Default,
        },
        Row {
            label: "Euler",
            method: Method::Plain(Base::Euler),
            gains: GainPolicy::Default,
        },
    ]
}

/// The worst invariant of a run: max over the samples of the largest block error, and its
/// name; or the blow-up.
fn worst(t: &Recording) -> (f64, String) {
    let (mut e, mut name) = (0.0f64, String::new());
    for (b, n) in t.blocks.iter().enumerate() {
        let m = t.max_error(b);
        if m > e || m.is_nan() {
            e = m;
            name = n.clone();
        }
    }
    (e, name)
}

fn cell(t: &Recording) -> String {
    match &t.failure {
        Some(err) => {
            let what = match err {
                lasalle::StepError::Diverged { .. } => "diverged",
                _ => "blow-up",
            };
            format!("{what} at t = {:.3}", err.time().unwrap_or(f64::NAN))
        }
        None => {
            let (e, name) = worst(t);
            format!("{} ({name})", sci(e))
        }
    }
}

/// Runs the study for one model; returns the markdown section and the JSON rows.
#[allow(clippy::too_many_arguments)]
fn study<Mdl, const N: usize, const M: usize, const G: usize>(
    title: &str,
    model: &Mdl,
    x0: &[f64; N],
    t_end: f64,
    steps: &[f64],
    structure: (Method, &'static str),
    quiet: bool,
    stability: &mut String,
) -> Result<(String, serde_json::Value), String>
where
    Mdl: RunModel<[f64; N], [f64; M], [f64; G]>,
{
    let mut header = vec!["method".to_string()];
    header.extend(steps.iter().map(|h| format!("h = {h}")));
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut table = Table::new(&header_refs);
    let mut json_rows = Vec::new();
    for row in rows::<G>(structure) {
        let mut cells = vec![row.label.to_string()];
        for &h in steps {
            let mut spec = RunSpec::new(row.method, h, t_end);
            spec.gains = row.gains.clone();
            spec.every = (spec.steps() / 5000).max(1);
            let trace = simulate(model, x0, &spec, !quiet).map_err(|e| e.to_string())?;
            cells.push(cell(&trace));
            let (e, name) = worst(&trace);
            json_rows.push(json!({
                "method": row.label,
                "h": h,
                "worst_max_error": json_number(e),
                "worst_invariant": name,
                "max_errors": trace.blocks.iter().enumerate()
                    .map(|(b, n)| (n.clone(), json_number(trace.max_error(b))))
                    .collect::<serde_json::Map<_, _>>(),
                "gains_initial": trace.gains_initial,
                "gains_final": trace.gains_final,
                "failure": trace.failure.as_ref().map(|e| e.to_string()),
                "wall_seconds": trace.wall_seconds,
            }));
        }
        table.row(cells);
    }
    // stability of feedback-Euler on −∇V at x0: h·L < 2
    let paper = model.default_gain_values();
    let l_paper = gauss_newton_norm::<Mdl, f64, [f64; N], [f64; M]>(model, x0, paper);
    let l_unit = gauss_newton_norm::<Mdl, f64, [f64; N], [f64; M]>(model, x0, &[1.0; G]);
    let _ = writeln!(
        stability,
        "| {title} | {} | {} | {} | {} |",
        sci(l_paper),
        sci(2.0 / l_paper),
        sci(l_unit),
        sci(2.0 / l_unit)
    );
    let mut s = String::new();
    let _ = writeln!(
        s,
        "### {title}, t ∈ [0, {t_end}]\n\nLargest sampled invariant error over the run (and which \
         invariant); `blow-up` = the run stopped with a non-finite state or at a guard; `diverged` = an invariant's error passed 10³ times its scale.\n"
    );
    s.push_str(&table.markdown());
    Ok((s, json!(json_rows)))
}

/// Runs the gain study into `dir`.
pub fn run(args: &ExperimentArgs, dir: &Path) -> CliResult {
    let scale = args.t_end.map(|t| t / 100.0).unwrap_or(1.0);
    let mut stability = String::from(
        "| system | L(x₀), paper gains | 2/L | L(x₀), unity gains | 2/L |\n| --- | --- | --- | --- | --- |\n",
    );
    let mut report = format!(
        "## Gain study (beyond the paper)\n\n`{}`\n\nFeedback-Euler with the paper's gains, unity gains, \
         the scaled fixed gain α = c/(h·L(x₀)) and the periodic adaptive gain α = 0.8·c/(h·L(x)) \
         re-estimated every 100 steps (c = 1; L = ‖DfᵀKDf‖₂ for unit K, by power iteration on the \
         generated Jacobian), against the structure-preserving method, RK4 and Euler.\n\n",
        command_line(args, "gains")
    );
    let mut json_all = serde_json::Map::new();

    let rb = RigidBody::default().prepare();
    let (s, j) = study(
        "free rigid body",
        &rb,
        &rb.point_paper(),
        100.0 * scale,
        &[1e-3, 3e-3, 1e-2, 3e-2],
        (Method::Splitting, "splitting"),
        args.quiet,
        &mut stability,
    )?;
    report.push_str(&s);
    json_all.insert("rigid-body".into(), j);

    let kp = Kepler::default().prepare();
    let (s, j) = study(
        "Kepler (e = 0.8)",
        &kp,
        &kp.point_paper(),
        10.0 * super::kepler::PERIOD * scale,
        &[1e-3, 5e-3, 2e-2, 5e-2],
        (Method::StormerVerlet(VerletVariant::A), "Störmer–Verlet A"),
        args.quiet,
        &mut stability,
    )?;
    report.push('\n');
    report.push_str(&s);
    json_all.insert("kepler".into(), j);

    let pk = PerturbedKepler::default().prepare();
    let x0 = pk.point_paper();
    let (s, j) = study(
        "perturbed Kepler (e = 0.6)",
        &pk,
        &x0,
        200.0 * scale,
        &[3e-3, 1e-2, 3e-2, 1e-1],
        (Method::StormerVerlet(VerletVariant::A), "Störmer–Verlet A"),
        args.quiet,
        &mut stability,
    )?;
    report.push('\n');
    report.push_str(&s);
    json_all.insert("perturbed-kepler".into(), j);

    // The pericentre question: x(0) is the pericentre of the perturbed orbit (x ⟂ v, r = 0.4).
    let pericentre = pericentre_check(&pk, &x0);
    let _ = writeln!(
        report,
        "\n### Stability of feedback-Euler on −∇V (h·L < 2)\n\nL = ‖DfᵀKDf‖₂ at the initial state \
         (for the perturbed Kepler problem that is the pericentre); Euler is stable on the feedback \
         term for h < 2/L.\n\n{stability}\n{pericentre}"
    );
    std::fs::write(dir.join("summary.md"), &report)?;
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&serde_json::Value::Object(json_all))? + "\n",
    )?;
    if !args.quiet {
        println!("{report}");
        println!("wrote {}", dir.display());
    }
    Ok(())
}

/// h·L at the perturbed Kepler pericentre and its maximum along the orbit, for Δt = 0.03.
fn pericentre_check(model: &PerturbedKeplerPrepared, x0: &[f64; 6]) -> String {
    let h = 0.03;
    let gains_of = |k: [f64; 2]| gauss_newton_norm(model, x0, &k);
    // L along one exact orbit (DOPRI5 reference over one radial period ≈ 3.9)
    let times: Vec<f64> = (0..=400).map(|i| i as f64 * 0.01).collect();
    let along =
        super::perturbed_kepler::dense_reference(model, x0, &times, 1e-10).unwrap_or_default();
    let norms = |k: [f64; 2]| {
        along
            .iter()
            .map(|x| gauss_newton_norm(model, x, &k))
            .collect::<Vec<f64>>()
    };
    let max_along = |k: [f64; 2]| norms(k).into_iter().fold(0.0f64, f64::max);
    let min_along = |k: [f64; 2]| norms(k).into_iter().fold(f64::INFINITY, f64::min);
    let (lp, lu) = (gains_of([2.0, 3.0]), gains_of([1.0, 1.0]));
    let (mp, mu) = (max_along([2.0, 3.0]), max_along([1.0, 1.0]));
    let verdict = |hl: f64| {
        if hl < 2.0 {
            "below Euler's limit 2 (stable)"
        } else {
            "above Euler's limit 2: feedback-Euler is locally unstable there"
        }
    };
    format!(
        "Perturbed Kepler, Δt = {h}: at the pericentre h·L = {:.3} with the paper's gains (2, 3), {}, \
         and {:.3} with unity gains, {}. The largest h·L along the orbit is {:.3} (paper gains) and \
         {:.3} (unity); Euler's limit is reached at h = 2/L = {:.4} (paper gains) and {:.4} (unity). \
         Along one orbit L (unity gains) ranges over [{:.3}, {:.3}], a factor {:.1}.\n",
        h * lp,
        verdict(h * lp),
        h * lu,
        verdict(h * lu),
        h * mp,
        h * mu,
        2.0 / mp,
        2.0 / mu,
        min_along([1.0, 1.0]),
        mu,
        mu / min_along([1.0, 1.0]),
    )
}
