//! `lasalle run <model> [--method m] [--dt h] [--t-end T] [--param k=v] [--init p] [--gains g]
//! [--rtol r] [--atol a] [--format table|json|csv] [--out dir]`: one integration, written as
//! `trace.csv` (t, state, each invariant's error) and `summary.json` (counters, wall time,
//! final and maximal errors, failure).

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use lasalle::{Declared, GainPolicy, ModelInfo, Parameters, Preset};

use super::load::{load, BackendArg};
use super::sim::{apply_param, initial_state, simulate, Method, RunSpec};
use super::{usage, value, CliResult, Given};

/// What `lasalle run` prints on standard output.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// A short report: steps, evaluations, time, each invariant's final and largest error.
    #[default]
    Table,
    /// The summary (counters, CPU and wall time, invariant errors) as one JSON line.
    Json,
    /// The trace as CSV (what `trace.csv` holds).
    Csv,
}

/// Arguments of `lasalle run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// The model: a path to a model file (`my_model.lsl`) or the name of a built-in model
    /// (kepler, rigid-body, perturbed-kepler, cr3bp, so3-type-i, …).
    pub model: String,
    /// A run preset declared in the model file (`run NAME { … }`); default: its first one.
    /// Flags override the preset's settings.
    #[arg(long)]
    pub preset: Option<String>,
    /// The method: euler, heun, rk4, dopri5; feedback-<base> (X − ∇V); projection-<base>;
    /// stormer-verlet-a / -b (partitioned models); splitting (models declaring
    /// `splitting rigid_body(…)`); taylor, feedback-taylor (the Taylor method on X − ∇V),
    /// split-taylor (a Taylor step of X, then x ← x − h∇V). Default: the preset's, else
    /// feedback-euler.
    #[arg(long, short)]
    pub method: Option<String>,
    /// Step size of fixed-step methods (required unless the preset gives one); the first step
    /// of adaptive ones (default: chosen by the method).
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// End time; default: the preset's.
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub t_end: Option<f64>,
    /// Set a parameter, `name=value[,value…]` (e.g. `--param I=3,2,1`, `--param mu=1`);
    /// repeatable.
    #[arg(long, value_name = "NAME=V")]
    pub param: Vec<String>,
    /// The initial state: a named point of the model (default: the preset's, else its first
    /// point) or the flat state as comma-separated numbers.
    #[arg(long, allow_hyphen_values = true)]
    pub init: Option<String>,
    /// Gains of feedback methods: default (the model's for fixed-step methods, `step` for
    /// adaptive ones), model (the model file's), auto (adaptive for fixed-step methods, step
    /// for adaptive ones), fixed[:c], adaptive[:m[:c]], step[:c[:m]] (h·k·L = c·rtol^(1/p) at
    /// every step of an adaptive method), or k1,k2,…
    #[arg(long, default_value = "default", allow_hyphen_values = true)]
    pub gains: String,
    /// Tolerance of the projection methods on |f(x) − f(x₀)|₂ (default: dt, as the paper's
    /// TolFun).
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub projection_tol: Option<f64>,
    /// Relative tolerance of adaptive methods (dopri5 and its forms; the tolerance ε of the
    /// Taylor methods). Default 1e-10.
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub rtol: Option<f64>,
    /// Absolute tolerance of adaptive methods (the Taylor methods have one tolerance: equal to
    /// --rtol if both are given). Default 1e-10.
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub atol: Option<f64>,
    /// Record every n-th step (default: the preset's, else about 20000 samples).
    #[arg(long, value_parser = value::count, allow_hyphen_values = true)]
    pub every: Option<u64>,
    /// The most steps a run may take (fixed-step runs needing more are refused before they
    /// start).
    #[arg(long, default_value_t = super::sim::DEFAULT_MAX_STEPS, value_parser = value::count, allow_hyphen_values = true)]
    pub max_steps: u64,
    /// The run has diverged, and stops with exit code 1, when an invariant's error exceeds
    /// this many times max(|f(x₀)|, 1).
    #[arg(long, default_value_t = lasalle::DEFAULT_MAX_DRIFT, value_parser = value::positive, allow_hyphen_values = true)]
    pub max_drift: f64,
    /// How the model's functions run: compiled to native code when the model is loaded
    /// (jit), or interpreted.
    #[arg(long, value_enum, default_value_t)]
    pub backend: BackendArg,
    /// Output directory (default: out/<model>-<method>/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// No progress bar and no report on standard output.
    #[arg(long, short)]
    pub quiet: bool,
    /// What to print on standard output: the report (table), the summary as one JSON line
    /// (json), or the trace (csv); with json and csv nothing else is printed.
    #[arg(long, value_enum, default_value_t)]
    pub format: Format,
}

/// The preset `--preset` names, or the model's first one.
fn preset(
    model: &impl Declared<f64, Vec<f64>>,
    name: Option<&str>,
) -> Result<Option<&'static Preset>, String> {
    let presets = model.presets();
    match name {
        None => Ok(presets.first()),
        Some(name) => presets
            .iter()
            .find(|p| p.name == name)
            .map(Some)
            .ok_or_else(|| {
                let known: Vec<&str> = presets.iter().map(|p| p.name).collect();
                if known.is_empty() {
                    format!("unknown preset `{name}`: the model declares no `run` preset")
                } else {
                    format!(
                        "unknown preset `{name}`; the model's presets: {}",
                        known.join(", ")
                    )
                }
            }),
    }
}

/// The spec and the initial state of a run: the preset's settings, overridden by the flags;
/// a flag that does not apply to the method is refused.
fn run_spec(
    args: &RunArgs,
    given: &Given,
    model: &mut lasalle::LoadedModel,
    preset: Option<&Preset>,
) -> CliResult<(RunSpec, Vec<f64>)> {
    let model_name = model.model_name();
    let missing = |what: &str, flag: &str| {
        usage(format!(
            "give {flag}: model `{model_name}` declares no {what} (add `run NAME {{ {what} = …; }}` to the model file)"
        ))
    };
    if let Some(p) = preset {
        for (name, values) in p.params {
            model.set_param(name, values).map_err(usage)?;
        }
    }
    for p in &args.param {
        apply_param(model, p).map_err(usage)?;
    }
    let method: Method = args
        .method
        .as_deref()
        .or(preset.and_then(|p| p.method))
        .unwrap_or("feedback-euler")
        .parse()
        .map_err(usage)?;
    // the preset's step and gains are for its own method, or for any fixed-step one
    let own = preset
        .filter(|p| !method.is_adaptive() || p.method.is_none_or(|m| m.parse() == Ok(method)));
    let init = match (&args.init, preset.and_then(|p| p.init)) {
        (Some(init), _) => init.clone(),
        (None, Some(init)) => init.to_string(),
        (None, None) => model
            .point_names()
            .first()
            .map(|n| n.to_string())
            .ok_or_else(|| usage("the model has no named point: give --init x1,x2,…"))?,
    };
    let x0 = initial_state(model, &init).map_err(usage)?;
    let dt = match args.dt.or(own.and_then(|p| p.dt)) {
        Some(dt) => dt,
        None if method.is_adaptive() => 0.0,
        None => return Err(missing("dt", "--dt")),
    };
    let t_end = args
        .t_end
        .or(preset.and_then(|p| p.t_end))
        .ok_or_else(|| missing("t_end", "--t-end"))?;
    let mut spec = RunSpec::new(method, dt, t_end);
    spec.gains = match (
        args.gains.parse::<GainPolicy>().map_err(usage)?,
        own.and_then(|p| p.gains),
    ) {
        (GainPolicy::Default, Some(g)) if method.is_feedback() => GainPolicy::Explicit(g.to_vec()),
        (policy, _) => policy,
    };
    tolerances(&mut spec, given, args.rtol, args.atol)?;
    spec.tol = args
        .projection_tol
        .unwrap_or(if dt > 0.0 { dt } else { spec.rtol });
    spec.every = args.every.or(preset.and_then(|p| p.every)).unwrap_or(0);
    spec.progress = !args.quiet && args.format == Format::Table;
    spec.max_steps = args.max_steps;
    spec.max_drift = args.max_drift;
    Ok((spec, x0))
}

/// Sets `--rtol` and `--atol` on `spec` (the Taylor methods' one tolerance from either) and
/// refuses the flags that do not apply to its method: the tolerances for fixed-step methods,
/// `--gains` for methods without feedback, `--projection-tol` for non-projection methods.
pub fn tolerances(
    spec: &mut RunSpec,
    given: &Given,
    rtol: Option<f64>,
    atol: Option<f64>,
) -> CliResult {
    let method = spec.method;
    if !method.is_adaptive() {
        given.refuse(
            &["rtol", "atol"],
            &format!(
                "applies to adaptive methods (dopri5, feedback-dopri5, projection-dopri5, taylor, \
                 feedback-taylor, split-taylor); `{method}` takes fixed steps of --dt"
            ),
        )?;
    }
    if !method.is_feedback() {
        given.refuse(
            &["gains"],
            &format!("applies to feedback methods (feedback-*, split-taylor), not to `{method}`"),
        )?;
    }
    if !matches!(method, Method::Projection(_)) {
        given.refuse(
            &["projection_tol"],
            &format!("applies to the projection methods (projection-*), not to `{method}`"),
        )?;
    }
    if matches!(method, Method::Taylor { .. } | Method::SplitTaylor) {
        // Jorba & Zou's one tolerance, absolute below ‖x‖∞ = 1 and relative above
        if let (Some(r), Some(a)) = (rtol, atol) {
            if r != a {
                return Err(usage(format!(
                    "`{method}` has one tolerance ε (absolute for |x| ≤ 1, relative above): \
                     give --rtol alone, not --rtol {r} with --atol {a}"
                )));
            }
        }
        spec.rtol = rtol.or(atol).unwrap_or(spec.rtol);
        spec.atol = spec.rtol;
    } else {
        spec.rtol = rtol.unwrap_or(spec.rtol);
        spec.atol = atol.unwrap_or(spec.atol);
    }
    Ok(())
}

/// Runs `lasalle run`.
pub fn run(args: &RunArgs, given: &Given) -> CliResult {
    let (mut model, stem) = load(&args.model, args.backend.into())?;
    let preset = preset(&model, args.preset.as_deref()).map_err(usage)?;
    let (spec, x0) = run_spec(args, given, &mut model, preset)?;
    let method = spec.method;
    let trace = simulate(&model, &x0, &spec).map_err(usage)?;
    let name = model.model_name();

    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("out/{stem}-{method}")));
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    trace.write_csv(&dir.join("trace.csv"))?;
    let mut summary = trace.summary_json();
    summary["model"] = name.into();
    summary["model_file"] = stem.clone().into();
    summary["preset"] = preset.map(|p| p.name).into();
    summary["backend"] = format!("{:?}", model.backend()).to_lowercase().into();
    summary["load_seconds"] = model.load_time().as_secs_f64().into();
    summary["dt"] = spec.dt.into();
    summary["t_end"] = spec.t_end.into();
    if method.is_adaptive() {
        summary["rtol"] = spec.rtol.into();
        summary["atol"] = spec.atol.into();
    }
    summary["max_drift"] = spec.max_drift.into();
    summary["x0"] = x0.clone().into();
    if method.is_feedback() {
        summary["gain_policy"] = args.gains.clone().into();
    }
    if matches!(method, Method::Projection(_)) {
        summary["projection_tol"] = spec.tol.into();
    }
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&summary)? + "\n",
    )?;
    match args.format {
        Format::Json => println!("{summary}"),
        Format::Csv => trace.write_csv_to(std::io::stdout().lock())?,
        Format::Table => {}
    }
    if let Some(e) = &trace.failure {
        return Err(format!(
            "{method} on `{name}` stopped: {e}\n(samples up to the failure are in {})",
            dir.display()
        )
        .into());
    }
    if !args.quiet && args.format == Format::Table {
        let dt = if spec.dt > 0.0 {
            format!("dt = {}", spec.dt)
        } else {
            "dt chosen by the method".to_string()
        };
        println!(
            "{name} {method} {dt} to t = {}: {} steps, {} evaluations, {:.3} s (model loaded in {:.1} ms)",
            spec.t_end,
            trace.steps,
            trace.evaluations,
            trace.wall_seconds,
            model.load_time().as_secs_f64() * 1e3
        );
        for (b, name) in trace.blocks.iter().enumerate() {
            println!(
                "  |Δ{name}|: final {:.3e}, max {:.3e}",
                trace.final_error(b),
                trace.max_error(b)
            );
        }
        if let Some(g) = &trace.gains_final {
            println!("  gains: {g:?}");
        }
        println!("wrote {}/trace.csv and summary.json", dir.display());
    }
    Ok(())
}
