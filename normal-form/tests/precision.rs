//! Accuracy beyond f64. Errors are measured against double-double runs in a rotated normal
//! basis (H̄ does not depend on the basis, rounding does), an estimate independent of the
//! precision itself.

mod common;

use lasalle_normal_form::validate::EARTH_MOON_MU;
use lasalle_normal_form::{NormalForm, Options, Precision};

fn run(mu: f64, order: usize, precision: Precision, rotation: Vec<f64>) -> NormalForm {
    let mut opts = Options::with_order(order)
        .precision(precision)
        .error_estimate(false)
        .transform(false);
    opts.basis_rotation = rotation;
    common::l4_normal_form(mu, &opts).unwrap()
}

fn worst_relative(a: &NormalForm, b: &NormalForm, max_degree: usize) -> f64 {
    a.hamiltonian
        .iter()
        .zip(&b.hamiltonian)
        .filter(|(x, _)| x.degree <= max_degree)
        .map(|(x, y)| {
            (((x.coeff.value - y.coeff.value) + (x.coeff.lo - y.coeff.lo))
                / (y.coeff.value + y.coeff.lo))
                .abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn double_double_at_mu_0_001_through_degree_12() {
    let dd = run(0.001, 12, Precision::DoubleDouble, vec![]);
    let dd_rot = run(0.001, 12, Precision::DoubleDouble, vec![0.7, -1.3]);
    let err = worst_relative(&dd_rot, &dd, 12);
    assert!(err < 1e-10, "dd relative error {err:e}");
    // f64 loses the degree-12 coefficients there (small divisor ω₂ ≈ 0.082)
    let f = run(0.001, 12, Precision::F64, vec![]);
    assert!(worst_relative(&f, &dd, 12) > 1e-3);
}

/// f64 through degree 8 at Earth–Moon: every coefficient to 1e-10 relative (I₁⁴ = 1.28 sits
/// next to I₁²I₂² = −5.5e4), thanks to the compensated low degrees; plain f64 arithmetic
/// loses I₁⁴ to ~2e-9 (see the crate docs, "f64 at Earth–Moon").
#[test]
fn f64_at_earth_moon() {
    let dd = run(EARTH_MOON_MU, 8, Precision::DoubleDouble, vec![]);
    let f = run(EARTH_MOON_MU, 8, Precision::F64, vec![]);
    let e6 = worst_relative(&f, &dd, 6);
    let e8 = worst_relative(&f, &dd, 8);
    assert!(e6 < 2e-11, "f64 through degree 6: {e6:e}");
    assert!(e8 < 1e-10, "f64 through degree 8: {e8:e}");
    let mut plain = Options::with_order(8)
        .error_estimate(false)
        .transform(false);
    plain.compensated_degree = 0;
    let p = common::l4_normal_form(EARTH_MOON_MU, &plain).unwrap();
    let e8_plain = worst_relative(&p, &dd, 8);
    assert!(e8_plain > 5.0 * e8, "plain f64 {e8_plain:e} vs {e8:e}");
}

#[test]
fn error_estimates_are_reported() {
    let nf = common::l4_normal_form(0.001, &Options::with_order(8).transform(false)).unwrap();
    assert!(nf.hamiltonian.iter().all(|t| t.coeff.error.is_some()));
    // the estimate |f64 − dd| is the actual f64 error
    let dd = run(0.001, 8, Precision::DoubleDouble, vec![]);
    for (t, r) in nf.hamiltonian.iter().zip(&dd.hamiltonian) {
        let actual = ((t.coeff.value - r.coeff.value) - r.coeff.lo).abs();
        assert!(
            (t.coeff.error.unwrap() - actual).abs() <= 1e-3 * actual + 1e-16 * r.coeff.value.abs()
        );
    }
}

/// Quad-double against double-double at Earth–Moon through order 12: the same coefficients
/// to double-double's own accuracy there (~1e-25, see the crate docs), and quad-double
/// against itself in a rotated basis far below that (its unit roundoff is 2⁻²⁰⁹).
#[test]
fn quad_double_agrees_with_double_double_at_low_order() {
    let dd = run(EARTH_MOON_MU, 12, Precision::DoubleDouble, vec![]);
    let qd = run(EARTH_MOON_MU, 12, Precision::QuadDouble, vec![]);
    let qd_rot = run(EARTH_MOON_MU, 12, Precision::QuadDouble, vec![0.7, -1.3]);
    assert_eq!(qd.precision, Precision::QuadDouble);
    let e = worst_relative(&dd, &qd, 12);
    assert!(e < 1e-22, "dd against qd: {e:e}");
    // the reported values carry double-double digits, so this compares qd runs to ~1e-31
    let e = worst_relative(&qd_rot, &qd, 12);
    assert!(e < 1e-29, "qd rotated: {e:e}");
    // the frequencies agree with the double-double ones to the last dd digit
    for (a, b) in qd.omega.iter().zip(&dd.omega) {
        assert!(
            ((a.value - b.value) + (a.lo - b.lo)).abs() < 1e-30,
            "{a:?} {b:?}"
        );
    }
}

/// Sun–Jupiter beyond order 23: double-double loses the degree-24 coefficients and the
/// automatic precision goes on to quad-double, which keeps them.
#[test]
fn automatic_precision_reaches_quad_double_at_sun_jupiter() {
    let opts = Options::with_order(26)
        .transform(false)
        .estimate(lasalle_normal_form::ErrorEstimate::Rotation)
        .precision(Precision::DoubleDouble);
    match common::l4_normal_form(SUN_JUPITER_MU, &opts) {
        Err(lasalle_normal_form::NormalFormError::PrecisionLost { degree, .. }) => {
            assert!((20..=26).contains(&degree), "{degree}")
        }
        other => panic!(
            "expected dd to lose precision, got {:?}",
            other.map(|n| n.precision)
        ),
    }
    let nf = common::l4_normal_form(SUN_JUPITER_MU, &opts.auto_precision(true)).unwrap();
    assert_eq!(nf.precision, Precision::QuadDouble);
    assert!(nf
        .diagnostics
        .precision_note
        .as_ref()
        .unwrap()
        .contains("quad-double"));
    for d in &nf.diagnostics.hbar_degrees {
        assert!(d.max_relative_error.unwrap() < 1e-20, "{d:?}");
    }
}

/// Sun–Jupiter: μ = m_J/(m_S + m_J) with m_S/m_J = 1047.35.
const SUN_JUPITER_MU: f64 = 0.000953875;
