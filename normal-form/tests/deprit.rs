//! D₄ at L4 against Deprit & Deprit-Bartholomé's closed form, and the critical mass ratio μ_c.

mod common;

use lasalle_normal_form::validate::{deprit_d4, mu_routh, EARTH_MOON_MU};
use lasalle_normal_form::{normalize, Dd, Options, Point, Precision};

/// D₄ of `models/cr3bp.lsl` at its point L4, given as an exact equilibrium.
fn d4(mu: f64, precision: Precision) -> f64 {
    let opts = Options::with_order(4)
        .precision(precision)
        .error_estimate(false)
        .transform(false);
    let h = common::cr3bp(mu);
    let nf = normalize(&h, &Point::Given(common::l4(mu)), &opts).expect("normal form");
    let d = nf.d4.expect("two degrees of freedom").d4;
    d.value + d.lo
}

/// The textbook D₄ in double-double (the f64 `deprit_d4` loses a few ulps to the
/// cancellation in 36 − 541w + 644w² near μ_c, more than the 1e-15 checked here).
fn deprit_d4_dd(mu: f64) -> f64 {
    let c = Dd::new;
    let w = c(mu) * (c(1.0) - c(mu)) * c(6.75);
    let num = c(36.0) - c(541.0) * w + c(644.0) * w * w;
    let den = c(8.0) * (c(1.0) - c(4.0) * w) * (c(4.0) - c(25.0) * w);
    let d = -(num / den);
    d.hi + d.lo
}

/// Our D₄ is the textbook expression with the opposite sign (see the crate docs, "Sign of D₄"),
/// its magnitude to 1e-15 relative in double-double and 1e-10 in f64 (docs/normal-form.md), on
/// the μ of the table there and across the stable range.
#[test]
fn d4_matches_deprit_across_the_stable_range() {
    let mu_r = mu_routh();
    // away from 1:3 (0.013516), 1:2 (0.024294), μ_c (D₄ = 0) and μ_R (1:1)
    let mus = [
        1e-4,
        5e-4,
        0.001,
        0.003,
        0.005,
        0.008,
        0.01,
        EARTH_MOON_MU,
        0.016,
        0.02,
        0.028,
        0.03,
        0.034,
        0.037,
    ];
    for (precision, tol) in [(Precision::F64, 1e-10), (Precision::DoubleDouble, 1e-15)] {
        let mut worst = 0.0f64;
        for &mu in &mus {
            assert!(mu < mu_r);
            let reference = deprit_d4_dd(mu);
            assert!(((reference - deprit_d4(mu)) / reference).abs() < 1e-13);
            let ours = d4(mu, precision);
            let rel = ((ours + reference) / reference).abs();
            worst = worst.max(rel);
            assert!(
                rel < tol,
                "mu = {mu} ({precision}): ours {ours}, Deprit {reference}, rel {rel:e}"
            );
        }
        println!("{precision}: largest relative difference from -D4(Deprit) {worst:.1e}");
    }
}

#[test]
fn critical_mass_ratio_from_our_d4() {
    // secant/bisection on our D₄(μ) in double-double
    let (mut a, mut b) = (0.0105, 0.0113);
    let (mut fa, fb) = (
        d4(a, Precision::DoubleDouble),
        d4(b, Precision::DoubleDouble),
    );
    assert!(fa * fb < 0.0);
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        let fm = d4(m, Precision::DoubleDouble);
        if fm * fa <= 0.0 {
            b = m;
        } else {
            a = m;
            fa = fm;
        }
        if b - a < 1e-15 {
            break;
        }
    }
    let mu_c = 0.5 * (a + b);
    // the zero of 36 − 541w + 644w², w = 27μ(1−μ)/4
    let w = (541.0 - 199_945f64.sqrt()) / 1288.0;
    let exact = (1.0 - (1.0 - 16.0 * w / 27.0).sqrt()) / 2.0;
    assert!((mu_c - 0.0109137).abs() < 1e-7, "mu_c = {mu_c}");
    assert!(
        (mu_c - exact).abs() < 1e-12,
        "mu_c = {mu_c}, closed form {exact}"
    );
}

/// The quartic coefficients one by one, against the closed forms of Deprit & Deprit-Bartholomé
/// (1967) as given in Meyer, Hall & Offin, *Introduction to Hamiltonian Dynamical Systems and
/// the N-Body Problem*: with w = ω₁²ω₂²,
///
/// ```text
/// A = ω₂²(81 − 696ω₁² + 124ω₁⁴) / (72(1 − 2ω₁²)²(1 − 5ω₁²))
/// B = −ω₁ω₂(43 + 64w) / (6(1 − 4w)(4 − 25w))
/// C = ω₁²(81 − 696ω₂² + 124ω₂⁴) / (72(1 − 2ω₂²)²(1 − 5ω₂²))
/// ```
///
/// They settle the sign of D₄: these very A, B, C give Aω₂² + 2Bω₁ω₂ + Cω₁² =
/// +(36 − 541w + 644w²)/(8(1 − 4w)(4 − 25w)), so the leading minus of the textbook D₄ does not
/// follow from its own coefficients; ours agree with all three and with integrated orbits.
#[test]
fn quartic_coefficients_match_the_closed_forms() {
    for mu in [0.001, 0.005, 0.01, EARTH_MOON_MU, 0.02, 0.03] {
        let opts = Options::with_order(4)
            .precision(Precision::DoubleDouble)
            .error_estimate(false)
            .transform(false);
        let nf = normalize(&common::cr3bp(mu), &Point::Given(common::l4(mu)), &opts)
            .expect("normal form");
        let am = nf.d4.expect("two degrees of freedom");
        let (o1, o2) = lasalle_normal_form::validate::l4_frequencies(mu);
        let w = o1 * o1 * o2 * o2;
        let a = o2 * o2 * (81.0 - 696.0 * o1 * o1 + 124.0 * o1.powi(4))
            / (72.0 * (1.0 - 2.0 * o1 * o1).powi(2) * (1.0 - 5.0 * o1 * o1));
        let b = -o1 * o2 * (43.0 + 64.0 * w) / (6.0 * (1.0 - 4.0 * w) * (4.0 - 25.0 * w));
        let c = o1 * o1 * (81.0 - 696.0 * o2 * o2 + 124.0 * o2.powi(4))
            / (72.0 * (1.0 - 2.0 * o2 * o2).powi(2) * (1.0 - 5.0 * o2 * o2));
        for (name, ours, closed) in [
            ("A", am.a.value, a),
            ("B", am.b.value, b),
            ("C", am.c.value, c),
        ] {
            assert!(
                ((ours - closed) / closed).abs() < 1e-10,
                "mu = {mu}: {name} = {ours}, closed form {closed}"
            );
        }
        let d = a * o2 * o2 + 2.0 * b * o1 * o2 + c * o1 * o1;
        assert!(
            ((d + deprit_d4(mu)) / d).abs() < 1e-10,
            "mu = {mu}: the closed forms give D4 = {d}"
        );
    }
}
