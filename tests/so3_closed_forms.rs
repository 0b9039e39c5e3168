//! The thesis' closed-form extremals (Rodgerson 2009, Theorems 4.3.1–7.3.1, Appendix B) against
//! integration: for each of the 19 Appendix B cases, DOPRI5 at rtol = atol = 1e-13 with dense
//! output at 501 times over the case's ode45 span, compared with
//! - the corrected closed form [`Extremal`] (must agree to 1e-10), and
//! - the printed closed forms (Appendix B's MATLAB, transcribed in [`CASES`]), which must be
//!   far off where `docs/so3.md` says the thesis is wrong;
//! - the listings with every constant exact ([`exact_listing`]), which must fit at their phase;
//! - every printed constant against its exact value at four decimals (the errata listed in
//!   [`ERRATA`], the table of `docs/so3.md`).
//!
//! Run with `--nocapture` to see the table of `docs/so3.md`.

use lasalle::models::{
    so3_type_i::So3TypeI, so3_type_iia::So3TypeIia, so3_type_iib::So3TypeIib,
    so3_type_iii::So3TypeIii,
};
use lasalle::{Control, DormandPrince, DormandPrinceOptions, Driver};
use lasalle_analysis::closed_forms::{
    casimir, exact_listing, printed_constants, prop_5_3_1_printed, prop_6_3_1_printed,
    prop_7_3_2_printed, theorem_4_3_2_p3, Case, Constant, Extremal, P3Form, Printed, Type, CASES,
};

const OUTPUTS: usize = 501;
const TOL: f64 = 1e-10;

/// Integrates the extremal of `case` (with g(0) = I) and returns P at `OUTPUTS` equally spaced
/// times on [0, t_end].
fn integrate(case: &Case) -> Vec<(f64, [f64; 3])> {
    integrate_from(case.figure, case.ty, case.c, case.p0, case.t_end)
}

fn integrate_from(
    figure: &str,
    ty: Type,
    c: [f64; 3],
    p0: [f64; 3],
    t_end: f64,
) -> Vec<(f64, [f64; 3])> {
    let times: Vec<f64> = (0..OUTPUTS)
        .map(|i| t_end * i as f64 / (OUTPUTS - 1) as f64)
        .collect();
    let mut x0 = [0.0; 12];
    x0[..3].copy_from_slice(&p0);
    x0[3] = 1.0;
    x0[7] = 1.0;
    x0[11] = 1.0;
    let opts = DormandPrinceOptions {
        rtol: 1e-13,
        atol: 1e-13,
        ..Default::default()
    };
    let mut out = Vec::with_capacity(OUTPUTS);
    let mut observer = |_: u64, t: f64, x: &[f64; 12]| {
        out.push((t, [x[0], x[1], x[2]]));
        Control::Continue
    };
    let mut dp = DormandPrince::<f64, [f64; 12]>::new(opts);
    let driver = Driver::new(0.0, t_end, 0.0).max_steps(10_000_000);
    let [c1, c2, c3] = c;
    let res = match ty {
        Type::I => {
            let m = So3TypeI::<f64> { c1 }.prepare();
            driver.run_dense(&mut dp, &m, &x0, &times, &mut observer)
        }
        Type::IIa => {
            let m = So3TypeIia::<f64> { c1, c2 }.prepare();
            driver.run_dense(&mut dp, &m, &x0, &times, &mut observer)
        }
        Type::IIb => {
            let m = So3TypeIib::<f64> { c1, c2 }.prepare();
            driver.run_dense(&mut dp, &m, &x0, &times, &mut observer)
        }
        Type::III => {
            let m = So3TypeIii::<f64> { c1, c2, c3 }.prepare();
            driver.run_dense(&mut dp, &m, &x0, &times, &mut observer)
        }
    };
    res.unwrap_or_else(|e| panic!("{figure}: {e}"));
    assert_eq!(out.len(), OUTPUTS, "{figure}: dense output incomplete");
    out
}

/// max |a − b|, with NaN counted as ∞ (`f64::max` would drop it).
fn worse(acc: f64, d: f64) -> f64 {
    if d.is_nan() {
        f64::INFINITY
    } else {
        acc.max(d)
    }
}

fn max_diff(reference: &[(f64, [f64; 3])], f: impl Fn(f64) -> [f64; 3]) -> f64 {
    reference.iter().fold(0.0f64, |acc, (t, p)| {
        let q = f(*t);
        (0..3).fold(acc, |a, i| worse(a, (q[i] - p[i]).abs()))
    })
}

/// The printed form compared sign-blind in P₁, P₂ (the thesis leaves their sign as "±" and
/// plots both): max over t and i of | |Pᵢ printed| − |Pᵢ| | for i = 1, 2 and |P₃ printed − P₃|.
fn printed_diff(reference: &[(f64, [f64; 3])], f: &Printed, m: f64) -> f64 {
    reference.iter().fold(0.0f64, |acc, (t, p)| {
        let q = f.eval(*t, m);
        let d = (q[0].abs() - p[0].abs())
            .abs()
            .max((q[1].abs() - p[1].abs()).abs())
            .max((q[2] - p[2]).abs());
        worse(acc, d)
    })
}

fn figure(name: &str) -> usize {
    CASES
        .iter()
        .position(|c| c.figure == name)
        .unwrap_or_else(|| panic!("no case {name}"))
}

/// One case: the corrected closed form within `TOL` of the integration, and the report line.
fn check_case(name: &str) {
    let case = &CASES[figure(name)];
    let reference = integrate(case);
    let exact = Extremal::of_case(case);
    let err = max_diff(&reference, |t| exact.p(t));
    let mut line = format!(
        "{:5} {:4} corrected {:.2e} | m {:.6} (k {:.4}) scale {:.4} | P3 period {:.6}",
        case.figure,
        format!("{:?}", case.ty),
        err,
        exact.parameter(),
        exact.parameter().sqrt(),
        exact.time_scale(),
        exact.p3_period()
    );
    for f in &case.printed {
        line += &format!(
            " | {}: m=k {:.2e} (period {:.4}), m=k² {:.2e} (period {:.4}), P(0) = [{:.4}, {:.4}, {:.4}]",
            f.name,
            printed_diff(&reference, f, f.k),
            f.period(f.k),
            printed_diff(&reference, f, f.k * f.k),
            f.period(f.k * f.k),
            f.eval(0.0, f.k * f.k)[0],
            f.eval(0.0, f.k * f.k)[1],
            f.eval(0.0, f.k * f.k)[2],
        );
    }
    println!("{line}");
    assert!(
        err <= TOL,
        "{}: corrected closed form differs from DOPRI5 by {err:.3e}",
        case.figure
    );
    // the closed form keeps H and K (a check independent of the integration)
    let (h0, k0) = (case.ty.hamiltonian(case.c, case.p0), casimir(case.p0));
    for (t, _) in &reference {
        let p = exact.p(*t);
        assert!((case.ty.hamiltonian(case.c, p) - h0).abs() <= 1e-12 * (1.0 + h0.abs()));
        assert!((casimir(p) - k0).abs() <= 1e-12 * (1.0 + k0));
    }
}

macro_rules! cases {
    ($($test:ident => $name:literal,)*) => {
        $(
            #[test]
            fn $test() {
                check_case($name);
            }
        )*
    };
}

cases! {
    c01_type_i => "C.1",
    c02_type_iia => "C.2",
    c03_type_iia => "C.3",
    c04_type_iia => "C.4",
    c05_type_iia => "C.5",
    c06_type_iib => "C.6",
    c07_type_iib => "C.7",
    c08_type_iib => "C.8",
    c09_type_iib => "C.9",
    c10_type_iii => "C.10",
    c11_type_iii => "C.11",
    c12_type_iii => "C.12",
    c13_type_iii => "C.13",
    c14_type_iii => "C.14",
    c15_type_iii => "C.15",
    c16_type_iii => "C.16",
    c17_type_iii => "C.17",
    c18_type_iii => "C.18",
    c19_type_iii => "C.19",
}

/// The special-case propositions (c₁ = c₂): the corrected form (a uniform rotation of
/// (P₁, P₂), or of the pair of equal axes) matches integration; Prop. 5.3.1 as printed is
/// right, Prop. 6.3.1 has the wrong sign of P₂, Prop. 7.3.2 grows like cosh.
/// A printed proposition: (c, P(0), t) ↦ P(t).
type PrintedProp = fn([f64; 3], [f64; 3], f64) -> [f64; 3];

#[test]
fn special_case_propositions() {
    struct Special {
        name: &'static str,
        ty: Type,
        c: [f64; 3],
        p0: [f64; 3],
        printed: Option<PrintedProp>,
        printed_ok: bool,
    }
    let specials = [
        Special {
            name: "Prop. 5.3.1 (IIa, c1 = c2)",
            ty: Type::IIa,
            c: [1.5, 1.5, 0.0],
            p0: [1.0, 2.0, 3.0],
            printed: Some(|c, p, t| prop_5_3_1_printed(c[0], p, t)),
            printed_ok: true,
        },
        Special {
            name: "Prop. 6.3.1 (IIb, c1 = c2)",
            ty: Type::IIb,
            c: [1.5, 1.5, 0.0],
            p0: [1.0, 2.0, 3.0],
            printed: Some(|c, p, t| prop_6_3_1_printed(c[0], p, t)),
            printed_ok: false,
        },
        Special {
            name: "Prop. 7.3.2 (III, c1 = c2 != c3)",
            ty: Type::III,
            c: [1.5, 1.5, 0.4],
            p0: [1.0, 2.0, 0.5],
            printed: Some(prop_7_3_2_printed),
            printed_ok: false,
        },
        Special {
            name: "after Prop. 7.3.2 (III, c1 != c2 = c3)",
            ty: Type::III,
            c: [0.7, 2.0, 2.0],
            p0: [1.0, 2.0, 0.5],
            printed: None,
            printed_ok: false,
        },
        Special {
            name: "Prop. 7.3.1 (III, c1 = c2 = c3)",
            ty: Type::III,
            c: [2.0, 2.0, 2.0],
            p0: [1.0, 2.0, 0.5],
            printed: None,
            printed_ok: false,
        },
    ];
    for s in &specials {
        let t_end = 10.0;
        let reference = integrate_from(s.name, s.ty, s.c, s.p0, t_end);
        let exact = Extremal::new(s.ty, s.c, s.p0);
        let err = max_diff(&reference, |t| exact.p(t));
        let printed = s.printed.map(|f| max_diff(&reference, |t| f(s.c, s.p0, t)));
        println!("{}: corrected {err:.2e}, printed {printed:?}", s.name);
        assert!(err <= TOL, "{}: corrected differs by {err:.3e}", s.name);
        if let Some(e) = printed {
            if s.printed_ok {
                assert!(e <= TOL, "{}: printed differs by {e:.3e}", s.name);
            } else {
                assert!(e > 1.0, "{}: printed only {e:.3e} off", s.name);
            }
        }
    }
}

/// The listings that start at the right point: with m = k² only these fit (to the four-decimal
/// rounding of their constants).
const FIT_AFTER_M_FIX: [(&str, &str); 3] = [("C.1", "dc"), ("C.10", "dn"), ("C.11", "cn")];

/// The printed closed forms are far off: with MATLAB's `ellipj(·, k)` every listing misses by
/// more than 0.3; fixing only m = k² leaves every listing but the three of `FIT_AFTER_M_FIX`
/// more than 0.3 off (their P(0) is not the case's P(0): the missing phase), and those three
/// within 1e-2; the printed periods with m = k² are right except C.6 (k printed 0.0403 for
/// 0.4026) and C.17 (time scale printed 0.5278 for 0.7265).
#[test]
fn printed_forms_are_off_where_the_thesis_is_wrong() {
    for case in &CASES {
        let reference = integrate(case);
        let exact = Extremal::of_case(case);
        let period = exact.p3_period();
        for f in &case.printed {
            let at = format!("{} {}", case.figure, f.name);
            let as_printed = printed_diff(&reference, f, f.k);
            assert!(
                as_printed > 0.3,
                "{at}: ellipj(., k) only {as_printed:.3e} off"
            );
            let m_fixed = printed_diff(&reference, f, f.k * f.k);
            let start = f.eval(0.0, f.k * f.k);
            let start_diff = (0..3).fold(0.0f64, |a, i| {
                worse(a, (start[i].abs() - case.p0[i].abs()).abs())
            });
            if FIT_AFTER_M_FIX.contains(&(case.figure, f.name)) {
                assert!(m_fixed < 1e-2, "{at}: m = k² still {m_fixed:.3e} off");
                assert!(start_diff < 1e-2, "{at}: P(0) off by {start_diff:.3e}");
            } else {
                assert!(m_fixed > 0.3, "{at}: m = k² only {m_fixed:.3e} off");
                assert!(start_diff > 0.05, "{at}: P(0) only {start_diff:.3e} off");
            }
            // periods: ellipj(., k) is wrong everywhere; with k² right but for two misprints
            let rel = |p: f64| (p - period).abs() / period;
            assert!(
                rel(f.period(f.k)) > 0.02,
                "{at}: period with m = k is right"
            );
            match case.figure {
                "C.6" => {
                    assert!(rel(f.period(f.k * f.k)) > 0.04, "{at}");
                    let k = 10.0 * f.k; // 0.403: the decimal slip undone
                    assert!(rel(f.period(k * k)) < 2e-3, "{at}: {}", f.period(k * k));
                }
                "C.17" => {
                    assert!(rel(f.period(f.k * f.k)) > 0.3, "{at}");
                    let fixed = Printed {
                        omega: 0.7265,
                        ..*f
                    };
                    assert!(rel(fixed.period(f.k * f.k)) < 2e-3, "{at}");
                    assert!((exact.time_scale() - 0.7265).abs() < 1e-4, "{at}");
                }
                _ => assert!(
                    rel(f.period(f.k * f.k)) < 2e-3,
                    "{at}: period {} vs {period}",
                    f.period(f.k * f.k)
                ),
            }
        }
    }
}

/// Theorem 4.3.2 (Weierstrass ℘, Type I): with its printed invariants and ℘ on the bounded
/// branch with a phase, P₃ matches integration — for C.1 and for starts away from a turning
/// point.
#[test]
fn theorem_4_3_2_with_bounded_branch_and_phase() {
    for (c1, p0) in [
        (2.0, [4.0, 0.0, 1.0]),
        (2.0, [3.0, 1.0, 0.5]),
        (0.7, [1.0, -2.0, 0.3]),
        (3.0, [-2.0, 0.5, -1.0]),
    ] {
        let reference = integrate_from("Theorem 4.3.2", Type::I, [c1, 0.0, 0.0], p0, 10.0);
        let err = reference.iter().fold(0.0f64, |a, (t, p)| {
            worse(a, (theorem_4_3_2_p3(c1, p0, *t) - p[2]).abs())
        });
        println!("Theorem 4.3.2, c1 = {c1}, P(0) = {p0:?}: P3 off by {err:.2e}");
        assert!(
            err <= TOL,
            "Theorem 4.3.2 c1 = {c1} P(0) = {p0:?}: {err:.3e}"
        );
        let exact = Extremal::new(Type::I, [c1, 0.0, 0.0], p0);
        assert!(max_diff(&reference, |t| exact.p(t)) <= TOL);
    }
}

/// Types I and IIb restarted from points of their own closed-form orbit — at and 10⁻⁹ either
/// side of the turning points (the zeros of the vanishing component, found by bisection) and
/// at generic times — reproduce the orbit: P_restart(t) = P(t₁ + t) to 1e-10 on [0, 10]; for
/// Type I so does Theorem 4.3.2's corrected P₃.
#[test]
fn restarts_along_the_orbit() {
    for case in CASES.iter().filter(|c| matches!(c.ty, Type::I | Type::IIb)) {
        let orbit = Extremal::of_case(case);
        let half = 0.5 * orbit.p3_period();
        // the turning points in [0, 2·period): sign changes of P1 or P2
        let mut starts = vec![0.37 * half, 1.21 * half];
        let n = 400;
        for i in 0..n {
            let (t0, t1) = (
                4.0 * half * i as f64 / n as f64,
                4.0 * half * (i + 1) as f64 / n as f64,
            );
            for comp in 0..2 {
                let (mut lo, mut hi) = (t0, t1);
                let s = |t: f64| orbit.p(t)[comp];
                if s(lo) * s(hi) >= 0.0 {
                    continue;
                }
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if s(lo) * s(mid) <= 0.0 {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                starts.extend([lo, lo - 1e-9, lo + 1e-9]);
            }
        }
        assert!(starts.len() >= 5, "{}: no turning point found", case.figure);
        let mut worst = 0.0f64;
        for &t1 in &starts {
            let restart = Extremal::new(case.ty, case.c, orbit.p(t1));
            for k in 0..=200 {
                let t = 10.0 * k as f64 / 200.0;
                let (a, b) = (restart.p(t), orbit.p(t1 + t));
                for i in 0..3 {
                    worst = worse(worst, (a[i] - b[i]).abs());
                }
                if case.ty == Type::I {
                    let p3 = theorem_4_3_2_p3(case.c[0], orbit.p(t1), t);
                    worst = worse(worst, (p3 - b[2]).abs());
                }
            }
        }
        println!(
            "{}: {} restarts, max difference {worst:.2e}",
            case.figure,
            starts.len()
        );
        assert!(
            worst <= TOL,
            "{}: restart differs by {worst:.3e}",
            case.figure
        );
    }
}

/// Theorems 4.3.1 and 6.3.1 impose H² − K > 0 ("since c₁ is real"); extremals with H² < K
/// exist (their α, β = H ± √(H² − K) are complex, so the printed forms do not apply) and the
/// corrected forms cover them.
#[test]
fn extremals_with_h2_below_k() {
    for (ty, c, p0) in [
        (Type::I, [2.0, 0.0, 0.0], [3.0, 1.0, 0.5]),
        (Type::IIb, [1.0, 2.0, 0.0], [1.0, 1.0, 0.5]),
        (Type::IIb, [1.0, 0.5, 0.0], [0.5, 1.0, -0.5]),
    ] {
        let (h, k) = (ty.hamiltonian(c, p0), casimir(p0));
        assert!(h * h < k, "{ty:?} {p0:?}: H² = {} ≥ K = {k}", h * h);
        let reference = integrate_from("H² < K", ty, c, p0, 10.0);
        let err = max_diff(&reference, |t| Extremal::new(ty, c, p0).p(t));
        println!(
            "{ty:?} c = {c:?} P(0) = {p0:?}: H² − K = {:.4}, corrected {err:.2e}",
            h * h - k
        );
        assert!(err <= TOL, "{ty:?} {p0:?}: {err:.3e}");
    }
}

/// The listings with a defect beyond the convention and the phase: C.4 nd (P₁, P₂ exchanged),
/// C.6 (k printed 0.0403 for 0.4026), C.7 ds (denominator a for √(a² + b²)), C.17 (ω printed
/// 0.5278 for 0.7265).
const DEFECTIVE: [(&str, &str); 6] = [
    ("C.4", "nd"),
    ("C.6", "dc"),
    ("C.6", "ns"),
    ("C.7", "ds"),
    ("C.17", "sd"),
    ("C.17", "cn"),
];

/// A defective listing with the repair of `docs/so3.md` (#7–#10).
fn repaired(figure: &str, f: &Printed) -> Printed {
    match (figure, f.name) {
        ("C.4", "nd") => Printed {
            p1: f.p2,
            p2: f.p1,
            ..*f
        },
        // b/a of Theorem 6.3.1 CASE (I) from C.6's H and K
        ("C.6", _) => Printed { k: 0.4026, ..*f },
        ("C.7", "ds") => match f.p3 {
            P3Form::Mobius { n0, n1, f: jf, .. } => Printed {
                p3: P3Form::Mobius {
                    n0,
                    n1,
                    d1: 10.7522,
                    f: jf,
                },
                ..*f
            },
            P3Form::Scaled(..) => unreachable!("C.7 ds is a Möbius form"),
        },
        ("C.17", _) => Printed {
            omega: 0.7265,
            ..*f
        },
        _ => unreachable!("{figure} {} is not defective", f.name),
    }
}

/// What [`best_shift`] minimises over the span: the largest of |ΔP₃|, |Δ(P₁²)|, |Δ(P₂²)|
/// (squares, so that neither the "±" nor √ of a rounded radicand near a zero — √(10⁻³) ≈ 0.03
/// — counts), or |ΔP₃| alone.
#[derive(Clone, Copy)]
enum Metric {
    Squares,
    P3,
}

/// The best time shift t₀ for a printed listing with m = k²: the difference of
/// P_printed(t + t₀) from the integration (see [`Metric`]), minimised over t₀ (a scan of one
/// period, then a golden-section refinement).
fn best_shift(reference: &[(f64, [f64; 3])], f: &Printed) -> (f64, f64) {
    best_shift_by(reference, f, Metric::Squares)
}

fn best_shift_by(reference: &[(f64, [f64; 3])], f: &Printed, metric: Metric) -> (f64, f64) {
    let m = f.k * f.k;
    let err = |t0: f64| {
        reference.iter().fold(0.0f64, |acc, (t, p)| {
            let q = f.eval(t + t0, m);
            let d = match metric {
                Metric::Squares => (q[0] * q[0] - p[0] * p[0])
                    .abs()
                    .max((q[1] * q[1] - p[1] * p[1]).abs())
                    .max((q[2] - p[2]).abs()),
                Metric::P3 => (q[2] - p[2]).abs(),
            };
            worse(acc, d)
        })
    };
    let period = f.period(m);
    let n = 4000;
    let (mut best_t, mut best_e) = (0.0, f64::INFINITY);
    for i in 0..n {
        let t0 = period * i as f64 / n as f64;
        let e = err(t0);
        if e < best_e {
            (best_t, best_e) = (t0, e);
        }
    }
    let (mut a, mut b) = (best_t - period / n as f64, best_t + period / n as f64);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..60 {
        let (x1, x2) = (b - g * (b - a), a + g * (b - a));
        if err(x1) < err(x2) {
            b = x2;
        } else {
            a = x1;
        }
    }
    let t0 = 0.5 * (a + b);
    (t0, err(t0).min(best_e))
}

/// With m = k² *and* the right phase every listing fits to the four-decimal rounding of its
/// constants — except the six with a further defect, which stay far off whatever the phase.
/// So the convention (#1) and the phase (#2) are the whole story for the other 32.
#[test]
fn printed_forms_fit_up_to_the_phase() {
    for case in &CASES {
        let reference = integrate(case);
        for f in &case.printed {
            let (t0, e) = best_shift(&reference, f);
            let at = format!("{} {}", case.figure, f.name);
            println!("{at}: best shift t0 = {t0:.5}, max difference {e:.2e}");
            if DEFECTIVE.contains(&(case.figure, f.name)) {
                assert!(e > 0.1, "{at}: fits ({e:.3e}) though listed as defective");
                // the documented repair makes it fit
                let fixed = repaired(case.figure, f);
                let (t1, e1) = best_shift(&reference, &fixed);
                println!("{at} repaired: best shift t0 = {t1:.5}, max difference {e1:.2e}");
                assert!(e1 < 2e-2, "{at}: repaired listing still {e1:.3e} off");
            } else {
                assert!(e < 2e-2, "{at}: {e:.3e} off even with the best phase");
            }
        }
    }
}

/// How a printed constant that does not round to its exact value is wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Erratum {
    /// Off by at most 3 in the fourth decimal: computed from rounded intermediates or
    /// truncated; harmless at the listings' accuracy.
    LastDigit,
    /// Wrong; the exact value rounded to four decimals, and the row of `docs/so3.md`'s
    /// discrepancy table.
    Misprint(f64, &'static str),
}

/// Every printed constant of Appendix B that is not its exact value rounded to four decimals.
/// (figure, listing, constant, how)
const ERRATA: [(&str, &str, &str, Erratum); 28] = {
    use Erratum::*;
    [
        ("C.4", "nd", "P₁²: 1", Misprint(-2.0, "#10")),
        ("C.4", "nd", "P₁²: P₃²", Misprint(0.3333, "#10")),
        ("C.4", "nd", "P₂²: 1", Misprint(16.0, "#10")),
        ("C.4", "nd", "P₂²: P₃²", Misprint(-1.3333, "#10")),
        ("C.6", "dc, ns", "k", Misprint(0.4026, "#8")),
        ("C.6", "dc, ns", "P₁²: 1", LastDigit),
        ("C.7", "ds", "β√(a²+b²)", LastDigit),
        ("C.7", "ds", "√(a²+b²)", Misprint(10.7522, "#9")),
        ("C.8", "dc, ns", "k", Misprint(0.4430, "#14")),
        ("C.12", "nd, dn", "P₁²: 1", LastDigit),
        ("C.12", "nd, dn", "P₂²: 1", LastDigit),
        ("C.12", "dn", "A", LastDigit),
        ("C.13", "sd, cn", "k", LastDigit),
        ("C.13", "sd", "A", LastDigit),
        ("C.13", "sd, cn", "P₁²: 1", LastDigit),
        ("C.13", "sd, cn", "P₂²: 1", LastDigit),
        ("C.14", "nd, dn", "k", LastDigit),
        ("C.14", "nd, dn", "P₁²: 1", LastDigit),
        ("C.14", "nd, dn", "P₂²: 1", LastDigit),
        ("C.15", "sd, cn", "P₁²: 1", LastDigit),
        ("C.15", "sd, cn", "P₂²: 1", LastDigit),
        ("C.16", "nd, dn", "k", LastDigit),
        ("C.16", "nd, dn", "P₁²: 1", LastDigit),
        ("C.16", "nd, dn", "P₂²: 1", LastDigit),
        ("C.17", "sd, cn", "ω", Misprint(0.7265, "#7")),
        ("C.17", "sd, cn", "P₁²: 1", LastDigit),
        ("C.17", "sd, cn", "P₂²: 1", LastDigit),
        ("C.19", "sn, cd", "P₂²: 1", LastDigit),
    ]
};

fn erratum(c: &Constant) -> Option<Erratum> {
    ERRATA
        .iter()
        .find(|e| e.0 == c.figure && e.1 == c.listing && e.2 == c.name)
        .map(|e| e.3)
}

/// The row of `docs/so3.md`'s table of printed constants.
fn constant_row(c: &Constant) -> String {
    let verdict = match erratum(c) {
        None => "✓".to_string(),
        Some(Erratum::LastDigit) => format!("last digit ({:+.1e})", c.printed - c.exact),
        Some(Erratum::Misprint(_, row)) => format!("**misprint** ({row})"),
    };
    format!(
        "| {} | {} | {} | {} | {:.6} | {} |",
        c.figure, c.listing, c.name, c.printed, c.exact, verdict
    )
}

/// Every printed constant of every Appendix B listing — time scales ω, moduli k, amplitudes,
/// the Möbius coefficients α, βa, a, the coefficients of P₁² and P₂², the four-decimal ode45
/// initial values — against its exact value from c, P(0), H, K: each one rounds to it at four
/// decimals or is in [`ERRATA`] (a last-digit slip of at most 3·10⁻⁴, or a misprint whose
/// exact value is the one documented). So a new misprint, or a transcription "fixed" wrongly,
/// fails here. The rows are those of the table in `docs/so3.md`, which must list them all.
#[test]
fn printed_constants_against_exact_values() {
    let all = printed_constants();
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/so3.md"))
        .expect("docs/so3.md");
    let (mut ok, mut last, mut wrong) = (0, 0, 0);
    let (mut missing, mut unlisted) = (Vec::new(), Vec::new());
    for c in &all {
        let row = constant_row(c);
        println!("{row}");
        if !doc.contains(&row) {
            missing.push(row.clone());
        }
        let at = format!("{} {} {}", c.figure, c.listing, c.name);
        match erratum(c) {
            None => {
                if c.rounds() {
                    ok += 1;
                } else {
                    unlisted.push(format!(
                        "{at}: printed {} but exact {:.6}",
                        c.printed, c.exact
                    ));
                }
            }
            Some(Erratum::LastDigit) => {
                assert!(!c.rounds(), "{at}: listed as a last-digit slip but rounds");
                assert!(
                    (c.printed - c.exact).abs() <= 3e-4,
                    "{at}: printed {} exact {:.6}: more than a last-digit slip",
                    c.printed,
                    c.exact
                );
                last += 1;
            }
            Some(Erratum::Misprint(documented, _)) => {
                assert!(!c.rounds(), "{at}: listed as a misprint but rounds");
                assert!(
                    (c.printed - c.exact).abs() > 3e-4,
                    "{at}: a last-digit slip, not a misprint"
                );
                assert!(
                    (documented - c.exact).abs() <= 0.5e-4 + 1e-12,
                    "{at}: exact {:.6}, documented {documented}",
                    c.exact
                );
                wrong += 1;
            }
        }
    }
    // every erratum names a constant that exists
    for e in &ERRATA {
        assert!(
            all.iter()
                .any(|c| c.figure == e.0 && c.listing == e.1 && c.name == e.2),
            "ERRATA names no printed constant: {e:?}"
        );
    }
    println!(
        "{} constants: {ok} round to the exact value, {last} last-digit slips, {wrong} misprints",
        all.len()
    );
    assert!(
        unlisted.is_empty(),
        "printed constants that do not round to their exact value and are not in ERRATA:\n{}",
        unlisted.join("\n")
    );
    assert!(
        missing.is_empty(),
        "docs/so3.md lacks these rows of the table of printed constants:\n{}",
        missing.join("\n")
    );
}

/// The listings with every constant exact ([`exact_listing`]: the theorems' formulas at full
/// precision, with m = k²) fit the integration at their best phase to 1e-8 — all 38, including
/// the four with a misprinted constant — which checks the exact values the constants are
/// compared with.
#[test]
fn exact_listings_fit_the_integration() {
    for case in &CASES {
        let reference = integrate(case);
        for which in 0..2 {
            let f = exact_listing(case, which);
            let (t0, e) = best_shift(&reference, &f);
            println!(
                "{} {} exact: best shift {t0:.6}, max difference {e:.2e}",
                case.figure, f.name
            );
            assert!(
                e < 1e-8,
                "{} {}: exact listing {e:.3e} off",
                case.figure,
                f.name
            );
        }
    }
}

/// C.8's modulus: printed 0.4407, exact b/a = 0.443007. The best-phase error in P₃ of the
/// listings (m = k²) over the ode45 spans [0, 10] and [0, 30], as printed, with k = 0.4430 and
/// with every constant exact.
#[test]
fn c8_modulus() {
    let case = &CASES[figure("C.8")];
    let exact_k = exact_listing(case, 0).k;
    println!("C.8: k printed {}, exact {exact_k:.6}", case.printed[0].k);
    assert!((exact_k - 0.4430).abs() < 0.5e-4);
    for t_end in [10.0, 30.0] {
        let reference = integrate_from(case.figure, case.ty, case.c, case.p0, t_end);
        for which in 0..2 {
            let f = case.printed[which];
            let (_, printed) = best_shift_by(&reference, &f, Metric::P3);
            let (_, k4) = best_shift_by(&reference, &Printed { k: 0.4430, ..f }, Metric::P3);
            let (_, k_exact) = best_shift_by(&reference, &Printed { k: exact_k, ..f }, Metric::P3);
            let (_, all) = best_shift_by(&reference, &exact_listing(case, which), Metric::P3);
            println!(
                "C.8 {} on [0, {t_end}]: max |ΔP3| at the best phase: k = 0.4407 {printed:.2e}, \
                 k = 0.4430 {k4:.2e}, k = {exact_k:.6} {k_exact:.2e}, all constants exact {all:.2e}",
                f.name
            );
            // the misprint: 3.8e-3 on [0, 30], 3.7e-4 on [0, 10]; with k = 0.4430 what remains
            // (1.1e-4, 1.2e-4) is the four-decimal rounding of the other constants
            assert!(
                printed > 3.0 * k4,
                "C.8 {}: {printed:.3e} vs {k4:.3e}",
                f.name
            );
            assert!(k4 < 3e-4, "C.8 {}: k = 0.4430 leaves {k4:.3e}", f.name);
            assert!(all < 1e-8, "C.8 {}: exact listing {all:.3e}", f.name);
        }
    }
}
