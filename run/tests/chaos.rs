//! The variational equations and the chaos indicators against what is known independently:
//! exp(At) for linear systems, central finite differences of the flow, the flow's own
//! identities (Φ(t)X(x₀) = X(x(t)), ΦᵀJΦ = J), the divergence theorem for the spectrum's sum,
//! Lorenz's exponents, the ± pairing of Hamiltonian spectra and MEGNO's limits.

#![allow(clippy::needless_range_loop)] // matrices are compared entry by entry

use lasalle_exec::{Backend, LoadedModel};
use lasalle_run::chaos::{
    extend, indicators, lyapunov_spectrum, read_indicators, state_transition, Extension,
};
use lasalle_run::{
    simulate, simulate_lanes, simulate_many, Base, Init, Member, Method, ModelSource, RunSpec,
};
use lasalle_runtime::Parameters;

const OSC: &str = "model Osc { state q: scalar, p: scalar; param w = 1.7;
    d/dt q = p; d/dt p = -w^2 * q; point start { q = 0.3; p = -0.2; } }";

const DAMPED: &str = "model Damped { state q: scalar, p: scalar; param c = 0.3; param w = 2;
    d/dt q = p; d/dt p = -w^2 * q - c * p; point start { q = 1; p = 0; } }";

const LORENZ: &str = "model Lorenz { state x: scalar, y: scalar, z: scalar;
    param sigma = 10; param rho = 28; param beta = 8/3;
    d/dt x = sigma * (y - x); d/dt y = x * (rho - z) - y; d/dt z = x * y - beta * z;
    point start { x = 1; y = 1; z = 1; } }";

const KEPLER: &str = "model Kepler { state x: vec2, v: vec2; param mu = 1;
    d/dt x = v; d/dt v = -mu * x / norm(x)^3;
    point start { x = [1, 0]; v = [0, 1.2]; } }";

fn henon_heiles() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../models/henon_heiles.lsl"
    ))
    .unwrap()
}

/// A state in the chaotic sea of the E = 1/8 section q₀ = 0 (Hénon & Heiles 1964, fig. 5):
/// q₁ = −0.1, p₁ = 0, p₀ > 0 from the energy.
fn henon_heiles_chaotic() -> Vec<f64> {
    let q1: f64 = -0.1;
    let p0 = (2.0 * (0.125 - q1 * q1 / 2.0 + q1.powi(3) / 3.0)).sqrt();
    vec![0.0, q1, p0, 0.0]
}

fn load(text: &str, backend: Backend) -> LoadedModel {
    LoadedModel::from_source("test.lsl", text, backend).unwrap()
}

fn spec(method: Method, t_end: f64, tol: f64) -> RunSpec {
    let mut s = RunSpec::new(method, 0.0, t_end);
    s.rtol = tol;
    s.atol = tol;
    s.every = u64::MAX;
    s
}

const DOPRI5: Method = Method::Plain(Base::Dopri5);
const TAYLOR: Method = Method::Taylor { feedback: false };

/// The oscillator's Φ(t) = exp(At) = [[cos wt, sin wt / w], [−w sin wt, cos wt]], on every
/// back end and with the adaptive methods.
#[test]
fn oscillator_stm_is_exp_at() {
    let (w, t) = (1.7f64, 13.0f64);
    let exact = [
        [(w * t).cos(), (w * t).sin() / w],
        [-w * (w * t).sin(), (w * t).cos()],
    ];
    for backend in Backend::available() {
        for method in [DOPRI5, TAYLOR] {
            let m = load(OSC, *backend);
            let x0 = m.point("start").unwrap();
            let tr = state_transition(&m, &x0, &spec(method, t, 1e-12)).unwrap();
            for i in 0..2 {
                for j in 0..2 {
                    let err = (tr.phi[i][j] - exact[i][j]).abs();
                    assert!(
                        err < 1e-9,
                        "{backend:?} {method}: Φ[{i}][{j}] off by {err:e}"
                    );
                }
            }
        }
    }
}

/// A non-normal linear system: the damped oscillator's exp(At) in closed form.
#[test]
fn damped_oscillator_stm_is_exp_at() {
    let (c, w, t) = (0.3f64, 2.0f64, 7.5f64);
    // A = [[0, 1], [−w², −c]]: exp(At) = e^{−ct/2} [cos Ωt I + sin(Ωt)/Ω (A + c/2 I)]
    let om = (w * w - c * c / 4.0).sqrt();
    let (e, co, si) = ((-c * t / 2.0).exp(), (om * t).cos(), (om * t).sin() / om);
    let exact = [
        [e * (co + si * c / 2.0), e * si],
        [e * si * (-w * w), e * (co + si * (-c + c / 2.0))],
    ];
    let m = load(DAMPED, Backend::default());
    let tr = state_transition(&m, &[1.0, 0.0], &spec(DOPRI5, t, 1e-12)).unwrap();
    for i in 0..2 {
        for j in 0..2 {
            assert!(
                (tr.phi[i][j] - exact[i][j]).abs() < 1e-9,
                "Φ[{i}][{j}] = {} ≠ {}",
                tr.phi[i][j],
                exact[i][j]
            );
        }
    }
}

/// Kepler's Φ over two orbits of an eccentric orbit: against central differences of the
/// flow, the identity Φ(t)X(x₀) = X(x(t)) and symplecticity ΦᵀJΦ = J.
#[test]
fn kepler_stm_matches_finite_differences_and_flow_identities() {
    let m = load(KEPLER, Backend::default());
    let x0 = m.point("start").unwrap();
    let t = 12.0;
    let tight = spec(DOPRI5, t, 1e-13);
    let tr = state_transition(&m, &x0, &tight).unwrap();
    let flow = |x: &[f64]| {
        simulate(&m, &x.to_vec(), &tight)
            .unwrap()
            .last_state()
            .to_vec()
    };
    let h = 1e-5;
    for j in 0..4 {
        let (mut a, mut b) = (x0.clone(), x0.clone());
        a[j] += h;
        b[j] -= h;
        let (fa, fb) = (flow(&a), flow(&b));
        for i in 0..4 {
            let fd = (fa[i] - fb[i]) / (2.0 * h);
            let err = (fd - tr.phi[i][j]).abs();
            assert!(
                err < 1e-5 * (1.0 + fd.abs()),
                "Φ[{i}][{j}] = {} vs central difference {fd}",
                tr.phi[i][j]
            );
        }
    }
    let field = |x: &[f64]| {
        let r3 = (x[0] * x[0] + x[1] * x[1]).powf(1.5);
        [x[2], x[3], -x[0] / r3, -x[1] / r3]
    };
    let (f0, f1) = (field(&x0), field(&tr.x));
    for i in 0..4 {
        let phi_f0: f64 = (0..4).map(|j| tr.phi[i][j] * f0[j]).sum();
        assert!(
            (phi_f0 - f1[i]).abs() < 1e-8,
            "(Φ X(x₀))[{i}] = {phi_f0} ≠ {}",
            f1[i]
        );
    }
    // J = [[0, I], [−I, 0]] on (x, v)
    let jmul = |v: [f64; 4]| [v[2], v[3], -v[0], -v[1]];
    for a in 0..4 {
        for b in 0..4 {
            let col = |k: usize| [tr.phi[0][k], tr.phi[1][k], tr.phi[2][k], tr.phi[3][k]];
            let jb = jmul(col(b));
            let s: f64 = (0..4).map(|i| col(a)[i] * jb[i]).sum();
            let expected = jmul(std::array::from_fn(|i| if i == b { 1.0 } else { 0.0 }))[a];
            assert!((s - expected).abs() < 1e-8, "(ΦᵀJΦ)[{a}][{b}] = {s}");
        }
    }
}

/// Lorenz: the spectrum's sum is the (constant) divergence −(σ + 1 + β), the largest
/// exponent 0.9056 and the middle one 0 (Sprott, Chaos and Time-Series Analysis, 2003).
#[test]
fn lorenz_spectrum() {
    let m = load(LORENZ, Backend::default());
    let sp = lyapunov_spectrum(&m, &[1.0, 1.0, 1.0], &spec(DOPRI5, 2000.0, 1e-10), 1.0).unwrap();
    let sum: f64 = sp.exponents.iter().sum();
    let divergence = -(10.0 + 1.0 + 8.0 / 3.0);
    assert!((sum - divergence).abs() < 1e-6, "Σλ = {sum}");
    assert!(
        (sp.exponents[0] - 0.9056).abs() < 0.03,
        "{:?}",
        sp.exponents
    );
    assert!(sp.exponents[1].abs() < 0.01, "{:?}", sp.exponents);
    assert!(
        (sp.exponents[2] + 14.5723).abs() < 0.03,
        "{:?}",
        sp.exponents
    );
    assert_eq!(sp.renormalisations, 2000);
}

/// A damped oscillator: both exponents are −c/2 (its divergence is −c).
#[test]
fn damped_oscillator_spectrum_sums_to_the_divergence() {
    let m = load(DAMPED, Backend::Interpreter);
    let sp = lyapunov_spectrum(&m, &[1.0, 0.0], &spec(TAYLOR, 200.0, 1e-12), 0.5).unwrap();
    assert!(
        (sp.exponents.iter().sum::<f64>() + 0.3).abs() < 1e-9,
        "{sp:?}"
    );
    for l in &sp.exponents {
        assert!((l + 0.15).abs() < 0.02, "{sp:?}");
    }
}

/// ẋ = −x, ẏ = y/2: the tangent vectors start on the eigenvectors e₁, e₂, so Gram–Schmidt
/// keeps them there and accumulates −1 in the first column and 1/2 in the second — the
/// decreasing order is (1/2, −1), the columns' (−1, 1/2), both exact.
#[test]
fn the_spectrum_is_decreasing_and_the_columns_order_kept_apart() {
    let m = load(
        "model Split { state x: scalar, y: scalar; d/dt x = -x; d/dt y = y / 2;
         point start { x = 1; y = 1; } }",
        Backend::default(),
    );
    let sp = lyapunov_spectrum(&m, &[1.0, 1.0], &spec(DOPRI5, 20.0, 1e-12), 1.0).unwrap();
    for (got, exact) in [(&sp.exponents, [0.5, -1.0]), (&sp.qr_order, [-1.0, 0.5])] {
        for (l, e) in got.iter().zip(exact) {
            assert!((l - e).abs() < 1e-9, "{sp:?}");
        }
    }
}

/// Hénon–Heiles in its chaotic sea: the spectrum is (λ, 0, 0, −λ) with λ > 0, and sums to 0.
#[test]
fn henon_heiles_spectrum_comes_in_pairs() {
    let m = load(&henon_heiles(), Backend::default());
    let x0 = henon_heiles_chaotic();
    let sp = lyapunov_spectrum(&m, &x0, &spec(DOPRI5, 5000.0, 1e-11), 2.0).unwrap();
    let l = &sp.exponents;
    assert!(l[0] > 0.02, "{l:?}");
    assert!((l[0] + l[3]).abs() < 1e-3 * l[0].max(1.0), "{l:?}");
    assert!(l[1].abs() < 0.01 && l[2].abs() < 0.01, "{l:?}");
    assert!(l.iter().sum::<f64>().abs() < 1e-8, "{l:?}");
}

/// MEGNO: ⟨Y⟩ → 0 on the oscillator's (isochronous) orbits, → 2 on a quasi-periodic orbit of
/// Hénon–Heiles, and grows like λt/2 in its chaotic sea and on Lorenz's attractor, where the
/// unit tangent vector's mean growth rate is the largest exponent.
#[test]
fn megno_limits() {
    let osc = load(OSC, Backend::default());
    let (_, ind) = indicators(&osc, &[0.3, -0.2], &spec(DOPRI5, 2000.0, 1e-12)).unwrap();
    assert!(ind.megno_mean.abs() < 0.01, "{ind:?}");
    assert!((ind.t - 2000.0).abs() < 1e-9);

    let hh = load(&henon_heiles(), Backend::default());
    let regular = hh.point("regular").unwrap();
    let (_, ind) = indicators(&hh, &regular, &spec(TAYLOR, 5000.0, 1e-12)).unwrap();
    assert!((ind.megno_mean - 2.0).abs() < 0.1, "{ind:?}");
    assert!(ind.mle < 0.01, "{ind:?}");

    let chaotic = henon_heiles_chaotic();
    let (_, ind) = indicators(&hh, &chaotic, &spec(DOPRI5, 5000.0, 1e-11)).unwrap();
    assert!(ind.megno_mean > 20.0 && ind.mle > 0.03, "{ind:?}");
    // ⟨Y⟩ ≈ λt/2 for large t
    let slope = 2.0 * ind.megno_mean / ind.t;
    assert!((slope - ind.mle).abs() < 0.15 * ind.mle, "{ind:?}");

    // Lorenz: the unit tangent vector's growth rate is the largest exponent, 0.9056
    let lorenz = load(LORENZ, Backend::default());
    let (_, ind) = indicators(&lorenz, &[1.0, 1.0, 1.0], &spec(DOPRI5, 2000.0, 1e-10)).unwrap();
    assert!((ind.mle - 0.9056).abs() < 0.01, "{ind:?}");
    assert!(
        (2.0 * ind.megno_mean / ind.t - ind.mle).abs() < 0.02 * ind.mle,
        "{ind:?}"
    );
}

/// The FLI is the supremum of ln‖w‖ over the run (Froeschlé, Lega & Gonczi 1997), not its
/// last value: for the oscillator q̈ = −ω²q, w(t) = Φ(t)w(0) with w(0) = (1, 1)/√2 has
/// ‖w‖² = ½ vᵀMv, v = (cos ωt, sin ωt), M = [[2, 1/ω − ω], [1/ω − ω, 1/ω² + ω²]], whose
/// largest value over a period is ½ λ_max(M): FLI = ½ ln(λ_max(M)/2) once t exceeds a period,
/// while ln‖w(t)‖ oscillates below it.
#[test]
fn fli_is_the_supremum_of_the_log_growth() {
    let osc = load(OSC, Backend::default());
    let w = 1.7f64;
    let (m11, m12, m22) = (2.0, 1.0 / w - w, 1.0 / (w * w) + w * w);
    let lmax = (m11 + m22) / 2.0 + (((m11 - m22) / 2.0).powi(2) + m12 * m12).sqrt();
    let sup = 0.5 * (lmax / 2.0).ln();
    for (method, tol) in [(DOPRI5, 1e-12), (TAYLOR, 1e-14)] {
        for t_end in [4.0, 10.0, 10.9] {
            let (_, ind) = indicators(&osc, &[0.3, -0.2], &spec(method, t_end, tol)).unwrap();
            let (c, s) = ((w * t_end).cos(), (w * t_end).sin());
            let last = 0.5 * ((m11 * c * c + 2.0 * m12 * c * s + m22 * s * s) / 2.0).ln();
            eprintln!(
                "{method} t = {t_end}: FLI {} (sup {sup}), ln‖w(t)‖ {last}",
                ind.fli
            );
            assert!(
                (ind.fli - sup).abs() < 1e-9,
                "{method} t = {t_end}: {ind:?}"
            );
            assert!((ind.mle * t_end - last).abs() < 1e-9, "{ind:?}");
            assert!(
                sup - last > 0.05,
                "t = {t_end}: ℓ(t) should lie below its sup"
            );
        }
    }
}

/// The model file's points: `chaotic` in the chaotic sea of E = 1/8 (⟨Y⟩ grows like λt/2 with
/// λ > 0), `regular` on a quasi-periodic orbit of E = 1/12 (⟨Y⟩ → 2, λ → 0).
#[test]
fn henon_heiles_points_are_what_they_are_named() {
    let hh = load(&henon_heiles(), Backend::default());
    let h = |x: &[f64]| {
        (x[2] * x[2] + x[3] * x[3] + x[0] * x[0] + x[1] * x[1]) / 2.0 + x[0] * x[0] * x[1]
            - x[1].powi(3) / 3.0
    };
    let chaotic = hh.point("chaotic").unwrap();
    assert!((h(&chaotic) - 0.125).abs() < 1e-15, "{chaotic:?}");
    let (_, ind) = indicators(&hh, &chaotic, &spec(TAYLOR, 5000.0, 1e-12)).unwrap();
    eprintln!("chaotic: {ind:?}");
    assert!(ind.megno_mean > 20.0 && ind.mle > 0.03, "{ind:?}");
    let regular = hh.point("regular").unwrap();
    let (_, ind) = indicators(&hh, &regular, &spec(TAYLOR, 5000.0, 1e-12)).unwrap();
    eprintln!("regular: {ind:?}");
    assert!(
        (ind.megno_mean - 2.0).abs() < 0.1 && ind.mle < 0.01,
        "{ind:?}"
    );
}

/// The same indicators from the JIT and the interpreter, and a method that changes x by
/// something other than the field is refused.
#[test]
fn back_ends_agree_and_feedback_is_refused() {
    let hh = henon_heiles();
    let x0 = henon_heiles_chaotic();
    let s = spec(DOPRI5, 50.0, 1e-12);
    let got: Vec<_> = Backend::available()
        .iter()
        .map(|b| indicators(&load(&hh, *b), &x0, &s).unwrap().1)
        .collect();
    for g in &got[1..] {
        assert!((g.fli - got[0].fli).abs() < 1e-9, "{got:?}");
    }
    let m = load(&hh, Backend::default());
    let err = indicators(&m, &x0, &spec(Method::Feedback(Base::Rk4), 1.0, 1e-10)).unwrap_err();
    assert!(
        err.to_string()
            .contains("use euler, heun, rk4, dopri5 or taylor"),
        "{err}"
    );
}

/// The indicators' model in an ensemble (what `lasalle sweep --indicator` runs): rk4 in lanes
/// of 1, 3 and 8 rows gives every row's final extended state bitwise as the lone run of
/// [`indicators`] does, and so its MEGNO and exponent; so does the Taylor method, whose rows go
/// two at a time through its batch kernel (`TaylorLanes`). The FLI needs the peaks of ln‖w‖,
/// which lanes do not locate: an ensemble that records events runs each row alone and gives
/// the lone run's supremum.
#[test]
fn indicators_in_lanes_are_the_lone_runs() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/henon_heiles.lsl");
    let source = ModelSource::read(path, Backend::Jit)
        .unwrap()
        .extended(Extension::Indicators);
    let hh = load(&henon_heiles(), Backend::Jit);
    let starts: Vec<Vec<f64>> = (0..7)
        .map(|k| {
            let q1 = -0.3 + 0.1 * k as f64;
            let p0 = (2.0 * (0.125 - q1 * q1 / 2.0 + q1.powi(3) / 3.0)).sqrt();
            vec![0.0, q1, p0, 0.0]
        })
        .collect();
    let members: Vec<Member> = starts
        .iter()
        .map(|x| Member::at(Extension::Indicators.extend_state(x)))
        .collect();
    for (method, dt, tol) in [
        (Method::Plain(Base::Rk4), 0.01, 1e-10),
        (TAYLOR, 0.0, 1e-12),
    ] {
        let mut s = spec(method, 100.0, tol);
        s.dt = dt;
        let alone: Vec<_> = starts
            .iter()
            .map(|x| indicators(&hh, x, &s).unwrap())
            .collect();
        for (lanes, record_events) in [(1, false), (3, false), (8, false), (8, true)] {
            let s = RunSpec {
                record_events,
                ..s.clone()
            };
            if method == TAYLOR || lanes == 1 {
                // no Runge–Kutta lanes (the Taylor method's are `TaylorLanes`)
            } else {
                // the lanes ran (and only where no events are to be located)
                let extended = extend(&hh, Extension::Indicators).unwrap();
                let x0s: Vec<Vec<f64>> = members
                    .iter()
                    .map(|m| match &m.init {
                        Init::State(x) => x.clone(),
                        _ => unreachable!(),
                    })
                    .collect();
                let laned = simulate_lanes(&extended, &x0s[..lanes.min(x0s.len())], &s);
                assert_eq!(laned.is_some(), !record_events, "{method}, {lanes} lanes");
            }
            let ensemble = simulate_many(&source, &members, &s, 1, lanes).unwrap();
            for (k, (got, (rec, ind))) in ensemble.recordings.iter().zip(&alone).enumerate() {
                let got = got.as_ref().unwrap();
                let what = format!("{method}, {lanes} lanes, row {k}");
                assert_eq!(got.last_state(), rec.last_state(), "{what}");
                let found = read_indicators(got, 4).unwrap();
                assert_eq!(found.megno_mean, ind.megno_mean, "{what}");
                assert_eq!(found.mle, ind.mle, "{what}");
                if record_events {
                    assert_eq!(found.fli, ind.fli, "{what}");
                }
            }
        }
    }
}

/// A model loaded with its families kept as loops is extended in loop form (its field from the
/// families' bodies, not from the unrolled model): MEGNO, the exponent, the FLI, Φ(t) and the
/// spectrum of 5 bodies and of an FPUT chain equal those of the same model unrolled, to the
/// rounding the two summation orders leave (amplified by the flow over the run), on every back
/// end, with dopri5 and the Taylor method (the loop form of the variational field's program).
#[test]
fn loop_families_give_the_unrolled_indicators() {
    use lasalle_exec::Families;
    let read = |name: &str| {
        std::fs::read_to_string(format!("{}/../models/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
    };
    let fput = read("fput.lsl").replace("param n = 16;", "param n = 7;");
    for (text, point, t_end) in [(read("nbody.lsl"), "ring", 6.0), (fput, "mode1", 30.0)] {
        for backend in Backend::available() {
            let loops =
                LoadedModel::from_source_with("m.lsl", &text, *backend, Families::Loops).unwrap();
            let unrolled = load(&text, *backend);
            for ext in [
                Extension::Indicators,
                Extension::Variational { tangents: 2 },
            ] {
                assert!(
                    matches!(loops.extended(ext), Some(Ok(_))),
                    "{point}: the loop form of {ext:?}"
                );
            }
            assert!(unrolled.extended(Extension::Indicators).is_none());
            let x0 = unrolled.point(point).unwrap();
            let close = |a: f64, b: f64, what: &str| {
                assert!(
                    (a - b).abs() <= 1e-9 * b.abs().max(1.0),
                    "{point} {backend:?} {what}: loops {a}, unrolled {b}"
                );
            };
            // taylor: the staged field's Taylor program in loop form against the unrolled
            // extension's
            for method in [DOPRI5, TAYLOR] {
                let s = spec(method, t_end, 1e-12);
                let (rec, a) = indicators(&loops, &x0, &s).unwrap();
                let (_, b) = indicators(&unrolled, &x0, &s).unwrap();
                eprintln!("{point} {backend:?} {method}: loops {a:?}, unrolled {b:?}");
                assert!(rec.failure.is_none() && b.megno_mean > 0.0 && b.fli > 0.0);
                close(a.megno_mean, b.megno_mean, &format!("{method} ⟨Y⟩"));
                close(a.megno, b.megno, &format!("{method} Y"));
                close(a.mle, b.mle, &format!("{method} ℓ/t"));
                close(a.fli, b.fli, &format!("{method} FLI"));
            }
            for method in [DOPRI5, TAYLOR] {
                let s = spec(method, t_end / 4.0, 1e-12);
                let a = state_transition(&loops, &x0, &s).unwrap();
                let b = state_transition(&unrolled, &x0, &s).unwrap();
                for (ra, rb) in a.phi.iter().zip(&b.phi) {
                    for (&pa, &pb) in ra.iter().zip(rb) {
                        close(pa, pb, &format!("{method} Φ"));
                    }
                }
            }
            let s = spec(DOPRI5, 2.0, 1e-12);
            let a = lyapunov_spectrum(&loops, &x0, &s, 1.0).unwrap();
            let b = lyapunov_spectrum(&unrolled, &x0, &s, 1.0).unwrap();
            for (&la, &lb) in a.exponents.iter().zip(&b.exponents) {
                close(la, lb, "spectrum");
            }
        }
    }
}
