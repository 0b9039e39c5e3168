//! The run engine on loaded models: presets with overrides, progress, counters, and
//! ensembles whose members get bitwise the results they get alone.

use std::cell::RefCell;

use lasalle_exec::{Backend, LoadedModel};
use lasalle_run::{
    find_preset, simulate, simulate_many, simulate_with_progress, Init, Member, Method,
    ModelSource, Recording, RunError, RunSpec,
};
use lasalle_runtime::{GainPolicy, Parameters, StepError};

fn model_path(stem: &str) -> String {
    format!("{}/../models/{stem}.lsl", env!("CARGO_MANIFEST_DIR"))
}

fn load(stem: &str) -> LoadedModel {
    LoadedModel::load(model_path(stem), Backend::Jit).unwrap()
}

/// Everything but the timings, bit for bit.
fn assert_same(a: &Recording, b: &Recording, what: &str) {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a.t), bits(&b.t), "{what}: times");
    assert_eq!(bits(&a.x), bits(&b.x), "{what}: states");
    assert_eq!(bits(&a.errors), bits(&b.errors), "{what}: errors");
    assert_eq!(
        (a.steps, a.evaluations, a.rejections),
        (b.steps, b.evaluations, b.rejections),
        "{what}: counts"
    );
    let counters = |r: &Recording| {
        r.counters
            .iter()
            .map(|(name, v)| (*name, v.to_bits()))
            .collect::<Vec<_>>()
    };
    assert_eq!(counters(a), counters(b), "{what}: counters");
    assert_eq!(a.gains_final, b.gains_final, "{what}: gains");
    assert_eq!(
        a.failure.as_ref().map(|e| e.to_string()),
        b.failure.as_ref().map(|e| e.to_string()),
        "{what}: failure"
    );
}

#[test]
fn a_preset_with_overrides_sets_parameters_and_the_initial_point() {
    let mut model = load("so3_type_iii");
    let preset = find_preset(&model, Some("case_c18")).unwrap().unwrap();
    let (name, values) = preset.params[0];
    let (spec, x0) = RunSpec::from_preset(Some(preset))
        .t_end(0.5)
        .prepare(&mut model)
        .unwrap();
    assert_eq!(model.param(name).unwrap(), values);
    assert_eq!(Some(x0.clone()), model.point(preset.init.unwrap()));
    assert_eq!(spec.t_end, 0.5);
    let rec = simulate(&model, &x0, &spec).unwrap();
    assert!(rec.failure.is_none());
    assert_eq!(rec.t_final(), 0.5);
    assert!(find_preset(&model, Some("nope"))
        .unwrap_err()
        .to_string()
        .contains("unknown preset `nope`"));
}

#[test]
fn progress_is_reported_and_counters_come_from_the_stepper() {
    let model = load("kepler");
    let x0 = model.point("paper").unwrap();
    let spec = RunSpec::builder()
        .method("projection-euler".parse().unwrap())
        .dt(1e-3)
        .t_end(300.0)
        .build()
        .unwrap();
    let seen = RefCell::new(Vec::new());
    let rec = simulate_with_progress(&model, &x0, &spec, &|t| seen.borrow_mut().push(t)).unwrap();
    let seen = seen.into_inner();
    // 3·10⁵ steps: the start and every 2¹⁶ steps
    assert_eq!(seen.len(), 5, "{seen:?}");
    assert!(seen.windows(2).all(|w| w[0] < w[1] && w[1] <= spec.t_end));
    assert!(rec.counter("newton_iterations").unwrap() > 0.0);
    assert!(rec.counter("projected_steps").unwrap() > 0.0);
    let summary = rec.summary_json();
    assert_eq!(
        summary["stats"]["newton_iterations"],
        rec.counter("newton_iterations").unwrap()
    );
    // the adaptive gain reports its last estimate
    let spec = RunSpec::new("feedback-euler".parse().unwrap(), 0.01, 10.0);
    let spec = RunSpec {
        gains: GainPolicy::Adaptive { every: 10, c: 1.0 },
        ..spec
    };
    let rec = simulate(&model, &x0, &spec).unwrap();
    assert!(rec.counter("last_gauss_newton_norm").unwrap() > 0.0);
}

#[test]
fn ensemble_members_get_their_lone_results() {
    let source = ModelSource::read(model_path("kepler"), Backend::Jit).unwrap();
    let x0 = [1.0, 0.0, 0.0, 0.0, 1.2, 0.0];
    let mut members = Vec::new();
    for mu in [1.0, 1.2] {
        for v in [0.9, 1.0, 1.1, 1.3, 0.02] {
            members.push(Member::at(x0.to_vec()).param("mu", [mu]).set(4, v));
        }
    }
    // the model file's parameters, after members that changed them
    members.push(Member::new(Init::Text("paper".into())));
    // the Taylor method's rows in lanes of two orbits, refilled as orbits end (from the first
    // step 0.01, to a near-collision for v = 0.02)
    for method in ["rk4", "feedback-heun", "taylor"] {
        let mut spec = RunSpec::new(method.parse::<Method>().unwrap(), 0.01, 20.0);
        spec.every = u64::MAX;
        let mut alone = Vec::new();
        for m in &members {
            let mut model = source.load().unwrap();
            for (name, values) in &m.params {
                model.set_param(name, values).unwrap();
            }
            let x = match &m.init {
                Init::State(x) => {
                    let mut x = x.clone();
                    for &(i, v) in &m.set {
                        x[i] = v;
                    }
                    x
                }
                _ => model.point("paper").unwrap(),
            };
            alone.push(simulate(&model, &x, &spec).unwrap());
        }
        for (threads, lanes) in [(1, 1), (1, 4), (2, 8)] {
            let ensemble = simulate_many(&source, &members, &spec, threads, lanes).unwrap();
            assert_eq!(ensemble.threads, threads);
            assert_eq!(ensemble.recordings.len(), members.len());
            for (k, (got, want)) in ensemble.recordings.iter().zip(&alone).enumerate() {
                let got = got.as_ref().unwrap();
                assert_same(
                    got,
                    want,
                    &format!("{method}, {threads} threads, {lanes} lanes, member {k}"),
                );
            }
        }
    }
}

#[test]
fn a_member_that_cannot_start_fails_alone() {
    let source = ModelSource::read(model_path("kepler"), Backend::Interpreter).unwrap();
    let members = [
        Member::default(),
        Member::default().param("zz", [1.0]),
        Member::new(Init::Text("nowhere".into())),
        Member::at(vec![0.0; 6]),
        Member::default().set(9, 1.0),
    ];
    let spec = RunSpec::new("rk4".parse().unwrap(), 0.01, 1.0);
    let ensemble = simulate_many(&source, &members, &spec, 1, 8).unwrap();
    let r = &ensemble.recordings;
    assert!(r[0].as_ref().is_ok_and(|rec| rec.failure.is_none()));
    let message = |k: usize| r[k].as_ref().unwrap_err().to_string();
    assert!(
        message(1).contains("unknown parameter `zz`"),
        "{}",
        message(1)
    );
    assert!(
        message(2).contains("unknown point `nowhere`"),
        "{}",
        message(2)
    );
    assert!(matches!(r[3], Err(RunError::Model(_))), "{:?}", r[3]);
    assert!(message(4).contains("component 9"), "{}", message(4));
    // a spec that cannot run is refused before any thread starts
    let bad = RunSpec::new("rk4".parse().unwrap(), -1.0, 1.0);
    assert!(matches!(
        simulate_many(&source, &members, &bad, 1, 8),
        Err(RunError::Spec(_))
    ));
}

/// A batch of compiled steps stops before the first step whose new state is not finite or
/// whose guard fails, strict or not, as the generic stepper does: the same step, state and
/// message. x' = x³ from 2 with Euler and h = 1 overflows to infinity at the eighth step.
#[test]
fn compiled_batches_stop_where_the_generic_stepper_does() {
    for (guard, expected) in [
        ("", "non-finite"),
        ("guard bounded: x < 1e100;", "guard `bounded`"),
        ("guard bounded: x <= 1e100;", "guard `bounded`"),
    ] {
        let text = format!("model Blowup {{ state x: scalar; d/dt x = x^3; {guard} }}");
        let jit = LoadedModel::from_source("blowup.lsl", &text, Backend::Jit).unwrap();
        let interp = LoadedModel::from_source("blowup.lsl", &text, Backend::Interpreter).unwrap();
        for every in [1, 1000] {
            let mut spec = RunSpec::new("euler".parse::<Method>().unwrap(), 1.0, 100.0);
            spec.every = every;
            let a = simulate(&jit, &vec![2.0], &spec).unwrap();
            let b = simulate(&interp, &vec![2.0], &spec).unwrap();
            let failure = a
                .failure
                .as_ref()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(
                failure.contains(expected),
                "{guard} every {every}: {failure}"
            );
            assert_same(&a, &b, &format!("blow-up, {guard} every {every}"));
        }
    }
}

/// Euler on the free rigid body amplifies every rotation by √(1 + ω²h²) a step: at h = 0.1
/// the energy passes its drift bound within a few hundred steps. The run stops at the first
/// sample past the bound, with batches of compiled steps between the samples (JIT) as with
/// one step at a time (interpreter), and does not record the diverged sample.
#[test]
fn a_drifting_run_stops_at_its_first_sample_past_the_bound() {
    let jit = load("rigid_body");
    let interp = LoadedModel::load(model_path("rigid_body"), Backend::Interpreter).unwrap();
    let x0 = jit.point("paper").unwrap();
    for every in [1, 7, 40] {
        let mut spec = RunSpec::new("euler".parse::<Method>().unwrap(), 0.1, 1e4);
        spec.every = every;
        spec.max_drift = 10.0;
        let a = simulate(&jit, &x0, &spec).unwrap();
        let b = simulate(&interp, &x0, &spec).unwrap();
        assert_same(&a, &b, &format!("drift, every {every}"));
        let Some(StepError::Diverged { step, t, .. }) = &a.failure else {
            panic!("every {every}: expected a divergence, got {:?}", a.failure);
        };
        assert_eq!(step % every, 0, "checked at the samples: {step}");
        assert!(*step > every, "{step}");
        let samples = a.t.len();
        assert_eq!(
            samples as u64,
            step / every,
            "every sample up to the failure's"
        );
        assert!(a.t_final() < *t);
        // within the bound at the last sample, past it at the next: the run of the same
        // spec to the last sample's time ends without a failure
        let mut before = spec.clone();
        before.t_end = a.t_final();
        let c = simulate(&interp, &x0, &before).unwrap();
        assert!(c.failure.is_none(), "{:?}", c.failure);
    }
}

/// A fixed step compiled whole by the JIT (the stages, the field and the guards in one
/// function) gives bitwise the generic stepper's run, which the interpreter takes, for every
/// fixed-step method on the field and on X − ∇V, a guard's failure included.
#[test]
fn compiled_steps_are_bitwise_the_generic_steppers_runs() {
    for stem in ["kepler", "rigid_body", "perturbed_kepler"] {
        let jit = load(stem);
        let interp = LoadedModel::load(model_path(stem), Backend::Interpreter).unwrap();
        let x0 = jit.point(jit.point_names()[0]).unwrap();
        for method in [
            "euler",
            "heun",
            "rk4",
            "feedback-euler",
            "feedback-heun",
            "feedback-rk4",
        ] {
            // samples every few steps, and far apart (the steps between go in batches)
            for every in [0, 7, 300] {
                let mut spec = RunSpec::new(method.parse::<Method>().unwrap(), 1e-3, 2.0);
                spec.every = every;
                let a = simulate(&jit, &x0, &spec).unwrap();
                let b = simulate(&interp, &x0, &spec).unwrap();
                assert!(a.failure.is_none(), "{stem} {method}: {:?}", a.failure);
                assert_same(&a, &b, &format!("{stem} {method} every {every}"));
            }
        }
    }
    // Kepler's guard `resolved: dt * norm(v) <= norm(x)` fails near the pericentre of this
    // eccentric orbit at this step: the same step, time, state and message
    let jit = load("kepler");
    let interp = LoadedModel::load(model_path("kepler"), Backend::Interpreter).unwrap();
    let x0 = vec![1.0, 0.0, 0.0, 0.0, 0.3, 0.0];
    for (method, every) in [
        ("euler", 0),
        ("rk4", 0),
        ("feedback-rk4", 0),
        ("euler", 30),
        ("rk4", 30),
    ] {
        // (with a sample every 30 steps the failing step lies inside a batch)
        let mut spec = RunSpec::new(method.parse::<Method>().unwrap(), 0.25, 10.0);
        spec.every = every;
        let a = simulate(&jit, &x0, &spec).unwrap();
        let b = simulate(&interp, &x0, &spec).unwrap();
        let failure = a
            .failure
            .as_ref()
            .map(|e| e.to_string())
            .unwrap_or_default();
        // (the bounded feedback steps after the base method's step: the guard fails first)
        assert!(failure.contains("guard `resolved`"), "{method}: {failure}");
        assert_same(&a, &b, &format!("kepler {method}, guard"));
    }
}
