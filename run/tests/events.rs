//! Events and output times against closed forms: Kepler's pericentre passages at the
//! multiples of the period, the harmonic oscillator's zeros at π/2 + kπ for every method
//! within that method's own error, directions, terminal events, touches, and `t_eval`.

use std::f64::consts::PI;

use lasalle_exec::{Backend, LoadedModel};
use lasalle_run::{simulate, Recording, RunSpec};

/// x = cos t, v = −sin t, with its energy as an integral (for the feedback and projection
/// methods) and events of every kind.
const OSCILLATOR: &str = "
model Oscillator {
    state x: scalar, v: scalar;
    d/dt x = v;
    d/dt v = -x;
    integral E = (x^2 + v^2) / 2 gain 1;
    event zero: x = 0;
    event up: x = 0 rising;
    event down: x = 0 falling;
    point start { x = 1; v = 0; }
}";

fn load(text: &str, backend: Backend) -> LoadedModel {
    LoadedModel::from_source("test.lsl", text, backend).unwrap()
}

fn run(model: &LoadedModel, method: &str, dt: f64, tol: f64, t_end: f64) -> Recording {
    let x0 = model_point(model, "start");
    let mut b = RunSpec::builder()
        .method(method.parse().unwrap())
        .t_end(t_end)
        .every(1);
    let m: lasalle_run::Method = method.parse().unwrap();
    if m.is_adaptive() {
        b = b.rtol(tol);
        if !m.is_taylor() {
            b = b.atol(tol);
        }
    } else {
        b = b.dt(dt);
    }
    simulate(model, &x0, &b.build().unwrap()).unwrap()
}

fn model_point(model: &LoadedModel, name: &str) -> Vec<f64> {
    lasalle_runtime::Parameters::point(model, name).unwrap()
}

/// Every method finds the oscillator's zeros at π/2 + kπ to within its own error: the
/// largest error of its recorded states against the closed form (a crossing of |ẋ| = 1
/// moves by as much as the state is off), plus the interpolant's.
#[test]
fn every_method_finds_the_zeros_of_cos_within_its_error() {
    let model = load(OSCILLATOR, Backend::Jit);
    let t_end = 20.0;
    let cases: &[(&str, f64, f64)] = &[
        ("euler", 1e-4, 0.0),
        ("heun", 1e-3, 0.0),
        ("rk4", 0.02, 0.0),
        ("dopri5", 0.0, 1e-12),
        ("taylor", 0.0, 1e-15),
        ("stormer-verlet-a", 0.01, 0.0),
        ("stormer-verlet-b", 0.01, 0.0),
        ("symplectic4", 0.02, 0.0),
        ("symplectic6", 0.05, 0.0),
        ("symplectic8", 0.1, 0.0),
        ("feedback-rk4", 0.02, 0.0),
        ("projection-rk4", 0.02, 0.0),
        ("feedback-dopri5", 0.0, 1e-11),
        ("feedback-taylor", 0.0, 1e-14),
        ("split-taylor", 0.0, 1e-14),
    ];
    for &(method, dt, tol) in cases {
        let rec = run(&model, method, dt, tol, t_end);
        assert!(rec.failure.is_none(), "{method}: {:?}", rec.failure);
        let state_error = (0..rec.len())
            .map(|i| {
                let (t, x) = (rec.t[i], rec.state(i));
                (x[0] - t.cos()).abs().max((x[1] + t.sin()).abs())
            })
            .fold(0.0, f64::max);
        let zeros: Vec<f64> = rec.events_named("zero").map(|e| e.t).collect();
        assert_eq!(zeros.len(), 6, "{method}: {zeros:?}"); // π/2 … 11π/2 < 20
        let mut worst = 0.0f64;
        for (k, t) in zeros.iter().enumerate() {
            worst = worst.max((t - (PI / 2.0 + k as f64 * PI)).abs());
        }
        // the Hermite cubic of fixed-step methods adds up to h⁴/384 max|x⁗| = h⁴/384
        let allowed = 4.0 * state_error + dt.powi(4) / 384.0 + 1e-13;
        assert!(
            worst <= allowed,
            "{method}: crossing error {worst:.2e} > {allowed:.2e} (state error {state_error:.2e})"
        );
        // the state recorded at a crossing is on the section x = 0 to the same error
        for e in rec.events_named("zero") {
            assert!(
                e.x[0].abs() <= allowed,
                "{method}: x = {:e} at a zero",
                e.x[0]
            );
            assert_eq!(e.invariants.len(), 1);
            assert!(
                (e.invariants[0] - 0.5).abs() < 1e-2,
                "{method}: E = {}",
                e.invariants[0]
            );
        }
        eprintln!("{method:>18}: crossing error {worst:.2e}, state error {state_error:.2e}");
    }
}

/// `rising` counts x going up through 0 (at 3π/2 + 2kπ), `falling` going down (π/2 + 2kπ);
/// both alternate in the unfiltered event.
#[test]
fn rising_and_falling() {
    let model = load(OSCILLATOR, Backend::Jit);
    let rec = run(&model, "dopri5", 0.0, 1e-12, 20.0);
    let up: Vec<f64> = rec.events_named("up").map(|e| e.t).collect();
    let down: Vec<f64> = rec.events_named("down").map(|e| e.t).collect();
    assert_eq!(up.len(), 3);
    assert_eq!(down.len(), 3);
    for (k, (u, d)) in up.iter().zip(&down).enumerate() {
        assert!((u - (1.5 * PI + 2.0 * PI * k as f64)).abs() < 1e-9, "{u}");
        assert!((d - (0.5 * PI + 2.0 * PI * k as f64)).abs() < 1e-9, "{d}");
    }
    assert!(rec.events_named("up").all(|e| e.rising && !e.touch));
    assert!(rec.events_named("down").all(|e| !e.rising));
    let both: Vec<bool> = rec.events_named("zero").map(|e| e.rising).collect();
    assert_eq!(both, [false, true, false, true, false, true]);
    // time order across events
    assert!(rec.events.windows(2).all(|w| w[0].t <= w[1].t));
}

/// A terminal event ends the run at its first crossing, with the state there as the last
/// sample; crossings after it are not recorded. v = −sin t first rises through 1/2 at 7π/6.
#[test]
fn a_terminal_event_stops_the_run_where_it_crosses() {
    let text = OSCILLATOR.replace(
        "point start",
        "event half: v - 0.5 = 0 rising stop;\n    point start",
    );
    for method in ["dopri5", "rk4", "taylor"] {
        let model = load(&text, Backend::Jit);
        let rec = run(&model, method, 1e-3, 1e-13, 20.0);
        let stop = rec.stopped_by.as_ref().expect("stopped by `half`");
        let t_star = 7.0 * PI / 6.0;
        assert_eq!(stop.name, "half");
        assert!((stop.t - t_star).abs() < 1e-10, "{method}: {}", stop.t);
        assert!(rec.failure.is_none());
        assert_eq!(rec.t_final(), stop.t);
        let last = rec.last_state();
        assert!((last[1] - 0.5).abs() < 1e-10 && (last[0] - t_star.cos()).abs() < 1e-10);
        // π/2 (down) lies before, 3π/2 (up) after
        assert_eq!(rec.events_named("down").count(), 1, "{method}");
        assert_eq!(rec.events_named("up").count(), 0, "{method}");
        let summary = rec.summary_json();
        assert_eq!(summary["events"]["stopped_by"]["event"], "half");
    }
}

/// A function that only touches zero (g = −(t − 1.3)², and one that reaches 10⁻²⁰ above it,
/// a pair of crossings 2·10⁻¹⁰ apart) is one crossing, flagged as a touch; one that stays
/// clearly negative is none. Also across the grid of fixed steps, where the touch falls at
/// a step's end (t = 1.3 with dt = 0.1) or inside one.
#[test]
fn a_touch_is_found_once() {
    let text = OSCILLATOR.replace(
        "point start",
        "event graze: -(t - 1.3)^2 = 0;\n    event pair: 1e-20 - (t - 1.3)^2 = 0;\n    event miss: -1e-3 - (t - 1.3)^2 = 0;\n    point start",
    );
    let model = load(&text, Backend::Jit);
    for (method, dt) in [
        ("dopri5", 0.0),
        ("rk4", 0.1),
        ("rk4", 0.07),
        ("taylor", 0.0),
    ] {
        let rec = run(&model, method, dt, 1e-12, 3.0);
        for name in ["graze", "pair"] {
            let hits: Vec<_> = rec.events_named(name).collect();
            assert_eq!(hits.len(), 1, "{method} dt = {dt}: {name} {hits:?}");
            assert!(hits[0].touch);
            assert!((hits[0].t - 1.3).abs() < 1e-6, "{method}: {}", hits[0].t);
        }
        assert_eq!(rec.events_named("miss").count(), 0);
    }
}

/// Kepler's pericentre passages (e = 0.5) over a thousand orbits against the closed-form
/// period T = 2π a^{3/2}/√μ, a = −μ/(2E) from the initial state: with the Taylor method at
/// ε = 10⁻¹⁶ the k-th passage lies at kT to 1e-10 for every k ≤ 1000 (measured 4e-11); at
/// ε = 10⁻¹⁵ to 2e-10 (1.4e-10: the truncation error's drift of the energy, 1.3e-14, turned
/// into phase); with DOPRI5 at 1e-14 to 3e-7 (1.7e-7, its energy drifting by 1.8e-11 over
/// 1.1·10⁶ steps). Every orbit between two passages lasts T to 1e-11 (Taylor; 1e-9 DOPRI5):
/// what remains is the integration's error, not the location's.
#[test]
fn kepler_pericentres_at_the_multiples_of_the_period() {
    let text = "
model Kepler {
    state x: vec2, v: vec2;
    param mu = 1.0;
    let r = norm(x);
    d/dt x = v;
    d/dt v = -mu * x / r^3;
    integral E = dot(v, v) / 2 - mu / r;
    event pericentre: dot(x, v) = 0 rising;
    event apocentre: dot(x, v) = 0 falling;
    point start { x = [0.5, 0]; v = [0, sqrt(3)]; }
}";
    let model = load(text, Backend::Jit);
    let orbits = 1000;
    let x0 = model_point(&model, "start");
    let mu = 1.0;
    let energy = (x0[2] * x0[2] + x0[3] * x0[3]) / 2.0 - mu / x0[0].hypot(x0[1]);
    let a = -mu / (2.0 * energy);
    let period = 2.0 * PI * a.powf(1.5) / mu.sqrt();
    let t_end = period * orbits as f64 + 1.0;
    // (method, tolerance, bound on an orbit's error, bound on the passages' error)
    for (method, tol, orbit, drift) in [
        ("dopri5", 1e-14, 1e-9, 3e-7),
        ("taylor", 1e-15, 1e-11, 2e-10),
        ("taylor", 1e-16, 1e-11, 1e-10),
    ] {
        let mut b = RunSpec::builder()
            .method(method.parse().unwrap())
            .t_end(t_end)
            .rtol(tol)
            .every(1000);
        if method == "dopri5" {
            b = b.atol(tol);
        }
        let rec = simulate(&model, &x0, &b.build().unwrap()).unwrap();
        let peri: Vec<f64> = rec.events_named("pericentre").map(|e| e.t).collect();
        let apo: Vec<f64> = rec.events_named("apocentre").map(|e| e.t).collect();
        assert_eq!(peri.len(), orbits, "{method}");
        assert_eq!(apo.len(), orbits, "{method}");
        let orbit_error = |ts: &[f64]| {
            ts.windows(2)
                .map(|w| (w[1] - w[0] - period).abs())
                .fold(0.0, f64::max)
        };
        let (per_orbit, per_orbit_apo) = (orbit_error(&peri), orbit_error(&apo));
        let last = (peri[orbits - 1] - period * orbits as f64).abs();
        let worst = peri
            .iter()
            .enumerate()
            .map(|(k, t)| (t - period * (k + 1) as f64).abs())
            .fold(0.0, f64::max);
        let drift_e = rec
            .events_named("pericentre")
            .map(|e| (e.invariants[0] - energy).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "{method} at {tol:e}: {} steps; orbit T to {per_orbit:.2e} (apocentres \
             {per_orbit_apo:.2e}); passage k at kT to {worst:.2e}; energy drift {drift_e:.1e}",
            rec.steps
        );
        assert!(
            per_orbit < orbit,
            "{method}: an orbit off 2π by {per_orbit:e}"
        );
        assert!(per_orbit_apo < orbit, "{method}: {per_orbit_apo:e}");
        assert!(last < drift && worst < drift, "{method}: {worst:e}");
        // at a pericentre r = a(1 − e) = 0.5, at an apocentre a(1 + e) = 1.5
        for (name, r0) in [("pericentre", 0.5), ("apocentre", 1.5)] {
            for e in rec.events_named(name) {
                let r = e.x[0].hypot(e.x[1]);
                assert!((r - r0).abs() < 1e-9, "{method}: r = {r} at a {name}");
            }
        }
    }
}

/// Output times: the states at `t_eval` against cos and sin for an adaptive, a Taylor and a
/// fixed-step method; the adaptive ones take the same steps as without output times.
#[test]
fn t_eval_against_the_closed_form() {
    let model = load(OSCILLATOR, Backend::Jit);
    let times = lasalle_run::parse_t_eval("0:10:101").unwrap();
    for (method, dt, tol, allowed) in [
        ("dopri5", 0.0, 1e-12, 1e-10),
        ("taylor", 0.0, 1e-15, 1e-12),
        ("rk4", 0.05, 0.0, 1e-6),
        ("symplectic4", 0.05, 0.0, 1e-5),
    ] {
        let m: lasalle_run::Method = method.parse().unwrap();
        let mut b = RunSpec::builder().method(m).t_end(10.0);
        b = if m.is_adaptive() {
            b.rtol(tol)
        } else {
            b.dt(dt)
        };
        if m.is_adaptive() && !m.is_taylor() {
            b = b.atol(tol);
        }
        let plain = simulate(
            &model,
            &model_point(&model, "start"),
            &b.clone().build().unwrap(),
        )
        .unwrap();
        let spec = b.t_eval(times.clone()).build().unwrap();
        let rec = simulate(&model, &model_point(&model, "start"), &spec).unwrap();
        assert_eq!(rec.t, times, "{method}");
        assert_eq!(
            rec.steps, plain.steps,
            "{method}: output times changed the steps"
        );
        for i in 0..rec.len() {
            let t = rec.t[i];
            let x = rec.state(i);
            let err = (x[0] - t.cos()).abs().max((x[1] + t.sin()).abs());
            assert!(err < allowed, "{method} at t = {t}: {err:e}");
        }
    }
    // output times outside the run are refused
    let bad = RunSpec::builder()
        .method("rk4".parse().unwrap())
        .dt(0.1)
        .t_end(1.0)
        .t_eval(vec![0.5, 2.0])
        .build();
    assert!(bad.unwrap_err().to_string().contains("outside"));
}

/// The interpreter computes the event functions bitwise as the JIT does.
#[test]
fn interpreter_and_jit_event_values_agree_bitwise() {
    use lasalle_runtime::Declared;
    let text = OSCILLATOR.replace(
        "point start",
        "event mixed: x * sin(t) - v^3 / (1 + t^2) = 0;\n    point start",
    );
    let jit = load(&text, Backend::Jit);
    let interp = load(&text, Backend::Interpreter);
    assert_eq!(jit.events().len(), 4);
    assert_eq!(jit.events()[1].name, "up");
    let (mut a, mut b) = (vec![0.0; 4], vec![0.0; 4]);
    for k in 0..50 {
        let x = vec![(k as f64 * 0.37).sin(), (k as f64 * 0.11).cos() * 3.0];
        let t = k as f64 * 0.7 - 3.0;
        jit.event_values(&x, t, &mut a);
        interp.event_values(&x, t, &mut b);
        assert_eq!(
            a.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        let want = x[0] * t.sin() - x[1].powi(3) / (1.0 + t * t);
        assert!((a[3] - want).abs() < 1e-14 * (1.0 + want.abs()));
    }
}

/// An ensemble of an events model runs no member in lanes (lanes record neither events nor
/// output times): every member's crossings and samples are those of its lone run.
#[test]
fn ensembles_keep_each_members_events_and_output_times() {
    use lasalle_run::{simulate_many, Member, ModelSource};
    let source = ModelSource::new("test.lsl", OSCILLATOR, Backend::Jit);
    let model = load(OSCILLATOR, Backend::Jit);
    let members: Vec<Member> = (0..8)
        .map(|k| Member::at(vec![1.0 + 0.1 * k as f64, 0.0]))
        .collect();
    for t_eval in [vec![], vec![0.5, 1.0, 2.5, 9.0]] {
        let spec = RunSpec::builder()
            .method("rk4".parse().unwrap())
            .dt(0.01)
            .t_end(10.0)
            .every(u64::MAX)
            .t_eval(t_eval.clone())
            .build()
            .unwrap();
        let many = simulate_many(&source, &members, &spec, 2, 8).unwrap();
        for (m, rec) in members.iter().zip(&many.recordings) {
            let rec = rec.as_ref().unwrap();
            let lasalle_run::Init::State(x0) = &m.init else {
                unreachable!()
            };
            let lone = simulate(&model, x0, &spec).unwrap();
            // x = A cos t: zeros at π/2, 3π/2 (rising) and 5π/2 before t = 10
            assert_eq!(rec.events, lone.events);
            assert_eq!(rec.events_named("zero").count(), 3);
            assert_eq!(rec.events_named("up").count(), 1);
            assert_eq!((&rec.t, &rec.x), (&lone.t, &lone.x));
            if !t_eval.is_empty() {
                assert_eq!(rec.t, t_eval);
            }
        }
    }
}

/// An interrupt stops a run within a few hundred steps of being set, and an ensemble starts
/// no member after it.
#[test]
fn an_interrupt_stops_runs_and_ensembles() {
    use lasalle_run::{simulate_many, Interrupt, Member, ModelSource, RunError};
    use lasalle_runtime::StepError;
    let model = load(OSCILLATOR, Backend::Jit);
    let stop = Interrupt::new();
    let mut spec = RunSpec::builder()
        .method("rk4".parse().unwrap())
        .dt(1e-5)
        .t_end(1e3)
        .build()
        .unwrap();
    spec.interrupt = Some(stop.clone());
    let started = std::time::Instant::now();
    let rec = std::thread::scope(|s| {
        s.spawn(|| {
            std::thread::sleep(std::time::Duration::from_millis(100));
            stop.stop();
        });
        simulate(&model, &vec![1.0, 0.0], &spec).unwrap()
    });
    // 10⁹ steps would take many seconds
    assert!(started.elapsed().as_secs_f64() < 5.0);
    let Some(StepError::Interrupted { t, step, state }) = &rec.failure else {
        panic!("{:?}", rec.failure);
    };
    assert!(*t > 0.0 && *t < 1e3 && step % 256 == 0);
    assert!((state[0] - t.cos()).abs() < 1e-9);
    // already stopped: nothing starts
    let source = ModelSource::new("test.lsl", OSCILLATOR, Backend::Jit);
    let members = vec![Member::at(vec![1.0, 0.0]); 4];
    let many = simulate_many(&source, &members, &spec, 2, 1).unwrap();
    assert!(many
        .recordings
        .iter()
        .all(|r| matches!(r, Err(RunError::Interrupted))));
}
