//! `lasalle normal-form <model> --param mu=… --order N [--format table|json|csv] [--out file]`
//!
//! Birkhoff normal form of a Hamiltonian model at an elliptic equilibrium (see
//! `lasalle_normal_form` for the conventions).

use super::CliResult;
use clap::{Args, ValueEnum};
use lasalle_normal_form::{normalize_model_file, ModelPoint, Options, Precision};
use std::path::PathBuf;

/// Output formats of `lasalle normal-form`.
#[derive(Clone, Copy, ValueEnum)]
enum Format {
    /// Human-readable tables.
    Table,
    /// Everything as JSON.
    Json,
    /// One row per coefficient.
    Csv,
}

/// Arguments of `lasalle normal-form`.
#[derive(Args)]
pub struct NormalFormArgs {
    /// The model file (with `hamiltonian` and `structure canonical(q, p)`).
    model: PathBuf,
    /// Override a scalar parameter, e.g. `--param mu=0.0121505856`. Repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    /// Truncation degree N of the normal form (≥ 2).
    #[arg(long, default_value_t = 12)]
    order: usize,
    /// The equilibrium: a point of the model (`L4`) or a comma-separated starting guess for
    /// Newton's method on ∇H = 0 (flat state order). Default: the model's first point.
    #[arg(long, value_name = "POINT|x1,x2,…")]
    at: Option<String>,
    /// Working precision: `f64` or `dd` (double-double, ~32 digits).
    #[arg(long, default_value = "f64")]
    precision: String,
    /// Keep resonant terms instead of stopping at a (near-)resonance.
    #[arg(long)]
    resonant: bool,
    /// |m·ω| below this counts as a resonance.
    #[arg(long, default_value_t = 1e-6)]
    resonance_tol: f64,
    /// Skip the error estimate (a second run in the other precision).
    #[arg(long)]
    no_error_estimate: bool,
    /// Output format.
    #[arg(long, value_enum, default_value = "table")]
    format: Format,
    /// Write the output here instead of standard output.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Also write Rust code for H̄(I), ∂H̄/∂I and the maps to and from normal coordinates.
    #[arg(long, value_name = "FILE")]
    emit_rust: Option<PathBuf>,
}

fn parse_param(s: &str) -> CliResult<(String, f64)> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("`--param {s}`: expected NAME=VALUE"))?;
    let value: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("`--param {s}`: `{value}` is not a number"))?;
    Ok((name.trim().to_string(), value))
}

/// Runs `lasalle normal-form`.
pub fn run(args: &NormalFormArgs) -> CliResult {
    let params = args
        .params
        .iter()
        .map(|p| parse_param(p))
        .collect::<CliResult<Vec<_>>>()?;
    let point = match &args.at {
        None => ModelPoint::Auto,
        Some(s) if s.contains(',') || s.parse::<f64>().is_ok() => {
            let values = s
                .split(',')
                .map(|v| {
                    v.trim()
                        .parse::<f64>()
                        .map_err(|_| format!("`--at {s}`: `{v}` is not a number"))
                })
                .collect::<Result<Vec<_>, _>>()?;
            ModelPoint::Values(values)
        }
        Some(name) => ModelPoint::Named(name.clone()),
    };
    let precision: Precision = args
        .precision
        .parse()
        .map_err(|e| format!("`--precision`: {e}"))?;
    let options = Options {
        order: args.order,
        precision,
        resonant: args.resonant,
        resonance_tol: args.resonance_tol,
        error_estimate: !args.no_error_estimate,
        transform: args.emit_rust.is_some(),
        ..Options::default()
    };
    let nf = normalize_model_file(&args.model, &params, &point, &options)?;
    let text = match args.format {
        Format::Table => nf.to_table(),
        Format::Json => nf.to_json(),
        Format::Csv => nf.to_csv(),
    };
    match &args.out {
        Some(file) => std::fs::write(file, text)?,
        None => print!("{text}"),
    }
    if let Some(file) = &args.emit_rust {
        let code = nf
            .to_rust()
            .ok_or("the transformation to normal coordinates was not computed")?;
        std::fs::write(file, code)?;
        eprintln!("wrote {}", file.display());
    }
    Ok(())
}
