//! `lasalle run <model> --method <m> [--dt h] [--t-end T] [--param k=v] [--init p] [--gains g]
//! [--out dir]`: one integration, written as `trace.csv` (t, state, each invariant's error) and
//! `summary.json` (counters, wall time, final and maximal errors, failure).

use std::path::PathBuf;

use clap::Args;
use lasalle::models::{
    coupled_oscillators::CoupledOscillators, cr3bp::CR3BP, kepler::Kepler,
    perturbed_kepler::PerturbedKepler, rigid_body::RigidBody, so3_type_i::So3TypeI,
};
use lasalle::GainPolicy;

use super::sim::{apply_param, initial_state, simulate, CliModel, Method, ModelName, RunSpec};
use super::CliResult;

/// Arguments of `lasalle run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// The model: rigid-body, kepler or perturbed-kepler.
    pub model: String,
    /// The method: euler, heun, rk4, dopri5; feedback-<base> (X − ∇V); projection-<base>;
    /// stormer-verlet-a / -b (partitioned models); splitting (rigid body).
    #[arg(long, short, default_value = "feedback-euler")]
    pub method: String,
    /// Step size (the initial step for dopri5; default: the paper's Δt for the model —
    /// 1e-4 rigid body, 0.005 Kepler, 0.03 perturbed Kepler).
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// End time (default: the paper's — 1000, one period 70.2481, 200).
    #[arg(long, allow_negative_numbers = true)]
    pub t_end: Option<f64>,
    /// Set a parameter, `name=value[,value…]` (e.g. `--param I=3,2,1`, `--param mu=1`);
    /// repeatable.
    #[arg(long, value_name = "NAME=V")]
    pub param: Vec<String>,
    /// The initial state: a named point of the model (default: `paper` if the model has it,
    /// else its first point) or the flat state as comma-separated numbers.
    #[arg(long, allow_hyphen_values = true)]
    pub init: Option<String>,
    /// Gains of feedback methods: default (the model's), auto (= adaptive), fixed[:c],
    /// adaptive[:m[:c]], or k1,k2,…
    #[arg(long, default_value = "default")]
    pub gains: String,
    /// Projection tolerance on |f(x) − f(x₀)|₂ (default: dt, as the paper's TolFun).
    #[arg(long)]
    pub tol: Option<f64>,
    /// Relative tolerance of dopri5.
    #[arg(long, default_value_t = 1e-10)]
    pub rtol: f64,
    /// Absolute tolerance of dopri5.
    #[arg(long, default_value_t = 1e-10)]
    pub atol: f64,
    /// Record every n-th step (default: about 20000 samples).
    #[arg(long, default_value_t = 0)]
    pub every: u64,
    /// Output directory (default: out/<model>-<method>/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// No progress bar and no report on standard output.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The default step size and end time for a model: the paper's (§4) for its three models.
pub fn paper_step_and_end(model: ModelName) -> (f64, f64) {
    match model {
        ModelName::RigidBody => (1e-4, 1000.0),
        ModelName::Kepler => (0.005, 70.2481),
        ModelName::PerturbedKepler => (0.03, 200.0),
        ModelName::Cr3bp => (1e-3, 100.0),
        ModelName::So3TypeI => (1e-3, 10.0), // the thesis' Appendix B span
        ModelName::CoupledOscillators => (1e-2, 100.0),
    }
}

/// Runs `lasalle run`.
pub fn run(args: &RunArgs) -> CliResult {
    let model: ModelName = args.model.parse()?;
    match model {
        ModelName::RigidBody => run_model::<RigidBody, 12, 13, 3>(args, model),
        ModelName::Kepler => run_model::<Kepler, 6, 6, 2>(args, model),
        ModelName::PerturbedKepler => run_model::<PerturbedKepler, 6, 4, 2>(args, model),
        ModelName::Cr3bp => run_model::<CR3BP, 4, 1, 1>(args, model),
        ModelName::So3TypeI => run_model::<So3TypeI, 12, 14, 4>(args, model),
        ModelName::CoupledOscillators => run_model::<CoupledOscillators, 4, 1, 1>(args, model),
    }
}

/// `paper` if the model has that point, else its first point.
fn default_point(model: &impl lasalle::Parameters) -> Result<String, String> {
    let names = model.point_names();
    names
        .iter()
        .find(|&&n| n == "paper")
        .or(names.first())
        .map(|n| n.to_string())
        .ok_or_else(|| "the model has no named point: give --init x1,x2,…".to_string())
}

fn run_model<Mdl, const N: usize, const M: usize, const G: usize>(
    args: &RunArgs,
    name: ModelName,
) -> CliResult
where
    Mdl: CliModel<[f64; N], [f64; M], [f64; G]> + Default,
{
    let method: Method = args.method.parse()?;
    let mut model = Mdl::default();
    for p in &args.param {
        apply_param(&mut model, p)?;
    }
    let init = match &args.init {
        Some(init) => init.clone(),
        None => default_point(&model)?,
    };
    let x0: [f64; N] = initial_state(&model, &init)?
        .try_into()
        .expect("initial_state checks the dimension");
    let (dt0, t_end0) = paper_step_and_end(name);
    let dt = args.dt.unwrap_or(dt0);
    let mut spec = RunSpec::new(method, dt, args.t_end.unwrap_or(t_end0));
    spec.gains = args.gains.parse::<GainPolicy>()?;
    spec.tol = args.tol.unwrap_or(dt);
    spec.rtol = args.rtol;
    spec.atol = args.atol;
    spec.every = args.every;
    spec.progress = !args.quiet;
    let trace = simulate(&model, &x0, &spec)?;

    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("out/{}-{}", name, method)));
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    trace.write_csv(&dir.join("trace.csv"))?;
    let mut summary = trace.summary_json();
    summary["model"] = name.cli_name().into();
    summary["dt"] = dt.into();
    summary["t_end"] = spec.t_end.into();
    summary["x0"] = x0.to_vec().into();
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
    if let Some(e) = &trace.failure {
        return Err(format!(
            "{} on `{}` stopped: {e}\n(samples up to the failure are in {})",
            method,
            name,
            dir.display()
        )
        .into());
    }
    if !args.quiet {
        println!(
            "{} {} dt = {dt} to t = {}: {} steps, {} evaluations, {:.3} s",
            name, method, spec.t_end, trace.steps, trace.evaluations, trace.wall_seconds
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
