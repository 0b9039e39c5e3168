//! Properties of the symbolic core on random expressions (deterministic seeds): lowering and
//! simplification preserve values, symbolic derivatives agree with finite differences, and
//! emission is deterministic. The expressions use every scalar function of the language,
//! the Jacobi elliptic functions, quotients and F included (their values from
//! `lasalle_elliptic`, m ∈ {0, 0.3, 0.81, 1}).

use std::collections::HashMap;

use lasalle_codegen::derive;
use lasalle_codegen::ir::diff;
use lasalle_codegen::ir::Input;
use lasalle_codegen::{generate_source, lower_source};
use lasalle_testkit::Rng;

/// A random expression in x and y with its value at (x, y), computed directly in f64 while
/// it is built (an evaluator independent of the generator). Domains are kept safe: logarithms
/// and roots take positive arguments, divisions positive denominators.
fn expr(r: &mut Rng, x: f64, y: f64, depth: u32) -> (String, f64) {
    if depth == 0 || r.below(5) == 0 {
        return match r.below(4) {
            0 => ("x".into(), x),
            1 => ("y".into(), y),
            _ => {
                let c = (r.below(7) as f64 - 3.0) / 2.0;
                (format!("({c})"), c)
            }
        };
    }
    let (a, va) = expr(r, x, y, depth - 1);
    let (b, vb) = expr(r, x, y, depth - 1);
    let pos = |s: &str, v: f64| (format!("(1 + ({s})^2)"), 1.0 + v * v);
    // elliptic functions: a parameter m from a few constants, both ends included
    let m = [0.0, 0.3, 0.81, 1.0][r.below(4)];
    let j = lasalle_elliptic::ellipj(va, m);
    match r.below(16) {
        0 => (format!("({a} + {b})"), va + vb),
        1 => (format!("({a} - {b})"), va - vb),
        2 => (format!("({a} * {b})"), va * vb),
        3 => {
            let (d, vd) = pos(&b, vb);
            (format!("({a} / {d})"), va / vd)
        }
        4 => {
            let n = r.below(5) as i32 - 2;
            // no 1/0: a constant zero raised to a negative power is refused by the generator
            // (a non-finite constant), and the reference would go on with ∞
            let n = if va == 0.0 { n.abs() } else { n };
            let v = if n < 0 { 1.0 / va.powi(-n) } else { va.powi(n) };
            (format!("({a})^({n})"), v)
        }
        5 => {
            let (p, vp) = pos(&a, va);
            (format!("sqrt({p})"), vp.sqrt())
        }
        6 => {
            let (p, vp) = pos(&a, va);
            (format!("{p}^(3/2)"), vp.powf(1.5))
        }
        7 => {
            let (p, vp) = pos(&a, va);
            (format!("log({p})"), vp.ln())
        }
        8 => (format!("exp(({a}) / 4)"), (va / 4.0).exp()),
        9 => (format!("sin({a})"), va.sin()),
        10 => (format!("cos({a})"), va.cos()),
        11 => (format!("sn({a}, {m})"), j.sn),
        12 => (format!("cn({a}, {m})"), j.cn),
        13 => (format!("dn({a}, {m})"), j.dn),
        // the quotients whose denominator dn ≥ √(1 − m) stays away from 0 for m < 1
        14 => match r.below(3) {
            0 => (format!("nd({a}, {m})"), 1.0 / j.dn),
            1 => (format!("sd({a}, {m})"), j.sn / j.dn),
            _ => (format!("cd({a}, {m})"), j.cn / j.dn),
        },
        _ => {
            let m = m.min(0.9); // F(φ | 1) is infinite at φ = ±π/2
            let f = lasalle_elliptic::ellipf(va, m);
            (format!("ellipf({a}, {m})"), f)
        }
    }
}

fn model_text(e: &str) -> String {
    format!("model P {{ state x: scalar, y: scalar; d/dt x = {e}; d/dt y = 0; }}")
}

fn eval_at(m: &lasalle_codegen::Model, id: lasalle_codegen::ir::Id, x: f64, y: f64) -> f64 {
    m.graph.eval_f64(&[id], &mut |i| match i {
        Input::State(0) => x,
        Input::State(1) => y,
        _ => f64::NAN,
    })[0]
}

/// Lowering, folding and the canonical forms of the DAG keep the value of the expression.
#[test]
fn simplification_preserves_values() {
    let mut r = Rng::new(0x1234_5678_9abc_def1);
    let mut checked = 0;
    for _ in 0..400 {
        let (x, y) = (
            0.3 + r.below(100) as f64 / 70.0,
            -0.8 + r.below(100) as f64 / 60.0,
        );
        let (text, want) = expr(&mut r, x, y, 4);
        if !want.is_finite() || want.abs() > 1e8 {
            continue;
        }
        let m = match lower_source("p.lsl", &model_text(&text)) {
            Ok(m) => m,
            Err(e) => panic!("{text}: {e}"),
        };
        let (got, scale) = m.graph.eval_with_scale(m.field[0], &mut |i| match i {
            Input::State(0) => x,
            Input::State(1) => y,
            _ => f64::NAN,
        });
        assert!(
            (got - want).abs() <= 1e-12 * scale.max(want.abs()).max(1.0),
            "{text} at ({x}, {y}): {got} vs {want} (scale {scale})"
        );
        checked += 1;
    }
    assert!(checked > 300, "only {checked} expressions were checked");
}

/// ∂f/∂x by the symbolic forward mode agrees with central differences of f.
#[test]
fn derivatives_match_finite_differences() {
    let mut r = Rng::new(0xfeed_beef_cafe_f00d);
    let mut checked = 0;
    for _ in 0..300 {
        let (x, y) = (
            0.3 + r.below(100) as f64 / 70.0,
            -0.8 + r.below(100) as f64 / 60.0,
        );
        let (text, v) = expr(&mut r, x, y, 3);
        if !v.is_finite() || v.abs() > 1e6 {
            continue;
        }
        let mut m = lower_source("p.lsl", &model_text(&text)).unwrap();
        let f = m.field[0];
        let mut memo = HashMap::new();
        let df = diff(&mut m.graph, f, Input::State(0), &mut memo);
        let h = 1e-5;
        let fd = (eval_at(&m, f, x + h, y) - eval_at(&m, f, x - h, y)) / (2.0 * h);
        let sym = eval_at(&m, df, x, y);
        if !fd.is_finite() || fd.abs() > 1e5 {
            continue;
        }
        assert!(
            (sym - fd).abs() <= 1e-5 * (1.0 + fd.abs()),
            "d/dx {text} at ({x}, {y}): symbolic {sym}, finite differences {fd}"
        );
        checked += 1;
    }
    assert!(checked > 200, "only {checked} derivatives were checked");
}

/// The same model generates the same bytes every time (hash maps with random seeds inside
/// must not leak into the output), and the derivatives are the same DAG nodes.
#[test]
fn emission_is_deterministic() {
    let mut r = Rng::new(42);
    for _ in 0..20 {
        let (e1, _) = expr(&mut r, 0.5, 0.5, 3);
        let (e2, _) = expr(&mut r, 0.5, 0.5, 3);
        let text = format!(
            "model D {{ state x: scalar, y: scalar; param k = 2; let u = {e1};\n\
             d/dt x = k * u + y; d/dt y = {e2}; point p {{ x = 1; y = 1; }} }}"
        );
        let a = generate_source("d.lsl", &text);
        let b = generate_source("d.lsl", &text);
        match (a, b) {
            (Ok(a), Ok(b)) => assert_eq!(a.code, b.code, "{text}"),
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
            _ => panic!("one run generated, the other did not: {text}"),
        }
        let d1 = derive(lower_source("d.lsl", &text).unwrap());
        let d2 = derive(lower_source("d.lsl", &text).unwrap());
        assert_eq!(d1.derivatives.feedback, d2.derivatives.feedback);
        assert_eq!(d1.model.graph.len(), d2.model.graph.len());
    }
}
