//! The standard projection method (GNI §IV.4, Algorithm 4.2) on Kepler (A·L ≡ 0 makes
//! Df Dfᵀ singular) and on the free rigid body (RᵀR − I has 9 components, 6 independent).

#![allow(clippy::needless_range_loop)]

mod common;

use common::*;
use lasalle_runtime::*;

/// Projected Euler keeps |f(x) − f(x₀)| ≤ tol at every step while plain Euler drifts.
#[test]
fn projected_euler_on_kepler_stays_within_tolerance() {
    let k = Kepler { mu: 1.0 };
    let orbit = KeplerOrbit { e: 0.8, rp: 1.0 };
    let x0 = orbit.initial();
    let h = 0.005;
    let t_end = 2.0 * orbit.period();
    for tol in [1e-8, 0.005] {
        let mut proj = Projection::from_initial(ExplicitRk::euler(), &k, &x0, tol);
        let mut worst = 0.0f64;
        let end = integrate(
            &mut proj,
            &k,
            &x0,
            0.0,
            t_end,
            h,
            &mut |_s: u64, _t: f64, x: &[f64; 6]| {
                let mut f = [0.0; 6];
                k.invariants(x, &mut f);
                let mut f0 = [0.0; 6];
                k.invariants(&x0, &mut f0);
                worst = worst.max(dist(&f, &f0));
                Control::Continue
            },
        )
        .unwrap();
        eprintln!(
            "tol {tol:e}: worst |Δf| = {worst:.3e}, {} steps, {} projections, {} Newton iterations",
            end.steps,
            proj.projections(),
            proj.newton_iterations()
        );
        assert!(worst <= tol, "tol {tol:e}: |Δf| reached {worst:e}");
        assert!(proj.projections() > 0);
        // the stepper reports its counters itself, for the front ends' summaries
        assert_eq!(
            Stepper::<f64, [f64; 6], Kepler>::counters(&proj),
            [
                ("newton_iterations", proj.newton_iterations() as f64),
                ("projected_steps", proj.projections() as f64)
            ]
        );
    }
    // plain Euler for comparison
    let mut rec = Recorder::new(&k, &x0, 1000, 100_000);
    integrate(&mut ExplicitRk::euler(), &k, &x0, 0.0, t_end, h, &mut rec).unwrap();
    let a = rec.block_index("A").unwrap();
    eprintln!("plain Euler: max |ΔA| = {:.3e}", rec.max_error(a));
    assert!(rec.max_error(a) > 1e-2); // measured 2.45e-2
}

/// Rigid body, Euler + projection with tol 1e-10: orthogonality, energy and π all kept,
/// although the 9 constraint rows are pairwise equal (rank-deficient Df Dfᵀ).
#[test]
fn projected_euler_on_rigid_body() {
    let body = rigid_body([3.0, 2.0, 1.0]);
    let x0 = RigidBody::initial();
    let tol = 1e-10;
    let mut proj = Projection::from_initial(ExplicitRk::euler(), &body, &x0, tol);
    let mut rec = Recorder::new(&body, &x0, 1, 20_002);
    let end = integrate(&mut proj, &body, &x0, 0.0, 20.0, 1e-3, &mut rec).unwrap();
    let names: Vec<&str> = rec.blocks().iter().map(|b| b.0).collect();
    assert_eq!(names, ["C", "E", "pi"]);
    for b in 0..3 {
        assert!(
            rec.max_error(b) <= tol,
            "{}: {:e}",
            names[b],
            rec.max_error(b)
        );
    }
    assert!(RigidBody::orthogonality_error(&end.x) <= tol);
    eprintln!(
        "rigid body: {} Newton iterations over {} steps ({} projections)",
        proj.newton_iterations(),
        end.steps,
        proj.projections()
    );
    // plain Euler drifts in all three
    let mut rec = Recorder::new(&body, &x0, 100, 300);
    integrate(
        &mut ExplicitRk::euler(),
        &body,
        &x0,
        0.0,
        20.0,
        1e-3,
        &mut rec,
    )
    .unwrap();
    for b in 0..3 {
        assert!(
            rec.max_error(b) > 1e-3,
            "plain Euler {}: {:e}",
            names[b],
            rec.max_error(b)
        );
    }
}

/// Projection also wraps higher-order and adaptive steppers.
#[test]
fn projection_wraps_any_stepper() {
    let k = Kepler { mu: 1.0 };
    let orbit = KeplerOrbit { e: 0.5, rp: 0.5 };
    let x0 = orbit.initial();
    let mut proj =
        Projection::from_initial(DormandPrince::with_tolerances(1e-6, 1e-6), &k, &x0, 1e-12);
    assert!(Stepper::<f64, [f64; 6], Kepler>::is_adaptive(&proj));
    let end = integrate(&mut proj, &k, &x0, 0.0, 10.0, 0.0, &mut ()).unwrap();
    let (mut f, mut f0) = ([0.0; 6], [0.0; 6]);
    k.invariants(&end.x, &mut f);
    k.invariants(&x0, &mut f0);
    assert!(dist(&f, &f0) <= 1e-12);
    assert!(dist(&end.x, &orbit.exact(10.0)) < 1e-3);
}

/// Non-convergence is an error with the time and the state, not a silent pass.
#[test]
fn projection_failure_is_reported() {
    let k = Kepler { mu: 1.0 };
    let x0 = KeplerOrbit { e: 0.8, rp: 1.0 }.initial();
    // an unreachable target: |A|² = μ² + 2E|L|² cannot hold with these values
    let target = [0.0, 0.0, 1.0, 5.0, 0.0, 0.0];
    let mut proj = Projection::new(ExplicitRk::euler(), target, 1e-10).max_iterations(20);
    let err = integrate(&mut proj, &k, &x0, 0.0, 1.0, 0.01, &mut ()).unwrap_err();
    eprintln!("{err}");
    match err {
        StepError::ProjectionNotConverged {
            t,
            iterations,
            state,
            ..
        } => {
            assert!((t - 0.01).abs() < 1e-15);
            assert!(iterations <= 20);
            assert_eq!(state.len(), 6);
        }
        other => panic!("unexpected error {other}"),
    }
}
