//! Repeated frequencies: a diagonalisable repeated frequency is a 1:1 (or
//! 1:−1) resonance, normalised with `resonant`; a non-diagonalisable one is refused by name.

use lasalle_normal_form::models::PolynomialHamiltonian;
use lasalle_normal_form::{
    normalize, HamiltonianFn, NormalForm, NormalFormError, Options, Point, Scalar,
};

/// Hénon–Heiles, `H = (px² + py² + x² + y²)/2 + x²y − y³/3`, z = (x, y, px, py).
fn henon_heiles() -> PolynomialHamiltonian {
    PolynomialHamiltonian::from_terms(
        2,
        &[
            (0.5, &[2, 0, 0, 0]),
            (0.5, &[0, 2, 0, 0]),
            (0.5, &[0, 0, 2, 0]),
            (0.5, &[0, 0, 0, 2]),
            (1.0, &[2, 1, 0, 0]),
            (-1.0 / 3.0, &[0, 3, 0, 0]),
        ],
    )
}

/// Hénon–Heiles seen through a linear symplectic change of variables `z = T ζ` that mixes all
/// four coordinates (a shear in q by a symmetric B, then a rotation in (q₁, p₂)…), so that the
/// 1:1 eigenspace is not aligned with the coordinates.
struct MixedHenonHeiles;

impl HamiltonianFn for MixedHenonHeiles {
    fn n_dof(&self) -> usize {
        2
    }
    fn eval<S: Scalar>(&self, z: &[S]) -> S {
        let c = |x: f64| S::from_f64(x);
        // shear: q ← q + B p with B = [[0.3, 0.2], [0.2, −0.1]] (symplectic)
        let q1 = z[0].add(&z[2].mul(&c(0.3))).add(&z[3].mul(&c(0.2)));
        let q2 = z[1].add(&z[2].mul(&c(0.2))).sub(&z[3].mul(&c(0.1)));
        // then p ← p + D q with D = [[0.5, 0], [0, −0.25]] (symplectic)
        let p1 = z[2].add(&q1.mul(&c(0.5)));
        let p2 = z[3].sub(&q2.mul(&c(0.25)));
        let half = c(0.5);
        let h2 = q1
            .mul(&q1)
            .add(&q2.mul(&q2))
            .add(&p1.mul(&p1))
            .add(&p2.mul(&p2))
            .mul(&half);
        h2.add(&q1.mul(&q1).mul(&q2))
            .sub(&q2.mul(&q2).mul(&q2).mul(&c(1.0 / 3.0)))
    }
}

/// H̄ at normal coordinates (Q', P'), resonant terms included.
fn hbar_at(nf: &NormalForm, w: &[f64]) -> f64 {
    let n = nf.n_dof;
    let actions: Vec<f64> = (0..n)
        .map(|k| 0.5 * (w[k] * w[k] + w[n + k] * w[n + k]))
        .collect();
    let s = std::f64::consts::FRAC_1_SQRT_2;
    // x_k = (Q_k − iP_k)/√2, y_k = (P_k − iQ_k)/√2, as (re, im)
    let x: Vec<(f64, f64)> = (0..n).map(|k| (s * w[k], -s * w[n + k])).collect();
    let y: Vec<(f64, f64)> = (0..n).map(|k| (s * w[n + k], -s * w[k])).collect();
    let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let mut res = (0.0, 0.0);
    for t in &nf.resonant_terms {
        let mut m = (t.re, t.im);
        for k in 0..n {
            for _ in 0..t.x[k] {
                m = mul(m, x[k]);
            }
            for _ in 0..t.y[k] {
                m = mul(m, y[k]);
            }
        }
        res = (res.0 + m.0, res.1 + m.1);
    }
    assert!(res.1.abs() < 1e-12, "resonant part not real: {res:?}");
    nf.energy_at(&actions) + res.0
}

/// max over a few directions of |H(z) − H̄(Q'(z), P'(z))| at amplitude `eps`.
fn conjugacy_defect<H: HamiltonianFn>(h: &H, nf: &NormalForm, eps: f64) -> f64 {
    let dirs = [
        [0.6, -0.3, 0.5, 0.55],
        [-0.2, 0.7, 0.4, -0.55],
        [0.5, 0.5, -0.5, 0.5],
    ];
    dirs.iter()
        .map(|d| {
            let z: Vec<f64> = d.iter().map(|x| x * eps).collect();
            let w = nf.to_normal(&z).expect("transformation computed");
            (h.eval(&z) - hbar_at(nf, &w)).abs()
        })
        .fold(0.0, f64::max)
}

fn origin() -> Point {
    Point::Newton(vec![0.0; 4])
}

#[test]
fn henon_heiles_is_a_1_1_resonance_not_a_non_elliptic_point() {
    let h = henon_heiles();
    let e = normalize(&h, &origin(), &Options::with_order(6)).unwrap_err();
    match &e {
        NormalFormError::Resonance { m, order, .. } => {
            assert_eq!(m, &vec![1, -1]);
            assert_eq!(*order, 4);
        }
        other => panic!("expected the 1:1 resonance, got {other}"),
    }
    let msg = e.to_string();
    assert!(
        msg.contains("m = (1, -1)") && msg.contains("--resonant") && msg.contains("--order 3"),
        "{msg}"
    );
    // degree 3 meets no resonant monomial: the Birkhoff form to order 3 exists
    let nf = normalize(&h, &origin(), &Options::with_order(3)).expect("order 3");
    assert_eq!(nf.frequencies_linear(), vec![1.0, 1.0]);
}

#[test]
fn resonant_normal_form_of_henon_heiles_conjugates_h() {
    let h = henon_heiles();
    let nf = normalize(&h, &origin(), &Options::with_order(6).resonant(true)).expect("resonant");
    assert_eq!(nf.signs, vec![1, 1]);
    for w in nf.frequencies_linear() {
        assert!((w - 1.0).abs() < 1e-15, "{w}");
    }
    assert!(nf.diagnostics.symplectic_residual < 1e-14);
    assert!(nf.diagnostics.diagonal_residual < 1e-14);
    assert!(nf.d4.is_none(), "D4 means nothing with resonant terms");
    assert!(!nf.resonant_terms.is_empty());
    // only 1:1 terms are kept: m = a − b ∝ (1, −1)
    for t in &nf.resonant_terms {
        assert_eq!(t.x[0] + t.x[1], t.y[0] + t.y[1], "{t:?}");
    }
    // H = H̄ ∘ (to normal coordinates) up to degree 7: the defect scales like ε⁷
    let (d1, d2) = (
        conjugacy_defect(&h, &nf, 0.02),
        conjugacy_defect(&h, &nf, 0.01),
    );
    assert!(d1 < 1e-10 && d2 < 1e-12, "{d1:e} {d2:e}");
    assert!(
        d1 / d2 > 60.0,
        "defect does not scale like ε⁷: {d1:e} / {d2:e}"
    );
    // without the resonant terms the conjugacy fails at degree 4
    let mut cut = nf.clone();
    cut.resonant_terms.clear();
    let d_cut = conjugacy_defect(&h, &cut, 0.02);
    assert!(d_cut > 1e3 * d1, "{d_cut:e} vs {d1:e}");
    // the table does not claim H̄ = Σ h_a I^a, and has no D4 line
    let table = nf.to_table();
    assert!(table.contains("resonant normal form"), "{table}");
    assert!(!table.contains("Hbar = H(z_eq) + sum_a h_a I^a"), "{table}");
    assert!(
        !table.contains("Arnold-Moser") && !table.contains("D4 ="),
        "{table}"
    );
}

#[test]
fn repeated_frequency_in_mixed_coordinates() {
    let h = MixedHenonHeiles;
    let nf = normalize(&h, &origin(), &Options::with_order(5).resonant(true)).expect("resonant");
    for w in nf.frequencies_linear() {
        assert!((w - 1.0).abs() < 1e-14, "{w}");
    }
    assert!(nf.diagnostics.symplectic_residual < 1e-13);
    assert!(nf.diagnostics.diagonal_residual < 1e-13);
    let (d1, d2) = (
        conjugacy_defect(&h, &nf, 0.02),
        conjugacy_defect(&h, &nf, 0.01),
    );
    assert!(d2 < 1e-11 && d1 / d2 > 30.0, "{d1:e} {d2:e}");
}

#[test]
fn one_to_minus_one_resonance_has_opposite_signs() {
    // H₂ = I₁ − I₂: a repeated pair with opposite Krein signatures
    let h = PolynomialHamiltonian::from_terms(
        2,
        &[
            (0.5, &[2, 0, 0, 0]),
            (-0.5, &[0, 2, 0, 0]),
            (0.5, &[0, 0, 2, 0]),
            (-0.5, &[0, 0, 0, 2]),
            (1.0, &[2, 1, 0, 0]),
            (0.3, &[1, 0, 0, 2]),
        ],
    );
    let nf = normalize(&h, &origin(), &Options::with_order(5).resonant(true)).expect("1:-1");
    let mut s = nf.signs.clone();
    s.sort();
    assert_eq!(s, vec![-1, 1]);
    let (d1, d2) = (
        conjugacy_defect(&h, &nf, 0.02),
        conjugacy_defect(&h, &nf, 0.01),
    );
    assert!(d2 < 1e-11 && d1 / d2 > 30.0, "{d1:e} {d2:e}");
}

#[test]
fn a_non_diagonalisable_repeated_frequency_is_named() {
    // H₂ = (q₂p₁ − q₁p₂) + (q₁² + q₂²)/2: ±i double with one eigenvector each (the normal
    // form of a Krein collision)
    let h = PolynomialHamiltonian::from_terms(
        2,
        &[
            (1.0, &[0, 1, 1, 0]),
            (-1.0, &[1, 0, 0, 1]),
            (0.5, &[2, 0, 0, 0]),
            (0.5, &[0, 2, 0, 0]),
            (1.0, &[3, 0, 0, 0]),
        ],
    );
    let e = normalize(&h, &origin(), &Options::with_order(4).resonant(true)).unwrap_err();
    match &e {
        NormalFormError::Defective {
            multiplicity,
            eigenvectors,
            ..
        } => assert_eq!((*multiplicity, *eigenvectors), (2, 1)),
        other => panic!("expected a defective frequency, got {other}"),
    }
    assert!(e.to_string().contains("not diagonalisable"), "{e}");
}
