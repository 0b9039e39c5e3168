//! The cost of loading a family against its size, stage by stage: the N-body family
//! (`models/nbody.lsl`, N bodies, N(N − 1)/2 pair terms) or the FPUT chain (`models/fput.lsl`,
//! n particles), each size in a process of its own so that the peak memory is its own.
//!
//! ```sh
//! cargo run --release -p lasalle-exec --example load_scale                      # N-body, N = 3 … 256
//! cargo run --release -p lasalle-exec --example load_scale -- 3 6 12 24         # chosen sizes
//! cargo run --release -p lasalle-exec --example load_scale -- --model fput 16 64 256 1024
//! cargo run --release -p lasalle-exec --example load_scale -- --json 3 6        # one JSON object a row
//! cargo run --release -p lasalle-exec --example load_scale -- --families loops   # families as loops
//! ```
//!
//! With `--families loops` (or `auto`) the model is lowered with its families kept as loops
//! ([`lasalle_model::loops`]) and a row measures what that form builds: parse and lower,
//! the loop tapes of the field and the integrals (Hamilton's equations of each family from one
//! gradient) and of the derived functions (Df, V, ∇V, X − ∇V, the half-fields), in `derive`;
//! the conservation of the integrals on the families' bodies (`check`), and the JIT
//! compilation of every one of those tapes. It has no rewrites for emission or Taylor
//! program: those columns are `—`.
//!
//! The stages, in the order `lasalle run` takes them: parse and lower (with Hamilton's
//! equations, ∇H by reverse mode); derive (Df of the integrals, the Lie derivatives, ∇V,
//! X − ∇V); check (the proofs that the integrals are conserved, and sampling where a proof
//! fails); the rewrites for emission (factoring, shared roots, products and sums) and the
//! lowering of the field, integrals, Jacobian, V, ∇V, X − ∇V and half-field tapes; the Taylor
//! program of the field; and the JIT compilation of every tape `lasalle run` compiles. Times
//! are the CPU time of the thread (Linux's `/proc/thread-self/schedstat`, elsewhere the wall
//! clock), so that a busy machine stretches them less than it stretches the wall clock; the
//! peak memory is the process's high-water mark (`VmHWM`). Larger sizes are skipped once one
//! took longer than `--limit` seconds (default 120). The exponents are the slopes of
//! log(load) and log(peak memory) against log(size) between successive rows, where the size
//! is the number of pair terms (N-body) or of particles (FPUT): 1 is linear in the model.

use std::process::Command;
use std::time::{Duration, Instant};

use lasalle_exec::{Backend, LoopKernel, Stage, StagedKernel};
use lasalle_model::loops::{Families, LoopModel};
use lasalle_model::tape::{taylor::TaylorProgram, ModelTapes};

const NBODY: &str = include_str!("../../models/nbody.lsl");
const FPUT: &str = include_str!("../../models/fput.lsl");

/// The thread's CPU time (the wall clock where schedstat is not available).
fn cpu() -> Duration {
    thread_local!(static START: Instant = Instant::now());
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .map(Duration::from_nanos)
        .unwrap_or_else(|| START.with(|s| s.elapsed()))
}

/// Peak resident memory of this process, MiB (Linux; 0 elsewhere).
fn peak_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kib| kib / 1024.0)
}

/// The model text of a family at size `n`, and the size the exponents use.
fn source(model: &str, n: usize) -> (String, usize) {
    let (text, default, size) = match model {
        "nbody" => (NBODY, "param n = 5;", n * (n - 1) / 2),
        "fput" => (FPUT, "param n = 16;", n),
        other => panic!("--model nbody|fput, not {other}"),
    };
    assert!(
        text.contains(default),
        "{model}.lsl has its size on `{default}`"
    );
    (text.replace(default, &format!("param n = {n};")), size)
}

/// One row of the loop form, as a JSON object (stages it does not have are −1).
fn loop_row(model: &str, n: usize, families: Families) {
    let (text, size) = source(model, n);
    let t = cpu();
    let lm = LoopModel::from_source("model.lsl", &text, families).expect("the model lowers");
    let parse_lower = (cpu() - t).as_secs_f64();
    let t = cpu();
    let tapes = lm.tapes().expect("the loop tapes");
    let jacobian = lm.jacobian().expect("the loop tape of Df");
    let feedback = lm.feedback().expect("the loop tapes of V, ∇V and X − ∇V");
    let partition = lm.partition().expect("the half-fields");
    let derive = (cpu() - t).as_secs_f64();
    let t = cpu();
    lm.check().expect("the integrals are conserved");
    let check = (cpu() - t).as_secs_f64();
    let t = cpu();
    let halves = partition.iter().flat_map(|p| [&p.field_q, &p.field_p]);
    for tape in [&tapes.field, &tapes.invariants, &jacobian]
        .into_iter()
        .chain(halves)
    {
        LoopKernel::new(tape, Backend::Jit).expect("the JIT compiles");
    }
    for stage in [Stage::Lyapunov, Stage::Gradient, Stage::Feedback] {
        StagedKernel::new(&feedback, stage, Backend::Jit).expect("the JIT compiles");
    }
    let jit = (cpu() - t).as_secs_f64();
    let largest = tapes
        .field
        .instructions()
        .max(tapes.invariants.instructions());
    let load = parse_lower + derive + check + jit;
    println!(
        "{{\"model\": \"{model}\", \"n\": {n}, \"size\": {size}, \"largest_tape\": {largest}, \"parse_lower\": {parse_lower:.6}, \"derive\": {derive:.6}, \"check\": {check:.6}, \"taylor\": -1, \"jit\": {jit:.6}, \"rewrite\": -1, \"lower_tapes\": -1, \"load\": {load:.6}, \"peak_mib\": {:.1}}}",
        peak_mib()
    );
}

/// One row, as a JSON object: the stages' CPU seconds for size `n`.
fn row(model: &str, n: usize) {
    let (text, size) = source(model, n);
    let mut seconds = Vec::new();
    let mut stage = |name: &'static str, t0: Duration| {
        seconds.push((name, (cpu() - t0).as_secs_f64()));
    };
    let t = cpu();
    let lowered = lasalle_model::lower_source("model.lsl", &text).expect("the model lowers");
    stage("parse_lower", t);
    let t = cpu();
    let derived = lasalle_model::derive(lowered);
    stage("derive", t);
    let t = cpu();
    lasalle_model::check(&derived).expect("the integrals are conserved");
    stage("check", t);
    let (tapes, times) = ModelTapes::timed(&derived, cpu).expect("tapes");
    let t = cpu();
    TaylorProgram::new(&tapes.field).expect("the Taylor program");
    stage("taylor", t);
    let t = cpu();
    let mut all = vec![
        &tapes.field,
        &tapes.invariants,
        &tapes.jacobian,
        &tapes.lyapunov,
        &tapes.lyapunov_gradient,
        &tapes.feedback,
    ];
    if let Some(p) = &tapes.partition {
        all.push(&p.field_q);
        all.push(&p.field_p);
    }
    let largest = all.iter().map(|t| t.body.len()).max().unwrap_or(0);
    for tape in all {
        Backend::Jit.compile(tape).expect("the JIT compiles");
    }
    stage("jit", t);
    seconds.push(("rewrite", times.rewrite.as_secs_f64()));
    seconds.push(("lower_tapes", times.lower.as_secs_f64()));
    let load: f64 = seconds.iter().map(|(_, s)| s).sum();
    let fields: Vec<String> = seconds
        .iter()
        .map(|(k, s)| format!("\"{k}\": {s:.6}"))
        .collect();
    println!(
        "{{\"model\": \"{model}\", \"n\": {n}, \"size\": {size}, \"largest_tape\": {largest}, {}, \"load\": {load:.6}, \"peak_mib\": {:.1}}}",
        fields.join(", "),
        peak_mib()
    );
}

/// Seconds with three decimals; `—` for a stage the row does not have.
fn secs(x: f64) -> String {
    if x < 0.0 {
        "—".to_string()
    } else {
        format!("{x:.3}")
    }
}

/// A number of a row's JSON object.
fn get(row: &str, key: &str) -> f64 {
    let at = row.find(&format!("\"{key}\": ")).expect("the key") + key.len() + 4;
    let rest = &row[at..];
    let end = rest.find([',', '}']).expect("a number");
    rest[..end].trim().parse().expect("a number")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut model = "nbody".to_string();
    let mut limit = 120.0;
    let mut json = false;
    let mut sizes = Vec::new();
    let mut one = None;
    let mut families = Families::Unrolled;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--model" => model = it.next().expect("--model nbody|fput").clone(),
            "--limit" => {
                limit = it
                    .next()
                    .and_then(|s| s.parse().ok())
                    .expect("--limit SECONDS")
            }
            "--json" => json = true,
            "--families" => {
                families = it
                    .next()
                    .and_then(|s| Families::parse(s))
                    .expect("--families loops|auto|unrolled")
            }
            "--row" => one = Some(it.next().and_then(|s| s.parse().ok()).expect("--row N")),
            n => sizes.push(n.parse::<usize>().expect("a size")),
        }
    }
    if let Some(n) = one {
        match families {
            Families::Unrolled => row(&model, n),
            f => loop_row(&model, n, f),
        }
        return;
    }
    let families_arg = match families {
        Families::Unrolled => "unrolled",
        Families::Loops => "loops",
        Families::Auto => "auto",
    };
    if sizes.is_empty() {
        sizes = match model.as_str() {
            "fput" => vec![16, 32, 64, 128, 256, 512, 1024],
            _ => vec![3, 6, 12, 24, 48, 96, 128, 256],
        };
    }
    let (what, size) = match model.as_str() {
        "fput" => ("particles n", "n"),
        _ => ("bodies N", "pairs"),
    };
    if !json {
        println!(
            "| {what} | {size} | largest tape | parse + lower | derive | check | rewrites | lowering | Taylor program | JIT | load s | exponent | peak MiB | exponent |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    }
    let exe = std::env::current_exe().expect("this program");
    let mut last: Option<(f64, f64, f64)> = None;
    for n in sizes {
        let t = Instant::now();
        let out = Command::new(&exe)
            .args(["--model", &model, "--families", families_arg])
            .args(["--row", &n.to_string()])
            .output()
            .expect("the row runs");
        if !out.status.success() {
            eprintln!("n = {n} failed: {}", String::from_utf8_lossy(&out.stderr));
            std::process::exit(1);
        }
        let r = String::from_utf8_lossy(&out.stdout).trim().to_string();
        if json {
            println!("{r}");
        } else {
            let s = |k| get(&r, k);
            let (sz, load, peak) = (s("size"), s("load"), s("peak_mib"));
            // No exponent where a time is below the clock's resolution.
            let slope = |a: f64, b: f64, sz0: f64| {
                let e = (a / b).ln() / (sz / sz0).ln();
                if e.is_finite() {
                    format!("{e:.2}")
                } else {
                    String::new()
                }
            };
            let (e_load, e_peak) = match last {
                Some((sz0, l0, p0)) if sz > sz0 => (slope(load, l0, sz0), slope(peak, p0, sz0)),
                _ => (String::new(), String::new()),
            };
            println!(
                "| {n} | {sz} | {} | {} | {} | {} | {} | {} | {} | {} | {load:.2} | {e_load} | {peak:.0} | {e_peak} |",
                s("largest_tape"),
                secs(s("parse_lower")),
                secs(s("derive")),
                secs(s("check")),
                secs(s("rewrite")),
                secs(s("lower_tapes")),
                secs(s("taylor")),
                secs(s("jit")),
            );
            last = Some((sz, load, peak));
        }
        if t.elapsed().as_secs_f64() > limit {
            eprintln!("n = {n} took more than {limit} s: larger sizes skipped");
            break;
        }
    }
}
