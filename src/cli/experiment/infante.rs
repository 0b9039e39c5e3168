//! Infante's Table I ("Stability criteria for n-th order, homogeneous linear differential
//! equations", NASA TM X-53478, fifth paper): for n = 2, 3, 4 the matrices B_k solving
//! AᵀB + BA = −C_k for the companion matrix A(a₁ … aₙ), solved symbolically in the aᵢ
//! ([`lasalle_analysis::infante`]), each proved by expanding AᵀB + BA + C_k to 0 and checked
//! in floating point at a Hurwitz point, where B_k must be positive definite (Lemma 2.1).

use std::fmt::Write as _;
use std::path::Path;

use lasalle_analysis::infante::examples::{
    example1_boundary, example1_printed, example2_bound, example2_printed,
};
use lasalle_analysis::infante::{self, Poly, Solution};
use serde_json::json;

use super::{write_figure, write_outputs, Chart, ExperimentArgs, Style};
use crate::cli::CliResult;

/// A Hurwitz point for each order (all roots of sⁿ + a₁sⁿ⁻¹ + … + aₙ in the left half-plane).
const POINTS: [&[f64]; 3] = [&[3.0, 2.0], &[3.0, 3.0, 1.0], &[4.0, 6.0, 4.0, 1.0]];

fn matrix(m: &[Vec<Poly>]) -> String {
    let rows: Vec<String> = m
        .iter()
        .map(|r| {
            format!(
                "[{}]",
                r.iter()
                    .map(|p| p.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
        .collect();
    format!("[{}]", rows.join(", "))
}

fn diagonal(c: &[Poly]) -> String {
    format!(
        "diag({})",
        c.iter()
            .map(|p| p.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// One order's block of the report and its JSON.
fn order(n: usize, a: &[f64], report: &mut String) -> CliResult<serde_json::Value> {
    let table: Vec<Solution> = infante::table(n)?;
    let hurwitz = infante::hurwitz(n);
    let _ = writeln!(
        report,
        "## n = {n}\n\nHurwitz determinants: {}. Check point a = {a:?}.\n\n| k | B_k | C_k | AᵀB + BA + C expands to 0 | max residual at a | smallest Cholesky pivot of B at a |\n| --- | --- | --- | --- | --- | --- |",
        hurwitz
            .iter()
            .enumerate()
            .map(|(i, d)| format!("Δ{} = {d}", i + 1))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut rows = Vec::new();
    for (k, s) in table.iter().enumerate() {
        let proved = s.proves();
        let (residual, pivot) = s.check_at(a);
        if !proved || residual > 1e-12 || pivot <= 0.0 {
            return Err(format!(
                "n = {n}, k = {}: the solution fails its checks (proved {proved}, residual {residual:e}, pivot {pivot})",
                k + 1
            )
            .into());
        }
        let _ = writeln!(
            report,
            "| {} | {} | {} | {} | {residual:.1e} | {pivot:.4} |",
            k + 1,
            matrix(&s.b),
            diagonal(&s.c),
            if proved { "yes" } else { "no" }
        );
        rows.push(json!({"k": k + 1, "B": s.b.iter().map(|r| r.iter().map(|p| p.to_string()).collect::<Vec<_>>()).collect::<Vec<_>>(),
            "C": s.c.iter().map(|p| p.to_string()).collect::<Vec<_>>(), "proved": proved, "residual": residual, "min_pivot": pivot}));
    }
    let _ = writeln!(report);
    Ok(json!({"n": n, "a": a, "table": rows}))
}

/// Runs the experiment into `dir`.
pub fn run(args: &ExperimentArgs, dir: &Path) -> CliResult {
    let mut report = String::from(
        "# Infante's Table I\n\n`cargo run --release -- experiment infante`\n\n\
         B_k solves AᵀB + BA = −C_k for the companion matrix A (2.4) of \
         x⁽ⁿ⁾ + a₁x⁽ⁿ⁻¹⁾ + … + aₙx = 0, with C₁ = 2 diag(Δₙ, 0, …, 0) and C_k = 2Δₙ₋₁e_ke_kᵀ \
         (k ≥ 2), Δⱼ the Hurwitz determinants; V = xᵀB_kx has V̇ = −xᵀC_kx.\n\n",
    );
    let mut orders = Vec::new();
    for (i, a) in POINTS.iter().enumerate() {
        orders.push(order(i + 2, a, &mut report)?);
    }
    let one = example_one(args, dir, &mut report)?;
    let two = example_two(args, dir, &mut report)?;
    write_outputs(
        dir,
        &[],
        &report,
        json!({"orders": orders, "example1": one, "example2": two}),
        args.quiet,
    )
}

/// Example 1: the boundary z₂*(z₁) found by maximising over α against (4.9); figure 1.
fn example_one(
    args: &ExperimentArgs,
    dir: &Path,
    report: &mut String,
) -> CliResult<serde_json::Value> {
    let _ = writeln!(
        report,
        "## Example 1: ẍ + pẋ + q(t)x = 0, z = q/p²\n\nz₂* is the largest z₂ with the criterion (i = 2) \
         holding for q/p² ∈ [z₁, z₂], maximised over α₁, α₂; (4.9) is z₁ + 2√(¼ + z₁ + √z₁).\n\n\
         | z₁ | z₂* (p = 1) | z₂* (p = 2.5) | (4.9) | max relative difference | α₁/p | α₂/p² | (4.8) ¼ + z₁ + √z₁ |\n\
         | --- | --- | --- | --- | --- | --- | --- | --- |"
    );
    let (mut z1s, mut found, mut printed, mut rows) = (vec![], vec![], vec![], vec![]);
    for m in 1..=40 {
        let z1 = 0.1 * m as f64;
        let (a, b) = (example1_boundary(1.0, z1), example1_boundary(2.5, z1));
        let (Some(a), Some(b)) = (a, b) else {
            return Err(format!("Example 1: no α reaches z₁ = {z1}").into());
        };
        let z2 = example1_printed(z1);
        let rel = ((a.z2 - z2).abs()).max((b.z2 - z2).abs()) / z2;
        if m % 5 == 0 || m == 1 {
            let _ = writeln!(
                report,
                "| {z1:.1} | {:.12} | {:.12} | {z2:.12} | {rel:.1e} | {:.6} | {:.9} | {:.9} |",
                a.z2,
                b.z2,
                a.alpha[0],
                a.alpha[1],
                0.25 + z1 + z1.sqrt()
            );
        }
        rows.push(
            json!({"z1": z1, "z2_p1": a.z2, "z2_p2_5": b.z2, "printed": z2, "alpha_p1": a.alpha}),
        );
        z1s.push(z1);
        found.push(a.z2);
        printed.push(z2);
    }
    let _ = writeln!(
        report,
        "\nGhizzetti's region (the paper's Figure 1, domain A) is not reproduced: the OCR has neither \
         the figure nor Ghizzetti's formula, only that his hyperellipsoids lie inside the paraboloids.\n"
    );
    if !args.no_figures {
        let mut c = Chart::new(
            "Infante, Example 1: the criterion's region in (q₁/p², q₂/p²)",
            "z₁ = q₁/p²",
            "z₂ = q₂/p²",
            false,
        );
        c.add(
            "(4.9) z₂ = z₁ + 2√(¼ + z₁ + √z₁)",
            z1s.clone(),
            printed,
            0,
            Style::Line,
        );
        c.add(
            "lasalle: max over α of the criterion's interval",
            z1s.clone(),
            found,
            3,
            Style::Markers,
        );
        c.add("z₂ = z₁ (constant q)", z1s.clone(), z1s, 5, Style::Line);
        write_figure(dir, "fig1_example1", &[c], (1, 1), (800, 600))?;
    }
    Ok(json!(rows))
}

/// Example 2: the bound on r found by maximising over α against (4.20); figure 2.
fn example_two(
    args: &ExperimentArgs,
    dir: &Path,
    report: &mut String,
) -> CliResult<serde_json::Value> {
    let _ = writeln!(
        report,
        "## Example 2: x⃛ + pẍ + ẋ + r(t)x = 0, C = C₁ + λC₂, i = 3\n\nr₂* is the largest r₂ with the \
         criterion holding for r ∈ (0, r₂): α₂, α₃ maximise w(0) for each α₁ (the maximum is 0), α₁ \
         maximises the interval's upper end. (4.20), which the paper says is Starzinski's region: \
         (p² − p⁴/4)/(λ + p) for p ≤ √2, 1/(λ + p) for p ≥ √2; r < p is the Routh–Hurwitz bound for constant r.\n\n\
         | λ | p | r₂* | (4.20) | relative difference | α (lasalle) | max w(0) |\n| --- | --- | --- | --- | --- | --- | --- |"
    );
    let mut rows = Vec::new();
    let mut chart = Chart::new(
        "Infante, Example 2: bound on r(t) against p",
        "p",
        "r₂",
        false,
    );
    for (color, lambda) in [0.01, 0.5].into_iter().enumerate() {
        let (mut ps, mut found, mut printed) = (vec![], vec![], vec![]);
        for m in 1..=30 {
            let p = 0.1 * m as f64;
            let e = example2_bound(p, lambda)
                .ok_or_else(|| format!("Example 2: no α for p = {p}, λ = {lambda}"))?;
            let r = example2_printed(p, lambda);
            if m % 5 == 0 || m == 14 {
                let _ = writeln!(
                    report,
                    "| {lambda} | {p:.1} | {:.10} | {r:.10} | {:.1e} | [{:.5}, {:.5}, {:.5}] | {:.1e} |",
                    e.r2,
                    (e.r2 - r).abs() / r,
                    e.alpha[0],
                    e.alpha[1],
                    e.alpha[2],
                    e.w0
                );
            }
            rows.push(json!({"lambda": lambda, "p": p, "r2": e.r2, "printed": r, "alpha": e.alpha, "w0": e.w0}));
            ps.push(p);
            found.push(e.r2);
            printed.push(r);
        }
        chart.add(
            &format!("(4.20) = Starzinski, λ = {lambda}"),
            ps.clone(),
            printed,
            2 * color,
            Style::Line,
        );
        chart.add(
            &format!("lasalle, λ = {lambda}"),
            ps.clone(),
            found,
            2 * color + 1,
            Style::Markers,
        );
        if color == 0 {
            chart.add(
                "r = p (Routh–Hurwitz, constant r)",
                ps.clone(),
                ps,
                5,
                Style::Line,
            );
        }
    }
    let _ = writeln!(report);
    if !args.no_figures {
        write_figure(dir, "fig2_example2", &[chart], (1, 1), (800, 600))?;
    }
    Ok(json!(rows))
}
