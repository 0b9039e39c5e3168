//! Closed forms in Jacobi elliptic functions written as model expressions: the pendulum of
//! `models/pendulum_closed_form.lsl` (generated code) and Euler's top of docs/so3.md (loaded
//! from the docs' text), against integration, identities and finite differences.

use lasalle::elliptic::{ellipf, ellipj, ellipk};
use lasalle::models::pendulum_closed_form::PendulumClosedForm;
use lasalle::models::so3_type_iii::So3TypeIii;
use lasalle::{
    integrate, Backend, Control, DormandPrince, DormandPrinceOptions, Driver, Field, Invariants,
    LoadedModel, Parameters,
};

fn tight() -> DormandPrinceOptions<f64> {
    DormandPrinceOptions {
        rtol: 1e-13,
        atol: 1e-13,
        ..Default::default()
    }
}

/// θ(t) = 2 asin(k sn(t | k²)) solves θ'' = −sin θ: the model's θ and ω = θ' integrated from
/// `bottom` match the closed form and the integrated pendulum, and its ω' is −sin θ there.
#[test]
fn pendulum_closed_form_solves_the_pendulum() {
    let sys = PendulumClosedForm::<f64>::default().prepare();
    let k = sys.k;
    let m = k * k;
    let x0 = sys.point_bottom();
    let pendulum = LoadedModel::from_source(
        "pendulum.lsl",
        "model Pendulum { state theta: scalar, omega: scalar;
           d/dt theta = omega; d/dt omega = -sin(theta);
           integral E = omega^2/2 - cos(theta); }",
        Backend::Interpreter,
    )
    .unwrap();
    let mut worst = [0.0f64; 3];
    for i in 1..=40 {
        let t = 0.5 * i as f64;
        let end = integrate(
            &mut DormandPrince::new(tight()),
            &sys,
            &x0,
            0.0,
            t,
            0.0,
            &mut (),
        )
        .unwrap();
        let x = end.x;
        let j = ellipj(t, m);
        let theta = 2.0 * (k * j.sn).asin();
        worst[0] = worst[0]
            .max((x[1] - theta).abs())
            .max((x[2] - 2.0 * k * j.cn).abs());
        // the identity: the model's θ'' = ω' equals −sin θ on the closed form
        let mut dx = [0.0; 6];
        sys.field(&[t, theta, 2.0 * k * j.cn, 0.0, 0.0, 0.0], &mut dx);
        worst[1] = worst[1].max((dx[2] + theta.sin()).abs());
        // …and the pendulum integrated from θ = 0, ω = 2k
        let p = integrate(
            &mut DormandPrince::new(tight()),
            &pendulum,
            &vec![0.0, 2.0 * k],
            0.0,
            t,
            0.0,
            &mut (),
        )
        .unwrap();
        worst[2] = worst[2].max((p.x[0] - x[1]).abs());
    }
    println!(
        "pendulum: model vs closed form {:.1e}, ω' + sin θ {:.1e}, model vs pendulum {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(
        worst[0] < 1e-10 && worst[1] < 1e-14 && worst[2] < 1e-10,
        "{worst:?}"
    );
}

/// The generated invariants' Jacobian (∂/∂t of cn, F, sd, …) against central differences,
/// and the invariants' values at the closed form.
#[test]
fn pendulum_closed_form_derivatives() {
    let sys = PendulumClosedForm::<f64>::default().prepare();
    let m = sys.k * sys.k;
    for (i, &t) in [0.3, -1.1, 1.4, 2.9].iter().enumerate() {
        let x = [t, 0.2 * i as f64, -0.4, 0.7, 0.1, -0.2];
        let mut jac = [[0.0; 6]; 4];
        sys.invariants_jacobian(&x, &mut jac);
        let f = |x: &[f64; 6]| {
            let mut f = [0.0; 4];
            sys.invariants(x, &mut f);
            f
        };
        for c in 0..6 {
            let h = 1e-5;
            let (mut xp, mut xm) = (x, x);
            xp[c] += h;
            xm[c] -= h;
            let (fp, fm) = (f(&xp), f(&xm));
            for r in 0..4 {
                let fd = (fp[r] - fm[r]) / (2.0 * h);
                assert!(
                    (jac[r][c] - fd).abs() < 1e-8 * (1.0 + fd.abs()),
                    "∂f{r}/∂x{c} at t = {t}: {} vs {fd}",
                    jac[r][c]
                );
            }
        }
        // ∂W/∂t = 2k sn dn, by the derivative rule cn' = −sn dn
        let j = ellipj(t, m);
        assert!((jac[0][0] - 2.0 * sys.k * j.sn * j.dn).abs() < 1e-15);
        // the invariants vanish on the closed form
        let on = [
            t,
            0.0,
            2.0 * sys.k * j.cn,
            ellipf(t, m),
            j.sn / j.dn,
            t / ellipk(m),
        ];
        assert!(f(&on).iter().all(|v| v.abs() < 1e-15), "{:?}", f(&on));
    }
}

/// The model text of docs/so3.md's "A closed form as a model expression".
fn euler_top_text() -> String {
    let doc = include_str!("../docs/so3.md");
    let start = doc
        .find("```lsl\nmodel EulerTopClosedForm")
        .expect("the model in docs/so3.md")
        + 7;
    let end = start + doc[start..].find("```").expect("closed");
    doc[start..end].to_string()
}

/// Euler's top (Type III, c = (1, 2, 3), P(0) = (½, 0, 2)) in closed form as a model: its
/// `closed_form` integral is proved by the generator, and evaluated along the integrated
/// extremal of `models/so3_type_iii.lsl` it stays at rounding level.
#[test]
fn euler_top_closed_form_matches_the_extremal() {
    let cf = LoadedModel::from_source("euler_top.lsl", &euler_top_text(), Backend::Jit)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(cf.conservation()[0].name, "closed_form");
    assert!(
        matches!(
            cf.conservation()[0].verdict,
            lasalle_codegen::Verdict::Proved
        ),
        "{:?}",
        cf.conservation()[0].verdict
    );
    let sys = So3TypeIii::<f64> {
        c1: 1.0,
        c2: 2.0,
        c3: 3.0,
    }
    .prepare();
    let mut x0 = [0.0; 12];
    x0[..3].copy_from_slice(&[0.5, 0.0, 2.0]);
    x0[3] = 1.0;
    x0[7] = 1.0;
    x0[11] = 1.0;
    let times: Vec<f64> = (0..=300).map(|i| 0.1 * i as f64).collect();
    let mut worst = 0.0f64;
    let mut observer = |_: u64, t: f64, x: &[f64; 12]| {
        let mut f = vec![0.0; 3];
        cf.invariants(&vec![t, x[0], x[1], x[2]], &mut f);
        worst = f.iter().fold(worst, |w, v| w.max(v.abs()));
        Control::Continue
    };
    Driver::new(0.0, 30.0, 0.0)
        .run_dense(
            &mut DormandPrince::<f64, [f64; 12]>::new(tight()),
            &sys,
            &x0,
            &times,
            &mut observer,
        )
        .unwrap();
    println!("Euler top: |P(t) − closed form| ≤ {worst:.1e} on [0, 30]");
    assert!(worst < 1e-10, "{worst:e}");
    // the model's own start point is P(0)
    assert_eq!(cf.point("start").unwrap(), vec![0.0, 0.5, 0.0, 2.0]);
}
