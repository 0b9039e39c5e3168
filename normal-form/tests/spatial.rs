//! The spatial restricted three-body problem (`models/cr3bp_spatial.lsl`) at L4: three degrees
//! of freedom, vertical frequency 1, and the planar model on I_z = 0.

mod common;

use lasalle_normal_form::{NormalForm, Options, Precision};
use lasalle_testkit::same;
use std::time::Instant;

const EARTH_MOON: f64 = 0.01215058560962404;

/// Index of the vertical mode (frequency 1) and the map from the planar modes (ω₁ > ω₂) to
/// the spatial ones.
fn modes(nf: &NormalForm) -> (usize, [usize; 2]) {
    let w = nf.frequencies_linear();
    let v = w
        .iter()
        .position(|x| (x - 1.0).abs() < 1e-12)
        .expect("a vertical frequency 1");
    let planar: Vec<usize> = (0..3).filter(|&k| k != v).collect();
    (v, [planar[0], planar[1]])
}

#[test]
fn spatial_l4_to_order_16_in_double_double() {
    let t = Instant::now();
    let opts = Options::with_order(16)
        .precision(Precision::DoubleDouble)
        .error_estimate(false)
        .transform(false);
    let nf = common::spatial_l4_normal_form(EARTH_MOON, &opts).expect("spatial normal form");
    let spatial_time = t.elapsed().as_secs_f64();
    assert_eq!(nf.n_dof, 3);
    let (v, [k1, k2]) = modes(&nf);
    // the vertical oscillation at L4 has frequency exactly 1 (r₁ = r₂ = 1), and positive sign
    let w = nf.frequencies_linear();
    assert!((w[v] - 1.0).abs() < 1e-15, "vertical frequency {}", w[v]);
    assert_eq!(nf.signs[v], 1);
    assert!(nf.diagnostics.symplectic_residual < 1e-25);
    assert!(nf.diagnostics.hbar_imag_residual < 1e-20);

    let planar = common::l4_normal_form(EARTH_MOON, &opts).expect("planar normal form");
    let wp = planar.frequencies_linear();
    assert!(
        wp.len() == 2 && same(wp[0], w[k1]) && same(wp[1], w[k2]),
        "{wp:?} vs {w:?}"
    );
    assert_eq!(planar.signs, vec![nf.signs[k1], nf.signs[k2]]);
    // with I_z = 0 every coefficient is the planar model's: compare the whole tables
    let mut compared = 0;
    let mut worst: f64 = 0.0;
    for t in nf.hamiltonian.iter().filter(|t| t.exponents[v] == 0) {
        let a = [t.exponents[k1], t.exponents[k2]];
        let p = planar
            .hamiltonian
            .iter()
            .find(|u| u.exponents == a)
            .expect("the same monomial in the planar table");
        let (x, y) = (t.coeff.value + t.coeff.lo, p.coeff.value + p.coeff.lo);
        let rel = (x - y).abs() / y.abs();
        worst = worst.max(rel);
        // the leading parts bit for bit, the double-double values to 1e-24 (docs/normal-form.md)
        assert!(
            same(t.coeff.value, p.coeff.value) && rel <= 1e-24,
            "I^{a:?}: spatial {x:e} ({:e}), planar {y:e} ({:e})",
            t.coeff.lo,
            p.coeff.lo
        );
        compared += 1;
    }
    assert_eq!(compared, planar.hamiltonian.len());
    eprintln!(
        "spatial L4, order 16, dd: {spatial_time:.2} s; {} coefficients, planar ones agree to {worst:.1e}",
        nf.hamiltonian.len()
    );
    // and the vertical action does couple: I_z² and I_z I_1 terms are present
    let coupled = nf
        .hamiltonian
        .iter()
        .filter(|t| t.exponents[v] > 0 && t.degree == 4)
        .filter(|t| t.coeff.value.abs() > 1e-3)
        .count();
    assert!(coupled >= 2, "{coupled}");
    // a generous bound for two shared cores (measured: see the crate docs)
    assert!(
        spatial_time < 120.0,
        "3-DOF order 16 in dd took {spatial_time:.1} s"
    );
}

#[test]
fn spatial_l4_frequency_map_at_low_order_in_f64() {
    // the same in f64 at order 8, with the transformation: the vertical frequency shifts with
    // the planar actions through the coupling terms, and the table lists D4 only for 2 DOF
    let nf = common::spatial_l4_normal_form(EARTH_MOON, &Options::with_order(8))
        .expect("spatial normal form");
    assert!(nf.d4.is_none());
    let (v, _) = modes(&nf);
    let nu = nf.frequencies(&[0.0, 0.0, 0.0]);
    assert!((nu[v] - 1.0).abs() < 1e-14);
    let z = [
        0.5 - EARTH_MOON + 1e-3,
        0.866,
        1e-3,
        -0.866,
        0.5 - EARTH_MOON,
        0.0,
    ];
    let actions = nf.actions(&z).expect("transformation");
    assert!(actions.iter().all(|&i| i >= 0.0));
    assert!(actions[v] > 0.0);
}
