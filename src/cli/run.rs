//! `lasalle run <model> [--method m] [--dt h] [--t-end T] [--param k=v] [--init p] [--gains g]
//! [--rtol r] [--atol a] [--format table|json|csv] [--out dir]`: one integration, written as
//! `trace.csv` (t, state, each invariant's error) and `summary.json` (counters, wall time,
//! maximal and final errors, the feedback gains' stability, failure).

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use lasalle::{
    find_preset, GainPolicy, Method, MethodSetting, ModelInfo, Preset, RunError, RunSpec,
};

use super::args::parse_param;
use super::load::{load_with, BackendArg, FamiliesOpt};
use super::{usage, value, CliResult, Given};

/// What `lasalle run` prints on standard output.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// A short report: steps, evaluations, time, each invariant's largest and final error.
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
    /// stormer-verlet-a / -b, symplectic4 / 6 / 8 (compositions of Störmer–Verlet; partitioned
    /// models); splitting (models declaring
    /// `splitting rigid_body(…)`); taylor, feedback-taylor (the Taylor method on X − ∇V),
    /// split-taylor (a Taylor step of X, then x ← x − h∇V). Default: the preset's, else
    /// feedback-euler.
    #[arg(long, short)]
    pub method: Option<String>,
    /// Step size of fixed-step methods (required unless the preset gives one); the first step
    /// of adaptive ones (default: chosen by the method).
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// End time (the run starts at t = 0; a negative one integrates backwards); default: the
    /// preset's.
    #[arg(long, value_parser = value::end_time, allow_hyphen_values = true)]
    pub t_end: Option<f64>,
    /// Set a parameter, `name=value[,value…]` (e.g. `--param I=3,2,1`, `--param mu=1`);
    /// repeatable.
    #[arg(long, value_name = "NAME=V")]
    pub param: Vec<String>,
    /// The initial state: a named point of the model (default: the preset's, else its first
    /// point) or the flat state as comma-separated numbers.
    #[arg(long, allow_hyphen_values = true)]
    pub init: Option<String>,
    /// Gains of feedback methods: default (`bounded` for fixed-step methods, `step` for
    /// adaptive ones), model (the model file's, unchanged), bounded[:c] (the model file's,
    /// scaled down where h·k·L would pass c times the method's stability interval, default
    /// c = 0.1), auto (adaptive for fixed-step methods, step
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
    #[arg(long, default_value_t = lasalle::DEFAULT_MAX_STEPS, value_parser = value::count, allow_hyphen_values = true)]
    pub max_steps: u64,
    /// The run has diverged, and stops with exit code 1, when an invariant's error exceeds
    /// this many times max(|f(x₀)|, 1).
    #[arg(long, default_value_t = lasalle::DEFAULT_MAX_DRIFT, value_parser = value::positive, allow_hyphen_values = true)]
    pub max_drift: f64,
    /// Record the state at these times instead of every n-th step: `a:b:n` (n times from a
    /// to b) or a comma-separated list, within [0, --t-end]; taken from each method's
    /// continuous extension (adaptive methods keep their own steps).
    #[arg(long, value_name = "A:B:N|T,…", allow_hyphen_values = true)]
    pub t_eval: Option<String>,
    /// A discontinuous field (`sign(g)`) in the sense of Filippov: sliding on a switching
    /// surface both sides' fields point into (default: classical solutions, docs/switching.md).
    #[arg(long)]
    pub filippov: bool,
    /// How the model's functions run: compiled to native code when the model is loaded
    /// (jit), or interpreted.
    #[arg(long, value_enum, default_value_t)]
    pub backend: BackendArg,
    #[command(flatten)]
    pub families: FamiliesOpt,
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
    /// The variational equations and chaos indicators.
    #[command(flatten)]
    pub chaos: super::chaos::ChaosArgs,
}

/// The spec and the initial state of a run: the preset's settings, overridden by the flags
/// (resolved by the library's [`lasalle::RunSpecBuilder`]); a flag that does not apply to the
/// method is refused.
fn run_spec(
    args: &RunArgs,
    given: &Given,
    model: &mut lasalle::LoadedModel,
    preset: Option<&Preset>,
) -> CliResult<(RunSpec, Vec<f64>)> {
    let mut builder = RunSpec::from_preset(preset);
    for p in &args.param {
        let (name, values) = parse_param(p).map_err(usage)?;
        builder = builder.param(name, values);
    }
    if let Some(m) = &args.method {
        builder = builder.method(m.parse().map_err(usage)?);
    }
    let method = builder.resolved_method().map_err(usage)?;
    refuse_inapplicable(method, given)?;
    builder = builder
        .gains(args.gains.parse::<GainPolicy>().map_err(usage)?)
        .max_steps(args.max_steps)
        .max_drift(args.max_drift);
    if let Some(dt) = args.dt {
        builder = builder.dt(dt);
    }
    if let Some(t_end) = args.t_end {
        builder = builder.t_end(t_end);
    }
    if let Some(rtol) = args.rtol {
        builder = builder.rtol(rtol);
    }
    if let Some(atol) = args.atol {
        builder = builder.atol(atol);
    }
    if let Some(tol) = args.projection_tol {
        builder = builder.projection_tol(tol);
    }
    if let Some(every) = args.every {
        builder = builder.every(every);
    }
    if let Some(init) = &args.init {
        builder = builder.init(init.as_str());
    }
    if let Some(times) = &args.t_eval {
        given.refuse(
            &["every"],
            "does not apply with --t-eval, which records the state at the times it lists",
        )?;
        builder = builder.t_eval(lasalle::run::parse_t_eval(times).map_err(usage)?);
    }
    if args.filippov {
        if lasalle::Declared::<f64, Vec<f64>>::switches(model).is_empty() {
            return Err(usage(format!(
                "--filippov applies to discontinuous fields, and model `{}` switches on no `sign(g)`",
                model.model_name()
            )));
        }
        builder = builder.switching(lasalle::run::Switching::Filippov);
    }
    builder.prepare(model).map_err(|e| match e {
        RunError::Missing(what) => {
            let flag = format!("--{}", what.replace('_', "-"));
            usage(format!(
                "give {flag}: model `{}` declares no {what} (add `run NAME {{ {what} = …; }}` to the model file)",
                model.model_name()
            ))
        }
        e => usage(e),
    })
}

/// Refuses the flags that do not apply to `method` ([`Method::refuses`]): the tolerances for
/// fixed-step methods, `--gains` for methods without feedback, `--projection-tol` for
/// non-projection methods.
pub fn refuse_inapplicable(method: Method, given: &Given) -> CliResult {
    for setting in MethodSetting::ALL {
        if let Some(why) = method.refuses(setting) {
            given.refuse(&[setting.name()], &why)?;
        }
    }
    Ok(())
}

/// Runs `lasalle run`.
pub fn run(args: &RunArgs, given: &Given) -> CliResult {
    let (mut model, stem) = load_with(&args.model, args.backend.into(), args.families.into())?;
    let preset = find_preset(&model, args.preset.as_deref()).map_err(usage)?;
    let (spec, x0) = run_spec(args, given, &mut model, preset)?;
    let method = spec.method;
    let shown = !args.quiet && args.format == Format::Table;
    let recording = super::progress::simulate(&model, &x0, &spec, shown).map_err(usage)?;
    let name = model.model_name();

    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("out/{stem}-{method}")));
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    recording.write_csv(dir.join("trace.csv"))?;
    let has_events = !lasalle::Declared::<f64, Vec<f64>>::events(&model).is_empty();
    if has_events {
        recording.write_events_csv(dir.join("events.csv"))?;
    }
    let mut summary = recording.summary_json();
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
    if recording.failure.is_none() {
        let chaos = &args.chaos;
        let extended = (&model, x0.as_slice(), &spec);
        super::chaos::extend_summary(chaos, extended, &dir, &mut summary, given, shown)?;
    }
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&summary)? + "\n",
    )?;
    match args.format {
        Format::Json => println!("{summary}"),
        Format::Csv => recording.write_csv_to(std::io::stdout().lock())?,
        Format::Table => {}
    }
    if let Some(warning) = recording.stability.as_ref().and_then(|s| s.warning()) {
        eprintln!("{warning}");
    }
    if let Some(e) = &recording.failure {
        let hint = match e {
            lasalle::StepError::MaxSteps { .. } => "; --max-steps raises the budget",
            _ => "",
        };
        return Err(format!(
            "{method} on `{name}` stopped: {e}\n(samples up to the failure are in {}{hint})",
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
        // the variational runs' time, after the run's own
        let extended = match summary["extended_seconds"].as_f64() {
            Some(s) => format!(" + {s:.3} s of variational runs"),
            None => String::new(),
        };
        println!(
            "{name} {method} {dt} to t = {}: {} steps, {} evaluations, {:.3} s{extended} (model loaded in {:.1} ms)",
            spec.t_end,
            recording.steps,
            recording.evaluations,
            recording.wall_seconds,
            model.load_time().as_secs_f64() * 1e3
        );
        for (b, name) in recording.blocks.iter().enumerate() {
            println!(
                "  |Δ{name}|: max {:.3e}, final {:.3e}",
                recording.max_error(b),
                recording.final_error(b)
            );
        }
        if let Some(g) = &recording.gains_final {
            println!("  gains: {g:?}");
        }
        if let Some(s) = &recording.stability {
            let capped = match s.capped {
                Some((0, _)) => ", the model's gains throughout".to_string(),
                Some((n, f)) => {
                    format!(", the model's gains scaled down in {n} steps (by {f:.2e} at most)")
                }
                None => String::new(),
            };
            println!(
                "  h·k·L: max {:.3e} (stability interval {:.4}){capped}",
                s.max_h_k_l, s.interval
            );
        }
        super::chaos::report(&summary);
        if let Some(e) = &recording.stopped_by {
            println!("  stopped by event `{}` at t = {}", e.name, e.t);
        }
        switches_report(&model, &spec, &recording);
        delays_report(&model, &recording);
        if has_events {
            println!("  {} event crossings (events.csv)", recording.events.len());
        }
        println!("wrote {}/trace.csv and summary.json", dir.display());
    }
    Ok(())
}

/// The delays of a run of a delay equation and whether its solution grows or decays.
fn delays_report(model: &lasalle::LoadedModel, recording: &lasalle::Recording) {
    let delays = lasalle::Declared::<f64, Vec<f64>>::delays(model);
    if delays.is_empty() || recording.is_empty() {
        return;
    }
    let n = recording.state_names.len();
    let lags = lasalle::run::lags(model, &recording.x[..n].to_vec()).unwrap_or_default();
    for (d, r) in delays.iter().zip(lags) {
        println!(
            "  method of steps: `{}` with delay {r}, constant history x(t) = x(0) for t ≤ 0",
            d.text
        );
    }
    if let Some(g) = lasalle::run::growth(recording, delays) {
        println!(
            "  |x| from {:.6e} to {:.6e}: {}, rate {:.6} (ln|x| per unit time over the second half)",
            g.initial,
            g.last,
            g.verdict(),
            g.rate
        );
    }
}

/// The switches of a run of a discontinuous field: each one's time and state, then the final
/// state (the first 20 switches).
fn switches_report(model: &lasalle::LoadedModel, spec: &RunSpec, recording: &lasalle::Recording) {
    let switches = lasalle::Declared::<f64, Vec<f64>>::switches(model);
    if switches.is_empty() {
        return;
    }
    let n = model.dim() - 2 * switches.len();
    let show = |x: &[f64]| {
        x[..n]
            .iter()
            .map(|v| format!("{v}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    println!("  {} solution", spec.switching.name());
    let names: Vec<&str> = lasalle::Declared::<f64, Vec<f64>>::events(model)
        .iter()
        .map(|e| e.name)
        .collect();
    let hits = recording.events.iter().filter(|h| {
        switches
            .iter()
            .any(|s| (s.event..s.event + 4).any(|i| names[i] == h.name))
    });
    for h in hits.take(20) {
        println!(
            "  switch at `{}` at t = {}: x = ({})",
            h.name,
            h.t,
            show(&h.x)
        );
    }
    if !recording.is_empty() {
        println!(
            "  at t = {}: x = ({})",
            recording.t_final(),
            show(recording.last_state())
        );
    }
}
