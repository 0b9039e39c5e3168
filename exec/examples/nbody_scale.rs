//! The cost of loading the N-body family (`models/nbody.lsl`) against N, stage by stage:
//! parse and lower, derive (∇H, Df, ∇V, X − ∇V), check (the proofs of H, P and L), the tapes,
//! the Taylor program of the field, and the JIT compilation of every tape `lasalle run` loads,
//! with the process's peak memory. Each N runs in a process of its own (so that the peak is
//! its own):
//!
//! ```sh
//! cargo run --release -p lasalle-exec --example nbody_scale                 # N = 3 … 256
//! cargo run --release -p lasalle-exec --example nbody_scale -- 3 6 12 24    # chosen sizes
//! ```
//! Larger sizes are skipped once one took longer than 120 s (`--limit SECONDS`).

use std::process::Command;
use std::time::Instant;

use lasalle_exec::Backend;
use lasalle_model::tape::{taylor::TaylorProgram, ModelTapes};

const MODEL: &str = include_str!("../../models/nbody.lsl");

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

/// One row: the stages' seconds for `n` bodies.
fn row(n: usize) {
    let text = MODEL.replace("param n = 5;", &format!("param n = {n};"));
    assert!(text.contains(&format!("param n = {n};")));
    let t = Instant::now();
    let model = lasalle_model::lower_source("nbody.lsl", &text).expect("the model lowers");
    let lower = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let derived = lasalle_model::derive(model);
    let derive = t.elapsed().as_secs_f64();
    let t = Instant::now();
    lasalle_model::check(&derived).expect("H, P and L are conserved");
    let check = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let tapes = ModelTapes::new(&derived).expect("tapes");
    let tape = t.elapsed().as_secs_f64();
    let t = Instant::now();
    TaylorProgram::new(&tapes.field).expect("the Taylor program");
    let taylor = t.elapsed().as_secs_f64();
    let t = Instant::now();
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
    let jit = t.elapsed().as_secs_f64();
    let total = lower + derive + check + tape + taylor + jit;
    println!(
        "| {n} | {} | {largest} | {lower:.3} | {derive:.3} | {check:.3} | {tape:.3} | {taylor:.3} | {jit:.3} | {total:.2} | {:.0} |",
        n * (n - 1) / 2,
        peak_mib()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(n) = args.iter().position(|a| a == "--row") {
        row(args[n + 1].parse().expect("a size"));
        return;
    }
    let mut limit = 120.0;
    let mut sizes = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--limit" {
            limit = it
                .next()
                .and_then(|s| s.parse().ok())
                .expect("--limit SECONDS");
        } else {
            sizes.push(a.parse::<usize>().expect("a number of bodies"));
        }
    }
    if sizes.is_empty() {
        sizes = vec![3, 6, 12, 24, 48, 96, 128, 256];
    }
    println!("| bodies N | pairs | largest tape | parse + lower s | derive s | check s | tapes s | Taylor program s | JIT s | load s | peak MiB |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let exe = std::env::current_exe().expect("this program");
    for n in sizes {
        let t = Instant::now();
        let out = Command::new(&exe)
            .args(["--row", &n.to_string()])
            .output()
            .expect("the row runs");
        print!("{}", String::from_utf8_lossy(&out.stdout));
        if !out.status.success() {
            eprintln!("N = {n} failed: {}", String::from_utf8_lossy(&out.stderr));
            break;
        }
        if t.elapsed().as_secs_f64() > limit {
            eprintln!("N = {n} took more than {limit} s: larger sizes skipped");
            break;
        }
    }
}
