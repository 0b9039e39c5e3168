//! Finite-time stability at Earth–Moon L4 (`lasalle_analysis::canonical`) against DOPRI5:
//! orbits from every action split and phase on the inner sphere never leave the outer tube
//! before the bound, the bound's differential inequality holds along every orbit, and the
//! measured action drift scales with the radius like the bound's lowest remainder degree.
//! Plus the verdicts (Arnold–Moser, linear instability beyond Routh's ratio, resonance) and
//! the errors.

use lasalle_analysis::canonical::{
    analyse, analyse_with, CanonicalOptions, CanonicalReport, SearchEnd, SearchEvent, SearchStop,
    Validation, Verdict,
};
use lasalle_codegen::Model;
use lasalle_normal_form::bound::Metric;
use lasalle_normal_form::validate::{deprit_d4, mu_routh, EARTH_MOON_MU};
use lasalle_normal_form::ModelPoint;

mod common;
use common::lasalle_text;

fn cr3bp() -> Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/cr3bp.lsl");
    lasalle_codegen::load_model(path).expect("models/cr3bp.lsl loads")
}

fn options(tubes: &[(f64, f64)], order: usize, metric: Metric) -> CanonicalOptions {
    CanonicalOptions {
        point: ModelPoint::Named("L4".into()),
        tubes: tubes.to_vec(),
        max_order: order,
        optimal: false,
        for_time: Vec::new(),
        outer_ratio: 2.0,
        remainder_degree: None,
        metric,
        validate: None,
        certified: false,
        budget: None,
        progress: None,
    }
}

fn run(mu: f64, o: &CanonicalOptions) -> Result<CanonicalReport, String> {
    analyse(&cr3bp(), &[("mu".to_string(), mu)], o)
}

#[test]
fn bounds_hold_along_integrated_orbits_and_drift_scales_as_predicted() {
    let radii = [1e-2, 5e-3, 2.5e-3];
    let tubes: Vec<(f64, f64)> = radii.iter().map(|&d| (d, 2.0 * d)).collect();
    let o = CanonicalOptions {
        validate: Some(Validation {
            horizon: 30.0,
            splits: 2,
            phases: 2,
            ..Validation::default()
        }),
        ..options(&tubes, 6, Metric::LinearNormal)
    };
    let report = run(EARTH_MOON_MU, &o).unwrap();
    for tube in &report.tubes {
        let v = tube.validation.as_ref().unwrap();
        assert_eq!(v.orbits, 8);
        let best = tube
            .orders
            .iter()
            .find(|r| Some(r.order) == tube.best_order)
            .unwrap();
        let t = best.gradient.unwrap().lower;
        // no orbit leaves the outer tube before the bound (none leaves at all here: L4 is
        // KAM-stable at Earth–Moon)
        assert!(v.first_exit.is_none_or(|e| e >= t), "d0 {}: {v:?}", tube.d0);
        for (r, m) in tube.orders.iter().zip(&v.measured) {
            // dρ/dt ≤ F(ρ) along every orbit, in the normal coordinates of every order (all
            // resolved at these radii and orders)
            assert!(
                m.resolved,
                "d0 {} N {}: {m:?} noise {}",
                tube.d0, r.order, v.noise
            );
            assert!(m.worst_ratio <= 1.0, "d0 {} N {}: {m:?}", tube.d0, r.order);
            let (g, rad) = (r.gradient.unwrap(), r.radial.unwrap());
            assert!(g.lower <= g.upper && g.upper < 1.01 * g.lower);
            assert!(rad.lower >= std::f64::consts::SQRT_2 * g.lower);
            assert_eq!(r.lowest_degree, Some(r.order + 1));
            // ρ₀ ≈ d₀ and ρ₁ ≈ d₁ up to the nonlinear distortion of the maps
            assert!(r.rho0 > tube.d0 && r.rho0 < 1.3 * tube.d0, "{r:?}");
            assert!(r.rho1 < tube.d1 && r.rho1 > 0.7 * tube.d1, "{r:?}");
        }
    }
    // at the smallest radius the bound grows with the order: 2.6e2, 3.0e4
    let small = &report.tubes[2];
    assert_eq!(small.best_order, Some(6));
    assert!(
        small.orders[1].gradient.unwrap().lower > 50.0 * small.orders[0].gradient.unwrap().lower
    );
    // drift of Σ I over t ≤ 30 ∝ d0^e with e = N + 1 (measured 5.1 and 7.9 over 0.0025…0.01)
    let e = report.drift_exponents.clone();
    assert_eq!(e.len(), 2);
    for (n, fitted, predicted, _) in e {
        assert_eq!(predicted, n + 1);
        assert!((fitted - predicted as f64).abs() < 1.0, "N {n}: {fitted}");
    }
}

#[test]
fn verdicts_at_l4() {
    let none = options(&[], 12, Metric::Euclidean);
    let r = run(EARTH_MOON_MU, &none).unwrap();
    match r.verdict {
        // our D4 is minus Deprit's textbook value (see the lasalle-normal-form crate docs)
        Verdict::StableArnoldMoser { d4, .. } => {
            assert!((d4 + deprit_d4(EARTH_MOON_MU)).abs() < 1e-10, "{d4}")
        }
        v => panic!("{v:?}"),
    }
    assert!((r.condition.unwrap() - 29.558).abs() < 1e-3);
    let r = run(1.02 * mu_routh(), &none).unwrap();
    assert!(
        matches!(r.verdict, Verdict::LinearlyUnstable { .. }),
        "{:?}",
        r.verdict
    );
    // 1:2 resonance at μ ≈ 0.0242939
    let r = run(0.024293897, &none).unwrap();
    match &r.verdict {
        Verdict::NotDecided { why } => assert!(why.contains("resonance"), "{why}"),
        v => panic!("{v:?}"),
    }
}

#[test]
fn errors_are_located() {
    let err = |tubes: &[(f64, f64)], metric, mu| run(mu, &options(tubes, 6, metric)).unwrap_err();
    // a tube without a bound is reported with its reason; the other tubes go on
    let failure = |tubes: &[(f64, f64)], metric, mu| {
        let r = run(mu, &options(tubes, 6, metric)).unwrap();
        assert_eq!(r.tubes.len(), tubes.len());
        let failed: Vec<String> = r.tubes.iter().filter_map(|t| t.failure.clone()).collect();
        assert_eq!(failed.len(), 1, "{failed:?}");
        assert!(
            r.tubes.iter().any(|t| t.best_order.is_some()),
            "the good tube is bounded"
        );
        failed[0].clone()
    };
    let e = failure(
        &[(1e-3, 2e-3), (1e-3, 1e-1)],
        Metric::Euclidean,
        EARTH_MOON_MU,
    );
    assert!(
        e.contains("condition number 29.6") && e.contains("linear-normal"),
        "{e}"
    );
    let e = err(&[(2e-3, 1e-3)], Metric::LinearNormal, EARTH_MOON_MU);
    assert!(e.contains("0 < d0 < d1"), "{e}");
    let e = err(&[(1e-3, 2e-3)], Metric::LinearNormal, 1.02 * mu_routh());
    assert!(e.contains("not elliptic"), "{e}");
    let e = err(&[(1e-3, 2e-3)], Metric::LinearNormal, 0.024293897);
    assert!(e.contains("resonan"), "{e}");
    // the maps stop converging: no bound at any order
    let e = failure(
        &[(5e-3, 1e-2), (3e-2, 6e-2)],
        Metric::LinearNormal,
        EARTH_MOON_MU,
    );
    assert!(e.contains("too wide"), "{e}");
}

#[test]
fn command_line() {
    let (ok, out, err) = lasalle_text(&["stability", "models/cr3bp.lsl"]);
    assert!(ok, "{err}");
    assert!(
        out.contains("Arnold–Moser") && out.contains("cond(A) = 29.558"),
        "{out}"
    );
    let (ok, out, err) = lasalle_text(&[
        "stability",
        "models/cr3bp.lsl",
        "--param",
        "mu=0.01215058560962404",
        "--metric",
        "linear-normal",
        "--time-bound",
        "5e-3,1e-2",
        "--order",
        "6",
        "--format",
        "csv",
    ]);
    assert!(ok, "{err}");
    let rows: Vec<&str> = out.lines().collect();
    assert_eq!(rows.len(), 3, "{out}");
    assert!(rows[0].starts_with("d0,d1,metric,order"));
    // N = 6 is the best order here (T = 5.6e2 against 19 at N = 4)
    assert!(rows[2].starts_with("5e-3,1e-2,linear-normal,6,12,") && rows[2].contains(",true,"));
    let (ok, out, _) = lasalle_text(&[
        "stability",
        "models/cr3bp.lsl",
        "--metric",
        "linear-normal",
        "--time-bound",
        "5e-3,1e-2",
        "--order",
        "4",
        "--format",
        "json",
    ]);
    assert!(ok);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["verdict"]["kind"], "stable-arnold-moser");
    assert_eq!(v["tubes"][0]["best_order"], 4);
    // a tube without a bound: its reason in the report, exit code 1 (the flags' own errors
    // are rows of tests/cli.rs)
    let (ok, out, err) = lasalle_text(&[
        "stability",
        "models/cr3bp.lsl",
        "--time-bound",
        "1e-3,2e-3",
        "--order",
        "12",
    ]);
    assert!(!ok && err.contains("1 of 1 tubes have no bound"), "{err}");
    assert!(out.contains("condition number 29.6"), "{out}");
}

/// The order search: T(N) grows up to the order it reports, and with a ceiling below the
/// optimum the report says the optimum was not bracketed.
#[test]
fn order_search_reports_the_largest_bound_and_whether_it_was_bracketed() {
    let o = CanonicalOptions {
        optimal: true,
        ..options(&[(1e-2, 2e-2)], 8, Metric::LinearNormal)
    };
    let report = run(EARTH_MOON_MU, &o).unwrap();
    assert!(report.order_search);
    let tube = &report.tubes[0];
    let times: Vec<f64> = tube
        .orders
        .iter()
        .map(|r| r.gradient.unwrap().lower)
        .collect();
    // 0.44, 2.8, 8.6 at N = 4, 6, 8 (the table in docs/stability.md): still growing at 8
    assert!(times.windows(2).all(|w| w[1] > w[0]), "{times:?}");
    assert_eq!(tube.best_order, Some(8));
    assert_eq!(tube.optimum_bracketed, Some(false));
    for r in &tube.orders {
        assert!(r.seconds > 0.0);
    }
}

/// The order search stops a tube without a bound after its first order, with its reason,
/// while the other tubes go on; each row is told as soon as its order is computed.
#[test]
fn order_search_stops_a_tube_without_bound_at_once() {
    let o = CanonicalOptions {
        optimal: true,
        ..options(&[(3e-2, 6e-2), (1e-2, 2e-2)], 8, Metric::LinearNormal)
    };
    let mut events: Vec<String> = Vec::new();
    let report = analyse_with(
        &cr3bp(),
        &[("mu".to_string(), EARTH_MOON_MU)],
        &o,
        &mut |e| match e {
            SearchEvent::Row { tube, row } => events.push(format!("row {tube} {}", row.order)),
            SearchEvent::TubeEnd { tube, end } => events.push(format!("end {tube} {end:?}")),
            _ => {}
        },
    )
    .unwrap();
    let wide = &report.tubes[0];
    assert_eq!(wide.orders.len(), 1);
    assert_eq!(wide.search_end, Some(SearchEnd::NoBound { order: 4 }));
    assert!(wide.failure.as_ref().unwrap().contains("too wide"));
    let good = &report.tubes[1];
    assert_eq!(good.orders.len(), 3);
    assert_eq!(good.search_end, Some(SearchEnd::Ceiling { last: 8 }));
    assert_eq!(
        events,
        [
            "row 0 4",
            "row 1 4",
            "end 0 NoBound { order: 4 }",
            "row 1 6",
            "row 1 8"
        ]
    );
}

/// The time budget ends a search whose bound still grows, with the best order so far.
#[test]
fn budget_ends_a_search_that_still_grows() {
    let o = CanonicalOptions {
        optimal: true,
        budget: Some(0.0),
        ..options(&[(5e-3, 1e-2)], 60, Metric::LinearNormal)
    };
    let report = run(EARTH_MOON_MU, &o).unwrap();
    let tube = &report.tubes[0];
    assert_eq!(tube.orders.len(), 1);
    assert_eq!(tube.best_order, Some(4));
    assert_eq!(
        tube.search_end,
        Some(SearchEnd::Budget {
            budget: 0.0,
            last: 4
        })
    );
    assert_eq!(tube.optimum_bracketed, Some(false));
    assert!(report.to_table().contains("still growing at N = 4"));
}

/// `for_time`: the radius found keeps its tube for T (measured again through the fixed-tube
/// path) and is the largest within the bisection's tolerance at its order.
#[test]
fn radius_for_a_time_is_the_largest_that_holds() {
    let time = 1e4;
    let o = CanonicalOptions {
        for_time: vec![time],
        ..options(&[], 6, Metric::LinearNormal)
    };
    let report = run(EARTH_MOON_MU, &o).unwrap();
    let r = &report.radii[0];
    let at6 = r.orders.iter().find(|a| a.order == 6).unwrap();
    let d0 = at6.d0.unwrap();
    assert!(at6.time.unwrap() >= time);
    let check = |d: f64| {
        let rep = run(
            EARTH_MOON_MU,
            &options(&[(d, 2.0 * d)], 6, Metric::LinearNormal),
        )
        .unwrap();
        rep.tubes[0].orders.last().unwrap().gradient.unwrap().lower
    };
    assert!(check(d0) >= time);
    assert!(check(1.01 * d0) < time);
    // a larger order keeps a larger radius here (the optimum lies beyond N = 6)
    assert_eq!(r.best_order, Some(6));
    assert!(r.orders[0].d0.unwrap() < d0);
}

/// `certified`: the certified time of a tube at its best order is positive, its ρ₀ and ρ₁
/// enclose the estimate's sampled extrema over the spheres, and it is reported next to the
/// estimate. (It may exceed the estimate: the estimate's ℓ¹ norm is the weaker bound on
/// dρ/dt; both are lower bounds on the exit time.)
#[test]
fn certified_time_reported_with_the_estimate() {
    let o = CanonicalOptions {
        certified: true,
        ..options(&[(1.25e-3, 2.5e-3)], 4, Metric::LinearNormal)
    };
    let r = run(EARTH_MOON_MU, &o).unwrap();
    let t = &r.tubes[0];
    let row = t.orders.last().unwrap();
    let est = row.gradient.unwrap().lower;
    let c = t.certified.as_ref().unwrap().as_ref().unwrap();
    let time = c.time.expect("a certified time");
    assert!(time > 0.0 && time.is_finite(), "{time} vs {est}");
    assert!(c.rho0 >= row.rho0 && c.rho1 <= row.rho1, "{c:?} vs {row:?}");
    assert!(r.to_table().contains("certified (interval arithmetic"));
    // the certified order search stops at the ceiling `--order 4`
    let search = t.certified_orders.as_ref().unwrap();
    assert_eq!(search.best_order, Some(4));
    assert_eq!(search.stop, SearchStop::Ceiling);
}

/// `certified` with `for_time`: the certified radius has a certified time ≥ T, the radius
/// that failed lies within the search's tolerance above it, and both radii are printed.
#[test]
fn certified_radius_reported_with_the_estimate() {
    let time = 1e4;
    let o = CanonicalOptions {
        certified: true,
        for_time: vec![time],
        ..options(&[], 4, Metric::LinearNormal)
    };
    let r = run(EARTH_MOON_MU, &o).unwrap();
    let radius = &r.radii[0];
    let search = radius.certified_radius.as_ref().unwrap();
    let best = search.best().unwrap();
    let tube = best.tube.as_ref().unwrap();
    assert!(tube.time.unwrap() >= time);
    let (failed, t) = best.failed.unwrap();
    assert!(
        failed > tube.d0 && failed <= 1.011 * tube.d0,
        "{failed} vs {}",
        tube.d0
    );
    assert!(t.is_none_or(|t| t < time));
    let table = r.to_table();
    assert!(table.contains("certified radius"), "{table}");
    assert!(table.contains(&format!("{:.5e}", tube.d0)), "{table}");
}
