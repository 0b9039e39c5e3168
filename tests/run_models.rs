//! `lasalle run` works on every generated model, not only the paper's three: the CR3BP's
//! automatic Jacobi integral is kept by the feedback integrator (issue 4, item 1).

use std::path::PathBuf;
use std::process::Command;

/// Runs `lasalle run <args> --out <dir>` and returns the max error of each invariant.
fn run(name: &str, args: &[&str]) -> serde_json::Value {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let status = Command::new(env!("CARGO_BIN_EXE_lasalle"))
        .arg("run")
        .args(args)
        .args(["-q", "--out"])
        .arg(&out)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .status()
        .expect("run lasalle");
    assert!(status.success(), "lasalle run {args:?} failed");
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn max_error(summary: &serde_json::Value, invariant: &str) -> f64 {
    summary["invariant_errors"][invariant]["max"]
        .as_f64()
        .expect("max error")
}

#[test]
fn feedback_euler_keeps_the_jacobi_integral_of_the_cr3bp() {
    // 2·10⁵ steps: Euler drifts to |ΔH| ≈ 6e-3; feedback-Euler with adaptive gains (Bae &
    // Chang) stays near 2e-8, with the fixed gain 20 near 2e-5.
    let common = ["--init", "near_L4", "--dt", "0.005", "--t-end", "1000"];
    let euler = run(
        "cr3bp-euler",
        &[&["cr3bp", "-m", "euler"][..], &common].concat(),
    );
    let feedback = run(
        "cr3bp-feedback",
        &[
            &["cr3bp", "-m", "feedback-euler", "--gains", "auto"][..],
            &common,
        ]
        .concat(),
    );
    let (e, f) = (max_error(&euler, "H"), max_error(&feedback, "H"));
    assert!(
        f < 1e-6 && f * 1e4 < e,
        "|ΔH|: feedback-Euler {f:.2e}, Euler {e:.2e}"
    );
}

#[test]
fn every_model_runs() {
    let so3 = run("so3", &["so3-type-i", "-m", "feedback-rk4", "--dt", "0.01"]);
    for name in ["H", "casimir", "orthogonality"] {
        assert!(
            max_error(&so3, name) < 1e-5,
            "{name}: {}",
            max_error(&so3, name)
        );
    }
    let osc = run(
        "oscillators",
        &[
            "coupled-oscillators",
            "-m",
            "stormer-verlet-b",
            "--init",
            "excited",
        ],
    );
    assert!(max_error(&osc, "H") < 1e-5);
}

#[test]
fn a_singular_initial_state_is_an_error_not_a_panic() {
    let out = Command::new(env!("CARGO_BIN_EXE_lasalle"))
        .args([
            "run",
            "kepler",
            "-m",
            "euler",
            "--init",
            "0,0,0,0,0,0",
            "-q",
        ])
        .output()
        .expect("run lasalle");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("invalid initial state") && !err.contains("panicked"),
        "{err}"
    );
}
