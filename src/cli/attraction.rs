//! `lasalle stability` for a planar field without Hamiltonian structure: the domain of
//! attraction of an asymptotically stable equilibrium estimated by the area-optimal quadratic
//! Lyapunov function, the Lyapunov-equation one (Q = I) and a Lyapunov function the model
//! names (`let energy = …`), with the saddles' stable manifolds and a figure. See
//! `docs/stability.md`.

use std::path::{Path, PathBuf};

use clap::Args;
use lasalle::{LoadedModel, ModelInfo};
use lasalle_analysis::attraction::{
    self, Analysis, Estimate, LyapunovFunction, Mat2, PlanarSystem, Saddle,
};
use lasalle_analysis::stability::{self, principal_axes, AttractionReport, StabilityOptions};

use super::plot::{write_figure, Chart, Style};
use super::CliResult;
use lasalle::parse_numbers;

/// The options of `lasalle stability` for dissipative planar models.
#[derive(Args, Debug)]
pub struct AttractionArgs {
    /// Planar fields: also estimate with this scalar `let` of the model as the Lyapunov
    /// function (default: `energy`, if the model has it).
    #[arg(long, value_name = "NAME")]
    pub lyapunov: Option<String>,
    /// Planar fields: the search radius about the equilibrium (default: chosen from the
    /// Lyapunov-equation estimate).
    #[arg(long, value_name = "R")]
    pub radius: Option<f64>,
    /// Planar fields: write the figure (estimates, V̇ = 0, trajectories, stable manifolds)
    /// as FILE's stem .svg and .png.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<String>,
}

fn fmt_mat(p: Mat2) -> String {
    format!(
        "[[{:.6}, {:.6}], [{:.6}, {:.6}]]",
        p[0][0], p[0][1], p[1][0], p[1][1]
    )
}

fn limit_text(e: &Estimate) -> String {
    let at = format!("({:.4}, {:.4})", e.contact[0], e.contact[1]);
    match e.limit {
        attraction::Limit::VdotPositive => format!("V̇ > 0 beyond {at}"),
        attraction::Limit::NotIncreasing => format!("V stops increasing at {at}"),
        attraction::Limit::SearchRadius => "the search radius".to_string(),
    }
}

fn row(name: &str, e: &Estimate) {
    println!(
        "  {:<28} {:>12.6} {:>12.6}   {:<40} {}",
        name,
        e.level,
        e.area,
        limit_text(e),
        e.check.theorem()
    );
}

/// The result where no estimate is bounded: V̇ < 0 at every sample out to the largest search
/// radius (a linear field such as Duffing's with ε₂ = 0 attracts the whole plane).
fn unbounded(report: &AttractionReport, json: bool) -> CliResult {
    let AttractionReport::Unbounded {
        model,
        file,
        equilibrium: xe,
        radius,
    } = report
    else {
        return Ok(());
    };
    if json {
        println!("{}", serde_json::to_string_pretty(&report.to_json())?);
    } else {
        println!(
            "{model} ({file}): equilibrium ({:.6}, {:.6}) attracts everything sampled: V̇ < 0 for \
             V = yᵀPy (AᵀP + PA = −I) out to radius {radius:.3e}, so no boundary of its domain \
             of attraction was found (a linear field's domain is the whole plane)",
            xe[0], xe[1]
        );
    }
    Ok(())
}

/// Runs the analysis for `model` (already parameterised) and prints or plots it.
pub fn run(
    model: &LoadedModel,
    stem: &str,
    at: Option<&str>,
    json: bool,
    args: &AttractionArgs,
) -> CliResult {
    let figure = args.plot.as_deref().map(figure_target).transpose()?;
    let at = match at {
        Some(at) => {
            let x = parse_numbers(at).map_err(|e| format!("invalid --at `{at}`: {e}"))?;
            if x.len() != model.dim() {
                return Err(format!(
                    "--at needs {} numbers (the state), got {}",
                    model.dim(),
                    x.len()
                )
                .into());
            }
            Some(x)
        }
        None => None,
    };
    let opts = StabilityOptions {
        at,
        lyapunov: args.lyapunov.clone(),
        radius: args.radius,
        ..StabilityOptions::default()
    };
    let report =
        stability::attraction(model, stem, &opts).map_err(|e| e.message("with --at x1,x2"))?;
    let b = match &report {
        AttractionReport::Bounded(b) => b,
        AttractionReport::Unbounded { .. } => {
            if figure.is_some() {
                eprintln!("note: no figure: there is no bounded estimate to draw");
            }
            return unbounded(&report, json);
        }
    };
    let (sys, analysis, saddles, axes) = (&b.system, &b.analysis, &b.saddles, &b.axes);
    let (by_let, opts, xe) = (b.by_let.as_ref(), &b.options, analysis.equilibrium);
    if let Some((dir, name)) = &figure {
        plot(model, sys, analysis, by_let, saddles, dir, name)?;
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&report.to_json())?);
        return Ok(());
    }
    let pstr: Vec<String> = b
        .params
        .iter()
        .map(|(n, v)| match v.as_slice() {
            [x] => format!("{n} = {}", serde_json::json!(x)),
            _ => format!("{n} = {}", serde_json::json!(v)),
        })
        .collect();
    println!(
        "{} ({stem}): planar field without Hamiltonian structure; {}",
        model.model_name(),
        pstr.join(", ")
    );
    let a = analysis.jacobian;
    let [e1, e2] = analysis.eigenvalues;
    println!(
        "Equilibrium ({}, {}): A = {}, eigenvalues {:.6}{:+.6}i, {:.6}{:+.6}i: asymptotically stable",
        xe[0],
        xe[1],
        fmt_mat(a),
        e1.0,
        e1.1,
        e2.0,
        e2.1
    );
    println!(
        "\nEstimates {{V < ℓ*}} of the domain of attraction, ℓ* = inf {{V : V̇ > 0}} ({} rays × {} radii within {:.4} of the equilibrium, refined; re-checked on {} points inside):",
        opts.rays, opts.radii, analysis.radius, analysis.optimal.estimate.check.samples
    );
    println!(
        "  {:<28} {:>12} {:>12}   {:<40} certificate (sampled)",
        "V", "ℓ*", "area", "limited by"
    );
    row("optimal quadratic yᵀPy", &analysis.optimal.estimate);
    row(
        "Lyapunov equation, Q = I",
        &analysis.lyapunov_equation.estimate,
    );
    if let Some((n, e)) = by_let {
        row(&format!("`let {n}`"), e);
    }
    let o = &analysis.optimal;
    println!(
        "\nOptimal P = {} (AᵀP + PA = −Q, Q = {}; {} evaluations of the area)",
        fmt_mat(o.p),
        fmt_mat(o.q),
        analysis.evaluations
    );
    println!(
        "  scaled to P₁₂ = 1: P₁₁ = {:.6}, P₂₂ = {:.6}, ℓ* = {:.6}; the estimate is {:.6}·y₁² + {:.6}·y₁y₂ + {:.6}·y₂² < 1",
        o.p[0][0] / o.p[0][1],
        o.p[1][1] / o.p[0][1],
        o.estimate.level / o.p[0][1],
        o.p[0][0] / o.estimate.level,
        2.0 * o.p[0][1] / o.estimate.level,
        o.p[1][1] / o.estimate.level
    );
    println!(
        "  Lyapunov-equation P (Q = I/2) = {}",
        fmt_mat(analysis.lyapunov_equation.p)
    );
    if saddles.is_empty() {
        println!("\nNo saddle within the search radius.");
    } else {
        println!("\nSaddles (their stable manifolds, integrated backwards, bound the domain):");
        for s in saddles.iter() {
            println!(
                "  ({:.6}, {:.6}): eigenvalues {:.6}, {:.6}",
                s.x[0], s.x[1], s.eigenvalues[0], s.eigenvalues[1]
            );
        }
        println!("Along the optimal ellipse's principal axes: the estimate's radius and the nearest stable manifold:");
        for (u, r, m) in axes.iter() {
            println!(
                "  direction ({:+.4}, {:+.4}): estimate {:.4}, stable manifold {}",
                u[0],
                u[1],
                r,
                m.map_or("beyond the search radius".to_string(), |d| format!(
                    "{d:.4}"
                ))
            );
        }
    }
    if let Some(file) = &args.plot {
        println!("\nwrote the figure {file} (.svg and .png)");
    }
    Ok(())
}

fn quad(p: Mat2, u: [f64; 2]) -> f64 {
    p[0][0] * u[0] * u[0] + 2.0 * p[0][1] * u[0] * u[1] + p[1][1] * u[1] * u[1]
}

/// Splits a polyline into the pieces inside the square window |x − c|∞ ≤ w.
fn clip(path: &[[f64; 2]], c: [f64; 2], w: f64) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut pieces = Vec::new();
    let mut cur: (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    for x in path {
        if (x[0] - c[0]).abs() <= w && (x[1] - c[1]).abs() <= w {
            cur.0.push(x[0]);
            cur.1.push(x[1]);
        } else if !cur.0.is_empty() {
            pieces.push(std::mem::take(&mut cur));
        }
    }
    if !cur.0.is_empty() {
        pieces.push(cur);
    }
    pieces
}

fn plot(
    model: &LoadedModel,
    sys: &PlanarSystem,
    analysis: &Analysis,
    by_let: Option<&(String, Estimate)>,
    saddles: &[Saddle],
    dir: &Path,
    name: &str,
) -> CliResult {
    let xe = analysis.equilibrium;
    let o = &analysis.optimal;
    let extent = principal_axes(o.p)
        .iter()
        .map(|(_, l)| (o.estimate.level / l).sqrt())
        .fold(0.0, f64::max);
    let w = 1.4 * extent;
    let mut chart = Chart::new(
        &format!(
            "{}: estimates of the domain of attraction of ({}, {})",
            model.model_name(),
            xe[0],
            xe[1]
        ),
        "x1",
        "x2",
        false,
    );
    chart.equal_aspect = true;
    let curve = |chart: &mut Chart, label: &str, path: &[[f64; 2]], color: usize, style: Style| {
        for (k, (x, y)) in clip(path, xe, w).into_iter().enumerate() {
            chart.add(if k == 0 { label } else { "" }, x, y, color, style);
        }
    };
    // trajectories from just inside the optimal estimate (they converge) and from a ring
    // outside it (some converge, some escape across the stable manifolds)
    for k in 0..16 {
        let t = 2.0 * std::f64::consts::PI * (k / 2) as f64 / 8.0 + 0.2;
        let u = [t.cos(), t.sin()];
        let r = if k % 2 == 0 {
            0.97 * (o.estimate.level / quad(o.p, u)).sqrt()
        } else {
            1.15 * extent
        };
        let x0 = [xe[0] + r * u[0], xe[1] + r * u[1]];
        let path = attraction::trajectory(model, x0, 30.0, false, xe, 3.0 * w)?;
        curve(
            &mut chart,
            if k == 0 { "trajectories" } else { "" },
            &path,
            4,
            Style::Line,
        );
    }
    for (k, b) in saddles.iter().flat_map(|s| &s.stable_manifold).enumerate() {
        let label = if k == 0 {
            "stable manifolds of the saddles"
        } else {
            ""
        };
        curve(&mut chart, label, b, 5, Style::Line);
    }
    // V̇ = 0 for the optimal P: sign changes on a grid
    let n = 300;
    let h = 2.0 * w / n as f64;
    let at = |i: usize, j: usize| [xe[0] - w + h * i as f64, xe[1] - w + h * j as f64];
    let mut zx = Vec::new();
    let mut zy = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, r, u) = (at(i, j), at(i + 1, j), at(i, j + 1));
            let s = sys.vdot(o.p, x);
            if s * sys.vdot(o.p, r) < 0.0 || s * sys.vdot(o.p, u) < 0.0 {
                zx.push(x[0] + h / 2.0);
                zy.push(x[1] + h / 2.0);
            }
        }
    }
    chart.add("V̇ = 0 (optimal P)", zx, zy, 3, Style::Dots);
    let ellipse = |p: Mat2, level: f64| -> Vec<[f64; 2]> {
        (0..=720)
            .map(|k| {
                let t = 2.0 * std::f64::consts::PI * k as f64 / 720.0;
                let u = [t.cos(), t.sin()];
                let r = (level / quad(p, u)).sqrt();
                [xe[0] + r * u[0], xe[1] + r * u[1]]
            })
            .collect()
    };
    curve(
        &mut chart,
        &format!("optimal quadratic, area {:.2}", o.estimate.area),
        &ellipse(o.p, o.estimate.level),
        0,
        Style::Line,
    );
    let l = &analysis.lyapunov_equation;
    curve(
        &mut chart,
        &format!("Lyapunov equation Q = I, area {:.2}", l.estimate.area),
        &ellipse(l.p, l.estimate.level),
        1,
        Style::Line,
    );
    if let Some((name, e)) = by_let {
        let mut b = sys.boundary(LyapunovFunction::Let(name), e.level, analysis.radius, 720)?;
        b.push(b[0]);
        curve(
            &mut chart,
            &format!("{name} < {:.4}, area {:.2}", e.level, e.area),
            &b,
            2,
            Style::Line,
        );
    }
    write_figure(dir, name, &[chart], (1, 1), (900, 900))
}

/// The directory and stem of `--plot FILE`, checked before any work.
fn figure_target(file: &str) -> CliResult<(PathBuf, String)> {
    let path = Path::new(file);
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if !dir.is_dir() {
        return Err(format!(
            "cannot write the figure `{file}`: `{}` is not a directory",
            dir.display()
        )
        .into());
    }
    let stem = path
        .file_stem()
        .ok_or_else(|| format!("--plot `{file}` names no file"))?
        .to_string_lossy()
        .into_owned();
    Ok((dir.to_path_buf(), stem))
}
