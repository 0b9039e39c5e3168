//! Certified tube times (`interval::certified`): against a closed form, against integration,
//! and below the estimate at Earth–Moon L4.

mod common;

use lasalle_normal_form::bound::{tube_radii, Bound, Metric, Norm, TubeRadii};
use lasalle_normal_form::interval::certified::{certified_tube, CertifiedOptions, CertifiedTube};
use lasalle_normal_form::models::PolynomialHamiltonian;

use lasalle_normal_form::validate::EARTH_MOON_MU;
use lasalle_normal_form::{
    normalize, taylor, HamiltonianFn, MonomialTable, NormalForm, Options, Point, Poly, PolyMap,
};
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
    // the majorant of Ẇ = ±2pq² on |y| = r is (4/3)^{1/2} r³ (Cauchy–Schwarz with the
    // weight α!/s! = 1/3 of pq², against 2r³ for the ℓ¹ sum), so dρ/dt ≤ ρ²/√3 and the
    // certified time is √3 (1/ρ₀ − 1/ρ₁), from below
    let exact = 3f64.sqrt() * (1.0 / 0.3 - 1.0 / 0.31);
    let time = c.time.unwrap();
    assert!(
        time <= exact && time > exact * (1.0 - 2e-3),
        "{time} vs {exact}"
    );
    assert!(
        (c.wdot.c[3] - (4.0f64 / 3.0).sqrt()).abs() < 1e-12,
        "{:?}",
        c.wdot.c
    );
    assert!(c
        .wdot
        .c
        .iter()
        .enumerate()
        .all(|(s, &v)| s == 3 || v < 1e-12));
    // integration (RK4, dt = 1e-4) from 360 points of the inner circle: every orbit that
    // reaches |y| = d1 needs at least the certified time (about 0.28 for the fastest; the
    // true maximum of |Ẇ| on the circle, 4r³/(3√3), would give 0.279: the orbit along the
    // worst direction nearly attains it)
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

/// |Ẇ(y)| at a point, in f64, from the model's own gradient (a degree-1 jet) and the map
/// truncated as the certified bound truncates it: ẏ = B J ∇H(x_e + A y),
/// Ẇ = 2 Σ_i T_i(y) Σ_j ∂_j T_i(y) ẏ_j. Independent of the interval Taylor models.
fn wdot_at<H: HamiltonianFn>(h: &H, nf: &NormalForm, map_degree: usize, y: &[f64]) -> f64 {
    let n = y.len();
    let xe = nf.equilibrium_f64();
    let x: Vec<f64> = (0..n)
        .map(|i| xe[i] + (0..n).map(|j| nf.linear_map[i][j] * y[j]).sum::<f64>())
        .collect();
    let t1 = Arc::new(MonomialTable::new(n, 1));
    let p = taylor(h, &x, &t1);
    let grad: Vec<f64> = (0..n)
        .map(|i| {
            let mut e = vec![0u8; n];
            e[i] = 1;
            p.coeff(&e)
        })
        .collect();
    let nd = n / 2;
    let xdot: Vec<f64> = (0..n)
        .map(|i| if i < nd { grad[i + nd] } else { -grad[i - nd] })
        .collect();
    let ydot: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| nf.linear_inverse[i][j] * xdot[j]).sum())
        .collect();
    let map = nf.to_normal_map.as_ref().unwrap();
    let mut w = 0.0;
    for ti in &map.components {
        let mut ti = ti.clone();
        ti.truncate(map_degree);
        let dt: f64 = (0..n).map(|j| ti.derivative(j).eval(y) * ydot[j]).sum();
        w += 2.0 * ti.eval(y) * dt;
    }
    w.abs()
}

/// The certified majorant G of |Ẇ| holds at `samples` points of each sphere |y| = r
/// (r from y0/2 to y1; pseudo-random directions); returns the largest |Ẇ|/G(r) seen.
fn check_majorant<H: HamiltonianFn>(
    h: &H,
    nf: &NormalForm,
    c: &CertifiedTube,
    samples: usize,
) -> f64 {
    let n = 2 * nf.n_dof;
    let mut rng = lasalle_testkit::Rng::new(0x9e37_79b9_7f4a_7c15);
    let mut worst: f64 = 0.0;
    for r in [0.5 * c.y0, c.y0, 0.5 * (c.y0 + c.y1), c.y1] {
        let g = c.wdot.eval(r);
        for _ in 0..samples {
            let v: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            let y: Vec<f64> = v.iter().map(|x| x * r / norm).collect();
            let wd = wdot_at(h, nf, c.map_degree, &y);
            assert!(wd <= g, "|Ẇ| = {wd:e} > G({r:e}) = {g:e} at {y:?}");
            worst = worst.max(wd / g);
        }
    }
    worst
}

/// The certified tube d0 → d1 in the linear normal metric, the estimate's radii of the same
/// tube and the estimate's time.
fn certified_and_estimate<H: HamiltonianFn>(
    h: &H,
    nf: &NormalForm,
    d0: f64,
    d1: f64,
) -> (CertifiedTube, TubeRadii, f64) {
    let metric = Metric::LinearNormal;
    let c = certified_tube(h, nf, d0, d1, metric, &CertifiedOptions::default()).unwrap();
    let r = tube_radii(nf, d0, d1, metric).unwrap();
    let est = Bound::new(nf.remainder.as_ref().unwrap(), Norm::Gradient)
        .time(r.rho0, r.rho1)
        .lower;
    (c, r, est)
}

/// The spatial problem at Earth–Moon L4 (three degrees of freedom, the map cut at degree N):
/// a positive certified time, whose majorant of |Ẇ| holds at sampled points of the spheres.
#[test]
fn spatial_earth_moon_l4_certified() {
    let h = common::cr3bp_spatial(EARTH_MOON_MU);
    let n = 6usize;
    let opts = Options {
        remainder_degree: Some((2 * n).min(n + 8)),
        inverse_transform: false,
        ..Options::with_order(n)
    };
    let nf = common::spatial_l4_normal_form(EARTH_MOON_MU, &opts).unwrap();
    let (d0, d1) = (2.5e-3, 5e-3);
    let start = std::time::Instant::now();
    let (c, _, est) = certified_and_estimate(&h, &nf, d0, d1);
    let worst = check_majorant(&h, &nf, &c, 200);
    eprintln!(
        "spatial N = {n}: certified {:?} (ρ₀ ≤ {:.5e}, ρ₁ ≥ {:.5e}, map degree {}, K = {}, D = {}, {:.1} s), estimate {est:.4e}; sampled |Ẇ|/G ≤ {worst:.3e}",
        c.time, c.rho0, c.rho1, c.map_degree, c.field_degree, c.model_degree, start.elapsed().as_secs_f64()
    );
    assert_eq!(c.map_degree, n);
    assert!(c.rho0 >= d0 && c.rho1 <= d1);
    let time = c.time.expect("a certified time");
    assert!(time > 0.0 && time.is_finite(), "{time}");
}

/// At Earth–Moon L4 the certified time is a positive lower bound whose majorant of |Ẇ|
/// holds at sampled points, and whose ρ₀, ρ₁ enclose the sampled extrema of the estimate.
#[test]
fn earth_moon_l4_certified_against_samples() {
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
        let (c, r, est) = certified_and_estimate(&h, &nf, d0, d1);
        eprintln!(
            "N = {n}, d0 = {d0}: certified {:?} (ρ₀ ≤ {:.5e}, ρ₁ ≥ {:.5e}, {:.2} s), estimate {est:.4e} (ρ₀ {:.5e}, ρ₁ {:.5e})",
            c.time, c.rho0, c.rho1, start.elapsed().as_secs_f64(), r.rho0, r.rho1
        );
        assert!(c.rho0 >= r.rho0 && c.rho1 <= r.rho1);
        let time = c.time.expect("a certified time");
        let worst = check_majorant(&h, &nf, &c, 300);
        eprintln!(
            "sampled |Ẇ|/G ≤ {worst:.3e}; certified/estimate = {:.3}",
            time / est
        );
        assert!(time > 0.0 && time.is_finite(), "{time} vs {est}");
    }
}

/// The certified radius for a time (Earth–Moon L4, N = 4, a small case): the radius found
/// has a certified time ≥ T, a radius 10 % larger has not, the search's bracket is as
/// narrow as asked, and the setup reused across radii gives the same tube as the one-shot
/// [`certified_tube`].
#[test]
fn certified_radius_for_a_time_is_the_largest_that_holds() {
    use lasalle_normal_form::interval::certified::CertifiedSetup;
    let h = common::cr3bp(EARTH_MOON_MU);
    let n = 4usize;
    let opts = Options {
        remainder_degree: Some(2 * n),
        inverse_transform: false,
        ..Options::with_order(n)
    };
    let nf = common::l4_normal_form(EARTH_MOON_MU, &opts).unwrap();
    let setup =
        CertifiedSetup::new(&h, &nf, Metric::LinearNormal, &CertifiedOptions::default()).unwrap();
    // the cached setup and the one-shot function agree exactly
    let (d0, k) = (2.5e-3, 2.0);
    let a = setup.tube(d0, k * d0).unwrap();
    let b = certified_tube(
        &h,
        &nf,
        d0,
        k * d0,
        Metric::LinearNormal,
        &CertifiedOptions::default(),
    )
    .unwrap();
    assert_eq!((a.rho0, a.rho1, a.time), (b.rho0, b.rho1, b.time));
    // a time ten times what this tube certifies: the radius must shrink
    let time = 10.0 * a.time.expect("a certified time at 2.5e-3");
    let r = setup.radius_for_time(time, k, a, 1e-2, 16).unwrap();
    let tube = r.tube.as_ref().expect("a certified radius");
    let d = tube.d0;
    assert!(d < d0, "{d}");
    assert!(tube.time.unwrap() >= time, "{:?} < {time}", tube.time);
    let (failed, _) = r.failed.expect("a bracket");
    assert!(
        failed > d && failed <= 1.01 * d * (1.0 + 1e-12),
        "{failed} vs {d}"
    );
    // independently: the tube 10 % larger does not reach T, and the radius found reaches it
    let larger = setup.tube(1.1 * d, k * 1.1 * d).unwrap();
    assert!(larger.time.is_none_or(|t| t < time), "{:?}", larger.time);
    let again = certified_tube(
        &h,
        &nf,
        d,
        k * d,
        Metric::LinearNormal,
        &CertifiedOptions::default(),
    )
    .unwrap();
    assert!(again.time.unwrap() >= time);
    eprintln!(
        "T = {time:.4e}: certified radius {d:.5e} (T ≥ {:.4e}), fails at {failed:.5e}; {} radii tried, {:.1} s (setup {:.1} s)",
        tube.time.unwrap(),
        r.evaluations.len(),
        r.seconds,
        setup.seconds
    );
    // the certified time falls with the radius over the radii tried
    let mut tried: Vec<(f64, f64)> = r
        .evaluations
        .iter()
        .filter_map(|&(d, t)| t.map(|t| (d, t)))
        .collect();
    tried.sort_by(|x, y| x.0.total_cmp(&y.0));
    assert!(tried.windows(2).all(|w| w[1].1 <= w[0].1), "{tried:?}");
}

/// Sun–Jupiter L4, N = 8: the tube is centred at the true equilibrium, proved (Krawczyk, in
/// balls with double-double centres) to lie in a box of half-width below 10⁻²⁷ that contains the
/// closed form of L4, q = (½ − μ, √3/2), p = (−√3/2, ½ − μ) (checked in quad-double). So Ẇ
/// has no degree-1 term, and its degree-2 term, enclosed in balls, is far below what the
/// `f64` centre and the `f64` enclosures of B⁻¹ and BJBᵀ left (2.5·10⁻¹³ r and
/// 7·10⁻¹¹ r², which held the certified time below 2·10⁹ at every order: 4.1696e8 here).
#[test]
fn sun_jupiter_l4_certified_above_the_rounding_floor() {
    use lasalle_normal_form::interval::certified::CertifiedSetup;
    use lasalle_normal_form::{Coeff, Qd, Real};
    let mu = 0.000953875;
    let h = common::cr3bp(mu);
    let n = 8usize;
    let opts = Options {
        remainder_degree: Some((2 * n).min(n + 8)),
        inverse_transform: false,
        ..Options::with_order(n)
    };
    let nf = common::l4_normal_form(mu, &opts).unwrap();
    let setup =
        CertifiedSetup::new(&h, &nf, Metric::LinearNormal, &CertifiedOptions::default()).unwrap();
    let centre = setup.centre.as_ref().expect("the equilibrium proved");
    let half = Qd::from_f64(0.5) - Qd::from_f64(mu);
    let s3 = Real::sqrt(Qd::from_f64(3.0)) / Qd::from_f64(2.0);
    for (b, exact) in centre.iter().zip([half, s3, -s3, half]) {
        let d = exact - Qd::from_words([b.hi, b.lo, 0.0, 0.0]);
        let d = if d < Qd::from_f64(0.0) { -d } else { d };
        assert!(d <= Qd::from_f64(b.rad), "{b:?} misses {exact}");
        assert!(b.rad < 1e-27, "{b:?}");
    }
    let c = setup.tube(5e-4, 1e-3).unwrap();
    eprintln!(
        "Sun–Jupiter N = {n}: T ≥ {:?}, centre ± {:?}, Ẇ majorant by degree {:?}",
        c.time,
        c.centre_radius,
        &c.wdot.c[..4]
    );
    assert!(
        c.wdot.c[0] < 1e-300 && c.wdot.c[1] < 1e-300,
        "{:?}",
        c.wdot.c
    );
    assert!(c.wdot.c[2] < 1e-12, "{:?}", c.wdot.c);
    let time = c.time.expect("a certified time");
    assert!(time > 6e8, "{time}");
}

/// Sun–Jupiter L4, N = 8, the normal form in double-double: with T and A⁻¹ taken as the
/// double-double numbers they are and Ẇ's degrees ≤ N + 1 enclosed in balls, the degrees
/// that cancel for the exact normal form (2…N) come out at the rounding of double-double:
/// the majorant's degree-3 coefficient below 10⁻²⁰ (it was 10⁻¹⁰ with T's `f64`
/// coefficients and `f64` intervals, which capped this tube's certified time near 10¹³), and
/// degrees 2…N together below 10⁻⁶ of the remainder's first degree N + 1 at ρ₀ (they were
/// 6·10⁻⁴ of it). The tightened majorant still holds at sampled points of the inner and
/// outer spheres, where |Ẇ| comes from the model's gradient in `f64` (independent of the
/// Taylor models; its rounding, about 10⁻¹⁹ here, is allowed for).
#[test]
fn sun_jupiter_l4_low_degrees_of_wdot_cancel_in_double_double() {
    use lasalle_normal_form::Precision;
    let mu = 0.000953875;
    let h = common::cr3bp(mu);
    let n = 8usize;
    let opts = Options {
        remainder_degree: Some((2 * n).min(n + 8)),
        inverse_transform: false,
        precision: Precision::DoubleDouble,
        ..Options::with_order(n)
    };
    let nf = common::l4_normal_form(mu, &opts).unwrap();
    let c = certified_tube(
        &h,
        &nf,
        5e-4,
        1e-3,
        Metric::LinearNormal,
        &CertifiedOptions::default(),
    )
    .unwrap();
    let g = &c.wdot.c;
    eprintln!(
        "Sun–Jupiter N = {n} (dd): T ≥ {:?}, G by degree {g:?}",
        c.time
    );
    assert!(g[0] < 1e-300 && g[1] < 1e-300, "{g:?}");
    assert!(g[3] < 1e-20, "degree 3 of Ẇ: {:e}", g[3]);
    let r = c.rho0;
    let low: f64 = (2..=n).map(|s| g[s] * r.powi(s as i32)).sum();
    let first = g[n + 1] * r.powi(n as i32 + 1);
    assert!(
        low < 1e-6 * first,
        "degrees 2…{n}: {low:e} against {first:e}"
    );
    let time = c.time.expect("a certified time");
    assert!(time > 7.0918e8, "{time}");
    // the majorant against |Ẇ| from the model's gradient, on the inner and outer spheres
    let mut rng = lasalle_testkit::Rng::new(0x2545_f491_4f6c_dd1d);
    for rad in [c.y0, c.y1] {
        let bound = c.wdot.eval(rad) + 1e-18;
        for _ in 0..100 {
            let v: Vec<f64> = (0..4).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            let y: Vec<f64> = v.iter().map(|x| x * rad / norm).collect();
            let wd = wdot_at(&h, &nf, c.map_degree, &y);
            assert!(
                wd <= bound,
                "|Ẇ| = {wd:e} > G({rad:e}) = {bound:e} at {y:?}"
            );
        }
    }
}
