//! The failure modes: resonances (Assumption 1′), a non-elliptic equilibrium, bad input.

mod common;

use lasalle_normal_form::{normalize, NormalFormError, Options, Point};

fn run(
    mu: f64,
    order: usize,
    resonant: bool,
) -> Result<lasalle_normal_form::NormalForm, NormalFormError> {
    let opts = Options::with_order(order)
        .resonant(resonant)
        .error_estimate(false);
    common::l4_normal_form(mu, &opts)
}

#[test]
fn resonance_1_2_stops_at_order_3() {
    let e = run(0.0242939, 3, false).unwrap_err();
    match &e {
        NormalFormError::Resonance {
            m,
            m_dot_omega,
            order,
            ..
        } => {
            assert_eq!(m, &vec![1, -2]);
            assert_eq!(*order, 3);
            assert!(m_dot_omega.abs() < 1e-6);
        }
        other => panic!("expected a resonance, got {other}"),
    }
    let msg = e.to_string();
    assert!(
        msg.contains("m = (1, -2)") && msg.contains("order 3"),
        "{msg}"
    );
    // order 2 (linear normal form only) is fine
    assert!(run(0.0242939, 2, false).is_ok());
}

#[test]
fn resonance_1_3_stops_at_order_4() {
    assert!(run(0.0135160, 3, false).is_ok());
    match run(0.0135160, 4, false).unwrap_err() {
        NormalFormError::Resonance { m, order, .. } => {
            assert_eq!(m, vec![1, -3]);
            assert_eq!(order, 4);
        }
        other => panic!("expected a resonance, got {other}"),
    }
}

#[test]
fn resonant_mode_keeps_the_resonant_terms() {
    let nf = run(0.0242939, 6, true).expect("resonant normal form");
    assert!(!nf.resonant_terms.is_empty());
    // x1 y2² or y1 x2² type terms (m = ±(1, −2) in the positive-frequency convention)
    assert!(nf.resonant_terms.iter().all(|t| {
        let m: Vec<i32> = (0..2).map(|k| t.x[k] as i32 - t.y[k] as i32).collect();
        let m = [m[0] * nf.signs[0] as i32, m[1] * nf.signs[1] as i32];
        (m[0] * 2 + m[1]) == 0 || (m == [0, 0])
    }));
    assert!(nf
        .small_divisors
        .iter()
        .any(|d| d.resonant && d.m == vec![1, -2]));
    assert!(nf.flow(&common::l4(0.0242939), 1.0).is_none());
}

#[test]
fn beyond_routh_is_not_elliptic() {
    let e = run(0.05, 6, false).unwrap_err();
    match &e {
        NormalFormError::NotElliptic { eigenvalues, .. } => {
            assert_eq!(eigenvalues.len(), 4);
            assert!(eigenvalues
                .iter()
                .all(|l| l.re.abs() > 1e-3 && l.im.abs() > 1e-3));
        }
        other => panic!("expected not elliptic, got {other}"),
    }
    assert!(
        e.to_string()
            .starts_with("equilibrium is not elliptic: eigenvalues"),
        "{e}"
    );
}

#[test]
fn a_point_that_is_not_an_equilibrium() {
    let h = common::cr3bp(0.01);
    let e = normalize(
        &h,
        &Point::Given(vec![0.5, 0.8, -0.8, 0.5]),
        &Options::with_order(4),
    )
    .unwrap_err();
    assert!(matches!(e, NormalFormError::NotAnEquilibrium { .. }), "{e}");
    // the same point as a Newton start converges to L4
    let nf = normalize(
        &h,
        &Point::Newton(vec![0.5, 0.8, -0.8, 0.5]),
        &Options::with_order(4),
    )
    .unwrap();
    let l4 = common::l4(0.01);
    assert!(nf
        .equilibrium
        .iter()
        .zip(&l4)
        .all(|(a, b)| (a.value - b).abs() < 1e-14));
    assert!(matches!(
        normalize(&h, &Point::Newton(l4.to_vec()), &Options::with_order(1)),
        Err(NormalFormError::Invalid(_))
    ));
}

/// A Hamiltonian that calls an elliptic function is refused before any series is formed
/// (jets have no elliptic functions).
#[test]
fn elliptic_functions_are_refused() {
    let text = "model Ell { state q: scalar, p: scalar; param m = 0.5;
        hamiltonian H = p^2/2 + q^2/2 + sn(q, m)^4; structure canonical(q, p); }";
    let model = lasalle_model::lower_source("ell.lsl", text).unwrap();
    let e = lasalle_normal_form::ModelHamiltonian::new(&model, &[])
        .err()
        .expect("refused");
    assert!(
        matches!(&e, NormalFormError::Model(m) if m.contains("elliptic functions")),
        "{e}"
    );
}

/// A model file that does not load keeps the generator's typed, located diagnostics: the
/// same message as `lasalle_model::load_model` (file:line:col, the line, a caret, a help),
/// and its `DiagnosticKind`.
#[test]
fn model_files_that_do_not_load_keep_their_diagnostics() {
    let dir = std::env::temp_dir().join(format!("lasalle-nf-load-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.lsl");
    std::fs::write(
        &path,
        "model Bad { state q: scalar, p: scalar;\n    hamiltonian H = p^2/2 + w*q^2/2;\n    structure canonical(q, p); }\n",
    )
    .unwrap();
    let e = lasalle_normal_form::normalize_model_file(
        &path,
        &[],
        &lasalle_normal_form::ModelPoint::Auto,
        &Options::with_order(4),
    )
    .unwrap_err();
    let direct = lasalle_model::load_model(&path)
        .err()
        .expect("does not load");
    assert_eq!(e.to_string(), direct.to_string());
    assert!(e.to_string().contains("bad.lsl:2:"), "{e}");
    let NormalFormError::Load(load) = &e else {
        panic!("not a load error: {e:?}")
    };
    let lasalle_model::Error::Model(diagnostics) = &*load.0 else {
        panic!("not a model diagnostic: {:?}", load.0)
    };
    assert_eq!(
        diagnostics[0].kind,
        lasalle_model::DiagnosticKind::UnknownName
    );
}

fn model_normal_form(text: &str) -> Result<lasalle_normal_form::NormalForm, NormalFormError> {
    let model = lasalle_model::lower_source("degenerate.lsl", text).unwrap();
    lasalle_normal_form::normalize_model(
        &model,
        &[],
        &lasalle_normal_form::ModelPoint::Auto,
        &Options::with_order(4),
    )
}

/// Coupled quartic oscillators have no quadratic potential: zero frequencies, named as a
/// degeneracy (not as a resonance m = (0, 1) of a frequency 1e-9).
#[test]
fn zero_frequencies_are_a_degenerate_equilibrium() {
    let e = model_normal_form(
        "model Quartic { state q: vec2, p: vec2;
            hamiltonian H = (p[0]^2 + p[1]^2)/2 + (q[0]^4 + q[1]^4)/4 + q[0]^2*q[1]^2/2;
            structure canonical(q, p); point start { q = [0.1, 0.05]; p = [0, 0]; } }",
    )
    .unwrap_err();
    let NormalFormError::Degenerate { directions, .. } = &e else {
        panic!("expected a degenerate equilibrium, got {e}");
    };
    // the whole q-plane, and no symmetry
    assert_eq!(directions.len(), 2, "{e}");
    assert!(directions
        .iter()
        .all(|d| !d.symmetry && d.direction[2..] == [0.0, 0.0]));
    let msg = e.to_string();
    assert!(
        msg.contains("H₂ vanishes") && msg.contains("zero frequencies"),
        "{msg}"
    );
    assert!(!msg.contains("resonance"), "{msg}");
}

/// The Toda lattice's Hessian is singular along the translation q → q + t(1, 1, 1): the
/// equilibrium is found at once (∇H = 0 there) and the degeneracy names its symmetry and the
/// conserved momentum, instead of a Newton failure "at |∇H| = 0".
#[test]
fn a_translation_symmetry_is_named_with_its_momentum() {
    let e = model_normal_form(
        "model Toda { state q: vec3, p: vec3;
            hamiltonian H = (p[0]^2 + p[1]^2 + p[2]^2)/2 + exp(q[0] - q[1]) + exp(q[1] - q[2])
                + exp(q[2] - q[0]) - 3;
            structure canonical(q, p); point start { q = [0, 0, 0]; p = [0, 0, 0]; } }",
    )
    .unwrap_err();
    let NormalFormError::Degenerate { directions, .. } = &e else {
        panic!("expected a degenerate equilibrium, got {e}");
    };
    assert_eq!(directions.len(), 1, "{e}");
    let d = &directions[0];
    assert!(d.symmetry, "{e}");
    let third = 1.0 / 3f64.sqrt();
    assert!(
        d.direction[..3]
            .iter()
            .all(|c| (c.abs() - third).abs() < 1e-12),
        "{e}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("conserved momentum (0.577 p[0] + 0.577 p[1] + 0.577 p[2])"),
        "{msg}"
    );
    assert!(!msg.contains("newton"), "{msg}");
}
