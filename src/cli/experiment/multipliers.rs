//! Multipliers across coordinate systems (NASA TM X-53478, fourth paper: transforming
//! state variables and their Lagrange multipliers between coordinate systems): a thrusting
//! extremal integrated in the plumb-line frame (DOPRI5, rtol 1e-13), carried to the spherical
//! flight-path frame by λ = Jᵀσ ([`lasalle_analysis::multipliers`]), with the residuals of the
//! paper's identities at every accepted step; the transformed Euler–Lagrange equations against the spherical ones at
//! random points; the paper's printed partials against the IR's inverse Jacobian; and the
//! errors at the singular points of the change.

use std::fmt::Write as _;
use std::path::Path;

use lasalle_analysis::multipliers::flight_path::{
    self, example, printed_partials, sample_points, spherical, Check,
};
use serde_json::json;

use super::{write_outputs, ExperimentArgs};
use crate::cli::CliResult;

/// The paper's identities must hold to this relative residual.
const TOL: f64 = 1e-12;
/// The length of the thrust arc [s].
const ARC: f64 = 600.0;

/// The residuals along the extremal: the CSV and the worst of each column.
fn along(check: &Check, t_end: f64, dir: &Path) -> CliResult<([f64; 6], usize, (f64, f64))> {
    let (e, y0, s0, _) = example();
    let path = e.integrate(&y0, &s0, t_end)?;
    let mut csv = String::from(
        "t,r,phi,theta,v,gamma,delta,tan_alpha,tan_beta,norm,tan_alpha_res,tan_beta_res,thrust_res,state_res,adjoint_res\n",
    );
    let mut worst = [0.0f64; 6];
    let mut lambda_v = (f64::INFINITY, f64::NEG_INFINITY);
    for (t, y, s) in &path {
        let r = check.at(&e, *t, y, s)?;
        let x = spherical(y);
        let l = check.change().multipliers(&x, s)?;
        lambda_v = (lambda_v.0.min(l[3]), lambda_v.1.max(l[3]));
        let res = [
            r.norm,
            r.tan_alpha,
            r.tan_beta,
            r.thrust,
            r.state,
            r.adjoint,
        ];
        for (w, v) in worst.iter_mut().zip(res) {
            *w = w.max(v);
        }
        let _ = writeln!(
            csv,
            "{t},{},{},{},{},{},{},{},{},{}",
            x.map(|v| v.to_string()).join(","),
            r.tans.0,
            r.tans.1,
            res[0],
            res[1],
            res[2],
            res[3],
            res[4],
            res[5]
        );
    }
    std::fs::write(dir.join("extremal.csv"), csv)?;
    Ok((worst, path.len(), lambda_v))
}

/// The largest difference between the IR's ∂(v, γ, δ)/∂(l, m, n) and the printed partials,
/// for each entry, over the random points.
fn partials() -> CliResult<[[f64; 3]; 3]> {
    let change = flight_path::change();
    let mut worst = [[0.0f64; 3]; 3];
    for (x, _) in sample_points(200, 3) {
        let inv = change
            .jacobian(&x)?
            .try_inverse()
            .ok_or("the Jacobian is not invertible at a sample point")?;
        let p = printed_partials(&x);
        for a in 0..3 {
            for b in 0..3 {
                let d = (inv[(3 + a, 3 + b)] - p[a][b]).abs() / (1.0 + p[a][b].abs());
                worst[a][b] = worst[a][b].max(d);
            }
        }
    }
    Ok(worst)
}

/// Runs the experiment into `dir`.
pub fn run(args: &ExperimentArgs, dir: &Path) -> CliResult {
    let check = Check::new();
    let t_end = args.t_end.unwrap_or(ARC);
    let (worst, steps, lambda_v) = along(&check, t_end, dir)?;
    let names = [
        "σ_l² + σ_m² + σ_n² = λ_v² + λ_γ²/v² + λ_δ²/(v² cos²γ)",
        "tan α = λ_γ/(v λ_v)",
        "tan β = λ_δ/(v λ_v cos γ)",
        "\\|a\\| from the rates = T/M",
        "ẋ = J⁻¹ẏ against the printed spherical equations",
        "λ̇ = Jᵀσ̇ + J̇ᵀσ against −∂(λ·f)/∂x",
    ];
    let mut report = format!(
        "# Multipliers across coordinate systems\n\n`cargo run --release -- experiment multipliers`\n\n\
         A thrusting extremal in the plumb-line frame (μ = 398600.4418 km³/s², a = a₀/(1 − kt), \
         a₀ = 20 m/s², k = 10⁻³/s, thrust along σ_V) from (r, φ, θ, v, γ, δ) = (6678.137 km, 0.3, \
         0.5, 7.9 km/s, 0.05, 0.8), integrated over [0, {t_end}] s by DOPRI5 (rtol 10⁻¹³), {steps} \
         accepted steps; λ_v ranges over [{:.4}, {:.4}]. At every step the spherical state and \
         λ = Jᵀσ are formed and the paper's identities checked (largest relative residual; the \
         equations' residuals are relative to the magnitude of the terms summed):\n\n\
         | identity | largest residual |\n| --- | --- |\n",
        lambda_v.0, lambda_v.1
    );
    for (n, w) in names.iter().zip(worst) {
        let _ = writeln!(report, "| {n} | {w:.2e} |");
    }
    let mut random = 0.0f64;
    for (x, l) in sample_points(1000, 0x9E37_79B9_7F4A_7C15) {
        random = random.max(check.transformed_at(398_600.441_8, 0.02, &x, &l)?);
    }
    let _ = writeln!(
        report,
        "\nThe plumb-line Euler–Lagrange equations transformed to the spherical frame \
         (σ = J⁻ᵀλ, ẋ = J⁻¹ẏ, λ̇ = Jᵀσ̇ + J̇ᵀσ) against the spherical ones (ẋ the printed \
         equations, λ̇ = −∂(λ·f)/∂x by the IR) at 1000 random points: largest residual {random:.2e}.\n"
    );
    let p = partials()?;
    let _ = writeln!(
        report,
        "The printed partials ∂(v, γ, δ)/∂(l, m, n) against the IR's J⁻¹ at 200 random points \
         (largest |difference|/(1 + |printed|)):\n\n| | l | m | n |\n| --- | --- | --- | --- |"
    );
    for (a, row) in ["v", "γ", "δ"].iter().zip(p) {
        let _ = writeln!(
            report,
            "| {a} | {:.1e} | {:.1e} | {:.1e} |",
            row[0], row[1], row[2]
        );
    }
    let _ = writeln!(
        report,
        "\n(δ_l as printed has the opposite sign: its residual is that of the whole entry.)\n\n## Singular points\n"
    );
    let half_pi = std::f64::consts::FRAC_PI_2;
    let mut errors = Vec::new();
    for x in [
        [7000.0, 0.1, 0.2, 7.0, half_pi, 0.3],
        [7000.0, 0.1, 0.2, 0.0, 0.2, 0.3],
        [7000.0, half_pi, 0.2, 7.0, 0.2, 0.3],
    ] {
        let msg = match check.change().check(&x) {
            Err(e) => e.to_string(),
            Ok(_) => return Err(format!("{x:?} is not refused as singular").into()),
        };
        let _ = writeln!(report, "- {msg}");
        errors.push(msg);
    }
    let failed: Vec<&str> = names
        .iter()
        .zip(worst)
        .filter(|(_, w)| w.is_nan() || *w > TOL)
        .map(|(n, _)| *n)
        .collect();
    write_outputs(
        dir,
        &[],
        &report,
        json!({"steps": steps, "t_end": t_end, "lambda_v_range": [lambda_v.0, lambda_v.1],
               "residuals": names.iter().zip(worst).map(|(n, w)| json!({"identity": n, "max": w})).collect::<Vec<_>>(),
               "random_points_max": random, "printed_partials": p, "singular": errors}),
        args.quiet,
    )?;
    if !failed.is_empty() || random.is_nan() || random > TOL {
        return Err(format!(
            "identities above {TOL:e}: {failed:?}; transformed equations at random points: {random:e}"
        )
        .into());
    }
    Ok(())
}
