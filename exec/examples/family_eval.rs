//! Nanoseconds per evaluation of the field of a family model, unrolled (the field tape of
//! `lasalle run`, compiled by the JIT) against the loop form (one loop per family,
//! [`lasalle_model::loops`], compiled by the JIT), with the largest difference between the two
//! relative to the largest component.
//!
//! ```sh
//! cargo run --release -p lasalle-exec --example family_eval                 # N-body, N = 12 24 48
//! cargo run --release -p lasalle-exec --example family_eval -- 48 96
//! cargo run --release -p lasalle-exec --example family_eval -- --model fput 64 256 1024
//! ```
//!
//! Each figure is the best of five rounds of at least 0.2 s each (wall clock, one thread).

use std::hint::black_box;
use std::time::Instant;

use lasalle_exec::{Backend, Kernel, LoopKernel};
use lasalle_model::loops::{Families, LoopModel};
use lasalle_model::tape::ModelTapes;

const NBODY: &str = include_str!("../../models/nbody.lsl");
const FPUT: &str = include_str!("../../models/fput.lsl");

/// Best time per call of `f`, in ns.
fn ns_per_call(mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let mut calls = 0u64;
        let t = Instant::now();
        while t.elapsed().as_secs_f64() < 0.2 {
            for _ in 0..64 {
                f();
            }
            calls += 64;
        }
        best = best.min(t.elapsed().as_secs_f64() * 1e9 / calls as f64);
    }
    best
}

fn measure(k: &dyn Kernel, params: &[f64], x: &[f64]) -> (f64, Vec<f64>) {
    let h = k.hoist(params).expect("hoist");
    let mut out = vec![0.0; k.n_outputs()];
    k.eval(&h, x, &[], &[], &mut out).expect("eval");
    let first = out.clone();
    let ns = ns_per_call(|| {
        // SAFETY: the lengths are the kernel's (checked by the `eval` above).
        unsafe { k.eval_unchecked(&h, black_box(x), &[], &[], &mut out) };
        black_box(&out);
    });
    (ns, first)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut model = "nbody".to_string();
    let mut sizes = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--model" => model = it.next().expect("--model nbody|fput").clone(),
            n => sizes.push(n.parse::<usize>().expect("a size")),
        }
    }
    let (text, default) = match model.as_str() {
        "fput" => (FPUT, "param n = 16;"),
        _ => (NBODY, "param n = 5;"),
    };
    if sizes.is_empty() {
        sizes = vec![12, 24, 48];
    }
    println!("| {model} n | unrolled ns | loops ns | loops / unrolled | largest difference |");
    println!("|---|---|---|---|---|");
    for n in sizes {
        let text = text.replace(default, &format!("param n = {n};"));
        let lowered = lasalle_model::lower_source("m.lsl", &text).expect("the model lowers");
        let derived = lasalle_model::derive(lowered);
        let params = derived.model.default_params();
        let tapes = ModelTapes::new(&derived).expect("tapes");
        let unrolled = Backend::Jit
            .compile(&tapes.field)
            .expect("the JIT compiles");
        let lm = LoopModel::from_source("m.lsl", &text, Families::Loops).expect("loop form");
        let loops = LoopKernel::new(&lm.tapes().expect("loop tapes").field, Backend::Jit)
            .expect("the JIT compiles");
        let m = &derived.model;
        let x = m.point_values(&m.points[0].name, &params).expect("a point");
        let (a, fa) = measure(unrolled.as_ref(), &params, &x);
        let (b, fb) = measure(&loops, &params, &x);
        let scale = fa.iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
        let diff = fa
            .iter()
            .zip(&fb)
            .map(|(u, v)| (u - v).abs())
            .fold(0.0, f64::max);
        println!(
            "| {n} | {a:.0} | {b:.0} | {:.2} | {:.1e} |",
            b / a,
            diff / scale
        );
    }
}
