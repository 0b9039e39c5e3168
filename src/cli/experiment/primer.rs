//! The primer vector on coast arcs ("Analytical solution of the Euler–Lagrange equations for
//! optimum coast trajectories", NASA TM X-53478, seventh paper): the closed form
//! λ = F R + G Ṙ + (K₁x + K₂y)k ([`lasalle_analysis::primer`]) against the adjoint equation
//! (6) integrated as the variational equation of `models/kepler.lsl` (its state-transition
//! matrix, Taylor method, ε = 10⁻¹⁶) — the paper's test: a coast begun 1000 s after perigee,
//! compared 100 s later, for e = 0, 0.5, 0.9, 0.99, 1 and the hyperbola e = 1.5; then the
//! forms of G near e = 1 ((17), (18), the printed (25) and the first-order series).

use std::fmt::Write as _;
use std::path::Path;

use lasalle::run::chaos::state_transition;
use lasalle::{Backend, Method, Parameters, RunSpec};
use lasalle_analysis::primer::{digits, Coast, Conic, GForm, Primer};
use serde_json::json;

use super::super::load::load;
use super::{write_outputs, ExperimentArgs, Table};
use crate::cli::CliResult;

/// Earth's μ [km³/s²] and a perigee 300 km above a 6378.137 km Earth [km].
pub const MU: f64 = 398_600.441_8;
/// The perigee radius [km].
pub const RP: f64 = 6678.137;
/// The start of the coast after perigee and its length [s] (the paper's).
pub const T0: f64 = 1000.0;
/// The coast's length [s].
pub const COAST: f64 = 100.0;
/// λ and λ̇ at the start of the coast (perifocal axes; any values with a normal part).
pub const LAMBDA0: [f64; 3] = [0.3, -0.8, 0.5];
/// λ̇ at the start [1/s].
pub const DLAMBDA0: [f64; 3] = [1.2e-3, 0.7e-3, -0.9e-3];

/// The paper's eccentricities with the exact form of G for each.
const PAPER: [(f64, GForm); 6] = [
    (0.0, GForm::Exact),
    (0.5, GForm::Exact),
    (0.9, GForm::Exact),
    (0.99, GForm::Exact),
    (1.0, GForm::Parabolic),
    (1.5, GForm::Exact),
];

/// Eccentricities near 1 at which every form of G is compared.
const NEAR: [f64; 5] = [1.0 - 1e-2, 1.0 - 1e-4, 1.0 - 1e-7, 1.0 + 1e-7, 1.0 + 1e-4];

/// λ(t₁), λ̇(t₁) from the Kepler model's state-transition matrix over the coast.
fn integrated(model: &lasalle::LoadedModel, conic: &Conic) -> Result<Primer, String> {
    let s = conic.state(T0).map_err(|e| e.to_string())?;
    let x0 = [s.x, s.y, 0.0, s.vx, s.vy, 0.0];
    let mut spec = RunSpec::new(Method::Taylor { feedback: false }, 0.0, COAST);
    spec.rtol = 1e-16;
    spec.atol = 1e-16;
    let tr = state_transition(model, &x0, &spec).map_err(|e| e.to_string())?;
    let w0: Vec<f64> = LAMBDA0.iter().chain(&DLAMBDA0).copied().collect();
    let w: Vec<f64> = tr
        .phi
        .iter()
        .map(|row| row.iter().zip(&w0).map(|(a, b)| a * b).sum())
        .collect();
    Ok(Primer {
        lambda: [w[0], w[1], w[2]],
        dlambda: [w[3], w[4], w[5]],
    })
}

fn closed(conic: Conic, form: GForm) -> Result<Primer, String> {
    Coast::new(conic, form, T0, LAMBDA0, DLAMBDA0)
        .and_then(|c| c.primer(T0 + COAST))
        .map_err(|e| e.to_string())
}

fn vec3(v: [f64; 3]) -> String {
    format!("({:.10e}, {:.10e}, {:.10e})", v[0], v[1], v[2])
}

fn orbit(e: f64) -> &'static str {
    if e == 0.0 {
        "circle"
    } else if e < 1.0 {
        "ellipse"
    } else if e == 1.0 {
        "parabola"
    } else {
        "hyperbola"
    }
}

/// Runs the experiment into `dir`.
pub fn run(args: &ExperimentArgs, dir: &Path) -> CliResult {
    let (mut model, _) = load("kepler", Backend::Jit)?;
    model.set_param("mu", &[MU])?;
    let mut report = String::new();
    let _ = writeln!(
        report,
        "# The primer vector on coast arcs\n\n`cargo run --release -- experiment primer-vector`\n\n\
         μ = {MU} km³/s², r_p = {RP} km; a coast from t₀ = {T0} s after perigee to t₁ = {} s; \
         λ(t₀) = {LAMBDA0:?}, λ̇(t₀) = {DLAMBDA0:?} (perifocal axes). Integrated: the \
         state-transition matrix of models/kepler.lsl (Taylor, ε = 10⁻¹⁶) applied to (λ, λ̇)(t₀). \
         Digits: −log₁₀ of the relative difference of the vectors.\n",
        T0 + COAST
    );
    let mut table = Table::new(&[
        "e",
        "orbit",
        "G",
        "λ(t₁) closed form",
        "λ(t₁) integrated",
        "digits λ",
        "digits λ̇",
    ]);
    let mut rows = Vec::new();
    for (e, form) in PAPER {
        let conic = Conic::new(MU, RP, e)?;
        let (num, cf) = (integrated(&model, &conic)?, closed(conic, form)?);
        let (dl, dd) = (
            digits(&num.lambda, &cf.lambda),
            digits(&num.dlambda, &cf.dlambda),
        );
        table.row(vec![
            format!("{e}"),
            orbit(e).into(),
            form.name().into(),
            vec3(cf.lambda),
            vec3(num.lambda),
            format!("{dl:.1}"),
            format!("{dd:.1}"),
        ]);
        rows.push(
            json!({"e": e, "form": form.name(), "closed": cf.lambda, "integrated": num.lambda,
            "closed_dlambda": cf.dlambda, "integrated_dlambda": num.dlambda,
            "digits_lambda": dl, "digits_dlambda": dd}),
        );
    }
    let _ = writeln!(report, "## The paper's comparison\n\n{}", table.markdown());
    let mut near = Table::new(&["e", "(17)", "(18)", "(25) printed", "series"]);
    let mut near_json = Vec::new();
    for e in NEAR {
        let conic = Conic::new(MU, RP, e)?;
        let num = integrated(&model, &conic)?;
        let mut cells = vec![format!(
            "1 {} {:.0e}",
            if e < 1.0 { "−" } else { "+" },
            (1.0 - e).abs()
        )];
        let mut d = Vec::new();
        for form in GForm::ALL {
            let dl = digits(&num.lambda, &closed(conic, form)?.lambda);
            cells.push(format!("{dl:.1}"));
            d.push(dl);
        }
        near.row(cells);
        near_json.push(
            json!({"e": e, "digits_lambda": {"17": d[0], "18": d[1], "25": d[2], "series": d[3]}}),
        );
    }
    let _ = writeln!(
        report,
        "## Near e = 1: digits of λ(t₁) from each form of G\n\n{}",
        near.markdown()
    );
    let json = json!({"mu": MU, "rp": RP, "t0": T0, "t1": T0 + COAST, "lambda0": LAMBDA0,
        "dlambda0": DLAMBDA0, "paper": rows, "near_parabolic": near_json});
    write_outputs(dir, &[], &report, json, args.quiet)
}
