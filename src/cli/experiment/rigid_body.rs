//! §4.1, Figs. 1–4: the free rigid body, 𝕀 = diag(3, 2, 1), R(0) = I, Ω(0) = (1, 1, 1),
//! t ∈ [0, 1000], Δt = 1e-4 (10⁷ steps per method): feedback-Euler (k₀ = 50, k₁ = 100,
//! k₂ = 50), projection-Euler (tolerance Δt, the paper's `fsolve` TolFun), the three-rotation
//! splitting, and Euler.

use std::fmt::Write as _;
use std::path::Path;

use lasalle::models::rigid_body::RigidBody;
use serde_json::json;

use super::super::plot::{thin, write_figure, Chart, Style};
use lasalle::{json_number as num, Base, GainPolicy, Method, Recording, RunSpec};

use super::super::progress::simulate;
use super::hypotheses;
use super::{
    command_line, error_figure, failure_note, must, sci, write_outputs, ExperimentArgs, Table,
};
use crate::cli::CliResult;

/// The paper's methods, colours and legend names.
const METHODS: [(Method, usize, &str); 4] = [
    (Method::Feedback(Base::Euler), 0, "feedback-Euler"),
    (Method::Projection(Base::Euler), 1, "projection-Euler"),
    (Method::Splitting, 2, "splitting"),
    (Method::Plain(Base::Euler), 4, "Euler"),
];

/// The paper's value of E_Euler(1000) − E_splitting(1000).
pub const PAPER_ENERGY_GAP: f64 = 1.767e-3;

/// Runs the experiment into `dir`.
pub fn run(args: &ExperimentArgs, dir: &Path) -> CliResult {
    let model = RigidBody::default().prepare();
    let x0 = model.point_paper();
    let dt = args.dt.unwrap_or(1e-4);
    let t_end = args.t_end.unwrap_or(1000.0);
    let mut traces = Vec::new();
    for (method, _, _) in METHODS {
        let mut spec = RunSpec::new(method, dt, t_end);
        // the paper's runs: the model file's gains, as the paper gives them
        if method.is_feedback() {
            spec.gains = GainPolicy::ModelDefault;
        }
        // about 10⁴ samples: every 0.1 time units at the paper's step
        spec.every = (spec.steps() / 10_000).max(1);
        spec.tol = dt;
        traces.push(must(simulate(&model, &x0, &spec, !args.quiet))?);
    }
    let energy = |t: &Recording| {
        let w = &t.last_state()[9..12];
        0.5 * (model.i[0] * w[0] * w[0] + model.i[1] * w[1] * w[1] + model.i[2] * w[2] * w[2])
    };
    let (fb, proj, split, euler) = (&traces[0], &traces[1], &traces[2], &traces[3]);
    let gap = energy(euler) - energy(split);

    let mut table = Table::new(&[
        "method",
        "wall [s]",
        "steps",
        "|ΔE|(T)",
        "max |ΔE|",
        "|Δπ|(T)",
        "max |Δπ|",
        "‖RᵀR−I‖(T)",
        "max ‖RᵀR−I‖",
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
            sci(t.final_of("E")),
            sci(t.max_of("E")),
            sci(t.final_of("pi")),
            sci(t.max_of("pi")),
            sci(t.final_of("C")),
            sci(t.max_of("C")),
            note,
        ]);
    }
    let mut report = String::new();
    let _ = writeln!(
        report,
        "## Free rigid body (paper §4.1, Figs. 1–4)\n\n`{}`\n\n𝕀 = diag(3, 2, 1), R(0) = I, Ω(0) = (1, 1, 1), \
         t ∈ [0, {t_end}], Δt = {dt}; feedback gains (k₀, k₁, k₂) = (50, 100, 50); projection \
         tolerance {dt} on |f(x) − f(x₀)|₂. Errors at T = {t_end} and the largest of {} samples \
         (every {} steps).\n",
        command_line(args, "rigid-body"),
        fb.len(),
        fb.every
    );
    report.push_str(&table.markdown());
    let _ = writeln!(
        report,
        "\nE_Euler(T) − E_splitting(T) = {} (paper, T = 1000: {PAPER_ENERGY_GAP:.3e}); \
         E_splitting(T) − E(0) = {}.",
        sci(gap),
        sci(energy(split) - 3.0)
    );
    let _ = writeln!(
        report,
        "Wall time relative to feedback-Euler: projection {:.2}×, splitting {:.2}×, Euler {:.2}×.",
        proj.wall_seconds / fb.wall_seconds,
        split.wall_seconds / fb.wall_seconds,
        euler.wall_seconds / fb.wall_seconds
    );

    let hyp = hypotheses::rigid_body(&model, &x0, RigidBody::<f64>::default_gains(), fb);
    report.push_str(&hyp.markdown());
    hyp.print_warnings();

    let json = json!({
        "experiment": "rigid-body",
        "hypotheses": hyp.json(),
        "dt": dt,
        "t_end": t_end,
        "command": command_line(args, "rigid-body"),
        "methods": traces.iter().map(|t| t.summary_json()).collect::<Vec<_>>(),
        "energy_gap_euler_minus_splitting": num(gap),
        "paper_energy_gap": PAPER_ENERGY_GAP,
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
    // Fig. 1: Ω(t), one panel per method
    let panels: Vec<Chart> = traces
        .iter()
        .zip(METHODS)
        .map(|(t, (_, _, name))| {
            let mut c = Chart::new(&format!("Ω(t), {name}"), "t", "Ω", false);
            for k in 0..3 {
                let y: Vec<f64> = (0..t.len()).map(|i| t.state(i)[9 + k]).collect();
                let (x, y) = thin(&t.t, &y, 4000);
                c.add(&format!("Ω{}", k + 1), x, y, [0, 3, 2][k], Style::Line);
            }
            c
        })
        .collect();
    write_figure(dir, "fig1_omega", &panels, (2, 2), (640, 400))?;
    for figure in [
        ("fig2_energy", "E", "energy error |E(t) − E(0)|", "|ΔE|"),
        (
            "fig3_momentum",
            "pi",
            "spatial angular momentum error |π(t) − π(0)|",
            "|Δπ|",
        ),
        (
            "fig4_constraint",
            "C",
            "deviation from SO(3) ‖R(t)ᵀR(t) − I‖",
            "‖RᵀR − I‖",
        ),
    ] {
        error_figure(dir, figure, traces, &METHODS)?;
    }
    Ok(())
}
