//! Every adaptive run ends within its step budget: a seeded fuzz of tolerances (down past
//! what f64 delivers), spans (up to 10³⁰⁰), first steps and budgets on fields that are smooth,
//! stiff, discontinuous or escape in finite time. Each run either reaches its end time or
//! stops with a typed error; the field counts its evaluations and panics past what the budget
//! allows, so a run that would not end fails the test instead of hanging it.

mod common;

use std::cell::Cell;

use common::*;
use lasalle_runtime::*;
use lasalle_testkit::Rng;

/// The test fields, on R².
#[derive(Clone, Copy, Debug)]
enum Kind {
    /// The harmonic oscillator: smooth, bounded.
    Oscillator,
    /// ẋ = x² from x = 1: escapes at t = 1.
    Escape,
    /// ẋ = −sign(x): reaches 0 at t = 1 and chatters there.
    Discontinuous,
    /// ẋ = −10⁸ (x − y), ẏ = −y: stiff.
    Stiff,
}

/// A field that counts its evaluations and panics past `limit`.
struct Counted {
    kind: Kind,
    evaluations: Cell<u64>,
    limit: u64,
}

impl Field<f64, [f64; 2]> for Counted {
    fn field(&self, x: &[f64; 2], dx: &mut [f64; 2]) {
        let n = self.evaluations.get() + 1;
        assert!(
            n <= self.limit,
            "{:?}: {n} evaluations, past the budget's {}",
            self.kind,
            self.limit
        );
        self.evaluations.set(n);
        *dx = match self.kind {
            Kind::Oscillator => [x[1], -x[0]],
            Kind::Escape => [x[0] * x[0], 0.0],
            Kind::Discontinuous => [-x[0].signum(), 0.0],
            Kind::Stiff => [-1e8 * (x[0] - x[1]), -x[1]],
        };
    }
}

/// DOPRI5 spends at most 6 evaluations a trial step, one for the first stage and two to
/// choose the first step; the budget is checked before each step, whose own trials pass it by
/// at most `max_rejections` + 1.
fn evaluation_limit(budget: u64, opts: &DormandPrinceOptions<f64>) -> u64 {
    6 * (budget + u64::from(opts.max_rejections) + 1) + 3
}

#[test]
fn every_dopri5_run_ends_within_its_budget() {
    let mut rng = Rng::new(0x1a5a11e);
    let kinds = [
        Kind::Oscillator,
        Kind::Escape,
        Kind::Discontinuous,
        Kind::Stiff,
    ];
    let (mut reached, mut budgets, mut underflows, mut refused) = (0, 0, 0, 0);
    for case in 0..800 {
        let kind = kinds[case % kinds.len()];
        let opts = DormandPrinceOptions {
            rtol: rng.decade(-32.0, -1.0),
            atol: rng.decade(-300.0, -1.0),
            ..Default::default()
        };
        let t_end = rng.decade(-300.0, 300.0);
        // the first step: chosen by the method, or anything from subnormal to huge
        let h0 = if rng.unit() < 0.3 {
            0.0
        } else {
            rng.decade(-320.0, 10.0)
        };
        let budget = rng.decade(1.0, 4.0) as u64;
        let field = Counted {
            kind,
            evaluations: Cell::new(0),
            limit: evaluation_limit(budget, &opts),
        };
        let x0 = match kind {
            Kind::Oscillator | Kind::Stiff => [1.0, 0.5],
            Kind::Escape | Kind::Discontinuous => [1.0, 0.0],
        };
        let what =
            format!("case {case} {kind:?} {opts:?} t_end {t_end:e} h0 {h0:e} budget {budget}");
        let out = Driver::new(0.0, t_end, h0.min(t_end))
            .max_steps(budget)
            .run(&mut DormandPrince::new(opts), &field, &x0, &mut ());
        match out {
            Ok(s) => {
                assert_eq!(s.t, t_end, "{what}");
                assert!(s.steps + s.rejections <= budget + 51, "{what}: {s:?}");
                reached += 1;
            }
            Err(StepError::MaxSteps {
                steps, rejected, ..
            }) => {
                assert_eq!(steps, budget, "{what}");
                assert!(rejected <= budget + 51, "{what}");
                budgets += 1;
            }
            Err(StepError::StepSizeTooSmall { h, h_min, .. }) => {
                assert!(h < h_min, "{what}");
                underflows += 1;
            }
            Err(StepError::InvalidInput(m)) => {
                // only a tolerance below the floor, or a first step the method cannot use
                let floor = opts.rtol < rtol_floor::<f64>();
                assert!(floor == m.contains("rtol ≥"), "{what}: {m}");
                refused += 1;
            }
            Err(StepError::TooManyRejections { .. } | StepError::NonFinite { .. }) => {}
            Err(e) => panic!("{what}: {e}"),
        }
    }
    eprintln!("{reached} reached t_end, {budgets} spent the budget, {underflows} underflowed, {refused} refused");
    // the fuzz reaches every outcome that matters
    assert!(reached > 50 && budgets > 50 && underflows > 5 && refused > 50);
}

/// Rejected steps count against the budget: a run whose every trial is rejected (the
/// discontinuous field at a tolerance that never passes across the jump) still ends at it.
#[test]
fn rejected_steps_spend_the_budget() {
    let opts = DormandPrinceOptions {
        rtol: 1e-12,
        atol: 1e-12,
        ..Default::default()
    };
    let field = Counted {
        kind: Kind::Discontinuous,
        evaluations: Cell::new(0),
        limit: evaluation_limit(200, &opts),
    };
    let err = Driver::new(0.0, 2.0, 0.0)
        .max_steps(200)
        .run(&mut DormandPrince::new(opts), &field, &[1.0, 0.0], &mut ())
        .unwrap_err();
    eprintln!("{err}");
    let StepError::MaxSteps {
        steps, rejected, t, ..
    } = err
    else {
        panic!("{err}");
    };
    assert_eq!(steps, 200);
    assert!(rejected > 20, "{rejected} rejected");
    assert!((t - 1.0).abs() < 1e-3, "t = {t}");
}

/// The two runs that never ended: the oscillator at rtol = atol = 10⁻³⁰ is refused at once,
/// with the floor in the message; at the floor itself it ends in a few thousand steps.
#[test]
fn a_tolerance_below_the_floor_is_refused_and_the_floor_runs() {
    let mut dp = DormandPrince::with_tolerances(1e-30, 1e-30);
    let err = integrate(&mut dp, &Oscillator, &[1.0, 0.0], 0.0, 1.0, 0.0, &mut ()).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, StepError::InvalidInput(_)), "{msg}");
    assert!(msg.contains("rtol ≥ 1.11022302462515"), "{msg}");
    let floor = rtol_floor::<f64>();
    assert_eq!(floor, 10.0 * f64::EPSILON / 2.0);
    let mut dp = DormandPrince::with_tolerances(floor, floor);
    let end = integrate(&mut dp, &Oscillator, &[1.0, 0.0], 0.0, 1.0, 0.0, &mut ()).unwrap();
    assert!(end.steps < 5000, "{} steps", end.steps);
    // the error is near the floor's size: the tolerance is met, not only accepted
    assert!(
        (end.x[0] - 1f64.cos()).abs() < 1e-13,
        "{:e}",
        end.x[0] - 1f64.cos()
    );
}
