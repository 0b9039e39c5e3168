//! Lanes (`LoadedModel::lanes`, `LoadedModel::feedback_lanes`): k states advanced together by
//! the runtime's explicit Runge–Kutta steppers are, lane by lane, bitwise the runs of each
//! state alone — the field X and the feedback field X − ∇V (each lane with its own targets),
//! on every model of `models/`, every back end, k = 1, 3 (odd: the JIT's scalar tail), 8.

use lasalle_exec::{Backend, FeedbackLanes, LaneField, Lanes, LoadedModel, PackError};
use lasalle_runtime::{Driver, ExplicitRk, FeedbackField, Field, ModelInfo, Parameters, Stepper};
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

/// The states `xs` run together in `lanes` and each alone (`lone`) agree bitwise.
fn agree<L, S>(
    name: &str,
    stepper: &S,
    lanes: &L,
    xs: &[Vec<f64>],
    lone: impl Fn(&mut S, &[f64]) -> Vec<f64>,
) where
    L: LaneField,
    S: Stepper<f64, Vec<f64>, L> + Clone,
{
    let together = Driver::new(0.0, 0.05, 1e-3)
        .run(
            &mut stepper.clone(),
            lanes,
            &lanes.pack(xs).unwrap(),
            &mut (),
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(together.steps, 50);
    for (l, x) in xs.iter().enumerate() {
        let alone = lone(&mut stepper.clone(), x);
        let lane = lanes.unpack(&together.x, l);
        assert!(
            lane.iter()
                .zip(&alone)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{name}: lane {l} of {} differs from its lone run:\n{lane:?}\n{alone:?}",
            xs.len(),
        );
    }
}

/// X and X − ∇V with `stepper`, k lanes vs alone.
fn both_fields<S>(name: &str, stepper: S, model: &LoadedModel, xs: &[Vec<f64>])
where
    S: for<'m> Stepper<f64, Vec<f64>, Lanes<'m>>
        + for<'m> Stepper<f64, Vec<f64>, FeedbackLanes<'m>>
        + Stepper<f64, Vec<f64>, LoadedModel>
        + for<'m> Stepper<f64, Vec<f64>, FeedbackField<'m, LoadedModel, Vec<f64>, Vec<f64>>>
        + Clone,
{
    let driver = Driver::new(0.0, 0.05, 1e-3);
    let k = xs.len();
    agree(name, &stepper, &model.lanes(k), xs, |s, x| {
        driver.run(s, model, &x.to_vec(), &mut ()).unwrap().x
    });
    // the model's gains, scaled where h·k·L would leave the methods' stability intervals at the
    // first state (Arenstorf's orbit starts by the Moon)
    let mut gains = model.default_gain_values().to_vec();
    let trace =
        lasalle_runtime::gauss_newton_trace::<_, f64, Vec<f64>, Vec<f64>>(model, &xs[0], &gains);
    let scale = (1.0 / (1e-3 * trace)).min(1.0);
    gains.iter_mut().for_each(|g| *g *= scale);
    let feedback = model.feedback_lanes(k, &gains).unwrap();
    agree(
        &format!("{name}, feedback"),
        &stepper,
        &feedback,
        xs,
        |s, x| {
            let x0 = x.to_vec();
            let field = FeedbackField::from_initial(model, &x0, gains.clone());
            driver.run(s, &field, &x0, &mut ()).unwrap().x
        },
    );
}

#[test]
fn lanes_are_lone_runs_bitwise() {
    let paths = lasalle_testkit::model_files();
    let mut rng = Rng::new(17);
    for backend in Backend::available() {
        for path in &paths {
            let model = LoadedModel::load(path, *backend).unwrap();
            for k in [1, 3, 8] {
                let xs = starts(&model, k, &mut rng);
                let name = format!("{} ({backend:?}, {k} lanes)", path.display());
                let euler = ExplicitRk::<f64, 1, Vec<f64>>::euler();
                let heun = ExplicitRk::<f64, 2, Vec<f64>>::heun();
                let rk4 = ExplicitRk::<f64, 4, Vec<f64>>::rk4();
                both_fields(&format!("{name}, euler"), euler, &model, &xs);
                both_fields(&format!("{name}, heun"), heun, &model, &xs);
                both_fields(&format!("{name}, rk4"), rk4, &model, &xs);
            }
        }
    }
}

#[test]
fn pack_refuses_what_does_not_fit() {
    let text = "model Osc { state q: scalar, p: scalar; d/dt q = p; d/dt p = -q;
                integral E = p^2 + q^2 gain k = 1; }";
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
    lanes.field(&vec![0.0; 3], &mut dx);
    assert!(dx.iter().all(|v| v.is_nan()));
    // the feedback lanes carry each lane's targets f(x₀) = p² + q² after its state
    let feedback = model.feedback_lanes(2, &[1.0]).unwrap();
    let x = feedback.pack(&[vec![1.0, 2.0], vec![3.0, 4.0]]).unwrap();
    assert_eq!(x, [1.0, 3.0, 2.0, 4.0, 5.0, 25.0]);
    assert_eq!(feedback.unpack(&x, 1), [3.0, 4.0]);
    let e = model
        .feedback_lanes(2, &[1.0, 2.0])
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("gains"), "{e}");
}
