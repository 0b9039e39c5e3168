//! One Taylor step (coefficients to order p, Jorba–Zou step, Horner) per model at tol 1e-15
//! and 1e-10: Kepler at its pericentre (e = 0.8) and the free rigid body, with the compiled
//! kernel (JIT back end, the default) and the interpreted one; and the coefficients alone
//! (`kernel/…`), so that the driver's share is the difference; and the kernel of the
//! recurrences without fused powers (`kernel-unfused/…`, `TaylorProgram::unfused`). With the
//! JIT, the batch kernel on two orbits per call (`kernel-lanes/…`, per orbit), also for the
//! MEGNO system of Hénon–Heiles (`henon_heiles+megno`, the extended field of a MEGNO map).
//!
//! `cargo bench -p lasalle-exec --bench taylor` (ns per step).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use lasalle_exec::{Backend, LoadedModel, TaylorOptions, TaylorTape};
use lasalle_model::tape::{taylor::TaylorProgram, ModelTapes};
use lasalle_runtime::{Parameters, Stepper, TaylorKernel};
use std::time::Duration;

fn model(name: &str, backend: Backend) -> LoadedModel {
    let path = format!("{}/../models/{name}.lsl", env!("CARGO_MANIFEST_DIR"));
    LoadedModel::load(path, backend).expect("model")
}

/// The field kernel of `m`'s back end at order `p` without fused powers.
fn unfused(m: &LoadedModel, p: u32) -> Box<dyn TaylorKernel<LoadedModel>> {
    let tape = ModelTapes::new(m.derived().expect("the model lowers"))
        .expect("tapes")
        .field;
    let program = TaylorProgram::unfused(&tape).expect("program");
    #[cfg(feature = "jit")]
    if m.backend() == Backend::Jit {
        let jit = lasalle_exec::jit::taylor::JitTaylor::with_program(program, &tape, m.params(), p);
        return Box::new(jit.expect("compiles"));
    }
    Box::new(TaylorTape::with_program(program, &tape, m.params(), p).expect("kernel"))
}

fn steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("taylor_step");
    group.measurement_time(Duration::from_secs(3));
    for name in ["kepler", "rigid_body"] {
        for &backend in Backend::available() {
            let m = model(name, backend);
            let x0 = m.point("paper").expect("point paper");
            for tol in [1e-15, 1e-10] {
                let opts = TaylorOptions::with_tol(tol);
                let mut taylor = m.taylor(opts).expect("taylor");
                let p = Stepper::<f64, Vec<f64>, LoadedModel>::order(&taylor);
                let label = format!("{name}/{backend:?}/tol={tol:e}/p={p}");
                let mut x = x0.clone();
                group.bench_function(format!("step/{label}"), |b| {
                    b.iter(|| {
                        x.copy_from_slice(&x0);
                        black_box(taylor.step(&m, 0.0, &mut x, 10.0).expect("step"));
                    })
                });
                let kernel = m.taylor_tapes(p).expect("kernels").field;
                for (what, mut kernel) in [("kernel", kernel), ("kernel-unfused", unfused(&m, p))] {
                    group.bench_function(format!("{what}/{label}"), |b| {
                        b.iter(|| {
                            kernel.compute(black_box(&x0), p as usize);
                            black_box(kernel.coefficients(0)[p as usize]);
                        })
                    });
                }
            }
        }
    }
    group.finish();
}

/// The scalar kernel against the batch kernel of two orbits, per orbit.
#[cfg(feature = "jit")]
fn lanes(c: &mut Criterion) {
    use criterion::Throughput;
    use lasalle_exec::jit::taylor::{JitTaylorBatch, LANES};
    use lasalle_model::variational::Extension;
    use lasalle_runtime::TaylorBatch;
    let mut group = c.benchmark_group("taylor_lanes");
    group.measurement_time(Duration::from_secs(3));
    let megno = {
        let hh = model("henon_heiles", Backend::Jit);
        let extended = Extension::Indicators
            .apply(hh.model().expect("the model lowers"))
            .expect("extends");
        let m = LoadedModel::from_model(extended, Backend::Jit).expect("loads");
        let x0 = Extension::Indicators.extend_state(&[0.0, 0.1, 0.45, 0.0]);
        (m, x0)
    };
    let mut cases: Vec<(String, LoadedModel, Vec<f64>)> = ["kepler", "rigid_body"]
        .map(|name| {
            let m = model(name, Backend::Jit);
            let x0 = m.point("paper").expect("point paper");
            (name.to_string(), m, x0)
        })
        .into();
    cases.push(("henon_heiles+megno".into(), megno.0, megno.1));
    for (name, m, x0) in &cases {
        for tol in [1e-15, 1e-10] {
            let p = TaylorOptions::with_tol(tol).checked_order().expect("order");
            let tape = ModelTapes::new(m.derived().expect("the model lowers"))
                .expect("tapes")
                .field;
            let Some(mut batch) = JitTaylorBatch::new(&tape, m.params(), p).expect("compiles")
            else {
                continue;
            };
            let mut kernel = m.taylor_tapes(p).expect("kernels").field;
            let packed: Vec<f64> = (0..x0.len() * LANES).map(|j| x0[j / LANES]).collect();
            let label = format!("{name}/tol={tol:e}/p={p}");
            group.throughput(Throughput::Elements(1));
            group.bench_function(format!("kernel/{label}"), |b| {
                b.iter(|| {
                    kernel.compute(black_box(x0), p as usize);
                    black_box(kernel.coefficients(0)[p as usize]);
                })
            });
            group.throughput(Throughput::Elements(LANES as u64));
            group.bench_function(format!("kernel-lanes/{label}"), |b| {
                b.iter(|| {
                    batch.compute(black_box(&packed));
                    black_box(batch.table()[p as usize * LANES]);
                })
            });
        }
    }
    group.finish();
}

#[cfg(feature = "jit")]
criterion_group!(benches, steps, lanes);
#[cfg(not(feature = "jit"))]
criterion_group!(benches, steps);
criterion_main!(benches);
