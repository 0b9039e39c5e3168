//! Backward runs (a negative end time) against the closed form of the harmonic oscillator,
//! for every method that has a time-reversed form; events keep their direction in the
//! model's time; the methods without one say so.

use lasalle_exec::{Backend, LoadedModel};
use lasalle_run::{simulate, Method, RunError, RunSpec};

/// x = cos t, v = −sin t (a partitioned field, with its energy as an integral).
const OSCILLATOR: &str = "
model Oscillator {
    state x: scalar, v: scalar;
    d/dt x = v;
    d/dt v = -x;
    integral E = (x^2 + v^2) / 2 gain 1;
    event up: x = 0 rising;
    point start { x = 1; v = 0; }
}";

fn spec(method: &str, t_end: f64) -> RunSpec {
    let m: Method = method.parse().unwrap();
    let mut b = RunSpec::builder().method(m).t_end(t_end).every(1);
    if m.is_adaptive() {
        b = b.rtol(1e-13);
        if !m.is_taylor() {
            b = b.atol(1e-13);
        }
    } else {
        b = b.dt(1e-3);
    }
    b.build().unwrap()
}

#[test]
fn every_reversible_method_follows_the_closed_form_backwards() {
    let model = LoadedModel::from_source("osc.lsl", OSCILLATOR, Backend::Jit).unwrap();
    let x0 = vec![1.0, 0.0];
    for (method, tol) in [
        ("rk4", 1e-11),
        ("dopri5", 1e-10),
        ("taylor", 1e-12),
        ("feedback-rk4", 1e-11),
        ("feedback-dopri5", 1e-10),
        ("projection-rk4", 1e-11),
        ("stormer-verlet-a", 1e-6),
        ("symplectic6", 1e-11),
    ] {
        let rec = simulate(&model, &x0, &spec(method, -5.0)).unwrap();
        assert!(rec.failure.is_none(), "{method}: {:?}", rec.failure);
        assert_eq!(rec.t[0], 0.0);
        assert!(
            rec.t.windows(2).all(|w| w[1] < w[0]),
            "{method}: times decrease"
        );
        assert_eq!(*rec.t.last().unwrap(), -5.0, "{method}");
        for (i, &t) in rec.t.iter().enumerate() {
            let x = rec.state(i);
            let err = (x[0] - t.cos()).abs().max((x[1] + t.sin()).abs());
            assert!(err < tol, "{method} at t = {t}: error {err:e}");
        }
        // `up` (x = 0 rising in t) at t = −π/2: x = cos t rises through 0 there
        let ups: Vec<f64> = rec.events.iter().map(|e| e.t).collect();
        assert_eq!(ups.len(), 1, "{method}: {ups:?}");
        assert!(
            (ups[0] + std::f64::consts::FRAC_PI_2).abs() < 1e-6,
            "{method}: {ups:?}"
        );
        assert!(rec.events[0].rising, "{method}");
    }
}

#[test]
fn taylor_backwards_then_forwards_returns_to_the_start() {
    let model = LoadedModel::from_source("osc.lsl", OSCILLATOR, Backend::Jit).unwrap();
    let x0 = vec![1.0, 0.0];
    let back = simulate(&model, &x0, &spec("taylor", -30.0)).unwrap();
    let there = back.state(back.len() - 1).to_vec();
    let forth = simulate(&model, &there, &spec("taylor", 30.0)).unwrap();
    let end = forth.state(forth.len() - 1);
    assert!(
        (end[0] - 1.0).abs() < 1e-12 && end[1].abs() < 1e-12,
        "{end:?}"
    );
}

#[test]
fn methods_without_a_reversed_form_say_so() {
    let model = LoadedModel::from_source("osc.lsl", OSCILLATOR, Backend::Jit).unwrap();
    for method in ["feedback-taylor", "split-taylor"] {
        match simulate(&model, &vec![1.0, 0.0], &spec(method, -1.0)) {
            Err(RunError::Spec(m)) => assert!(m.contains("cannot integrate backwards"), "{m}"),
            other => panic!("{method}: {other:?}"),
        }
    }
}
