//! One test suite, run on every back end: every function of every model in `models/` and of
//! random models using every operator and function of the DSL, at random states.
//!
//! Agreement required:
//! - back end vs `Tape::eval::<f64>`: bitwise (NaN = NaN);
//! - k lanes (k = 1, 2, 3, 4, 5, 7, 8: every path of the JIT's four-, two- and one-lane loops)
//!   vs one state: bitwise;
//! - tape vs the DAG (`Graph::eval_with_scale`, no emission rewrites): the tape reorders sums
//!   and products, so |tape − DAG| ≤ 1e-12 · S, where S bounds the magnitude of the terms whose
//!   rounding errors accumulate (Σ|terms| through sums); for well-conditioned values this is a
//!   few ulps.

use lasalle_exec::Backend;
use lasalle_model::ir::{Id, Input};
use lasalle_model::tape::{ModelTapes, Tape};
use lasalle_model::Model;
use lasalle_model::{derive, Derived};
use lasalle_testkit::{assert_same, same, Rng};

/// ±[0.5, 1.5): away from 0, so |x| of a vec3 is ≥ 0.86 (Kepler's r).
fn component(rng: &mut Rng) -> f64 {
    let m = 0.5 + rng.unit();
    m * rng.sign()
}

/// A model with its derivatives and tapes, and the DAG roots of each tape.
struct Case {
    name: String,
    model: Model,
    tapes: ModelTapes,
    roots: Vec<(&'static str, Vec<Id>)>,
}

impl Case {
    fn new(name: &str, model: Model, checked: bool) -> Case {
        let derived = derive(model);
        if checked {
            lasalle_model::check(&derived).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        let tapes = ModelTapes::new(&derived).unwrap();
        let Derived {
            model,
            derivatives: d,
        } = derived;
        let mut roots = vec![
            ("field", model.field.clone()),
            ("invariants", model.invariant_ids()),
            ("jacobian", d.jacobian.iter().flatten().copied().collect()),
            ("lyapunov", vec![model.lyapunov]),
            ("lyapunov_gradient", d.lyapunov_gradient.clone()),
            ("feedback", d.feedback.clone()),
        ];
        if let Some(h) = &model.hamiltonian {
            roots.push(("hamiltonian", vec![h.h]));
        }
        if let Some(is_q) = &d.partition {
            for (name, q) in [("field_q", true), ("field_p", false)] {
                let ids = model
                    .field
                    .iter()
                    .zip(is_q)
                    .filter(|(_, &x)| x == q)
                    .map(|(&id, _)| id)
                    .collect();
                roots.push((name, ids));
            }
        }
        Case {
            name: name.to_string(),
            model,
            tapes,
            roots,
        }
    }

    /// Checks every tape of the case on `backend` at `samples` random states.
    fn run(&self, backend: Backend, samples: usize, rng: &mut Rng) {
        let model = &self.model;
        let (n, m) = (model.dim(), model.invariant_dim());
        let params = model.default_params();
        let gains: Vec<f64> = model.gains.iter().map(|k| k.default).collect();
        let tapes = self.tapes.all();
        assert_eq!(tapes.len(), self.roots.len());
        let kernels: Vec<_> = tapes
            .iter()
            .map(|(name, t)| {
                backend
                    .compile(t)
                    .unwrap_or_else(|e| panic!("{} {name}: {e}", self.name))
            })
            .collect();
        let hoisted: Vec<Vec<f64>> = kernels.iter().map(|k| k.hoist(&params).unwrap()).collect();
        let states: Vec<Vec<f64>> = (0..samples)
            .map(|_| (0..n).map(|_| component(rng)).collect())
            .collect();
        let x0: Vec<f64> = (0..n).map(|_| component(rng)).collect();
        // The target f(x₀).
        let target = self.tapes.invariants.eval(&params, &x0, &[], &[]).unwrap();
        assert_eq!(target.len(), m);
        for (t, (((name, tape), kernel), hoisted)) in
            tapes.iter().zip(&kernels).zip(&hoisted).enumerate()
        {
            let (root_name, ids) = &self.roots[t];
            assert_eq!(name, root_name);
            let outs = tape.outputs.len();
            assert_eq!(outs, ids.len(), "{} {name}", self.name);
            // Only V, ∇V and X − ∇V take targets and gains.
            let (target, gains) = (&target[..tape.dims.targets], &gains[..tape.dims.gains]);
            let mut results = Vec::with_capacity(samples);
            for x in &states {
                let at =
                    |what: &str| format!("{} {name} ({backend:?}) {what} at x = {x:?}", self.name);
                let reference = tape.eval(&params, x, target, gains).unwrap();
                let mut out = vec![0.0; outs];
                kernel.eval(hoisted, x, target, gains, &mut out).unwrap();
                for (j, (&a, &b)) in out.iter().zip(&reference).enumerate() {
                    assert!(
                        same(a, b),
                        "{}: output {j}: {a:e} vs tape {b:e}",
                        at("bitwise")
                    );
                }
                for (j, &id) in ids.iter().enumerate() {
                    let (v, scale) = model.graph.eval_with_scale(id, &mut |i| match i {
                        Input::State(k) => x[k as usize],
                        Input::Param(k) => params[k as usize],
                        Input::Target(k) => target[k as usize],
                        Input::Gain(k) => gains[k as usize],
                        Input::Symbol(_) => f64::NAN,
                    });
                    let a = out[j];
                    let ok = same(a, v)
                        || (a - v).abs() <= 1e-12 * scale.abs()
                        || (!v.is_finite() && !a.is_finite())
                        || !scale.is_finite();
                    assert!(
                        ok,
                        "{}: output {j}: {a:e} vs DAG {v:e} (scale {scale:e})",
                        at("DAG")
                    );
                }
                results.push(out);
            }
            // Lanes: k states at once, bitwise equal to one at a time.
            for k in [1usize, 2, 3, 4, 5, 7, 8] {
                for chunk in results.chunks(k).zip(states.chunks(k)).take(6) {
                    let (expect, xs) = chunk;
                    let k = xs.len();
                    let mut soa = vec![0.0; n * k];
                    for (l, x) in xs.iter().enumerate() {
                        for i in 0..n {
                            soa[i * k + l] = x[i];
                        }
                    }
                    let mut out = vec![f64::NAN; outs * k];
                    kernel
                        .eval_lanes(k, hoisted, &soa, target, gains, &mut out)
                        .unwrap();
                    for (l, e) in expect.iter().enumerate() {
                        for j in 0..outs {
                            assert!(
                                same(out[j * k + l], e[j]),
                                "{} {name} ({backend:?}) lanes k = {k}, lane {l}, output {j}: {:e} vs {:e}",
                                self.name,
                                out[j * k + l],
                                e[j]
                            );
                        }
                    }
                }
            }
        }
    }
}

fn model_cases() -> Vec<Case> {
    let paths = lasalle_testkit::model_files();
    paths
        .iter()
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            Case::new(&name, lasalle_model::load_model(p).unwrap(), true)
        })
        .collect()
}

/// Random model text using every operator and function of the DSL.
struct Gen {
    rng: Rng,
    /// Inside the `let` itself, which cannot refer to itself.
    in_let: bool,
}

impl Gen {
    /// A scalar expression of depth ≤ d.
    fn scalar(&mut self, d: u32) -> String {
        if d == 0 {
            return match self.rng.below(8) {
                0 => "y".into(),
                1 => format!("x[{}]", self.rng.below(3)),
                2 => "a".into(),
                3 => "b[1]".into(),
                4 if !self.in_let => "u".into(),
                4 => "y".into(),
                5 => "norm(x)".into(),
                6 => format!("{:.3}", 0.25 + 2.0 * self.rng.unit()),
                _ => "w".into(),
            };
        }
        let s = |g: &mut Gen| g.scalar(d - 1);
        // the parameter m of the elliptic functions: parameters and numbers only
        let m = ["0", "0.5", "1", "(a^2 / (1 + a^2))"][self.rng.below(4)];
        // K and F are infinite at m = 1 (beyond φ = π/2): a non-finite constant is refused
        let m_below_1 = if m == "1" { "0.99" } else { m };
        match self.rng.below(26) {
            0 | 1 => format!("({} + {})", s(self), s(self)),
            2 | 3 => format!("({} - {})", s(self), s(self)),
            4 | 5 => format!("({} * {})", s(self), s(self)),
            6 => format!("({} / (1.5 + sin({})))", s(self), s(self)),
            7 => format!("(-{})", s(self)),
            8 => format!("({})^{}", s(self), [2, 3, 4, 7][self.rng.below(4)]),
            9 => format!("(1 + ({})^2)^-{}", s(self), 1 + self.rng.below(3)),
            10 => format!(
                "(1 + ({})^2)^({})",
                s(self),
                ["1/2", "3/2", "-1/2", "-3/2", "5/2", "1/3", "2/3", "-4/3"][self.rng.below(8)]
            ),
            11 => format!("sqrt(1 + ({})^2)", s(self)),
            12 => format!("exp({} / 4)", s(self)),
            13 => format!("log(2 + sin({}))", s(self)),
            14 => format!("sin({})", s(self)),
            15 => format!("cos({})", s(self)),
            16 => format!("dot(x, {})", self.vector(d - 1)),
            17 => format!("norm({})", self.vector(d - 1)),
            18 => format!("{}[{}]", self.vector(d - 1), self.rng.below(3)),
            19 => format!("trace(hat(x) * hat({}))", self.vector(d - 1)),
            20 => format!("(a * {} + a * {})", s(self), s(self)),
            22 => format!(
                "{}({}, {m})",
                ["sn", "cn", "dn"][self.rng.below(3)],
                s(self)
            ),
            23 => {
                let quotients = ["ns", "nc", "nd", "sc", "sd", "cs", "cd", "ds", "dc"];
                format!("{}({}, {m})", quotients[self.rng.below(9)], s(self))
            }
            24 => format!("ellipf({}, {m_below_1})", s(self)),
            25 => format!("(ellipk({m_below_1}) * {})", s(self)),
            _ => format!("(x[0] * {} * y / x[1])", s(self)),
        }
    }

    /// A vec3 expression of depth ≤ d.
    fn vector(&mut self, d: u32) -> String {
        if d == 0 {
            return ["x", "b", "[y, a, 1]"][self.rng.below(3)].into();
        }
        match self.rng.below(8) {
            0 => format!("cross(x, {})", self.vector(d - 1)),
            1 => format!("({} * {})", self.scalar(d - 1), self.vector(d - 1)),
            2 => format!("({} + {})", self.vector(d - 1), self.vector(d - 1)),
            3 => format!("({} - {})", self.vector(d - 1), self.vector(d - 1)),
            4 => format!("(hat({}) * x)", self.vector(d - 1)),
            5 => format!("(transpose(M) * {})", self.vector(d - 1)),
            6 => format!("({} / norm(x))", self.vector(d - 1)),
            _ => format!(
                "[{}, {}, {}]",
                self.scalar(d - 1),
                self.scalar(d - 1),
                self.scalar(d - 1)
            ),
        }
    }

    fn model(&mut self, i: usize) -> String {
        let d = 3;
        self.in_let = true;
        let u = self.scalar(2);
        self.in_let = false;
        format!(
            "model Random{i} {{
    state x: vec3, y: scalar;
    param a = 1.25;
    param b = [0.5, -0.75, 2];
    param M = [[1, 0.5, 0], [0, 2, 0.25], [0.125, 0, 3]];
    param w = a * 2;
    let u = {u};
    d/dt x = {vx};
    d/dt y = {vy};
    integral F = {f} gain k1 = 2;
    constraint C = {c};
}}",
            vx = self.vector(d),
            vy = self.scalar(d),
            f = self.scalar(d),
            c = self.vector(2),
        )
    }
}

fn random_cases(count: usize) -> Vec<Case> {
    let mut g = Gen {
        rng: Rng::new(0x9e37_79b9_7f4a_7c15),
        in_let: false,
    };
    (0..count)
        .map(|i| {
            let text = g.model(i);
            let model = lasalle_model::lower_source(&format!("random{i}.lsl"), &text)
                .unwrap_or_else(|e| panic!("{e}\n{text}"));
            Case::new(&format!("random{i}"), model, false)
        })
        .collect()
}

fn suite(backend: Backend) {
    let mut rng = Rng::new(0x2545_f491_4f6c_dd1d);
    for case in model_cases() {
        case.run(backend, 200, &mut rng);
    }
    for case in random_cases(40) {
        case.run(backend, 25, &mut rng);
    }
}

#[test]
fn interpreter() {
    suite(Backend::Interpreter);
}

#[cfg(feature = "jit")]
#[test]
fn jit() {
    suite(Backend::Jit);
}

/// The pairing pass of the JIT's `eval` really pairs on the models whose x, y, z components
/// run through the same operations (so `jit` above checks paired code bitwise against the
/// tape, on every function of every model and of the random models).
#[cfg(feature = "jit")]
#[test]
fn jit_pairs_the_components() {
    for case in model_cases() {
        let kernel = lasalle_exec::jit::JitKernel::new(&case.tapes.feedback).unwrap();
        let (paired, len) = (kernel.paired_instructions(), case.tapes.feedback.body.len());
        assert!(paired <= len, "{}: {paired} of {len}", case.name);
        if ["kepler.lsl", "rigid_body.lsl", "coupled_oscillators.lsl"].contains(&&*case.name) {
            assert!(4 * paired >= len, "{}: {paired} of {len} paired", case.name);
        }
    }
}

/// Operand vectors of two parameter-only values (the coupled oscillators' ω/2 and a, b, c
/// coefficients) are loaded from the vector slots that the JIT's `hoist` appends to the
/// tape's hoisted values: they follow a change of the parameters, and a hoisted array made
/// by another kernel (without them) is refused.
#[cfg(feature = "jit")]
#[test]
fn jit_vector_slots_follow_the_parameters() {
    let case = model_cases()
        .into_iter()
        .find(|c| c.name == "coupled_oscillators.lsl")
        .unwrap();
    let tape = &case.tapes.feedback;
    let jit = Backend::Jit.compile(tape).unwrap();
    let params: Vec<f64> = case
        .model
        .default_params()
        .iter()
        .enumerate()
        .map(|(i, p)| p * (1.5 + 0.25 * i as f64))
        .collect();
    let (hoisted, tape_hoisted) = (jit.hoist(&params).unwrap(), tape.hoist(&params).unwrap());
    assert!(hoisted.len() > tape_hoisted.len(), "no vector slot");
    assert_same(
        &hoisted[..tape_hoisted.len()],
        &tape_hoisted,
        "hoisted values",
    );
    let d = jit.dims();
    let mut rng = Rng::new(7);
    let x: Vec<f64> = (0..d.state).map(|_| component(&mut rng)).collect();
    let (t, g) = (vec![0.25; d.targets], vec![1.5; d.gains]);
    let mut out = vec![0.0; jit.n_outputs()];
    jit.eval(&hoisted, &x, &t, &g, &mut out).unwrap();
    let reference = tape.eval(&params, &x, &t, &g).unwrap();
    assert!(out.iter().zip(&reference).all(|(&a, &b)| same(a, b)));
    assert!(jit.eval(&tape_hoisted, &x, &t, &g, &mut out).is_err());
}

#[test]
fn bad_arguments_are_errors_not_panics() {
    for &backend in Backend::available() {
        let case = &model_cases()[0];
        let kernel = backend.compile(&case.tapes.feedback).unwrap();
        let d = kernel.dims();
        let hoisted = kernel.hoist(&case.model.default_params()).unwrap();
        assert!(kernel.hoist(&[]).is_err() || d.params == 0);
        let (x, t, g) = (vec![0.5; d.state], vec![0.0; d.targets], vec![1.0; d.gains]);
        let mut out = vec![0.0; kernel.n_outputs()];
        assert!(kernel.eval(&hoisted, &x[1..], &t, &g, &mut out).is_err());
        assert!(kernel.eval(&hoisted, &x, &t, &g, &mut out[1..]).is_err());
        assert!(kernel
            .eval_lanes(2, &hoisted, &x, &t, &g, &mut out)
            .is_err());
        kernel.eval(&hoisted, &x, &t, &g, &mut out).unwrap();
        kernel
            .eval_lanes(0, &hoisted, &[], &t, &g, &mut [])
            .unwrap();
        let mut broken = Tape::clone(&case.tapes.feedback);
        broken.outputs.push(lasalle_exec::Reg(u32::MAX));
        assert!(backend.compile(&broken).is_err());
    }
}

/// The interpreter folds products and negations used once into sums and differences (`a·b ± c`,
/// `c − a·b`, `x − y` for `x + (−y)`, `−0 − x` for `−x`): every combination of a product, a
/// negation and a plain value on either side of `+` and `−`, at every sign of zero and at
/// values that cancel, bitwise as the tape (NaN = NaN); and the lanes as one state.
#[test]
fn folded_sums_keep_the_signs_of_zero() {
    use lasalle_exec::{Dims, Op, Reg};
    // x0, x1, x2, x3; then the forms of the operands: a product, a negation, a plain value
    let forms = |body: &mut Vec<Op>, k: u32| -> Reg {
        let (a, b) = (Reg(k % 4), Reg((k + 1) % 4));
        match k % 3 {
            0 => body.push(Op::Mul(a, b)),
            1 => body.push(Op::Neg(a)),
            _ => body.push(Op::Add(a, b)),
        }
        Reg(body.len() as u32 - 1)
    };
    let mut body: Vec<Op> = (0..4).map(Op::State).collect();
    let mut outputs = Vec::new();
    for i in 0..6 {
        for j in 0..6 {
            for sub in [false, true] {
                // each operand used once, so it is folded where the interpreter can
                let (x, y) = (forms(&mut body, i), forms(&mut body, j + 1));
                body.push(if sub { Op::Sub(x, y) } else { Op::Add(x, y) });
                outputs.push(Reg(body.len() as u32 - 1));
            }
        }
    }
    // −u − v: the negation of the minuend is computed on its own
    let (u, v) = (Reg(body.len() as u32), Reg(body.len() as u32 + 1));
    body.extend([Op::Neg(Reg(0)), Op::Neg(Reg(1)), Op::Sub(u, v)]);
    outputs.push(Reg(body.len() as u32 - 1));
    let tape = Tape {
        body,
        outputs,
        dims: Dims {
            state: 4,
            ..Dims::default()
        },
        ..Tape::default()
    };
    let kernel = Backend::Interpreter.compile(&tape).unwrap();
    let values = [0.0, -0.0, 1.0, -1.0, 2.0, f64::INFINITY, f64::NAN];
    let mut states = Vec::new();
    for &a in &values {
        for &b in &values {
            states.push(vec![a, b, -a, b]);
            states.push(vec![a, b, b, -0.0]);
        }
    }
    let outs = tape.outputs.len();
    for x in &states {
        let reference = tape.eval::<f64>(&[], x, &[], &[]).unwrap();
        let mut out = vec![0.0; outs];
        kernel.eval(&[], x, &[], &[], &mut out).unwrap();
        let mut lanes = vec![0.0; outs * 2];
        let soa: Vec<f64> = x.iter().flat_map(|&v| [v, v]).collect();
        kernel
            .eval_lanes(2, &[], &soa, &[], &[], &mut lanes)
            .unwrap();
        for j in 0..outs {
            assert!(
                same(out[j], reference[j]),
                "output {j} at {x:?}: {:e} vs tape {:e}",
                out[j],
                reference[j]
            );
            assert!(
                same(lanes[2 * j], reference[j]),
                "lanes output {j} at {x:?}"
            );
        }
    }
}
