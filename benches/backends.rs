//! X − ∇V per evaluation, through the runtime's `Lyapunov::feedback_field`, for every model in
//! `models/`: the emitted Rust (`emitted`) against the model loaded at run time
//! ([`LoadedModel`]) on the JIT (`jit`) and on the interpreter (`interpreter`).
//!
//! ```sh
//! cargo bench --bench backends -- --warm-up-time 1 --measurement-time 3 feedback/
//! ```
//!
//! The state is the model's first declared point (or 0.6 + 0.1·i) moved off it by
//! 1e-3·sin(0.7·k), so every term of ∇V is live; the three results are checked to agree
//! bitwise before timing.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use lasalle::{models, Backend, Lyapunov, LoadedModel, Parameters, MODEL_FILES};

fn loaded(file: &str, backend: Backend) -> LoadedModel {
    let (_, text) = MODEL_FILES
        .iter()
        .find(|(stem, _)| *stem == file)
        .expect("model file");
    LoadedModel::from_source(file, text, backend).expect("loads")
}

macro_rules! bench_model {
    ($c:ident, $file:literal, $ty:ty) => {{
        type Model = $ty;
        const N: usize = Model::N;
        let sys = Model::default();
        let jit = loaded($file, Backend::Jit);
        let interp = loaded($file, Backend::Interpreter);
        let mut x0 = [0.0; N];
        match jit.point_names().first().and_then(|p| jit.point(p)) {
            Some(p) => x0.copy_from_slice(&p),
            None => x0.iter_mut().enumerate().for_each(|(i, v)| *v = 0.6 + 0.1 * i as f64),
        }
        let mut x = x0;
        for (k, v) in x.iter_mut().enumerate() {
            *v += 1e-3 * (k as f64 * 0.7).sin();
        }
        let target = sys.targets(&x0);
        let gains = Model::default_gains();
        let (xv, tv, gv) = (x.to_vec(), target.to_vec(), gains.to_vec());
        let mut want = [0.0; N];
        sys.feedback_field(&x, &target, &gains, &mut want);
        for m in [&jit, &interp] {
            let mut got = vec![0.0; N];
            m.feedback_field(&xv, &tv, &gv, &mut got);
            assert!(
                got.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{}: {:?} vs emitted {want:?}",
                $file,
                m.backend()
            );
        }
        let mut g = $c.benchmark_group(concat!("feedback/", $file));
        g.bench_function("emitted", |b| {
            let mut dx = [0.0; N];
            b.iter(|| {
                black_box(&sys).feedback_field(
                    black_box(&x),
                    black_box(&target),
                    black_box(&gains),
                    &mut dx,
                );
                black_box(&dx);
            })
        });
        for (label, m) in [("jit", &jit), ("interpreter", &interp)] {
            g.bench_function(label, |b| {
                let mut dx = vec![0.0; N];
                b.iter(|| {
                    black_box(m).feedback_field(
                        black_box(&xv),
                        black_box(&tv),
                        black_box(&gv),
                        &mut dx,
                    );
                    black_box(&dx);
                })
            });
        }
        g.finish();
    }};
}

fn feedback(c: &mut Criterion) {
    bench_model!(c, "coupled_oscillators", models::coupled_oscillators::CoupledOscillators);
    bench_model!(c, "cr3bp", models::cr3bp::CR3BP);
    bench_model!(c, "kepler", models::kepler::Kepler);
    bench_model!(c, "perturbed_kepler", models::perturbed_kepler::PerturbedKepler);
    bench_model!(c, "rigid_body", models::rigid_body::RigidBody);
    bench_model!(c, "so3_type_i", models::so3_type_i::So3TypeI);
    bench_model!(c, "so3_type_iia", models::so3_type_iia::So3TypeIia);
    bench_model!(c, "so3_type_iib", models::so3_type_iib::So3TypeIib);
    bench_model!(c, "so3_type_iii", models::so3_type_iii::So3TypeIii);
}

criterion_group!(benches, feedback);
criterion_main!(benches);
