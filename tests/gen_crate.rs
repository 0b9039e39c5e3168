//! `lasalle gen <model> --crate <dir>` writes a crate that another project can depend on:
//! named after the model, with no path of this checkout in its manifest unless one is asked
//! for. The test builds one (against this checkout's runtime through `--runtime-path`, so it
//! runs offline) and runs a test inside it that uses the generated model.

use std::path::Path;
use std::process::{Command, Output};

fn lasalle_gen(root: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lasalle"))
        .arg("gen")
        .args(args)
        .current_dir(root)
        .output()
        .expect("run lasalle gen")
}

#[test]
fn generated_crate_builds_and_works() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let work = root.join("target/gen-crate-test");
    let dir = work.join("orbit-crate");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&work).unwrap();
    // A file named after something else than its model: the crate is named after the model.
    std::fs::copy(root.join("models/kepler.lsl"), work.join("orbit.lsl")).unwrap();
    let out = lasalle_gen(
        root,
        &[
            "target/gen-crate-test/orbit.lsl",
            "--crate",
            "target/gen-crate-test/orbit-crate",
            "--runtime-path",
            "../../../runtime",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
    assert!(manifest.contains("name = \"kepler-model\""), "{manifest}");
    assert!(
        manifest.contains("lasalle-runtime = { path = \"../../../runtime\" }"),
        "the path as given: {manifest}"
    );
    std::fs::create_dir_all(dir.join("tests")).unwrap();
    std::fs::write(
        dir.join("tests/smoke.rs"),
        r#"
use kepler_model::orbit::Kepler;
use lasalle_runtime::{Field, Invariants};
#[test]
fn kepler_from_the_generated_crate() {
    let m = Kepler::<f64>::default();
    let x = m.point_paper();
    let mut f = [0.0; 6];
    m.invariants(&x, &mut f);
    assert!((f[2] - 1.8f64.sqrt()).abs() < 1e-15 && (f[3] - 0.8).abs() < 1e-15);
    let mut dx = [0.0; 6];
    m.prepare().field(&x, &mut dx);
    assert_eq!(dx[3], -1.0);
}
"#,
    )
    .unwrap();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["test", "--offline", "--quiet"])
        .env("CARGO_TARGET_DIR", work.join("target"))
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

#[test]
fn by_default_the_crate_depends_on_the_runtime_by_version() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("target/gen-crate-test/by-version");
    let _ = std::fs::remove_dir_all(&dir);
    let out = lasalle_gen(
        root,
        &["rigid_body", "--crate", "target/gen-crate-test/by-version"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
    assert!(
        manifest.contains("name = \"rigid-body-model\""),
        "{manifest}"
    );
    let version = env!("CARGO_PKG_VERSION");
    assert!(
        manifest.contains(&format!("lasalle-runtime = \"{version}\"")),
        "{manifest}"
    );
    assert!(
        !manifest.contains("path"),
        "no path of this checkout: {manifest}"
    );
}

#[test]
fn a_runtime_path_without_a_runtime_is_refused() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = lasalle_gen(
        root,
        &[
            "kepler",
            "--crate",
            "target/gen-crate-test/nowhere",
            "--runtime-path",
            "no/such/runtime",
        ],
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--runtime-path no/such/runtime") && err.contains("relative to the crate"),
        "{err}"
    );
}
