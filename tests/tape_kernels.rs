//! The kernels emitted from the tapes, on every model file in `models/` (the list `build.rs`
//! writes from the directory, so a new file is covered without a change here; a model emitted
//! in its loop form has no Taylor kernels or lanes, and is checked by `tape_vs_emitted` alone):
//! - the emitted Taylor kernels (`kernels::TaylorField`, `kernels::TaylorFeedback`) compute the
//!   coefficients that the interpreted `lasalle_exec::TaylorTape` computes, bitwise, at random
//!   states, and the compiled and loaded Taylor integrators take the same steps;
//! - every batched function (`kernels::Lanes`, K = 4 and 8) equals the scalar emitted function
//!   (or the tape, for the Hamiltonian, which has no scalar function) lane by lane, bitwise;
//! - a compiled Taylor step, plain or feedback, allocates nothing.

use lasalle::models;
use lasalle::{Backend, LoadedModel};
use lasalle_codegen::tape::{ModelTapes, Tape};
use lasalle_exec::TaylorTape;
use lasalle_runtime::taylor::{TaylorKernel, EMITTED_MAX_ORDER};
use lasalle_runtime::{Field, Invariants, Lyapunov, Partitioned};
use lasalle_testkit::{allocations, CountingAllocator};

mod common;
use common::tapes;
use lasalle_testkit::{known_ulps, same, within_ulps};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Numbers in ±[0.5, 1.5), from a fixed seed.
fn rng() -> impl FnMut() -> f64 {
    let mut rng = lasalle_testkit::Rng::new(0x9e37_79b9_7f4a_7c15);
    move || (0.5 + rng.unit()) * rng.sign()
}

/// The emitted kernel against the interpreted one at `x`, to order 20: every coefficient.
fn same_coefficients<M>(
    what: &str,
    emitted: &mut dyn TaylorKernel<M>,
    tape: &mut TaylorTape,
    x: &[f64],
) {
    let order = 20;
    emitted.compute(x, order);
    tape.compute(x, order);
    for i in 0..x.len() {
        let (a, b) = (emitted.coefficients(i), tape.state_coefficients(i));
        assert_eq!(a.len(), order + 1);
        for (k, (&u, &v)) in a.iter().zip(b).enumerate() {
            assert!(
                same(u, v),
                "{what}: x_{i}^[{k}] at {x:?}: emitted {u:e}, tape {v:e}"
            );
        }
    }
}

/// Lane `l` of a batch against one state's values: bitwise, or within the ulps of the largest
/// value known for the model file (`lasalle_testkit::known_ulps`).
fn same_lane<const K: usize>(file: &str, what: &str, lanes: &[[f64; K]], l: usize, scalar: &[f64]) {
    assert_eq!(lanes.len(), scalar.len(), "{what}");
    let max = known_ulps(file);
    let scale = scalar.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (j, (row, &s)) in lanes.iter().zip(scalar).enumerate() {
        assert!(
            within_ulps(row[l], s, max, scale),
            "{file}: {what}[{j}] lane {l}: {:e} vs scalar {s:e}",
            row[l]
        );
    }
}

/// Component `i` of every lane.
fn soa<const N: usize, const K: usize>(xs: &[[f64; N]; K]) -> [[f64; K]; N] {
    std::array::from_fn(|i| std::array::from_fn(|l| xs[l][i]))
}

macro_rules! check_model {
    ($module:ident, $ty:ident, $prepared:ident, $file:literal, loops: true, $($flags:tt)*) => {
        // the loop form has no Taylor kernels and no lanes of the derived functions
    };
    ($module:ident, $ty:ident, $prepared:ident, $file:literal, loops: false, invariants: $inv:tt, partitioned: $part:tt, hamiltonian: $ham:tt) => {
        mod $module {
            use super::*;
            use models::$module::kernels;
            type Model = models::$module::$ty;
            type Prepared = models::$module::$prepared;
            const N: usize = Model::N;
            const M: usize = Model::M;
            const FILE: &str = $file;

            #[test]
            fn taylor_kernels_agree_with_the_tape() {
                let (model, tapes) = tapes(FILE);
                let sys = Model::default().prepare();
                let params = model.default_params();
                let order = EMITTED_MAX_ORDER as u32;
                let mut tf = TaylorTape::new(&tapes.field, &params, order).unwrap();
                let mut tb = TaylorTape::new(&tapes.feedback, &params, order).unwrap();
                let mut ef = kernels::TaylorField::new(&sys);
                let mut eb = kernels::TaylorFeedback::new(&sys);
                let mut rand = rng();
                let gains = Model::default_gains();
                for _ in 0..20 {
                    let x: [f64; N] = std::array::from_fn(|_| rand());
                    let x0: [f64; N] = std::array::from_fn(|_| rand());
                    let target = sys.targets(&x0);
                    TaylorKernel::<Prepared>::set_inputs(&mut eb, &target, &gains).unwrap();
                    TaylorKernel::<LoadedModel>::set_inputs(&mut tb, &target, &gains).unwrap();
                    same_coefficients::<Prepared>("field", &mut ef, &mut tf, &x);
                    same_coefficients::<Prepared>("feedback", &mut eb, &mut tb, &x);
                }
                // a parameter change reaches the emitted kernels through `sync`
                let mut changed = sys;
                let p2: Vec<f64> = params.iter().map(|p| p * 1.25 + 0.125).collect();
                let names: Vec<&str> = Model::PARAMS.iter().map(|s| s.name).collect();
                for (slot, name) in Model::PARAMS.iter().zip(&names) {
                    let len = slot.shape.len();
                    lasalle_runtime::Parameters::set_param(
                        &mut changed,
                        name,
                        &p2[slot.offset..slot.offset + len],
                    )
                    .unwrap();
                }
                let p2 = changed.slot_values().to_vec();
                TaylorKernel::<Prepared>::sync(&mut ef, &changed).unwrap();
                tf.set_params(&p2).unwrap();
                let x: [f64; N] = std::array::from_fn(|_| rand());
                same_coefficients::<Prepared>("field after a parameter change", &mut ef, &mut tf, &x);
            }

            #[test]
            fn lanes_equal_scalar_calls() {
                let (_, tapes) = tapes(FILE);
                let sys = Model::default().prepare();
                let params = sys.slot_values();
                let mut rand = rng();
                let gains = Model::default_gains();
                let x0: [f64; N] = std::array::from_fn(|_| rand());
                let target = sys.targets(&x0);
                let lanes = sys.lanes();
                for _ in 0..10 {
                    check_lanes::<4>(&sys, &lanes, &tapes, &params, &target, &gains, &mut rand);
                    check_lanes::<8>(&sys, &lanes, &tapes, &params, &target, &gains, &mut rand);
                }
            }

            #[allow(unused_variables)]
            fn check_lanes<const K: usize>(
                sys: &Prepared,
                lanes: &kernels::Lanes,
                tapes: &ModelTapes,
                params: &[f64],
                target: &[f64; M],
                gains: &[f64; Model::G],
                rand: &mut impl FnMut() -> f64,
            ) {
                let xs: [[f64; N]; K] = std::array::from_fn(|_| std::array::from_fn(|_| rand()));
                let x = soa(&xs);
                let mut dx = [[0.0; K]; N];
                lanes.field(&x, &mut dx);
                let mut f = [[0.0; K]; M];
                lanes.invariants(&x, &mut f);
                let mut jac = [[0.0; K]; M * N];
                lanes.jacobian(&x, &mut jac);
                let mut v = [[0.0; K]; 1];
                let mut grad = [[0.0; K]; N];
                let mut fb = [[0.0; K]; N];
                check_model!(@derived $inv, lanes, x, target, gains, v, grad, fb);
                for (l, xl) in xs.iter().enumerate() {
                    let mut s = [0.0; N];
                    sys.field(xl, &mut s);
                    same_lane(FILE, "field", &dx, l, &s);
                    let mut sf = [0.0; M];
                    sys.invariants(xl, &mut sf);
                    same_lane(FILE, "invariants", &f, l, &sf);
                    let mut sj = [[0.0; N]; M];
                    sys.invariants_jacobian(xl, &mut sj);
                    same_lane(FILE, "jacobian", &jac, l, sj.as_flattened());
                    same_lane(FILE, "lyapunov", &v, l, &[sys.lyapunov(xl, target, gains)]);
                    sys.lyapunov_gradient(xl, target, gains, &mut s);
                    same_lane(FILE, "lyapunov_gradient", &grad, l, &s);
                    sys.feedback_field(xl, target, gains, &mut s);
                    same_lane(FILE, "feedback", &fb, l, &s);
                }
                check_model!(@partitioned $part, sys, lanes, tapes, xs, x, K);
                check_model!(@hamiltonian $ham, lanes, tapes, params, xs, x, K);
            }
        }
    };
    // without invariants the lanes of V, ∇V and X − ∇V read no targets and no gains
    (@derived true, $lanes:ident, $x:ident, $t:ident, $g:ident, $v:ident, $grad:ident, $fb:ident) => {
        $lanes.lyapunov(&$x, $t, $g, &mut $v);
        $lanes.lyapunov_gradient(&$x, $t, $g, &mut $grad);
        $lanes.feedback(&$x, $t, $g, &mut $fb);
    };
    (@derived false, $lanes:ident, $x:ident, $t:ident, $g:ident, $v:ident, $grad:ident, $fb:ident) => {
        $lanes.lyapunov(&$x, &mut $v);
        $lanes.lyapunov_gradient(&$x, &mut $grad);
        $lanes.feedback(&$x, &mut $fb);
    };
    (@partitioned true, $sys:ident, $lanes:ident, $tapes:ident, $xs:ident, $x:ident, $k:ident) => {
        let is_q = &$tapes.partition.as_ref().expect("partitioned").is_q;
        let nq = is_q.iter().filter(|&&q| q).count();
        let mut oq = vec![[0.0; $k]; nq];
        let mut op = vec![[0.0; $k]; N - nq];
        $lanes.field_q(&$x, (&mut oq[..]).try_into().unwrap());
        $lanes.field_p(&$x, (&mut op[..]).try_into().unwrap());
        for (l, xl) in $xs.iter().enumerate() {
            let (mut dq, mut dp) = ([0.0; N], [0.0; N]);
            $sys.field_q(xl, &mut dq);
            $sys.field_p(xl, &mut dp);
            let q: Vec<f64> = (0..N).filter(|&i| is_q[i]).map(|i| dq[i]).collect();
            let p: Vec<f64> = (0..N).filter(|&i| !is_q[i]).map(|i| dp[i]).collect();
            same_lane(FILE, "field_q", &oq, l, &q);
            same_lane(FILE, "field_p", &op, l, &p);
        }
    };
    (@partitioned false, $sys:ident, $lanes:ident, $tapes:ident, $($rest:tt)*) => {
        assert!($tapes.partition.is_none(), "the tapes are partitioned, the emitted model not");
    };
    (@hamiltonian true, $lanes:ident, $tapes:ident, $params:ident, $xs:ident, $x:ident, $k:ident) => {
        let tape: &Tape = $tapes.hamiltonian.as_ref().expect("a Hamiltonian");
        let mut h = [[0.0; $k]; 1];
        $lanes.hamiltonian(&$x, &mut h);
        for (l, xl) in $xs.iter().enumerate() {
            same_lane(FILE, "hamiltonian", &h, l, &tape.eval($params, xl, &[], &[]).unwrap());
        }
    };
    (@hamiltonian false, $lanes:ident, $tapes:ident, $($rest:tt)*) => {
        assert!($tapes.hamiltonian.is_none(), "the tapes have a Hamiltonian, the lanes not");
    };
}

include!(concat!(env!("OUT_DIR"), "/model_list.rs"));
for_each_model!(check_model);

/// Kepler (e = 0.8) over 10 periods: the compiled Taylor integrator (emitted kernels) and the
/// loaded one (the interpreted tape) take the same steps; L and A are kept to 1e-12.
#[test]
fn compiled_and_loaded_taylor_integrate_alike() {
    use lasalle_runtime::{integrate, TaylorOptions};
    let path = format!("{}/models/kepler.lsl", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    let loaded = LoadedModel::from_source(&path, &text, Backend::Interpreter).unwrap();
    let sys = models::kepler::Kepler::default().prepare();
    // e = 0.8 at perihelion: r = 0.2, v = sqrt(mu (1 + e) / r) with mu = 1
    let x0 = [0.2, 0.0, 0.0, 0.0, 9.0f64.sqrt(), 0.0];
    let params = sys.slot_values();
    assert_eq!(params.as_slice(), loaded.params(), "the same parameters");
    let t_end = 10.0 * 2.0 * std::f64::consts::PI; // a = 1
    let opts = TaylorOptions::with_tol(1e-15);
    let mut compiled = sys.taylor(opts).unwrap();
    let mut interpreted = loaded.taylor(opts).unwrap();
    let a = integrate(&mut compiled, &sys, &x0, 0.0, t_end, 0.0, &mut ()).unwrap();
    let xv = x0.to_vec();
    let b = integrate(&mut interpreted, &loaded, &xv, 0.0, t_end, 0.0, &mut ()).unwrap();
    assert_eq!(a.steps, b.steps);
    for (u, v) in a.x.iter().zip(&b.x) {
        assert!(same(*u, *v), "{:?} vs {:?}", a.x, b.x);
    }
    let (mut f0, mut f1) = (
        [0.0; models::kepler::Kepler::<f64>::M],
        [0.0; models::kepler::Kepler::<f64>::M],
    );
    sys.invariants(&x0, &mut f0);
    sys.invariants(&a.x, &mut f1);
    for (u, v) in f0.iter().zip(&f1) {
        assert!((u - v).abs() < 1e-12, "invariants {f0:?} → {f1:?}");
    }
}

/// Steps of the compiled rigid body's Taylor integrator, on X and on X − ∇V through a
/// `FeedbackField` with array gains, allocate nothing (the kernels' tables are allocated when
/// the integrator is built).
#[test]
fn compiled_taylor_steps_do_not_allocate() {
    use lasalle_runtime::{FeedbackField, Stepper, TaylorOptions};
    let sys = models::rigid_body::RigidBody::default().prepare();
    let x0 = sys.point_paper();
    let fb = FeedbackField::from_initial(&sys, &x0, models::rigid_body::RigidBody::default_gains());
    let mut taylor = sys.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
    let mut x = x0;
    // the first steps (no allocation expected either, but outside the count)
    taylor.step(&sys, 0.0, &mut x, 0.1).unwrap();
    taylor.step(&fb, 0.0, &mut x, 0.1).unwrap();
    let before = allocations();
    for k in 0..10 {
        let t = 0.1 * f64::from(k);
        taylor.step(&sys, t, &mut x, 0.1).unwrap();
        taylor.step(&fb, t, &mut x, 0.1).unwrap();
    }
    assert_eq!(allocations(), before, "allocations in 20 steps");
    assert!(x.iter().all(|v| v.is_finite()));
}
