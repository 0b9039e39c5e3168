//! Gains for adaptive methods: step counts and final invariant errors of
//! DOPRI5 and the Taylor method, plain, with the feedback term at the model's (the paper's)
//! gains, and with the step-tracking gain `--gains auto` (h·k·L = 2·tol^(1/p), see
//! `lasalle::step_gain_target`), over tolerances 1e-8 … 1e-15, on the rigid body (t = 1000),
//! Kepler e = 0.8 (1000 periods) and the perturbed Kepler problem (1000 periods of the
//! unperturbed orbit, T = 2π). Step counts are deterministic (no timing). A run with the paper's
//! gains is stopped after 10× the plain method's steps (the table then says `> …`).

use std::fmt::Write as _;
use std::path::Path;

use lasalle::{Backend, GainPolicy, Parameters};
use serde_json::json;

use super::super::load::load;
use lasalle::{json_number as num, Base, Method, Recording, RunSpec};

use super::super::progress::simulate;
use super::{command_line, error_figure, sci, ExperimentArgs, Table};
use crate::cli::CliResult;

/// The tolerances of the study.
const TOLERANCES: [f64; 5] = [1e-8, 1e-10, 1e-12, 1e-14, 1e-15];

/// The largest final invariant error over the blocks (NaN if the run stopped early).
fn final_worst(t: &Recording) -> f64 {
    if t.failure.is_some() {
        return f64::NAN;
    }
    (0..t.blocks.len())
        .map(|b| t.final_error(b))
        .fold(0.0, f64::max)
}

/// Steps of a run, `> n` if it hit the step budget.
fn steps_cell(t: &Recording, budget: u64) -> String {
    match &t.failure {
        Some(lasalle::StepError::MaxSteps { .. }) => format!("> {budget}"),
        Some(e) => format!("failed: {e}"),
        None => t.steps.to_string(),
    }
}

/// The final error, or `—` for a run that stopped early.
fn error_cell(t: &Recording) -> String {
    if t.failure.is_some() {
        "—".to_string()
    } else {
        sci(final_worst(t))
    }
}

/// Runs the study into `dir`.
pub fn run(args: &ExperimentArgs, dir: &Path) -> CliResult {
    let periods = args.periods.unwrap_or(1000.0);
    let systems = [
        ("rigid-body", args.t_end.unwrap_or(1000.0)),
        ("kepler", periods * super::kepler::PERIOD),
        ("perturbed-kepler", periods * std::f64::consts::TAU),
    ];
    let mut table = Table::new(&[
        "system",
        "tol",
        "method",
        "steps plain",
        "steps fb auto",
        "ratio",
        "steps fb paper",
        "err plain",
        "err fb auto",
        "err fb paper",
    ]);
    let mut rows = Vec::new();
    let mut figure = Vec::new();
    for (name, t_end) in systems {
        let (model, _) = load(name, Backend::Jit)?;
        let x0 = model
            .point_names()
            .first()
            .and_then(|p| model.point(p))
            .ok_or_else(|| format!("model `{name}` has no named point"))?;
        for tol in TOLERANCES {
            for (label, plain, feedback) in [
                (
                    "dopri5",
                    Method::Plain(Base::Dopri5),
                    Method::Feedback(Base::Dopri5),
                ),
                (
                    "taylor",
                    Method::Taylor { feedback: false },
                    Method::Taylor { feedback: true },
                ),
            ] {
                let spec = |method: Method, gains: GainPolicy, max_steps: u64| {
                    let mut s = RunSpec::new(method, 0.01, t_end);
                    s.rtol = tol;
                    s.atol = tol;
                    s.gains = gains;
                    s.every = 10;
                    s.max_steps = max_steps;
                    s
                };
                let shown = !args.quiet;
                let p = simulate(
                    &model,
                    &x0,
                    &spec(plain, GainPolicy::Default, u64::MAX),
                    shown,
                )?;
                let a = simulate(
                    &model,
                    &x0,
                    &spec(feedback, GainPolicy::Auto, u64::MAX),
                    shown,
                )?;
                let budget = 10 * p.steps.max(1);
                let d = simulate(
                    &model,
                    &x0,
                    &spec(feedback, GainPolicy::ModelDefault, budget),
                    shown,
                )?;
                let ratio = a.steps as f64 / p.steps as f64;
                table.row(vec![
                    name.to_string(),
                    format!("{tol:e}"),
                    label.to_string(),
                    steps_cell(&p, budget),
                    steps_cell(&a, budget),
                    format!("{ratio:.3}"),
                    steps_cell(&d, budget),
                    error_cell(&p),
                    error_cell(&a),
                    error_cell(&d),
                ]);
                rows.push(json!({
                    "system": name, "t_end": t_end, "tol": tol, "method": label,
                    "steps_plain": p.steps, "steps_feedback_auto": a.steps,
                    "steps_feedback_paper": d.steps, "paper_hit_budget": d.failure.is_some(),
                    "ratio": ratio,
                    "final_error_plain": num(final_worst(&p)),
                    "final_error_feedback_auto": num(final_worst(&a)),
                    "final_error_feedback_paper": num(final_worst(&d)),
                    "gains_auto_initial": a.gains_initial,
                }));
                if name == "rigid-body" && tol == 1e-12 {
                    figure.push((p, plain, format!("{label}, plain")));
                    figure.push((a, feedback, format!("feedback-{label}, --gains auto")));
                }
            }
        }
    }
    let mut report = String::new();
    let _ = writeln!(
        report,
        "## Gains for adaptive methods\n\n`{}`\n\nSteps and the largest final invariant error \
         (over the invariant blocks) of DOPRI5 and the Taylor method at rtol = atol = tol: \
         plain, feedback with `--gains auto` (the step-tracking gain h·k·L(x) = 2·tol^(1/p)), \
         and feedback with the paper's gains (stopped after 10× the plain steps: `> n`). \
         Periods: {periods}.\n",
        command_line(args, "adaptive-gains")
    );
    report.push_str(&table.markdown());
    std::fs::write(dir.join("summary.md"), &report)?;
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&json!(rows))? + "\n",
    )?;
    if !args.no_figures && !figure.is_empty() {
        let methods: Vec<(Method, usize, &str)> = figure
            .iter()
            .enumerate()
            .map(|(i, (_, m, n))| (*m, i, n.as_str()))
            .collect();
        let traces: Vec<Recording> = figure.iter().map(|(t, _, _)| t.clone()).collect();
        error_figure(
            dir,
            (
                "adaptive-gains-rigid-body-energy",
                "E",
                "rigid body, tol 1e-12: energy error, plain vs feedback (--gains auto)",
                "|E(t) - E(0)|",
            ),
            &traces,
            &methods,
        )?;
    }
    if !args.quiet {
        println!("{report}");
        println!("wrote {}", dir.display());
    }
    Ok(())
}
