//! Infante's Table I (n = 2, 3) against the paper's printed matrices, the symbolic proof and
//! the numerical check of every B_k, and the located refusal of a non-companion matrix.

use lasalle_analysis::infante::{self, companion, companion_coefficients, InfanteError, Poly};
use lasalle_model::ir::{Graph, Input};

/// a₁ … aₙ and the integer k as polynomials in n variables.
fn vars(n: usize) -> (Vec<Poly>, impl Fn(i128) -> Poly) {
    ((0..n).map(|k| Poly::var(n, k)).collect(), move |c| {
        Poly::constant(n, c)
    })
}

fn b_of(n: usize, k: usize) -> Vec<Vec<Poly>> {
    infante::solve(&infante::c_diagonal(n, k)).unwrap().b
}

#[test]
fn table_one_n_2_is_the_papers() {
    let (a, c) = vars(2);
    let (a1, a2) = (&a[0], &a[1]);
    // B₁ = [[a₁² + a₂, a₁], [a₁, 1]], C₁ = diag(2a₁a₂, 0)
    let b1 = vec![vec![a1.mul(a1).add(a2), a1.clone()], vec![a1.clone(), c(1)]];
    assert_eq!(b_of(2, 1), b1);
    assert_eq!(infante::c_diagonal(2, 1), vec![c(2).mul(a1).mul(a2), c(0)]);
    // B₂ = diag(a₂, 1), C₂ = diag(0, 2a₁)
    assert_eq!(b_of(2, 2), vec![vec![a2.clone(), c(0)], vec![c(0), c(1)]]);
    assert_eq!(infante::c_diagonal(2, 2), vec![c(0), c(2).mul(a1)]);
}

#[test]
fn table_one_n_3_is_the_papers() {
    let (a, c) = vars(3);
    let (a1, a2, a3) = (&a[0], &a[1], &a[2]);
    let delta2 = a1.mul(a2).sub(a3);
    // B₂ = [[a₁a₃, a₃, 0], [a₃, a₁² + a₂, a₁], [0, a₁, 1]], C₂ = diag(0, 2(a₁a₂ − a₃), 0)
    let b2 = vec![
        vec![a1.mul(a3), a3.clone(), c(0)],
        vec![a3.clone(), a1.mul(a1).add(a2), a1.clone()],
        vec![c(0), a1.clone(), c(1)],
    ];
    assert_eq!(b_of(3, 2), b2);
    assert_eq!(
        infante::c_diagonal(3, 2),
        vec![c(0), c(2).mul(&delta2), c(0)]
    );
    // B₃ = [[a₃², a₂a₃, 0], [a₂a₃, a₁a₃ + a₂², a₃], [0, a₃, a₂]], C₃ = diag(0, 0, 2(a₁a₂ − a₃))
    let b3 = vec![
        vec![a3.mul(a3), a2.mul(a3), c(0)],
        vec![a2.mul(a3), a1.mul(a3).add(&a2.mul(a2)), a3.clone()],
        vec![c(0), a3.clone(), a2.clone()],
    ];
    assert_eq!(b_of(3, 3), b3);
    assert_eq!(
        infante::c_diagonal(3, 3),
        vec![c(0), c(0), c(2).mul(&delta2)]
    );
    // C₁ = diag(2a₃(a₁a₂ − a₃), 0, 0), B₁ = [[a₂(a₁a₂ − a₃) + a₁²a₃, a₁²a₂, a₁a₂ − a₃],
    // [a₁²a₂, a₁³ + a₃, a₁²], [a₁a₂ − a₃, a₁², a₁]] (the printed B₁, read through the OCR)
    assert_eq!(
        infante::c_diagonal(3, 1),
        vec![c(2).mul(a3).mul(&delta2), c(0), c(0)]
    );
    let a1sq = a1.mul(a1);
    let b1 = vec![
        vec![
            a2.mul(&delta2).add(&a1sq.mul(a3)),
            a1sq.mul(a2),
            delta2.clone(),
        ],
        vec![a1sq.mul(a2), a1sq.mul(a1).add(a3), a1sq.clone()],
        vec![delta2.clone(), a1sq.clone(), a1.clone()],
    ];
    assert_eq!(b_of(3, 1), b1);
}

#[test]
fn every_b_is_proved_and_positive_definite_at_a_hurwitz_point() {
    for (n, a) in [
        (2, vec![3.0, 2.0]),
        (3, vec![3.0, 3.0, 1.0]),
        (4, vec![4.0, 6.0, 4.0, 1.0]),
    ] {
        for s in infante::table(n).unwrap() {
            assert!(s.proves(), "n = {n}: AᵀB + BA + C does not expand to 0");
            let (residual, pivot) = s.check_at(&a);
            assert!(
                residual < 1e-12 && pivot > 0.0,
                "n = {n}: {residual} {pivot}"
            );
        }
    }
}

#[test]
fn a_wrong_b_does_not_prove() {
    let mut s = infante::solve(&infante::c_diagonal(2, 2)).unwrap();
    s.b[1][1] = Poly::constant(2, 2);
    assert!(!s.proves());
    assert!(s.check_at(&[3.0, 2.0]).0 > 1.0);
}

#[test]
fn hurwitz_determinants() {
    let (a, c) = vars(3);
    let d = infante::hurwitz(3);
    assert_eq!(d[0], a[0]);
    assert_eq!(d[1], a[0].mul(&a[1]).sub(&a[2]));
    assert_eq!(d[2], a[2].mul(&d[1]));
    assert_eq!(infante::hurwitz(1), vec![Poly::var(1, 0)]);
    assert_eq!(c(2).mul(&d[0]), Poly::constant(3, 2).mul(&a[0]));
}

#[test]
fn the_coefficients_are_read_off_a_companion_matrix() {
    let mut g = Graph::new();
    let m = companion(&mut g, 3);
    let a = companion_coefficients(&mut g, &m).unwrap();
    for (k, id) in a.iter().enumerate() {
        assert_eq!(*id, g.input(Input::Param(k as u32)));
    }
}

#[test]
fn a_non_companion_matrix_is_refused_where_it_departs() {
    let mut g = Graph::new();
    let mut m = companion(&mut g, 3);
    m[0][2] = g.input(Input::Param(0));
    let e = companion_coefficients(&mut g, &m).unwrap_err();
    assert_eq!(
        e,
        InfanteError::NotCompanion {
            row: 1,
            column: 3,
            expected: "0".into(),
            found: "p0".into()
        }
    );
    assert!(e.to_string().contains("entry (1, 3)"));
    let rect = vec![vec![g.num(0.0), g.num(1.0)]];
    assert!(matches!(
        companion_coefficients(&mut g, &rect),
        Err(InfanteError::Shape(_))
    ));
}

#[test]
fn a_c_outside_the_papers_family_is_reported_as_rational() {
    // C = diag(1, 0): B has the Hurwitz determinant a₁a₂ in its denominators
    let c = vec![Poly::constant(2, 1), Poly::constant(2, 0)];
    let e = infante::solve(&c).unwrap_err();
    assert!(e.to_string().contains("not a polynomial"), "{e}");
}
