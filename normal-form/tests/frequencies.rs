//! The normal form against the true flow: frequencies measured along DOPRI5 orbits of the full
//! CR3BP near L4 (Earth–Moon), and the truncated normal-form flow against the linear one.

mod common;

use lasalle_normal_form::validate::{measure_frequencies, orbit, EARTH_MOON_MU};
use lasalle_normal_form::{NormalForm, Options};

fn nf(order: usize) -> NormalForm {
    common::l4_normal_form(
        EARTH_MOON_MU,
        &Options::with_order(order).error_estimate(false),
    )
    .unwrap()
}

#[test]
fn frequencies_converge_to_the_measured_ones() {
    let h = common::cr3bp(EARTH_MOON_MU);
    let reference = nf(14);
    // actions I ≈ 5e-5 in both modes (normal amplitudes 0.01)
    let z0 = reference.from_normal(&[0.01, 0.0, 0.0, 0.01]).unwrap();
    let measured = measure_frequencies(&h, &reference, &z0, 1000.0, 0.5, 1e-13).unwrap();
    let mut errors = Vec::new();
    for order in [2, 4, 6, 8, 10] {
        let f = nf(order);
        let nu = f.frequencies(&f.actions(&z0).unwrap_or(vec![0.0; 2]));
        let err = nu
            .iter()
            .zip(&measured)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        errors.push(err);
    }
    // linear: 7.5e-5; order 4: ~3e-6; order 6: ~2e-9; then the measurement floor (~1e-10)
    assert!(
        errors[0] > 5e-5
            && errors[1] < 5e-6
            && errors[2] < 1e-8
            && errors[3] < 2e-9
            && errors[4] < 2e-9,
        "{errors:?}"
    );
    assert!(
        errors[0] > 10.0 * errors[1] && errors[1] > 100.0 * errors[2],
        "{errors:?}"
    );
}

#[test]
fn normal_form_flow_tracks_the_orbit_better_than_the_linear_flow() {
    let h = common::cr3bp(EARTH_MOON_MU);
    let nf = nf(10);
    let z0 = nf.from_normal(&[0.02, 0.0, 0.01, 0.0]).unwrap();
    // over T = 100 (≈ 15 short and 5 long periods)
    let times: Vec<f64> = (1..=20).map(|k| 5.0 * k as f64).collect();
    let zs = orbit(&h, &z0, &times, 1e-13).unwrap();
    let (mut worst_nf, mut worst_lin): (f64, f64) = (0.0, 0.0);
    for (&t, z) in times.iter().zip(&zs) {
        let dist = |a: &[f64]| {
            a.iter()
                .zip(z)
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        worst_nf = worst_nf.max(dist(&nf.flow(&z0, t).unwrap()));
        worst_lin = worst_lin.max(dist(&nf.linear_flow(&z0, t)));
    }
    assert!(
        worst_nf < 1e-5 && worst_lin > 1e-2,
        "normal form {worst_nf:e}, linear {worst_lin:e}"
    );
    assert!(worst_nf * 1e3 < worst_lin);
}

#[test]
fn transformations_are_inverse_and_symplectic() {
    let nf = nf(12);
    assert!(nf.diagnostics.symplectic_residual < 1e-13);
    let w = [1e-3, -2e-3, 5e-4, 1.5e-3];
    let back = nf.to_normal(&nf.from_normal(&w).unwrap()).unwrap();
    assert!(
        back.iter().zip(&w).all(|(a, b)| (a - b).abs() < 1e-15),
        "{back:?}"
    );
    // H is conserved into H̄: H(z) = H̄(I(z)) up to the truncation
    let h = common::cr3bp(EARTH_MOON_MU);
    let z = nf.from_normal(&w).unwrap();
    let hz: f64 = lasalle_normal_form::HamiltonianFn::eval(&h, &z);
    let hbar = nf.energy_at(&nf.actions(&z).unwrap());
    assert!((hz - hbar).abs() < 1e-15, "{hz} vs {hbar}");
}
