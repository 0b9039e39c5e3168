//! Golden files: the emitted code of `golden/*.lsl` is byte-identical to `golden/*.rs`
//! (deterministic output), and that code compiles and runs (it is included below).
//! Regenerate with `UPDATE_GOLDEN=1 cargo test -p lasalle-codegen --test golden`.

use std::path::Path;

#[allow(missing_docs, dead_code)] // a test uses part of the generated API
mod pendulum_generated {
    include!("golden/pendulum.rs");
}

/// A model without parameters (E0392 if its `T` were unused) whose state and `let` names are
/// Rust keywords or names the emitted code uses (`fn`, `self`, `type`, `lit`, `T`, `_`, `x`).
#[allow(missing_docs, dead_code)]
mod hostile_generated {
    include!("golden/hostile.rs");
}

/// A matrix model with an explicit `lyapunov V` (the free rigid body of `models/`).
#[allow(missing_docs, dead_code)]
mod rigid_body_generated {
    include!("golden/rigid_body.rs");
}

/// A Hamiltonian model (the planar circular restricted three-body problem of `models/`).
#[allow(missing_docs, dead_code)]
mod cr3bp_generated {
    include!("golden/cr3bp.rs");
}

/// The loop form: the FPUT chain of `models/` at n = 6, its families kept as loops; compiled
/// here without a warning.
#[deny(warnings)]
#[allow(missing_docs, dead_code)]
mod fput_loops_generated {
    include!("golden/fput_loops.rs");
}

/// Generates `golden/<name>.lsl` and compares it with `golden/<name>.rs`.
fn assert_golden(name: &str) {
    assert_golden_with(name, lasalle_codegen::Families::Unrolled);
}

/// [`assert_golden`] with the families emitted as `families` says.
fn assert_golden_with(name: &str, families: lasalle_codegen::Families) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden");
    let text = std::fs::read_to_string(dir.join(format!("{name}.lsl"))).unwrap();
    let path = format!("golden/{name}.lsl");
    let generated = lasalle_codegen::generate_source_with(&path, &text, families).unwrap();
    let code = lasalle_codegen::Generated {
        models: vec![generated],
    }
    .module_file();
    let golden = dir.join(format!("{name}.rs"));
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&golden, &code).unwrap();
    }
    let expected = std::fs::read_to_string(&golden).unwrap();
    assert!(
        code == expected,
        "emitted code differs from {}; rerun with UPDATE_GOLDEN=1 if intended",
        golden.display()
    );
}

#[test]
fn emitted_code_matches_the_golden_file() {
    assert_golden("pendulum");
}

#[test]
fn hostile_names_and_no_parameters_match_the_golden_file() {
    assert_golden("hostile");
}

#[test]
fn a_matrix_model_with_an_explicit_v_matches_the_golden_file() {
    assert_golden("rigid_body");
}

#[test]
fn a_hamiltonian_model_matches_the_golden_file() {
    assert_golden("cr3bp");
}

#[test]
fn the_loop_form_of_a_chain_matches_the_golden_file() {
    assert_golden_with("fput_loops", lasalle_codegen::Families::Loops);
}

/// The emitted loops of the FPUT chain against its equations of motion written out here:
/// q̇ᵢ = pᵢ, ṗᵢ = F(qᵢ₊₁ − qᵢ) − F(qᵢ − qᵢ₋₁) with F(r) = r + α r² + β r³ and q₋₁ = q₆ = 0
/// (the walls), and H = Σ pᵢ²/2 + Σ V(qᵢ₊₁ − qᵢ) over the 7 springs.
#[test]
fn the_loop_form_of_the_chain_runs() {
    use fput_loops_generated::fput_loops::Fput;
    use lasalle_runtime::{Declared, Field, Invariants, Lyapunov, Partitioned};
    let model = Fput {
        params: [0.25, 0.125], // α, β
    };
    let (a, b) = (0.25, 0.125);
    let m = model.prepare();
    let x: [f64; 12] = std::array::from_fn(|k| ((k * 7 + 3) % 11) as f64 / 10.0 - 0.45);
    let mut dx = [0.0; 12];
    m.field(&x, &mut dx);
    let q = |i: isize| {
        if (0..6).contains(&i) {
            x[i as usize]
        } else {
            0.0
        }
    };
    let force = |r: f64| r + a * r * r + b * r * r * r;
    for i in 0..6 {
        assert_eq!(dx[i], x[6 + i], "q̇[{i}]");
        let j = i as isize;
        let want = force(q(j + 1) - q(j)) - force(q(j) - q(j - 1));
        assert!(
            (dx[6 + i] - want).abs() < 1e-14,
            "ṗ[{i}]: {} vs {want}",
            dx[6 + i]
        );
    }
    let v = |r: f64| r * r / 2.0 + a * r * r * r / 3.0 + b * r * r * r * r / 4.0;
    let want: f64 = x[6..].iter().map(|p| p * p / 2.0).sum::<f64>()
        + (-1..6).map(|j| v(q(j + 1) - q(j))).sum::<f64>();
    let mut f = [0.0; 1];
    m.invariants(&x, &mut f);
    assert!((f[0] - want).abs() < 1e-14, "H: {} vs {want}", f[0]);
    // ∇H = (−ṗ, p) from the same closed forms
    let grad_h: [f64; 12] = std::array::from_fn(|k| {
        if k < 6 {
            let j = k as isize;
            force(q(j) - q(j - 1)) - force(q(j + 1) - q(j))
        } else {
            x[k]
        }
    });
    let mut jac = [[f64::NAN; 12]; 1];
    m.invariants_jacobian(&x, &mut jac);
    for k in 0..12 {
        assert!(
            (jac[0][k] - grad_h[k]).abs() < 1e-14,
            "∂H/∂x[{k}]: {} vs {}",
            jac[0][k],
            grad_h[k]
        );
    }
    // V = k/2 (H − H₀)², ∇V = k (H − H₀) ∇H, X − ∇V
    let (h0, gain) = (0.3, [2.5]);
    let dh = want - h0;
    let v = m.lyapunov(&x, &[h0], &gain);
    assert!(
        (v - 1.25 * dh * dh).abs() < 1e-14,
        "V: {v} vs {}",
        1.25 * dh * dh
    );
    let (mut grad, mut fb) = ([f64::NAN; 12], [f64::NAN; 12]);
    m.lyapunov_gradient(&x, &[h0], &gain, &mut grad);
    m.feedback_field(&x, &[h0], &gain, &mut fb);
    for k in 0..12 {
        let g = 2.5 * dh * grad_h[k];
        assert!(
            (grad[k] - g).abs() < 1e-14,
            "∂V/∂x[{k}]: {} vs {g}",
            grad[k]
        );
        let want = dx[k] - g;
        assert!(
            (fb[k] - want).abs() < 1e-14,
            "(X − ∇V)[{k}]: {} vs {want}",
            fb[k]
        );
    }
    // the half-fields: q̇ = p into q's components, ṗ into p's, the others left alone
    assert_eq!(m.is_q(), &[[true; 6], [false; 6]].concat()[..]);
    assert!(m.partitioned().is_some());
    let (mut q_rate, mut p_rate) = ([7.0; 12], [7.0; 12]);
    m.field_q(&x, &mut q_rate);
    m.field_p(&x, &mut p_rate);
    for k in 0..6 {
        assert_eq!((q_rate[k], q_rate[k + 6]), (dx[k], 7.0), "q̇[{k}]");
        assert_eq!((p_rate[k], p_rate[k + 6]), (7.0, dx[k + 6]), "ṗ[{k}]");
    }
    assert_eq!(m.presets()[0].method, Some("stormer-verlet-b"));
    // parameters by name: setting α prepares again, as a model built with that α
    use lasalle_runtime::{ParamError, Parameters};
    let mut by_name = Fput::default().prepare();
    assert_eq!(by_name.param("alpha"), Some(vec![0.25]));
    assert_eq!(by_name.point_names(), &["mode1"]);
    assert_eq!(by_name.point("mode1"), Some(Fput::POINTS[0].1.to_vec()));
    by_name.set_param("beta", &[0.125]).unwrap();
    let mut again = [0.0; 12];
    by_name.field(&x, &mut again);
    assert_eq!(again, dx, "β = 0.125 set by name");
    assert_eq!(by_name.param("beta"), Some(vec![0.125]));
    assert_eq!(
        by_name.point("mode1"),
        None,
        "known at the default parameters only"
    );
    assert!(matches!(
        by_name.set_param("alpha", &[1.0, 2.0]),
        Err(ParamError::WrongLength {
            expected: 1,
            given: 2,
            ..
        })
    ));
    match by_name.set_param("gamma", &[1.0]) {
        Err(ParamError::Unknown { known, .. }) => assert_eq!(known, "`alpha`, `beta`"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_rigid_body_code_runs() {
    use lasalle_runtime::{Field, Invariants, Lyapunov};
    use rigid_body_generated::rigid_body::RigidBody;
    let m = RigidBody::<f64>::default(); // 𝕀 = diag(3, 2, 1)
    let p = m.prepare();
    let x = m.point_paper(); // R = I, Ω = (1, 1, 1)
    let mut dx = [0.0; 12];
    p.field(&x, &mut dx);
    // Ṙ = R Ω̂ = Ω̂ (column-major), Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω) = ((2 − 1)/3, (1 − 3)/2, (3 − 2)/1)
    let hat = [0.0, 1.0, -1.0, -1.0, 0.0, 1.0, 1.0, -1.0, 0.0];
    assert_eq!(dx[..9], hat);
    assert_eq!(dx[9..], [1.0 / 3.0, -1.0, 1.0]);
    // f = (RᵀR − I, E, π): 0, E = 3, π = 𝕀Ω = (3, 2, 1)
    let mut f = [0.0; 13];
    p.invariants(&x, &mut f);
    assert_eq!(f[..9], [0.0; 9]);
    assert_eq!(f[9..], [3.0, 3.0, 2.0, 1.0]);
    // On the target set V = 0 and the feedback field is the field.
    let gains = RigidBody::<f64>::default_gains();
    assert_eq!(p.lyapunov(&x, &f, &gains), 0.0);
    let mut fb = [0.0; 12];
    p.feedback_field(&x, &f, &gains, &mut fb);
    assert_eq!(fb, dx);
    // Off it, V = k₁/2 (E − E₀)² for a shifted energy target.
    let mut target = f;
    target[9] -= 0.5;
    assert!((p.lyapunov(&x, &target, &gains) - 100.0 / 2.0 * 0.25).abs() < 1e-12);
    // The state views, without turbofish.
    assert_eq!(RigidBody::<f64>::r(&x)[(1, 1)], 1.0);
    assert_eq!(RigidBody::<f64>::omega(&x)[2], 1.0);
}

#[test]
fn the_cr3bp_code_runs() {
    use cr3bp_generated::cr3bp::CR3BP;
    use lasalle_runtime::{Field, Invariants};
    let m = CR3BP::<f64>::default();
    let mu = m.mu;
    let s = [0.3, 0.7, -0.4, 0.2];
    let [q0, q1, p0, p1] = s;
    let mut ds = [0.0; 4];
    let m = m.prepare();
    m.field(&s, &mut ds);
    // q̇ = ∂H/∂p, ṗ = −∂H/∂q for H = |p|²/2 + q₁p₀ − q₀p₁ − (1 − μ)/r₁ − μ/r₂
    let r1 = ((q0 + mu).powi(2) + q1 * q1).sqrt();
    let r2 = ((q0 - 1.0 + mu).powi(2) + q1 * q1).sqrt();
    let want = [
        p0 + q1,
        p1 - q0,
        p1 - (1.0 - mu) * (q0 + mu) / r1.powi(3) - mu * (q0 - 1.0 + mu) / r2.powi(3),
        -p0 - (1.0 - mu) * q1 / r1.powi(3) - mu * q1 / r2.powi(3),
    ];
    for (got, want) in ds.iter().zip(want) {
        assert!((got - want).abs() < 1e-14, "{ds:?} vs {want}");
    }
    // The Jacobi integral at the state
    let mut h = [0.0];
    m.invariants(&s, &mut h);
    let jacobi = (p0 * p0 + p1 * p1) / 2.0 + q1 * p0 - q0 * p1 - (1.0 - mu) / r1 - mu / r2;
    assert!((h[0] - jacobi).abs() < 1e-14);
}

#[test]
fn the_golden_code_runs() {
    use lasalle_runtime::{Field, Invariants, Lyapunov};
    use pendulum_generated::pendulum::Pendulum;
    let m = Pendulum::<f64>::default().prepare();
    let x = [0.5, -0.25];
    let mut dx = [0.0; 2];
    m.field(&x, &mut dx);
    assert_eq!(dx, [-0.25, -9.81 * 0.5f64.sin()]);
    let mut f = [0.0; 1];
    m.invariants(&x, &mut f);
    assert_eq!(f[0], 0.03125 - 9.81 * 0.5f64.cos());
    // V = k/2 (E − E0)², ∇V = k (E − E0) ∇E
    let target = [f[0] - 0.1];
    let mut grad = [0.0; 2];
    m.lyapunov_gradient(&x, &target, &[2.0], &mut grad);
    let want = [2.0 * 0.1 * 9.81 * 0.5f64.sin(), 2.0 * 0.1 * -0.25];
    assert!(
        (grad[0] - want[0]).abs() < 1e-14 && (grad[1] - want[1]).abs() < 1e-14,
        "{grad:?}"
    );
    assert_eq!(m.point_rest(), [0.0, 0.0]);
}

#[test]
fn the_prepared_model_reads_its_parameters_and_follows_set_param() {
    use lasalle_runtime::{Field, Parameters};
    use pendulum_generated::pendulum::Pendulum;
    let m = Pendulum::<f64> {
        l: 2.0,
        ..Default::default()
    };
    let mut p = m.prepare();
    let x = [0.5, -0.25];
    let mut a = [0.0; 2];
    p.field(&x, &mut a);
    assert_eq!(a[1], -(9.81 / 2.0) * 0.5f64.sin());
    assert_eq!(p.l, 2.0); // the parameters, through Deref
                          // set_param prepares again: the prepared −g/l follows l
    p.set_param("l", &[4.0]).unwrap();
    p.field(&x, &mut a);
    assert_eq!(a[1], -(9.81 / 4.0) * 0.5f64.sin());
    assert_eq!(p.param("l"), Some(vec![4.0]));
    assert!(p.set_param("l", &[1.0, 2.0]).is_err());
    assert_eq!(
        p.l, 4.0,
        "a rejected value leaves the parameters as they were"
    );
}

#[test]
fn the_hostile_code_runs() {
    use hostile_generated::hostile::Hostile;
    use lasalle_runtime::{Field, Invariants, Parameters};
    let m = Hostile::<f64>::default().prepare();
    // state: fn, self, type[0], type[1], x, x_mut
    let s = [0.5, -0.25, 2.0, 3.0, 0.75, 1.5];
    let mut dx = [0.0; 6];
    m.field(&s, &mut dx);
    let t = 1.0 + (2.0f64 * 0.75).powi(2); // T = 1 + lit², lit = type[0]·x
    assert_eq!(dx, [-0.25 * t, -0.5 * t, 3.0, -2.0, 1.5, -0.75]);
    let mut f = [0.0; 2];
    m.invariants(&s, &mut f);
    assert_eq!(f, [0.3125, 13.0]);
    assert_eq!(Hostile::<f64>::type_(&s)[1], 3.0);
    assert_eq!(Hostile::<f64>::x_mut_2(&s), 1.5);
    assert_eq!(m.point("start"), Some(vec![1.0, 0.0, 1.0, 0.0, 0.0, 1.0]));
    assert_eq!(m.param("anything"), None);
}
