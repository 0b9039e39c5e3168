//! The Taylor program in loop form: interpreter and JIT bitwise equal, and the coefficients
//! those of the unrolled model's Taylor program up to the order of summation, for the N-body
//! and FPUT families at several sizes.

use lasalle_exec::jit::taylor::{
    JitLoopFeedbackTaylor, JitLoopTaylor, JitTaylor, MAX_INSTRUCTIONS,
};
use lasalle_exec::{LoadedModel, LoopFeedbackTaylor, LoopTaylorTape, TaylorTape};
use lasalle_model::loops::{Families, LoopModel};
use lasalle_model::tape::{Dims, Tape};
use lasalle_runtime::taylor::TaylorKernel;

const NBODY: &str = include_str!("../../models/nbody.lsl");
const FPUT: &str = include_str!("../../models/fput.lsl");

fn sized(text: &str, default: &str, n: usize) -> String {
    assert!(text.contains(default));
    text.replace(default, &format!("param n = {n};"))
}

fn numbers(seed: u64, len: usize) -> Vec<f64> {
    let mut rng = lasalle_testkit::Rng::new(seed);
    (0..len).map(|_| rng.uniform(-1.0, 1.0)).collect()
}

const ORDER: u32 = 20;

/// Coefficients of orders 0..=ORDER of every state component, from the loop form by the
/// interpreter and the JIT (checked bitwise equal) and from the unrolled program.
fn check(text: &str, state: impl Fn(u64, usize) -> Vec<f64>) {
    let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
    assert!(!lm.families().is_empty(), "the model has a loop family");
    let field = lm.tapes().unwrap().field;
    let program = field.taylor().unwrap();
    // the code does not grow with the tuples: one body per region
    assert_eq!(program.regions.len(), field.regions.len());
    let model = lasalle_model::lower_source("m.lsl", text).unwrap();
    let dims = Dims {
        state: model.dim(),
        params: model.param_slots(),
        targets: 0,
        gains: 0,
    };
    let unrolled = Tape::from_graph(&model.graph, &model.field, dims).unwrap();
    let params = lm.default_params();
    let mut interp = LoopTaylorTape::new(&field, &params, ORDER).unwrap();
    let mut jit = JitLoopTaylor::new(&field, &params, ORDER).unwrap();
    let mut plain = TaylorTape::new(&unrolled, &params, ORDER).unwrap();
    let n = lm.dim();
    for seed in 0..3 {
        let x = state(seed, n);
        interp.compute(&x, ORDER as usize);
        TaylorKernel::<LoadedModel>::compute(&mut jit, &x, ORDER as usize);
        plain.compute(&x, ORDER as usize);
        let bits = |c: &[f64]| c.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for i in 0..n {
            let a = interp.state_coefficients(i);
            let b = TaylorKernel::<LoadedModel>::coefficients(&jit, i);
            assert_eq!(a.len(), ORDER as usize + 1);
            assert_eq!(
                bits(a),
                bits(b),
                "component {i}: interpreter and JIT differ"
            );
        }
        // against the unrolled program, per order relative to the order's largest coefficient
        for k in 0..=ORDER as usize {
            let scale = (0..n).fold(0.0f64, |m, i| m.max(plain.state_coefficients(i)[k].abs()));
            assert!(scale > 0.0 || k > 1, "order {k} is not trivial");
            for i in 0..n {
                let (a, u) = (
                    interp.state_coefficients(i)[k],
                    plain.state_coefficients(i)[k],
                );
                assert!(
                    (a - u).abs() <= 1e-13 * scale,
                    "seed {seed}, component {i}, order {k}: loops {a:e}, unrolled {u:e} (scale {scale:e})"
                );
            }
        }
    }
}

/// Bodies spread along a line (0.9 apart) with random offsets and momenta.
fn nbody_state(seed: u64, n: usize) -> Vec<f64> {
    let r = numbers(seed, n);
    (0..n)
        .map(|i| {
            if i < n / 2 {
                0.3 * r[i] + (i / 3) as f64 * 0.9
            } else {
                0.5 * r[i]
            }
        })
        .collect()
}

#[test]
fn nbody_loop_taylor_is_the_unrolled_programs() {
    for n in [3, 9, 20] {
        check(&sized(NBODY, "param n = 5;", n), nbody_state);
    }
}

#[test]
fn fput_loop_taylor_is_the_unrolled_programs() {
    for n in [5, 12, 40] {
        let text = sized(FPUT, "param n = 16;", n).replace("param beta = 0;", "param beta = 0.7;");
        check(&text, |seed, len| {
            numbers(seed, len).iter().map(|v| 0.5 * v).collect()
        });
    }
}

/// The interpreter's coefficients at a lower order are the first ones of the full order's,
/// and a change of parameters is picked up.
#[test]
fn loop_taylor_orders_and_parameters() {
    let text = sized(NBODY, "param n = 5;", 4);
    let lm = LoopModel::from_source("m.lsl", &text, Families::Loops).unwrap();
    let field = lm.tapes().unwrap().field;
    let mut params = lm.default_params();
    let mut k = LoopTaylorTape::new(&field, &params, ORDER).unwrap();
    let x = nbody_state(7, lm.dim());
    k.compute(&x, ORDER as usize);
    let full: Vec<Vec<f64>> = (0..lm.dim())
        .map(|i| k.state_coefficients(i).to_vec())
        .collect();
    k.compute(&x, 5);
    for (i, c) in full.iter().enumerate() {
        assert_eq!(k.state_coefficients(i), &c[..6]);
    }
    // doubling every parameter doubles the masses and G, which changes the forces
    for p in &mut params {
        *p *= 2.0;
    }
    k.set_params(&params).unwrap();
    k.compute(&x, ORDER as usize);
    let changed = (0..lm.dim()).any(|i| k.state_coefficients(i)[1] != full[i][1]);
    assert!(changed, "new parameters change the field");
}

/// A chain whose pair term has a cosine, an exponential, a square root and a quotient: the
/// recurrences of sine and cosine, exponential, power and division in loop form.
#[test]
fn transcendental_chain_loop_taylor_is_the_unrolled_programs() {
    let text = "model Chain {
        param n = 9;
        state q: scalar[n], p: scalar[n];
        param k: scalar[n] = [i in 0..n: 1 + i / 4];
        hamiltonian H = sum(i in 0..n: p[i]^2 / 2)
            + sum(i in 0..n-1: k[i] * (1 - cos(q[i+1] - q[i])) + 0.1 * exp(q[i] * q[i+1])
                  + sqrt(1 + q[i]^2) / (2 + q[i+1]^2));
        structure canonical(q, p);
    }";
    check(text, |seed, len| {
        numbers(seed, len).iter().map(|v| 0.8 * v).collect()
    });
}

/// The staged Taylor kernels' coefficients at `x` (after a compute at ORDER): the interpreter's
/// and the JIT's bitwise equal, order 0 `x` and order 1 `field` bitwise, and every order the
/// unrolled program's to 10⁻¹³ of its order's largest coefficient in each of `blocks`.
fn staged_agree(
    [interp, jit]: [&dyn TaylorKernel<LoadedModel>; 2],
    plain: &TaylorTape,
    (x, field): (&[f64], &[f64]),
    blocks: &[std::ops::Range<usize>],
    what: &str,
) {
    let bits = |c: &[f64]| c.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for i in 0..x.len() {
        let (a, b) = (interp.coefficients(i), jit.coefficients(i));
        assert_eq!(a.len(), ORDER as usize + 1);
        assert_eq!(
            bits(a),
            bits(b),
            "{what}, component {i}: interpreter and JIT differ"
        );
        assert_eq!(a[0].to_bits(), x[i].to_bits());
        assert_eq!(
            a[1].to_bits(),
            field[i].to_bits(),
            "{what}, component {i}: order 1 is not the staged field"
        );
    }
    for k in 0..=ORDER as usize {
        for block in blocks {
            let scale = block
                .clone()
                .fold(0.0f64, |m, i| m.max(plain.state_coefficients(i)[k].abs()));
            assert!(scale > 0.0, "{what}: order {k} is not trivial");
            for i in block.clone() {
                let (a, u) = (interp.coefficients(i)[k], plain.state_coefficients(i)[k]);
                assert!(
                    (a - u).abs() <= 1e-13 * scale,
                    "{what}, component {i}, order {k}: loops {a:e}, unrolled {u:e} (scale {scale:e})"
                );
            }
        }
    }
}

/// The Taylor program of X − ∇V in loop form ([`LoopFeedbackTaylor`], [`JitLoopFeedbackTaylor`]):
/// interpreter and JIT bitwise equal, order 1 bitwise X − ∇V of the staged tapes, and every
/// order the unrolled model's program of X − ∇V up to the order of summation, with targets off
/// the state's level set and distinct gains.
fn check_feedback(text: &str, state: impl Fn(u64, usize) -> Vec<f64>) {
    let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
    assert!(!lm.families().is_empty(), "the model has a loop family");
    let stages = lm.feedback().unwrap();
    let program = stages.taylor().unwrap();
    assert!(program.sums_count > 0, "V reads a family's sum");
    // the JIT compiles every stage (the weights' program is small)
    let size = JitTaylor::instructions(&program.weights, ORDER as usize);
    assert!(size <= MAX_INSTRUCTIONS, "{size}");
    let unrolled = lasalle_model::derive(lasalle_model::lower_source("m.lsl", text).unwrap());
    let tapes = lasalle_model::tape::ModelTapes::new(&unrolled).unwrap();
    let params = lm.default_params();
    let invariants = lm.tapes().unwrap().invariants;
    let gains: Vec<f64> = (0..unrolled.model.gains.len())
        .map(|i| 0.7 + 0.3 * i as f64)
        .collect();
    let mut interp = LoopFeedbackTaylor::new(&stages, &params, ORDER).unwrap();
    let mut jit = JitLoopFeedbackTaylor::new(&stages, &params, ORDER).unwrap();
    let mut plain = TaylorTape::new(&tapes.feedback, &params, ORDER).unwrap();
    let n = lm.dim();
    for seed in 0..3 {
        let x = state(seed, n);
        let target: Vec<f64> = invariants
            .eval(&params, &state(seed + 10, n))
            .unwrap()
            .iter()
            .map(|v| 0.9 * v + 0.05)
            .collect();
        TaylorKernel::<LoadedModel>::set_inputs(&mut interp, &target, &gains).unwrap();
        TaylorKernel::<LoadedModel>::set_inputs(&mut jit, &target, &gains).unwrap();
        TaylorKernel::<LoadedModel>::set_inputs(&mut plain, &target, &gains).unwrap();
        interp.compute(&x, ORDER as usize);
        TaylorKernel::<LoadedModel>::compute(&mut jit, &x, ORDER as usize);
        plain.compute(&x, ORDER as usize);
        let field = stages.eval_feedback(&params, &x, &target, &gains).unwrap();
        staged_agree(
            [&interp, &jit],
            &plain,
            (&x, &field),
            std::slice::from_ref(&(0..n)),
            &format!("seed {seed}"),
        );
    }
    // the gains enter: doubling them changes order 1 where ∇V does not vanish
    let x = state(0, n);
    let before: Vec<f64> = (0..n).map(|i| interp.state_coefficients(i)[1]).collect();
    let doubled: Vec<f64> = gains.iter().map(|g| 2.0 * g).collect();
    let target = vec![0.5; invariants.n_outputs()];
    TaylorKernel::<LoadedModel>::set_inputs(&mut interp, &target, &doubled).unwrap();
    interp.compute(&x, ORDER as usize);
    assert!((0..n).any(|i| interp.state_coefficients(i)[1] != before[i]));
    // wrong lengths are refused, not read past
    let short = TaylorKernel::<LoadedModel>::set_inputs(&mut jit, &target[1..], &gains);
    assert!(short.is_err());
}

#[test]
fn nbody_loop_feedback_taylor_is_the_unrolled_programs() {
    for n in [4, 6] {
        check_feedback(&sized(NBODY, "param n = 5;", n), nbody_state);
    }
}

#[test]
fn fput_loop_feedback_taylor_is_the_unrolled_programs() {
    for n in [5, 12] {
        let text = sized(FPUT, "param n = 16;", n).replace("param beta = 0;", "param beta = 0.7;");
        check_feedback(&text, |seed, len| {
            numbers(seed, len).iter().map(|v| 0.5 * v).collect()
        });
    }
}

/// The chaos indicators' field of the loop-form extension (staged as X − ∇V is): interpreter
/// and JIT bitwise equal, order 1 bitwise the staged field, and every order the unrolled
/// extension's program up to the order of summation, at random extended states (x, then a
/// tangent u, then ℓ, τ, a, b).
fn check_indicators(text: &str, state: impl Fn(u64, usize) -> Vec<f64>) {
    use lasalle_model::loops::ExtendedField;
    use lasalle_model::variational::Extension;
    let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
    assert!(!lm.families().is_empty(), "the model has a loop family");
    let ext = lm.extend(Extension::Indicators).unwrap();
    let ExtendedField::Staged(stages) = ext.field().unwrap() else {
        panic!("the indicators' field is staged")
    };
    let program = stages.taylor().unwrap();
    let n = lm.dim();
    assert_eq!(program.sums_count, n + 4, "S = (A·u, 0, 0, 0, 0)");
    // the JIT's code calls the interpreter for stage 2 (λ and the rates: too large to unroll)
    let size = JitTaylor::instructions(&program.weights, ORDER as usize);
    assert!(size > MAX_INSTRUCTIONS, "{size}");
    let model = ext.unrolled().unwrap();
    let e = model.dim();
    assert_eq!(e, 2 * n + 4);
    let dims = Dims {
        state: e,
        params: model.param_slots(),
        targets: 0,
        gains: 0,
    };
    let unrolled = Tape::from_graph(&model.graph, &model.field, dims).unwrap();
    let params = lm.default_params();
    let mut interp = LoopFeedbackTaylor::new(&stages, &params, ORDER).unwrap();
    let mut jit = JitLoopFeedbackTaylor::new(&stages, &params, ORDER).unwrap();
    let mut plain = TaylorTape::new(&unrolled, &params, ORDER).unwrap();
    for seed in 0..3 {
        let mut x = state(seed, n);
        x.extend(numbers(seed + 20, n + 4));
        interp.compute(&x, ORDER as usize);
        TaylorKernel::<LoadedModel>::compute(&mut jit, &x, ORDER as usize);
        plain.compute(&x, ORDER as usize);
        let field = ExtendedField::Staged(stages.clone())
            .eval(&params, &x)
            .unwrap();
        // per block (x, u, then ℓ, τ, a, b): their scales differ by orders of magnitude
        staged_agree(
            [&interp, &jit],
            &plain,
            (&x, &field),
            &[0..n, n..2 * n, 2 * n..e],
            &format!("seed {seed}"),
        );
    }
}

#[test]
fn nbody_loop_indicators_taylor_is_the_unrolled_extensions() {
    for n in [4, 6] {
        check_indicators(&sized(NBODY, "param n = 5;", n), nbody_state);
    }
}

#[test]
fn fput_loop_indicators_taylor_is_the_unrolled_extensions() {
    for n in [5, 12] {
        let text = sized(FPUT, "param n = 16;", n).replace("param beta = 0;", "param beta = 0.7;");
        check_indicators(&text, |seed, len| {
            numbers(seed, len).iter().map(|v| 0.5 * v).collect()
        });
    }
}
