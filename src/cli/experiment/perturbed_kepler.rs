//! §4.3, Figs. 8–10: the perturbed Kepler problem U(r) = −μ/r − δ/r³, μ = 1, δ = 0.0025,
//! e = 0.6 (GNI Example IV.4.3), t ∈ [0, 200], Δt = 0.03: feedback-Euler (k₁ = 2, k₂ = 3),
//! projection-Euler (tolerance 1e-8), Störmer–Verlet (GNI (3.4)), and adaptive Dormand–Prince
//! 5(4) with rtol = atol = 1e-10 (the paper's `ode45`) as the reference. Beyond the paper's
//! figures: the distance |x(t) − x_ref(t)| of each orbit from the reference, the reference
//! interpolated at the fixed-step times (dense output), and the reference's own error against a
//! DOPRI5 run at rtol = atol = 1e-13.

use std::fmt::Write as _;
use std::path::Path;

use lasalle::models::perturbed_kepler::{PerturbedKepler, PerturbedKeplerPrepared};
use lasalle::{Control, Declared, DormandPrince, Driver, VerletVariant};
use serde_json::json;

use super::super::plot::{thin, write_figure, Chart, Style};
use lasalle::{json_number as num, Base, GainPolicy, Method, Recording, RunSpec};

use super::super::progress::simulate;
use super::hypotheses;
use super::{
    command_line, error_figure, failure_note, must, sci, write_outputs, ExperimentArgs, Table,
};
use crate::cli::CliResult;

const METHODS: [(Method, usize, &str); 4] = [
    (Method::Feedback(Base::Euler), 0, "feedback-Euler"),
    (Method::Projection(Base::Euler), 1, "projection-Euler"),
    (Method::StormerVerlet(VerletVariant::A), 2, "Störmer–Verlet"),
    (Method::Plain(Base::Dopri5), 5, "DOPRI5 (reference)"),
];

/// Tolerances of the reference (the paper's ode45 options).
pub const REFERENCE_TOL: f64 = 1e-10;
/// Tolerances of the run that checks the reference.
pub const CHECK_TOL: f64 = 1e-13;

/// DOPRI5 with rtol = atol = `tol`, interpolated at `times` (dense output); the states.
pub fn dense_reference(
    model: &PerturbedKeplerPrepared,
    x0: &[f64; 6],
    times: &[f64],
    tol: f64,
) -> Result<Vec<[f64; 6]>, String> {
    let mut out = Vec::with_capacity(times.len());
    let t_end = *times.last().ok_or("no output times")?;
    Driver::new(0.0, t_end, 0.0)
        .guard(1, |x: &[f64; 6]| {
            model.check_guards(x, 0.0).map(|g| g.to_string())
        })
        .run_dense(
            &mut DormandPrince::with_tolerances(tol, tol),
            model,
            x0,
            times,
            &mut |_i: u64, _t: f64, x: &[f64; 6]| {
                out.push(*x);
                Control::Continue
            },
        )
        .map_err(|e| format!("reference run failed: {e}"))?;
    Ok(out)
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Runs the experiment into `dir`.
pub fn run(args: &ExperimentArgs, dir: &Path) -> CliResult {
    let model = PerturbedKepler::default().prepare();
    let x0 = model.point_paper();
    let dt = args.dt.unwrap_or(0.03);
    let t_end = args.t_end.unwrap_or(200.0);
    let mut traces = Vec::new();
    for (method, _, _) in METHODS {
        let adaptive = method == Method::Plain(Base::Dopri5);
        let mut spec = RunSpec::new(method, if adaptive { 0.0 } else { dt }, t_end);
        // the paper's runs: the model file's gains, as the paper gives them
        if method.is_feedback() {
            spec.gains = GainPolicy::ModelDefault;
        }
        spec.every = 1;
        spec.tol = 1e-8;
        spec.rtol = REFERENCE_TOL;
        spec.atol = REFERENCE_TOL;
        traces.push(must(simulate(&model, &x0, &spec, !args.quiet))?);
    }
    // the reference at the fixed-step sample times, and its check at tighter tolerances
    let times = traces[0].t.clone();
    let reference = dense_reference(&model, &x0, &times, REFERENCE_TOL)?;
    let check = dense_reference(&model, &x0, &times, CHECK_TOL)?;
    let ref_error: Vec<f64> = reference
        .iter()
        .zip(&check)
        .map(|(a, b)| distance(a, b))
        .collect();
    let distances: Vec<Vec<f64>> = traces[..3]
        .iter()
        .map(|t| {
            (0..t.len().min(reference.len()))
                .map(|i| distance(t.state(i), &reference[i]))
                .collect()
        })
        .collect();
    let max = |v: &[f64]| v.iter().fold(0.0f64, |m, d| m.max(*d));

    let mut table = Table::new(&[
        "method",
        "wall [s]",
        "steps",
        "|ΔE|(T)",
        "max |ΔE|",
        "|ΔL|(T)",
        "max |ΔL|",
        "|x − x_ref|(T)",
        "max |x − x_ref|",
        "notes",
    ]);
    for (i, t) in traces.iter().enumerate() {
        let mut note = failure_note(t);
        if let (Some(n), Some(p)) = (t.counter("newton_iterations"), t.counter("projected_steps")) {
            note = format!("{p} of {} steps projected, {n} Newton iterations", t.steps);
        }
        let d = if i < 3 { &distances[i] } else { &ref_error };
        if i == 3 {
            note = format!(
                "{} rejected steps; distance = error vs DOPRI5 at tol {CHECK_TOL:e}",
                t.rejections
            );
        }
        table.row(vec![
            format!("`{}`", t.method),
            format!("{:.4}", t.wall_seconds),
            t.steps.to_string(),
            sci(t.final_of("E")),
            sci(t.max_of("E")),
            sci(t.final_of("L")),
            sci(t.max_of("L")),
            sci(*d.last().unwrap_or(&f64::NAN)),
            sci(max(d)),
            note,
        ]);
    }
    let mut report = String::new();
    let _ = writeln!(
        report,
        "## Perturbed Kepler problem (paper §4.3, Figs. 8–10)\n\n`{}`\n\nU(r) = −1/r − 0.0025/r³, \
         x(0) = (0.4, 0, 0), v(0) = (0, 2, 0), t ∈ [0, {t_end}], Δt = {dt}; feedback gains \
         (k₁, k₂) = (2, 3); projection tolerance 1e-8; reference DOPRI5 with rtol = atol = \
         {REFERENCE_TOL:e}, interpolated at the {} fixed-step times. Every step is sampled.\n",
        command_line(args, "perturbed-kepler"),
        times.len()
    );
    report.push_str(&table.markdown());

    let hyp = hypotheses::perturbed_kepler(&model, &x0);
    report.push_str(&hyp.markdown());
    hyp.print_warnings();

    let json = json!({
        "experiment": "perturbed-kepler",
        "hypotheses": hyp.json(),
        "dt": dt,
        "t_end": t_end,
        "command": command_line(args, "perturbed-kepler"),
        "methods": traces.iter().enumerate().map(|(i, t)| {
            let d = if i < 3 { &distances[i] } else { &ref_error };
            let mut s = t.summary_json();
            s["distance_from_reference"] = json!({
                "final": num(*d.last().unwrap_or(&f64::NAN)),
                "max": num(max(d)),
            });
            s
        }).collect::<Vec<_>>(),
    });
    write_outputs(
        dir,
        &traces.iter().collect::<Vec<_>>(),
        &report,
        json,
        args.quiet,
    )?;
    if !args.no_figures {
        figures(dir, &traces, &times, &distances, &ref_error)?;
    }
    Ok(())
}

fn figures(
    dir: &Path,
    traces: &[Recording],
    times: &[f64],
    distances: &[Vec<f64>],
    ref_error: &[f64],
) -> CliResult {
    let panels: Vec<Chart> = traces
        .iter()
        .zip(METHODS)
        .map(|(t, (_, color, name))| {
            let mut c = Chart::new(&format!("orbit x(t), {name}"), "x₁", "x₂", false);
            c.equal_aspect = true;
            let x1: Vec<f64> = (0..t.len()).map(|i| t.state(i)[0]).collect();
            let x2: Vec<f64> = (0..t.len()).map(|i| t.state(i)[1]).collect();
            c.add("", x1, x2, color, Style::Line);
            c
        })
        .collect();
    write_figure(dir, "fig8_orbit", &panels, (2, 2), (560, 460))?;
    for figure in [
        ("fig9_energy", "E", "energy error |E(t) − E(0)|", "|ΔE|"),
        (
            "fig10_angular_momentum",
            "L",
            "angular momentum error |L(t) − L(0)|",
            "|ΔL|",
        ),
    ] {
        error_figure(dir, figure, traces, &METHODS)?;
    }
    let mut c = Chart::new(
        "distance from the DOPRI5 reference |x(t) − x_ref(t)|",
        "t",
        "|x − x_ref|",
        true,
    );
    for (d, (_, color, name)) in distances.iter().zip(METHODS) {
        let (x, y) = thin(&times[..d.len()], d, 4000);
        c.add(name, x, y, color, Style::Line);
    }
    let (x, y) = thin(times, ref_error, 4000);
    c.add("DOPRI5 1e-10 vs 1e-13", x, y, 5, Style::Line);
    write_figure(dir, "fig11_distance", &[c], (1, 1), (900, 560))?;
    Ok(())
}
