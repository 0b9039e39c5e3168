//! Lanes (`LoadedModel::lanes`): k states advanced together by the runtime's explicit
//! Runge–Kutta steppers are, lane by lane, bitwise the runs of each state alone — on every
//! model of `models/`, every back end, k = 1, 3 (odd: the JIT's scalar tail), 8.

use lasalle_exec::{Backend, LoadedModel, PackError};
use lasalle_runtime::{Driver, ExplicitRk, Parameters, Stepper};
use lasalle_testkit::Rng;

/// k states near the model's first point (or near 1 in every component if it has none).
fn starts(model: &LoadedModel, k: usize, rng: &mut Rng) -> Vec<Vec<f64>> {
    let base = match model.point_names().first() {
        Some(p) => model.point(p).unwrap(),
        None => vec![1.0; model.dim()],
    };
    (0..k)
        .map(|_| {
            base.iter()
                .map(|v| v + 1e-3 * rng.uniform(-1.0, 1.0))
                .collect()
        })
        .collect()
}

fn agree<S: Stepper<f64, Vec<f64>, LoadedModel> + Clone>(
    name: &str,
    model: &LoadedModel,
    stepper: S,
    rng: &mut Rng,
) where
    for<'m> S: Stepper<f64, Vec<f64>, lasalle_exec::Lanes<'m>>,
{
    let driver = Driver::new(0.0, 0.05, 1e-3);
    for k in [1, 3, 8] {
        let xs = starts(model, k, rng);
        let lanes = model.lanes(k);
        let together = driver
            .run(
                &mut stepper.clone(),
                &lanes,
                &lanes.pack(&xs).unwrap(),
                &mut (),
            )
            .unwrap_or_else(|e| panic!("{name}, {k} lanes: {e}"));
        assert_eq!(together.steps, 50);
        for (l, x) in xs.iter().enumerate() {
            let alone = driver
                .run(&mut stepper.clone(), model, x, &mut ())
                .unwrap_or_else(|e| panic!("{name}, alone: {e}"));
            let lane = lanes.unpack(&together.x, l);
            assert!(
                lane.iter()
                    .zip(&alone.x)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{name}: lane {l} of {k} differs from its lone run:\n{lane:?}\n{:?}",
                alone.x
            );
        }
    }
}

#[test]
fn lanes_are_lone_runs_bitwise() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../models");
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "lsl"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 6);
    let mut rng = Rng::new(17);
    for backend in Backend::available() {
        for path in &paths {
            let model = LoadedModel::load(path, *backend).unwrap();
            let name = format!("{} ({backend:?})", path.display());
            agree(
                &name,
                &model,
                ExplicitRk::<f64, 1, Vec<f64>>::euler(),
                &mut rng,
            );
            agree(
                &name,
                &model,
                ExplicitRk::<f64, 2, Vec<f64>>::heun(),
                &mut rng,
            );
            agree(
                &name,
                &model,
                ExplicitRk::<f64, 4, Vec<f64>>::rk4(),
                &mut rng,
            );
        }
    }
}

#[test]
fn pack_refuses_what_does_not_fit() {
    let text = "model Osc { state q: scalar, p: scalar; d/dt q = p; d/dt p = -q; }";
    let model = LoadedModel::from_source("osc.lsl", text, Backend::Interpreter).unwrap();
    let lanes = model.lanes(2);
    assert_eq!(
        lanes.pack(&[vec![1.0, 0.0]]),
        Err(PackError::Count { given: 1, lanes: 2 })
    );
    assert_eq!(
        lanes.pack(&[vec![1.0, 0.0], vec![1.0]]),
        Err(PackError::Dim {
            index: 1,
            len: 1,
            dim: 2
        })
    );
    let x = lanes.pack(&[vec![1.0, 2.0], vec![3.0, 4.0]]).unwrap();
    assert_eq!(x, [1.0, 3.0, 2.0, 4.0]);
    assert_eq!(lanes.unpack(&x, 1), [3.0, 4.0]);
    // a state of the wrong length gives NaN, which the driver reports as a blow-up
    let mut dx = vec![0.0; 3];
    lasalle_runtime::Field::field(&lanes, &vec![0.0; 3], &mut dx);
    assert!(dx.iter().all(|v| v.is_nan()));
}
