//! Convergence order of every fixed-step stepper: the slope of log(error) against log(h) over
//! a step sweep on a smooth problem with a known solution must be within ±0.15 of the order.

#![allow(clippy::needless_range_loop)]

mod common;

use common::*;
use lasalle_runtime::*;

/// Kepler orbit with e = 0.5, a = 1, integrated over t ∈ [0, 2] (through periapsis passage
/// region, r from 0.5 to ~1.4): smooth and nonlinear, with the exact solution from Kepler's
/// equation.
const ORBIT: KeplerOrbit = KeplerOrbit { e: 0.5, rp: 0.5 };
const T_END: f64 = 2.0;

fn kepler_error<S: Stepper<f64, [f64; 6], Kepler>>(mut stepper: S, n: u64) -> f64 {
    let x0 = ORBIT.initial();
    let h = T_END / n as f64;
    let end = integrate(
        &mut stepper,
        &Kepler { mu: 1.0 },
        &x0,
        0.0,
        T_END,
        h,
        &mut (),
    )
    .unwrap();
    assert_eq!(end.steps, n);
    assert_eq!(end.t, T_END);
    dist(&end.x, &ORBIT.exact(T_END))
}

fn check_order(name: &str, order: f64, ns: &[u64], err: impl Fn(u64) -> f64) {
    let hs: Vec<f64> = ns.iter().map(|&n| T_END / n as f64).collect();
    let errs: Vec<f64> = ns.iter().map(|&n| err(n)).collect();
    let slope = fit_slope(&hs, &errs);
    eprintln!(
        "{name}: errors {:?} slope {slope:.4}",
        errs.iter().map(|e| format!("{e:.2e}")).collect::<Vec<_>>()
    );
    assert!(
        (slope - order).abs() <= 0.15,
        "{name}: observed order {slope:.3}, expected {order} (errors {errs:?})"
    );
}

#[test]
fn euler_is_first_order() {
    check_order("euler", 1.0, &[4000, 8000, 16000, 32000, 64000], |n| {
        kepler_error(ExplicitRk::euler(), n)
    });
}

#[test]
fn heun_is_second_order() {
    check_order("heun", 2.0, &[500, 1000, 2000, 4000, 8000], |n| {
        kepler_error(ExplicitRk::heun(), n)
    });
}

#[test]
fn rk4_is_fourth_order() {
    check_order("rk4", 4.0, &[100, 200, 400, 800, 1600], |n| {
        kepler_error(ExplicitRk::rk4(), n)
    });
}

#[test]
fn dopri5_tableau_is_fifth_order() {
    check_order("dopri5 fixed", 5.0, &[50, 100, 200, 400], |n| {
        kepler_error(ExplicitRk::dormand_prince54(), n)
    });
}

#[test]
fn stormer_verlet_a_and_b_are_second_order() {
    check_order(
        "stormer-verlet-a",
        2.0,
        &[250, 500, 1000, 2000, 4000],
        |n| kepler_error(StormerVerlet::a(), n),
    );
    check_order(
        "stormer-verlet-b",
        2.0,
        &[250, 500, 1000, 2000, 4000],
        |n| kepler_error(StormerVerlet::b(), n),
    );
}

/// The two Störmer–Verlet variants are different methods (A ≠ B after one step) but both
/// exact for q̈ = 0 and both time-reversible: stepping with −h undoes a step.
#[test]
fn stormer_verlet_variants_differ_and_are_reversible() {
    let k = Kepler { mu: 1.0 };
    let x0 = ORBIT.initial();
    let (mut xa, mut xb) = (x0, x0);
    StormerVerlet::a().step(&k, 0.0, &mut xa, 0.1).unwrap();
    StormerVerlet::b().step(&k, 0.0, &mut xb, 0.1).unwrap();
    assert!(dist(&xa, &xb) > 1e-4, "A and B coincide: {xa:?}");
    for mut sv in [StormerVerlet::a(), StormerVerlet::b()] {
        let mut x = x0;
        Stepper::<f64, [f64; 6], Kepler>::step(&mut sv, &k, 0.0, &mut x, 0.1).unwrap();
        Stepper::<f64, [f64; 6], Kepler>::step(&mut sv, &k, 0.1, &mut x, -0.1).unwrap();
        assert!(
            dist(&x, &x0) < 1e-14,
            "{:?} not reversible: {x:?}",
            sv.variant
        );
    }
}

/// Pendulum: Störmer–Verlet A is second order on a second problem too (reference: DOPRI5 at
/// rtol = 1e-13).
#[test]
fn stormer_verlet_pendulum() {
    let x0 = [2.0, 0.0];
    let t_end = 5.0;
    let mut dp = DormandPrince::with_tolerances(1e-13, 1e-13);
    let reference = integrate(&mut dp, &pendulum(), &x0, 0.0, t_end, 0.0, &mut ())
        .unwrap()
        .x;
    let ns = [200u64, 400, 800, 1600];
    let hs: Vec<f64> = ns.iter().map(|&n| t_end / n as f64).collect();
    let errs: Vec<f64> = ns
        .iter()
        .map(|&n| {
            let end = integrate(
                &mut StormerVerlet::a(),
                &pendulum(),
                &x0,
                0.0,
                t_end,
                t_end / n as f64,
                &mut (),
            )
            .unwrap();
            dist(&end.x, &reference)
        })
        .collect();
    let slope = fit_slope(&hs, &errs);
    assert!(
        (slope - 2.0).abs() <= 0.15,
        "slope {slope}, errors {errs:?}"
    );
}

/// Three-rotation splitting of the free rigid body: order 2 against a DOPRI5 reference
/// (rtol = atol = 1e-13) for 𝕀 = diag(3, 2, 1), R(0) = I, Ω(0) = (1, 1, 1) on t ∈ [0, 5].
#[test]
fn rigid_body_splitting_is_second_order() {
    let inertia = [3.0, 2.0, 1.0];
    let body = rigid_body(inertia);
    let x0 = RigidBody::initial();
    let t_end = 5.0;
    let mut dp = DormandPrince::with_tolerances(1e-13, 1e-13);
    let reference = integrate(&mut dp, &body, &x0, 0.0, t_end, 0.0, &mut ())
        .unwrap()
        .x;
    let ns = [250u64, 500, 1000, 2000, 4000];
    let hs: Vec<f64> = ns.iter().map(|&n| t_end / n as f64).collect();
    let errs: Vec<f64> = ns
        .iter()
        .map(|&n| {
            let mut s = RigidBodySplitting::new(inertia);
            let end = integrate(&mut s, &body, &x0, 0.0, t_end, t_end / n as f64, &mut ()).unwrap();
            dist(&end.x, &reference)
        })
        .collect();
    let slope = fit_slope(&hs, &errs);
    eprintln!(
        "splitting: errors {:?} slope {slope:.4}",
        errs.iter().map(|e| format!("{e:.2e}")).collect::<Vec<_>>()
    );
    assert!(
        (slope - 2.0).abs() <= 0.15,
        "slope {slope}, errors {errs:?}"
    );
}

/// RK4 on the harmonic oscillator: the fixed-step driver hits t_end exactly, also with a
/// step that does not divide the interval (last step shortened).
#[test]
fn driver_hits_end_time_with_partial_last_step() {
    let end = integrate(
        &mut ExplicitRk::rk4(),
        &Oscillator,
        &[1.0, 0.0],
        0.0,
        1.0,
        0.3,
        &mut (),
    )
    .unwrap();
    assert_eq!(end.steps, 4);
    assert_eq!(end.t, 1.0);
    assert!((end.x[0] - 1f64.cos()).abs() < 1e-3);
    // many steps: t = t0 + n h, no accumulation
    let mut last_t = 0.0;
    let end = integrate(
        &mut ExplicitRk::euler(),
        &Oscillator,
        &[1.0, 0.0],
        0.0,
        10.0,
        1e-4,
        &mut |_s: u64, t: f64, _x: &[f64; 2]| {
            last_t = t;
            Control::Continue
        },
    )
    .unwrap();
    assert_eq!(end.steps, 100_000);
    assert_eq!(last_t, 10.0);
}

/// The compositions of Störmer–Verlet have the orders 4, 6 and 8 their weights promise (the
/// eighth-order sweep starts where the error is asymptotic and stays above the rounding floor).
#[test]
fn compositions_have_orders_4_6_8() {
    check_order("symplectic4", 4.0, &[100, 200, 400, 800, 1600], |n| {
        kepler_error(Composition::order4(), n)
    });
    check_order("symplectic6", 6.0, &[40, 60, 80, 120, 160], |n| {
        kepler_error(Composition::order6(), n)
    });
    check_order("symplectic8", 8.0, &[50, 60, 80, 100, 120], |n| {
        kepler_error(Composition::order8(), n)
    });
    for c in [
        Composition::<[f64; 6]>::order4(),
        Composition::order6(),
        Composition::order8(),
    ] {
        let sum: f64 = c.weights().iter().sum();
        assert!((sum - 1.0).abs() < 1e-15, "{sum}");
    }
}

/// Symplectic: over 10⁶ steps (≈ 2·10⁴ periods of the e = 0.5 orbit) the energy error stays
/// bounded — its largest value in the second half is no larger than in the first — while a
/// non-symplectic method of the same order (RK4) drifts.
#[test]
fn compositions_keep_the_energy_bounded_over_a_million_steps() {
    let k = Kepler { mu: 1.0 };
    let x0 = ORBIT.initial();
    let e0 = k.energy(&x0);
    let worst = |mut stepper: Box<dyn Stepper<f64, [f64; 6], Kepler>>, h: f64| {
        let (mut x, mut halves) = (x0, [0.0f64; 2]);
        for n in 0..1_000_000u64 {
            stepper.step(&k, n as f64 * h, &mut x, h).unwrap();
            let half = usize::from(n >= 500_000);
            halves[half] = halves[half].max((k.energy(&x) - e0).abs());
        }
        halves
    };
    for (name, stepper, h) in [
        (
            "symplectic4",
            Box::new(Composition::order4()) as Box<dyn Stepper<_, _, _>>,
            0.05,
        ),
        ("symplectic6", Box::new(Composition::order6()), 0.05),
        ("symplectic8", Box::new(Composition::order8()), 0.05),
    ] {
        let [first, second] = worst(stepper, h);
        eprintln!("{name}: max |ΔE| {first:.2e} (first half), {second:.2e} (second half)");
        assert!(
            second <= 1.5 * first && second < 1e-4,
            "{name}: {first:e} → {second:e}"
        );
    }
    let [first, second] = worst(Box::new(ExplicitRk::rk4()), 0.05);
    eprintln!("rk4: max |ΔE| {first:.2e} (first half), {second:.2e} (second half)");
    assert!(second > 1.8 * first, "RK4 drifts: {first:e} → {second:e}");
}
