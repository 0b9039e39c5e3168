//! The primer vector's closed form on coast arcs against an independent integration of the
//! paper's (6) along Kepler motion, the Kepler solution against the conic's own relations,
//! and the near-parabolic series against (17) and (18).

use lasalle_analysis::primer::{digits, Coast, Conic, GForm, KeplerState};
use lasalle_runtime::{Control, DormandPrince, DormandPrinceOptions, Driver, Field};

/// Earth's μ in km³/s² and a perigee 300 km above a 6378.137 km Earth.
const MU: f64 = 398_600.441_8;
const RP: f64 = 6678.137;
const LAMBDA0: [f64; 3] = [0.3, -0.8, 0.5];
const DLAMBDA0: [f64; 3] = [1.2e-3, 0.7e-3, -0.9e-3];

/// (R, Ṙ, λ, λ̇) under Ṙ = V, V̇ = −μR/r³ and the paper's (6), λ̈ = −μλ/r³ + 3μ(λ·R)R/r⁵.
struct Adjoint;

impl Field<f64, Vec<f64>> for Adjoint {
    fn field(&self, s: &Vec<f64>, d: &mut Vec<f64>) {
        let r2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
        let r = r2.sqrt();
        let k = MU / (r2 * r);
        let dot = s[6] * s[0] + s[7] * s[1] + s[8] * s[2];
        for i in 0..3 {
            d[i] = s[3 + i];
            d[3 + i] = -k * s[i];
            d[6 + i] = s[9 + i];
            d[9 + i] = -k * s[6 + i] + 3.0 * k * dot * s[i] / r2;
        }
    }
}

fn integrate(conic: &Conic, t0: f64, t1: f64) -> Vec<f64> {
    let s = conic.state(t0).unwrap();
    let mut x = vec![s.x, s.y, 0.0, s.vx, s.vy, 0.0];
    x.extend(LAMBDA0);
    x.extend(DLAMBDA0);
    let opts = DormandPrinceOptions {
        rtol: 1e-14,
        atol: 1e-16,
        ..Default::default()
    };
    let mut dp5 = DormandPrince::<f64, Vec<f64>>::new(opts);
    let driver = Driver::new(t0, t1, 0.0).max_steps(10_000_000);
    let mut observe = |_: u64, _: f64, _: &Vec<f64>| Control::Continue;
    driver.run(&mut dp5, &Adjoint, &x, &mut observe).unwrap().x
}

fn closed(conic: Conic, form: GForm, t0: f64, t1: f64) -> Vec<f64> {
    let coast = Coast::new(conic, form, t0, LAMBDA0, DLAMBDA0).unwrap();
    let p = coast.primer(t1).unwrap();
    p.lambda.iter().chain(&p.dlambda).copied().collect()
}

#[test]
fn the_closed_form_meets_the_integrated_adjoint_equation_for_every_conic() {
    // the paper's comparison: a coast begun 1000 s after perigee, 100 s later
    for (e, form) in [
        (0.0, GForm::Exact),
        (0.5, GForm::Exact),
        (0.9, GForm::Exact),
        (0.99, GForm::Exact),
        (1.0, GForm::Parabolic),
        (1.5, GForm::Exact),
    ] {
        let conic = Conic::new(MU, RP, e).unwrap();
        let num = integrate(&conic, 1000.0, 1100.0);
        let cf = closed(conic, form, 1000.0, 1100.0);
        let d_lambda = digits(&num[6..9], &cf[..3]);
        let d_dlambda = digits(&num[9..12], &cf[3..]);
        assert!(
            d_lambda > 11.0 && d_dlambda > 11.0,
            "e = {e}: {d_lambda} {d_dlambda} digits"
        );
        // the integrated orbit is the universal-variable one
        let s = conic.state(1100.0).unwrap();
        assert!(digits(&num[..2], &[s.x, s.y]) > 11.0, "e = {e}: orbit");
    }
}

#[test]
fn the_closed_form_starts_where_it_was_set_up() {
    for e in [0.0, 0.3, 1.0, 2.0] {
        let conic = Conic::new(MU, RP, e).unwrap();
        let form = if e == 1.0 {
            GForm::Parabolic
        } else {
            GForm::Exact
        };
        let cf = closed(conic, form, 1000.0, 1000.0);
        assert!(digits(&LAMBDA0, &cf[..3]) > 14.0, "e = {e}");
        assert!(digits(&DLAMBDA0, &cf[3..]) > 14.0, "e = {e}");
    }
}

fn conic_relations(conic: &Conic, s: &KeplerState) -> (f64, f64, f64) {
    let h = s.x * s.vy - s.y * s.vx;
    let energy = 0.5 * (s.vx * s.vx + s.vy * s.vy) - conic.mu / s.r;
    // r = p − e x on every conic (the focus–directrix property)
    let focus = s.r - (conic.p() - conic.e * s.x);
    (
        h - conic.h(),
        energy + conic.mu * conic.alpha() / 2.0,
        focus,
    )
}

#[test]
fn the_kepler_solution_keeps_h_the_energy_and_the_conic() {
    for e in [0.0, 0.5, 0.99, 1.0, 1.0 + 1e-9, 1.5, 4.0] {
        let conic = Conic::new(MU, RP, e).unwrap();
        for t in [-3000.0, 0.0, 1.0, 1000.0, 1100.0, 5000.0, 1e5] {
            let s = conic.state(t).unwrap();
            let (dh, de, df) = conic_relations(&conic, &s);
            assert!(
                dh.abs() < 1e-12 * conic.h(),
                "e = {e}, t = {t}: h off by {dh}"
            );
            assert!(
                de.abs() < 1e-12 * MU / RP,
                "e = {e}, t = {t}: energy off by {de}"
            );
            assert!(
                df.abs() < 1e-11 * s.r,
                "e = {e}, t = {t}: r ≠ p − ex by {df}"
            );
        }
    }
}

#[test]
fn the_kepler_solution_meets_keplers_equation_in_the_eccentric_anomaly() {
    // e = 0.5: t = (u − e sin u)/n with x = a(cos u − e), y = a√(1 − e²) sin u
    let conic = Conic::new(MU, RP, 0.5).unwrap();
    let a = RP / 0.5;
    let n = (MU / a.powi(3)).sqrt();
    for t in [100.0, 1000.0, 4000.0] {
        let s = conic.state(t).unwrap();
        let u = (s.y / (a * 0.75f64.sqrt())).atan2(s.x / a + 0.5);
        let kepler = (u - 0.5 * u.sin()) / n;
        assert!((kepler - t).abs() < 1e-9 * t, "t = {t}: {kepler}");
    }
}

#[test]
fn the_k4_and_k5_terms_are_the_integrals_of_minus_2x_and_minus_2y() {
    // dG/dt = K₃ − 2F: the K₄ term's rate is −2x, the K₅ term's −2y (centred differences)
    for (e, form) in [
        (0.0, GForm::Exact),
        (0.5, GForm::Exact),
        (1.0, GForm::Parabolic),
        (1.5, GForm::Exact),
    ] {
        let conic = Conic::new(MU, RP, e).unwrap();
        let (t, dt) = (1000.0, 1e-2);
        let k4 = |t: f64| form.k4_term(&conic, &conic.state(t).unwrap(), t);
        let k5 = |t: f64| GForm::k5_term(&conic, &conic.state(t).unwrap());
        let s = conic.state(t).unwrap();
        let rate4 = (k4(t + dt) - k4(t - dt)) / (2.0 * dt);
        let rate5 = (k5(t + dt) - k5(t - dt)) / (2.0 * dt);
        assert!(
            (rate4 + 2.0 * s.x).abs() < 1e-7 * s.r,
            "e = {e}: K₄ rate {rate4} vs {}",
            -2.0 * s.x
        );
        assert!(
            (rate5 + 2.0 * s.y).abs() < 1e-7 * s.r,
            "e = {e}: K₅ rate {rate5} vs {}",
            -2.0 * s.y
        );
    }
}

#[test]
fn the_near_parabolic_series_reduces_to_the_parabola_at_e_1() {
    let conic = Conic::new(MU, RP, 1.0).unwrap();
    for t in [10.0, 1100.0, 1e5] {
        let s = conic.state(t).unwrap();
        let parabolic = GForm::Parabolic.k4_term(&conic, &s, t);
        assert_eq!(GForm::Printed.k4_term(&conic, &s, t), parabolic);
        assert_eq!(GForm::Series.k4_term(&conic, &s, t), parabolic);
    }
}

/// |K₄ term of `form` − that of (17)| relative to (17)'s, at 1100 s after perigee.
fn k4_error(e: f64, form: GForm) -> f64 {
    let conic = Conic::new(MU, RP, e).unwrap();
    let s = conic.state(1100.0).unwrap();
    let exact = GForm::Exact.k4_term(&conic, &s, 1100.0);
    (form.k4_term(&conic, &s, 1100.0) - exact).abs() / exact.abs()
}

#[test]
fn the_series_errs_by_eps_squared_and_the_printed_25_and_18_by_eps() {
    // ε = 10⁻², 10⁻³ on both sides of e = 1: (17) itself loses about log₁₀(1/ε) digits to
    // cancellation there, far fewer than the errors measured
    for sign in [1.0, -1.0] {
        let (e2, e3) = (1.0 - sign * 1e-2, 1.0 - sign * 1e-3);
        let series = k4_error(e2, GForm::Series) / k4_error(e3, GForm::Series);
        assert!((60.0..160.0).contains(&series), "series: ratio {series}");
        for form in [GForm::Printed, GForm::Parabolic] {
            let ratio = k4_error(e2, form) / k4_error(e3, form);
            assert!(
                (6.0..16.0).contains(&ratio),
                "{}: ratio {ratio}",
                form.name()
            );
        }
    }
}

#[test]
fn near_e_1_the_series_beats_the_cancelling_17() {
    // at e = 1 − 10⁻⁷, (17) loses about 7 digits to cancellation and more in the time;
    // the series errs by O(ε²) = 10⁻¹⁴
    let conic = Conic::new(MU, RP, 1.0 - 1e-7).unwrap();
    let num = integrate(&conic, 1000.0, 1100.0);
    let series = closed(conic, GForm::Series, 1000.0, 1100.0);
    assert!(digits(&num[6..9], &series[..3]) > 11.0);
}
