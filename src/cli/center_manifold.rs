//! `lasalle normal-form MODEL --at L1 --center-manifold --order N`: the centre manifold of a
//! saddle × centre point (see `lasalle_normal_form::center`), its tables, JSON, CSV, emitted
//! Rust and model code, and Poincaré sections of the reduced Hamiltonian.

use super::load::model_text;
use super::normal_form::{parse_param, Format, NormalFormArgs, OutputFile, PrecisionArg};
use super::plot::{write_figure, Chart, Style};
use super::CliResult;
use lasalle_normal_form::center::{
    center_manifold_model, center_manifold_model_at, poincare, CenterManifold, CenterOptions,
};
use lasalle_normal_form::Precision;
use std::path::Path;

/// Runs the centre-manifold variant of `lasalle normal-form`.
pub fn run(args: &NormalFormArgs) -> CliResult {
    if args.resonant {
        return Err(super::usage(
            "`--resonant` does not apply with `--center-manifold` (the reduction has no small divisors: their real part is λ(a1 − b1))".to_string(),
        ));
    }
    let params = args
        .params
        .iter()
        .map(|p| parse_param(p))
        .collect::<CliResult<Vec<_>>>()
        .map_err(super::usage)?;
    let energies: Vec<f64> = if args.poincare.is_some() {
        args.energies
            .split(',')
            .map(|v| match v.trim().parse::<f64>() {
                Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
                _ => Err(format!(
                    "`--energies {}`: `{v}` is not a positive number",
                    args.energies
                )),
            })
            .collect::<Result<_, _>>()
            .map_err(super::usage)?
    } else {
        Vec::new()
    };
    if let Some(dir) = &args.poincare {
        if !dir.is_dir() {
            return Err(super::usage(format!(
                "`--poincare {}`: not a directory; create it or choose another",
                dir.display()
            )));
        }
    }
    let mut out_file = args
        .out
        .as_deref()
        .map(|p| OutputFile::check("--out", p))
        .transpose()
        .map_err(super::usage)?;
    let mut rust_file = args
        .emit_rust
        .as_deref()
        .map(|p| OutputFile::check("--emit-rust", p))
        .transpose()
        .map_err(super::usage)?;
    let mut model_file = args
        .emit_model
        .as_deref()
        .map(|p| OutputFile::check("--emit-model", p))
        .transpose()
        .map_err(super::usage)?;
    let (path, _, text) = model_text(&args.model)?;
    let model = lasalle_codegen::lower_source(&path, &text).map_err(super::model_failure)?;
    let known: Vec<&str> = model.params.iter().map(|p| p.name.as_str()).collect();
    if let Some((name, _)) = params.iter().find(|(n, _)| model.param(n).is_none()) {
        return Err(super::usage(format!(
            "--param: unknown parameter `{name}` (the model has: {})",
            known.join(", ")
        )));
    }
    let options = CenterOptions {
        order: args.order,
        precision: match args.precision {
            PrecisionArg::F64 => Precision::F64,
            PrecisionArg::Auto | PrecisionArg::Dd => Precision::DoubleDouble,
        },
        transform: args.emit_rust.is_some(),
        ..CenterOptions::default()
    };
    let at = args.at.clone().unwrap_or_else(|| "L1".to_string());
    let result = if at.contains(',') || at.parse::<f64>().is_ok() {
        let values = at
            .split(',')
            .map(|v| match v.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(format!("`--at {at}`: `{v}` is not a finite number")),
            })
            .collect::<Result<Vec<_>, _>>()
            .map_err(super::usage)?;
        center_manifold_model_at(&model, &params, &values, &options)
    } else {
        center_manifold_model(&model, &params, &at, &options)
    };
    let cm = result.map_err(|e| format!("{path}: {e}"))?;
    let text = match args.format {
        Format::Table => cm.to_table(),
        Format::Json => cm.to_json(),
        Format::Csv => cm.to_csv(),
    };
    match &mut out_file {
        Some(file) => file.write(&text)?,
        None => print!("{text}"),
    }
    if let Some(file) = &mut rust_file {
        let code = cm
            .to_rust()
            .ok_or("the coordinate changes were not computed")?;
        file.write(&code)?;
        eprintln!("wrote {}", file.path.display());
    }
    if let Some(file) = &mut model_file {
        file.write(&cm.to_lsl())?;
        eprintln!("wrote {}", file.path.display());
    }
    if let Some(dir) = &args.poincare {
        poincare_figure(&cm, dir, &energies)?;
    }
    Ok(())
}

/// One panel per energy: the section Q3 = 0 in (Q2, P2), γ-scaled, with the planar
/// Lyapunov orbit (boundary), the vertical Lyapunov and halo fixed points, and the orbits.
fn poincare_figure(cm: &CenterManifold, dir: &Path, energies: &[f64]) -> CliResult {
    if cm.n_dof != 3 {
        return Err(format!(
            "`--poincare`: the section Q3 = 0 needs a two-degree-of-freedom centre manifold (a spatial model); this one has {}",
            cm.n_dof - 1
        )
        .into());
    }
    let g = cm.gamma.map_or(1.0, |g| g.value);
    let unit = if cm.gamma.is_some() {
        " (units of gamma)"
    } else {
        ""
    };
    let mut panels = Vec::new();
    for &e in energies {
        let h = e * g * g;
        let section = poincare::poincare_map(cm, h, 16, 150)
            .map_err(|m| format!("`--energies`: h = {e}: {m}"))?;
        eprintln!(
            "h = {e}: planar Lyapunov orbit Q2 = {:.6}, vertical trace {:.6}; vertical Lyapunov fixed point {}; {} halo fixed point(s){}",
            section.boundary.q2 / g,
            section.boundary.vertical_trace,
            section.vertical.as_ref().map_or("not found".to_string(), |v| format!(
                "({:.6}, {:.6})",
                v.point[0] / g,
                v.point[1] / g
            )),
            section.halos.len(),
            section
                .halos
                .iter()
                .map(|v| format!(" ({:.6}, {:.6})", v.point[0] / g, v.point[1] / g))
                .collect::<String>()
        );
        if section.unlifted > 0 {
            eprintln!(
                "warning: h = {e}: {} seed(s) inside the boundary could not be lifted to the energy level (the truncated series is used outside its domain)",
                section.unlifted
            );
        }
        let mut chart = Chart::new(
            &format!(
                "{} {}: section Q3 = 0, h = {e}",
                cm.model.split('(').next().unwrap_or(""),
                cm.point
            ),
            &format!("Q2{unit}"),
            &format!("P2{unit}"),
            false,
        );
        chart.equal_aspect = true;
        for (k, o) in section.orbits.iter().enumerate() {
            let x = o.points.iter().map(|p| p[0] / g).collect();
            let y = o.points.iter().map(|p| p[1] / g).collect();
            chart.add("", x, y, [0, 2, 4][k % 3], Style::Dots);
        }
        let curve = &section.boundary.curve;
        chart.add(
            "planar Lyapunov (boundary)",
            curve.iter().map(|p| p[0] / g).collect(),
            curve.iter().map(|p| p[1] / g).collect(),
            5,
            Style::Line,
        );
        if let Some(v) = &section.vertical {
            chart.add(
                "vertical Lyapunov",
                vec![v.point[0] / g],
                vec![v.point[1] / g],
                3,
                Style::Markers,
            );
        }
        if !section.halos.is_empty() {
            chart.add(
                "halo",
                section.halos.iter().map(|v| v.point[0] / g).collect(),
                section.halos.iter().map(|v| v.point[1] / g).collect(),
                1,
                Style::Markers,
            );
        }
        panels.push(chart);
    }
    let stem = format!("center_manifold_{}", cm.point);
    let cols = panels.len().min(2);
    let rows = panels.len().div_ceil(cols);
    write_figure(dir, &stem, &panels, (rows, cols), (600, 600))?;
    eprintln!("wrote {}/{stem}.svg and .png", dir.display());
    Ok(())
}
