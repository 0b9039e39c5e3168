//! X − ∇V per model: JIT vs interpreter, one state and 8 lanes; the time from model text to
//! compiled kernels (`build/`: parse, derive, check, build every tape, compile every tape) and
//! of the compilation of the tapes alone (`compile/`).
//!
//! `cargo bench -p lasalle-exec` (ns per evaluation; the lane benches report per state).

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use lasalle_exec::{Backend, Kernel};
use lasalle_model::tape::ModelTapes;
use std::path::PathBuf;
use std::time::Duration;

fn models() -> Vec<(String, String)> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../models");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("models/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "lsl"))
        .collect();
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).expect("model file"))
        })
        .collect()
}

/// Model text → every tape compiled on `backend`.
fn build(
    name: &str,
    text: &str,
    backend: Backend,
) -> (lasalle_model::Model, ModelTapes, Vec<Box<dyn Kernel>>) {
    let model = lasalle_model::lower_source(name, text).expect("model");
    let derived = lasalle_model::derive(model);
    lasalle_model::check(&derived).expect("check");
    let tapes = ModelTapes::new(&derived).expect("tapes");
    let kernels = tapes
        .all()
        .into_iter()
        .map(|(_, t)| backend.compile(t).expect("compile"))
        .collect();
    (derived.model, tapes, kernels)
}

fn kernels(c: &mut Criterion) {
    for (name, text) in models() {
        for backend in Backend::available().iter().copied() {
            let label = match backend {
                Backend::Jit => "jit",
                Backend::Interpreter => "interp",
            };
            c.bench_function(&format!("build/{name}/{label}"), |b| {
                b.iter(|| build(&name, black_box(&text), backend))
            });
            let (model, tapes, _) = build(&name, &text, backend);
            c.bench_function(&format!("compile/{name}/{label}"), |b| {
                b.iter(|| {
                    for (_, t) in tapes.all() {
                        black_box(backend.compile(t).expect("compile"));
                    }
                })
            });
            let k = backend.compile(&tapes.feedback).expect("compile");
            let d = k.dims();
            let h = k.hoist(&model.default_params()).expect("hoist");
            let x: Vec<f64> = (0..d.state).map(|i| 0.6 + 0.1 * i as f64).collect();
            let f0: Vec<f64> = vec![0.1; d.targets];
            let gains: Vec<f64> = model.gains.iter().map(|g| g.default).collect();
            let mut out = vec![0.0; k.n_outputs()];
            let mut group = c.benchmark_group(format!("feedback/{name}"));
            group.throughput(Throughput::Elements(1));
            group.bench_function(format!("{label}/1"), |b| {
                b.iter(|| k.eval(&h, black_box(&x), &f0, &gains, &mut out).unwrap())
            });
            const K: usize = 8;
            let xs: Vec<f64> = (0..d.state * K).map(|i| 0.6 + 0.01 * i as f64).collect();
            let mut outs = vec![0.0; k.n_outputs() * K];
            group.throughput(Throughput::Elements(K as u64));
            group.bench_function(format!("{label}/{K}"), |b| {
                b.iter(|| {
                    k.eval_lanes(K, &h, black_box(&xs), &f0, &gains, &mut outs)
                        .unwrap()
                })
            });
            group.finish();
        }
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
        .sample_size(20);
    targets = kernels
}
criterion_main!(benches);
