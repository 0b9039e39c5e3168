//! No silent garbage: a run that diverges stops with a failure that names what diverged, the
//! time and the step, and the command line exits with 1; the defaults of the adaptive
//! feedback methods follow the step (they cost about the plain method's steps), and adaptive
//! methods choose their own first step.
//!
//! The Pleiades (seven bodies, `tests/models/pleiades.lsl`, a model written pair by pair as a
//! user writes it) against the reference solution of the IVP test set (Mazzia & Magherini,
//! 16 digits at t = 3).

mod common;

use std::path::PathBuf;

use common::lasalle;
use lasalle::models::rigid_body::RigidBody;
use lasalle::{DriftBound, Driver, ExplicitRk, StepError};
use lasalle_testkit::PLEIADES_AT_3;

const PLEIADES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/models/pleiades.lsl");
/// The same Pleiades as a family, with the test set's point and preset.
const PLEIADES_MODEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/pleiades.lsl");
const ARENSTORF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/arenstorf.lsl");

fn out(name: &str) -> String {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("divergence")
        .join(name);
    dir.to_str().unwrap().to_string()
}

/// `lasalle run` with `args`, its summary.json and standard error.
fn run(name: &str, args: &[&str]) -> (Option<i32>, serde_json::Value, String) {
    let dir = out(name);
    let mut all = vec!["run"];
    all.extend(args);
    all.extend(["--format", "json", "--out", &dir]);
    let o = lasalle(&all);
    let summary = std::fs::read_to_string(format!("{dir}/summary.json")).expect("summary.json");
    (
        o.status.code(),
        serde_json::from_str(&summary).unwrap(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The largest distance from the reference, positions and velocities (p = m v, m_i = i).
fn distance_from_reference(summary: &serde_json::Value) -> f64 {
    let x: Vec<f64> = summary["final_state"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().expect("a finite final state"))
        .collect();
    (0..28)
        .map(|i| {
            let v = if i < 14 {
                x[i]
            } else {
                x[i] / ((i % 7) + 1) as f64
            };
            (v - PLEIADES_AT_3[i]).abs()
        })
        .fold(0.0, f64::max)
}

/// The run that used to diverge with the model's gains: split-taylor at rtol 1e-12 from a first step 5·10⁻⁴ to t = 3.
const SPLIT_TAYLOR: &[&str] = &[
    PLEIADES,
    "-m",
    "split-taylor",
    "--rtol",
    "1e-12",
    "--dt",
    "5e-4",
    "--t-end",
    "3",
];

#[test]
fn pleiades_split_taylor_default_gains_are_accurate() {
    let (code, s, stderr) = run("split-taylor", SPLIT_TAYLOR);
    assert_eq!(code, Some(0), "{stderr}");
    let d = distance_from_reference(&s);
    assert!(
        d < 1e-8,
        "split-taylor at t = 3 is {d:e} from the reference"
    );
    let h = s["invariant_errors"]["H"]["max"].as_f64().unwrap();
    assert!(h < 1e-6, "|ΔH| = {h:e}");
}

#[test]
fn pleiades_with_gains_too_stiff_for_the_step_fails_naming_what_diverged() {
    // the model file's gains (1 per invariant) with split-taylor's steps: h·k·L far past 2
    let args = [SPLIT_TAYLOR, &["--gains", "model"]].concat();
    let (code, s, stderr) = run("split-taylor-model-gains", &args);
    assert_eq!(code, Some(1), "a diverged run exits with 1: {stderr}");
    let failure = &s["failure"];
    let message = failure["message"].as_str().unwrap();
    assert!(message.contains("diverged at step"), "{message}");
    assert!(message.contains("invariant"), "{message}");
    assert!(failure["step"].as_u64().unwrap() > 0);
    let t = failure["t"].as_f64().unwrap();
    assert!(t > 0.0 && t < 3.0, "{t}");
    assert!(stderr.contains("diverged at step"), "{stderr}");
    // nothing of the diverged state is reported as a result
    let last_t = s["t_final"].as_f64().unwrap();
    assert!(
        last_t < t,
        "the last sample ({last_t}) is before the failure ({t})"
    );
    for (name, e) in s["invariant_errors"].as_object().unwrap() {
        assert!(e["max"].as_f64().is_some_and(f64::is_finite), "{name}: {e}");
    }
}

/// Steps of `method` on `model` with the default gains, from its summary.
fn steps(model: &str, method: &str, tol: &str, t_end: &str) -> u64 {
    let name = format!("steps-{}-{method}", model.replace(['/', '.'], "_"));
    let args = [
        model, "-m", method, "--rtol", tol, "--t-end", t_end, "--every", "1000000",
    ];
    let (code, s, stderr) = run(&name, &args);
    assert_eq!(code, Some(0), "{model} {method}: {stderr}");
    s["steps"].as_u64().unwrap()
}

/// The adaptive feedback methods' default gains follow the step: at most ~2× the plain
/// method's steps (the model file's gains took 312 288 steps against 1 010 on the Pleiades).
#[test]
fn adaptive_feedback_defaults_cost_about_the_plain_method() {
    let cases = [
        (PLEIADES, "3"),
        ("kepler", "70.2481"),
        ("rigid_body", "100"),
        ("perturbed_kepler", "200"),
        ("cr3bp", "100"),
        ("so3_type_iia", "10"),
    ];
    let mut report = Vec::new();
    for (model, t_end) in cases {
        for (plain, feedback, tol) in [
            ("dopri5", "feedback-dopri5", "1e-10"),
            ("taylor", "feedback-taylor", "1e-12"),
            ("taylor", "split-taylor", "1e-12"),
        ] {
            let p = steps(model, plain, tol, t_end);
            let f = steps(model, feedback, tol, t_end);
            let ratio = f as f64 / p as f64;
            report.push(format!("{model} {feedback}: {f} / {p} = {ratio:.2}"));
            assert!(ratio <= 2.0, "{}", report.join("\n"));
        }
    }
    println!("{}", report.join("\n"));
}

/// The runtime's check on its own: Euler on the free rigid body amplifies every rotation by
/// √(1 + ω²h²) a step; at h = 0.1 the energy passes ten times its scale within 10⁴ steps, and
/// the driver stops at the first check past the bound, with the step and the time.
#[test]
fn drift_bound_stops_the_driver() {
    let m = RigidBody::<f64>::default().prepare();
    let x0 = m.point_paper();
    let bound = DriftBound::new(&m, &x0, 10.0);
    let err = Driver::new(0.0, 1e4, 0.1)
        .divergence(5, |x: &[f64; 12]| bound.check(x))
        .run(&mut ExplicitRk::euler(), &m, &x0, &mut ())
        .unwrap_err();
    let StepError::Diverged {
        step, t, message, ..
    } = &err
    else {
        panic!("expected a divergence, got {err}");
    };
    assert_eq!(step % 5, 0, "checked every 5 steps: {err}");
    assert!((t - *step as f64 * 0.1).abs() < 1e-9, "{err}");
    assert!(message.starts_with("invariant "), "{message}");
    assert!(bound.check(&x0).is_none());
}

/// Duffing's cubic spring outside the saddles blows up in finite time: a non-finite state,
/// reported with its step, exit code 1.
#[test]
fn a_fixed_step_blow_up_exits_with_1_and_says_where() {
    let args = [
        "duffing", "-m", "rk4", "--dt", "0.01", "--t-end", "30", "--init", "10,0",
    ];
    let (code, s, stderr) = run("duffing-blow-up", &args);
    assert_eq!(code, Some(1), "{stderr}");
    let message = s["failure"]["message"].as_str().unwrap();
    assert!(message.contains("blow-up: non-finite"), "{message}");
    assert!(s["failure"]["step"].as_u64().is_some_and(|n| n > 0), "{s}");
}

/// The largest error of every invariant of a run (its summary's `invariant_errors`).
fn largest_errors(summary: &serde_json::Value) -> Vec<(String, f64)> {
    summary["invariant_errors"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(name, e)| (name.clone(), e["max"].as_f64().expect("a finite error")))
        .collect()
}

/// `feedback` is no worse than `plain`: every invariant's largest error within `factor` of
/// the plain method's (or below `floor`, rounding on an invariant the plain method keeps
/// exactly, as RK4 keeps a linear one), and the distance `orbit` within `factor` too.
fn no_worse(
    plain: &serde_json::Value,
    feedback: &serde_json::Value,
    orbit: impl Fn(&serde_json::Value) -> f64,
    factor: f64,
    floor: f64,
) -> String {
    let mut report = Vec::new();
    for ((name, p), (_, f)) in largest_errors(plain).iter().zip(largest_errors(feedback)) {
        report.push(format!("|Δ{name}| max: rk4 {p:.3e}, feedback-rk4 {f:.3e}"));
        assert!(f <= factor * p.max(floor), "{}", report.join("\n"));
    }
    let (p, f) = (orbit(plain), orbit(feedback));
    report.push(format!("orbit error: rk4 {p:.3e}, feedback-rk4 {f:.3e}"));
    assert!(f <= factor * p, "{}", report.join("\n"));
    report.join("\n")
}

/// The stability report of a fixed-step feedback run.
fn stability(summary: &serde_json::Value) -> (bool, f64, f64) {
    let s = &summary["stability"];
    (
        s["left_interval"].as_bool().expect("a stability report"),
        s["max_h_k_L"].as_f64().unwrap(),
        s["interval"].as_f64().unwrap(),
    )
}

/// The Pleiades with RK4 at h = 10⁻⁴ to t = 3: with the default (bounded) gains feedback-RK4
/// keeps each invariant's largest error and the distance from the test set's reference within
/// 4× plain RK4's, the momentum's within 10⁻¹⁰ (RK4 keeps a linear invariant to rounding; the
/// feedback step along ∇H moves it by h·k·(H − H₀)·Σᵢ ∂H/∂pᵢ until its own feedback pulls it
/// back); the model file's gains (1 each) leave RK4's stability interval in the close
/// encounters (h·k·L ≫ 2.785) and the run says so.
#[test]
fn pleiades_feedback_rk4_default_gains_are_no_worse_than_rk4() {
    let args = |method| {
        [
            PLEIADES_MODEL,
            "-m",
            method,
            "--dt",
            "1e-4",
            "--t-end",
            "3",
            "--every",
            "1",
        ]
    };
    let (code, rk4, stderr) = run("pleiades-rk4", &args("rk4"));
    assert_eq!(code, Some(0), "{stderr}");
    let (code, fb, stderr) = run("pleiades-feedback-rk4", &args("feedback-rk4"));
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    let report = no_worse(&rk4, &fb, distance_from_reference, 4.0, 1e-10 / 4.0);
    let (left, hkl, beta) = stability(&fb);
    assert!(!left && hkl <= 0.5 * beta * (1.0 + 1e-12), "{hkl} {beta}");
    assert!(fb["stability"]["capped_steps"].as_u64().unwrap() > 0);
    println!("{report}");

    let model_gains = [&args("feedback-rk4")[..], &["--gains", "model"]].concat();
    let (code, fb, stderr) = run("pleiades-feedback-rk4-model", &model_gains);
    let (left, hkl, beta) = stability(&fb);
    assert!(left && hkl > beta, "{hkl} {beta}");
    assert!(
        stderr.contains("warning: the feedback gains left"),
        "{stderr}"
    );
    let t = fb["stability"]["first_outside_t"].as_f64().unwrap();
    assert!(t > 0.0 && t < 3.0, "{t}");
    println!("--gains model: exit {code:?}, h·k·L up to {hkl:.3e}, first at t = {t}");
}

/// Arenstorf's periodic orbit (one period, RK4 at h = 10⁻⁴): with the default gains
/// feedback-RK4 keeps the Jacobi integral's largest error and the orbit's closure error below
/// RK4's; explicit gains too stiff for the step are reported.
#[test]
fn arenstorf_feedback_rk4_default_gains_are_no_worse_than_rk4() {
    let period = "17.0652165601579625588917206249";
    let args = |method| {
        [
            ARENSTORF, "-m", method, "--dt", "1e-4", "--t-end", period, "--every", "1",
        ]
    };
    let closure = |s: &serde_json::Value| {
        let x: Vec<f64> = s["final_state"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let x0 = [0.994, 0.0, 0.0, -2.001_585_106_379_082_5];
        x.iter()
            .zip(x0)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    };
    let (code, rk4, stderr) = run("arenstorf-rk4", &args("rk4"));
    assert_eq!(code, Some(0), "{stderr}");
    let (code, fb, stderr) = run("arenstorf-feedback-rk4", &args("feedback-rk4"));
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    let report = no_worse(&rk4, &fb, closure, 1.0, 0.0);
    assert!(!stability(&fb).0);
    println!("{report}");

    let stiff = [&args("feedback-rk4")[..], &["--gains", "1000"]].concat();
    let (_, fb, stderr) = run("arenstorf-feedback-rk4-stiff", &stiff);
    let (left, hkl, beta) = stability(&fb);
    assert!(left && hkl > beta, "{hkl} {beta}");
    assert!(
        stderr.contains("warning: the feedback gains left"),
        "{stderr}"
    );
}
