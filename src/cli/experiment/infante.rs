//! Infante's Table I ("Stability criteria for n-th order, homogeneous linear differential
//! equations", NASA TM X-53478, fifth paper): for n = 2, 3, 4 the matrices B_k solving
//! AᵀB + BA = −C_k for the companion matrix A(a₁ … aₙ), solved symbolically in the aᵢ
//! ([`lasalle_analysis::infante`]), each proved by expanding AᵀB + BA + C_k to 0 and checked
//! in floating point at a Hurwitz point, where B_k must be positive definite (Lemma 2.1).

use std::fmt::Write as _;
use std::path::Path;

use lasalle_analysis::infante::{self, Poly, Solution};
use serde_json::json;

use super::{write_outputs, ExperimentArgs};
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
    write_outputs(dir, &[], &report, json!({"orders": orders}), args.quiet)
}
