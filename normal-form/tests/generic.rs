//! Nothing is specific to the CR3BP: other Hamiltonians, in the DSL or built in Rust, go
//! through the same path; and the DSL path agrees with an independent hand-written CR3BP.

mod common;

use lasalle_normal_form::models::PolynomialHamiltonian;
use lasalle_normal_form::validate::measure_frequencies;
use lasalle_normal_form::{
    normalize, normalize_model_file, HamiltonianFn, ModelPoint, Options, Point, Precision, Scalar,
};

#[test]
fn anharmonic_oscillator_closed_form() {
    // H = ½(p² + q²) + αq³/3 + βq⁴/4  ⇒  H̄ = I + (3β/8 − 5α²/12) I² + …
    for (alpha, beta) in [(0.0, 1.0), (1.0, 0.0), (0.3, -0.7)] {
        let h = PolynomialHamiltonian::from_terms(
            1,
            &[
                (0.5, &[2, 0]),
                (0.5, &[0, 2]),
                (alpha / 3.0, &[3, 0]),
                (beta / 4.0, &[4, 0]),
            ],
        );
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

/// Three degrees of freedom: uncoupled quartic oscillators `ω(q² + p²)/2 + βq⁴/4` have
/// `h_{2e_k} = 3β_k/8` (⟨q⁴⟩ = 3I²/2);
/// with a cubic coupling q₁q₂q₃ the two precisions still agree.
#[test]
fn three_degrees_of_freedom() {
    let w = [1.0, 2f64.sqrt(), 3f64.sqrt()];
    let beta = [0.3, -0.2, 0.5];
    let mut terms: Vec<(f64, Vec<u8>)> = Vec::new();
    for k in 0..3 {
        let mut e = vec![0u8; 6];
        e[k] = 2;
        terms.push((w[k] / 2.0, e.clone()));
        e[k] = 4;
        terms.push((beta[k] / 4.0, e.clone()));
        e[k] = 0;
        e[3 + k] = 2;
        terms.push((w[k] / 2.0, e));
    }
    let build = |t: &[(f64, Vec<u8>)]| {
        let r: Vec<(f64, &[u8])> = t.iter().map(|(c, e)| (*c, &e[..])).collect();
        PolynomialHamiltonian::from_terms(3, &r)
    };
    let opts = Options::with_order(6).error_estimate(false);
    let nf = normalize(&build(&terms), &Point::Given(vec![0.0; 6]), &opts).unwrap();
    assert_eq!(nf.signs, vec![1, 1, 1]);
    for k in 0..3 {
        // ω sorted decreasing: mode k is at position 2 − k
        let mut a = [0u32; 3];
        a[2 - k] = 2;
        let expected = 3.0 * beta[k] / 8.0;
        assert!(
            (nf.coefficient(&a) - expected).abs() < 1e-14,
            "{a:?}: {} vs {expected}",
            nf.coefficient(&a)
        );
    }
    let mut coupled = terms.clone();
    coupled.push((0.1, vec![1, 1, 1, 0, 0, 0]));
    let h = build(&coupled);
    let f = normalize(&h, &Point::Given(vec![0.0; 6]), &opts).unwrap();
    let d = normalize(
        &h,
        &Point::Given(vec![0.0; 6]),
        &opts.clone().precision(Precision::DoubleDouble),
    )
    .unwrap();
    assert_eq!(f.hamiltonian.len(), d.hamiltonian.len());
    for (a, b) in f.hamiltonian.iter().zip(&d.hamiltonian) {
        let y = b.coeff.value + b.coeff.lo;
        assert!(
            (a.coeff.value - y).abs() <= 1e-12 * y.abs().max(1e-3),
            "{:?}: {} vs {y}",
            a.exponents,
            a.coeff.value
        );
    }
    assert!(f.coefficient(&[1, 1, 1]).abs() > 1e-4);
    // the transformation maps back and forth
    let wv = [1e-3, -2e-3, 5e-4, 1.5e-3, 7e-4, -1e-3];
    let back = f.to_normal(&f.from_normal(&wv).unwrap()).unwrap();
    assert!(back.iter().zip(&wv).all(|(a, b)| (a - b).abs() < 1e-14));
}

/// `models/coupled_oscillators.lsl`: frequencies √2 and 1 with cubic and quartic couplings.
#[test]
fn coupled_oscillators_frequencies() {
    let model = common::oscillators_model();
    let h = lasalle_normal_form::ModelHamiltonian::new(model, &[]).unwrap();
    let nf = normalize(
        &h,
        &Point::Newton(vec![0.01, -0.02, 0.0, 0.01]),
        &Options::with_order(10),
    )
    .unwrap();
    let om = nf.frequencies_linear();
    assert!((om[0] - 2f64.sqrt()).abs() < 1e-14 && (om[1] - 1.0).abs() < 1e-14);
    assert_eq!(nf.signs, vec![1, 1]);
    assert!(nf.equilibrium.iter().all(|v| v.value.abs() < 1e-15));
    assert!(nf.to_rust().is_some());
    // frequencies measured along true orbits
    let z0 = nf.from_normal(&[0.05, 0.03, 0.0, 0.0]).unwrap();
    let measured = measure_frequencies(&h, &nf, &z0, 600.0, 0.25, 1e-13).unwrap();
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

/// The planar CR3BP written out by hand (seed eq. 6; primaries 1−μ at (−μ, 0) and μ at
/// (1−μ, 0)): an independent cross-check of the DSL path (parser, lowering, `Graph::eval`
/// over jets) that `models/cr3bp.lsl` goes through.
struct HandWrittenCr3bp {
    mu: f64,
}

impl HamiltonianFn for HandWrittenCr3bp {
    fn n_dof(&self) -> usize {
        2
    }
    fn eval<S: Scalar>(&self, z: &[S]) -> S {
        let (q1, q2, p1, p2) = (&z[0], &z[1], &z[2], &z[3]);
        let mu = S::from_f64(self.mu);
        let one_mu = S::from_f64(1.0).sub(&mu);
        let a = q1.add(&mu);
        let b = q1.sub(&one_mu);
        let r1sq = a.mul(&a).add(&q2.mul(q2));
        let r2sq = b.mul(&b).add(&q2.mul(q2));
        let kinetic = S::from_f64(0.5).mul(&p1.mul(p1).add(&p2.mul(p2)));
        let coriolis = q2.mul(p1).sub(&q1.mul(p2));
        kinetic
            .add(&coriolis)
            .sub(&one_mu.mul(&r1sq.sqrt().recip()))
            .sub(&mu.mul(&r2sq.sqrt().recip()))
    }
}

#[test]
fn dsl_cr3bp_agrees_with_the_hand_written_one() {
    let mu = 0.01;
    let hand = HandWrittenCr3bp { mu };
    let dsl = common::cr3bp(mu);
    let l4 = dsl.point("L4").unwrap();
    let s = 3f64.sqrt() / 2.0;
    assert_eq!(l4, vec![0.5 - mu, s, -s, 0.5 - mu]);
    let z = [0.3, 0.7, -0.8, 0.45];
    let (a, b): (f64, f64) = (hand.eval(&z), dsl.eval(&z));
    assert!((a - b).abs() < 1e-15, "{a} vs {b}");
    for precision in [Precision::F64, Precision::DoubleDouble] {
        let opts = Options::with_order(8)
            .precision(precision)
            .error_estimate(false);
        let from_file = common::l4_normal_form(mu, &opts).unwrap();
        let direct = normalize(&hand, &Point::Newton(l4.clone()), &opts).unwrap();
        assert_eq!(from_file.hamiltonian.len(), direct.hamiltonian.len());
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
}

#[test]
fn model_files_and_their_errors() {
    let nf = normalize_model_file(
        common::workspace_file("models/coupled_oscillators.lsl"),
        &[],
        &ModelPoint::Auto,
        &Options::with_order(8),
    )
    .expect("model normal form");
    assert_eq!(nf.n_dof, 2);
    assert!((nf.frequencies_linear()[0] - 2f64.sqrt()).abs() < 1e-14);
    let e = normalize_model_file(
        common::workspace_file("models/cr3bp.lsl"),
        &[("nu".into(), 0.1)],
        &ModelPoint::Auto,
        &Options::default(),
    );
    assert!(e
        .unwrap_err()
        .to_string()
        .contains("unknown parameter `nu`"));
}
