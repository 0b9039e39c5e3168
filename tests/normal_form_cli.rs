//! `lasalle normal-form` from the command line: tables, JSON, and the errors the issue names.

use std::process::Command;

fn lasalle(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lasalle"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run lasalle");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn earth_moon_json_has_deprit_d4() {
    let (ok, out, err) = lasalle(&[
        "normal-form",
        "models/cr3bp.lsl",
        "--param",
        "mu=0.01215058560962404",
        "--order",
        "6",
        "--format",
        "json",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("valid JSON");
    let d4 = v["d4"]["d4"]["value"]
        .as_f64()
        .or_else(|| v["d4"]["value"].as_f64())
        .expect("D4 in the JSON");
    // Deprit & Deprit-Bartholomé (1967): |D4| = |36 − 541w + 644w²| / (8(1 − 4w)(4 − 25w)), w = ω1²ω2²
    let mu: f64 = 0.01215058560962404;
    let w = 27.0 * mu * (1.0 - mu) / 4.0;
    let deprit = (36.0 - 541.0 * w + 644.0 * w * w) / (8.0 * (1.0 - 4.0 * w) * (4.0 - 25.0 * w));
    assert!(
        (d4.abs() - deprit.abs()).abs() < 1e-10 * deprit.abs(),
        "D4 = {d4}, Deprit {deprit}"
    );
}

#[test]
fn errors_name_the_resonance_and_the_eigenvalues() {
    let (ok, _, err) = lasalle(&[
        "normal-form",
        "models/cr3bp.lsl",
        "--param",
        "mu=0.0242939",
        "--order",
        "3",
    ]);
    assert!(
        !ok && err.contains("resonance m = (1, -2) at order 3"),
        "{err}"
    );
    let (ok, _, err) = lasalle(&["normal-form", "models/cr3bp.lsl", "--param", "mu=0.05"]);
    assert!(
        !ok && err.contains("equilibrium is not elliptic") && err.contains("0.730149841692i"),
        "{err}"
    );
    let (ok, _, err) = lasalle(&["normal-form", "models/kepler.lsl"]);
    assert!(!ok && err.contains("has no `hamiltonian`"), "{err}");
}
