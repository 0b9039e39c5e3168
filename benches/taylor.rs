//! The Taylor method (tolerance 1e-15, Jorba–Zou order 19) on two long runs, with
//! the emitted kernels of the compiled models and with the interpreted tape of the same models
//! loaded from their files: CPU time per run (the process's CPU time over as many runs as fill
//! `MIN_CPU`, divided by their number), steps, and the largest final invariant error ‖f(x) − f(x₀)‖∞ over all components.
//!
//! ```sh
//! cargo bench --bench taylor
//! ```
//!
//! - Kepler, e = 0.8 (point `paper`: r = 1, v = √1.8, a = 5), 1000 periods (t = 2000π·5^{3/2});
//! - the free rigid body (point `paper`), t = 1000.

use std::time::Duration;

use lasalle::models::{kepler::Kepler, rigid_body::RigidBody};
use lasalle::{
    integrate, Backend, Invariants, LoadedModel, Parameters, Stepper, TaylorOptions, MODEL_FILES,
};

const MIN_CPU: Duration = Duration::from_millis(500);

/// The CPU time of this process (user + system), from `/proc/self/stat`; the wall clock
/// elsewhere.
fn cpu_time() -> Duration {
    let ticks = std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            // fields after the command name (which is in parentheses): utime and stime are 14, 15
            let rest = &s[s.rfind(')')? + 2..];
            let f: Vec<&str> = rest.split_whitespace().collect();
            Some(f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?)
        });
    match ticks {
        // the kernel's USER_HZ is 100 on every Linux architecture Rust supports
        Some(t) => Duration::from_millis(t * 10),
        None => std::time::UNIX_EPOCH.elapsed().unwrap_or_default(),
    }
}

/// The mean CPU time of runs of `run` filling `MIN_CPU` (at least one), and the last result.
fn timed<R>(mut run: impl FnMut() -> R) -> (Duration, R) {
    let start = cpu_time();
    let mut runs = 0u32;
    loop {
        let out = run();
        runs += 1;
        let spent = cpu_time() - start;
        if spent >= MIN_CPU {
            return (spent / runs, out);
        }
    }
}

fn loaded(stem: &str) -> LoadedModel {
    let (_, text) = MODEL_FILES
        .iter()
        .find(|(s, _)| *s == stem)
        .expect("a model of models/");
    LoadedModel::from_source(&format!("models/{stem}.lsl"), text, Backend::Interpreter)
        .expect("loads")
}

fn max_error(f0: &[f64], f1: &[f64]) -> f64 {
    f0.iter()
        .zip(f1)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

fn report(what: &str, kernels: &str, (time, (steps, err)): (Duration, (u64, f64))) {
    println!(
        "{what:<26} {kernels:<12} {:>9.4} s {steps:>9} steps  max |f − f0| {err:.2e}",
        time.as_secs_f64()
    );
}

/// The order of a Taylor integrator on its model's own field.
fn order_of<M, const N: usize>(taylor: &lasalle::Taylor<M>) -> u32
where
    lasalle::Taylor<M>: Stepper<f64, [f64; N], M>,
{
    Stepper::<f64, [f64; N], M>::order(taylor)
}

macro_rules! run {
    ($what:expr, $ty:ty, $stem:literal, $t_end:expr) => {{
        let opts = TaylorOptions::with_tol(1e-15);
        let sys = <$ty>::default().prepare();
        let x0 = sys.point_paper();
        let mut f0 = [0.0; <$ty>::M];
        sys.invariants(&x0, &mut f0);
        let compiled = timed(|| {
            let mut taylor = sys.taylor(opts).expect("kernels");
            let end = integrate(&mut taylor, &sys, &x0, 0.0, $t_end, 0.0, &mut ()).expect("run");
            let mut f1 = [0.0; <$ty>::M];
            sys.invariants(&end.x, &mut f1);
            (end.steps, max_error(&f0, &f1))
        });
        report($what, "emitted", compiled);
        let m = loaded($stem);
        let x0 = m.point("paper").expect("point paper");
        let tape = timed(|| {
            let mut taylor = m.taylor(opts).expect("kernels");
            let end = integrate(&mut taylor, &m, &x0, 0.0, $t_end, 0.0, &mut ()).expect("run");
            let (mut a, mut b) = (vec![0.0; f0.len()], vec![0.0; f0.len()]);
            m.invariants(&x0, &mut a);
            m.invariants(&end.x, &mut b);
            (end.steps, max_error(&a, &b))
        });
        report($what, "tape", tape);
        let order = order_of::<_, { <$ty>::N }>(&sys.taylor(opts).expect("kernels"));
        println!("{:<26} order {order}", "");
    }};
}

fn main() {
    // `cargo bench` passes `--bench`; any other argument selects nothing here
    let period = 2.0 * std::f64::consts::PI * 5f64.powf(1.5);
    run!(
        "kepler e=0.8, 1000 periods",
        Kepler<f64>,
        "kepler",
        1000.0 * period
    );
    run!("rigid body, t = 1000", RigidBody<f64>, "rigid_body", 1000.0);
}
