//! Every run ends within its step budget, as `lasalle run` and Python's `solve` make them:
//! a seeded fuzz of methods (DOPRI5 on X and on X − ∇V, Taylor), tolerances (down past
//! what f64 delivers), spans (up to 10³⁰⁰), first steps and budgets, on a smooth field, a
//! finite escape and a Kepler collision. Each spec is refused with the reason or its run
//! reaches its end or stops with a typed failure. The runs carry an [`Interrupt`] whose poll
//! counts the driver's readings (one every `INTERRUPT_EVERY` steps): a run that reads it more
//! often than its budget allows is stopped there and fails the test instead of hanging it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use lasalle_exec::{Backend, LoadedModel};
use lasalle_run::{simulate, Base, Interrupt, Method, RunError, RunSpec};
use lasalle_runtime::{taylor, Parameters, StepError, INTERRUPT_EVERY};
use lasalle_testkit::Rng;

const OSC: &str = "model Osc { state q: scalar, p: scalar;
    d/dt q = p; d/dt p = -q;
    integral H = (q^2 + p^2) / 2 gain k = 1;
    point start { q = 1; p = 0; } }";

/// ẋ = x², y at rest: x escapes at t = 1.
const ESCAPE: &str = "model Escape { state x: scalar, y: scalar;
    d/dt x = x^2; d/dt y = 0;
    integral Y = y gain k = 1;
    point start { x = 1; y = 1; } }";

/// From rest at r = 1 the orbit falls into the origin at t = π/(2√2).
const COLLISION: &str = "model Fall { state x: vec2, v: vec2;
    d/dt x = v; d/dt v = -x / norm(x)^3;
    integral E = (v[0]^2 + v[1]^2) / 2 - 1 / norm(x) gain k = 1;
    point start { x = [1, 0]; v = [0, 0]; } }";

/// How one fuzzed spec ended.
#[derive(Debug, Default)]
struct Tally {
    refused: u32,
    reached: u32,
    budget: u32,
    underflow: u32,
    other: u32,
}

/// One fuzzed run of `model` with `method`; tallies how it ended and fails on a run past its
/// budget.
fn fuzz_one(model: &LoadedModel, method: Method, rng: &mut Rng, tally: &mut Tally) {
    let t_end = rng.decade(-300.0, 300.0);
    let dt = if rng.unit() < 0.5 {
        0.0
    } else {
        rng.decade(-300.0, 1.0).min(t_end)
    };
    let mut spec = RunSpec::new(method, dt, t_end);
    spec.rtol = rng.decade(-34.0, -1.0);
    spec.atol = if method.is_taylor() {
        spec.rtol
    } else {
        rng.decade(-34.0, -1.0)
    };
    spec.max_steps = rng.decade(1.0, 4.0) as u64;
    // the driver reads the interrupt at the start and every INTERRUPT_EVERY steps: past the
    // budget (and one step's 51 trials) it stops the run and the count says so
    let readings = Arc::new(AtomicU64::new(0));
    let limit = (spec.max_steps + 51) / INTERRUPT_EVERY + 2;
    let seen = readings.clone();
    spec.interrupt = Some(Interrupt::with_poll(move || {
        seen.fetch_add(1, Ordering::Relaxed) + 1 > limit
    }));
    let what = format!(
        "{method} t_end {t_end:e} dt {dt:e} rtol {:e} atol {:e} budget {}",
        spec.rtol, spec.atol, spec.max_steps
    );
    let x0 = model.point("start").unwrap();
    let rec = match simulate(model, &x0, &spec) {
        Ok(rec) => rec,
        Err(RunError::Spec(m)) => {
            let floor = if method.is_taylor() {
                taylor::TOL_FLOOR
            } else {
                lasalle_runtime::rtol_floor()
            };
            assert!(spec.rtol < floor && m.contains("--rtol"), "{what}: {m}");
            tally.refused += 1;
            return;
        }
        Err(e) => panic!("{what}: {e}"),
    };
    assert!(
        readings.load(Ordering::Relaxed) <= limit,
        "{what}: ran past its budget ({:?})",
        rec.failure
    );
    assert!(
        rec.steps + rec.rejections <= spec.max_steps + 51,
        "{what}: {} steps, {} rejected",
        rec.steps,
        rec.rejections
    );
    match &rec.failure {
        None => {
            assert_eq!(rec.t_final(), t_end, "{what}");
            tally.reached += 1;
        }
        Some(StepError::MaxSteps { steps, .. }) => {
            assert_eq!(*steps, spec.max_steps, "{what}");
            tally.budget += 1;
        }
        Some(StepError::StepSizeTooSmall { .. }) => tally.underflow += 1,
        Some(StepError::Interrupted { .. }) => panic!("{what}: ran past its budget"),
        Some(
            StepError::TooManyRejections { .. }
            | StepError::NonFinite { .. }
            | StepError::Diverged { .. }
            | StepError::Guard { .. }
            | StepError::InvalidInput(_),
        ) => tally.other += 1,
        Some(e) => panic!("{what}: {e}"),
    }
}

#[test]
fn every_adaptive_run_ends_within_its_budget() {
    let mut rng = Rng::new(0x5eed_b0d9e7);
    let models = [OSC, ESCAPE, COLLISION]
        .map(|text| LoadedModel::from_source("fuzz.lsl", text, Backend::default()).unwrap());
    let methods = [
        Method::Plain(Base::Dopri5),
        Method::Feedback(Base::Dopri5),
        Method::Taylor { feedback: false },
    ];
    let mut tally = Tally::default();
    for case in 0..450 {
        let model = &models[case % models.len()];
        let method = methods[(case / models.len()) % methods.len()];
        fuzz_one(model, method, &mut rng, &mut tally);
    }
    eprintln!("{tally:?}");
    // every outcome that matters occurs
    assert!(tally.refused > 30 && tally.reached > 30, "{tally:?}");
    assert!(tally.budget > 30 && tally.underflow > 5, "{tally:?}");
}

/// The runs that never ended: the oscillator with DOPRI5 at rtol = atol = 10⁻³⁰ is refused
/// before it starts, naming the floor; at the floor it ends in a few thousand steps; Taylor
/// at 10⁻³⁰ (order 36) ends in about as many steps as at 10⁻¹⁵, and below u² is refused.
#[test]
fn tolerances_below_the_floor_are_refused_and_at_the_floor_runs_end() {
    let model = LoadedModel::from_source("osc.lsl", OSC, Backend::default()).unwrap();
    let x0 = model.point("start").unwrap();
    let build = |method: &str, rtol: f64| {
        RunSpec::builder()
            .method(method.parse().unwrap())
            .t_end(1.0)
            .rtol(rtol)
            .atol(rtol)
            .build()
    };
    let e = build("dopri5", 1e-30).unwrap_err().to_string();
    assert!(
        e.contains("--rtol 1e-30 is below 1.110e-15") && e.contains("give --rtol 1.12e-15 or more"),
        "{e}"
    );
    let floor = lasalle_runtime::rtol_floor::<f64>();
    let rec = simulate(&model, &x0, &build("dopri5", floor).unwrap()).unwrap();
    assert!(
        rec.failure.is_none() && rec.steps < 5000,
        "{} steps",
        rec.steps
    );
    assert!((rec.last_state()[0] - 1f64.cos()).abs() < 1e-13);
    let e = build("taylor", 1e-33).unwrap_err().to_string();
    assert!(e.contains("below 1.233e-32"), "{e}");
    let steps = |rtol| {
        let rec = simulate(&model, &x0, &build("taylor", rtol).unwrap()).unwrap();
        assert!(rec.failure.is_none());
        assert!((rec.last_state()[0] - 1f64.cos()).abs() < 1e-15);
        rec.steps
    };
    let (tight, usual) = (steps(1e-30), steps(1e-15));
    assert!(
        tight <= usual + 2,
        "{tight} steps at 1e-30, {usual} at 1e-15"
    );
}

/// Taylor cannot pass a collision: its Jorba–Zou step shrinks with the radius of convergence
/// and the run stops at the step floor, just short of the collision time, with the reason.
#[test]
fn taylor_stops_at_a_collision_with_a_step_underflow() {
    let model = LoadedModel::from_source("fall.lsl", COLLISION, Backend::default()).unwrap();
    let x0 = model.point("start").unwrap();
    let spec = RunSpec::builder()
        .method("taylor".parse().unwrap())
        .t_end(2.0)
        .rtol(1e-15)
        .max_drift(1e300) // the energy's error grows without bound at the collision
        .build()
        .unwrap();
    let rec = simulate(&model, &x0, &spec).unwrap();
    let e = rec.failure.expect("the run cannot pass the collision");
    let t_collision = std::f64::consts::PI / (2.0 * 2f64.sqrt());
    assert!(matches!(e, StepError::StepSizeTooSmall { .. }), "{e}");
    assert!(
        e.to_string().starts_with("step size underflow at t = "),
        "{e}"
    );
    let t = e.time().unwrap();
    assert!((t - t_collision).abs() < 1e-6, "t = {t}, {e}");
}
