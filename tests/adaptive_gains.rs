//! The step-tracking gain of adaptive methods (`--gains step` / `auto`): with
//! h·k·L(x) = 2·tol^(1/p) before every step, feedback-DOPRI5 and feedback-Taylor take about as
//! many steps as the plain methods at the same tolerance (deterministic step counts, no timing)
//! and end with smaller invariant errors; with the paper's gains feedback-DOPRI5 needs more than
//! ten times the steps; and the feedback pulls a perturbed state back to the invariant set.
//! `lasalle experiment adaptive-gains` prints the full table (docs/performance.md).

use lasalle::exec::{Taylor, TaylorOptions};
use lasalle::{
    integrate, scaled_gains, step_gain_target, AdaptiveGain, Backend, DormandPrince, FeedbackField,
    Invariants, LoadedModel, ModelInfo, Parameters, StepError, Stepper,
};

mod common;
use common::lasalle;

/// The model file `models/<stem>.lsl` on the JIT and its `paper` point.
fn model(stem: &str) -> (LoadedModel, Vec<f64>) {
    let path = format!("{}/models/{stem}.lsl", env!("CARGO_MANIFEST_DIR"));
    let m = LoadedModel::load(&path, Backend::Jit).expect("the model loads");
    let x0 = m.point("paper").expect("a `paper` point");
    (m, x0)
}

/// max over the invariant blocks of |fᵢ(x) − fᵢ(x₀)|₂.
fn worst_error(m: &LoadedModel, x0: &[f64], x: &[f64]) -> f64 {
    let dim = m.invariant_dim();
    let (mut f0, mut f1) = (vec![0.0; dim], vec![0.0; dim]);
    m.invariants(&x0.to_vec(), &mut f0);
    m.invariants(&x.to_vec(), &mut f1);
    m.invariant_infos()
        .iter()
        .map(|b| {
            (b.slot.offset..b.slot.offset + b.slot.shape.len())
                .map(|i| (f1[i] - f0[i]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max)
}

/// (steps, final worst invariant error) of `stepper` on the plain field.
fn plain<S: Stepper<f64, Vec<f64>, LoadedModel>>(
    m: &LoadedModel,
    x0: &[f64],
    t_end: f64,
    stepper: &mut S,
) -> (u64, f64) {
    let x0 = x0.to_vec();
    let s = integrate(stepper, m, &x0, 0.0, t_end, 0.01, &mut ()).expect("plain run");
    (s.steps, worst_error(m, &x0, &s.x))
}

/// (steps, final worst invariant error) of `stepper` on X − ∇V with the step-tracking gain for
/// a method of order `order` at `tol`, starting at `start` with the target f(`x0`).
fn feedback<S>(
    m: &LoadedModel,
    x0: &[f64],
    start: &[f64],
    t_end: f64,
    (tol, order): (f64, u32),
    stepper: S,
) -> (u64, f64)
where
    S: for<'a> Stepper<f64, Vec<f64>, FeedbackField<'a, LoadedModel, Vec<f64>, Vec<f64>>>,
{
    let x0 = x0.to_vec();
    let unit = vec![1.0; m.gain_names().len()];
    let target = step_gain_target(2.0, tol, order);
    let gains = scaled_gains(m, &x0, &unit, 0.01, target).expect("gains at x0");
    let fb = FeedbackField::from_initial(m, &x0, gains);
    let mut st = AdaptiveGain::new(stepper, unit, 10).c(target).safety(1.0);
    let s = integrate(&mut st, &fb, &start.to_vec(), 0.0, t_end, 0.01, &mut ()).expect("run");
    (s.steps, worst_error(m, &x0, &s.x))
}

/// Steps at most 1.25× plain and final error no worse than plain.
fn check(what: &str, (p_steps, p_err): (u64, f64), (f_steps, f_err): (u64, f64)) {
    let ratio = f_steps as f64 / p_steps as f64;
    assert!(
        ratio <= 1.25,
        "{what}: feedback took {f_steps} steps, plain {p_steps} (ratio {ratio:.3})"
    );
    assert!(
        f_err <= p_err,
        "{what}: feedback error {f_err:e} > plain {p_err:e}"
    );
}

const TOL: f64 = 1e-10;
/// Kepler's period for the paper's orbit (a = 5): 2π·5^{3/2}.
const KEPLER_PERIOD: f64 = 70.248_147_310_071_6;

#[test]
fn step_gain_keeps_dopri5_steps() {
    for (stem, t_end) in [("rigid_body", 1000.0), ("kepler", 100.0 * KEPLER_PERIOD)] {
        let (m, x0) = model(stem);
        let dp = || DormandPrince::<f64, Vec<f64>>::with_tolerances(TOL, TOL);
        let p = plain(&m, &x0, t_end, &mut dp());
        let f = feedback(&m, &x0, &x0, t_end, (TOL, 5), dp());
        check(&format!("{stem} dopri5"), p, f);
    }
}

#[test]
fn step_gain_keeps_taylor_steps() {
    for (stem, t_end) in [("rigid_body", 1000.0), ("kepler", 100.0 * KEPLER_PERIOD)] {
        let (m, x0) = model(stem);
        let taylor = || m.taylor(TaylorOptions::with_tol(TOL)).expect("taylor");
        let mut t = taylor();
        let order = <Taylor<LoadedModel> as Stepper<f64, Vec<f64>, LoadedModel>>::order(&t);
        let p = plain(&m, &x0, t_end, &mut t);
        let f = feedback(&m, &x0, &x0, t_end, (TOL, order), taylor());
        check(&format!("{stem} taylor"), p, f);
    }
}

/// The contrast: the rigid body's paper gains (50, 100, 50) make feedback-DOPRI5 stiff.
#[test]
fn paper_gains_make_dopri5_stiff() {
    let (m, x0) = model("rigid_body");
    let dp = || DormandPrince::<f64, Vec<f64>>::with_tolerances(TOL, TOL);
    let (p_steps, _) = plain(&m, &x0, 1000.0, &mut dp());
    let fb = FeedbackField::from_initial(&m, &x0, m.default_gain_values().to_vec());
    let budget = 10 * p_steps;
    let r = lasalle::Driver::new(0.0, 1000.0, 0.01)
        .max_steps(budget)
        .run(&mut dp(), &fb, &x0, &mut ());
    assert!(
        matches!(r, Err(StepError::MaxSteps { .. })),
        "paper gains finished within {budget} steps: {r:?}"
    );
}

/// Started 1e-6 off the invariant set (v scaled by 1 + 1e-6), feedback-DOPRI5 and
/// feedback-Taylor with the step-tracking gain come back to tolerance level; plain DOPRI5 keeps
/// the offset.
#[test]
fn step_gain_pulls_a_perturbed_state_back() {
    let (m, x0) = model("kepler");
    let mut start = x0.clone();
    for v in &mut start[3..6] {
        *v *= 1.0 + 1e-6;
    }
    let t_end = 10.0 * KEPLER_PERIOD;
    let dp = || DormandPrince::<f64, Vec<f64>>::with_tolerances(TOL, TOL);
    let s = integrate(&mut dp(), &m, &start, 0.0, t_end, 0.01, &mut ()).expect("plain");
    let plain_err = worst_error(&m, &x0, &s.x);
    assert!(
        plain_err > 1e-7,
        "plain DOPRI5 lost the offset: {plain_err:e}"
    );
    let (_, f_err) = feedback(&m, &x0, &start, t_end, (TOL, 5), dp());
    assert!(f_err < 1e-9, "feedback-DOPRI5 did not pull back: {f_err:e}");
    let taylor = m.taylor(TaylorOptions::with_tol(TOL)).expect("taylor");
    let order = <Taylor<LoadedModel> as Stepper<f64, Vec<f64>, LoadedModel>>::order(&taylor);
    let (_, t_err) = feedback(&m, &x0, &start, t_end, (TOL, order), taylor);
    assert!(t_err < 1e-9, "feedback-Taylor did not pull back: {t_err:e}");
}

/// `lasalle run --gains auto` picks the step-tracking gain for feedback-DOPRI5 (the plain step
/// count within 1.25×, a smaller error) and `--format json` prints the summary with the CPU time.
#[test]
fn cli_auto_gains_and_json_summary() {
    let out = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("adaptive-gains-cli");
    let run = |method: &str, gains: &[&str]| -> serde_json::Value {
        let mut args = vec!["run", "rigid-body", "-m", method, "--rtol", "1e-10"];
        args.extend([
            "--atol", "1e-10", "--t-end", "200", "--format", "json", "--out",
        ]);
        args.push(out.to_str().unwrap());
        args.extend(gains);
        let o = lasalle(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_str(String::from_utf8_lossy(&o.stdout).trim()).expect("one JSON line")
    };
    let worst = |s: &serde_json::Value| {
        s["invariant_errors"]
            .as_object()
            .unwrap()
            .values()
            .map(|e| e["final"].as_f64().unwrap())
            .fold(0.0, f64::max)
    };
    let plain = run("dopri5", &[]);
    let fb = run("feedback-dopri5", &["--gains", "auto"]);
    let (p, f) = (
        plain["steps"].as_u64().unwrap(),
        fb["steps"].as_u64().unwrap(),
    );
    assert!(f as f64 <= 1.25 * p as f64, "steps {f} vs plain {p}");
    assert!(
        worst(&fb) < worst(&plain),
        "{} vs {}",
        worst(&fb),
        worst(&plain)
    );
    assert!(fb["cpu_seconds"].as_f64().unwrap() > 0.0);
    assert_eq!(fb["rtol"].as_f64(), Some(1e-10));
}

/// `--gains step` follows an adaptive method's step: refused, with a message, for fixed steps.
#[test]
fn cli_step_gains_need_an_adaptive_method() {
    let o = lasalle(&[
        "run",
        "kepler",
        "-m",
        "feedback-rk4",
        "--gains",
        "step",
        "-q",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("adaptive method"), "{err}");
}

/// `lasalle bench-eval` prints ns per state for 1 and 8 lanes, and per chained evaluation.
#[test]
fn cli_bench_eval_prints_ns_per_state() {
    let json = ["--format", "json"];
    let o = lasalle(
        &[
            &["bench-eval", "kepler", "--lanes", "1,8", "--repeat", "1"][..],
            &json,
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    for k in ["1", "8"] {
        let ns = v["ns_per_state"][k].as_f64().expect("a number");
        assert!(ns > 0.0 && ns.is_finite(), "{k}: {ns}");
    }
    let bad = lasalle(&["bench-eval", "kepler", "--lanes", "0"]);
    assert!(!bad.status.success());

    // chained: one lane, each call waiting for the last
    let o = lasalle(
        &[
            &["bench-eval", "kepler", "--chain", "--repeat", "1"][..],
            &json,
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    let ns = v["ns_per_state"]["1"].as_f64().expect("a number");
    assert!(ns > 0.0 && ns.is_finite(), "{ns}");
    assert!(v["what"].as_str().is_some_and(|w| w.contains("chained")));
    let bad = lasalle(&["bench-eval", "kepler", "--chain", "--lanes", "1,4"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--lanes 1"));
}
