//! One model, three ways to run it: emitted Rust compiled ahead of time, the same functions
//! JIT-compiled by Cranelift when the model file is loaded, and the tape interpreter
//! (Criterion).
//!
//! ```sh
//! cargo bench --bench backends                    # everything (~18 minutes)
//! cargo bench --bench backends -- feedback/kepler # one model
//! cargo bench --bench backends -- lanes/          # batched X − ∇V
//! ```
//!
//! - `feedback/<model>/{emitted,emitted_call,jit_raw,jit,interpreter}`: one evaluation of
//!   X − ∇V at a state off the target set, through the runtime trait
//!   (`Lyapunov::feedback_field`) as a stepper calls it (the emitted code on the prepared
//!   model, `model.prepare()`, as a run uses it). `emitted` is inlined into the benchmark
//!   loop, so consecutive evaluations overlap and nothing is paid for a call; `emitted_call` calls the same code through an opaque function pointer,
//!   as `jit` calls its code (and `interpreter` its loop): the like-for-like comparison;
//!   `jit_raw` calls the JIT's `eval` directly on the arrays of `emitted_call`, not through
//!   `LoadedModel` and its `Vec` states (their lengths compared, their data pointers loaded):
//!   `jit` − `jit_raw` is what the safe interface costs per call, `jit_raw` / `emitted_call`
//!   the ratio of the code alone. These evaluations are independent, so the processor
//!   overlaps one with the next: they time throughput;
//! - `feedback/<model>/{emitted,jit,interpreter}_chained`: the same calls (through the pointer
//!   for the emitted code), each at a state computed from the last one's result, as the
//!   stages of an integration are: they time the latency of one evaluation, what a
//!   single-state integration waits for;
//! - `lanes/<model>/{emitted,jit}_k{4,8}`: X − ∇V for K states per call (structure of
//!   arrays) for the three paper models: `<Model>Lanes::feedback::<K>` emitted from the tape,
//!   and the JIT's `Kernel::eval_lanes`; the throughput is in states, so Criterion's
//!   `thrpt` is states per second and the time per state is the time over K;
//! - `load/<model>`: reading nothing, parsing, deriving, checking every invariant and compiling
//!   every function of the model with the JIT (what `lasalle run model.lsl` pays before its
//!   first step);
//! - `run/{rigid_body,kepler}_1e5/{emitted,jit}`: 10⁵ feedback-Euler steps through `integrate`,
//!   where each evaluation waits for the previous one (as in every integration);
//!   `run/rigid_body_dopri5/{emitted,jit}`: feedback-DOPRI5 on the rigid body, t ∈ [0, 20] at
//!   tolerance 1e-12, the adaptive stepper's work included.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lasalle::models;
use lasalle::{
    integrate, Backend, DormandPrince, ExplicitRk, FeedbackField, LoadedModel, Lyapunov,
    MODEL_FILES,
};

/// `x0` moved off the target set by a fixed small perturbation.
fn perturbed(x0: &[f64]) -> Vec<f64> {
    x0.iter()
        .enumerate()
        .map(|(k, v)| v + 1e-3 * (k as f64 * 0.7).sin())
        .collect()
}

fn loaded(stem: &str, backend: Backend) -> LoadedModel {
    let (_, text) = MODEL_FILES
        .iter()
        .find(|(s, _)| *s == stem)
        .expect("a model of models/");
    LoadedModel::from_source(&format!("models/{stem}.lsl"), text, backend).expect("loads")
}

/// `L::feedback_field` as a plain function pointer: called through `black_box` of it, the
/// emitted code is not inlined into the benchmark loop, as the JIT's code is not.
#[allow(clippy::type_complexity)]
fn feedback_fn<L, X, F, K>(_: &L) -> fn(&L, &X, &F, &K, &mut X)
where
    L: Lyapunov<f64, X, F, K>,
    X: lasalle::State<f64>,
    F: lasalle::State<f64>,
    K: lasalle::State<f64>,
{
    |l, x, target, gains, dx| l.feedback_field(x, target, gains, dx)
}

/// `xs ← x₀ + 10⁻³⁰·dx`: `xs` stays within 10⁻³⁰ of `x₀` (equal, where `x₀` is not tiny), but
/// the processor must wait for `dx`, so the next evaluation waits for this one, as the stages
/// of an integration do. One loop for arrays and vectors alike, vectorised: a 128-bit load of
/// two components the stores of one scalar loop wrote would stall (no store forwarding).
#[inline(always)]
fn feed_back(xs: &mut [f64], x0: &[f64], dx: &[f64]) {
    for ((c, x), f) in xs.iter_mut().zip(x0).zip(dx) {
        *c = x + 1e-30 * f;
    }
}

macro_rules! feedback_bench {
    ($c:expr, $stem:literal, $ty:ty, $point:ident) => {{
        let m = <$ty>::default().prepare();
        let x0 = m.$point();
        let target = m.targets(&x0);
        let gains = <$ty>::default_gains();
        let x: [f64; <$ty>::N] = perturbed(&x0).try_into().unwrap();
        let mut g = $c.benchmark_group(concat!("feedback/", $stem));
        let prepared = m.prepare();
        g.bench_function("emitted", |b| {
            let mut dx = [0.0; <$ty>::N];
            b.iter(|| {
                black_box(&prepared).feedback_field(
                    black_box(&x),
                    black_box(&target),
                    black_box(&gains),
                    &mut dx,
                );
                black_box(dx[0])
            })
        });
        g.bench_function("emitted_call", |b| {
            let f = black_box(feedback_fn(&prepared));
            let mut dx = [0.0; <$ty>::N];
            b.iter(|| {
                f(
                    black_box(&prepared),
                    black_box(&x),
                    black_box(&target),
                    black_box(&gains),
                    &mut dx,
                );
                black_box(dx[0])
            })
        });
        let jit = Backend::Jit
            .compile(&tapes($stem).feedback)
            .expect("compiles");
        let hoisted = jit.hoist(&m.slot_values()).expect("hoists");
        let raw = jit.raw_eval().expect("the JIT hands out its eval");
        g.bench_function("jit_raw", |b| {
            let mut dx = [0.0; <$ty>::N];
            b.iter(|| {
                // SAFETY: `hoisted` comes from `jit.hoist`, and `x`, `target`, `gains`, `dx`
                // have the kernel's lengths (the model's N, M, G and N outputs); `jit` is
                // alive.
                unsafe {
                    raw(
                        black_box(&hoisted).as_ptr(),
                        black_box(&x).as_ptr(),
                        black_box(&target).as_ptr(),
                        black_box(&gains).as_ptr(),
                        dx.as_mut_ptr(),
                    )
                };
                black_box(dx[0])
            })
        });
        g.bench_function("emitted_chained", |b| {
            let f = black_box(feedback_fn(&prepared));
            let (mut xs, mut dx) = (x, [0.0; <$ty>::N]);
            b.iter(|| {
                f(&prepared, &xs, &target, &gains, &mut dx);
                feed_back(&mut xs, &x, &dx);
            });
            black_box(xs[0]);
        });
        for (name, backend) in [("jit", Backend::Jit), ("interpreter", Backend::Interpreter)] {
            let l = loaded($stem, backend);
            let (xv, tv, gv) = (x.to_vec(), target.to_vec(), gains.to_vec());
            let mut dx = vec![0.0; <$ty>::N];
            g.bench_function(name, |b| {
                b.iter(|| {
                    black_box(&l).feedback_field(
                        black_box(&xv),
                        black_box(&tv),
                        black_box(&gv),
                        &mut dx,
                    );
                    black_box(dx[0])
                })
            });
            let mut xs = xv.clone();
            g.bench_function(format!("{name}_chained"), |b| {
                b.iter(|| {
                    l.feedback_field(&xs, &tv, &gv, &mut dx);
                    feed_back(&mut xs, &xv, &dx);
                })
            });
            black_box(xs[0]);
        }
        g.finish();
    }};
}

fn feedback(c: &mut Criterion) {
    feedback_bench!(
        c,
        "rigid_body",
        models::rigid_body::RigidBody<f64>,
        point_paper
    );
    feedback_bench!(c, "kepler", models::kepler::Kepler<f64>, point_paper);
    feedback_bench!(
        c,
        "perturbed_kepler",
        models::perturbed_kepler::PerturbedKepler<f64>,
        point_paper
    );
    feedback_bench!(c, "cr3bp", models::cr3bp::CR3BP<f64>, point_near_l4);
    feedback_bench!(
        c,
        "coupled_oscillators",
        models::coupled_oscillators::CoupledOscillators<f64>,
        point_excited
    );
    feedback_bench!(
        c,
        "cr3bp_spatial",
        models::cr3bp_spatial::CR3BPSpatial<f64>,
        point_near_l4
    );
    feedback_bench!(c, "duffing", models::duffing::Duffing<f64>, point_inside);
    feedback_bench!(
        c,
        "pendulum_closed_form",
        models::pendulum_closed_form::PendulumClosedForm<f64>,
        point_bottom
    );
    feedback_bench!(
        c,
        "so3_type_i",
        models::so3_type_i::So3TypeI<f64>,
        point_case_c1
    );
    feedback_bench!(
        c,
        "so3_type_iia",
        models::so3_type_iia::So3TypeIia<f64>,
        point_case_c2
    );
    feedback_bench!(
        c,
        "so3_type_iib",
        models::so3_type_iib::So3TypeIib<f64>,
        point_case_c6
    );
    feedback_bench!(
        c,
        "so3_type_iii",
        models::so3_type_iii::So3TypeIii<f64>,
        point_case_c10
    );
}

/// The tapes of a model of `models/`, as the emitted code is generated.
fn tapes(stem: &str) -> lasalle_codegen::tape::ModelTapes {
    let (_, text) = MODEL_FILES
        .iter()
        .find(|(s, _)| *s == stem)
        .expect("a model of models/");
    let model = lasalle_codegen::lower_source(&format!("models/{stem}.lsl"), text).expect("lowers");
    let derived = lasalle_codegen::derive(model);
    lasalle_codegen::check(&derived).expect("checks");
    lasalle_codegen::tape::ModelTapes::new(&derived).expect("tapes")
}

macro_rules! lanes_bench {
    ($c:expr, $stem:literal, $ty:ty, $($k:literal),*) => {{
        const N: usize = <$ty>::N;
        let m = <$ty>::default().prepare();
        let x0 = m.point_paper();
        let target = m.targets(&x0);
        let gains = <$ty>::default_gains();
        let lanes = m.lanes();
        let jit = Backend::Jit.compile(&tapes($stem).feedback).expect("compiles");
        let hoisted = jit.hoist(&m.slot_values()).expect("hoists");
        let mut g = $c.benchmark_group(concat!("lanes/", $stem));
        $({
            const K: usize = $k;
            // K states off the target set, component i of lane l at x[i][l]
            let x: [[f64; K]; N] = std::array::from_fn(|i| {
                std::array::from_fn(|l| perturbed(&x0)[i] + 1e-4 * l as f64)
            });
            g.throughput(Throughput::Elements(K as u64));
            g.bench_function(concat!("emitted_k", $k), |b| {
                let mut out = [[0.0; K]; N];
                b.iter(|| {
                    black_box(&lanes).feedback(black_box(&x), &target, &gains, &mut out);
                    black_box(out[0][0])
                })
            });
            g.bench_function(concat!("jit_k", $k), |b| {
                let flat = x.as_flattened();
                let mut out = vec![0.0; N * K];
                b.iter(|| {
                    jit.eval_lanes(K, &hoisted, black_box(flat), &target, &gains, &mut out)
                        .expect("lengths");
                    black_box(out[0])
                })
            });
        })*
        g.finish();
    }};
}

fn lanes(c: &mut Criterion) {
    lanes_bench!(c, "rigid_body", models::rigid_body::RigidBody<f64>, 4, 8);
    lanes_bench!(c, "kepler", models::kepler::Kepler<f64>, 4, 8);
    lanes_bench!(
        c,
        "perturbed_kepler",
        models::perturbed_kepler::PerturbedKepler<f64>,
        4,
        8
    );
}

fn load(c: &mut Criterion) {
    let mut g = c.benchmark_group("load");
    g.sample_size(10);
    for (stem, text) in MODEL_FILES {
        g.bench_function(*stem, |b| {
            b.iter(|| LoadedModel::from_source(stem, black_box(text), Backend::Jit).expect("loads"))
        });
    }
    g.finish();
}

/// `run/<group>/{emitted,jit}`: `integrate` with the stepper `$stepper` (built afresh for
/// each run, for the state type of each side) on the feedback field with `$gains` of the
/// model at its paper point, from t = 0 to `$t_end` with step `$h`; emitted on the prepared
/// model, JIT on the model file loaded.
macro_rules! run_bench {
    (
        $c:expr, $group:literal, $stem:literal, $ty:ty, $gains:expr, $stepper:expr,
        $t_end:expr, $h:expr
    ) => {{
        let mut g = $c.benchmark_group(concat!("run/", $group));
        g.sample_size(10).measurement_time(Duration::from_secs(5));
        let m = <$ty>::default().prepare();
        let x0 = m.point_paper();
        g.bench_function("emitted", |b| {
            b.iter(|| {
                let fb = FeedbackField::from_initial(&m, &x0, $gains);
                integrate(&mut $stepper, &fb, &x0, 0.0, $t_end, $h, &mut ())
                    .unwrap()
                    .x[0]
            })
        });
        let l = loaded($stem, Backend::Jit);
        let y0 = x0.to_vec();
        g.bench_function("jit", |b| {
            b.iter(|| {
                let fb = FeedbackField::from_initial(&l, &y0, $gains.to_vec());
                integrate(&mut $stepper, &fb, &y0, 0.0, $t_end, $h, &mut ())
                    .unwrap()
                    .x[0]
            })
        });
        g.finish();
    }};
}

fn run(c: &mut Criterion) {
    type RigidBody = models::rigid_body::RigidBody<f64>;
    type Kepler = models::kepler::Kepler<f64>;
    // 10⁵ feedback-Euler steps: each evaluation waits for the last (Kepler at the paper's step)
    let (rigid_gains, kepler_gains) = ([50.0, 100.0, 50.0], [4.0, 2.0]);
    run_bench!(
        c,
        "rigid_body_1e5",
        "rigid_body",
        RigidBody,
        rigid_gains,
        ExplicitRk::euler(),
        10.0,
        1e-4
    );
    run_bench!(
        c,
        "kepler_1e5",
        "kepler",
        Kepler,
        kepler_gains,
        ExplicitRk::euler(),
        500.0,
        0.005
    );
    // the rigid body, feedback-DOPRI5 at rtol = atol = 1e-12 for t ∈ [0, 20] (about 44 000
    // steps): the adaptive stepper's own work on the states next to the field's
    run_bench!(
        c,
        "rigid_body_dopri5",
        "rigid_body",
        RigidBody,
        rigid_gains,
        DormandPrince::with_tolerances(1e-12, 1e-12),
        20.0,
        1e-4
    );
}

criterion_group!(benches, feedback, lanes, load, run);
criterion_main!(benches);
