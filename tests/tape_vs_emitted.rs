//! The tapes of `lasalle_codegen::tape` and their back ends compute what the emitted Rust
//! computes, bitwise: every function of every model in `models/`, at random states.

use lasalle::models;
use lasalle_codegen::tape::Tape;
use lasalle_exec::{Backend, Kernel};
use lasalle_runtime::{Field, Invariants, Lyapunov, Partitioned};

mod common;
use common::{same, tapes};

/// A tape with its kernel on every back end and their hoisted values.
struct Compiled<'a> {
    what: &'static str,
    tape: &'a Tape,
    kernels: Vec<(Backend, Box<dyn Kernel>, Vec<f64>)>,
}

impl<'a> Compiled<'a> {
    fn new(what: &'static str, tape: &'a Tape, params: &[f64]) -> Self {
        let kernels = Backend::available()
            .iter()
            .map(|&b| {
                let k = b.compile(tape).unwrap();
                let h = k.hoist(params).unwrap();
                (b, k, h)
            })
            .collect();
        Compiled {
            what,
            tape,
            kernels,
        }
    }

    /// The tape (`Tape::eval`) and every back end against the emitted values.
    fn agree(&self, params: &[f64], x: &[f64], t: &[f64], g: &[f64], emitted: &[f64]) {
        let tape = self.tape;
        let (t, g) = (&t[..tape.dims.targets], &g[..tape.dims.gains]);
        let mut results = vec![("tape".to_string(), tape.eval(params, x, t, g).unwrap())];
        for (backend, k, h) in &self.kernels {
            let mut out = vec![0.0; k.n_outputs()];
            k.eval(h, x, t, g, &mut out).unwrap();
            results.push((format!("{backend:?}"), out));
        }
        for (name, got) in results {
            assert_eq!(got.len(), emitted.len(), "{}", self.what);
            for (j, (&a, &b)) in got.iter().zip(emitted).enumerate() {
                assert!(
                    same(a, b),
                    "{} [{j}] at x = {x:?}: {name} {a:e} vs emitted {b:e}",
                    self.what
                );
            }
        }
    }
}

macro_rules! check_model {
    ($test:ident, $file:literal, $ty:ty, partitioned: $part:tt) => {
        #[test]
        fn $test() {
            type Model = $ty;
            const N: usize = Model::N;
            const M: usize = Model::M;
            let (model, tapes) = tapes($file);
            let sys = Model::default().prepare();
            let params = model.default_params();
            let gains = Model::default_gains();
            let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
            let mut rand = move || {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                let u = (seed >> 11) as f64 / (1u64 << 53) as f64;
                if seed & 1 == 0 { 0.5 + u } else { -0.5 - u }
            };
            let mut x0 = [0.0; N];
            x0.iter_mut().for_each(|v| *v = rand());
            let target = sys.targets(&x0);
            let p = &params[..];
            let [field, invariants, jacobian, lyapunov, gradient, feedback] = [
                ("field", &tapes.field),
                ("invariants", &tapes.invariants),
                ("jacobian", &tapes.jacobian),
                ("lyapunov", &tapes.lyapunov),
                ("lyapunov_gradient", &tapes.lyapunov_gradient),
                ("feedback", &tapes.feedback),
            ]
            .map(|(what, tape)| Compiled::new(what, tape, p));
            let halves = tapes.partition.as_ref().map(|part| {
                (
                    Compiled::new("field_q", &part.field_q, p),
                    Compiled::new("field_p", &part.field_p, p),
                )
            });
            for _ in 0..200 {
                let mut x = [0.0; N];
                x.iter_mut().for_each(|v| *v = rand());
                let (t, g) = (&target[..], &gains[..]);
                let mut dx = [0.0; N];
                sys.field(&x, &mut dx);
                field.agree(p, &x, t, g, &dx);
                let mut f = [0.0; M];
                sys.invariants(&x, &mut f);
                invariants.agree(p, &x, t, g, &f);
                let mut jac = [[0.0; N]; M];
                sys.invariants_jacobian(&x, &mut jac);
                jacobian.agree(p, &x, t, g, jac.as_flattened());
                let v = sys.lyapunov(&x, &target, &gains);
                lyapunov.agree(p, &x, t, g, &[v]);
                let mut grad = [0.0; N];
                sys.lyapunov_gradient(&x, &target, &gains, &mut grad);
                gradient.agree(p, &x, t, g, &grad);
                let mut fb = [0.0; N];
                sys.feedback_field(&x, &target, &gains, &mut fb);
                feedback.agree(p, &x, t, g, &fb);
                check_model!(@partitioned $part, sys, tapes, halves, x, p, t, g, N);
            }
        }
    };
    (@partitioned true, $sys:ident, $tapes:ident, $halves:ident, $x:ident, $p:ident, $t:ident, $g:ident, $n:ident) => {
        let part = $tapes.partition.as_ref().expect("partitioned");
        let (cq, cp) = $halves.as_ref().expect("partitioned");
        let (mut dq, mut dp) = ([0.0; $n], [0.0; $n]);
        $sys.field_q(&$x, &mut dq);
        $sys.field_p(&$x, &mut dp);
        let q: Vec<f64> = (0..$n).filter(|&k| part.is_q[k]).map(|k| dq[k]).collect();
        let pp: Vec<f64> = (0..$n).filter(|&k| !part.is_q[k]).map(|k| dp[k]).collect();
        cq.agree($p, &$x, $t, $g, &q);
        cp.agree($p, &$x, $t, $g, &pp);
    };
    (@partitioned false, $sys:ident, $tapes:ident, $halves:ident, $($rest:tt)*) => {
        let _ = &$halves;
        assert!($tapes.partition.is_none(), "the model is partitioned: check field_q/field_p");
    };
}

check_model!(coupled_oscillators, "coupled_oscillators.lsl", models::coupled_oscillators::CoupledOscillators, partitioned: true);
check_model!(cr3bp, "cr3bp.lsl", models::cr3bp::CR3BP, partitioned: false);
check_model!(duffing, "duffing.lsl", models::duffing::Duffing, partitioned: false);
check_model!(kepler, "kepler.lsl", models::kepler::Kepler, partitioned: true);
check_model!(pendulum_closed_form, "pendulum_closed_form.lsl", models::pendulum_closed_form::PendulumClosedForm, partitioned: true);
check_model!(perturbed_kepler, "perturbed_kepler.lsl", models::perturbed_kepler::PerturbedKepler, partitioned: true);
check_model!(rigid_body, "rigid_body.lsl", models::rigid_body::RigidBody, partitioned: false);
check_model!(so3_type_i, "so3_type_i.lsl", models::so3_type_i::So3TypeI, partitioned: false);
