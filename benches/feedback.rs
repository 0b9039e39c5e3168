//! Generated vs hand-written feedback fields (Criterion).
//!
//! ```sh
//! cargo bench --bench feedback                 # everything (~2 minutes)
//! cargo bench --bench feedback -- field/       # ns per feedback-field evaluation only
//! ```
//!
//! - `field/<model>/{prepared,hand}`: one evaluation of X − ∇V at a state off the target set
//!   (so every term of ∇V is live), inputs through `black_box`: `prepared` on the prepared
//!   model (`model.prepare()`, parameter-only values computed once, as a run uses it);
//! - `run/rigid_body_1e7/{generated,hand}`: the paper's rigid-body experiment, 10⁷
//!   feedback-Euler steps of Δt = 1e-4, as a plain loop x ← x + h·(X − ∇V)(x), the generated
//!   field on the prepared model;
//! - `run/rigid_body_1e7/driver`: the same steps through the runtime's `integrate` with
//!   `ExplicitRk::euler()` and a `FeedbackField` (blow-up checks and the observer call per step).

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use lasalle::models::{kepler::Kepler, rigid_body::RigidBody};
use lasalle::{integrate, ExplicitRk, FeedbackField, Invariants, Lyapunov};

mod handwritten;

/// A rigid-body state near, but off, the target set of the paper's initial point.
fn rigid_body_state() -> [f64; 12] {
    let mut x = RigidBody::<f64>::default().point_paper();
    for (k, v) in x.iter_mut().enumerate() {
        *v += 1e-3 * (k as f64 * 0.7).sin();
    }
    x
}

fn kepler_state() -> [f64; 6] {
    let mut x = Kepler::<f64>::default().point_paper();
    for (k, v) in x.iter_mut().enumerate() {
        *v += 1e-3 * (k as f64 * 0.7).cos();
    }
    x
}

fn fields(c: &mut Criterion) {
    let rb = RigidBody::default();
    let prepared = rb.prepare();
    let x0 = rb.point_paper();
    let target = prepared.targets(&x0);
    let gains = RigidBody::<f64>::default_gains();
    let x = rigid_body_state();
    let mut g = c.benchmark_group("field/rigid_body");
    g.bench_function("prepared", |b| {
        let mut dx = [0.0; 12];
        b.iter(|| {
            black_box(&prepared).feedback_field(
                black_box(&x),
                black_box(&target),
                black_box(&gains),
                &mut dx,
            );
            black_box(dx)
        })
    });
    let (e0, pi0) = (target[9], [target[10], target[11], target[12]]);
    g.bench_function("hand", |b| {
        let mut dx = [0.0; 12];
        b.iter(|| {
            handwritten::rigid_body(
                black_box(&rb.i),
                black_box(&x),
                black_box(e0),
                black_box(&pi0),
                black_box(&gains),
                &mut dx,
            );
            black_box(dx)
        })
    });
    g.finish();

    let kp = Kepler::default();
    let prepared = kp.prepare();
    let s0 = kp.point_paper();
    let mut target = [0.0; 6];
    prepared.invariants(&s0, &mut target);
    let gains = Kepler::<f64>::default_gains();
    let s = kepler_state();
    let mut g = c.benchmark_group("field/kepler");
    g.bench_function("prepared", |b| {
        let mut ds = [0.0; 6];
        b.iter(|| {
            black_box(&prepared).feedback_field(
                black_box(&s),
                black_box(&target),
                black_box(&gains),
                &mut ds,
            );
            black_box(ds)
        })
    });
    let (l0, a0) = (
        [target[0], target[1], target[2]],
        [target[3], target[4], target[5]],
    );
    g.bench_function("hand", |b| {
        let mut ds = [0.0; 6];
        b.iter(|| {
            handwritten::kepler(
                black_box(kp.mu),
                black_box(&s),
                black_box(&l0),
                black_box(&a0),
                black_box(&gains),
                &mut ds,
            );
            black_box(ds)
        })
    });
    g.finish();
}

/// Steps of the paper's rigid-body experiment.
const STEPS: u64 = 10_000_000;
const H: f64 = 1e-4;

fn runs(c: &mut Criterion) {
    let rb = RigidBody::default().prepare();
    let x0 = rb.point_paper();
    let target = rb.targets(&x0);
    let gains = RigidBody::<f64>::default_gains();
    let mut g = c.benchmark_group("run/rigid_body_1e7");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(8));
    g.bench_function("generated", |b| {
        b.iter(|| {
            let (m, tg, k) = (
                black_box(&rb).prepare(),
                black_box(&target),
                black_box(&gains),
            );
            let mut x = black_box(x0);
            let mut dx = [0.0; 12];
            for _ in 0..STEPS {
                m.feedback_field(&x, tg, k, &mut dx);
                for n in 0..12 {
                    x[n] += H * dx[n];
                }
            }
            x
        })
    });
    let (e0, pi0) = (target[9], [target[10], target[11], target[12]]);
    g.bench_function("hand", |b| {
        b.iter(|| {
            let (i, k) = (black_box(&rb.i), black_box(&gains));
            let mut x = black_box(x0);
            let mut dx = [0.0; 12];
            for _ in 0..STEPS {
                handwritten::rigid_body(i, &x, e0, &pi0, k, &mut dx);
                for n in 0..12 {
                    x[n] += H * dx[n];
                }
            }
            x
        })
    });
    g.bench_function("driver", |b| {
        b.iter(|| {
            let model = black_box(&rb).prepare();
            let fb = FeedbackField::from_initial(&model, &x0, gains);
            let end = integrate(
                &mut ExplicitRk::euler(),
                &fb,
                &x0,
                0.0,
                STEPS as f64 * H,
                H,
                &mut (),
            )
            .expect("the paper's run does not blow up");
            end.x
        })
    });
    g.finish();
}

criterion_group!(benches, fields, runs);
criterion_main!(benches);
