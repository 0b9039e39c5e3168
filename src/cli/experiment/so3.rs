//! Optimal control on SO(3) (Rodgerson 2009, chs. 4–7): the four extremal systems Ṗ = P × ∇H
//! with the reconstruction ġ = g Ξ(u(P)), each from the first Appendix B case of its type
//! (the model file's first `run` preset, with its parameters), integrated to t = 1000 by
//! feedback-Euler, Euler, RK4 and DOPRI5: does g stay in SO(3), are H, the Casimir |P|² and the
//! spatial momentum Λ = gP kept? The models are loaded from their files (JIT), so this
//! experiment is also the run-time path's end-to-end check.

use std::fmt::Write as _;
use std::path::Path;

use lasalle::{Backend, Declared, Parameters};
use lasalle_analysis::closed_forms::{Extremal, Type};
use serde_json::json;

use super::super::load::load;
use super::super::plot::{thin, write_figure, Chart, Style};
use lasalle::{Base, GainPolicy, Method, Recording, RunSpec};

use super::super::progress::simulate;
use super::{
    command_line, error_figure, failure_note, must, sci, write_outputs, ExperimentArgs, Table,
};
use crate::cli::CliResult;

/// The methods, colours and legend names.
const METHODS: [(Method, usize, &str); 4] = [
    (Method::Feedback(Base::Euler), 0, "feedback-Euler"),
    (Method::Plain(Base::Euler), 4, "Euler"),
    (Method::Plain(Base::Rk4), 1, "RK4"),
    (Method::Plain(Base::Dopri5), 2, "DOPRI5"),
];

/// The four types: model file, title, the thesis' type.
const TYPES: [(&str, &str, Type); 4] = [
    ("so3_type_i", "Type I (ch. 4)", Type::I),
    ("so3_type_iia", "Type IIa (ch. 5)", Type::IIa),
    ("so3_type_iib", "Type IIb (ch. 6)", Type::IIb),
    ("so3_type_iii", "Type III (ch. 7)", Type::III),
];

/// The span of Appendix C's plots, over which the closed form is compared.
const CLOSED_FORM_SPAN: f64 = 30.0;

/// Runs the experiment into `dir` (a subdirectory per type).
pub fn run(args: &ExperimentArgs, dir: &Path) -> CliResult {
    let dt = args.dt.unwrap_or(1e-3);
    let t_end = args.t_end.unwrap_or(1000.0);
    let mut report = format!(
        "## Optimal control on SO(3): the four extremal systems with reconstruction\n\n`{}`\n\n\
         From the first Appendix B case of each type (g(0) = I), t ∈ [0, {t_end}], Δt = {dt} \
         (DOPRI5: rtol = atol = 1e-10); feedback-Euler with the model's gains. Largest errors \
         over the run.\n",
        command_line(args, "so3")
    );
    let mut json_types = Vec::new();
    for (stem, title, ty) in TYPES {
        let (mut model, _) = load(stem, Backend::Jit)?;
        let preset = model
            .presets()
            .first()
            .ok_or_else(|| format!("{stem}: no run preset for its Appendix B case"))?;
        for (name, values) in preset.params {
            model.set_param(name, values)?;
        }
        let init = preset
            .init
            .ok_or_else(|| format!("{stem}: the preset has no point"))?;
        let x0 = model
            .point(init)
            .ok_or_else(|| format!("{stem}: no point `{init}`"))?;
        let mut traces = Vec::new();
        for (method, _, _) in METHODS {
            let mut spec = RunSpec::new(method, dt, t_end);
            // the paper's runs: the model file's gains, as the paper gives them
            if method.is_feedback() {
                spec.gains = GainPolicy::ModelDefault;
            }
            // every accepted step of the adaptive method (≈ 5·10⁴), ≈ 10⁴ samples otherwise
            spec.every = if method.is_adaptive() {
                1
            } else {
                (spec.steps() / 10_000).max(1)
            };
            traces.push(must(simulate(&model, &x0, &spec, !args.quiet))?);
        }
        // the corrected closed form (docs/so3.md) against DOPRI5
        let c = ["c1", "c2", "c3"].map(|n| model.param(n).map_or(1.0, |v| v[0]));
        let closed = Extremal::new(ty, c, [x0[0], x0[1], x0[2]]);
        let reference = &traces[3];
        let closed_gap = (0..reference.len())
            .filter(|&i| reference.t[i] <= CLOSED_FORM_SPAN)
            .map(|i| {
                let p = closed.p(reference.t[i]);
                (0..3)
                    .map(|k| (p[k] - reference.state(i)[k]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        let mut table = Table::new(&[
            "method",
            "wall [s]",
            "steps",
            "max ‖gᵀg − I‖",
            "max |ΔH|",
            "max |Δ|P|²|",
            "max |ΔΛ|",
            "notes",
        ]);
        for t in &traces {
            table.row(vec![
                format!("`{}`", t.method),
                format!("{:.2}", t.wall_seconds),
                t.steps.to_string(),
                sci(t.max_of("orthogonality")),
                sci(t.max_of("H")),
                sci(t.max_of("casimir")),
                sci(t.max_of("Lambda")),
                failure_note(t),
            ]);
        }
        let params: Vec<String> = preset
            .params
            .iter()
            .map(|(n, v)| format!("{n} = {}", v[0]))
            .collect();
        let _ = writeln!(
            report,
            "\n### {title}: case `{}` ({}), P(0) = ({:.4}, {:.4}, {:.4})\n",
            preset.name,
            params.join(", "),
            x0[0],
            x0[1],
            x0[2]
        );
        report.push_str(&table.markdown());
        let _ = writeln!(
            report,
            "\nCorrected closed form vs DOPRI5 on [0, {CLOSED_FORM_SPAN}]: max |ΔP| = {} (the \
             integration's own error at rtol = atol = 1e-10).",
            sci(closed_gap)
        );
        let sub = dir.join(stem);
        std::fs::create_dir_all(&sub)
            .map_err(|e| format!("cannot create {}: {e}", sub.display()))?;
        write_outputs(
            &sub,
            &traces.iter().collect::<Vec<_>>(),
            &table.markdown(),
            json!({ "type": stem, "methods": traces.iter().map(|t| t.summary_json()).collect::<Vec<_>>() }),
            true,
        )?;
        if !args.no_figures {
            figures(&sub, title, &traces, &closed)?;
        }
        json_types.push(json!({
            "type": stem,
            "case": preset.name,
            "closed_form_max_difference": closed_gap,
            "methods": traces.iter().map(|t| t.summary_json()).collect::<Vec<_>>(),
        }));
    }
    let json = json!({
        "experiment": "so3",
        "dt": dt,
        "t_end": t_end,
        "command": command_line(args, "so3"),
        "types": json_types,
    });
    write_outputs(dir, &[], &report, json, args.quiet)
}

fn figures(dir: &Path, title: &str, traces: &[Recording], closed: &Extremal) -> CliResult {
    // P(t) from DOPRI5 (lines) and the closed form (dots) over Appendix C's span
    let reference = &traces[3];
    let mut c = Chart::new(
        &format!("P(t), {title}: DOPRI5 (lines), closed form (dots)"),
        "t",
        "P",
        false,
    );
    let shown: Vec<usize> = (0..reference.len())
        .filter(|&i| reference.t[i] <= CLOSED_FORM_SPAN)
        .collect();
    let t: Vec<f64> = shown.iter().map(|&i| reference.t[i]).collect();
    let t_dots: Vec<f64> = (0..=120)
        .map(|i| i as f64 * CLOSED_FORM_SPAN / 120.0)
        .collect();
    for k in 0..3 {
        let y: Vec<f64> = shown.iter().map(|&i| reference.state(i)[k]).collect();
        let (x, y) = thin(&t, &y, 4000);
        c.add(&format!("P{}", k + 1), x, y, [0, 3, 2][k], Style::Line);
        let y: Vec<f64> = t_dots.iter().map(|&s| closed.p(s)[k]).collect();
        c.add(
            &format!("P{} closed form", k + 1),
            t_dots.clone(),
            y,
            [0, 3, 2][k],
            Style::Dots,
        );
    }
    write_figure(dir, "fig_p", &[c], (1, 1), (900, 500))?;
    let p: Vec<[f64; 3]> = shown
        .iter()
        .map(|&i| {
            let x = reference.state(i);
            [x[0], x[1], x[2]]
        })
        .collect();
    let p_dots: Vec<[f64; 3]> = t_dots.iter().map(|&s| closed.p(s)).collect();
    write_figure(
        dir,
        "fig_sphere",
        &[sphere_chart(title, &p, &p_dots)],
        (1, 1),
        (640, 640),
    )?;
    for figure in [
        (
            "fig_orthogonality",
            "orthogonality",
            "deviation from SO(3) ‖gᵀg − I‖",
            "‖gᵀg − I‖",
        ),
        (
            "fig_hamiltonian",
            "H",
            "Hamiltonian error |H(t) − H(0)|",
            "|ΔH|",
        ),
        (
            "fig_casimir",
            "casimir",
            "Casimir error ||P(t)|² − |P(0)|²|",
            "|Δ|P|²|",
        ),
        (
            "fig_lambda",
            "Lambda",
            "spatial momentum error |gP(t) − gP(0)|",
            "|ΔΛ|",
        ),
    ] {
        error_figure(dir, figure, traces, &METHODS)?;
    }
    Ok(())
}

/// MATLAB's default `plot3` view (azimuth −37.5°, elevation 30°), as in Appendix C's (b), (d),
/// (f) panels: the unit vector towards the viewer and the screen's right and up directions.
fn matlab_view() -> [[f64; 3]; 3] {
    let (az, el) = ((-37.5f64).to_radians(), 30f64.to_radians());
    [
        [el.cos() * az.sin(), -el.cos() * az.cos(), el.sin()],
        [az.cos(), az.sin(), 0.0],
        [-el.sin() * az.sin(), el.sin() * az.cos(), el.cos()],
    ]
}

/// The curve P(t) on its Casimir sphere |P| = |P(0)| seen from MATLAB's default viewpoint
/// (orthographic): the sphere's outline and the front halves of the three coordinate great
/// circles, the integrated curve (solid in front, dotted behind the sphere) and the closed form
/// (dots).
fn sphere_chart(title: &str, p: &[[f64; 3]], closed: &[[f64; 3]]) -> Chart {
    let [toward, right, up] = matlab_view();
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let rho = p.first().map_or(1.0, |x| dot(x, x).sqrt());
    let mut c = Chart::new(
        &format!("P(t) on the Casimir sphere |P| = {rho:.4}, {title}"),
        "screen x (view az −37.5°, el 30°)",
        "screen y",
        false,
    );
    c.equal_aspect = true;
    let circle = |f: &dyn Fn(f64) -> [f64; 3]| -> Vec<[f64; 3]> {
        (0..=360).map(|i| f((i as f64).to_radians())).collect()
    };
    // the outline: the great circle orthogonal to the line of sight
    let outline =
        circle(&|a| std::array::from_fn(|k| rho * (a.cos() * right[k] + a.sin() * up[k])));
    c.add(
        "",
        outline.iter().map(|x| dot(x, &right)).collect(),
        outline.iter().map(|x| dot(x, &up)).collect(),
        5,
        Style::Line,
    );
    // front halves of the coordinate great circles, pen up behind the sphere
    let project_front = |pts: &[[f64; 3]]| -> (Vec<f64>, Vec<f64>) {
        pts.iter()
            .map(|x| {
                if dot(x, &toward) >= 0.0 {
                    (dot(x, &right), dot(x, &up))
                } else {
                    (f64::NAN, f64::NAN)
                }
            })
            .unzip()
    };
    for k in 0..3 {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let great = circle(&|a| {
            let mut x = [0.0; 3];
            x[i] = rho * a.cos();
            x[j] = rho * a.sin();
            x
        });
        let sparse: Vec<[f64; 3]> = great.into_iter().step_by(3).collect();
        let (x, y) = project_front(&sparse);
        c.add("", x, y, 5, Style::Dots);
    }
    let (x, y) = project_front(p);
    c.add("DOPRI5 (front)", x, y, 0, Style::Line);
    let (x, y): (Vec<f64>, Vec<f64>) = p
        .iter()
        .filter(|x| dot(x, &toward) < 0.0)
        .step_by(4)
        .map(|x| (dot(x, &right), dot(x, &up)))
        .unzip();
    c.add("DOPRI5 (behind)", x, y, 4, Style::Dots);
    let (x, y): (Vec<f64>, Vec<f64>) = closed.iter().map(|x| (dot(x, &right), dot(x, &up))).unzip();
    c.add("closed form", x, y, 3, Style::Dots);
    c
}
