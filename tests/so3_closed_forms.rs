//! The thesis' closed-form extremals (Rodgerson 2009, Theorems 4.3.1–7.3.1, Appendix B) against
//! integration: for each of the 19 Appendix B cases, DOPRI5 at rtol = atol = 1e-13 with dense
//! output at 501 times over the case's ode45 span, compared with
//! - the corrected closed form [`Extremal`] (must agree to 1e-10), and
//! - the printed closed forms (Appendix B's MATLAB, transcribed in [`CASES`]), which must be
//!   far off where `docs/so3.md` says the thesis is wrong.
//!
//! Run with `--nocapture` to see the table of `docs/so3.md`.

use lasalle::closed_forms::{casimir, Case, Extremal, Printed, Type, CASES};
use lasalle::models::{
    so3_type_i::So3TypeI, so3_type_iia::So3TypeIia, so3_type_iib::So3TypeIib,
    so3_type_iii::So3TypeIii,
};
use lasalle::{Control, DormandPrince, DormandPrinceOptions, Driver};

const OUTPUTS: usize = 501;
const TOL: f64 = 1e-10;

/// Integrates the extremal of `case` (with g(0) = I) and returns P at `OUTPUTS` equally spaced
/// times on [0, t_end].
fn integrate(case: &Case) -> Vec<(f64, [f64; 3])> {
    let times: Vec<f64> = (0..OUTPUTS)
        .map(|i| case.t_end * i as f64 / (OUTPUTS - 1) as f64)
        .collect();
    let mut x0 = [0.0; 12];
    x0[..3].copy_from_slice(&case.p0);
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
    let driver = Driver::new(0.0, case.t_end, 0.0).max_steps(10_000_000);
    let [c1, c2, c3] = case.c;
    let res = match case.ty {
        Type::I => {
            let m = So3TypeI::<f64> {
                c1,
                ..Default::default()
            };
            driver.run_dense(&mut dp, &m, &x0, &times, &mut observer)
        }
        Type::IIa => {
            let m = So3TypeIia::<f64> {
                c1,
                c2,
                ..Default::default()
            };
            driver.run_dense(&mut dp, &m, &x0, &times, &mut observer)
        }
        Type::IIb => {
            let m = So3TypeIib::<f64> {
                c1,
                c2,
                ..Default::default()
            };
            driver.run_dense(&mut dp, &m, &x0, &times, &mut observer)
        }
        Type::III => {
            let m = So3TypeIii::<f64> {
                c1,
                c2,
                c3,
                ..Default::default()
            };
            driver.run_dense(&mut dp, &m, &x0, &times, &mut observer)
        }
    };
    res.unwrap_or_else(|e| panic!("{}: {e}", case.figure));
    assert_eq!(
        out.len(),
        OUTPUTS,
        "{}: dense output incomplete",
        case.figure
    );
    out
}

fn max_diff(reference: &[(f64, [f64; 3])], f: impl Fn(f64) -> [f64; 3]) -> f64 {
    reference.iter().fold(0.0f64, |acc, (t, p)| {
        let q = f(*t);
        (0..3).fold(acc, |a, i| a.max((q[i] - p[i]).abs()))
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
        acc.max(if d.is_nan() { f64::INFINITY } else { d })
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
        "{:5} {:4} corrected {:.2e} | P3 period {:.6}",
        case.figure,
        format!("{:?}", case.ty),
        err,
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
