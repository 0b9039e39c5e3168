//! The cost of loading a family against its size, stage by stage: the N-body family
//! (`models/nbody.lsl`, N bodies, N(N − 1)/2 pair terms) or the FPUT chain (`models/fput.lsl`,
//! n particles), each size in a process of its own so that the peak memory is its own.
//!
//! ```sh
//! cargo run --release -p lasalle-exec --example load_scale                      # N-body, N = 3 … 256
//! cargo run --release -p lasalle-exec --example load_scale -- 3 6 12 24         # chosen sizes
//! cargo run --release -p lasalle-exec --example load_scale -- --model fput 16 64 256 1024
//! cargo run --release -p lasalle-exec --example load_scale -- --json 3 6        # one JSON object a row
//! ```
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

use lasalle_exec::Backend;
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
            "--row" => one = Some(it.next().and_then(|s| s.parse().ok()).expect("--row N")),
            n => sizes.push(n.parse::<usize>().expect("a size")),
        }
    }
    if let Some(n) = one {
        row(&model, n);
        return;
    }
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
            .args(["--model", &model, "--row", &n.to_string()])
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
            let slope = |a: f64, b: f64, sz0: f64| format!("{:.2}", (a / b).ln() / (sz / sz0).ln());
            let (e_load, e_peak) = match last {
                Some((sz0, l0, p0)) if sz > sz0 => (slope(load, l0, sz0), slope(peak, p0, sz0)),
                _ => (String::new(), String::new()),
            };
            println!(
                "| {n} | {sz} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {load:.2} | {e_load} | {peak:.0} | {e_peak} |",
                s("largest_tape"),
                s("parse_lower"),
                s("derive"),
                s("check"),
                s("rewrite"),
                s("lower_tapes"),
                s("taylor"),
                s("jit"),
            );
            last = Some((sz, load, peak));
        }
        if t.elapsed().as_secs_f64() > limit {
            eprintln!("n = {n} took more than {limit} s: larger sizes skipped");
            break;
        }
    }
}
