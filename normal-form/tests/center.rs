//! The centre manifolds at the collinear points against closed forms, published values and
//! the full problem's flow.

use lasalle_normal_form::center::{
    c_n, center_manifold_model, linear_frequencies, CenterManifold, CenterOptions, Collinear,
};
use lasalle_normal_form::models::PolynomialHamiltonian;
use lasalle_normal_form::validate::{orbit, EARTH_MOON_MU};
use lasalle_normal_form::{
    normalize, taylor, Dd, ModelHamiltonian, MonomialTable, Options, Point, Precision, Real,
};
use std::sync::Arc;

fn load(file: &str) -> lasalle_model::Model {
    let path = format!("{}/../models/{file}", env!("CARGO_MANIFEST_DIR"));
    lasalle_model::load_model(std::path::Path::new(&path)).unwrap()
}

fn cm(file: &str, point: &str, order: usize) -> CenterManifold {
    center_manifold_model(&load(file), &[], point, &CenterOptions::with_order(order)).unwrap()
}

fn dd(v: &lasalle_normal_form::Value) -> Dd {
    Dd::from_parts(v.value, v.lo)
}

/// Along the x axis the Legendre expansion is `−Σ c_n xⁿ` (scaled units), so the model's
/// Taylor coefficient of δxⁿ is `−c_n sⁿ γ^{2−n}` with s = ±1 the orientation.
#[test]
fn taylor_coefficients_along_the_axis_are_the_legendre_c_n() {
    let model = load("cr3bp.lsl");
    let h = ModelHamiltonian::new(&model, &[]).unwrap();
    for (point, which) in [
        ("L1", Collinear::L1),
        ("L2", Collinear::L2),
        ("L3", Collinear::L3),
    ] {
        let c = center_manifold_model(
            &model,
            &[],
            point,
            &CenterOptions {
                order: 2,
                birkhoff: false,
                transform: false,
                ..CenterOptions::default()
            },
        )
        .unwrap();
        let g = dd(c.gamma.as_ref().unwrap());
        let z: Vec<Dd> = c.equilibrium.iter().map(dd).collect();
        let table = Arc::new(MonomialTable::new(4, 12));
        let hz = taylor(&h, &z, &table);
        let coeff = |n: usize| hz.coeff(&[n as u8, 0, 0, 0]);
        // the orientation from n = 3
        let s = -(coeff(3) / c_n(EARTH_MOON_MU, which, g, 3))
            .to_f64()
            .signum();
        let pow = |x: Dd, k: i32| (0..k.abs()).fold(Dd::new(1.0), |a, _| a * x);
        for n in 2..=12u32 {
            let scale = Dd::new(1.0) / pow(g, n as i32 - 2);
            let want = -(c_n(EARTH_MOON_MU, which, g, n)) * Dd::new(s.powi(n as i32)) * scale;
            let got = coeff(n as usize);
            let rel = ((got - want) / want).abs().to_f64();
            assert!(rel < 1e-26, "{point} c_{n}: {got} vs {want} ({rel:e})");
        }
        // c₂ fixes the linear frequencies in closed form
        let (l, wp, wv) = linear_frequencies(c_n(EARTH_MOON_MU, which, g, 2));
        assert!(
            ((dd(&c.lambda) - l) / l).abs().to_f64() < 1e-28,
            "{point} lambda"
        );
        assert!(
            ((dd(&c.omega[0]) - wp) / wp).abs().to_f64() < 1e-28,
            "{point} omega_p"
        );
        let _ = wv;
    }
}

/// hiten 0.5.4's λ, ω_p, ω_v and γ at Earth–Moon L1 and L2 (`scripts/hiten_center_manifold.py`;
/// it rounds the frequencies to 12 decimals), and the planar characteristic equation
/// `s² + (2 − c₂)s + (1 + c₂ − 2c₂²) = 0` (s = λ², −ω_p²) to double-double.
#[test]
fn linear_frequencies_against_hiten_and_the_characteristic_equation() {
    for (point, which, lam, wp, wv) in [
        (
            "L1",
            Collinear::L1,
            2.932055933642,
            2.334385885086,
            2.268831094972,
        ),
        (
            "L2",
            Collinear::L2,
            2.158674320345,
            1.862645862177,
            1.786176142892,
        ),
    ] {
        let c = center_manifold_model(
            &load("cr3bp_spatial.lsl"),
            &[],
            point,
            &CenterOptions {
                order: 2,
                birkhoff: false,
                transform: false,
                ..CenterOptions::default()
            },
        )
        .unwrap();
        assert!(
            (c.lambda.value - lam).abs() < 2e-12,
            "{point}: λ = {}",
            c.lambda.value
        );
        assert!(
            (c.omega[0].value - wp).abs() < 2e-12,
            "{point}: ω_p = {}",
            c.omega[0].value
        );
        assert!(
            (c.omega[1].value - wv).abs() < 2e-12,
            "{point}: ω_v = {}",
            c.omega[1].value
        );
        let c2 = c_n(EARTH_MOON_MU, which, dd(c.gamma.as_ref().unwrap()), 2);
        let q =
            |s: Dd| s * s + (Dd::new(2.0) - c2) * s + Dd::new(1.0) + c2 - Dd::new(2.0) * c2 * c2;
        let l2 = dd(&c.lambda) * dd(&c.lambda);
        let w2 = dd(&c.omega[0]) * dd(&c.omega[0]);
        assert!(q(l2).abs().to_f64() < 1e-27 && q(-w2).abs().to_f64() < 1e-27);
        // the vertical frequency is √c₂
        assert!((dd(&c.omega[1]) * dd(&c.omega[1]) - c2).abs().to_f64() < 1e-27);
    }
}

/// The pruned Lie series (terms of degree + hyperbolic degree > N dropped) gives the same
/// reduced Hamiltonian and the same centre Birkhoff coefficients as the full one.
#[test]
fn pruning_leaves_the_reduced_hamiltonian_unchanged() {
    let model = load("cr3bp_spatial.lsl");
    let o = CenterOptions {
        order: 10,
        transform: false,
        ..CenterOptions::default()
    };
    let full = center_manifold_model(
        &model,
        &[],
        "L2",
        &CenterOptions {
            prune: false,
            ..o.clone()
        },
    )
    .unwrap();
    let pruned = center_manifold_model(&model, &[], "L2", &o).unwrap();
    let big = full
        .reduced
        .iter()
        .map(|t| t.coeff.value.abs())
        .fold(0.0, f64::max);
    assert_eq!(full.reduced.len(), pruned.reduced.len());
    for (a, b) in full.reduced.iter().zip(&pruned.reduced) {
        assert_eq!(a.exponents, b.exponents);
        let d = (dd(&a.coeff) - dd(&b.coeff)).abs().to_f64();
        assert!(
            d <= 1e-26 * big.max(1.0) * 10f64.powi(a.degree as i32),
            "{:?}: {} vs {}",
            a.exponents,
            a.coeff.value,
            b.coeff.value
        );
    }
    for b in &pruned.birkhoff {
        let a = full
            .birkhoff
            .iter()
            .find(|a| a.exponents == b.exponents)
            .unwrap();
        let rel = ((dd(&a.coeff) - dd(&b.coeff)) / dd(&a.coeff))
            .abs()
            .to_f64();
        assert!(
            rel < 1e-20,
            "{:?}: {} vs {}",
            a.exponents,
            a.coeff.value,
            b.coeff.value
        );
    }
}

/// The Birkhoff coefficients of the centre actions (a₁ = 0) computed here (the reduction
/// continued) equal those of the elliptic normal form applied to the reduced Hamiltonian as
/// a two-degree-of-freedom polynomial model: two independent paths to the same invariants.
#[test]
fn centre_birkhoff_coefficients_equal_the_elliptic_normal_form_of_the_reduced_hamiltonian() {
    let c = cm("cr3bp_spatial.lsl", "L1", 10);
    let h = PolynomialHamiltonian {
        poly: c.reduced_poly.clone(),
    };
    let o = Options::with_order(10)
        .precision(Precision::DoubleDouble)
        .transform(false);
    let nf = normalize(&h, &Point::Given(vec![0.0; 4]), &o).unwrap();
    assert!((nf.omega[0].value - c.omega[0].value).abs() < 1e-14);
    let mut checked = 0;
    for t in &nf.hamiltonian {
        let mut e = vec![0u32];
        e.extend(&t.exponents);
        let ours = c.birkhoff.iter().find(|b| b.exponents == e).unwrap();
        let rel = ((ours.coeff.value - t.coeff.value) / t.coeff.value).abs();
        // the reduced Hamiltonian is rounded to f64 before the second normal form
        assert!(
            rel < 1e-9,
            "{e:?}: {} vs {}",
            ours.coeff.value,
            t.coeff.value
        );
        checked += 1;
    }
    assert_eq!(checked, 20); // actions of degree 1..5 in two variables
}

/// The planar model's reduced Hamiltonian is the spatial one's restriction to Q3 = P3 = 0.
#[test]
fn planar_reduced_hamiltonian_is_the_restriction_of_the_spatial_one() {
    for point in ["L1", "L2", "L3"] {
        let p = cm("cr3bp.lsl", point, 8);
        let s = cm("cr3bp_spatial.lsl", point, 8);
        for t in p.reduced.iter().filter(|t| t.coeff.value != 0.0) {
            let e = [t.exponents[0], 0, t.exponents[1], 0];
            let u = s.reduced.iter().find(|u| u.exponents == e).unwrap();
            assert!(
                (u.coeff.value - t.coeff.value).abs()
                    <= 1e-20 + 1e-24 * 10f64.powi(t.degree as i32) + 1e-13 * t.coeff.value.abs(),
                "{point} {e:?}: {} vs {}",
                u.coeff.value,
                t.coeff.value
            );
        }
    }
}

/// Points of the centre manifold mapped into the model and integrated there stay on it:
/// their hyperbolic coordinates (Q1', P1') stay at the size of the truncation error (which
/// the unstable direction amplifies by e^{λt}), far below the e^{λt} growth of a point
/// displaced off the manifold by the same amount; the energy agrees with H_cm.
#[test]
fn centre_manifold_points_stay_on_the_manifold_in_the_full_problem() {
    let model = load("cr3bp_spatial.lsl");
    let h = ModelHamiltonian::new(&model, &[]).unwrap();
    let c = center_manifold_model(&model, &[], "L1", &CenterOptions::with_order(12)).unwrap();
    let g = c.gamma.unwrap().value;
    // a quasi-periodic point of amplitude ~0.1 γ in both centres
    let w = [0.1 * g, 0.05 * g, -0.04 * g, 0.08 * g];
    let z0 = c.to_model(&w).unwrap();
    let e_full = lasalle_normal_form::HamiltonianFn::eval(&h, &z0) - c.energy.value;
    let e_cm = c.reduced_energy(&w);
    assert!(((e_full - e_cm) / e_cm).abs() < 1e-9, "{e_full} vs {e_cm}");
    let hyp = |z: &[f64]| {
        let n = c.to_normal(z).unwrap();
        n[0].abs().max(n[3].abs())
    };
    assert!(hyp(&z0) < 1e-13);
    let times: Vec<f64> = (0..=40).map(|k| 0.1 * k as f64).collect();
    let on = orbit(&h, &z0, &times, 1e-13).unwrap();
    // the same point pushed off the manifold by 1e-8 in Q1
    let mut off_n = c.embed(&w);
    off_n[0] = 1e-8;
    let z1 = c.from_normal(&off_n).unwrap();
    let off = orbit(&h, &z1, &times, 1e-13).unwrap();
    let (a, b) = (hyp(on.last().unwrap()), hyp(off.last().unwrap()));
    // e^{λ·4} ≈ 1.2e5: the displaced point has grown to ~1e-3, the mapped one stays ≲ 1e-6
    assert!(b > 1e-4, "off the manifold: {b}");
    assert!(a < 1e-2 * b, "on the manifold: {a} (off: {b})");
}

/// The halo bifurcation at Earth–Moon L1, two ways. In the reduced flow (degree 16) it is the
/// energy at which the planar Lyapunov orbit's vertical monodromy trace passes 2; in the full
/// model the same trace is taken along the planar Lyapunov family found by differential
/// correction (DOPRI5, tolerance 10⁻¹³), without any normal form. They agree to 10⁻⁶
/// relative (8.6·10⁻⁸ measured). On the section Q₃ = 0 the two halo fixed points
/// (symmetric in Q₂, elliptic) exist above that energy, and below it Newton's method from the
/// same seeds finds only the vertical Lyapunov orbit.
#[test]
fn halo_fixed_points_appear_at_the_full_models_bifurcation_energy() {
    use lasalle_normal_form::center::lyapunov::full_halo_bifurcation;
    use lasalle_normal_form::center::poincare::{
        fixed_point, halo_bifurcation, planar_orbit, ReducedField,
    };
    let model = load("cr3bp_spatial.lsl");
    let c = center_manifold_model(
        &model,
        &[],
        "L1",
        &CenterOptions {
            order: 16,
            transform: false,
            birkhoff: false,
            ..CenterOptions::default()
        },
    )
    .unwrap();
    let g = c.gamma.unwrap().value;
    let g2 = g * g;
    let f = ReducedField::new(&c.reduced_poly).unwrap();
    let h_cm = halo_bifurcation(&f, 0.1 * g2, 0.6 * g2, 2.0 * g, 1e-10).unwrap();

    let h = ModelHamiltonian::new(&model, &[]).unwrap();
    let eq: Vec<f64> = c.equilibrium.iter().map(|v| v.value).collect();
    let (wp, wv) = (c.omega[0].value, c.omega[1].value);
    let full = full_halo_bifurcation(&h, &eq, wp, wv, 0.02 * g, -1.0, 1e-13).unwrap();
    assert!((full.vertical_trace - 2.0).abs() < 1e-8, "{full:?}");
    let rel = (h_cm - full.energy).abs() / full.energy;
    assert!(
        rel < 1e-6,
        "reduced flow h = {h_cm:e}, full model {:e} ({rel:e})",
        full.energy
    );
    // the period of the planar orbit at the bifurcation, both ways
    let o = planar_orbit(&f, h_cm, 2.0 * g, 400).unwrap();
    assert!(
        (o.period - full.period).abs() < 1e-6,
        "{} vs {}",
        o.period,
        full.period
    );

    // fixed points of the section map below and above
    let wv_period = 2.0 * std::f64::consts::PI / wv;
    let fixed = |hg: f64| {
        let e = hg * g2;
        let o = planar_orbit(&f, e, 2.0 * g, 400).unwrap();
        let p_max = 4.0 * (2.0 * e / wv).sqrt();
        let mut found: Vec<[f64; 2]> = Vec::new();
        for s in [
            0.0, 0.6, 0.75, 0.85, 0.92, 0.97, -0.6, -0.75, -0.85, -0.92, -0.97,
        ] {
            let seed = [s * o.q2, 0.0];
            if let Some(fp) =
                fixed_point(&f, e, seed, wv_period / 200.0, p_max, 1e-7 * g, 1e-11 * g)
            {
                assert!(fp.trace.abs() < 2.0, "elliptic: {fp:?}");
                if !found
                    .iter()
                    .any(|p| (p[0] - fp.point[0]).hypot(p[1] - fp.point[1]) < 1e-6 * g)
                {
                    found.push(fp.point);
                }
            }
        }
        found
    };
    let below = fixed(0.8 * h_cm / g2);
    assert_eq!(below.len(), 1, "below the bifurcation: {below:?}");
    assert!(
        below[0][0].abs() < 1e-9 * g,
        "the vertical orbit on P2 axis: {below:?}"
    );
    let above = fixed(1.5 * h_cm / g2);
    assert_eq!(above.len(), 3, "above the bifurcation: {above:?}");
    let mut halos: Vec<[f64; 2]> = above.into_iter().filter(|p| p[0].abs() > 0.1 * g).collect();
    halos.sort_by(|a, b| a[0].total_cmp(&b[0]));
    assert_eq!(halos.len(), 2);
    // mirror images under Q2 → −Q2
    assert!((halos[0][0] + halos[1][0]).abs() < 1e-6 * g, "{halos:?}");
    assert!((halos[0][1] - halos[1][1]).abs() < 1e-6 * g, "{halos:?}");
}

/// The quasi-halo islands at Earth–Moon L2, h = 0.4γ² (12 % above the halo bifurcation, where
/// they are thin): the section's seeds near each halo fixed point land inside its island,
/// i.e. at least two orbits per halo point stay close to it (within a fifth of its distance
/// to the vertical Lyapunov point) over all their returns, and circle it (their returns
/// lie on both sides of it in Q₂).
#[test]
fn thin_l2_halo_islands_are_seeded() {
    use lasalle_normal_form::center::poincare::poincare_map;
    let model = load("cr3bp_spatial.lsl");
    let c = center_manifold_model(
        &model,
        &[],
        "L2",
        &CenterOptions {
            order: 16,
            transform: false,
            birkhoff: false,
            ..CenterOptions::default()
        },
    )
    .unwrap();
    let g = c.gamma.unwrap().value;
    let s = poincare_map(&c, 0.4 * g * g, 4, 40).unwrap();
    let v = s.vertical.as_ref().unwrap().point;
    assert_eq!(s.halos.len(), 2, "{:?}", s.halos);
    for halo in &s.halos {
        let x = halo.point;
        let reach = (x[0] - v[0]).hypot(x[1] - v[1]);
        let trapped = s
            .orbits
            .iter()
            .filter(|o| o.points.len() >= 20)
            .filter(|o| {
                o.points
                    .iter()
                    .all(|p| (p[0] - x[0]).hypot(p[1] - x[1]) < 0.2 * reach)
                    && o.points.iter().any(|p| p[0] < x[0])
                    && o.points.iter().any(|p| p[0] > x[0])
            })
            .count();
        assert!(
            trapped >= 2,
            "halo at {x:?}: {trapped} orbits in its island"
        );
    }
}
