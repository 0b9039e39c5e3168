//! `lasalle normal-form` from the command line: tables, JSON, and its errors.

use std::process::Command;

mod common;
use common::lasalle_text;

#[test]
fn earth_moon_json_has_deprit_d4() {
    let (ok, out, err) = lasalle_text(&[
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
    let (ok, _, err) = lasalle_text(&[
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
    let (ok, _, err) = lasalle_text(&["normal-form", "models/cr3bp.lsl", "--param", "mu=0.05"]);
    assert!(
        !ok && err.contains("equilibrium is not elliptic") && err.contains("0.730149841692i"),
        "{err}"
    );
    let (ok, _, err) = lasalle_text(&["normal-form", "models/kepler.lsl"]);
    assert!(!ok && err.contains("has no `hamiltonian`"), "{err}");
}

/// `lasalle` with the given arguments in a fresh temporary directory.
fn scratch_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("lasalle-nf-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn a_repeated_frequency_is_a_1_1_resonance() {
    // w2 = 1 makes both frequencies 1
    let (ok, _, err) = lasalle_text(&[
        "normal-form",
        "models/coupled_oscillators.lsl",
        "--param",
        "w2=1",
        "--order",
        "6",
    ]);
    assert!(!ok, "{err}");
    assert!(
        err.contains("resonance m = (1, -1) at order 4")
            && err.contains("ω1 = ω2 is a repeated frequency")
            && err.contains("--resonant")
            && err.contains("--order 3")
            && !err.contains("not elliptic"),
        "{err}"
    );
    let (ok, out, err) = lasalle_text(&[
        "normal-form",
        "coupled_oscillators",
        "--param",
        "w2=1",
        "--order",
        "6",
        "--resonant",
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("resonant normal form"), "{out}");
    assert!(out.contains("resonant terms kept"), "{out}");
    assert!(!out.contains("sum_a h_a I^a,"), "{out}");
    assert!(
        !out.contains("Arnold-Moser") && !out.contains("D4 ="),
        "{out}"
    );
    assert!(out.contains("(kept: resonant)"), "{out}");
    let (ok, out, err) = lasalle_text(&[
        "normal-form",
        "coupled_oscillators",
        "--param",
        "w2=1",
        "--resonant",
        "--format",
        "json",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(v["d4"].is_null());
    assert_eq!(v["omega"][0]["value"].as_f64(), Some(1.0));
    assert_eq!(v["omega"][1]["value"].as_f64(), Some(1.0));
}

#[test]
fn f64_breakdown_at_earth_moon_is_detected() {
    // from degree 18 an f64 coefficient (I1^9) has > 1e-3 relative error
    let (ok, out, err) = lasalle_text(&[
        "normal-form",
        "cr3bp",
        "--order",
        "20",
        "--precision",
        "f64",
    ]);
    assert!(!ok && out.is_empty(), "{out}");
    assert!(
        err.contains("f64 is not enough for this normal form from degree 18 on")
            && err.contains("--precision dd"),
        "{err}"
    );
    // auto (the default) switches to double-double and says so
    let (ok, out, err) = lasalle_text(&["normal-form", "cr3bp", "--order", "20"]);
    assert!(ok, "{err}");
    assert!(err.contains("recomputed in double-double"), "{err}");
    assert!(out.contains("(dd precision") && out.contains("recomputed in double-double"));
    // below the breakdown f64 stays
    let (ok, out, err) = lasalle_text(&["normal-form", "cr3bp", "--order", "16"]);
    assert!(
        ok && out.contains("(f64 precision") && !err.contains("note"),
        "{err}"
    );
}

#[test]
fn error_estimate_cost_is_stated_and_cheap_by_default() {
    let (ok, out, err) = lasalle_text(&["normal-form", "cr3bp", "--order", "16"]);
    assert!(ok, "{err}");
    assert!(out.contains("normal planes rotated"), "{out}");
    let time = out
        .lines()
        .find(|l| l.starts_with("time:"))
        .expect("time line");
    assert!(time.contains("x the run"), "{time}");
    let (ok, out, _) = lasalle_text(&[
        "normal-form",
        "cr3bp",
        "--order",
        "12",
        "--error-estimate",
        "rerun",
    ]);
    assert!(
        ok && out.contains("errors estimated as |f64 - dd|"),
        "{out}"
    );
    let (ok, out, _) = lasalle_text(&["normal-form", "--help"]);
    assert!(ok && out.contains("3.3×"), "{out}");
}

#[test]
fn no_progress_bar_when_stderr_is_not_a_terminal() {
    // the bar is drawn only on a terminal (see also the library test of the
    // progress stages in normal-form/tests/progress.rs)
    let (ok, _, err) = lasalle_text(&["normal-form", "cr3bp", "--order", "14"]);
    assert!(ok);
    assert!(err.is_empty(), "stderr: {err:?}");
}

#[test]
fn progress_bar_on_a_terminal() {
    // run under `script` (util-linux) so that stderr is a pseudo-terminal
    let have_script = Command::new("script")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !have_script {
        eprintln!("`script` not available: skipped");
        return;
    }
    let cmd = format!(
        "{} normal-form cr3bp --order 24 --precision dd > /dev/null",
        env!("CARGO_BIN_EXE_lasalle")
    );
    let out = Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("script");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("dd: degree"), "{text}");
}

#[test]
fn bad_output_paths_fail_before_computing() {
    let dir = scratch_dir("paths");
    let missing = dir.join("no/such/dir/out.txt");
    let m = missing.to_string_lossy().into_owned();
    let (ok, out, err) = lasalle_text(&["normal-form", "cr3bp", "--order", "24", "--out", &m]);
    assert!(!ok && out.is_empty(), "{out}");
    assert!(
        err.contains(&format!("`--out {m}`")) && err.contains("does not exist"),
        "{err}"
    );
    // --emit-rust into a directory: nothing printed, nothing computed
    let d = dir.to_string_lossy().into_owned();
    let t = std::time::Instant::now();
    let (ok, out, err) =
        lasalle_text(&["normal-form", "cr3bp", "--order", "30", "--emit-rust", &d]);
    assert!(!ok && out.is_empty(), "{out}");
    assert!(
        err.contains(&format!("`--emit-rust {d}`: is a directory")),
        "{err}"
    );
    assert!(t.elapsed().as_secs_f64() < 2.0, "it computed first");
    // a good --out with a failing run leaves no empty file behind
    let file = dir.join("table.txt");
    let f = file.to_string_lossy().into_owned();
    let (ok, _, _) = lasalle_text(&["normal-form", "cr3bp", "--param", "mu=0.05", "--out", &f]);
    assert!(!ok && !file.exists());
    let (ok, out, err) = lasalle_text(&["normal-form", "cr3bp", "--order", "6", "--out", &f]);
    assert!(ok && out.is_empty(), "{err}");
    assert!(std::fs::read_to_string(&file)
        .unwrap()
        .contains("Birkhoff normal form"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn spatial_cr3bp_at_order_16_in_double_double() {
    // three degrees of freedom, vertical frequency 1 (by path: the built-in
    // name `cr3bp_spatial` works as well, but the list of embedded models is fixed when the
    // binary is built)
    let t = std::time::Instant::now();
    let (ok, out, err) = lasalle_text(&[
        "normal-form",
        "models/cr3bp_spatial.lsl",
        "--order",
        "16",
        "--precision",
        "dd",
        "--format",
        "json",
    ]);
    let secs = t.elapsed().as_secs_f64();
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["n_dof"].as_u64(), Some(3));
    let omega: Vec<f64> = v["omega"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["value"].as_f64().unwrap())
        .collect();
    assert_eq!(omega.len(), 3);
    assert!(omega.iter().any(|w| (w - 1.0).abs() < 1e-15), "{omega:?}");
    assert!(secs < 60.0, "{secs} s");
}
