//! Infante's criterion for time-varying coefficients (Theorem 2.1) and the paper's two
//! examples, against the printed formulas (4.4), (4.8), (4.9), (4.15), (4.19), (4.20) and
//! Table I, and the located refusals of models that are not in companion form.

use lasalle_analysis::infante::criterion::{lyapunov_b, Criterion, CriterionError};
use lasalle_analysis::infante::equation::{assess, CompanionEquation};
use lasalle_analysis::infante::examples::{
    example1_boundary, example1_printed, example2_bound, example2_printed,
};
use lasalle_analysis::infante::{c_diagonal, table};
use lasalle_model::lower_source;

/// B from the Kronecker solve equals Table I's symbolic B_k at a Hurwitz point.
#[test]
fn numerical_b_is_table_one() {
    for (n, a) in [(2, vec![3.0, 2.0]), (3, vec![3.0, 3.0, 1.0])] {
        for (k, s) in table(n).unwrap().iter().enumerate() {
            let c: Vec<f64> = c_diagonal(n, k + 1).iter().map(|p| p.eval(&a)).collect();
            let b = lyapunov_b(&a, &c).unwrap();
            for (row, symbolic) in b.iter().zip(&s.b) {
                for (x, p) in row.iter().zip(symbolic) {
                    assert!((x - p.eval(&a)).abs() < 1e-12, "n {n} k {k}");
                }
            }
        }
    }
}

/// Example 1's w is the paper's (4.4): 2(p − α₁) − [(q − α₂) − α₁(p − α₁)]²/(2α₁α₂) with
/// C = C₁ = diag(2α₁α₂, 0).
#[test]
fn example_one_w_is_the_printed_4_4() {
    let (a1, a2, p) = (0.7, 1.3, 1.1);
    let c = Criterion::new(&[a1, a2], &[2.0 * a1 * a2, 0.0]).unwrap();
    assert_eq!(c.i, 2);
    for q in [0.1, 0.9, 2.0, 3.5] {
        let printed = 2.0 * (p - a1) - ((q - a2) - a1 * (p - a1)).powi(2) / (2.0 * a1 * a2);
        assert!((c.w(&[p, q]) - printed).abs() < 1e-13, "q = {q}");
    }
}

/// The boundary lasalle finds by maximising over α is (4.9), for two dampings p, at the
/// α's of (4.7), (4.8): α₁ = p/2, α₂ = p²(¼ + z₁ + √z₁).
#[test]
fn example_one_boundary_is_the_printed_4_9() {
    for p in [1.0, 2.5] {
        for z1 in [0.05, 0.25, 1.0, 2.0, 4.0] {
            let e = example1_boundary(p, z1).unwrap();
            let printed = example1_printed(z1);
            assert!(
                (e.z2 - printed).abs() <= 1e-11 * printed,
                "p {p} z1 {z1}: {e:?}"
            );
            assert!((e.alpha[0] / p - 0.5).abs() < 1e-6, "{e:?}");
            let a2 = 0.25 + z1 + z1.sqrt();
            assert!((e.alpha[1] / (p * p) - a2).abs() < 1e-9 * a2, "{e:?}");
        }
    }
}

/// Example 2's bound is (4.20) on both sides of p = √2, with the α's of (4.15), (4.19).
#[test]
fn example_two_bound_is_the_printed_4_20() {
    for lambda in [0.1, 1.0] {
        for p in [0.5, 1.0, 1.4, 2.0, 3.0] {
            let e = example2_bound(p, lambda).unwrap();
            let printed = example2_printed(p, lambda);
            assert!(
                (e.r2 - printed).abs() <= 1e-7 * printed,
                "{e:?} vs {printed}"
            );
            assert!(e.w0.abs() < 1e-12 && e.r1.abs() < 1e-12, "{e:?}");
            // (4.19); the bound is flat in α₁ at its maximum, so α's are found to ~1e-4
            let a2 = if p * p <= 2.0 { 1.0 - p * p / 4.0 } else { 0.5 };
            assert!((e.alpha[1] - a2).abs() < 1e-4, "{e:?}");
            let [a1, _, a3] = e.alpha;
            assert!(
                (1.0 - e.alpha[1] - a1 * (p - a1)).abs() < 1e-6,
                "(4.15) {e:?}"
            );
            let d2 = a1 * e.alpha[1] - a3;
            assert!(
                ((p - a1) * d2 - a3 * (lambda + a1)).abs() < 1e-6,
                "(4.16) {e:?}"
            );
        }
    }
}

/// The refusals of α's and C's outside the theorem.
#[test]
fn bad_choices_are_refused() {
    assert!(matches!(
        Criterion::new(&[1.0, -1.0], &[1.0, 0.0]),
        Err(CriterionError::NotHurwitz { k: 2, .. })
    ));
    assert!(matches!(
        Criterion::new(&[1.0, 1.0], &[1.0, 1.0]),
        Err(CriterionError::BadC(_))
    ));
    // i = 1 for n = 2: β₂₁ = 0
    assert!(matches!(
        Criterion::new(&[1.0, 1.0], &[0.0, 1.0]),
        Err(CriterionError::BetaNotPositive { i: 1, .. })
    ));
    assert!(matches!(
        Criterion::new(&[1.0, 1.0], &[1.0]),
        Err(CriterionError::Size { alpha: 2, c: 1 })
    ));
}

const EXAMPLE1: &str = "model E1 {
    state x: scalar;
    state v: scalar;
    state clock: scalar;
    param p = 1;
    param q0 = 1.25;
    param dq = 0.95;
    d/dt x = v;
    d/dt v = -p * v - (q0 + dq * sin(clock)) * x;
    d/dt clock = 1;
}";

/// The equation read off a model, and the criterion along t: q(t) ∈ [0.3, 2.2] lies inside
/// the interval (0.25, 2.25) of α = (½, 1), C = diag(1, 0), where w = 1 − (q − 5/4)², so
/// min w = 1 − 0.95², at sin t = ±1.
#[test]
fn criterion_along_t_on_a_model() {
    let model = lower_source("e1.lsl", EXAMPLE1).unwrap();
    let params = model.default_params();
    let eq = CompanionEquation::from_model(&model, &params).unwrap();
    assert_eq!(eq.order(), 2);
    assert!(eq.time_varying());
    let p = eq.coefficients_at(0.5, &params);
    assert!((p[0] - 1.0).abs() < 1e-15 && (p[1] - (1.25 + 0.95 * 0.5f64.sin())).abs() < 1e-15);
    let c = Criterion::new(&[0.5, 1.0], &[1.0, 0.0]).unwrap();
    let a = assess(&eq, &c, &params, (0.0, 2.0 * std::f64::consts::PI), 64);
    assert!(a.holds());
    assert!(
        (a.min_w - (1.0 - 0.95f64.powi(2))).abs() < 1e-12,
        "{}",
        a.min_w
    );
    // a wider swing leaves the paraboloid
    let mut wide = params.clone();
    wide[2] = 1.1;
    let a = assess(&eq, &c, &wide, (0.0, 2.0 * std::f64::consts::PI), 64);
    assert!(!a.holds() && (a.min_w - (1.0 - 1.21)).abs() < 1e-12);
}

fn refusal(text: &str) -> String {
    let model = lower_source("bad.lsl", text).unwrap();
    let params = model.default_params();
    match CompanionEquation::from_model(&model, &params) {
        Ok(_) => panic!("accepted a model that is not in companion form"),
        Err(e) => e.to_string(),
    }
}

/// Models that are not an n-th order linear equation in companion form, each refused at the
/// offending line.
#[test]
fn non_companion_models_are_refused_with_their_line() {
    let e =
        refusal("model B { state x: scalar; state v: scalar;\n d/dt x = 2 * v;\n d/dt v = -x; }");
    assert!(
        e.starts_with("bad.lsl:2:2:") && e.contains("d/dt x is"),
        "{e}"
    );
    let e = refusal(
        "model B { state x: scalar; state v: scalar;\n d/dt x = v;\n d/dt v = -x * x - v; }",
    );
    assert!(
        e.starts_with("bad.lsl:3:2:") && e.contains("depends on the state x"),
        "{e}"
    );
    let e = refusal("model B { state x: scalar; state v: scalar; state c: scalar;\n d/dt x = v;\n d/dt v = -x - v + sin(c);\n d/dt c = 1; }");
    assert!(
        e.starts_with("bad.lsl:3:2:") && e.contains("not homogeneous"),
        "{e}"
    );
}
