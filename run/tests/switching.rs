//! Discontinuous fields (`sign(g)`) in both senses against H. Hermes, "Discontinuous vector
//! fields and feedback control" (NASA TM X-53478, 1966): Example 1's two strategies from
//! (1, 1) — the origin at t = 2, or Filippov's rest at (1, 0) from t = 1 — and Example 2's
//! circle, with the closed forms of both solutions; a chattering classical solution; the
//! located errors.

use lasalle_exec::{Backend, LoadedModel};
use lasalle_run::{simulate, Recording, RunSpec, Switching};

fn model_path(stem: &str) -> String {
    format!("{}/../models/{stem}.lsl", env!("CARGO_MANIFEST_DIR"))
}

fn run(model: &mut LoadedModel, preset: &str, sense: Switching, t_eval: &[f64]) -> Recording {
    let p = model.preset(preset).unwrap();
    let mut b = RunSpec::from_preset(Some(p))
        .rtol(1e-14)
        .atol(1e-14)
        .switching(sense);
    if !t_eval.is_empty() {
        b = b.t_eval(t_eval.to_vec());
    }
    let (spec, x0) = b.prepare(model).unwrap();
    let rec = simulate(&*model, &x0, &spec).unwrap();
    assert!(rec.failure.is_none(), "{preset}: {:?}", rec.failure);
    rec
}

/// The first switch at which the state is `at` (to 1e-12), and its time.
fn switch_at(rec: &Recording, at: [f64; 2]) -> f64 {
    rec.events
        .iter()
        .find(|h| (h.x[0] - at[0]).abs() < 1e-12 && (h.x[1] - at[1]).abs() < 1e-12)
        .unwrap_or_else(|| panic!("no switch at {at:?}: {:?}", rec.events))
        .t
}

fn last(rec: &Recording) -> [f64; 2] {
    let x = rec.last_state();
    [x[0], x[1]]
}

#[test]
fn strategy1_reaches_the_origin_at_t_2_in_both_senses() {
    for backend in [Backend::Jit, Backend::Interpreter] {
        let mut model = LoadedModel::load(model_path("min_time"), backend).unwrap();
        for sense in [Switching::Classical, Switching::Filippov] {
            let rec = run(&mut model, "strategy1", sense, &[]);
            let corner = switch_at(&rec, [0.0, 1.0]);
            let arrival = switch_at(&rec, [0.0, 0.0]);
            println!("strategy 1, {sense:?}: (0, 1) at t = {corner}, origin at t = {arrival}");
            assert!((corner - 1.0).abs() < 1e-12, "{sense:?}: {corner}");
            assert!((arrival - 2.0).abs() < 1e-12, "{sense:?}: {arrival}");
            let [a, b] = last(&rec);
            assert!(
                a.abs() < 1e-12 && b.abs() < 1e-12,
                "{sense:?}: rests at ({a}, {b})"
            );
            assert_eq!(rec.t_final(), 3.0);
        }
    }
}

#[test]
fn strategy2_reaches_the_origin_classically_and_rests_at_1_0_in_the_sense_of_filippov() {
    let mut model = LoadedModel::load(model_path("min_time"), Backend::Jit).unwrap();
    let classical = run(&mut model, "strategy2", Switching::Classical, &[]);
    let axis = switch_at(&classical, [1.0, 0.0]);
    let arrival = switch_at(&classical, [0.0, 0.0]);
    println!("strategy 2, classical: (1, 0) at t = {axis}, origin at t = {arrival}");
    assert!((axis - 1.0).abs() < 1e-12 && (arrival - 2.0).abs() < 1e-12);
    let [a, b] = last(&classical);
    assert!(a.abs() < 1e-12 && b.abs() < 1e-12);

    // Filippov: the fields above and below the x₁-axis point into it, K[X] ∋ 0 there
    let grid = [0.5, 0.75, 1.5, 2.0, 2.5, 3.0];
    let filippov = run(&mut model, "strategy2", Switching::Filippov, &grid);
    let rest = switch_at(&filippov, [1.0, 0.0]);
    let [a, b] = last(&filippov);
    println!("strategy 2, Filippov: (1, 0) at t = {rest}, at t = 3: ({a}, {b})");
    assert!((rest - 1.0).abs() < 1e-12);
    assert_eq!(filippov.t, grid);
    for (i, &t) in grid.iter().enumerate() {
        let x = filippov.state(i);
        let want = [1.0, (1.0 - t).max(0.0)];
        assert!((x[0] - want[0]).abs() < 1e-12 && (x[1] - want[1]).abs() < 1e-12);
        // the slide flag of x₂'s surface, the second one
        let k = filippov.state_names.iter().position(|n| n == "slide_1");
        assert_eq!(x[k.unwrap()], if t > 1.0 { 1.0 } else { 0.0 }, "at t = {t}");
    }
}

/// Example 2 from (0, 1.5): the rotation about the origin meets the circle at
/// t₁ = asin(ρ/2), at (ρ²/2, ρ cos t₁); classically it then turns about (1, 0) along the
/// circle and passes the origin after the angle from that point to (0, 0).
#[test]
fn the_circle_brings_classical_solutions_to_the_origin_and_filippov_ones_never() {
    let mut model = LoadedModel::load(model_path("filippov_circle"), Backend::Jit).unwrap();
    let rho: f64 = 1.5;
    let t1 = (rho / 2.0).asin();
    let (px, py) = (rho * rho / 2.0, rho * t1.cos());
    let arrival = t1 + py.atan2(px - 1.0) + std::f64::consts::PI;
    let classical = run(&mut model, "start", Switching::Classical, &[arrival]);
    let entry = classical.events.first().unwrap();
    let at_origin = classical.state(0);
    println!(
        "circle, classical: entry at t = {} (closed form {t1}), origin at t = {arrival}: |x| = {:e}",
        entry.t,
        at_origin[0].hypot(at_origin[1])
    );
    assert!((entry.t - t1).abs() < 1e-12);
    assert!(at_origin[0].hypot(at_origin[1]) < 1e-12);

    let grid: Vec<f64> = (0..=80).map(|k| k as f64 / 10.0).collect();
    let filippov = run(&mut model, "start", Switching::Filippov, &grid);
    let worst = (0..filippov.len())
        .map(|i| {
            let x = filippov.state(i);
            (x[0].hypot(x[1]) - rho).abs()
        })
        .fold(0.0, f64::max);
    println!("circle, Filippov: max ||x(t)| − |x(0)|| = {worst:e} over [0, 8]");
    assert!(worst < 1e-12);
    assert!(filippov.events.iter().all(|h| h.name == "sign_0"));
}

const CHATTER: &str = "
model Chatter {
    state x: scalar;
    d/dt x = -sign(x) + (1 - sign(x)^2);   // −1 above, +1 below, and +1 on x = 0
    point start { x = 1; }
}";

#[test]
fn a_classical_solution_that_chatters_is_an_error_and_filippov_slides() {
    let model = LoadedModel::from_source("chatter.lsl", CHATTER, Backend::Jit).unwrap();
    let x0 = lasalle_runtime::Parameters::point(&model, "start").unwrap();
    let spec = |sense| {
        RunSpec::builder()
            .method("dopri5".parse().unwrap())
            .t_end(3.0)
            .switching(sense)
            .build()
            .unwrap()
    };
    let err = simulate(&model, &x0, &spec(Switching::Classical)).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("chatters") && text.contains("--filippov"),
        "{text}"
    );
    let rec = simulate(&model, &x0, &spec(Switching::Filippov)).unwrap();
    assert!((rec.events[0].t - 1.0).abs() < 1e-12);
    assert!(rec.last_state()[0].abs() < 1e-12);
}

#[test]
fn sign_of_no_state_is_a_located_error() {
    let text = "model M {\n    state x: scalar;\n    param a = 1;\n    d/dt x = sign(a);\n}";
    let err = LoadedModel::from_source("m.lsl", text, Backend::Jit)
        .err()
        .unwrap()
        .to_string();
    assert!(
        err.contains("m.lsl:4:19") && err.contains("does not depend on it"),
        "{err}"
    );
}
