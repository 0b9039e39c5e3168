//! The driver fails loudly (blow-up, guard, step budget, invalid input) with the time and
//! state; observers, recorders and CSV output.

#![allow(clippy::needless_range_loop)]

mod common;

use common::*;
use lasalle_runtime::*;

/// ẋ = x² from x(0) = 1 blows up at t = 1; explicit Euler overflows shortly after.
struct Blow;
impl Field<f64, [f64; 1]> for Blow {
    fn field(&self, x: &[f64; 1], dx: &mut [f64; 1]) {
        dx[0] = x[0] * x[0];
    }
}

#[test]
fn blow_up_reports_time_and_state() {
    let err = integrate(
        &mut ExplicitRk::euler(),
        &Blow,
        &[1.0],
        0.0,
        5.0,
        0.01,
        &mut (),
    )
    .unwrap_err();
    let msg = err.to_string();
    eprintln!("{msg}");
    match &err {
        StepError::NonFinite { t, h, state, .. } => {
            assert!(*t > 1.0 && *t < 5.0, "t = {t}");
            assert_eq!(*h, 0.01);
            assert_eq!(state.len(), 1);
        }
        other => panic!("unexpected {other}"),
    }
    assert!(msg.starts_with("blow-up: non-finite"));
    assert!(msg.contains("t = "));
}

/// Adaptive DOPRI5 on the same problem cannot pass the singularity: it fails with a step-size
/// error near t = 1 instead of returning garbage.
#[test]
fn adaptive_blow_up_fails_near_singularity() {
    let mut dp = DormandPrince::with_tolerances(1e-8, 1e-8);
    let err = integrate(&mut dp, &Blow, &[1.0], 0.0, 2.0, 0.0, &mut ()).unwrap_err();
    eprintln!("{err}");
    let t = err.time().unwrap();
    assert!((t - 1.0).abs() < 1e-3, "t = {t}: {err}");
    assert!(matches!(
        err,
        StepError::StepSizeTooSmall { .. }
            | StepError::TooManyRejections { .. }
            | StepError::NonFinite { .. }
    ));
}

/// A Kepler collision orbit (v₀ = 0 falls into the origin at t = π/(2√2) for r₀ = 1, μ = 1)
/// is caught by a guard on |x|.
#[test]
fn guard_catches_kepler_collision() {
    let k = Kepler { mu: 1.0 };
    let x0 = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let err = Driver::new(0.0, 2.0, 1e-4)
        .guard(1, |x: &[f64; 6]| {
            let r = norm(&x[0..3]);
            (r < 5e-2).then(|| format!("near collision: |x| = {r:.3e}"))
        })
        .run(&mut ExplicitRk::rk4(), &k, &x0, &mut ())
        .unwrap_err();
    eprintln!("{err}");
    let t_collision = std::f64::consts::PI / (2.0 * 2f64.sqrt());
    match &err {
        StepError::Guard {
            t, message, state, ..
        } => {
            assert!(*t < t_collision && *t > t_collision - 0.01, "t = {t}");
            assert!(message.contains("near collision"));
            assert!(norm(&state[0..3]) < 5e-2);
        }
        other => panic!("unexpected {other}"),
    }
}

#[test]
fn max_steps_and_invalid_input() {
    let err = Driver::new(0.0, 1.0, 0.01)
        .max_steps(10)
        .run(&mut ExplicitRk::euler(), &Oscillator, &[1.0, 0.0], &mut ())
        .unwrap_err();
    assert!(
        matches!(err, StepError::MaxSteps { steps: 10, .. }),
        "{err}"
    );
    assert!((err.time().unwrap() - 0.1).abs() < 1e-12);
    for (t0, t1, h) in [
        (0.0, 1.0, 0.0),
        (0.0, 1.0, -0.1),
        (1.0, 0.0, 0.1),
        (0.0, f64::NAN, 0.1),
    ] {
        let err = integrate(
            &mut ExplicitRk::euler(),
            &Oscillator,
            &[1.0, 0.0],
            t0,
            t1,
            h,
            &mut (),
        )
        .unwrap_err();
        assert!(matches!(err, StepError::InvalidInput(_)), "{err}");
    }
    let err = integrate(
        &mut ExplicitRk::euler(),
        &Oscillator,
        &[f64::NAN, 0.0],
        0.0,
        1.0,
        0.1,
        &mut (),
    )
    .unwrap_err();
    assert!(matches!(err, StepError::NonFinite { .. }));
}

#[test]
fn observers_stride_stop_and_recorder() {
    // Stride: steps 0, 3, 6, 9 and the final step 10
    let mut seen = Vec::new();
    let mut obs = Stride::new(
        |n: u64, _t: f64, _x: &[f64; 2]| {
            seen.push(n);
            Control::Continue
        },
        3,
    );
    integrate(
        &mut ExplicitRk::euler(),
        &Oscillator,
        &[1.0, 0.0],
        0.0,
        1.0,
        0.1,
        &mut obs,
    )
    .unwrap();
    assert_eq!(seen, [0, 3, 6, 9, 10]);

    // StopWhen: stop when q < 0 (after a quarter period)
    let mut obs = StopWhen::new((), |_t: f64, x: &[f64; 2]| x[0] < 0.0);
    let end = integrate(
        &mut ExplicitRk::rk4(),
        &Oscillator,
        &[1.0, 0.0],
        0.0,
        10.0,
        0.01,
        &mut obs,
    )
    .unwrap();
    assert!(end.stopped_by_observer);
    assert!(
        (end.t - std::f64::consts::FRAC_PI_2).abs() < 0.011,
        "t = {}",
        end.t
    );

    // Recorder: capacity reserved up front is not exceeded, errors per invariant block
    let k = Kepler { mu: 1.0 };
    let x0 = KeplerOrbit { e: 0.5, rp: 0.5 }.initial();
    let n = 1000;
    let cap = sample_capacity(n, 7);
    let mut rec = Recorder::new(&k, &x0, 7, cap);
    let (p_t, p_x, p_e) = (rec.t.as_ptr(), rec.x.as_ptr(), rec.errors.as_ptr());
    integrate(
        &mut ExplicitRk::rk4(),
        &k,
        &x0,
        0.0,
        1.0,
        1.0 / n as f64,
        &mut rec,
    )
    .unwrap();
    assert_eq!(rec.len(), (n / 7 + 2) as usize); // 0, 7, …, 994 and the final 1000
    assert!(rec.len() <= cap);
    assert_eq!(
        (rec.t.as_ptr(), rec.x.as_ptr(), rec.errors.as_ptr()),
        (p_t, p_x, p_e),
        "reallocated"
    );
    assert_eq!(*rec.t.last().unwrap(), 1.0);
    assert_eq!(rec.errors_at(0), [0.0, 0.0]);
    assert!(rec.max_error(0) > 0.0 && rec.max_error(0) < 1e-8);

    // CSV output
    let mut buf = Vec::new();
    write_csv(&mut buf, &rec, Kepler { mu: 1.0 }.state_slots()).unwrap();
    let text = String::from_utf8(buf).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t,x[0],x[1],x[2],v[0],v[1],v[2],|ΔL|,|ΔA|"
    );
    assert_eq!(lines.count(), rec.len());
    assert_eq!(
        component_names(rigid_body([1.0; 3]).state_slots())[..4],
        ["R[0,0]", "R[1,0]", "R[2,0]", "R[0,1]"]
    );
}

/// Dense sampling with output times that include t₀ and coincide with the end.
#[test]
fn dense_sampling_edges() {
    let mut dp = DormandPrince::with_tolerances(1e-10, 1e-10);
    let times = [0.0, 0.0, 0.25, 1.0];
    let mut got = Vec::new();
    Driver::new(0.0, 2.0, 0.0)
        .run_dense(
            &mut dp,
            &Oscillator,
            &[1.0, 0.0],
            &times,
            &mut |i: u64, t: f64, x: &[f64; 2]| {
                got.push((i, t, x[0]));
                Control::Continue
            },
        )
        .unwrap();
    assert_eq!(got.len(), 4);
    for (i, t, q) in got {
        assert_eq!(t, times[i as usize]);
        assert!((q - t.cos()).abs() < 1e-9);
    }
    let err = Driver::new(0.0, 1.0, 0.0)
        .run_dense(&mut dp, &Oscillator, &[1.0, 0.0], &[0.5, 0.2], &mut ())
        .unwrap_err();
    assert!(matches!(err, StepError::InvalidInput(_)));
}

/// Everything is generic over the scalar: an `f32` oscillator through RK4, DOPRI5 and
/// projected Euler.
#[test]
fn f32_scalar_works() {
    struct Osc32;
    impl Field<f32, [f32; 2]> for Osc32 {
        fn field(&self, x: &[f32; 2], dx: &mut [f32; 2]) {
            dx[0] = x[1];
            dx[1] = -x[0];
        }
    }
    impl Invariants<f32, [f32; 2], [f32; 1]> for Osc32 {
        fn invariants(&self, x: &[f32; 2], f: &mut [f32; 1]) {
            f[0] = 0.5 * (x[0] * x[0] + x[1] * x[1]);
        }
        fn invariants_jacobian(&self, x: &[f32; 2], j: &mut [[f32; 2]; 1]) {
            j[0] = [x[0], x[1]];
        }
    }
    let x0 = [1.0f32, 0.0];
    let end = integrate(&mut ExplicitRk::rk4(), &Osc32, &x0, 0.0, 1.0, 0.01, &mut ()).unwrap();
    assert!((end.x[0] - 1f32.cos()).abs() < 1e-5);
    let mut dp = DormandPrince::<f32, [f32; 2]>::with_tolerances(1e-5, 1e-5);
    let end = integrate(&mut dp, &Osc32, &x0, 0.0, 1.0, 0.0, &mut ()).unwrap();
    assert!((end.x[0] - 1f32.cos()).abs() < 1e-4);
    let mut proj = Projection::from_initial(ExplicitRk::euler(), &Osc32, &x0, 1e-6);
    let end = integrate(&mut proj, &Osc32, &x0, 0.0, 1.0, 0.01, &mut ()).unwrap();
    assert!((0.5 * (end.x[0] * end.x[0] + end.x[1] * end.x[1]) - 0.5).abs() <= 1e-6);
}

/// An adaptive stepper that always takes the step 0.1 (not a binary fraction) and moves x by
/// it: the driver's time is the sum of the steps.
struct TenthSteps;
impl Stepper<f64, [f64; 1], Blow> for TenthSteps {
    fn step(
        &mut self,
        _field: &Blow,
        _t: f64,
        x: &mut [f64; 1],
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        let h_taken = h.min(0.1);
        x[0] += h_taken;
        Ok(StepOutcome {
            h_taken,
            h_next: 0.1,
            rejections: 0,
            evaluations: 1,
        })
    }
    fn order(&self) -> u32 {
        1
    }
    fn name(&self) -> String {
        "tenths".into()
    }
    fn is_adaptive(&self) -> bool {
        true
    }
}

/// The time of adaptive steps is their sum to within an ulp however many there are (the
/// driver sums them with compensation): after n steps of the double h = 0.1 it is n·h rounded
/// once, where the plain sum t += h has drifted by hundreds of ulps after 10⁶ steps.
#[test]
fn adaptive_time_is_the_compensated_sum_of_the_steps() {
    let h = 0.1f64;
    let n_steps = 1_000_000u64;
    let mut worst_ulps = 0.0f64;
    let mut naive = 0.0f64;
    let mut naive_ulps = 0.0f64;
    Driver::new(0.0, h * n_steps as f64 + 0.5, h)
        .max_steps(2 * n_steps)
        .run_stepwise(&mut TenthSteps, &Blow, &[0.0], |_, step, t, _| {
            if step > 0 && step <= n_steps {
                naive += h;
                let exact = step as f64 * h; // the exact product n·h rounded once
                let ulp = f64::EPSILON * exact;
                worst_ulps = worst_ulps.max((t - exact).abs() / ulp);
                naive_ulps = naive_ulps.max((naive - exact).abs() / ulp);
            }
            Control::Continue
        })
        .unwrap();
    eprintln!("compensated: {worst_ulps:.2} ulp; plain sum: {naive_ulps:.0} ulp");
    assert!(worst_ulps <= 1.0, "{worst_ulps} ulp");
    assert!(
        naive_ulps > 100.0,
        "the plain sum should drift: {naive_ulps}"
    );
}
