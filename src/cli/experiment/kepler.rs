//! §4.2, Figs. 5–7: the Kepler problem, μ = 1, x(0) = (1, 0, 0), v(0) = (0, √1.8, 0)
//! (e = 0.8, period T = 70.2481), t ∈ [0, 1000T], Δt = 0.005 (1.4·10⁷ steps per method):
//! feedback-Euler (k₁ = 4, k₂ = 2), projection-Euler (tolerance Δt), Störmer–Verlet A and B.

use std::fmt::Write as _;
use std::path::Path;

use lasalle::models::kepler::Kepler;
use lasalle::VerletVariant;
use serde_json::json;

use super::super::plot::{decimate, write_figure, Chart, Style};
use lasalle::{json_number as num, Base, GainPolicy, Method, Recording, RunSpec};

use super::super::progress::simulate;
use super::hypotheses;
use super::{
    command_line, error_figure, failure_note, must, sci, write_outputs, ExperimentArgs, Table,
};
use crate::cli::CliResult;

/// The period of the paper's orbit, 2π a^{3/2} with a = 1/(2 − 1.8) = 5, as the paper rounds it.
pub const PERIOD: f64 = 70.2481;

const METHODS: [(Method, usize, &str); 4] = [
    (Method::Feedback(Base::Euler), 0, "feedback-Euler"),
    (Method::Projection(Base::Euler), 1, "projection-Euler"),
    (
        Method::StormerVerlet(VerletVariant::A),
        2,
        "Störmer–Verlet A",
    ),
    (
        Method::StormerVerlet(VerletVariant::B),
        3,
        "Störmer–Verlet B",
    ),
];

/// The Laplace–Runge–Lenz vector A = v × (x × v) − μ x/|x| of a state (x, v).
pub fn lrl(s: &[f64], mu: f64) -> [f64; 3] {
    let (x, v) = ([s[0], s[1], s[2]], [s[3], s[4], s[5]]);
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let l = cross(x, v);
    let vl = cross(v, l);
    let r = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
    [
        vl[0] - mu * x[0] / r,
        vl[1] - mu * x[1] / r,
        vl[2] - mu * x[2] / r,
    ]
}

/// Runs the experiment into `dir`.
pub fn run(args: &ExperimentArgs, dir: &Path) -> CliResult {
    let model = Kepler::default().prepare();
    let x0 = model.point_paper();
    let dt = args.dt.unwrap_or(0.005);
    let periods = args.periods.unwrap_or(1000.0);
    let t_end = args.t_end.unwrap_or(periods * PERIOD);
    let mut traces = Vec::new();
    for (method, _, _) in METHODS {
        let mut spec = RunSpec::new(method, dt, t_end);
        // the paper's runs: the model file's gains, as the paper gives them
        if method.is_feedback() {
            spec.gains = GainPolicy::ModelDefault;
        }
        spec.every = (spec.steps() / 20_000).max(1);
        spec.tol = dt;
        traces.push(must(simulate(&model, &x0, &spec, !args.quiet))?);
    }
    let angle = |t: &Recording| {
        let a = lrl(t.last_state(), model.mu);
        a[1].atan2(a[0])
    };
    let mut table = Table::new(&[
        "method",
        "wall [s]",
        "steps",
        "|ΔA|(T)",
        "max |ΔA|",
        "|ΔL|(T)",
        "max |ΔL|",
        "arg A(T) [rad]",
        "notes",
    ]);
    for t in &traces {
        let mut note = failure_note(t);
        if let (Some(n), Some(p)) = (t.counter("newton_iterations"), t.counter("projected_steps")) {
            note = format!("{p} of {} steps projected, {n} Newton iterations", t.steps);
        }
        table.row(vec![
            format!("`{}`", t.method),
            format!("{:.2}", t.wall_seconds),
            t.steps.to_string(),
            sci(t.final_of("A")),
            sci(t.max_of("A")),
            sci(t.final_of("L")),
            sci(t.max_of("L")),
            format!("{:+.3e}", angle(t)),
            note,
        ]);
    }
    let fb = &traces[0];
    let mut report = String::new();
    let _ = writeln!(
        report,
        "## Kepler problem (paper §4.2, Figs. 5–7)\n\n`{}`\n\nμ = 1, x(0) = (1, 0, 0), v(0) = (0, √1.8, 0), \
         t ∈ [0, {t_end:.1}] ({:.1} periods of T = {PERIOD}), Δt = {dt}; feedback gains (k₁, k₂) = (4, 2); \
         projection tolerance {dt}. Errors at the end and the largest of {} samples (every {} steps); \
         arg A is the perihelion direction (0 initially): its drift is the precession.\n",
        command_line(args, "kepler"),
        t_end / PERIOD,
        fb.len(),
        fb.every
    );
    report.push_str(&table.markdown());
    let _ = writeln!(
        report,
        "\nWall time relative to feedback-Euler: {}.",
        traces[1..]
            .iter()
            .map(|t| format!("{} {:.2}×", t.method, t.wall_seconds / fb.wall_seconds))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let hyp = hypotheses::kepler(&model, &x0, Kepler::<f64>::default_gains(), fb);
    report.push_str(&hyp.markdown());
    hyp.print_warnings();
    let json = json!({
        "experiment": "kepler",
        "hypotheses": hyp.json(),
        "dt": dt,
        "t_end": t_end,
        "period": PERIOD,
        "command": command_line(args, "kepler"),
        "methods": traces.iter().map(|t| {
            let mut s = t.summary_json();
            s["lrl_angle_final"] = num(angle(t));
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
        figures(dir, &traces)?;
    }
    Ok(())
}

fn figures(dir: &Path, traces: &[Recording]) -> CliResult {
    let panels: Vec<Chart> = traces
        .iter()
        .zip(METHODS)
        .map(|(t, (_, color, name))| {
            let mut c = Chart::new(&format!("orbit x(t), {name}"), "x₁", "x₂", false);
            c.equal_aspect = true;
            let x1: Vec<f64> = (0..t.len()).map(|i| t.state(i)[0]).collect();
            let x2: Vec<f64> = (0..t.len()).map(|i| t.state(i)[1]).collect();
            let (x1, x2) = decimate(&x1, &x2, 8000);
            c.add("", x1, x2, color, Style::Dots);
            c
        })
        .collect();
    write_figure(dir, "fig5_orbit", &panels, (2, 2), (560, 460))?;
    for figure in [
        (
            "fig6_lrl",
            "A",
            "Laplace–Runge–Lenz vector error |A(t) − A(0)|",
            "|ΔA|",
        ),
        (
            "fig7_angular_momentum",
            "L",
            "angular momentum error |L(t) − L(0)|",
            "|ΔL|",
        ),
    ] {
        error_figure(dir, figure, traces, &METHODS)?;
    }
    Ok(())
}
