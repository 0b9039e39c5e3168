//! The optimal-control-on-SO(3) extremal models (Rodgerson 2009, chs. 4–7) against hand
//! transcriptions of the thesis:
//! - the generated fields equal the extremal equations (4.5)–(4.7), (5.5)–(5.7), (6.5)–(6.7),
//!   (7.5)–(7.7) together with the reconstruction ġ = g Ξ(u), Ξ = u1 E1 + u2 E2 + u3 E3 (+ E3)
//!   with the optimal controls of Theorems 4.2.1, 5.2.1, 6.2.1, 7.2.1, at 500 random states
//!   (P in a box, g a rotation from random Euler angles) and several parameter sets, to 1e-12
//!   relative;
//! - the generated invariants are H of (4.4), (5.4), (6.4), (7.4), gᵀg − I, the spatial momentum
//!   Λ = g P of (3.12) and the Casimir K = |P|² (Prop. 3.3.1);
//! - along DOPRI5 from every worked case of Appendix B (C.1–C.19, with its cᵢ and time span),
//!   H, K and Λ stay constant and g stays orthogonal;
//! - the models' points carry the P(0) of the thesis' ode45 calls;
//! - for c1 = c2 the integrated P(t) of Types IIa, IIb and III is the rotation of Props. 5.3.1,
//!   6.3.1 and 7.3.2.

use lasalle::models::{
    so3_type_i::So3TypeI, so3_type_iia::So3TypeIia, so3_type_iib::So3TypeIib,
    so3_type_iii::So3TypeIii,
};
use lasalle::{Control, DormandPrince, DormandPrinceOptions, Driver, Field, Invariants};
use lasalle_testkit::Rng;

const SAMPLES: usize = 500;
const REL: f64 = 1e-12;

type Mat = [[f64; 3]; 3];

fn mul(a: &Mat, b: &Mat) -> Mat {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The rotation Rz(φ1) Ry(φ2) Rx(φ3) (the thesis' "x-y-z convention" of §2).
fn rotation(phi1: f64, phi2: f64, phi3: f64) -> Mat {
    let (s1, c1) = phi1.sin_cos();
    let (s2, c2) = phi2.sin_cos();
    let (s3, c3) = phi3.sin_cos();
    let rz = [[c1, -s1, 0.0], [s1, c1, 0.0], [0.0, 0.0, 1.0]];
    let ry = [[c2, 0.0, s2], [0.0, 1.0, 0.0], [-s2, 0.0, c2]];
    let rx = [[1.0, 0.0, 0.0], [0.0, c3, -s3], [0.0, s3, c3]];
    mul(&mul(&rz, &ry), &rx)
}

/// The flat state: P, then g column-major.
fn state(p: [f64; 3], g: &Mat) -> [f64; 12] {
    let mut x = [0.0; 12];
    x[..3].copy_from_slice(&p);
    for j in 0..3 {
        for i in 0..3 {
            x[3 + 3 * j + i] = g[i][j];
        }
    }
    x
}

fn unpack(x: &[f64; 12]) -> ([f64; 3], Mat) {
    let g = std::array::from_fn(|i| std::array::from_fn(|j| x[3 + 3 * j + i]));
    ([x[0], x[1], x[2]], g)
}

/// A random state: P in [−3, 3]³, g = Rz Ry Rx of random angles.
fn random_state(rng: &mut Rng) -> [f64; 12] {
    let p = [
        rng.uniform(-3.0, 3.0),
        rng.uniform(-3.0, 3.0),
        rng.uniform(-3.0, 3.0),
    ];
    let pi = std::f64::consts::PI;
    let g = rotation(
        rng.uniform(-pi, pi),
        rng.uniform(-pi / 2.0, pi / 2.0),
        rng.uniform(-pi, pi),
    );
    state(p, &g)
}

/// The four types, with the thesis' equations written out by hand (not via P × ∇H).
/// The variants are the thesis' names (Roman numerals), not acronyms.
#[allow(clippy::upper_case_acronyms)]
#[derive(Clone, Copy, Debug, PartialEq)]
enum Type {
    I,
    IIa,
    IIb,
    III,
}

impl Type {
    /// Ṗ: (4.5)–(4.7), (5.5)–(5.7), (6.5)–(6.7), (7.5)–(7.7) as printed.
    fn extremals(self, c: [f64; 3], p: [f64; 3]) -> [f64; 3] {
        let [c1, c2, c3] = c;
        let [p1, p2, p3] = p;
        match self {
            Type::I => [p2, -p1 + p1 * p3 / c1, -p1 * p2 / c1],
            Type::IIa => [-p2 * p3 / c2, p1 * p3 / c1, (c1 - c2) / (c1 * c2) * p1 * p2],
            Type::IIb => [
                p2 - p2 * p3 / c2,
                -p1 + p1 * p3 / c1,
                (c1 - c2) / (c1 * c2) * p1 * p2,
            ],
            Type::III => [
                (c2 - c3) / (c2 * c3) * p2 * p3,
                (c3 - c1) / (c1 * c3) * p1 * p3,
                (c1 - c2) / (c1 * c2) * p1 * p2,
            ],
        }
    }

    /// The coefficients of Ξ = ξ1 E1 + ξ2 E2 + ξ3 E3 in ġ = g Ξ: the systems (4.2), (5.2), (6.2),
    /// (7.2) with the optimal controls (4.3), (5.3), (6.3), (7.3), ui = Pi/ci.
    fn xi(self, c: [f64; 3], p: [f64; 3]) -> [f64; 3] {
        let [c1, c2, c3] = c;
        let [p1, p2, p3] = p;
        match self {
            Type::I => [p1 / c1, 0.0, 1.0],
            Type::IIa => [p1 / c1, p2 / c2, 0.0],
            Type::IIb => [p1 / c1, p2 / c2, 1.0],
            Type::III => [p1 / c1, p2 / c2, p3 / c3],
        }
    }

    /// The optimal Hamiltonians (4.4), (5.4), (6.4), (7.4).
    fn hamiltonian(self, c: [f64; 3], p: [f64; 3]) -> f64 {
        let [c1, c2, c3] = c;
        let [p1, p2, p3] = p;
        match self {
            Type::I => p1 * p1 / (2.0 * c1) + p3,
            Type::IIa => 0.5 * (p1 * p1 / c1 + p2 * p2 / c2),
            Type::IIb => 0.5 * (p1 * p1 / c1 + p2 * p2 / c2) + p3,
            Type::III => 0.5 * (p1 * p1 / c1 + p2 * p2 / c2 + p3 * p3 / c3),
        }
    }

    /// The whole field: (Ṗ, ġ = g Ξ) with E1, E2, E3 the standard basis of so(3) (§2.2:
    /// Ei = hat(ei)), g column-major.
    fn field(self, c: [f64; 3], x: &[f64; 12]) -> [f64; 12] {
        let (p, g) = unpack(x);
        let [a, b, d] = self.xi(c, p);
        // a E1 + b E2 + d E3
        let xi = [[0.0, -d, b], [d, 0.0, -a], [-b, a, 0.0]];
        state(self.extremals(c, p), &mul(&g, &xi))
    }

    /// f = (H, gᵀg − I column-major, Λ = g P, K = |P|²), the models' stacked invariants.
    fn invariants(self, c: [f64; 3], x: &[f64; 12]) -> [f64; 14] {
        let (p, g) = unpack(x);
        let mut f = [0.0; 14];
        f[0] = self.hamiltonian(c, p);
        for j in 0..3 {
            for i in 0..3 {
                let gtg: f64 = (0..3).map(|k| g[k][i] * g[k][j]).sum();
                f[1 + 3 * j + i] = gtg - if i == j { 1.0 } else { 0.0 };
            }
        }
        for i in 0..3 {
            f[10 + i] = (0..3).map(|k| g[i][k] * p[k]).sum();
        }
        f[13] = p.iter().map(|v| v * v).sum();
        f
    }
}

/// A worked case of Appendix B: figure, type, (c1, c2, c3) (unused ones 0), P(0) as in the
/// thesis' ode45 call (4 decimals), and the ode45 time span.
struct Case {
    figure: &'static str,
    ty: Type,
    c: [f64; 3],
    p0: [f64; 3],
    t_end: f64,
}

const fn case(figure: &'static str, ty: Type, c: [f64; 3], p0: [f64; 3], t_end: f64) -> Case {
    Case {
        figure,
        ty,
        c,
        p0,
        t_end,
    }
}

const CASES: [Case; 19] = [
    case("C.1", Type::I, [2.0, 0.0, 0.0], [4.0, 0.0, 1.0], 10.0),
    case("C.2", Type::IIa, [4.0, 1.0, 0.0], [2.0, 2.0, 4.0], 10.0),
    case("C.3", Type::IIa, [4.0, 1.0, 0.0], [4.0, 2.0, 2.0], 10.0),
    case("C.4", Type::IIa, [1.0, 4.0, 0.0], [1.0, 2.0, 3.0], 10.0),
    case("C.5", Type::IIa, [1.0, 4.0, 0.0], [3.0, 2.0, 1.0], 10.0),
    case(
        "C.6",
        Type::IIb,
        [1.0, 0.5, 0.0],
        [0.3536, 0.8420, 0.1563],
        30.0,
    ),
    case(
        "C.7",
        Type::IIb,
        [1.0, 0.5, 0.0],
        [1.2247, 2.8284, -1.0],
        10.0,
    ),
    case(
        "C.8",
        Type::IIb,
        [1.0, 2.0, 0.0],
        [1.4577, 0.3953, 0.5],
        30.0,
    ),
    case("C.9", Type::IIb, [1.0, 2.0, 0.0], [4.4721, 1.0, -2.0], 10.0),
    case("C.10", Type::III, [3.0, 2.0, 4.0], [0.0, 1.0, 2.0], 30.0),
    case("C.11", Type::III, [3.0, 2.0, 4.0], [0.0, 2.0, 1.0], 30.0),
    case("C.12", Type::III, [1.0, 2.0, 3.0], [1.0, 1.0, 2.0], 30.0),
    case("C.13", Type::III, [1.0, 2.0, 3.0], [1.0, 1.0, 1.0], 30.0),
    case("C.14", Type::III, [2.0, 3.0, 1.0], [1.0, 1.0, 1.0], 30.0),
    case("C.15", Type::III, [2.0, 3.0, 1.0], [1.0, 2.0, 1.0], 30.0),
    case("C.16", Type::III, [3.0, 2.0, 1.0], [1.0, 1.0, 1.0], 30.0),
    case("C.17", Type::III, [3.0, 2.0, 1.0], [2.0, 1.0, 1.0], 30.0),
    case("C.18", Type::III, [2.0, 0.5, 1.0], [1.7321, 1.0, 1.0], 30.0),
    case("C.19", Type::III, [1.0, 3.0, 2.0], [2.0, 2.0, 2.0], 30.0),
];

/// Builds the generated model of a type with parameters c; the unused cᵢ are ignored.
macro_rules! with_model {
    ($ty:expr, $c:expr, |$m:ident| $body:expr) => {{
        let c: [f64; 3] = $c;
        match $ty {
            Type::I => {
                let $m = So3TypeI::<f64> { c1: c[0] }.prepare();
                $body
            }
            Type::IIa => {
                let $m = So3TypeIia::<f64> { c1: c[0], c2: c[1] }.prepare();
                $body
            }
            Type::IIb => {
                let $m = So3TypeIib::<f64> { c1: c[0], c2: c[1] }.prepare();
                $body
            }
            Type::III => {
                let $m = So3TypeIii::<f64> {
                    c1: c[0],
                    c2: c[1],
                    c3: c[2],
                }
                .prepare();
                $body
            }
        }
    }};
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn assert_close(what: &str, got: &[f64], want: &[f64], rel: f64) {
    let scale = max_abs(want).max(1e-300);
    let err = got
        .iter()
        .zip(want)
        .fold(0.0f64, |m, (g, w)| m.max((g - w).abs()));
    assert!(
        err <= rel * scale,
        "{what}: max error {err:.3e} relative {:.3e}\n got  {got:?}\n want {want:?}",
        err / scale
    );
}

/// Parameter sets per type: the thesis' (Appendix B), a few off-grid ones, and for the
/// two-parameter types c1 = c2 (Props. 5.3.1, 6.3.1), for Type III c1 = c2 ≠ c3 (Prop. 7.3.2).
fn parameter_sets(ty: Type, rng: &mut Rng) -> Vec<[f64; 3]> {
    let mut sets: Vec<[f64; 3]> = Vec::new();
    for case in CASES.iter().filter(|k| k.ty == ty) {
        if !sets.contains(&case.c) {
            sets.push(case.c);
        }
    }
    sets.push(match ty {
        Type::I => [0.7, 0.0, 0.0],
        Type::IIa | Type::IIb => [1.5, 1.5, 0.0],
        Type::III => [1.5, 1.5, 0.4],
    });
    for _ in 0..3 {
        sets.push([
            rng.uniform(0.2, 5.0),
            rng.uniform(0.2, 5.0),
            rng.uniform(0.2, 5.0),
        ]);
    }
    sets
}

const TYPES: [Type; 4] = [Type::I, Type::IIa, Type::IIb, Type::III];

#[test]
fn fields_are_the_thesis_extremal_equations_with_reconstruction() {
    let mut rng = Rng::new(0x5eed_0003_711a_eb44);
    for ty in TYPES {
        for c in parameter_sets(ty, &mut rng) {
            with_model!(ty, c, |m| {
                for k in 0..SAMPLES {
                    let x = random_state(&mut rng);
                    let mut dx = [0.0; 12];
                    m.field(&x, &mut dx);
                    let want = ty.field(c, &x);
                    let at = format!("{ty:?} c = {c:?} sample {k}");
                    assert_close(&format!("{at}: Ṗ"), &dx[..3], &want[..3], REL);
                    assert_close(&format!("{at}: ġ"), &dx[3..], &want[3..], REL);
                }
            });
        }
    }
}

#[test]
fn invariants_are_h_orthogonality_spatial_momentum_and_casimir() {
    let mut rng = Rng::new(0x0bad_5eed_c0ff_ee11);
    for ty in TYPES {
        for c in parameter_sets(ty, &mut rng) {
            with_model!(ty, c, |m| {
                for k in 0..SAMPLES {
                    let mut x = random_state(&mut rng);
                    // off SO(3) too, so that the orthogonality slots are non-trivial
                    if k % 2 == 1 {
                        for v in &mut x[3..] {
                            *v += rng.uniform(-0.1, 0.1);
                        }
                    }
                    let mut f = [0.0; 14];
                    m.invariants(&x, &mut f);
                    let want = ty.invariants(c, &x);
                    let at = format!("{ty:?} c = {c:?} sample {k}");
                    assert_close(&format!("{at}: H"), &f[..1], &want[..1], REL);
                    // absolute on the scale of |g|² ~ 1
                    let scale = max_abs(&x[3..]).powi(2);
                    for i in 1..10 {
                        assert!(
                            (f[i] - want[i]).abs() <= REL * scale,
                            "{at}: orthogonality {:?} vs {:?}",
                            &f[1..10],
                            &want[1..10]
                        );
                    }
                    assert_close(&format!("{at}: Λ"), &f[10..13], &want[10..13], REL);
                    assert_close(&format!("{at}: K"), &f[13..], &want[13..], REL);
                }
            });
        }
    }
}

/// The largest drift of H, K, Λ (relative to the size at t = 0) and of gᵀg − I along DOPRI5
/// from (P(0), g(0)) on [0, t_end], observed at every accepted step.
fn drift(ty: Type, c: [f64; 3], x0: &[f64; 12], t_end: f64) -> ([f64; 4], [f64; 12]) {
    let opts = DormandPrinceOptions {
        rtol: 1e-11,
        atol: 1e-13,
        ..Default::default()
    };
    with_model!(ty, c, |m| {
        let mut f0 = [0.0; 14];
        m.invariants(x0, &mut f0);
        let mut worst = [0.0f64; 4];
        let mut observer = |_: u64, _: f64, x: &[f64; 12]| {
            let mut f = [0.0; 14];
            m.invariants(x, &mut f);
            let dh = (f[0] - f0[0]).abs() / f0[0].abs().max(1.0);
            let dortho = max_abs(&f[1..10]);
            let dl = f[10..13]
                .iter()
                .zip(&f0[10..13])
                .fold(0.0f64, |a, (u, v)| a.max((u - v).abs()))
                / max_abs(&f0[10..13]).max(1.0);
            let dk = (f[13] - f0[13]).abs() / f0[13].max(1.0);
            for (w, d) in worst.iter_mut().zip([dh, dk, dortho, dl]) {
                *w = w.max(d);
            }
            Control::Continue
        };
        let mut dp = DormandPrince::<f64, [f64; 12]>::new(opts);
        let end = Driver::new(0.0, t_end, 0.0)
            .run(&mut dp, &m, x0, &mut observer)
            .unwrap_or_else(|e| panic!("{ty:?} c = {c:?}: {e}"));
        assert!((end.t - t_end).abs() < 1e-9 * t_end, "stopped at {}", end.t);
        (worst, end.x)
    })
}

#[test]
fn appendix_b_cases_conserve_h_casimir_spatial_momentum_and_orthogonality() {
    let mut rng = Rng::new(0xc0de_0000_0000_0019);
    for case in &CASES {
        // g(0) = I as in the thesis, and a random rotation
        let g_random = unpack(&random_state(&mut rng)).1;
        let identity = rotation(0.0, 0.0, 0.0);
        for g0 in [identity, g_random] {
            let x0 = state(case.p0, &g0);
            let (worst, end) = drift(case.ty, case.c, &x0, case.t_end);
            let [dh, dk, dortho, dl] = worst;
            let what = format!(
                "{} ({:?}, c = {:?}, P(0) = {:?}, t ∈ [0, {}])",
                case.figure, case.ty, case.c, case.p0, case.t_end
            );
            assert!(dh < 1e-8, "{what}: |ΔH| = {dh:.2e}");
            assert!(dk < 1e-8, "{what}: |ΔK| = {dk:.2e}");
            assert!(dortho < 1e-8, "{what}: |gᵀg − I| = {dortho:.2e}");
            assert!(dl < 1e-8, "{what}: |ΔΛ| = {dl:.2e}");
            // and the trajectory moved: the invariants are not conserved trivially
            let moved = max_abs(
                &end.iter()
                    .zip(&x0)
                    .map(|(a, b)| a - b)
                    .collect::<Vec<f64>>(),
            );
            assert!(moved > 1e-3, "{what}: the state did not move ({moved:.2e})");
        }
    }
}

#[test]
fn points_carry_the_appendix_b_initial_values() {
    let points: [(&str, [f64; 12]); 19] = [
        ("C.1", So3TypeI::<f64>::default().point_case_c1()),
        ("C.2", So3TypeIia::<f64>::default().point_case_c2()),
        ("C.3", So3TypeIia::<f64>::default().point_case_c3()),
        ("C.4", So3TypeIia::<f64>::default().point_case_c4()),
        ("C.5", So3TypeIia::<f64>::default().point_case_c5()),
        ("C.6", So3TypeIib::<f64>::default().point_case_c6()),
        ("C.7", So3TypeIib::<f64>::default().point_case_c7()),
        ("C.8", So3TypeIib::<f64>::default().point_case_c8()),
        ("C.9", So3TypeIib::<f64>::default().point_case_c9()),
        ("C.10", So3TypeIii::<f64>::default().point_case_c10()),
        ("C.11", So3TypeIii::<f64>::default().point_case_c11()),
        ("C.12", So3TypeIii::<f64>::default().point_case_c12()),
        ("C.13", So3TypeIii::<f64>::default().point_case_c13()),
        ("C.14", So3TypeIii::<f64>::default().point_case_c14()),
        ("C.15", So3TypeIii::<f64>::default().point_case_c15()),
        ("C.16", So3TypeIii::<f64>::default().point_case_c16()),
        ("C.17", So3TypeIii::<f64>::default().point_case_c17()),
        ("C.18", So3TypeIii::<f64>::default().point_case_c18()),
        ("C.19", So3TypeIii::<f64>::default().point_case_c19()),
    ];
    let identity = state([0.0; 3], &rotation(0.0, 0.0, 0.0));
    for ((figure, x), case) in points.iter().zip(&CASES) {
        assert_eq!(*figure, case.figure);
        // ode45 was given P(0) to 4 decimals
        for i in 0..3 {
            assert!(
                (x[i] - case.p0[i]).abs() <= 5e-5,
                "{figure}: P(0) = {:?}, thesis {:?}",
                &x[..3],
                case.p0
            );
        }
        assert_eq!(x[3..], identity[3..], "{figure}: g(0) = I");
    }
    // each type's default parameters are its first case's
    let first = |ty: Type| CASES.iter().find(|k| k.ty == ty).unwrap().c;
    assert_eq!(So3TypeI::<f64>::default().c1, first(Type::I)[0]);
    let iia = So3TypeIia::<f64>::default();
    assert_eq!([iia.c1, iia.c2], first(Type::IIa)[..2]);
    let iib = So3TypeIib::<f64>::default();
    assert_eq!([iib.c1, iib.c2], first(Type::IIb)[..2]);
    let iii = So3TypeIii::<f64>::default();
    assert_eq!([iii.c1, iii.c2, iii.c3], first(Type::III));
}

/// For c1 = c2 = c, P3 is constant and (P1, P2) rotates: Prop. 5.3.1 (Type IIa, by the angle
/// P3(0) t/c, as printed there); Prop. 6.3.1 (Type IIb, by −(1 − P3(0)/c) t: the matrix in its
/// proof; its closed form P2 = √k1 sin((1 − k2/c) t + k3) has the wrong sign, P2(0) → −P2(0));
/// Prop. 7.3.2 (Type III with c1 = c2 ≠ c3: by −(c − c3)/(c c3) P3(0) t, a rotation, where the
/// proposition prints cosh/sinh with mismatched arguments).
#[test]
fn equal_costs_give_rotations_props_5_3_1_6_3_1_7_3_2() {
    let c = 1.5;
    let c3 = 0.4;
    let p0 = [0.8, -0.6, 1.1];
    let t_end = 7.0;
    let x0 = state(p0, &rotation(0.3, -0.2, 0.9));
    for (ty, cs, omega) in [
        (Type::IIa, [c, c, 0.0], p0[2] / c),
        (Type::IIb, [c, c, 0.0], -(1.0 - p0[2] / c)),
        (Type::III, [c, c, c3], -(c - c3) / (c * c3) * p0[2]),
    ] {
        let (_, end) = drift(ty, cs, &x0, t_end);
        let (s, co) = (omega * t_end).sin_cos();
        let want = [p0[0] * co - p0[1] * s, p0[0] * s + p0[1] * co, p0[2]];
        assert_close(&format!("{ty:?}: P({t_end})"), &end[..3], &want, 1e-8);
    }
}
