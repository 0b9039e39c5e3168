//! Papers of NASA TM X-53478 reproduced by `lasalle experiment`: the primer vector on coast
//! arcs (seventh paper; docs/primer_vector.md), Infante's Table I (fifth paper;
//! docs/infante.md) and the multipliers across coordinate systems (fourth paper;
//! docs/multipliers.md), through the command line and their `summary.json`.

use std::path::PathBuf;

mod common;
use common::lasalle;

fn run(name: &str) -> serde_json::Value {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("tm-x53478-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    let out = lasalle(&["experiment", name, "-q", "--out", dir.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json written");
    serde_json::from_str(&text).expect("valid JSON")
}

#[test]
fn the_primer_vector_closed_form_meets_the_variational_equations_to_ten_digits() {
    let s = run("primer-vector");
    let rows = s["paper"].as_array().unwrap();
    let es: Vec<f64> = rows.iter().map(|r| r["e"].as_f64().unwrap()).collect();
    assert_eq!(es, [0.0, 0.5, 0.9, 0.99, 1.0, 1.5]);
    for r in rows {
        let (dl, dd) = (
            r["digits_lambda"].as_f64().unwrap(),
            r["digits_dlambda"].as_f64().unwrap(),
        );
        assert!(dl >= 10.0 && dd >= 10.0, "e = {}: {dl} {dd} digits", r["e"]);
    }
    // near e = 1 the first-order series holds where (17) cancels: its error is O(ε²), ε = 1 − e
    for r in s["near_parabolic"].as_array().unwrap() {
        let e = r["e"].as_f64().unwrap();
        let series = r["digits_lambda"]["series"].as_f64().unwrap();
        let eps = (1.0 - e).abs();
        if eps <= 1e-6 {
            assert!(series >= 10.0, "e = {e}: series {series} digits");
        } else if eps <= 1e-4 {
            assert!(series >= 9.0, "e = {e}: series {series} digits");
        }
    }
}

#[test]
fn infante_table_one_is_printed_and_proved() {
    let s = run("infante");
    let orders = s["orders"].as_array().unwrap();
    assert_eq!(orders.len(), 3);
    let n2 = &orders[0]["table"];
    assert_eq!(
        n2[0]["B"],
        serde_json::json!([["a₁² + a₂", "a₁"], ["a₁", "1"]])
    );
    assert_eq!(n2[0]["C"], serde_json::json!(["2a₁a₂", "0"]));
    assert_eq!(n2[1]["B"], serde_json::json!([["a₂", "0"], ["0", "1"]]));
    assert_eq!(n2[1]["C"], serde_json::json!(["0", "2a₁"]));
    let n3 = &orders[1]["table"];
    assert_eq!(
        n3[1]["B"],
        serde_json::json!([
            ["a₁a₃", "a₃", "0"],
            ["a₃", "a₁² + a₂", "a₁"],
            ["0", "a₁", "1"]
        ])
    );
    assert_eq!(
        n3[2]["B"],
        serde_json::json!([
            ["a₃²", "a₂a₃", "0"],
            ["a₂a₃", "a₁a₃ + a₂²", "a₃"],
            ["0", "a₃", "a₂"]
        ])
    );
    for o in orders {
        for row in o["table"].as_array().unwrap() {
            assert_eq!(row["proved"], true);
            assert!(row["min_pivot"].as_f64().unwrap() > 0.0);
        }
    }
    // Example 1: the boundary derived from the criterion is (4.9) for p = 1 and p = 2.5
    let one = s["example1"].as_array().unwrap();
    assert_eq!(one.len(), 40);
    for r in one {
        let printed = r["printed"].as_f64().unwrap();
        for key in ["z2_p1", "z2_p2_5"] {
            let z2 = r[key].as_f64().unwrap();
            assert!((z2 - printed).abs() <= 1e-11 * printed, "{r}");
        }
    }
    // Example 2: the bound derived from the criterion is (4.20)
    let two = s["example2"].as_array().unwrap();
    assert_eq!(two.len(), 60);
    for r in two {
        let (r2, printed) = (r["r2"].as_f64().unwrap(), r["printed"].as_f64().unwrap());
        assert!((r2 - printed).abs() <= 1e-7 * printed, "{r}");
    }
}

/// `lasalle infante` on Example 1's model: w = 1 − (q − 5/4)² along q = 1.25 + 0.95 sin t.
#[test]
fn infante_criterion_along_t_on_a_model_and_its_refusals() {
    let out = lasalle(&[
        "infante",
        "models/infante_example1.lsl",
        "--alpha",
        "0.5,1",
        "--c",
        "1,0",
        "--t-end",
        "6.283185307179586",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(s["holds"], true);
    assert!((s["min_w"].as_f64().unwrap() - (1.0 - 0.95f64.powi(2))).abs() < 1e-12);
    assert!((s["t_min"].as_f64().unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
    // a nonlinear model is refused at its line, with a model error's exit code
    let out = lasalle(&[
        "infante", "duffing", "--alpha", "1,1", "--c", "1,0", "--t-end", "1",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("duffing.lsl:") && err.contains("depends on the state x1"),
        "{err}"
    );
    // α's outside the Routh–Hurwitz region are a usage error
    let out = lasalle(&[
        "infante",
        "models/infante_example1.lsl",
        "--alpha",
        "1,-1",
        "--c",
        "1,0",
        "--t-end",
        "1",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("Δ2 = -1"), "{err}");
}

#[test]
fn the_multiplier_identities_hold_along_the_extremal_and_singular_points_are_named() {
    let s = run("multipliers");
    assert!(s["steps"].as_u64().unwrap() > 100);
    let residuals = s["residuals"].as_array().unwrap();
    assert_eq!(residuals.len(), 6);
    for r in residuals {
        let max = r["max"].as_f64().unwrap();
        assert!(max <= 1e-12, "{}: {max:e}", r["identity"]);
    }
    assert!(s["random_points_max"].as_f64().unwrap() <= 1e-12);
    // the printed δ_l has the opposite sign; the other eight partials agree to rounding
    let p = &s["printed_partials"];
    for a in 0..3 {
        for b in 0..3 {
            let d = p[a][b].as_f64().unwrap();
            if (a, b) == (2, 0) {
                assert!(d > 0.1, "δ_l: {d}");
            } else {
                assert!(d <= 1e-12, "({a}, {b}): {d}");
            }
        }
    }
    let singular: Vec<&str> = s["singular"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m.as_str().unwrap())
        .collect();
    for (msg, factor) in singular
        .iter()
        .zip(["cos(γ) = ", "v = 0.000e0", "cos(φ) = "])
    {
        assert!(msg.contains(&format!("the factor {factor}")), "{msg}");
    }
}
