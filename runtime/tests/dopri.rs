//! Adaptive Dormand–Prince 5(4): tolerance proportionality, dense output, FSAL cost,
//! controller behaviour, on the e = 0.8 Kepler orbit of Chang et al. §4.2 (exact solution from
//! Kepler's equation).

#![allow(clippy::needless_range_loop)]

mod common;

use common::*;
use lasalle_runtime::*;

/// x(0) = (1, 0, 0), v(0) = (0, √1.8, 0): e = 0.8, a = 5, T = 2π·5^{3/2} ≈ 70.2481.
const ORBIT: KeplerOrbit = KeplerOrbit { e: 0.8, rp: 1.0 };

fn one_period(tol: f64) -> (f64, Summary<f64, [f64; 6]>) {
    let x0 = ORBIT.initial();
    let t = ORBIT.period();
    let mut dp = DormandPrince::with_tolerances(tol, tol);
    let end = integrate(&mut dp, &Kepler { mu: 1.0 }, &x0, 0.0, t, 0.0, &mut ()).unwrap();
    assert_eq!(end.t, t);
    (dist(&end.x, &ORBIT.exact(t)), end)
}

#[test]
fn period_is_the_papers() {
    assert!((ORBIT.period() - 70.2481).abs() < 1e-4);
    let x = ORBIT.exact(ORBIT.period());
    assert!(dist(&x, &ORBIT.initial()) < 1e-12);
}

/// The global error after one period shrinks in proportion to the tolerance. The tolerance
/// is local (per step), and on this eccentric orbit the global error at the periapsis
/// (speed 3) is ~2–3·10³ times it (measured: 2.8e-3, 2.7e-5, 1.9e-7 for tol 1e-6, 1e-8,
/// 1e-10); the bound 1e4·tol leaves room for round-off but fails on a wrong controller.
#[test]
fn meets_tolerance_on_kepler() {
    let mut prev = f64::INFINITY;
    for tol in [1e-6, 1e-8, 1e-10] {
        let (err, end) = one_period(tol);
        eprintln!(
            "tol {tol:e}: error {err:.3e}, steps {}, rejections {}, evaluations {}",
            end.steps, end.rejections, end.evaluations
        );
        assert!(err < 1e4 * tol, "tol {tol:e}: error {err:e}");
        assert!(err < prev / 10.0, "error does not decrease with tol");
        prev = err;
        // FSAL: 6 evaluations per attempted step (the first stage of the first step comes
        // from the initial step selection, whose 2 evaluations are not counted)
        let attempts = end.steps + end.rejections;
        assert_eq!(end.evaluations, 6 * attempts);
    }
}

/// The paper's reference setting rtol = atol = 1e-10 keeps energy and A to ~1e-9 over one
/// period of the e = 0.8 orbit.
#[test]
fn invariants_at_tight_tolerance() {
    let (_, end) = one_period(1e-10);
    let k = Kepler { mu: 1.0 };
    let x0 = ORBIT.initial();
    assert!((k.energy(&end.x) - k.energy(&x0)).abs() < 1e-9);
    let (mut f, mut f0) = ([0.0; 6], [0.0; 6]);
    k.invariants(&end.x, &mut f);
    k.invariants(&x0, &mut f0);
    assert!(dist(&f, &f0) < 1e-8, "|Δf| = {:e}", dist(&f, &f0));
}

/// Dense output at 200 times across one period is as accurate as the steps themselves
/// (4th-order interpolant, HNW I §II.6).
#[test]
fn dense_output_is_accurate() {
    let x0 = ORBIT.initial();
    let t_end = ORBIT.period();
    let times: Vec<f64> = (0..=200).map(|i| t_end * i as f64 / 200.0).collect();
    for tol in [1e-7, 1e-10] {
        let mut dp = DormandPrince::with_tolerances(tol, tol);
        let mut worst = 0.0f64;
        let mut count = 0;
        let end = Driver::new(0.0, t_end, 0.0)
            .run_dense(
                &mut dp,
                &Kepler { mu: 1.0 },
                &x0,
                &times,
                &mut |i: u64, t: f64, x: &[f64; 6]| {
                    assert_eq!(t, times[i as usize]);
                    worst = worst.max(dist(x, &ORBIT.exact(t)));
                    count += 1;
                    Control::Continue
                },
            )
            .unwrap();
        eprintln!(
            "dense tol {tol:e}: worst error {worst:.3e} over {count} outputs, {} steps",
            end.steps
        );
        assert_eq!(count, times.len());
        assert!(
            end.steps < times.len() as u64 || tol < 1e-8,
            "steps not independent of outputs"
        );
        // as large as the step errors (see `meets_tolerance_on_kepler`), not larger
        assert!(
            worst < 1e4 * tol,
            "tol {tol:e}: dense output error {worst:e}"
        );
    }
}

/// The continuous extension is 4th order: its local error at the midpoint of a single step
/// from the exact initial value is O(h⁵).
#[test]
fn dense_output_local_order() {
    let hs = [0.4, 0.2, 0.1, 0.05];
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            // loose tolerances: the step is always accepted
            let mut dp = DormandPrince::<f64, [f64; 2]>::with_tolerances(1.0, 1.0);
            let mut x = [1.0, 0.0];
            let out = dp.step(&Oscillator, 0.0, &mut x, h).unwrap();
            assert_eq!(out.h_taken, h);
            let mut y = [0.0; 2];
            assert!(dp.interpolate(0.5 * h, &mut y));
            dist(&y, &[(0.5 * h).cos(), -(0.5 * h).sin()])
        })
        .collect();
    let slope = fit_slope(&hs, &errs);
    eprintln!("dense local errors {errs:?} slope {slope:.3}");
    assert!((slope - 5.0).abs() <= 0.15, "slope {slope}");
}

/// Interpolation reproduces both ends of the last step and refuses times outside it.
#[test]
fn dense_interval_ends() {
    let mut dp = DormandPrince::<f64, [f64; 2]>::with_tolerances(1e-8, 1e-8);
    let mut x = [1.0, 0.0];
    let x_old = x;
    let out = dp.step(&Oscillator, 0.0, &mut x, 0.1).unwrap();
    let (t0, t1) = dp.dense_interval().unwrap();
    assert_eq!((t0, t1), (0.0, out.h_taken));
    let mut y = [0.0; 2];
    assert!(dp.interpolate(t0, &mut y));
    assert!(dist(&y, &x_old) < 1e-15);
    assert!(dp.interpolate(t1, &mut y));
    assert!(dist(&y, &x) < 1e-15);
    assert!(!dp.interpolate(t1 + 0.05, &mut y));
    // several times at once (a pass of four and one) are the times one by one, bitwise
    let ts: Vec<f64> = [0.0, 0.2, 0.5, 0.9, 1.0]
        .iter()
        .map(|f| t0 + f * (t1 - t0))
        .collect();
    let mut many = [[0.0; 2]; 5];
    assert!(dp.interpolate_many(&ts, &mut many));
    for (&t, m) in ts.iter().zip(&many) {
        assert!(dp.interpolate(t, &mut y));
        assert_eq!(y.map(f64::to_bits), m.map(f64::to_bits), "t = {t}");
    }
    assert!(!dp.interpolate_many(&[t0, t1 + 0.05], &mut many[..2]));
}

/// The controller takes large steps on an easy problem and small ones near periapsis, and
/// the step size proposal grows by at most fac_max.
#[test]
fn controller_adapts_step() {
    let x0 = ORBIT.initial();
    let k = Kepler { mu: 1.0 };
    let mut dp = DormandPrince::with_tolerances(1e-8, 1e-8);
    let mut h = dp.initial_step(&k, 0.0, &x0, 70.0).unwrap();
    assert!(h > 1e-6 && h < 1.0, "initial step {h}");
    let mut x = x0;
    let mut t = 0.0;
    let (mut hmin, mut hmax) = (f64::INFINITY, 0.0f64);
    while t < ORBIT.period() / 2.0 {
        let out = dp.step(&k, t, &mut x, h).unwrap();
        assert!(out.h_next <= 10.0 * out.h_taken * (1.0 + 1e-12));
        t += out.h_taken;
        hmin = hmin.min(out.h_taken);
        hmax = hmax.max(out.h_taken);
        h = out.h_next;
    }
    eprintln!("h in [{hmin:.3e}, {hmax:.3e}]");
    assert!(hmax / hmin > 20.0, "no adaptation: h in [{hmin}, {hmax}]");
}

/// An explicit initial step is honoured and state changes between calls invalidate the FSAL
/// stage (the next step recomputes k₁, so results match a fresh stepper).
#[test]
fn fsal_cache_is_invalidated_by_outside_changes() {
    let k = Kepler { mu: 1.0 };
    let mut dp = DormandPrince::with_tolerances(1e-9, 1e-9);
    let mut x = ORBIT.initial();
    dp.step(&k, 0.0, &mut x, 0.01).unwrap();
    x[4] += 1e-3; // an outside change (e.g. a projection)
    let mut x_fresh = x;
    let a = dp.step(&k, 0.01, &mut x, 0.01).unwrap();
    let mut fresh = DormandPrince::with_tolerances(1e-9, 1e-9);
    let b = fresh.step(&k, 0.01, &mut x_fresh, 0.01).unwrap();
    assert_eq!(a.evaluations, 7);
    assert_eq!(b.evaluations, 7);
    assert_eq!(x, x_fresh);
}
