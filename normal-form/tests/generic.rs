//! Nothing is specific to the CR3BP: other Hamiltonians, written in Rust or in the DSL, go
//! through the same path.

use lasalle_normal_form::models::{Anharmonic, CoupledOscillators, Cr3bp};
use lasalle_normal_form::validate::measure_frequencies;
use lasalle_normal_form::{normalize, normalize_model_file, ModelPoint, Options, Point, Precision};

fn workspace_file(rel: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(rel)
}

#[test]
fn anharmonic_oscillator_closed_form() {
    // H = ½(p² + q²) + αq³/3 + βq⁴/4  ⇒  H̄ = I + (3β/8 − 5α²/12) I² + …
    for (alpha, beta) in [(0.0, 1.0), (1.0, 0.0), (0.3, -0.7)] {
        let h = Anharmonic { alpha, beta };
        let nf = normalize(&h, &Point::Given(vec![0.0, 0.0]), &Options::with_order(6)).unwrap();
        assert_eq!(nf.signs, vec![1]);
        assert!((nf.coefficient(&[1]) - 1.0).abs() < 1e-15);
        let expected = 3.0 * beta / 8.0 - 5.0 * alpha * alpha / 12.0;
        assert!(
            (nf.coefficient(&[2]) - expected).abs() < 1e-14,
            "{} vs {expected}",
            nf.coefficient(&[2])
        );
    }
}

#[test]
fn coupled_oscillators_frequencies() {
    let h = CoupledOscillators::default();
    let opts = Options::with_order(10);
    let nf = normalize(&h, &Point::Newton(vec![0.01, -0.02, 0.0, 0.01]), &opts).unwrap();
    let om = nf.frequencies_linear();
    assert!((om[0] - 2f64.sqrt()).abs() < 1e-14 && (om[1] - 1.0).abs() < 1e-14);
    assert_eq!(nf.signs, vec![1, 1]);
    assert!(nf.equilibrium.iter().all(|v| v.value.abs() < 1e-15));
    // frequencies measured along true orbits
    let z0 = nf.from_normal(&[0.05, 0.03, 0.0, 0.0]).unwrap();
    let measured = measure_frequencies(&h, &nf, &z0, 600.0, 0.25, 1e-13);
    let mut errors = Vec::new();
    for order in [2, 4, 6, 8] {
        let f = normalize(
            &h,
            &Point::Given(vec![0.0; 4]),
            &Options::with_order(order).error_estimate(false),
        )
        .unwrap();
        let nu = f.frequencies(&f.actions(&z0).unwrap_or(vec![0.0; 2]));
        errors.push(
            nu.iter()
                .zip(&measured)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max),
        );
    }
    assert!(errors.windows(2).all(|w| w[1] < w[0] / 5.0), "{errors:?}");
    assert!(errors[3] < 1e-7, "{errors:?}");
}

#[test]
fn dsl_models_go_through_the_same_path() {
    // the coupled-oscillator model file
    let nf = normalize_model_file(
        workspace_file("models/coupled_oscillators.lsl"),
        &[],
        &ModelPoint::Auto,
        &Options::with_order(8),
    )
    .expect("model normal form");
    assert_eq!(nf.n_dof, 2);
    assert!((nf.frequencies_linear()[0] - 2f64.sqrt()).abs() < 1e-14);
    assert!(nf.to_rust().is_some());
    // the CR3BP model file gives the same normal form as the Rust CR3BP, in both precisions
    for precision in [Precision::F64, Precision::DoubleDouble] {
        let opts = Options::with_order(8)
            .precision(precision)
            .error_estimate(false);
        let from_file = normalize_model_file(
            workspace_file("models/cr3bp.lsl"),
            &[("mu".to_string(), 0.01)],
            &ModelPoint::Named("L4".into()),
            &opts,
        )
        .unwrap();
        let h = Cr3bp { mu: 0.01 };
        let direct = normalize(&h, &Point::Newton(h.l4().to_vec()), &opts).unwrap();
        for (a, b) in from_file.hamiltonian.iter().zip(&direct.hamiltonian) {
            let (x, y) = (a.coeff.value + a.coeff.lo, b.coeff.value + b.coeff.lo);
            let tol = if precision == Precision::F64 {
                1e-9
            } else {
                1e-20
            };
            assert!(
                (x - y).abs() <= tol * y.abs(),
                "{:?}: {x} vs {y}",
                a.exponents
            );
        }
    }
    let e = normalize_model_file(
        workspace_file("models/cr3bp.lsl"),
        &[("nu".into(), 0.1)],
        &ModelPoint::Auto,
        &Options::default(),
    );
    assert!(e
        .unwrap_err()
        .to_string()
        .contains("unknown parameter `nu`"));
}
