//! The Gauss–Newton norm L = ‖Dfᵀ K Df‖₂ that the scaled and adaptive gains divide by: with
//! fewer invariant components than state components it is taken on the small matrix
//! K^½ Df Dfᵀ K^½, which must give the norm of the N × N matrix. The capped gains of a
//! fixed-step feedback run ([`GainBound`]) cost no allocation per step on a loaded model.

use lasalle_exec::{Backend, LoadedModel};
use lasalle_runtime::{
    gauss_newton_hessian, gauss_newton_norm, symmetric_spectral_norm, BoundMode, ExplicitRk,
    FeedbackField, GainBound, ModelInfo, Parameters, Stepper, DEFAULT_BOUND_FRACTION,
    FEEDBACK_STEP_INTERVAL,
};
use lasalle_testkit::{allocations, CountingAllocator};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// The Kepler orbit of the paper with a step large enough that its gains are capped near
/// periapsis: after the first step, which sizes the scratch storage, the steps of the capped
/// mode (base step, Σ|∇fᵢ|² per gain from the Jacobian, the feedback step) allocate nothing.
#[test]
fn capped_steps_allocate_nothing_after_the_first() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/kepler.lsl");
    let model = LoadedModel::load(path, Backend::Jit).unwrap();
    let x0 = model.point("paper").unwrap();
    let gains = model.default_gain_values().to_vec();
    let field = FeedbackField::from_initial(&model, &x0, gains.clone());
    let theta = DEFAULT_BOUND_FRACTION * FEEDBACK_STEP_INTERVAL;
    let mode = BoundMode::Cap {
        model: gains,
        theta,
    };
    let mut stepper = GainBound::new(ExplicitRk::rk4(), mode, FEEDBACK_STEP_INTERVAL);
    let (mut x, h) = (x0.clone(), 0.05);
    stepper.step(&field, 0.0, &mut x, h).unwrap();
    let before = allocations();
    for i in 1..200 {
        stepper.step(&field, i as f64 * h, &mut x, h).unwrap();
    }
    assert_eq!(allocations() - before, 0, "allocations in 199 steps");
    type Field<'a> = FeedbackField<'a, LoadedModel, Vec<f64>, Vec<f64>>;
    let counters = <_ as Stepper<f64, Vec<f64>, Field>>::counters(&stepper);
    let capped = counters
        .iter()
        .find(|(n, _)| *n == "capped_steps")
        .unwrap()
        .1;
    assert!(capped > 0.0, "no step was capped: {counters:?}");
    assert!(x.iter().all(|v| v.is_finite()), "{x:?}");
    // the bound held: h·k·L never passed θ
    assert!(
        stepper.max_hkl() <= theta * (1.0 + 1e-12),
        "{}",
        stepper.max_hkl()
    );
}

const NBODY: &str = include_str!("../../models/nbody.lsl");

#[test]
fn the_small_gram_matrix_gives_the_norm_of_the_large_one() {
    let text = NBODY.replace(
        NBODY
            .lines()
            .find(|l| l.trim_start().starts_with("param n ="))
            .expect("nbody.lsl sizes itself on a `param n = …;` line"),
        "param n = 5;",
    );
    let m = LoadedModel::from_source("nbody.lsl", &text, Backend::Jit).unwrap();
    let x = m.point("ring").unwrap();
    let (n, k) = (x.len(), m.gain_names().len());
    assert_eq!(n, 30);
    for gains in [vec![1.0; k], (1..=k).map(|g| g as f64 * 0.7).collect()] {
        let small = gauss_newton_norm::<_, f64, Vec<f64>, Vec<f64>>(&m, &x, &gains);
        let h = gauss_newton_hessian::<_, f64, Vec<f64>, Vec<f64>>(&m, &x, &gains);
        let large = symmetric_spectral_norm(&h, 2000, 1e-14);
        assert!(large > 0.0);
        assert!(
            (small - large).abs() <= 1e-7 * large,
            "gains {gains:?}: {small} on the Gram matrix, {large} on H_GN"
        );
    }
}
