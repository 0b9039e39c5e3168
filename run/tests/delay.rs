//! Delay equations (`delay(x, r)`) by the method of steps, on the example of J. P. LaSalle,
//! "An invariance principle in the theory of stability" (NASA TM X-53478, 1966), §3:
//! ẋ(t) = a x(t) + b x(t − r), x = 1 on [−r, 0]. Against the closed form of the method of
//! steps on [0, r] and [r, 2r], the rightmost root of the characteristic equation
//! λ = a + b e^{−λr} (Newton's method), and the paper's functional V with its derivative V̇;
//! the located errors.

use lasalle_exec::{Backend, LoadedModel};
use lasalle_run::{growth, simulate, Method, Recording, RunError, RunSpec};
use lasalle_runtime::{Declared, Parameters};

fn model_path(stem: &str) -> String {
    format!("{}/../models/{stem}.lsl", env!("CARGO_MANIFEST_DIR"))
}

/// The model with parameters (a, b, r).
fn model(backend: Backend, a: f64, b: f64, r: f64) -> LoadedModel {
    let mut m = LoadedModel::load(model_path("delay"), backend).unwrap();
    for (name, v) in [("a", a), ("b", b), ("r", r)] {
        m.set_param(name, &[v]).unwrap();
    }
    m
}

/// A run to `t_end`, sampled at `t_eval` (every step if empty).
fn run(m: &mut LoadedModel, t_end: f64, t_eval: &[f64]) -> Result<Recording, RunError> {
    let mut b = RunSpec::from_preset(m.preset("steps"))
        .t_end(t_end)
        .rtol(1e-13)
        .atol(1e-15);
    if !t_eval.is_empty() {
        b = b.t_eval(t_eval.to_vec());
    }
    let (spec, x0) = b.prepare(m)?;
    simulate(&*m, &x0, &spec)
}

/// The rightmost real root of λ = a + b e^{−λr} (b > 0: the function λ − a − b e^{−λr}
/// increases, one real root), by Newton's method from a + b.
fn characteristic_root(a: f64, b: f64, r: f64) -> f64 {
    let mut l = a + b;
    for _ in 0..100 {
        let e = b * (-l * r).exp();
        let step = (l - a - e) / (1.0 + r * e);
        l -= step;
        if step.abs() < 1e-16 {
            break;
        }
    }
    l
}

/// The method of steps in closed form from x = 1 on [−r, 0]: on [0, r]
/// x = c e^{at} − b/a with c = 1 + b/a; on [r, 2r], with s = t − r,
/// x = (x(r) − b²/a²) e^{as} + b c s e^{as} + b²/a².
fn exact(a: f64, b: f64, r: f64, t: f64) -> f64 {
    let c = 1.0 + b / a;
    let first = |t: f64| c * (a * t).exp() - b / a;
    if t <= r {
        return first(t);
    }
    let s = t - r;
    let k = b * b / (a * a);
    (first(r) - k) * (a * s).exp() + b * c * s * (a * s).exp() + k
}

#[test]
fn the_method_of_steps_matches_its_closed_form_on_two_intervals() {
    for backend in [Backend::Jit, Backend::Interpreter] {
        for (a, b, r) in [(0.5, 0.3, 1.0), (-0.5, 0.3, 1.0), (-1.2, 0.7, 0.6)] {
            let mut m = model(backend, a, b, r);
            let grid: Vec<f64> = (0..=200).map(|i| 2.0 * r * i as f64 / 200.0).collect();
            let rec = run(&mut m, 2.0 * r, &grid).unwrap();
            assert!(rec.failure.is_none(), "{:?}", rec.failure);
            assert_eq!(rec.t.len(), grid.len());
            let n = rec.state_names.len();
            let mut worst: f64 = 0.0;
            for (i, &t) in rec.t.iter().enumerate() {
                assert!((t - grid[i]).abs() < 1e-12, "sample {i} at {t}");
                let err = (rec.x[i * n] - exact(a, b, r, t)).abs();
                worst = worst.max(err);
                // the lag slot records x(t − r)
                let lagged = if t <= r { 1.0 } else { exact(a, b, r, t - r) };
                assert!((rec.x[i * n + 2] - lagged).abs() < 1e-10, "x(t − r) at {t}");
            }
            println!(
                "{backend:?} a = {a}, b = {b}, r = {r}: max |x − exact| on [0, 2r] = {worst:.2e}"
            );
            assert!(worst < 1e-10, "{worst}");
        }
    }
}

#[test]
fn growth_and_decay_rates_are_the_characteristic_root() {
    for (a, expected, verdict) in [(0.5, 0.655, "grows"), (-0.5, -0.151, "decays")] {
        let (b, r) = (0.3, 1.0);
        let lambda = characteristic_root(a, b, r);
        assert!((lambda - expected).abs() < 1e-3, "{lambda}");
        assert!((lambda - a - b * (-lambda * r).exp()).abs() < 1e-15);
        let mut m = model(Backend::Jit, a, b, r);
        let rec = run(&mut m, 30.0, &[20.0, 30.0]).unwrap();
        let x = |i: usize| rec.x[i * rec.state_names.len()];
        let rate = (x(1) / x(0)).ln() / 10.0;
        println!("a = {a}: rate {rate:.12} on [20, 30], root {lambda:.12}");
        assert!((rate - lambda).abs() < 1e-8, "{rate} vs {lambda}");
        assert!(x(1) > 0.0);
        let all = run(&mut m, 30.0, &[]).unwrap();
        let g = growth(&all, Declared::<f64, Vec<f64>>::delays(&m)).unwrap();
        assert_eq!(g.verdict(), verdict);
        assert!((g.rate - lambda).abs() < 1e-6, "{g:?}");
    }
}

/// The paper's functional V(φ) = −φ(0)²/(2a) + ½∫₋ᵣ⁰ φ(θ)² dθ along the solution x_t, and its
/// derivative V̇(φ) = −½[φ(0)² + (2b/a) φ(0) φ(−r) + φ(−r)²].
#[test]
fn the_papers_functional_decreases_along_the_solution() {
    let (b, r) = (0.3, 1.0);
    let steps = 1000; // per unit time
    let h = 1.0 / steps as f64;
    for a in [0.5, -0.5] {
        let mut m = model(Backend::Jit, a, b, r);
        let t_end = 10.0;
        let grid: Vec<f64> = (0..=(t_end as usize * steps))
            .map(|i| i as f64 * h)
            .collect();
        let rec = run(&mut m, t_end, &grid).unwrap();
        let n = rec.state_names.len();
        // x on [−r, t_end], the constant history first
        let lag = (r / h).round() as usize;
        let mut x = vec![1.0; lag];
        x.extend((0..rec.t.len()).map(|i| rec.x[i * n]));
        let at = |t: f64| x[lag + (t / h).round() as usize];
        // Simpson's rule over [t − r, t] (an even number of intervals)
        let integral = |t: f64| {
            let i0 = (t / h).round() as usize;
            let s: f64 = (0..=lag)
                .map(|j| {
                    let w = if j == 0 || j == lag {
                        1.0
                    } else if j % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    w * x[i0 + j].powi(2)
                })
                .sum();
            s * h / 3.0
        };
        let v = |t: f64| -at(t).powi(2) / (2.0 * a) + 0.5 * integral(t);
        let v_dot = |t: f64| {
            let (p0, pr) = (at(t), at(t - r));
            -0.5 * (p0 * p0 + 2.0 * b / a * p0 * pr + pr * pr)
        };
        println!("a = {a}: V(x_0) = {:.6}", v(0.0));
        let v0_expected = -1.0 / (2.0 * a) + r / 2.0;
        assert!((v(0.0) - v0_expected).abs() < 1e-12);
        let mut previous = v(0.0);
        for k in 1..=20 {
            let t = k as f64 * 0.5;
            let (vt, vd) = (v(t), v_dot(t));
            println!(
                "a = {a}: t = {t:4}: x = {:+.6e}, V = {vt:+.6e}, V̇ = {vd:+.6e}",
                at(t)
            );
            assert!(vd < 0.0, "V̇ = {vd} at {t}");
            assert!(vt < previous, "V grew at {t}");
            previous = vt;
            // V̇ is the derivative of V: a central difference, away from the breakpoints
            if k % 2 == 1 && t > 1.0 {
                let diff = (v(t + h) - v(t - h)) / (2.0 * h);
                assert!(
                    (diff - vd).abs() < 1e-5 * vd.abs().max(1.0),
                    "{diff} vs {vd} at {t}"
                );
            }
        }
        if a > 0.0 {
            // x_0 lies in G = {V < 0}, which no trajectory leaves: it is unbounded
            assert!(v(0.0) < 0.0 && previous < v(0.0));
        } else {
            assert!(v(0.0) > 0.0 && previous > 0.0 && previous < 0.05 * v(0.0));
        }
    }
}

#[test]
fn delay_errors_are_located() {
    let mut m = model(Backend::Jit, 0.5, 0.3, 1.0);
    for method in ["rk4", "taylor", "feedback-euler"] {
        let b = RunSpec::from_preset(m.preset("steps"))
            .method(method.parse::<Method>().unwrap())
            .dt(0.01);
        let (spec, x0) = b.prepare(&mut m).unwrap();
        let e = simulate(&m, &x0, &spec).unwrap_err().to_string();
        assert!(
            e.contains("delay.lsl:16:") && e.contains("-m dopri5"),
            "{method}: {e}"
        );
    }
    for r in [0.0, -1.0] {
        let mut bad = model(Backend::Jit, 0.5, 0.3, r);
        let e = run(&mut bad, 1.0, &[]).unwrap_err().to_string();
        assert!(
            e.contains("delay.lsl:16:") && e.contains("positive constant"),
            "{e}"
        );
    }
    let mut tiny = model(Backend::Jit, 0.5, 0.3, 1e-7);
    let e = run(&mut tiny, 1.0, &[]).unwrap_err().to_string();
    assert!(
        e.contains("delay.lsl:16:") && e.contains("intervals of the smallest delay"),
        "{e}"
    );
    let source = |body: &str| {
        format!("model D {{ state x: scalar, y: scalar; param r = 1; {body} point p {{ x = 1; y = 0; }} }}")
    };
    let rows: &[(&str, &str)] = &[
        ("d/dt x = delay(x * 2, r); d/dt y = 0;", "is not one"),
        ("d/dt x = delay(x, x); d/dt y = 0;", "depends on the state"),
        ("d/dt x = delay(x, 0); d/dt y = 0;", "this one is 0"),
        ("d/dt x = delay(x, -1.5); d/dt y = 0;", "this one is -1.5"),
        (
            "d/dt x = delay(x, r); d/dt y = 0; event e: delay(y, r) - 1 = 0;",
            "may not read a delayed state",
        ),
        (
            "d/dt x = delay(x, r) * sign(y); d/dt y = 1;",
            "may not also read delayed states",
        ),
    ];
    for (body, message) in rows {
        let text = source(body);
        let e = match lasalle_model::lower_source("bad.lsl", &text) {
            Ok(_) => panic!("accepted: {body}"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains(message) && e.contains("bad.lsl:1:"),
            "{body}: {e}"
        );
    }
}
