//! Loop tapes on both back ends: bitwise equal to each other and to the loop tape's own
//! evaluation, and equal to the unrolled model's tapes up to the order of summation.

use lasalle_exec::{Backend, Kernel, LoopKernel};
use lasalle_model::loops::{Families, LoopModel};
use lasalle_model::tape::{Dims, Tape};

const NBODY: &str = include_str!("../../models/nbody.lsl");
const FPUT: &str = include_str!("../../models/fput.lsl");

fn sized(text: &str, default: &str, n: usize) -> String {
    assert!(text.contains(default));
    text.replace(default, &format!("param n = {n};"))
}

/// Deterministic pseudo-random numbers in [-1, 1).
fn numbers(seed: u64, len: usize) -> Vec<f64> {
    let mut rng = lasalle_testkit::Rng::new(seed);
    (0..len).map(|_| rng.uniform(-1.0, 1.0)).collect()
}

fn eval(k: &dyn Kernel, params: &[f64], x: &[f64]) -> Vec<f64> {
    let h = k.hoist(params).unwrap();
    let mut out = vec![0.0; k.n_outputs()];
    k.eval(&h, x, &[], &[], &mut out).unwrap();
    out
}

fn check(text: &str) {
    let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
    assert!(!lm.families().is_empty());
    let tapes = lm.tapes().unwrap();
    let model = lasalle_model::lower_source("m.lsl", text).unwrap();
    let dims = Dims {
        state: model.dim(),
        params: model.param_slots(),
        targets: 0,
        gains: 0,
    };
    let plain_field = Tape::from_graph(&model.graph, &model.field, dims).unwrap();
    let plain_inv = Tape::from_graph(&model.graph, &model.invariant_ids(), dims).unwrap();
    let params = lm.default_params();
    for (loops, plain) in [
        (&tapes.field, &plain_field),
        (&tapes.invariants, &plain_inv),
    ] {
        let jit = LoopKernel::new(loops, Backend::Jit).unwrap();
        let interp = LoopKernel::new(loops, Backend::Interpreter).unwrap();
        let unrolled = Backend::Jit.compile(plain).unwrap();
        for s in 0..5 {
            let x: Vec<f64> = numbers(s, lm.dim())
                .iter()
                .enumerate()
                .map(|(i, v)| v + (i / 3) as f64 * 0.41)
                .collect();
            let a = eval(&jit, &params, &x);
            let b = eval(&interp, &params, &x);
            let c = loops.eval(&params, &x).unwrap();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a), bits(&b), "JIT and interpreter differ");
            assert_eq!(bits(&a), bits(&c), "JIT and the loop tape differ");
            let u = eval(unrolled.as_ref(), &params, &x);
            let scale = u.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            for (i, (p, q)) in a.iter().zip(&u).enumerate() {
                assert!(
                    (p - q).abs() <= 1e-13 * scale,
                    "output {i}: loops {p}, unrolled {q}"
                );
            }
            // Lanes: each lane is one evaluation.
            let k = 3;
            let mut xs = vec![0.0; x.len() * k];
            for (i, v) in x.iter().enumerate() {
                for lane in 0..k {
                    xs[i * k + lane] = v + lane as f64 * 1e-3;
                }
            }
            let h = jit.hoist(&params).unwrap();
            let mut out = vec![0.0; jit.n_outputs() * k];
            jit.eval_lanes(k, &h, &xs, &[], &[], &mut out).unwrap();
            for (j, v) in a.iter().enumerate() {
                assert_eq!(out[j * k].to_bits(), v.to_bits());
            }
        }
    }
}

#[test]
fn nbody_loop_kernels_agree() {
    for n in [3, 9, 20] {
        check(&sized(NBODY, "param n = 5;", n));
    }
}

#[test]
fn fput_loop_kernels_agree() {
    for n in [5, 40] {
        check(&sized(FPUT, "param n = 16;", n));
    }
    // with the cubic and quartic springs
    let text = sized(FPUT, "param n = 16;", 12).replace("param beta = 0;", "param beta = 0.7;");
    check(&text);
}

/// The JIT runs a region's tuples two at a time and the odd last one alone, adding the
/// outputs of each pair to `out` in the interpreter's order: equal bit for bit at odd and
/// even counts (N-body with 5 bodies: 10 pairs, 6: 15; FPUT with n odd and even: n − 1
/// neighbours and n kinetic terms), and where the two tuples of a pair add to the same
/// elements, three contributions each, their slots 128-bit loads (a second-neighbour chain).
#[test]
fn two_tuples_at_a_time_agree_with_the_interpreter_at_odd_and_even_counts() {
    let counts = |text: &str| {
        let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
        let field = lm.tapes().unwrap().field;
        field.regions.iter().map(|r| r.count).collect::<Vec<_>>()
    };
    let nbody5 = sized(NBODY, "param n = 5;", 5);
    let nbody6 = sized(NBODY, "param n = 5;", 6);
    assert!(counts(&nbody5).contains(&10) && counts(&nbody6).contains(&15));
    let beta = |n| sized(FPUT, "param n = 16;", n).replace("param beta = 0;", "param beta = 0.7;");
    let (fput7, fput8) = (beta(7), beta(8));
    let c = [counts(&fput7), counts(&fput8)].concat();
    assert!(c.iter().any(|n| n % 2 == 1) && c.iter().any(|n| n % 2 == 0));
    let chain = |n: usize| {
        format!(
            "model Chain {{\n param n = {n};\n state q: scalar[n], p: scalar[n];\n \
             hamiltonian H = sum(i in 0..n: p[i]^2 / 2)\n \
             + sum(i in 0..n-2: (q[i+1] - q[i])^2 / 2 + (q[i+2] - q[i])^4 / 4);\n \
             structure canonical(q, p);\n}}\n"
        )
    };
    for text in [nbody5, nbody6, fput7, fput8, chain(9), chain(10)] {
        check(&text);
    }
}

/// The compiled code of a region does not grow with the number of tuples.
#[test]
fn region_code_is_independent_of_n() {
    let ops = |n| {
        let lm = LoopModel::from_source("m.lsl", &sized(NBODY, "param n = 5;", n), Families::Loops)
            .unwrap();
        lm.tapes().unwrap().field.instructions()
    };
    assert_eq!(ops(10), ops(60));
}

mod loaded {
    use super::*;
    use lasalle_exec::LoadedModel;
    use lasalle_model::Verdict;
    use lasalle_runtime::{Declared, Field, Invariants, Lyapunov, ModelInfo, Parameters};

    fn close(a: &[f64], b: &[f64], what: &str) {
        let scale = b.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for (i, (p, q)) in a.iter().zip(b).enumerate() {
            assert!((p - q).abs() <= 1e-13 * scale, "{what}[{i}]: {p} vs {q}");
        }
    }

    /// A model loaded with its families as loops computes what the unrolled one computes, to
    /// rounding (every function a loop kernel), after a parameter change too.
    #[test]
    fn a_loaded_loop_model_agrees_with_the_unrolled_one() {
        let text = sized(NBODY, "param n = 5;", 10);
        let mut loops =
            LoadedModel::from_source_with("m.lsl", &text, Backend::Jit, Families::Loops).unwrap();
        let mut plain = LoadedModel::from_source("m.lsl", &text, Backend::Jit).unwrap();
        for c in loops.conservation() {
            assert_eq!(c.verdict, Verdict::Proved, "{}", c.name);
        }
        for round in 0..2 {
            if round == 1 {
                loops.set_param("G", &[0.7]).unwrap();
                plain.set_param("G", &[0.7]).unwrap();
            }
            let x = loops.point("ring").unwrap();
            lasalle_testkit::assert_same(&x, &plain.point("ring").unwrap(), "the point");
            let n = x.len();
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            loops.field(&x, &mut a);
            plain.field(&x, &mut b);
            close(&a, &b, "field");
            let m = plain.invariant_dim();
            let (mut fa, mut fb) = (vec![0.0; m], vec![0.0; m]);
            loops.invariants(&x, &mut fa);
            plain.invariants(&x, &mut fb);
            close(&fa, &fb, "invariants");
            let (mut ja, mut jb) = (vec![vec![0.0; n]; m], vec![vec![0.0; n]; m]);
            loops.invariants_jacobian(&x, &mut ja);
            plain.invariants_jacobian(&x, &mut jb);
            for (ra, rb) in ja.iter().zip(&jb) {
                close(ra, rb, "Df");
            }
            let target = fb.clone();
            let gains = plain.default_gain_values().to_vec();
            let y: Vec<f64> = x.iter().map(|v| v * 1.01).collect();
            let v = plain.lyapunov(&y, &target, &gains);
            assert!(v.is_finite() && v > 0.0);
            close(&[loops.lyapunov(&y, &target, &gains)], &[v], "V");
            let (mut ga, mut gb) = (vec![0.0; n], vec![0.0; n]);
            loops.lyapunov_gradient(&y, &target, &gains, &mut ga);
            plain.lyapunov_gradient(&y, &target, &gains, &mut gb);
            assert!(gb.iter().any(|v| *v != 0.0));
            close(&ga, &gb, "∇V");
            let (mut da, mut db) = (vec![0.0; n], vec![0.0; n]);
            loops.feedback_field(&y, &target, &gains, &mut da);
            plain.feedback_field(&y, &target, &gains, &mut db);
            assert!(db.iter().all(|v| v.is_finite()));
            close(&da, &db, "X − ∇V");
            let pa = loops.partitioned().expect("partitioned");
            let pb = plain.partitioned().expect("partitioned");
            assert_eq!(pa.is_q(), pb.is_q());
            for q in [true, false] {
                let (mut da, mut db) = (vec![0.0; n], vec![0.0; n]);
                if q {
                    pa.field_q(&x, &mut da);
                    pb.field_q(&x, &mut db);
                } else {
                    pa.field_p(&x, &mut da);
                    pb.field_p(&x, &mut db);
                }
                assert!(db.iter().all(|v| v.is_finite()));
                close(&da, &db, if q { "q̇" } else { "ṗ" });
            }
        }
    }

    /// Below the automatic threshold nothing is a loop: the model loads as usual.
    #[test]
    fn auto_loads_small_models_unrolled() {
        let text = sized(NBODY, "param n = 5;", 5);
        let m =
            LoadedModel::from_source_with("m.lsl", &text, Backend::Jit, Families::Auto).unwrap();
        let p = LoadedModel::from_source("m.lsl", &text, Backend::Jit).unwrap();
        let x = p.point("ring").unwrap();
        let (mut a, mut b) = (vec![0.0; x.len()], vec![0.0; x.len()]);
        m.field(&x, &mut a);
        p.field(&x, &mut b);
        lasalle_testkit::assert_same(&a, &b, "the field under `auto` and unrolled");
    }

    /// A model the loop form refuses loads unrolled under `auto`; `loops` reports why.
    #[test]
    fn auto_falls_back_to_unrolled_where_loops_refuse() {
        let text = "model Squared {\n param n = 80;\n state q: scalar[n], p: scalar[n];\n \
                    hamiltonian H = sum(i in 0..n: p[i]^2 / 2 + q[i]^2 / 2);\n \
                    structure canonical(q, p);\n \
                    integral S = sum(i in 0..n: p[i]^2 + q[i]^2)^2;\n}\n";
        let m = LoadedModel::from_source_with("m.lsl", text, Backend::Jit, Families::Auto);
        assert!(m.is_ok(), "{:?}", m.err());
        let e = LoadedModel::from_source_with("m.lsl", text, Backend::Jit, Families::Loops)
            .expect_err("refused")
            .to_string();
        assert!(
            e.contains("m.lsl:6") && e.contains("constant coefficient"),
            "{e}"
        );
    }
}

/// The derived functions in loop form (Df, V, ∇V, X − ∇V, the half-fields): the JIT and the
/// interpreter bit for bit equal to each other and to the tapes' own evaluation; equal to the
/// unrolled model's functions to rounding; Df equal to central differences of the integrals.
mod derived {
    use super::*;
    use lasalle_exec::{Stage, StagedKernel};
    use lasalle_model::loops::LoopFeedback;
    use lasalle_model::tape::ModelTapes;

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    fn close(a: &[f64], b: &[f64], tol: f64, what: &str) {
        assert_eq!(a.len(), b.len(), "{what}: lengths");
        let scale = b.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
        for (i, (p, q)) in a.iter().zip(b).enumerate() {
            assert!(
                (p - q).abs() <= tol * scale,
                "{what}[{i}]: {p} vs {q} (scale {scale})"
            );
        }
    }

    fn eval_full(k: &dyn Kernel, params: &[f64], x: &[f64], t: &[f64], g: &[f64]) -> Vec<f64> {
        let h = k.hoist(params).unwrap();
        let mut out = vec![0.0; k.n_outputs()];
        k.eval(&h, x, t, g, &mut out).unwrap();
        out
    }

    /// V, ∇V and X − ∇V at `y`: the staged kernels of the JIT and of the interpreter bit for
    /// bit equal to each other, to the tapes' own evaluation and lane by lane; equal to the
    /// unrolled model's functions to 10⁻¹³ relative.
    fn stages_agree(
        feedback: &LoopFeedback,
        plain: &ModelTapes,
        params: &[f64],
        y: &[f64],
        target: &[f64],
        gains: &[f64],
    ) {
        let n = y.len();
        for (stage, want) in [
            (Stage::Lyapunov, &plain.lyapunov),
            (Stage::Gradient, &plain.lyapunov_gradient),
            (Stage::Feedback, &plain.feedback),
        ] {
            let jit = StagedKernel::new(feedback, stage, Backend::Jit).unwrap();
            let int = StagedKernel::new(feedback, stage, Backend::Interpreter).unwrap();
            let a = eval_full(&jit, params, y, target, gains);
            let b = eval_full(&int, params, y, target, gains);
            assert_eq!(bits(&a), bits(&b), "{stage:?}: JIT, interpreter");
            let r = match stage {
                Stage::Lyapunov => vec![feedback.eval_lyapunov(params, y, target, gains).unwrap()],
                Stage::Gradient => feedback.eval_gradient(params, y, target, gains).unwrap(),
                Stage::Feedback => feedback.eval_feedback(params, y, target, gains).unwrap(),
            };
            assert_eq!(bits(&a), bits(&r), "{stage:?}: JIT, tapes");
            let u = want.eval(params, y, target, gains).unwrap();
            assert!(u.iter().any(|v| *v != 0.0), "{stage:?} vanishes");
            close(&a, &u, 1e-13, &format!("{stage:?}"));
            // lanes: each lane one evaluation
            let k = 2;
            let mut ys = vec![0.0; n * k];
            for (i, v) in y.iter().enumerate() {
                ys[i * k] = *v;
                ys[i * k + 1] = v + 1e-3;
            }
            let h = jit.hoist(params).unwrap();
            let mut out = vec![0.0; jit.n_outputs() * k];
            jit.eval_lanes(k, &h, &ys, target, gains, &mut out).unwrap();
            for (j, v) in a.iter().enumerate() {
                assert_eq!(out[j * k].to_bits(), v.to_bits());
            }
        }
    }

    fn check(text: &str) {
        let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
        assert!(!lm.families().is_empty());
        let unrolled = lasalle_model::derive(lasalle_model::lower_source("m.lsl", text).unwrap());
        let plain = ModelTapes::new(&unrolled).unwrap();
        let params = lm.default_params();
        let (n, m) = (lm.dim(), lm.invariant_dim());
        let invariants = lm.tapes().unwrap().invariants;
        let jacobian = lm.jacobian().unwrap();
        let feedback = lm.feedback().unwrap();
        let partition = lm.partition().unwrap().expect("partitioned");
        let up = plain
            .partition
            .as_ref()
            .expect("the unrolled field is partitioned");
        assert_eq!(partition.is_q, up.is_q);
        let jit_jac = LoopKernel::new(&jacobian, Backend::Jit).unwrap();
        let int_jac = LoopKernel::new(&jacobian, Backend::Interpreter).unwrap();
        let halves = [
            (&partition.field_q, &up.field_q),
            (&partition.field_p, &up.field_p),
        ];
        let gains: Vec<f64> = unrolled.model.gains.iter().map(|g| g.default).collect();
        assert!(gains.iter().all(|&g| g > 0.0));
        for s in 0..3 {
            let x: Vec<f64> = numbers(10 + s, n)
                .iter()
                .enumerate()
                .map(|(i, v)| v + (i / 3) as f64 * 0.41)
                .collect();
            // Df: back ends, the tapes, the unrolled Df, central differences.
            let a = eval(&jit_jac, &params, &x);
            assert_eq!(
                bits(&a),
                bits(&eval(&int_jac, &params, &x)),
                "Df: JIT, interpreter"
            );
            assert_eq!(
                bits(&a),
                bits(&jacobian.eval(&params, &x).unwrap()),
                "Df: JIT, tape"
            );
            let u = plain.jacobian.eval(&params, &x, &[], &[]).unwrap();
            assert!(u.iter().any(|v| *v != 0.0));
            close(&a, &u, 1e-13, "Df");
            let mut fd = vec![0.0; m * n];
            for i in 0..n {
                let h = 1e-5 * x[i].abs().max(1.0);
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[i] += h;
                xm[i] -= h;
                let (fp, fm) = (
                    invariants.eval(&params, &xp).unwrap(),
                    invariants.eval(&params, &xm).unwrap(),
                );
                for c in 0..m {
                    fd[c * n + i] = (fp[c] - fm[c]) / (2.0 * h);
                }
            }
            close(&a, &fd, 1e-7, "Df by central differences");
            // V, ∇V, X − ∇V at a state off the targets' level set.
            let f0 = invariants.eval(&params, &x).unwrap();
            let target: Vec<f64> = f0.iter().map(|v| v * 0.9 + 0.05).collect();
            let y: Vec<f64> = x.iter().map(|v| v * 1.01).collect();
            stages_agree(&feedback, &plain, &params, &y, &target, &gains);
            // The half-fields.
            for (loops, want) in halves {
                let jit = LoopKernel::new(loops, Backend::Jit).unwrap();
                let int = LoopKernel::new(loops, Backend::Interpreter).unwrap();
                let a = eval(&jit, &params, &x);
                assert_eq!(
                    bits(&a),
                    bits(&eval(&int, &params, &x)),
                    "half: JIT, interpreter"
                );
                assert_eq!(
                    bits(&a),
                    bits(&loops.eval(&params, &x).unwrap()),
                    "half: tape"
                );
                close(
                    &a,
                    &want.eval(&params, &x, &[], &[]).unwrap(),
                    1e-13,
                    "half-field",
                );
            }
        }
    }

    #[test]
    fn nbody_derived_loop_kernels_agree() {
        for n in [3, 9, 20] {
            check(&sized(NBODY, "param n = 5;", n));
        }
    }

    #[test]
    fn fput_derived_loop_kernels_agree() {
        for n in [5, 12, 40] {
            let text =
                sized(FPUT, "param n = 16;", n).replace("param beta = 0;", "param beta = 0.7;");
            check(&text);
        }
    }

    /// V, ∇V and X − ∇V of `text` (families as loops) against the unrolled model's, at three
    /// random states with targets off their level set and distinct gains.
    fn feedback_agrees(text: &str) {
        let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
        assert!(!lm.families().is_empty());
        let unrolled = lasalle_model::derive(lasalle_model::lower_source("m.lsl", text).unwrap());
        let plain = ModelTapes::new(&unrolled).unwrap();
        let params = lm.default_params();
        let invariants = lm.tapes().unwrap().invariants;
        let feedback = lm.feedback().unwrap();
        let gains: Vec<f64> = (0..unrolled.model.gains.len())
            .map(|i| 0.7 + 0.3 * i as f64)
            .collect();
        for s in 0..3 {
            let y: Vec<f64> = numbers(20 + s, lm.dim());
            let target: Vec<f64> = invariants
                .eval(&params, &numbers(30 + s, lm.dim()))
                .unwrap()
                .iter()
                .map(|v| 0.9 * v + 0.05)
                .collect();
            stages_agree(&feedback, &plain, &params, &y, &target, &gains);
        }
    }

    /// X − ∇V combines, after the one pass over the tuples, the gradients of several sums
    /// with their weights and the field's own family parts: a Hamiltonian whose one family
    /// term reads both q and p (its equations read from the energy's gradient on both
    /// members) beside a momentum whose term differs from it; and a field with a sum in an
    /// equation (carried as a family part of the field) beside an integral whose term is that
    /// sum's body with another coefficient, and whose plain part V also differentiates.
    #[test]
    fn the_combination_of_several_sums_agrees_with_the_unrolled_model() {
        feedback_agrees(
            "model Ring {\n param n = 9;\n state q: scalar[n], p: scalar[n];\n \
             hamiltonian H = sum(i in 0..n: p[i]^2 / 2 + (q[(i + 1) % n] - q[i])^4 / 4);\n \
             structure canonical(q, p);\n integral P = sum(i in 0..n: p[i]);\n}\n",
        );
        feedback_agrees(
            "model Sink {\n param n = 6;\n state x: scalar[n], s: scalar;\n \
             for i in 0..n: d/dt x[i] = -x[i];\n d/dt s = 3 * sum(i in 0..n: x[i]^2);\n \
             integral E = s + 1.5 * sum(i in 0..n: x[i]^2);\n \
             integral Q = s^2 / 4 + sum(i in 0..n: x[i]^2 * x[i]);\n}\n",
            // Q is not conserved: the stages of X − ∇V do not read whether it is
        );
    }
}
