//! One Taylor step (coefficients to order p, Jorba–Zou step, Horner) per model at tol 1e-15
//! and 1e-10: Kepler at its pericentre (e = 0.8) and the free rigid body.
//!
//! `cargo bench -p lasalle-exec --bench taylor` (ns per step).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use lasalle_exec::{Backend, LoadedModel, TaylorOptions};
use lasalle_runtime::{Parameters, Stepper};
use std::time::Duration;

fn model(name: &str) -> LoadedModel {
    let path = format!("{}/../models/{name}.lsl", env!("CARGO_MANIFEST_DIR"));
    LoadedModel::load(path, Backend::Interpreter).expect("model")
}

fn steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("taylor_step");
    group.measurement_time(Duration::from_secs(3));
    for name in ["kepler", "rigid_body"] {
        let m = model(name);
        let x0 = m.point("paper").expect("point paper");
        for tol in [1e-15, 1e-10] {
            let mut taylor = m.taylor(TaylorOptions::with_tol(tol)).expect("taylor");
            let label = format!(
                "{name}/tol={tol:e}/p={}",
                Stepper::<f64, Vec<f64>, LoadedModel>::order(&taylor)
            );
            let mut x = x0.clone();
            group.bench_function(label, |b| {
                b.iter(|| {
                    x.copy_from_slice(&x0);
                    black_box(taylor.step(&m, 0.0, &mut x, 10.0).expect("step"));
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, steps);
criterion_main!(benches);
