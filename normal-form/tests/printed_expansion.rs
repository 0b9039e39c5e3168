//! The expansion of the restricted three-body Hamiltonian at L4 printed in the first paper of
//! NASA TM X-53478 (Birkhoff normal forms and finite-time stability), its equations (7)–(9),
//! against lasalle's jets of `models/cr3bp.lsl` and against an independent evaluation of the
//! paper's Hamiltonian (6).
//!
//! The paper's coordinates are the model's: unit distance and angular velocity,
//! m₁ + m₂ = 1, m₁ = 1 − μ at x₁ = −μ, m₂ = μ at x₂ = 1 − μ, and about L4 = (a, b) with
//! a = ½ − μ, b = √3/2: x = a + q₁, y = b + q₂, u = −b + p₁, v = a + p₂, with
//! k = (3√3/4)(m₁ − m₂)/(m₁ + m₂) = (3√3/4)(1 − 2μ).
//!
//! What the OCR of the paper shows and what is derived (docs/normal-form.md, "The paper's
//! expansion (7)–(9)"): every numerator of (7)–(9) is legible; the denominators of (8) are not,
//! nor the k of its q₁³ term, nor most signs of (9). Those entries are derived by hand from the
//! Legendre expansion of 1/r about the unit vectors from the primaries to L4, and the test
//! checks the whole printed-and-derived table.

mod common;

use lasalle_normal_form::{taylor, Dd, MonomialTable, Real};
use std::sync::Arc;

/// One coefficient of (7)–(9): the monomial's exponents of z = (q₁, q₂, p₁, p₂), the term as
/// printed, and its value in terms of k and √3.
struct Printed {
    exponents: [u8; 4],
    term: &'static str,
    value: Dd,
}

/// (7) H₂, (8) H₃, (9) H₄ of the paper at mass ratio μ, in double-double.
fn printed(mu: f64) -> Vec<Printed> {
    let c = Dd::new;
    let s3 = c(3.0).sqrt();
    let k = c(3.0) * s3 / c(4.0) * (c(1.0) - c(2.0) * c(mu));
    let t = |exponents: [u8; 4], term: &'static str, value: Dd| Printed {
        exponents,
        term,
        value,
    };
    vec![
        // (7)
        t([0, 0, 2, 0], "½p₁²", c(0.5)),
        t([0, 0, 0, 2], "½p₂²", c(0.5)),
        t([0, 1, 1, 0], "q₂p₁", c(1.0)),
        t([1, 0, 0, 1], "−q₁p₂", c(-1.0)),
        t([2, 0, 0, 0], "⅛q₁²", c(1.0) / c(8.0)),
        t([1, 1, 0, 0], "−kq₁q₂", -k),
        t([0, 2, 0, 0], "−⅝q₂²", c(-5.0) / c(8.0)),
        // (8)
        t([3, 0, 0, 0], "−(7√3/36)kq₁³", -(c(7.0) * s3 / c(36.0)) * k),
        t([2, 1, 0, 0], "(3√3/16)q₁²q₂", c(3.0) * s3 / c(16.0)),
        t([1, 2, 0, 0], "(11√3/12)kq₁q₂²", c(11.0) * s3 / c(12.0) * k),
        t([0, 3, 0, 0], "(3√3/16)q₂³", c(3.0) * s3 / c(16.0)),
        // (9)
        t([4, 0, 0, 0], "(37/128)q₁⁴", c(37.0) / c(128.0)),
        t([3, 1, 0, 0], "(25/24)kq₁³q₂", c(25.0) / c(24.0) * k),
        t([2, 2, 0, 0], "−(123/64)q₁²q₂²", c(-123.0) / c(64.0)),
        t([1, 3, 0, 0], "−(15/8)kq₁q₂³", c(-15.0) / c(8.0) * k),
        t([0, 4, 0, 0], "−(3/128)q₂⁴", c(-3.0) / c(128.0)),
    ]
}

/// L4 of the model at mass ratio μ, exactly in double-double: (a, b, −b, a).
fn l4_dd(mu: f64) -> Vec<Dd> {
    let a = Dd::new(0.5) - Dd::new(mu);
    let b = Dd::new(3.0).sqrt() / Dd::new(2.0);
    vec![a, b, -b, a]
}

/// The mass ratios checked: Sun–Jupiter, 0.001, 0.01, Earth–Moon, 0.03, and one beyond
/// Routh's (the expansion does not care about stability).
const MUS: [f64; 6] = [
    9.538_754_045_839_5e-4,
    0.001,
    0.01,
    lasalle_normal_form::validate::EARTH_MOON_MU,
    0.03,
    0.1,
];

#[test]
fn printed_h2_h3_h4_equal_the_models_taylor_coefficients() {
    let table = Arc::new(MonomialTable::new(4, 4));
    for mu in MUS {
        let h = common::cr3bp(mu);
        let jet = taylor(&h, &l4_dd(mu), &table);
        let expected = printed(mu);
        let mut worst = 0.0f64;
        for (k, i, got) in jet.terms() {
            if k == 0 {
                continue;
            }
            let e = jet.exponents(k, i);
            let want = expected
                .iter()
                .find(|p| p.exponents[..] == *e)
                .map_or(Dd::new(0.0), |p| p.value);
            let err = (got - want).abs().to_f64();
            worst = worst.max(err);
            assert!(
                err < 1e-29,
                "mu = {mu}: coefficient of {e:?} is {got}, the paper's (7)–(9) give {want} ({err:e})"
            );
        }
        // and nothing printed is missing from the jet
        for p in &expected {
            let got = jet.coeff(&p.exponents);
            assert!(
                (got - p.value).abs().to_f64() < 1e-29,
                "mu = {mu}: {} is {} in the jet, {} printed",
                p.term,
                got,
                p.value
            );
        }
        println!("mu = {mu}: largest |lasalle − (7)–(9)| = {worst:.1e}");
    }
}

/// The paper's matrix E of H₂ = ½ rᵀE r, r = (q₁, q₂, p₁, p₂), is the Hessian at L4.
#[test]
fn the_matrix_e_is_the_hessian_at_l4() {
    let mu = lasalle_normal_form::validate::EARTH_MOON_MU;
    let table = Arc::new(MonomialTable::new(4, 2));
    let jet = taylor(&common::cr3bp(mu), &l4_dd(mu), &table);
    let k = Dd::new(3.0).sqrt() * Dd::new(0.75) * (Dd::new(1.0) - Dd::new(2.0 * mu));
    let c = Dd::new;
    let e = [
        [c(0.25), -k, c(0.0), c(-1.0)],
        [-k, c(-1.25), c(1.0), c(0.0)],
        [c(0.0), c(1.0), c(1.0), c(0.0)],
        [c(-1.0), c(0.0), c(0.0), c(1.0)],
    ];
    for i in 0..4 {
        for j in 0..4 {
            let mut ex = [0u8; 4];
            ex[i] += 1;
            ex[j] += 1;
            // ½ rᵀE r: the diagonal gives ½E_ii z_i², the pair (i, j) gives E_ij z_i z_j
            let want = if i == j { e[i][j] * c(0.5) } else { e[i][j] };
            let got = jet.coeff(&ex);
            assert!(
                (got - want).abs().to_f64() < 1e-30,
                "E[{i}][{j}]: jet {got}, printed {want}"
            );
        }
    }
}

/// The paper's Hamiltonian (6), H = ½(u² + v²) + (uy − vx) − m₁/r₁ − m₂/r₂, written here
/// directly (not through the model file or the jets), at L4 + z.
fn paper_hamiltonian(mu: f64, z: &[Dd; 4]) -> Dd {
    let l4 = l4_dd(mu);
    let (x, y) = (l4[0] + z[0], l4[1] + z[1]);
    let (u, v) = (l4[2] + z[2], l4[3] + z[3]);
    let c = Dd::new;
    let r1 = ((x + c(mu)) * (x + c(mu)) + y * y).sqrt();
    let r2 = ((x - c(1.0) + c(mu)) * (x - c(1.0) + c(mu)) + y * y).sqrt();
    c(0.5) * (u * u + v * v) + (u * y - v * x) - (c(1.0) - c(mu)) / r1 - c(mu) / r2
}

/// Σ (7)–(9) at z.
fn printed_sum(terms: &[Printed], z: &[Dd; 4]) -> Dd {
    terms.iter().fold(Dd::new(0.0), |acc, p| {
        let m = p
            .exponents
            .iter()
            .zip(z)
            .fold(p.value, |m, (&e, &x)| (0..e).fold(m, |m, _| m * x));
        acc + m
    })
}

/// H(L4 + εw) − H(L4) − (H₂ + H₃ + H₄)(εw) is O(ε⁵): halving ε divides it by 32 (a wrong
/// coefficient of degree s ≤ 4 would leave a part that is only divided by 2ˢ). At ε = 1e-5
/// this resolves an error of 1e-7 in a degree-4 coefficient and 1e-12 in a degree-3 one.
#[test]
fn printed_expansion_matches_the_hamiltonian_by_differences() {
    let directions: [[f64; 4]; 5] = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.6, -0.8, 0.0, 0.0],
        [0.5, 0.5, 0.3, -0.7],
        [-0.3, 0.9, -0.2, 0.25],
    ];
    for mu in MUS {
        let terms = printed(mu);
        let h0 = paper_hamiltonian(mu, &[Dd::new(0.0); 4]);
        let residual = |eps: f64, w: &[f64; 4]| {
            let z = w.map(|x| Dd::new(x * eps));
            paper_hamiltonian(mu, &z) - h0 - printed_sum(&terms, &z)
        };
        for w in &directions {
            let (r1, r2) = (residual(1e-5, w), residual(5e-6, w));
            let ratio = (r1 / r2).to_f64();
            assert!(
                (ratio - 32.0).abs() < 0.5,
                "mu = {mu}, direction {w:?}: residual {r1} at 1e-5, {r2} at 5e-6 (ratio {ratio}, O(ε⁵) gives 32)"
            );
        }
    }
}
