use super::*;
use crate::ir::{Graph, Input};

fn dims(state: usize, params: usize) -> Dims {
    Dims {
        state,
        params,
        ..Dims::default()
    }
}

#[test]
fn powi_is_bitwise_f64_powi() {
    let mut x = 0.734_f64;
    for n in (-40..=40).chain([i32::MAX, i32::MIN, 1 << 20, -(1 << 20) - 3]) {
        for _ in 0..8 {
            x = (x * 3.7 + 0.123).fract() * 2.5 - 0.6;
            assert_eq!(powi(x, n).to_bits(), x.powi(n).to_bits(), "{x}^{n}");
        }
    }
    assert_eq!(powi(f64::NAN, 0), 1.0);
}

#[test]
fn sums_put_positive_terms_first_and_products_divide() {
    // x0 − 2·x1 + x2·x3⁻² ⇒ x0 + x2 / x3² − 2·x1 as the emitter writes it
    let mut g = Graph::new();
    let [x0, x1, x2, x3] = [0, 1, 2, 3].map(|i| g.input(Input::State(i)));
    let m2 = g.num(-2.0);
    let t1 = g.mul(&[m2, x1]);
    let inv = g.pow(x3, Rational::int(-2));
    let t2 = g.mul(&[x2, inv]);
    let s = g.add(&[x0, t1, t2]);
    let tape = Tape::from_graph(&g, &[s], dims(4, 0)).unwrap();
    let ops: Vec<Op> = tape.body.clone();
    assert!(ops.iter().any(|op| matches!(op, Op::Div(..))), "{tape}");
    assert!(ops.iter().any(|op| matches!(op, Op::Sub(..))), "{tape}");
    assert!(!ops.iter().any(|op| matches!(op, Op::Neg(..))), "{tape}");
    let x = [0.3, 0.7, 1.9, 1.3];
    let expect = x[0] + x[2] / x[3].powi(2) - 2.0 * x[1];
    let got = tape.eval::<f64>(&[], &x, &[], &[]).unwrap()[0];
    assert_eq!(got.to_bits(), expect.to_bits());
}

#[test]
fn parameter_only_work_is_hoisted_and_constants_pooled() {
    // −mu·x/r³ with r = √(x² + y²): the coefficient −mu goes to the prelude
    let mut g = Graph::new();
    let (x, y, mu) = (
        g.input(Input::State(0)),
        g.input(Input::State(1)),
        g.input(Input::Param(0)),
    );
    let x2 = g.pow(x, Rational::int(2));
    let y2 = g.pow(y, Rational::int(2));
    let s = g.add(&[x2, y2]);
    let r3 = g.pow(s, Rational::new(-3, 2));
    let m = g.num(-1.0);
    let two = g.num(2.0);
    let mu2 = g.mul(&[two, mu]);
    let a = g.mul(&[m, mu, x, r3]);
    let b = g.mul(&[m, mu, y, r3]);
    let c = g.add(&[mu2, x]);
    let tape = Tape::from_graph(&g, &[a, b, c], dims(2, 1)).unwrap();
    assert!(!tape.body.iter().any(|op| matches!(op, Op::Param(_))));
    assert!(
        tape.prelude.iter().any(|op| matches!(op, Op::Mul(..))),
        "{tape}"
    );
    let consts = |ops: &[Op]| {
        let mut c: Vec<u64> = ops
            .iter()
            .filter_map(|op| match op {
                Op::Const(c) => Some(c.to_bits()),
                _ => None,
            })
            .collect();
        let n = c.len();
        c.dedup();
        (n, c.len())
    };
    let (n, distinct) = consts(&tape.body);
    assert_eq!(n, distinct);
    let (xv, yv, muv) = (0.8_f64, -1.1_f64, 1.3_f64);
    let out = tape.eval::<f64>(&[muv], &[xv, yv], &[], &[]).unwrap();
    let r3v = (xv * xv + yv * yv).sqrt().powi(3);
    assert!((out[0] - (-muv * xv / r3v)).abs() < 1e-15);
    assert_eq!(out[2].to_bits(), (2.0 * muv + xv).to_bits());
}

#[test]
fn bad_inputs_are_errors() {
    let mut g = Graph::new();
    let x = g.input(Input::State(3));
    let s = g.input(Input::Symbol(0));
    assert!(matches!(
        Tape::from_graph(&g, &[x], dims(2, 0)),
        Err(TapeError::InputOutOfRange { kind: "state", .. })
    ));
    assert_eq!(
        Tape::from_graph(&g, &[s], dims(4, 0)),
        Err(TapeError::Symbol(0))
    );
    let tape = Tape::from_graph(&g, &[x], dims(4, 0)).unwrap();
    assert!(matches!(
        tape.eval::<f64>(&[], &[1.0], &[], &[]),
        Err(TapeError::WrongLength { kind: "state", .. })
    ));
    let mut broken = tape.clone();
    broken.body.push(Op::Add(Reg(0), Reg(5)));
    assert!(matches!(broken.validate(), Err(TapeError::Malformed(_))));
    let mut broken = tape;
    broken.body.push(Op::Param(0));
    assert!(matches!(broken.validate(), Err(TapeError::Malformed(_))));
}

/// Every function of every model in `models/`: the tape against the DAG, to rounding.
#[test]
fn model_tapes_agree_with_the_dag() {
    let paths = lasalle_testkit::model_files();
    for path in paths {
        let model = crate::load_model(&path).unwrap();
        let derived = crate::derive::derive(model);
        crate::check::check(&derived).unwrap();
        let tapes = ModelTapes::new(&derived).unwrap();
        let (model, d) = (&derived.model, &derived.derivatives);
        let params = model.default_params();
        let n = model.dim();
        let state: Vec<f64> = (0..n).map(|i| 0.4 + 0.37 * i as f64).collect();
        let target: Vec<f64> = (0..model.invariant_dim()).map(|i| 0.1 * i as f64).collect();
        let gains: Vec<f64> = model.gains.iter().map(|k| k.default).collect();
        let dag = |ids: &[Id]| {
            ids.iter()
                .map(|&id| {
                    model.graph.eval_with_scale(id, &mut |i| match i {
                        Input::State(k) => state[k as usize],
                        Input::Param(k) => params[k as usize],
                        Input::Target(k) => target[k as usize],
                        Input::Gain(k) => gains[k as usize],
                        Input::Symbol(_) => f64::NAN,
                    })
                })
                .collect::<Vec<_>>()
        };
        let jac: Vec<Id> = d.jacobian.iter().flatten().copied().collect();
        let checks = [
            (&tapes.field, model.field.clone()),
            (&tapes.jacobian, jac),
            (&tapes.lyapunov, vec![model.lyapunov]),
            (&tapes.feedback, d.feedback.clone()),
        ];
        for (tape, ids) in checks {
            let (t, k) = (&target[..tape.dims.targets], &gains[..tape.dims.gains]);
            let got = tape.eval(&params, &state, t, k).unwrap();
            for ((v, scale), g) in dag(&ids).into_iter().zip(got) {
                assert!(
                    (v - g).abs() <= 1e-13 * scale.max(1e-300),
                    "{}: {v} vs {g} (scale {scale})",
                    path.display()
                );
            }
        }
    }
}

/// Sizes of the X − ∇V tapes of the models (printed with `--nocapture`), and a bound that
/// catches a lowering that stops sharing work.
#[test]
fn feedback_tapes_are_small() {
    let paths = lasalle_testkit::model_files();
    for path in paths {
        let model = crate::load_model(&path).unwrap();
        let derived = crate::derive::derive(model);
        crate::check::check(&derived).unwrap();
        let tapes = ModelTapes::new(&derived).unwrap();
        let (model, d) = (&derived.model, &derived.derivatives);
        let t = &tapes.feedback;
        let emitted = model.graph.clone().op_count(&d.feedback).dag;
        println!(
            "{}: X − ∇V body {} instructions ({} operations), prelude {}, hoisted {}; DAG ops {emitted}",
            path.file_name().unwrap().to_string_lossy(),
            t.body.len(),
            t.body_ops(),
            t.prelude.len(),
            t.hoisted.len()
        );
        assert!(t.body_ops() as u64 <= 2 * emitted + 8);
    }
}

#[test]
fn divisions_by_parameters_move_to_the_prelude() {
    // x0·x1·(p1 − p2)/p0 + x2/p0: the body multiplies by prepared values and divides by nothing
    let mut g = Graph::new();
    let [x0, x1, x2] = [0, 1, 2].map(|i| g.input(Input::State(i)));
    let [p0, p1, p2] = [0, 1, 2].map(|i| g.input(Input::Param(i)));
    let d = g.sub(p1, p2);
    let a = g.mul(&[x0, x1, d]);
    let a = g.div(a, p0);
    let b = g.div(x2, p0);
    let s = g.add(&[a, b]);
    let tape = Tape::from_graph(&g, &[s], dims(3, 3)).unwrap();
    assert!(
        !tape.body.iter().any(|op| matches!(op, Op::Div(..))),
        "{tape}"
    );
    assert!(
        tape.prelude.iter().any(|op| matches!(op, Op::Div(..))),
        "{tape}"
    );
    let (x, p) = ([0.3, -0.7, 1.9], [3.0, 2.0, 1.0]);
    let got = tape.eval(&p, &x, &[], &[]).unwrap()[0];
    let want = x[0] * x[1] * (p[1] - p[2]) / p[0] + x[2] / p[0];
    assert!(
        (got - want).abs() <= 4.0 * f64::EPSILON * want.abs(),
        "{got} vs {want}"
    );
}

#[test]
fn one_square_root_and_one_division_per_radius() {
    // μ·x/r³ + x/r with r = √(x² + y²): one Sqrt and one Div in the body
    let mut g = Graph::new();
    let [x, y] = [0, 1].map(|i| g.input(Input::State(i)));
    let mu = g.input(Input::Param(0));
    let (x2, y2) = (g.mul(&[x, x]), g.mul(&[y, y]));
    let s = g.add(&[x2, y2]);
    let r3 = g.pow(s, Rational::new(-3, 2));
    let r1 = g.pow(s, Rational::new(-1, 2));
    let a = g.mul(&[mu, x, r3]);
    let b = g.mul(&[x, r1]);
    let f = g.add(&[a, b]);
    let tape = Tape::from_graph(&g, &[f], dims(2, 1)).unwrap();
    let count = |p: fn(&Op) -> bool| tape.body.iter().filter(|op| p(op)).count();
    assert_eq!(count(|op| matches!(op, Op::Sqrt(_))), 1, "{tape}");
    assert_eq!(count(|op| matches!(op, Op::Div(..))), 1, "{tape}");
    let (xv, yv, m) = (0.6_f64, -0.8_f64, 1.5);
    let r = (xv * xv + yv * yv).sqrt();
    let want = m * xv / r.powi(3) + xv / r;
    let got = tape.eval(&[m], &[xv, yv], &[], &[]).unwrap()[0];
    assert!(
        (got - want).abs() <= 8.0 * f64::EPSILON * want.abs(),
        "{got} vs {want}"
    );
}
