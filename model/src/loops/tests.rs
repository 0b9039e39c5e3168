use super::*;
use crate::tape::Tape;

const NBODY: &str = include_str!("../../../models/nbody.lsl");
const FPUT: &str = include_str!("../../../models/fput.lsl");

fn sized(text: &str, default: &str, n: usize) -> String {
    assert!(text.contains(default));
    text.replace(default, &format!("param n = {n};"))
}

/// Deterministic pseudo-random numbers in [-1, 1).
fn numbers(seed: u64, len: usize) -> Vec<f64> {
    let mut rng = lasalle_testkit::Rng::new(seed);
    (0..len).map(|_| rng.uniform(-1.0, 1.0)).collect()
}

/// The loop form's field and invariants against the unrolled model's tapes.
fn agrees(text: &str, states: usize) -> LoopModel {
    let lm = LoopModel::from_source("m.lsl", text, Families::Loops).expect("loop form");
    assert!(!lm.families().is_empty(), "some family is a loop");
    let tapes = lm.tapes().expect("loop tapes");
    let model = lm.unrolled().expect("unrolled");
    let dims = Dims {
        state: model.dim(),
        params: model.param_slots(),
        targets: 0,
        gains: 0,
    };
    let field = Tape::from_graph(&model.graph, &model.field, dims).unwrap();
    let inv = Tape::from_graph(&model.graph, &model.invariant_ids(), dims).unwrap();
    let params = model.default_params();
    assert_eq!(params, lm.default_params());
    for s in 0..states {
        // Positions spread out so that no two bodies are close.
        let x: Vec<f64> = numbers(s as u64, model.dim())
            .iter()
            .enumerate()
            .map(|(i, v)| v + (i / 3) as f64 * 0.37)
            .collect();
        for (loops, plain) in [(&tapes.field, &field), (&tapes.invariants, &inv)] {
            let a = loops.eval(&params, &x).unwrap();
            let b = plain.eval(&params, &x, &[], &[]).unwrap();
            assert_eq!(a.len(), b.len());
            let scale = b.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            for (i, (u, v)) in a.iter().zip(&b).enumerate() {
                assert!(
                    (u - v).abs() <= 1e-13 * scale,
                    "output {i}: loops {u}, unrolled {v}"
                );
            }
        }
    }
    lm
}

#[test]
fn nbody_loops_agree_with_unrolled() {
    for n in [3, 7, 12] {
        let lm = agrees(&sized(NBODY, "param n = 5;", n), 4);
        // kinetic, pair, momentum, angular momentum
        assert_eq!(lm.families().len(), 4, "n = {n}");
        let pairs = lm.families().iter().map(|f| f.count).max().unwrap();
        assert_eq!(pairs, n * (n - 1) / 2);
    }
}

#[test]
fn fput_loops_agree_with_unrolled() {
    for n in [5, 33] {
        let lm = agrees(&sized(FPUT, "param n = 16;", n), 4);
        assert_eq!(lm.families().len(), 2, "n = {n}");
    }
}

#[test]
fn loop_code_size_is_independent_of_n() {
    let size = |n| {
        let lm = LoopModel::from_source("m.lsl", &sized(NBODY, "param n = 5;", n), Families::Loops)
            .unwrap();
        let t = lm.tapes().unwrap();
        t.field
            .regions
            .iter()
            .map(|r| r.tape.body.len())
            .sum::<usize>()
    };
    assert_eq!(size(8), size(40));
}

/// The field of four bodies against Newton's law written out by hand.
#[test]
fn nbody_field_is_newtons() {
    let n = 4;
    let lm =
        LoopModel::from_source("m.lsl", &sized(NBODY, "param n = 5;", n), Families::Loops).unwrap();
    let t = lm.tapes().unwrap();
    let params = lm.default_params();
    let m: Vec<f64> = (0..n).map(|i| 1.0 / (i as f64 + 1.0)).collect();
    let x: Vec<f64> = numbers(9, 6 * n)
        .iter()
        .enumerate()
        .map(|(i, v)| v + (i / 3) as f64)
        .collect();
    let (q, p) = x.split_at(3 * n);
    let f = t.field.eval(&params, &x).unwrap();
    for i in 0..n {
        for c in 0..3 {
            let qdot = p[3 * i + c] / m[i];
            let mut pdot = 0.0;
            for j in (0..n).filter(|&j| j != i) {
                let d: Vec<f64> = (0..3).map(|k| q[3 * j + k] - q[3 * i + k]).collect();
                let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                pdot += m[i] * m[j] * d[c] / (r * r * r);
            }
            assert!((f[3 * i + c] - qdot).abs() <= 1e-14 * qdot.abs().max(1.0));
            let fp = f[3 * n + 3 * i + c];
            assert!(
                (fp - pdot).abs() <= 1e-13 * pdot.abs().max(1.0),
                "{fp} vs {pdot}"
            );
        }
    }
}

#[test]
fn auto_keeps_small_families_unrolled() {
    let lm =
        LoopModel::from_source("m.lsl", &sized(NBODY, "param n = 5;", 5), Families::Auto).unwrap();
    assert!(lm.families().is_empty());
    let lm = LoopModel::from_source(
        "m.lsl",
        &sized(NBODY, "param n = 5;", 5),
        Families::Unrolled,
    )
    .unwrap();
    assert!(lm.families().is_empty());
}

#[test]
fn an_index_used_as_a_number_is_unrolled() {
    let text = "model M {\n param n = 4;\n state q: scalar[n], p: scalar[n];\n \
                hamiltonian H = sum(i in 0..n: p[i]^2 / 2 + (i + 1) * q[i]^2 / 2);\n \
                structure canonical(q, p);\n}\n";
    let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
    assert!(lm.families().is_empty());
    let t = lm.tapes().unwrap();
    // ṗ₂ = −3 q₂
    let mut x = vec![0.0; 8];
    x[2] = 0.5;
    assert_eq!(t.field.eval(&[], &x).unwrap()[6], -1.5);
}

#[test]
fn a_nonlinear_use_is_refused_with_its_place() {
    let text = "model M {\n param n = 4;\n state q: scalar[n], p: scalar[n];\n \
                hamiltonian H = sum(i in 0..n: p[i]^2 / 2 + q[i]^2 / 2);\n \
                structure canonical(q, p);\n \
                integral S = sum(i in 0..n: q[i] * p[i])^2;\n}\n";
    let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
    let e = lm.tapes().unwrap_err().to_string();
    assert!(
        e.contains("constant coefficient") && e.contains("m.lsl:6"),
        "{e}"
    );
}

fn verdicts(text: &str) -> Vec<(String, Verdict)> {
    let lm = LoopModel::from_source("m.lsl", text, Families::Loops).unwrap();
    lm.check()
        .unwrap()
        .into_iter()
        .map(|c| (c.name, c.verdict))
        .collect()
}

use crate::check::Verdict;

#[test]
fn nbody_integrals_are_proved_on_the_pair_term() {
    for n in [4, 30] {
        let v = verdicts(&sized(NBODY, "param n = 5;", n));
        let names: Vec<&str> = v.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["H", "P", "L"]);
        for (name, verdict) in &v {
            assert_eq!(*verdict, Verdict::Proved, "{name} at n = {n}");
        }
    }
}

#[test]
fn fput_energy_is_proved_by_the_structure() {
    let v = verdicts(&sized(FPUT, "param n = 16;", 20));
    assert_eq!(v, [("H".to_string(), Verdict::Proved)]);
}

/// The energy written again as an integral is a pair family the argument does not cover: it
/// is sampled, and found conserved.
#[test]
fn an_integral_the_argument_does_not_cover_is_sampled() {
    let text = sized(NBODY, "param n = 5;", 6).replace(
        "integral P =",
        "integral E = sum(i in 0..n: dot(p[i], p[i]) / (2 * m[i])) \
         - sum(i in 0..n, j in i+1..n: G * m[i] * m[j] / norm(q[i] - q[j]));\n    integral P =",
    );
    let v = verdicts(&text);
    assert_eq!(v[0], ("H".to_string(), Verdict::Proved));
    match &v[1] {
        (
            name,
            Verdict::Sampled {
                samples,
                worst_relative,
            },
        ) => {
            assert_eq!(name, "E");
            assert!(
                *samples > 100 && *worst_relative < 1e-12,
                "{samples} {worst_relative}"
            );
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(v[2].1, Verdict::Proved);
}

/// The walls push the chain: its momentum is not conserved, and the check says so.
#[test]
fn a_momentum_the_walls_break_is_an_error() {
    let text = sized(FPUT, "param n = 16;", 10).replace(
        "structure canonical(q, p);",
        "structure canonical(q, p);\n    integral P = sum(i in 0..n: p[i]);",
    );
    let lm = LoopModel::from_source("m.lsl", &text, Families::Loops).unwrap();
    let e = lm.check().unwrap_err().to_string();
    assert!(e.contains("integral `P` is not conserved"), "{e}");
}

/// A pair term that is not translation invariant: momentum is not conserved, the argument
/// must not prove it, and sampling finds it.
#[test]
fn a_pair_term_that_breaks_momentum_is_not_proved() {
    let text = sized(NBODY, "param n = 5;", 5)
        .replace("norm(q[i] - q[j])", "norm(q[i] - 2 * q[j])")
        .replace(
            "    integral L = sum(i in 0..n: cross(q[i], p[i]));     // angular momentum\n",
            "",
        );
    let lm = LoopModel::from_source("m.lsl", &text, Families::Loops).unwrap();
    let e = lm.check().unwrap_err().to_string();
    assert!(
        e.contains("integral `P` (component 0) is not conserved"),
        "{e}"
    );
}

/// A full double sum with a condition, halved: the same field as the triangular one.
#[test]
fn a_condition_selects_the_tuples() {
    let text = sized(NBODY, "param n = 5;", 7).replace(
        "sum(i in 0..n, j in i+1..n: G * m[i] * m[j] / norm(q[i] - q[j]))",
        "sum(i in 0..n, j in 0..n, i != j: G * m[i] * m[j] / norm(q[i] - q[j])) / 2",
    );
    let lm = agrees(&text, 3);
    assert!(lm.families().iter().any(|f| f.count == 7 * 6));
}

/// Periodic neighbours through `%`, and a sum in an equation (a reduction into one output).
#[test]
fn periodic_neighbours_and_a_sum_in_an_equation() {
    let text = "model Ring {\n param n = 9;\n state q: scalar[n], p: scalar[n];\n \
                hamiltonian H = sum(i in 0..n: p[i]^2 / 2 + (q[(i + 1) % n] - q[i])^4 / 4);\n \
                structure canonical(q, p);\n integral P = sum(i in 0..n: p[i]);\n}\n";
    agrees(text, 3);
    let v = verdicts(text);
    assert_eq!(v[1], ("P".to_string(), Verdict::Proved));
    let text = "model Sink {\n param n = 6;\n state x: scalar[n], s: scalar;\n \
                for i in 0..n: d/dt x[i] = -x[i];\n d/dt s = 3 * sum(i in 0..n: x[i]^2);\n}\n";
    let lm = agrees(text, 3);
    assert_eq!(lm.families().len(), 1);
}

/// An index out of range inside a loop family is reported as when it is unrolled.
#[test]
fn an_index_out_of_range_is_located() {
    let text = "model M {\n param n = 5;\n state q: scalar[n], p: scalar[n];\n \
                hamiltonian H = sum(i in 0..n: p[i]^2 / 2 + q[i + 1]^2);\n \
                structure canonical(q, p);\n}\n";
    let loops = LoopModel::from_source("m.lsl", text, Families::Loops)
        .unwrap_err()
        .to_string();
    let Err(unrolled) = crate::lower_source("m.lsl", text) else {
        panic!("the unrolled model lowers");
    };
    let unrolled = unrolled.to_string();
    assert!(
        loops.contains("index 5 is out of range 0..5 (where i = 4)"),
        "{loops}"
    );
    assert_eq!(loops, unrolled);
}

/// The index structure kept for the back ends that write loops: the ranges and conditions of
/// the head and each slot's subscript reproduce the tuples and the gathered indices, and a
/// subscript outside the integer expressions (a division) keeps none.
#[test]
fn the_index_structure_reproduces_the_tables() {
    use index::{tuples, Compare, Ix, LoopClause};
    let text = "model Ring {
        param n = 6;
        state q: vec2[n], p: vec2[n];
        hamiltonian H = sum(i in 0..n: dot(p[i], p[i]) / 2)
            + sum(i in 0..n, j in 0..n, i != j: dot(q[i], q[(j + 1) % n]) / 10)
            + sum(i in 0..n: q[(2 * i) / 2][0]^4);
        structure canonical(q, p);
    }";
    let lm = LoopModel::from_source("ring.lsl", text, Families::Loops).unwrap();
    let fams = lm.families();
    assert_eq!(fams.len(), 3);
    for fam in &fams[..2] {
        let clauses = fam.clauses.as_ref().expect("ranges and conditions");
        let all = tuples(clauses, usize::MAX).unwrap();
        assert_eq!(all.len(), fam.count);
        for slot in &fam.slots {
            let index = slot.index.as_ref().expect("a subscript of the indices");
            for (t, vars) in all.iter().enumerate() {
                assert_eq!(index.eval(vars), Some(i64::from(slot.column[t])));
            }
        }
    }
    // i in 0..6, j in 0..6, i != j: 30 tuples
    let pair = fams[1].clauses.as_ref().unwrap();
    assert_eq!(fams[1].count, 30);
    assert_eq!(
        pair[2],
        LoopClause::Cond {
            lhs: Ix::Var(0),
            op: Compare::Ne,
            rhs: Ix::Var(1)
        }
    );
    // q[(j + 1) % n], component 1: 2·((j + 1) mod 6) + 1
    let q_next = fams[1]
        .slots
        .iter()
        .filter_map(|s| s.index.as_ref())
        .find(|i| i.base == 1 && i.member.reads(1))
        .unwrap();
    assert_eq!(q_next.stride, 2);
    assert_eq!(q_next.eval(&[0, 5]), Some(1));
    // the division has no index expression: the tables stand alone
    assert!(fams[2].slots.iter().all(|s| s.index.is_none()));
    // and the loops still compute the field the unrolled model does
    agrees(text, 3);
}

/// The loop form of the variational equations and of the indicators against
/// [`Extension::apply`] of the unrolled model: the same declarations, the same field and the
/// same peak event value at random extended states.
fn extension_agrees(text: &str, ext: crate::variational::Extension, states: usize) {
    use crate::variational::Extension;
    let lm = LoopModel::from_source("m.lsl", text, Families::Loops).expect("loop form");
    assert!(!lm.families().is_empty(), "some family is a loop");
    let le = lm.extend(ext).expect("loop extension");
    let field = le.field().expect("extended field");
    assert_eq!(
        matches!(field, ExtendedField::Loop(_)),
        ext != Extension::Indicators
    );
    let model = le.unrolled().expect("unrolled extension");
    let decl = le.declarations();
    let names = |m: &crate::Model| -> Vec<(String, usize, usize)> {
        m.state
            .iter()
            .map(|s| (s.name.clone(), s.offset, s.shape.len()))
            .collect()
    };
    assert_eq!(names(decl), names(&model));
    let events =
        |m: &crate::Model| -> Vec<String> { m.events.iter().map(|e| e.name.clone()).collect() };
    assert_eq!(events(decl), events(&model));
    let (n, e) = (lm.dim(), model.dim());
    assert_eq!(e, ext.extended_dim(n));
    let dims = Dims {
        state: e,
        params: model.param_slots(),
        targets: 0,
        gains: 0,
    };
    let plain = Tape::from_graph(&model.graph, &model.field, dims).unwrap();
    let inv = Tape::from_graph(&model.graph, &model.invariant_ids(), dims).unwrap();
    let loop_inv = le.invariants().unwrap();
    let peak = le.peak().unwrap();
    assert_eq!(peak.is_some(), ext == Extension::Indicators);
    let params = model.default_params();
    for s in 0..states {
        let mut x: Vec<f64> = numbers(100 + s as u64, e)
            .iter()
            .enumerate()
            .map(|(i, v)| if i < n { v + (i / 3) as f64 * 0.37 } else { *v })
            .collect();
        if ext == Extension::Indicators {
            let clock = crate::variational::IndicatorSlots { n }.clock();
            x[clock] = x[clock].abs() + 0.5;
        }
        let a = field.eval(&params, &x).unwrap();
        let b = plain.eval(&params, &x, &[], &[]).unwrap();
        assert_eq!(a.len(), b.len());
        let scale = b.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for (i, (u, v)) in a.iter().zip(&b).enumerate() {
            assert!(
                (u - v).abs() <= 2e-14 * scale,
                "{ext:?} output {i}: loops {u}, unrolled {v}"
            );
        }
        // the tangent rows are not trivially equal
        assert!(b[n..2 * n].iter().any(|v| v.abs() > 1e-3), "{ext:?}");
        let (u, v) = (
            loop_inv.eval(&params, &x).unwrap(),
            inv.eval(&params, &x, &[], &[]).unwrap(),
        );
        for (u, v) in u.iter().zip(&v) {
            assert!((u - v).abs() <= 1e-13 * v.abs().max(1.0));
        }
        if let Some(peak) = &peak {
            let event = model.events.last().unwrap().value;
            let lambda = model.graph.eval_f64(&[event], &mut |i| match i {
                Input::State(k) => x[k as usize],
                Input::Param(k) => params[k as usize],
                _ => 0.0,
            })[0];
            let l = peak.eval_lyapunov(&params, &x, &[], &[0.25]).unwrap();
            assert!(
                (l - lambda).abs() <= 1e-14 * scale,
                "λ: loops {l}, unrolled {lambda}"
            );
            assert_eq!(l, a[2 * n], "λ is ℓ's rate");
        }
    }
}

#[test]
fn nbody_extensions_agree_with_unrolled() {
    use crate::variational::Extension;
    for n in [4, 5] {
        let text = sized(NBODY, "param n = 5;", n);
        extension_agrees(&text, Extension::Indicators, 3);
        extension_agrees(&text, Extension::Variational { tangents: 3 }, 3);
    }
}

#[test]
fn fput_extensions_agree_with_unrolled() {
    use crate::variational::Extension;
    let text = sized(FPUT, "param n = 16;", 9);
    extension_agrees(&text, Extension::Indicators, 3);
    extension_agrees(&text, Extension::Variational { tangents: 18 }, 2);
}

#[test]
fn extension_region_code_is_independent_of_n() {
    use crate::variational::Extension;
    let regions = |t: &LoopTape| t.regions.iter().map(|r| r.tape.body.len()).sum::<usize>();
    let size = |n| {
        let lm = LoopModel::from_source("m.lsl", &sized(NBODY, "param n = 5;", n), Families::Loops)
            .unwrap();
        let ind = match lm.extend(Extension::Indicators).unwrap().field().unwrap() {
            ExtendedField::Staged(s) => (regions(&s.sums), regions(&s.feedback)),
            ExtendedField::Loop(_) => panic!("the indicators are staged"),
        };
        let var = match lm
            .extend(Extension::Variational { tangents: 2 })
            .unwrap()
            .field()
            .unwrap()
        {
            ExtendedField::Loop(t) => regions(&t),
            ExtendedField::Staged(_) => panic!("the variational equations are one loop tape"),
        };
        (ind, var)
    };
    let (small, large) = (size(6), size(30));
    assert_eq!(small, large);
    assert!(small.0 .0 > 0 && small.1 > small.0 .1);
}
