//! `lasalle run <model> --method <m> [--dt h] [--t-end T] [--param k=v] [--init p] [--gains g]
//! [--json] [--out dir]`: one integration, written as `trace.csv` (t, state, each invariant's error) and
//! `summary.json` (counters, wall time, final and maximal errors, failure).

use std::path::PathBuf;

use clap::Args;
use lasalle::{Declared, GainPolicy, ModelInfo, Parameters, Preset};

use super::load::{load, BackendArg};
use super::sim::{apply_param, initial_state, simulate, Method, RunSpec};
use super::CliResult;

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
    /// Step size (the initial step for dopri5); default: the preset's.
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// End time; default: the preset's.
    #[arg(long, allow_negative_numbers = true)]
    pub t_end: Option<f64>,
    /// Set a parameter, `name=value[,value…]` (e.g. `--param I=3,2,1`, `--param mu=1`);
    /// repeatable.
    #[arg(long, value_name = "NAME=V")]
    pub param: Vec<String>,
    /// The initial state: a named point of the model (default: the preset's, else its first
    /// point) or the flat state as comma-separated numbers.
    #[arg(long, allow_hyphen_values = true)]
    pub init: Option<String>,
    /// Gains of feedback methods: default (the preset's, else the model's), auto (adaptive for
    /// fixed-step methods, step for dopri5 and taylor), fixed[:c], adaptive[:m[:c]],
    /// step[:c[:m]] (h·k·L = c·rtol^(1/p) at every step of an adaptive method), or k1,k2,…
    #[arg(long, default_value = "default", allow_hyphen_values = true)]
    pub gains: String,
    /// Projection tolerance on |f(x) − f(x₀)|₂ (default: dt, as the paper's TolFun).
    #[arg(long)]
    pub tol: Option<f64>,
    /// Relative tolerance of dopri5; the tolerance ε of the Taylor method.
    #[arg(long, default_value_t = 1e-10)]
    pub rtol: f64,
    /// Absolute tolerance of dopri5.
    #[arg(long, default_value_t = 1e-10)]
    pub atol: f64,
    /// Record every n-th step (default: the preset's, else about 20000 samples).
    #[arg(long)]
    pub every: Option<u64>,
    /// The most steps a run may take (fixed-step runs needing more are refused before they
    /// start).
    #[arg(long, default_value_t = super::sim::DEFAULT_MAX_STEPS)]
    pub max_steps: u64,
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
    /// Print the summary (counters, CPU and wall time, invariant errors) as one JSON line on
    /// standard output instead of the report (for scripts; implies --quiet).
    #[arg(long)]
    pub json: bool,
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

/// Runs `lasalle run`.
pub fn run(args: &RunArgs) -> CliResult {
    let (mut model, stem) = load(&args.model, args.backend.into())?;
    let preset = preset(&model, args.preset.as_deref())?;
    let model_name = model.model_name();
    let missing = |what: &str, flag: &str| {
        format!(
            "give {flag}: model `{model_name}` declares no {what} (add `run NAME {{ {what} = …; }}` to the model file)"
        )
    };
    if let Some(p) = preset {
        for (name, values) in p.params {
            model.set_param(name, values).map_err(|e| e.to_string())?;
        }
    }
    for p in &args.param {
        apply_param(&mut model, p)?;
    }
    let method: Method = args
        .method
        .as_deref()
        .or(preset.and_then(|p| p.method))
        .unwrap_or("feedback-euler")
        .parse()?;
    let init = match (&args.init, preset.and_then(|p| p.init)) {
        (Some(init), _) => init.clone(),
        (None, Some(init)) => init.to_string(),
        (None, None) => model
            .point_names()
            .first()
            .map(|n| n.to_string())
            .ok_or("the model has no named point: give --init x1,x2,…")?,
    };
    let x0 = initial_state(&model, &init)?;
    let dt = args
        .dt
        .or(preset.and_then(|p| p.dt))
        .ok_or_else(|| missing("dt", "--dt"))?;
    let t_end = args
        .t_end
        .or(preset.and_then(|p| p.t_end))
        .ok_or_else(|| missing("t_end", "--t-end"))?;
    let mut spec = RunSpec::new(method, dt, t_end);
    spec.gains = match (
        args.gains.parse::<GainPolicy>()?,
        preset.and_then(|p| p.gains),
    ) {
        (GainPolicy::ModelDefault, Some(g)) if method.is_feedback() => {
            GainPolicy::Explicit(g.to_vec())
        }
        (policy, _) => policy,
    };
    spec.tol = args.tol.unwrap_or(dt);
    spec.rtol = args.rtol;
    spec.atol = args.atol;
    spec.every = args.every.or(preset.and_then(|p| p.every)).unwrap_or(0);
    spec.progress = !(args.quiet || args.json);
    spec.max_steps = args.max_steps;
    let trace = simulate(&model, &x0, &spec)?;
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
    summary["dt"] = dt.into();
    summary["t_end"] = spec.t_end.into();
    if method.is_adaptive() {
        summary["rtol"] = spec.rtol.into();
        summary["atol"] = spec.atol.into();
    }
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
    if args.json {
        println!("{summary}");
    }
    if let Some(e) = &trace.failure {
        return Err(format!(
            "{method} on `{name}` stopped: {e}\n(samples up to the failure are in {})",
            dir.display()
        )
        .into());
    }
    if !(args.quiet || args.json) {
        println!(
            "{name} {method} dt = {dt} to t = {}: {} steps, {} evaluations, {:.3} s (model loaded in {:.1} ms)",
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
