//! Lagrange multipliers across coordinate systems (NASA TM X-53478, fourth paper: transforming
//! state variables and Lagrange multipliers between coordinate systems): the paper's
//! identities between the plumb-line and spherical flight-path frames along an integrated
//! thrusting extremal, the transformed Euler–Lagrange equations against the spherical ones at
//! random points, the paper's printed partials, a second coordinate change (planar polar
//! coordinates), and the singular points' errors.

use lasalle_analysis::multipliers::flight_path::{
    self, example, printed_partials, sample_points, spherical, Check,
};
use lasalle_analysis::multipliers::{CoordinateChange, EulerLagrange, MultiplierError};
use lasalle_model::ir::{Func, Graph, Id, Input, Rational};

const TOL: f64 = 1e-12;

#[test]
fn the_paper_identities_hold_along_an_integrated_extremal() {
    let (e, y0, s0, _) = example();
    let path = e.integrate(&y0, &s0, 600.0).unwrap();
    assert!(path.len() > 100, "{} steps", path.len());
    let check = Check::new();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (t, y, s) in &path {
        let r = check.at(&e, *t, y, s).unwrap();
        for (name, v) in [
            ("|σ_V|² = λ_v² + λ_γ²/v² + λ_δ²/(v²cos²γ)", r.norm),
            ("tan α = λ_γ/(vλ_v)", r.tan_alpha),
            ("tan β = λ_δ/(vλ_v cos γ)", r.tan_beta),
            ("|a| = T/M", r.thrust),
            ("transformed ẋ = printed ẋ", r.state),
            ("transformed λ̇ = −∂(λ·f)/∂x", r.adjoint),
        ] {
            assert!(v <= TOL, "t = {t}: {name}: residual {v:e}");
        }
        lo = lo.min(r.tans.0);
        hi = hi.max(r.tans.0);
    }
    // the extremal thrusts (the speed changes by more than 1 km/s) and the steering turns
    let x_end = spherical(&path.last().unwrap().1);
    assert!((x_end[3] - 7.9).abs() > 1.0, "v = {}", x_end[3]);
    assert!(hi - lo > 0.1, "tan α in [{lo}, {hi}]");
}

#[test]
fn the_printed_partials_carry_the_multipliers_back_only_with_delta_l_corrected() {
    // σ_V = Pᵀ(λ_v, λ_γ, λ_δ) with P the paper's ∂(v, γ, δ)/∂(l, m, n) (the paper's inverse
    // multiplier transformation), along the extremal: exact with δ_l's sign corrected, off by
    // far more than rounding with it as printed
    let (e, y0, s0, _) = example();
    let path = e.integrate(&y0, &s0, 600.0).unwrap();
    let change = flight_path::change();
    let mut worst_printed = 0.0f64;
    for (_, y, s) in path.iter().step_by(5) {
        let x = spherical(y);
        let l = change.multipliers(&x, s).unwrap();
        let mut p = printed_partials(&x);
        let back = |p: &[[f64; 3]; 3], c: usize| l[3] * p[0][c] + l[4] * p[1][c] + l[5] * p[2][c];
        let printed: Vec<f64> = (0..3).map(|c| back(&p, c)).collect();
        p[2][0] = -p[2][0];
        let norm = (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]).sqrt();
        for c in 0..3 {
            let fixed = back(&p, c);
            assert!(
                (fixed - s[3 + c]).abs() <= TOL * norm,
                "σ_{c}: {fixed} {}",
                s[3 + c]
            );
        }
        worst_printed = worst_printed.max((printed[0] - s[3]).abs() / norm);
    }
    assert!(worst_printed > 1e-2, "{worst_printed}");
}

#[test]
fn the_transformed_equations_are_the_spherical_ones_at_random_points() {
    let check = Check::new();
    for (x, l) in sample_points(500, 0x9E37_79B9_7F4A_7C15) {
        let r = check.transformed_at(398_600.441_8, 0.02, &x, &l).unwrap();
        assert!(r <= TOL, "x = {x:?}, λ = {l:?}: {r:e}");
    }
}

#[test]
fn the_plumb_line_adjoint_by_the_ir_is_the_printed_one() {
    let (e, y0, s0, _) = example();
    let path = e.integrate(&y0, &s0, 100.0).unwrap();
    let check = Check::new();
    for (t, y, s) in path.iter().step_by(7) {
        let r = check.plumb_line_adjoint(&e, *t, y, s);
        assert!(r <= TOL, "t = {t}: {r:e}");
    }
}

#[test]
fn the_hamiltonian_is_the_same_in_both_frames() {
    // λ·ẋ = σ·ẏ: the change is a cotangent lift
    let change = flight_path::change();
    let plumb = flight_path::plumb_line_equations();
    for (x, l) in sample_points(100, 7) {
        let sigma = change.multipliers_inverse(&x, &l).unwrap();
        let (yd, _) = plumb.eval(&change.apply(&x).unwrap(), &sigma, &[398_600.441_8, 0.02]);
        let xd = change.state_rates(&x, &yd).unwrap();
        let hx: f64 = l.iter().zip(&xd).map(|(a, b)| a * b).sum();
        let hy: f64 = sigma.iter().zip(&yd).map(|(a, b)| a * b).sum();
        let scale: f64 = sigma.iter().zip(&yd).map(|(a, b)| (a * b).abs()).sum();
        assert!((hx - hy).abs() <= TOL * scale, "{hx} {hy}");
    }
}

#[test]
fn the_ir_jacobian_matches_central_differences_and_the_inverse_round_trips() {
    let change = flight_path::change();
    for (x, _) in sample_points(50, 11) {
        let j = change.jacobian(&x).unwrap();
        for i in 0..6 {
            let h = 1e-6 * x[i].abs().max(1.0);
            let (mut xp, mut xm) = (x, x);
            xp[i] += h;
            xm[i] -= h;
            let (yp, ym) = (change.apply(&xp).unwrap(), change.apply(&xm).unwrap());
            for k in 0..6 {
                let fd = (yp[k] - ym[k]) / (2.0 * h);
                let s = j.column(i).amax().max(1e-3);
                assert!(
                    (fd - j[(k, i)]).abs() <= 1e-7 * s,
                    "∂y{k}/∂x{i}: {fd} {}",
                    j[(k, i)]
                );
            }
        }
        let y = change.apply(&x).unwrap();
        let back = spherical(&y);
        let two_pi = 2.0 * std::f64::consts::PI;
        for i in 0..6 {
            let mut d = back[i] - x[i];
            if i == 2 || i == 5 {
                d -= two_pi * (d / two_pi).round();
            }
            assert!(
                d.abs() <= 1e-12 * x[i].abs().max(1.0),
                "coordinate {i}: {} {}",
                back[i],
                x[i]
            );
        }
    }
}

#[test]
fn the_inverse_jacobian_is_the_printed_partials_but_for_the_sign_of_delta_l() {
    // the paper's v_l … δ_n; its δ_l carries a sign its δ_m, δ_n and the identities refute
    let change = flight_path::change();
    for (x, _) in sample_points(50, 3) {
        let inv = change.jacobian(&x).unwrap().try_inverse().unwrap();
        let p = printed_partials(&x);
        for a in 0..3 {
            for b in 0..3 {
                let derived = inv[(3 + a, 3 + b)];
                let printed = if (a, b) == (2, 0) { -p[a][b] } else { p[a][b] };
                assert!(
                    (derived - printed).abs() <= 1e-12 * (1.0 + printed.abs()),
                    "row {a} column {b}: {derived} {printed}"
                );
            }
        }
        assert!((inv[(5, 3)] - p[2][0]).abs() > 1e-6 || p[2][0].abs() < 1e-6);
    }
}

fn singular(change: &CoordinateChange, x: [f64; 6]) -> (String, Vec<(String, f64)>) {
    match change.check(&x) {
        Err(e @ MultiplierError::Singular { .. }) => {
            let msg = e.to_string();
            match e {
                MultiplierError::Singular { factors, .. } => (msg, factors),
                _ => unreachable!(),
            }
        }
        other => panic!("{x:?}: expected a singular point, got {other:?}"),
    }
}

#[test]
fn singular_points_are_refused_naming_the_point_and_the_vanishing_factor() {
    let change = flight_path::change();
    let half_pi = std::f64::consts::FRAC_PI_2;
    for (x, factor) in [
        ([7000.0, 0.1, 0.2, 7.0, half_pi, 0.3], "cos(γ)"),
        ([7000.0, 0.1, 0.2, 0.0, 0.2, 0.3], "v"),
        ([7000.0, half_pi, 0.2, 7.0, 0.2, 0.3], "cos(φ)"),
        ([0.0, 0.1, 0.2, 7.0, 0.2, 0.3], "r"),
    ] {
        let (msg, factors) = singular(&change, x);
        assert_eq!(
            factors.iter().map(|f| f.0.as_str()).collect::<Vec<_>>(),
            vec![factor],
            "{msg}"
        );
        assert!(msg.contains(&format!("{factor} = ")), "{msg}");
        assert!(msg.contains("r = ") && msg.contains("δ = 0.3"), "{msg}");
        // every inverse operation refuses the point; λ = Jᵀσ itself is defined
        let l = [1.0; 6];
        assert!(matches!(
            change.multipliers_inverse(&x, &l),
            Err(MultiplierError::Singular { .. })
        ));
        assert!(matches!(
            change.state_rates(&x, &l),
            Err(MultiplierError::Singular { .. })
        ));
        assert!(change.multipliers(&x, &l).is_ok());
    }
    // near, not at, the singular set the change is regular
    assert!(change
        .check(&[7000.0, 0.1, 0.2, 7.0, half_pi - 1e-6, 0.3])
        .is_ok());
}

#[test]
fn malformed_changes_and_points_are_refused() {
    let mut g = Graph::new();
    let x = g.input(Input::State(0));
    let p = g.input(Input::Param(0));
    let e = g.mul(&[x, p]);
    let err = CoordinateChange::new(g.clone(), &["a"], &["b"], vec![e])
        .err()
        .unwrap();
    assert!(
        err.to_string().contains("reads an input other than"),
        "{err}"
    );
    let err = CoordinateChange::new(g, &["a", "c"], &["b"], vec![x])
        .err()
        .unwrap();
    assert!(matches!(err, MultiplierError::Shape(_)), "{err}");
    let change = flight_path::change();
    assert!(matches!(
        change.apply(&[1.0; 5]),
        Err(MultiplierError::Shape(_))
    ));
    assert!(matches!(
        change.check(&[f64::NAN; 6]),
        Err(MultiplierError::Shape(_))
    ));
}

/// Planar polar coordinates (r, ϑ, ṙ, ϑ̇) ↦ (x, y, u, w) on a Kepler coast (μ = 1): the
/// Cartesian Euler–Lagrange equations transformed against the polar ones derived from
/// r̈ = rϑ̇² − 1/r², ϑ̈ = −2ṙϑ̇/r.
#[test]
fn a_second_change_polar_coordinates_transforms_the_kepler_adjoint() {
    let mut g = Graph::new();
    let s: Vec<Id> = (0..4).map(|i| g.input(Input::State(i))).collect();
    let (c, sn) = (g.func(Func::Cos, s[1]), g.func(Func::Sin, s[1]));
    let h = {
        let x = g.mul(&[s[0], c]);
        let y = g.mul(&[s[0], sn]);
        let a = g.mul(&[s[2], c]);
        let b = g.mul(&[s[0], s[3], sn]);
        let u = g.sub(a, b);
        let a = g.mul(&[s[2], sn]);
        let b = g.mul(&[s[0], s[3], c]);
        let w = g.add(&[a, b]);
        vec![x, y, u, w]
    };
    let change = CoordinateChange::new(g, &["r", "ϑ", "ṙ", "ϑ̇"], &["x", "y", "u", "w"], h).unwrap();

    let mut g = Graph::new();
    let s: Vec<Id> = (0..4).map(|i| g.input(Input::State(i))).collect();
    let r2 = {
        let a = g.pow(s[0], Rational::int(2));
        let b = g.pow(s[1], Rational::int(2));
        g.add(&[a, b])
    };
    let k = g.pow(r2, Rational::new(-3, 2));
    let fx = g.mul(&[s[0], k]);
    let fy = g.mul(&[s[1], k]);
    let (fx, fy) = (g.neg(fx), g.neg(fy));
    let cart = EulerLagrange::new(g, vec![s[2], s[3], fx, fy]);

    let mut g = Graph::new();
    let s: Vec<Id> = (0..4).map(|i| g.input(Input::State(i))).collect();
    let rr = {
        let a = g.pow(s[3], Rational::int(2));
        let a = g.mul(&[s[0], a]);
        let b = g.pow(s[0], Rational::int(-2));
        g.sub(a, b)
    };
    let tt = {
        let a = g.pow(s[0], Rational::int(-1));
        let two = g.num(-2.0);
        g.mul(&[two, s[2], s[3], a])
    };
    let polar = EulerLagrange::new(g, vec![s[2], s[3], rr, tt]);

    for (x, l) in sample_points(100, 5) {
        let p = [x[0] / 6000.0, x[2], x[4] * 0.5, x[5] * 0.3];
        let lam = [l[1], l[2], l[3], l[4]];
        let (xd, ld) = change.transform_equations(&cart, &[], &p, &lam).unwrap();
        let (fx, fl) = polar.eval(&p, &lam, &[]);
        let scale = 1.0 + fl.iter().chain(&fx).fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..4 {
            assert!(
                (xd[i] - fx[i]).abs() <= TOL * scale,
                "ẋ{i}: {} {}",
                xd[i],
                fx[i]
            );
            assert!(
                (ld[i] - fl[i]).abs() <= TOL * scale,
                "λ̇{i}: {} {}",
                ld[i],
                fl[i]
            );
        }
        // ϑ is cyclic: λ̇_ϑ = 0 in both frames
        assert!(ld[1].abs() <= TOL * scale, "{}", ld[1]);
    }
    // r = 0 is singular, by the factor r
    let err = change.check(&[0.0, 0.3, 1.0, 1.0]).unwrap_err();
    assert!(err.to_string().contains("the factor r = "), "{err}");
}
