//! Certified tube times (`interval::certified`): against a closed form, against integration,
//! and below the estimate at Earth–Moon L4.

mod common;

use lasalle_normal_form::bound::{tube_radii, Bound, Metric, Norm};
use lasalle_normal_form::interval::certified::{certified_tube, CertifiedOptions};
use lasalle_normal_form::models::PolynomialHamiltonian;

use lasalle_normal_form::validate::EARTH_MOON_MU;
use lasalle_normal_form::{normalize, MonomialTable, Options, Point, Poly, PolyMap};
use std::sync::Arc;

/// H = ½(q² + p²) − q³/3 with W = |y|² (the identity map, no normalisation): the field in
/// the linear normal coordinates is (ṗ, −q̇) up to the sign convention, Ẇ = ±2pq², whose
/// majorant is 2r³, so dρ/dt ≤ ρ² and the certified time is 1/ρ₀ − 1/ρ₁ exactly (from below:
/// the quadrature and the rounding only lose).
#[test]
fn closed_form_without_normalisation_and_against_integration() {
    let h = PolynomialHamiltonian::from_terms(
        1,
        &[(0.5, &[2, 0]), (0.5, &[0, 2]), (-1.0 / 3.0, &[3, 0])],
    );
    let mut nf = normalize(&h, &Point::Given(vec![0.0, 0.0]), &Options::with_order(4)).unwrap();
    let t = Arc::new(MonomialTable::new(2, 3));
    nf.to_normal_map = Some(PolyMap {
        components: (0..2).map(|v| Poly::variable(t.clone(), v, 0.0)).collect(),
    });
    let (d0, d1) = (0.3, 0.31);
    let c = certified_tube(
        &h,
        &nf,
        d0,
        d1,
        Metric::LinearNormal,
        &CertifiedOptions::default(),
    )
    .unwrap();
    assert_eq!((c.rho0, c.rho1), (0.3f64.next_up(), 0.31f64.next_down()));
    let exact = 1.0 / 0.3 - 1.0 / 0.31;
    let time = c.time.unwrap();
    assert!(
        time <= exact && time > exact * (1.0 - 2e-3),
        "{time} vs {exact}"
    );
    // the majorant of Ẇ is 2r³ and nothing else (up to rounding-size terms)
    assert!((c.wdot.c[3] - 2.0).abs() < 1e-12, "{:?}", c.wdot.c);
    assert!(c
        .wdot
        .c
        .iter()
        .enumerate()
        .all(|(s, &v)| s == 3 || v < 1e-12));
    // integration (RK4, dt = 1e-4) from 360 points of the inner circle: every orbit that
    // reaches |y| = d1 needs at least the certified time (about 0.28 for the fastest)
    let f = |z: [f64; 2]| [z[1], -z[0] + z[0] * z[0]];
    let mut fastest = f64::INFINITY;
    for k in 0..360 {
        let th = k as f64 * std::f64::consts::PI / 180.0;
        let mut z = [d0 * th.cos(), d0 * th.sin()];
        let dt = 1e-4;
        let mut t = 0.0;
        while t < 10.0 {
            let k1 = f(z);
            let k2 = f([z[0] + 0.5 * dt * k1[0], z[1] + 0.5 * dt * k1[1]]);
            let k3 = f([z[0] + 0.5 * dt * k2[0], z[1] + 0.5 * dt * k2[1]]);
            let k4 = f([z[0] + dt * k3[0], z[1] + dt * k3[1]]);
            for i in 0..2 {
                z[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            t += dt;
            if z[0].hypot(z[1]) >= d1 {
                fastest = fastest.min(t);
                break;
            }
        }
    }
    assert!(fastest.is_finite(), "some orbit leaves");
    assert!(
        time <= fastest,
        "certified {time} > integrated exit {fastest}"
    );
    assert!(fastest < 0.5, "{fastest}");
}

/// At Earth–Moon L4 the certified time is a positive lower bound, below the estimate of the
/// same order and tube.
#[test]
fn earth_moon_l4_certified_below_the_estimate() {
    let h = common::cr3bp(EARTH_MOON_MU);
    let (n, d0) = (6usize, 2.5e-3);
    {
        let opts = Options {
            remainder_degree: Some((2 * n).min(n + 8)),
            inverse_transform: false,
            ..Options::with_order(n)
        };
        let nf = common::l4_normal_form(EARTH_MOON_MU, &opts).unwrap();
        let d1 = 2.0 * d0;
        let start = std::time::Instant::now();
        let c = certified_tube(
            &h,
            &nf,
            d0,
            d1,
            Metric::LinearNormal,
            &CertifiedOptions::default(),
        )
        .unwrap();
        let r = tube_radii(&nf, d0, d1, Metric::LinearNormal).unwrap();
        let est = Bound::new(nf.remainder.as_ref().unwrap(), Norm::Gradient)
            .time(r.rho0, r.rho1)
            .lower;
        eprintln!(
            "N = {n}, d0 = {d0}: certified {:?} (ρ₀ ≤ {:.5e}, ρ₁ ≥ {:.5e}, {:.2} s), estimate {est:.4e} (ρ₀ {:.5e}, ρ₁ {:.5e})",
            c.time, c.rho0, c.rho1, start.elapsed().as_secs_f64(), r.rho0, r.rho1
        );
        assert!(c.rho0 >= r.rho0 && c.rho1 <= r.rho1);
        let time = c.time.expect("a certified time");
        assert!(time > 0.0 && time <= est, "{time} vs {est}");
    }
}
