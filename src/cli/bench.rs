//! `lasalle bench-eval <model> [--lanes 1,4,8] [--chain] [--field feedback|model]`: the CPU
//! time of the JIT-compiled feedback field X − ∇V (or the model's field X) per state, one
//! state per call and k states per call (structure of arrays, `Kernel::eval_lanes`), printed
//! as a table or (`--format json`) one JSON line — the counterpart of heyoka's batched
//! `make_cfunc` in `scripts/heyoka/bench.py`. With `--chain`, each call waits for the
//! last (latency, as in an integration) instead of independent calls (throughput).

use std::hint::black_box;

use clap::Args;
use lasalle::exec::{Backend, Families, Kernel, LoopKernel, LoopModel, Stage, StagedKernel};
use lasalle::{Invariants, ModelInfo, Parameters};
use lasalle_codegen::tape::ModelTapes;
use serde_json::json;

use super::load::{load_with, model_text, FamiliesOpt};
use super::CliResult;
use lasalle::{parse_numbers, process_cpu_seconds};

/// Arguments of `lasalle bench-eval`.
#[derive(Args, Debug)]
pub struct BenchEvalArgs {
    /// The model: a path to a model file or the name of a built-in model.
    pub model: String,
    /// Lane counts k to time (1 = one state per call with `eval`; at most `--states`, which
    /// times one call over all the states, as heyoka's batched functions are called); default
    /// 1,4,8 (1 with `--chain`).
    #[arg(long)]
    pub lanes: Option<String>,
    /// States per sweep (rounded up to a multiple of every k).
    #[arg(long, default_value_t = 1024, value_parser = super::value::size, allow_hyphen_values = true)]
    pub states: usize,
    /// Repetitions; the fastest is reported.
    #[arg(long, default_value_t = 5, value_parser = super::value::size, allow_hyphen_values = true)]
    pub repeat: usize,
    /// CPU seconds per repetition (at least).
    #[arg(long, default_value_t = 0.2, value_parser = super::value::positive, allow_hyphen_values = true)]
    pub seconds: f64,
    /// One state per call, each call's state computed from the previous call's result (as in
    /// an integration, where every evaluation waits for the last): times the latency of one
    /// evaluation rather than the throughput of independent ones. Only with `--lanes 1`.
    #[arg(long)]
    pub chain: bool,
    /// Which field to time: the feedback field X − ∇V (the default) or the model's own field X.
    #[arg(long, value_enum, default_value_t)]
    pub field: Timed,
    /// What to print: one line per lane count (table) or one JSON line (json, for scripts).
    #[arg(long, value_enum, default_value_t)]
    pub format: Format,
    #[command(flatten)]
    pub families: FamiliesOpt,
}

/// The field `lasalle bench-eval` times.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Timed {
    /// X − ∇V with the model's default gains, targets at the evaluation point.
    #[default]
    Feedback,
    /// The model's field X.
    Model,
}

/// What `lasalle bench-eval` prints.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// `k = 1: 23.1 ns per state`, one line per lane count.
    #[default]
    Table,
    /// `{"model": …, "what": …, "ns_per_state": {"1": …}}` on one line.
    Json,
}

/// The timed function as a loop kernel, if `families` keeps some family of the model as a
/// loop (under `auto`, `None` where the loop form refuses the model, which then loads
/// unrolled).
fn loop_kernel(
    path: &str,
    text: &str,
    families: Families,
    field: Timed,
) -> Result<Option<Box<dyn Kernel>>, String> {
    if families == Families::Unrolled {
        return Ok(None);
    }
    let lm = LoopModel::from_source(path, text, families).map_err(|e| e.to_string())?;
    if lm.families().is_empty() {
        return Ok(None);
    }
    let kernel = match field {
        Timed::Feedback => lm.feedback().map_err(|e| e.to_string()).and_then(|fb| {
            StagedKernel::new(&fb, Stage::Feedback, Backend::Jit)
                .map(|k| Box::new(k) as Box<dyn Kernel>)
                .map_err(|e| e.to_string())
        }),
        Timed::Model => lm.tapes().map_err(|e| e.to_string()).and_then(|t| {
            LoopKernel::new(&t.field, Backend::Jit)
                .map(|k| Box::new(k) as Box<dyn Kernel>)
                .map_err(|e| e.to_string())
        }),
    };
    match kernel {
        Ok(k) => Ok(Some(k)),
        Err(_) if families == Families::Auto => Ok(None),
        Err(e) => Err(e),
    }
}

/// Runs `lasalle bench-eval`.
pub fn run(args: &BenchEvalArgs) -> CliResult {
    let lanes = args
        .lanes
        .as_deref()
        .unwrap_or(if args.chain { "1" } else { "1,4,8" });
    let lanes: Vec<usize> = parse_numbers(lanes)
        .map_err(|e| super::usage(format!("invalid --lanes: {e}")))?
        .into_iter()
        .map(|k| {
            if k >= 1.0 && k.fract() == 0.0 && k <= args.states as f64 {
                Ok(k as usize)
            } else {
                Err(format!(
                    "invalid --lanes: {k} is not an integer in 1..={} (at most --states)",
                    args.states
                ))
            }
        })
        .collect::<Result<_, _>>()
        .map_err(super::usage)?;
    if args.chain && lanes != [1] {
        return Err(super::usage(
            "--chain times one state per call: use it with --lanes 1",
        ));
    }
    process_cpu_seconds().ok_or("no process CPU clock on this platform")?;
    let (shown, stem, text) = model_text(&args.model)?;
    let families: Families = args.families.into();
    let (loaded, _) = load_with(&args.model, Backend::Jit, families)?;
    let x0 = loaded
        .point_names()
        .first()
        .and_then(|p| loaded.point(p))
        .ok_or_else(|| format!("model `{shown}` has no named point to evaluate at"))?;
    // the feedback field's targets (the invariants at the point) and gains; X has none
    let (target, gains) = match args.field {
        Timed::Feedback => {
            let mut target = vec![0.0; loaded.invariant_dim()];
            loaded.invariants(&x0, &mut target);
            (target, loaded.default_gain_values().to_vec())
        }
        Timed::Model => (Vec::new(), Vec::new()),
    };

    let what = match args.field {
        Timed::Feedback => "feedback field X - grad V",
        Timed::Model => "field X",
    };
    let (kernel, what) = match loop_kernel(&shown, &text, families, args.field)? {
        Some(k) => (k, format!("{what} (families as loops)")),
        None => {
            let model = lasalle_codegen::lower_source(&shown, &text).map_err(|e| e.to_string())?;
            let derived = lasalle_codegen::derive(model);
            lasalle_codegen::check(&derived).map_err(|e| e.to_string())?;
            let tapes = ModelTapes::new(&derived).map_err(|e| e.to_string())?;
            let tape = match args.field {
                Timed::Feedback => &tapes.feedback,
                Timed::Model => &tapes.field,
            };
            let kernel = Backend::Jit.compile(tape).map_err(|e| e.to_string())?;
            (kernel, what.to_string())
        }
    };
    let hoisted = kernel.hoist(loaded.params()).map_err(|e| e.to_string())?;
    let (n, m) = (x0.len(), kernel.n_outputs());

    let mut results = serde_json::Map::new();
    for &k in &lanes {
        let calls = args.states.div_ceil(k);
        // states near x₀ (each lane a little different), structure of arrays per call
        let mut xs = vec![0.0; calls * n * k];
        for c in 0..calls {
            for (i, xi) in x0.iter().enumerate() {
                for l in 0..k {
                    let s = (c * k + l) as f64 / (calls * k) as f64;
                    xs[(c * n + i) * k + l] = xi * (1.0 + 1e-3 * s);
                }
            }
        }
        let mut out = vec![0.0; m * k];
        let mut chained = x0.clone();
        let mut sweep = || -> CliResult {
            for x in xs.chunks_exact(n * k) {
                if args.chain {
                    // x₀ + 10⁻³⁰·f(x) is x₀ (to 10⁻³⁰), but the processor must wait for f(x)
                    kernel.eval(&hoisted, &chained, &target, &gains, &mut out)?;
                    for ((c, x), f) in chained.iter_mut().zip(&x0).zip(&out) {
                        *c = x + 1e-30 * f;
                    }
                } else if k == 1 {
                    kernel.eval(&hoisted, black_box(x), &target, &gains, &mut out)?;
                } else {
                    kernel.eval_lanes(k, &hoisted, black_box(x), &target, &gains, &mut out)?;
                }
                black_box(&out);
            }
            Ok(())
        };
        sweep()?; // warm up
        let mut best = f64::INFINITY;
        for _ in 0..args.repeat {
            let (start, mut sweeps) = (process_cpu_seconds().unwrap_or(0.0), 0u64);
            let mut elapsed = 0.0;
            while elapsed < args.seconds {
                sweep()?;
                sweeps += 1;
                elapsed = process_cpu_seconds().unwrap_or(0.0) - start;
            }
            best = best.min(elapsed / (sweeps as f64 * (calls * k) as f64));
        }
        results.insert(k.to_string(), json!(best * 1e9));
    }
    let report = json!({
        "model": stem,
        "what": if args.chain {
            format!("{what}, JIT, CPU ns per chained evaluation (fastest of the repetitions)")
        } else {
            format!("{what}, JIT, CPU ns per state (fastest of the repetitions)")
        },
        "ns_per_state": results,
    });
    match args.format {
        Format::Json => println!("{report}"),
        Format::Table => {
            println!("{stem}: {}", report["what"].as_str().unwrap_or_default());
            for (k, ns) in &results {
                println!("  k = {k:>4}: {:.2} ns", ns.as_f64().unwrap_or(f64::NAN));
            }
        }
    }
    Ok(())
}
