//! `lasalle run` works on every generated model, not only the paper's three: the CR3BP's
//! automatic Jacobi integral is kept by the feedback integrator.

mod common;

use std::path::PathBuf;

/// Runs `lasalle run <args> --out <dir>` and returns the max error of each invariant.
fn run(name: &str, args: &[&str]) -> serde_json::Value {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let dir = out.to_str().unwrap();
    let o = common::lasalle(&[&["run"][..], args, &["-q", "--out", dir]].concat());
    assert!(
        o.status.success(),
        "lasalle run {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
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
