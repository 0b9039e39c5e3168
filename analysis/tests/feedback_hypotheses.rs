//! The hypotheses of "Feedback Integrators" (Chang, Jiménez & Perlmutter 2016) for its §4
//! systems: the closed forms and the level-set samplers against independent computations.

use lasalle_analysis::feedback_hypotheses::{
    central_force_level_set, euler_top_period, kepler_level_set, lemma_3_3_bound, lemma_3_6_bound,
    period_from_crossings, positive_roots, rank_check, rigid_body_level_set, theorem_3_9,
    turning_radii,
};
use nalgebra::{DMatrix, Matrix3, Vector3};

const I: [f64; 3] = [3.0, 2.0, 1.0];

/// Euler's equations 𝕀Ω̇ = 𝕀Ω × Ω, by classical RK4.
fn euler_rhs(w: [f64; 3]) -> [f64; 3] {
    let iw = [I[0] * w[0], I[1] * w[1], I[2] * w[2]];
    let c = [
        iw[1] * w[2] - iw[2] * w[1],
        iw[2] * w[0] - iw[0] * w[2],
        iw[0] * w[1] - iw[1] * w[0],
    ];
    [c[0] / I[0], c[1] / I[1], c[2] / I[2]]
}

fn rk4(w: [f64; 3], h: f64) -> [f64; 3] {
    let add =
        |a: [f64; 3], b: [f64; 3], s: f64| [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]];
    let k1 = euler_rhs(w);
    let k2 = euler_rhs(add(w, k1, h / 2.0));
    let k3 = euler_rhs(add(w, k2, h / 2.0));
    let k4 = euler_rhs(add(w, k3, h));
    let mut out = w;
    for i in 0..3 {
        out[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    out
}

/// §4.1: 𝕀 = diag(3, 2, 1), Ω(0) = (1, 1, 1): E = 3, |π|² = 14, T_Ω = 6.4227; the closed form
/// and an RK4 orbit (h = 1e-3, 10 periods) agree with it and with each other.
#[test]
fn rigid_body_period_is_the_papers() {
    let closed = euler_top_period(I, 3.0, 14.0).expect("off the separatrix");
    assert!((closed - 6.4227).abs() < 5e-5, "closed form {closed}");
    let h = 1e-3;
    let mut w = [1.0, 1.0, 1.0];
    let (mut t, mut y) = (vec![0.0], vec![w[1]]);
    for k in 1..=65_000 {
        w = rk4(w, h);
        t.push(k as f64 * h);
        y.push(w[1]);
    }
    let (measured, periods) = period_from_crossings(&t, &y).expect("crossings");
    assert!(periods >= 9, "{periods}");
    assert!((measured - closed).abs() < 1e-6, "{measured} vs {closed}");
    // the other side of the separatrix (|π|² < 2E·I₂): swap the roles of the extreme axes
    let w = [0.2f64, 1.0, 1.5];
    let e = 0.5 * (0..3).map(|k| I[k] * w[k] * w[k]).sum::<f64>();
    let p2 = (0..3).map(|k| (I[k] * w[k]).powi(2)).sum::<f64>();
    assert!(p2 < 2.0 * e * I[1]);
    let closed = euler_top_period(I, e, p2).unwrap();
    let mut x = w;
    let (mut t, mut y) = (vec![0.0], vec![x[1]]);
    for k in 1..=80_000 {
        x = rk4(x, h);
        t.push(k as f64 * h);
        y.push(x[1]);
    }
    let (measured, _) = period_from_crossings(&t, &y).unwrap();
    assert!((measured - closed).abs() < 1e-6, "{measured} vs {closed}");
    assert_eq!(euler_top_period(I, 3.0, 12.0), None, "separatrix");
}

/// Lemma 3.3 with the paper's gains (50, 100, 50), E₀ = 3, π₀ = (3, 2, 1): c < 12.5 = k₀/4.
/// Lemma 3.6 (36) with (4, 2), |L₀|² = 1.8, |A₀| = 0.8: c < 0.04 = k₂(μ − |A₀|)²/2.
#[test]
fn bounds_on_c() {
    assert_eq!(
        lemma_3_3_bound([50.0, 100.0, 50.0], 3.0, [3.0, 2.0, 1.0]),
        (12.5, 0)
    );
    assert_eq!(
        lemma_3_3_bound([50.0, 1.0, 50.0], 3.0, [3.0, 2.0, 1.0]),
        (1.5, 1)
    );
    let (c, which) = lemma_3_6_bound([4.0, 2.0], 1.0, [0.0, 0.0, 1.8f64.sqrt()], [0.8, 0.0, 0.0]);
    assert!((c - 0.04).abs() < 1e-15 && which == 1, "{c} {which}");
    assert_eq!(
        lemma_3_6_bound([4.0, 2.0], 1.0, [0.0, 0.0, 1.0], [1.2, 0.0, 0.0]).0,
        0.0
    );
}

#[test]
fn positive_roots_of_known_polynomials() {
    // (r − 0.5)(r − 2)(r + 3) = r³ + 0.5r² − 6.5r + 3
    let r = positive_roots(&[3.0, -6.5, 0.5, 1.0]);
    assert_eq!(r.len(), 2);
    assert!(
        (r[0] - 0.5).abs() < 1e-14 && (r[1] - 2.0).abs() < 1e-14,
        "{r:?}"
    );
    assert!(positive_roots(&[1.0, 0.0, 1.0]).is_empty());
    assert!(positive_roots(&[4.0]).is_empty());
}

/// §4.3: U = −1/r − 0.0025/r³, E₀ = −0.5390625, |L₀|² = 0.64: (58) has the roots
/// (0.64 ± √(0.64² − 0.03))/2, where (57) is far from zero; a circular orbit (v² = rU′(r))
/// is a common root, with δ and without.
#[test]
fn theorem_3_9_common_roots() {
    let (mu, delta) = (1.0, 0.0025);
    let t = theorem_3_9(mu, delta, -0.5390625, 0.64);
    let d = (0.64f64 * 0.64 - 12.0 * delta).sqrt();
    let expect = [(0.64 - d) / 2.0, (0.64 + d) / 2.0];
    assert_eq!(t.roots_58.len(), 2);
    for (k, &(r, res)) in t.roots_58.iter().enumerate() {
        assert!((r - expect[k]).abs() < 1e-14, "{r} vs {}", expect[k]);
        assert!(res > 0.1, "residual {res} at {r}");
    }
    assert_eq!(t.common_root(), None);
    for (delta, r0) in [(0.0025, 0.7), (0.0, 1.3), (0.0025, 0.2)] {
        let du = mu / (r0 * r0) + 3.0 * delta / r0.powi(4);
        let v2 = r0 * du;
        let e0 = 0.5 * v2 - mu / r0 - delta / r0.powi(3);
        let t = theorem_3_9(mu, delta, e0, r0 * r0 * v2);
        let r = t.common_root().expect("circular orbit");
        assert!((r - r0).abs() < 1e-9, "{r} vs {r0}");
    }
}

/// The §4.3 orbit turns at its pericentre r = 0.4 and apocentre; with δ > 0 the level set also
/// has the component below the first turning radius.
#[test]
fn turning_radii_of_the_perturbed_orbit() {
    let r = turning_radii(1.0, 0.0025, -0.5390625, 0.64);
    assert_eq!(r.len(), 3, "{r:?}");
    assert!((r[1] - 0.4).abs() < 1e-12, "{r:?}");
    assert!(r[0] < 0.01 && r[2] > 1.0, "{r:?}");
}

fn cross(a: Vector3<f64>, b: Vector3<f64>) -> Vector3<f64> {
    a.cross(&b)
}

#[test]
fn level_set_samples_lie_on_the_level_sets() {
    // rigid body: RᵀR = I, E = 3, R𝕀Ω = (3, 2, 1)
    let pts = rigid_body_level_set(I, 3.0, [3.0, 2.0, 1.0], 8, 4);
    assert_eq!(pts.len(), 8 * 8 * 4);
    for x in &pts {
        let r = Matrix3::from_column_slice(&x[..9]);
        let w = Vector3::new(x[9], x[10], x[11]);
        let iw = Vector3::new(I[0] * w[0], I[1] * w[1], I[2] * w[2]);
        assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-14);
        assert!((0.5 * w.dot(&iw) - 3.0).abs() < 1e-14);
        assert!((r * iw - Vector3::new(3.0, 2.0, 1.0)).norm() < 1e-13);
    }
    // Kepler: L = x × v, A = v × L − μx/|x|
    let (l0, a0) = (
        Vector3::new(0.0, 0.0, 1.8f64.sqrt()),
        Vector3::new(0.8, 0.0, 0.0),
    );
    for s in kepler_level_set(1.0, l0.into(), a0.into(), 64) {
        let (x, v) = (
            Vector3::new(s[0], s[1], s[2]),
            Vector3::new(s[3], s[4], s[5]),
        );
        let l = cross(x, v);
        assert!((l - l0).norm() < 1e-14);
        assert!((cross(v, l) - x / x.norm() - a0).norm() < 1e-13);
    }
    // perturbed Kepler: E, L
    let l0 = Vector3::new(0.0, 0.0, 0.8);
    let r = turning_radii(1.0, 0.0025, -0.5390625, 0.64);
    for s in central_force_level_set(1.0, 0.0025, -0.5390625, l0.into(), (r[1], r[2]), 8, 6) {
        let (x, v) = (
            Vector3::new(s[0], s[1], s[2]),
            Vector3::new(s[3], s[4], s[5]),
        );
        let e = 0.5 * v.norm_squared() - 1.0 / x.norm() - 0.0025 / x.norm().powi(3);
        assert!((e + 0.5390625).abs() < 1e-13);
        assert!((cross(x, v) - l0).norm() < 1e-14);
    }
}

#[test]
fn rank_check_reads_singular_values() {
    let full = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![3.0, 2.0, 1e-3]));
    let short = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![3.0, 2.0, 1e-14]));
    let c = rank_check(&[full.clone(), short], &[0.0, 1e-15], 3);
    assert_eq!(c.rank, (2, 3));
    assert!(!c.holds());
    assert_eq!(c.worst_sample, 1);
    assert!((c.smallest_required - 1e-14).abs() < 1e-20);
    assert_eq!(c.level_set_residual, 1e-15);
    let c = rank_check(&[full], &[0.0], 2);
    assert!(c.holds() && (c.largest_beyond - 1e-3).abs() < 1e-15 && c.largest == 3.0);
}
