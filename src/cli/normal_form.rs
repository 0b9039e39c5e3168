//! `lasalle normal-form <model> --param mu=… --order N [--format table|json|csv] [--out file]`
//!
//! Birkhoff normal form of a Hamiltonian model at an elliptic equilibrium (see
//! `lasalle_normal_form` for the conventions). The model is a path to a `.lsl` file or the name
//! of a built-in model (`cr3bp`, `cr3bp_spatial`, …).

use super::load::model_text;
use super::CliResult;
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lasalle_normal_form::{
    normalize_model, ErrorEstimate, ModelPoint, Options, Precision, Progress, Stage, MAX_ORDER,
};
use std::fs::OpenOptions;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Output formats of `lasalle normal-form`.
#[derive(Clone, Copy, ValueEnum)]
pub(super) enum Format {
    /// Human-readable tables.
    Table,
    /// Everything as JSON.
    Json,
    /// One row per coefficient.
    Csv,
}

/// `--precision`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum PrecisionArg {
    /// f64, redone in double-double when a coefficient's estimated relative error exceeds
    /// `--max-rel-error`; the output says so.
    Auto,
    /// IEEE double only: fails when a coefficient's estimated relative error exceeds
    /// `--max-rel-error`.
    #[value(alias = "double")]
    F64,
    /// Double-double (~32 digits), 1.2–3.3× the f64 time.
    #[value(alias = "double-double")]
    Dd,
}

/// `--error-estimate`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum EstimateArg {
    /// The cheaper one: for an f64 run a second f64 run with the normal planes rotated (about
    /// 1× the run); for a double-double run an f64 run (0.3–0.8× the run).
    Cheap,
    /// The other precision: for an f64 run a double-double run (1.2× the run at order ≤ 12,
    /// 3.3× at order ≥ 24: the real f64 error); for a double-double run as `cheap`.
    Rerun,
    /// No estimate, and no check of the precision.
    None,
}

/// Arguments of `lasalle normal-form`.
#[derive(Args)]
pub struct NormalFormArgs {
    /// The model: a `.lsl` file (with `hamiltonian` and `structure canonical(q, p)`) or the
    /// name of a built-in model (`cr3bp`, `cr3bp_spatial`, `coupled_oscillators`).
    pub(super) model: String,
    /// Override a scalar parameter, e.g. `--param mu=0.0121505856`. Repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub(super) params: Vec<String>,
    /// Truncation degree N of the normal form (2…120). Costs grow steeply with N and with the
    /// number of degrees of freedom (a progress bar is shown on a terminal).
    #[arg(long, default_value_t = 12, value_parser = super::value::size, allow_hyphen_values = true)]
    pub(super) order: usize,
    /// The equilibrium: a point of the model (`L4`) or a comma-separated starting guess for
    /// Newton's method on ∇H = 0 (flat state order). Default: the model's first point.
    #[arg(long, value_name = "POINT|x1,x2,…")]
    pub(super) at: Option<String>,
    /// Working precision. `auto` computes in f64 and redoes the computation in double-double
    /// when a coefficient's estimated relative error exceeds `--max-rel-error`, and says so.
    #[arg(long, value_enum, default_value = "auto")]
    pub(super) precision: PrecisionArg,
    /// Keep resonant terms instead of stopping at a (near-)resonance or a repeated frequency.
    #[arg(long)]
    pub(super) resonant: bool,
    /// |m·ω| below this counts as a resonance (a finite number ≥ 0).
    #[arg(long, default_value_t = 1e-6, value_parser = super::value::non_negative, allow_hyphen_values = true)]
    resonance_tol: f64,
    /// Largest estimated relative error accepted for a coefficient of H̄ (coefficients below
    /// 1000 unit roundoffs of the largest of their degree count relative to that size). Above
    /// it the numbers are not printed: with `--precision auto` the run is redone in
    /// double-double, otherwise it fails. In (0, 1]; default 1e-3, three correct digits. (At
    /// Earth–Moon L4 f64 passes through order 17 and fails from degree 18 on.)
    #[arg(long, default_value_t = DEFAULT_MAX_RELATIVE_ERROR, value_parser = super::value::positive, allow_hyphen_values = true)]
    max_rel_error: f64,
    /// How to estimate the error of each coefficient (also what `--max-rel-error` checks).
    /// `cheap` (default) costs about one more run; `rerun` in the other precision costs 1.2–3.3×
    /// an f64 run (the larger factor from order ~20 on). The time is printed with the table.
    #[arg(long, value_enum, default_value = "cheap")]
    error_estimate: EstimateArg,
    /// Skip the error estimate (the same as `--error-estimate none`): no precision check.
    #[arg(long, conflicts_with = "error_estimate")]
    no_error_estimate: bool,
    /// Output format.
    #[arg(long, value_enum, default_value = "table")]
    pub(super) format: Format,
    /// Write the output here instead of standard output.
    #[arg(long, value_name = "FILE")]
    pub(super) out: Option<PathBuf>,
    /// Also write Rust code for H̄(I), ∂H̄/∂I and the maps to and from normal coordinates
    /// (with `--center-manifold`: the reduced Hamiltonian, its field and the maps).
    #[arg(long, value_name = "FILE")]
    pub(super) emit_rust: Option<PathBuf>,
    /// At a saddle × centre point (`--at L1`, `L2`, `L3` of the three-body models): the
    /// Jorba–Masdemont reduction to the centre manifold, the reduced Hamiltonian, the
    /// Birkhoff normal form there and the coordinate changes (see docs/center_manifold.md).
    /// `--precision auto` means double-double here.
    #[arg(long)]
    pub(super) center_manifold: bool,
    /// With `--center-manifold`: write the reduced Hamiltonian as a model file (`.lsl`),
    /// which `lasalle run` compiles and integrates.
    #[arg(long, value_name = "FILE", requires = "center_manifold")]
    pub(super) emit_model: Option<PathBuf>,
    /// With `--center-manifold` (spatial model): write Poincaré sections Q3 = 0 of the
    /// reduced Hamiltonian at the `--energies` as `<DIR>/center_manifold_<point>.svg/.png`.
    #[arg(long, value_name = "DIR", requires = "center_manifold")]
    pub(super) poincare: Option<PathBuf>,
    /// Energies H_cm − E0 of the Poincaré sections, in Jorba & Masdemont's units (lengths
    /// scaled by γ, energies by γ²), comma-separated.
    #[arg(
        long,
        value_name = "H1,H2,…",
        default_value = "0.2,0.4,0.6,1.0",
        requires = "poincare"
    )]
    pub(super) energies: String,
}

use lasalle_normal_form::DEFAULT_MAX_RELATIVE_ERROR;

pub(super) fn parse_param(s: &str) -> CliResult<(String, f64)> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("`--param {s}`: expected NAME=VALUE"))?;
    let value: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("`--param {s}`: `{value}` is not a number"))?;
    if !value.is_finite() {
        return Err(format!("`--param {s}`: the value must be a finite number").into());
    }
    Ok((name.trim().to_string(), value))
}

/// The numeric options, checked before anything is computed; messages name the flag.
fn validate(args: &NormalFormArgs) -> CliResult {
    if !(2..=MAX_ORDER).contains(&args.order) {
        return Err(format!(
            "`--order {}`: the truncation degree must be between 2 and {MAX_ORDER}",
            args.order
        )
        .into());
    }
    if !(args.max_rel_error > 0.0 && args.max_rel_error <= 1.0) {
        return Err(format!(
            "`--max-rel-error {}`: must be a number in (0, 1] (default {DEFAULT_MAX_RELATIVE_ERROR:e})",
            args.max_rel_error
        )
        .into());
    }
    Ok(())
}

/// An output file named by `flag`, checked (and created, if missing) before the computation so
/// that a bad path fails at once; removed again if the run fails before writing it.
pub(super) struct OutputFile<'a> {
    flag: &'static str,
    pub(super) path: &'a Path,
    created: bool,
    written: bool,
}

impl<'a> OutputFile<'a> {
    pub(super) fn check(flag: &'static str, path: &'a Path) -> CliResult<Self> {
        let shown = path.display();
        if path.is_dir() {
            return Err(format!("`{flag} {shown}`: is a directory; give a file name").into());
        }
        let parent = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        if !parent.is_dir() {
            return Err(format!(
                "`{flag} {shown}`: the directory `{}` does not exist; create it or choose another path",
                parent.display()
            )
            .into());
        }
        let existed = path.exists();
        OpenOptions::new()
            .append(true)
            .create(true)
            .open(path)
            .map_err(|e| format!("`{flag} {shown}`: cannot write this file: {e}"))?;
        Ok(OutputFile {
            flag,
            path,
            created: !existed,
            written: false,
        })
    }

    pub(super) fn write(&mut self, text: &str) -> CliResult {
        std::fs::write(self.path, text).map_err(|e| {
            format!(
                "`{} {}`: cannot write this file: {e}",
                self.flag,
                self.path.display()
            )
        })?;
        self.written = true;
        Ok(())
    }
}

impl Drop for OutputFile<'_> {
    fn drop(&mut self) {
        if self.created && !self.written {
            let _ = std::fs::remove_file(self.path);
        }
    }
}

/// A progress bar over the degrees of the Lie normalisation, on standard error and only if it
/// is a terminal.
fn progress_bar() -> Option<(ProgressBar, Progress)> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{msg:>34} [{bar:40}] {pos}/{len} {elapsed_precise}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    let b = bar.clone();
    let progress = Progress(Arc::new(move |stage: Stage| match stage {
        Stage::Start(p) => {
            b.set_position(0);
            b.set_message(format!("{p}: expansion"));
        }
        Stage::Degree {
            degree,
            order,
            precision,
        } => {
            b.set_length((order - 2) as u64);
            b.set_position((degree - 3) as u64);
            b.set_message(format!("{precision}: degree {degree} of {order}"));
        }
        Stage::Transform => {
            b.set_position(b.length().unwrap_or(1));
            b.set_message("real forms and maps".to_string());
        }
        Stage::Rerun(p) => b.set_message(format!("rerun in {p}")),
        Stage::Done => b.finish_and_clear(),
    }));
    Some((bar, progress))
}

/// Runs `lasalle normal-form`.
pub fn run(args: &NormalFormArgs) -> CliResult {
    validate(args).map_err(super::usage)?;
    if args.center_manifold {
        return super::center_manifold::run(args);
    }
    let params = args
        .params
        .iter()
        .map(|p| parse_param(p))
        .collect::<CliResult<Vec<_>>>()
        .map_err(super::usage)?;
    let point = match &args.at {
        None => ModelPoint::Auto,
        Some(s) if s.contains(',') || s.parse::<f64>().is_ok() => {
            let values = s
                .split(',')
                .map(|v| match v.trim().parse::<f64>() {
                    Ok(x) if x.is_finite() => Ok(x),
                    _ => Err(format!("`--at {s}`: `{v}` is not a finite number")),
                })
                .collect::<Result<Vec<_>, _>>()
                .map_err(super::usage)?;
            ModelPoint::Values(values)
        }
        Some(name) => ModelPoint::Named(name.clone()),
    };
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
    let (path, _, text) = model_text(&args.model)?;
    let model = lasalle_codegen::lower_source(&path, &text).map_err(super::model_failure)?;
    // names the command line gives, checked before anything is computed
    let params_known: Vec<&str> = model.params.iter().map(|p| p.name.as_str()).collect();
    if let Some((name, _)) = params.iter().find(|(n, _)| model.param(n).is_none()) {
        return Err(super::usage(format!(
            "--param: unknown parameter `{name}` (the model has: {})",
            params_known.join(", ")
        )));
    }
    if let ModelPoint::Named(name) = &point {
        if !model.points.iter().any(|p| &p.name == name) {
            let known: Vec<&str> = model.points.iter().map(|p| p.name.as_str()).collect();
            return Err(super::usage(format!(
                "--at: unknown point `{name}` (the model has: {}; or give a Newton start x1,x2,…)",
                known.join(", ")
            )));
        }
    }
    let bar = progress_bar();
    let precision = match args.precision {
        PrecisionArg::Auto | PrecisionArg::F64 => Precision::F64,
        PrecisionArg::Dd => Precision::DoubleDouble,
    };
    let options = Options {
        order: args.order,
        precision,
        auto_precision: args.precision == PrecisionArg::Auto,
        max_relative_error: Some(args.max_rel_error),
        resonant: args.resonant,
        resonance_tol: args.resonance_tol,
        error_estimate: match (args.no_error_estimate, args.error_estimate, precision) {
            (true, _, _) | (_, EstimateArg::None, _) => ErrorEstimate::None,
            (_, EstimateArg::Cheap, Precision::F64) => ErrorEstimate::Rotation,
            _ => ErrorEstimate::OtherPrecision,
        },
        transform: args.emit_rust.is_some(),
        progress: bar.as_ref().map(|(_, p)| p.clone()),
        ..Options::default()
    };
    let result = normalize_model(&model, &params, &point, &options);
    if let Some((bar, _)) = &bar {
        bar.finish_and_clear();
    }
    let nf = result.map_err(|e| format!("{path}: {e}"))?;
    if let Some(note) = &nf.diagnostics.precision_note {
        eprintln!("note: {note}");
    }
    let text = match args.format {
        Format::Table => nf.to_table(),
        Format::Json => nf.to_json(),
        Format::Csv => nf.to_csv(),
    };
    let code = match &rust_file {
        Some(_) => Some(
            nf.to_rust()
                .ok_or("the transformation to normal coordinates was not computed")?,
        ),
        None => None,
    };
    match &mut out_file {
        Some(file) => file.write(&text)?,
        None => print!("{text}"),
    }
    if let (Some(file), Some(code)) = (&mut rust_file, code) {
        file.write(&code)?;
        eprintln!("wrote {}", file.path.display());
    }
    Ok(())
}
