//! `lasalle gen <model> --crate <dir>` writes a crate that another project can depend on:
//! build it, and run a test inside it that uses the generated model.

use std::path::Path;
use std::process::Command;

#[test]
fn generated_crate_builds_and_works() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("target/gen-crate-test/kepler-model");
    let _ = std::fs::remove_dir_all(&dir);
    let status = Command::new(env!("CARGO_BIN_EXE_lasalle"))
        .args(["gen", "models/kepler.lsl", "--crate"])
        .arg(&dir)
        .current_dir(root)
        .status()
        .expect("run lasalle gen");
    assert!(status.success());
    std::fs::create_dir_all(dir.join("tests")).unwrap();
    std::fs::write(
        dir.join("tests/smoke.rs"),
        r#"
use kepler_model::kepler::Kepler;
use lasalle_runtime::{Field, Invariants};
#[test]
fn kepler_from_the_generated_crate() {
    let m = Kepler::<f64>::default();
    let x = m.point_paper();
    let mut f = [0.0; 6];
    m.invariants(&x, &mut f);
    assert!((f[2] - 1.8f64.sqrt()).abs() < 1e-15 && (f[3] - 0.8).abs() < 1e-15);
    let mut dx = [0.0; 6];
    m.field(&x, &mut dx);
    assert_eq!(dx[3], -1.0);
}
"#,
    )
    .unwrap();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["test", "--offline", "--quiet"])
        .env(
            "CARGO_TARGET_DIR",
            root.join("target/gen-crate-test/target"),
        )
        .current_dir(&dir)
        .output()
        .expect("run cargo test in the generated crate");
    assert!(
        out.status.success(),
        "the generated crate failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
