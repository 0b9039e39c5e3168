//! Generated code builds outside this workspace with a plain `cargo build`:
//!
//! - `lasalle gen <model> --crate <dir>` writes a crate named after the model that depends on
//!   the runtime sources this lasalle was built from (a path relative to the crate) and
//!   carries this checkout's `Cargo.lock`; `cargo test` there builds it and runs a test that
//!   uses the model;
//! - a crate of a user's own, with `lasalle_codegen::Builder` in its `build.rs`, builds and
//!   passes its test the same way;
//! - `lasalle gen <model> --variational` writes the crate of the model's variational equations,
//!   and the Builder emits them next to the plain model;
//! - `lasalle gen <model> --families loops` writes the loop form of a model with families.
//!
//! Every build compiles the generated code without a warning.
//!
//! Both outside crates live under `target/gen-crate-test` and share one target directory, so
//! the second build reuses what the first compiled. Neither passes `--offline`: with this
//! checkout's lock, Cargo resolves without asking the registry and finds every crate in the
//! cache the workspace's build filled, so the builds work without a network — and the tests
//! check that Cargo did not update the registry index or download anything.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn lasalle_gen(args: &[&str]) -> Output {
    let args: Vec<&str> = std::iter::once("gen").chain(args.iter().copied()).collect();
    common::lasalle(&args)
}

/// A fresh directory `target/gen-crate-test/<name>`.
fn fresh(name: &str) -> PathBuf {
    let dir = root().join("target/gen-crate-test").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Plain `cargo <command>` in an outside crate (the target directory shared by the outside
/// crates): succeeds, without updating the registry index or downloading a crate.
fn cargo(dir: &Path, command: &str) {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .arg(command)
        .env(
            "CARGO_TARGET_DIR",
            root().join("target/gen-crate-test/target"),
        )
        .current_dir(dir)
        .output()
        .unwrap_or_else(|e| panic!("run cargo {command} in {}: {e}", dir.display()));
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(
        out.status.success(),
        "cargo {command} in {} failed:\n{stdout}\n{stderr}",
        dir.display()
    );
    for network in ["Updating", "Downloading"] {
        assert!(
            !stderr.contains(network),
            "cargo {command} in {} went to the registry:\n{stderr}",
            dir.display()
        );
    }
    // The generated code (and the runtime) compile without a warning.
    assert!(
        !stderr.contains("warning"),
        "cargo {command} in {} warned:\n{stderr}",
        dir.display()
    );
}

/// A test of the Kepler model of `models/kepler.lsl`, the struct at `path`.
fn kepler_test(path: &str) -> String {
    format!(
        r#"
use {path}::Kepler;
use lasalle_runtime::{{Field, Invariants}};
#[test]
fn kepler_from_outside() {{
    let m = Kepler::<f64>::default().prepare();
    let x = m.point_paper();
    let mut f = [0.0; 6];
    m.invariants(&x, &mut f);
    assert!((f[2] - 1.8f64.sqrt()).abs() < 1e-15 && (f[3] - 0.8).abs() < 1e-15);
    let mut dx = [0.0; 6];
    m.field(&x, &mut dx);
    assert_eq!(dx[3], -1.0);
}}
"#
    )
}

#[test]
fn a_generated_crate_builds_with_plain_cargo() {
    let work = fresh("orbit");
    // A file named after something else than its model: the crate is named after the model.
    std::fs::copy(root().join("models/kepler.lsl"), work.join("orbit.lsl")).unwrap();
    let out = lasalle_gen(&[
        "target/gen-crate-test/orbit/orbit.lsl",
        "--crate",
        "target/gen-crate-test/orbit/crate",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let dir = work.join("crate");
    let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
    assert!(manifest.contains("name = \"kepler-model\""), "{manifest}");
    // The runtime sources of this checkout, by a path relative to the crate.
    let path = manifest
        .split("lasalle-runtime = { path = \"")
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .unwrap_or_else(|| panic!("a path dependency: {manifest}"));
    assert!(path.starts_with("../"), "relative: {manifest}");
    assert_eq!(
        dir.join(path).canonicalize().unwrap(),
        root().join("runtime").canonicalize().unwrap()
    );
    assert!(
        stderr.contains("the runtime sources this lasalle was built from")
            && stderr.contains("Cargo.lock"),
        "says what it chose: {stderr}"
    );
    assert!(dir.join("Cargo.lock").is_file());
    std::fs::create_dir_all(dir.join("tests")).unwrap();
    std::fs::write(
        dir.join("tests/smoke.rs"),
        kepler_test("kepler_model::orbit"),
    )
    .unwrap();
    cargo(&dir, "build");
    cargo(&dir, "test");
}

#[test]
fn a_build_script_with_the_builder_builds_with_plain_cargo() {
    let dir = fresh("builder");
    std::fs::create_dir_all(dir.join("models")).unwrap();
    std::fs::create_dir_all(dir.join("src")).unwrap();
    std::fs::create_dir_all(dir.join("tests")).unwrap();
    std::fs::copy(
        root().join("models/kepler.lsl"),
        dir.join("models/kepler.lsl"),
    )
    .unwrap();
    std::fs::write(
        dir.join("models/oscillator.lsl"),
        "model Oscillator {\n    state q: scalar, p: scalar;\n    param w = 2;\n    \
         hamiltonian H = (p^2 + w^2 * q^2) / 2;\n    structure canonical(q, p);\n}\n",
    )
    .unwrap();
    // The crate docs' build script, with the paths of this checkout (relative to the crate).
    std::fs::write(
        dir.join("Cargo.toml"),
        "[package]\nname = \"orbits\"\nversion = \"0.1.0\"\nedition = \"2021\"\n\n\
         [dependencies]\nlasalle-runtime = { path = \"../../../runtime\" }\n\n\
         [build-dependencies]\nlasalle-codegen = { path = \"../../../codegen\" }\n\n\
         [workspace]\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("build.rs"),
        r#"fn main() {
    use lasalle_codegen::variational::Extension;
    let built = lasalle_codegen::Builder::new()
        .models_in("models")
        .model_extended("models/oscillator.lsl", Extension::Variational { tangents: 1 })
        .build();
    if let Err(e) = built {
        eprintln!("{e}");
        std::process::exit(1);
    }
}
"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("src/lib.rs"),
        "pub mod models {\n    include!(concat!(env!(\"OUT_DIR\"), \"/models.rs\"));\n}\n",
    )
    .unwrap();
    let oscillator = r#"
#[test]
fn oscillator_from_outside() {
    use lasalle_runtime::Field;
    let m = orbits::models::oscillator::Oscillator::<f64>::default();
    let mut dx = [0.0; 2];
    m.prepare().field(&[1.0, 0.0], &mut dx);
    assert_eq!(dx, [0.0, -4.0]);
}

#[test]
fn oscillator_tangent_from_outside() {
    use lasalle_runtime::Field;
    // (q, p, w_q, w_p): ẇ = DX·w = (w_p, −4 w_q)
    let m = orbits::models::oscillator_variational_1::OscillatorVariational1::<f64>::default();
    let mut dx = [0.0; 4];
    m.prepare().field(&[1.0, 0.0, 0.5, 0.25], &mut dx);
    assert_eq!(dx, [0.0, -4.0, 0.25, -2.0]);
}
"#;
    std::fs::write(
        dir.join("tests/smoke.rs"),
        kepler_test("orbits::models::kepler") + oscillator,
    )
    .unwrap();
    // What `lasalle gen` does for its crates: this checkout's lock, so Cargo resolves to the
    // versions the workspace's build fetched, without the registry's index.
    std::fs::copy(root().join("Cargo.lock"), dir.join("Cargo.lock")).unwrap();
    cargo(&dir, "build");
    cargo(&dir, "test");
}

/// Hénon–Heiles' field, H = (p² + q²)/2 + q₀²q₁ − q₁³/3, and its Jacobian DX written out:
/// the variational crate's field at (x, Φ = I) is (X, DX).
const HENON_HEILES_VARIATIONAL_TEST: &str = r#"
use henon_heiles_variational_model::henon_heiles_variational::HenonHeilesVariational;
use lasalle_runtime::Field;
#[test]
fn the_variational_field_is_x_and_its_jacobian() {
    let m = HenonHeilesVariational::<f64>::default().prepare();
    let x = m.point_chaotic();
    let (q0, q1) = (x[0], x[1]);
    let mut identity = [0.0; 16];
    (0..4).for_each(|i| identity[5 * i] = 1.0);
    assert_eq!(x[4..], identity);
    let mut dx = [0.0; 20];
    m.field(&x, &mut dx);
    let field = [x[2], x[3], -q0 - 2.0 * q0 * q1, -q1 - q0 * q0 + q1 * q1];
    // DX by columns (∂/∂q₀, ∂/∂q₁, ∂/∂p₀, ∂/∂p₁)
    let jacobian = [
        [0.0, 0.0, -1.0 - 2.0 * q1, -2.0 * q0],
        [0.0, 0.0, -2.0 * q0, -1.0 + 2.0 * q1],
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
    ];
    let want: Vec<f64> = field.iter().chain(jacobian.as_flattened()).copied().collect();
    for (k, (a, b)) in dx.iter().zip(&want).enumerate() {
        assert!((a - b).abs() <= 1e-15 * b.abs().max(1.0), "[{k}]: {a} vs {b}");
    }
}
"#;

#[test]
fn a_variational_crate_builds_with_plain_cargo() {
    let dir = fresh("variational");
    let out = lasalle_gen(&[
        "henon_heiles",
        "--variational",
        "--crate",
        "target/gen-crate-test/variational",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
    assert!(
        manifest.contains("name = \"henon-heiles-variational-model\""),
        "{manifest}"
    );
    std::fs::create_dir_all(dir.join("tests")).unwrap();
    std::fs::write(dir.join("tests/stm.rs"), HENON_HEILES_VARIATIONAL_TEST).unwrap();
    cargo(&dir, "build");
    cargo(&dir, "test");
}

/// The loop form of the N-body model of `models/` (5 bodies): its energy and momentum at its
/// point against the sums written out here from the point and the masses.
const NBODY_LOOPS_TEST: &str = r#"
use n_body_model::nbody::{NBody, DIM, INVARIANT_DIM};
use lasalle_runtime::{Declared, Field, Invariants};
#[test]
fn nbody_loops_from_outside() {
    let model = NBody::default();
    let m = model.prepare();
    let (_, x) = NBody::POINTS[0];
    let (g, mass) = (model.params[0], &model.params[1..]);
    let n = DIM / 6;
    let (q, p) = (&x[..3 * n], &x[3 * n..]);
    let mut energy = 0.0;
    let mut momentum = [0.0; 3];
    for i in 0..n {
        let pi = &p[3 * i..3 * i + 3];
        energy += (pi[0] * pi[0] + pi[1] * pi[1] + pi[2] * pi[2]) / (2.0 * mass[i]);
        for c in 0..3 {
            momentum[c] += pi[c];
        }
        for j in i + 1..n {
            let d: Vec<f64> = (0..3).map(|c| q[3 * i + c] - q[3 * j + c]).collect();
            let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            energy -= g * mass[i] * mass[j] / r;
        }
    }
    let mut f = [0.0; 7];
    m.invariants(&x, &mut f);
    assert!((f[0] - energy).abs() < 1e-14 * energy.abs(), "{} vs {energy}", f[0]);
    for c in 0..3 {
        assert!((f[1 + c] - momentum[c]).abs() < 1e-15, "P[{c}]");
    }
    // q̇ = p/m
    let mut dx = [0.0; DIM];
    m.field(&x, &mut dx);
    for k in 0..3 * n {
        assert!((dx[k] - p[k] / mass[k / 3]).abs() < 1e-15, "q̇[{k}]");
    }
    // Df: ∂H/∂p = p/m, ∂P_c/∂p = e_c, ∂P/∂q = 0
    let mut jac = [[f64::NAN; DIM]; INVARIANT_DIM];
    m.invariants_jacobian(&x, &mut jac);
    for k in 0..3 * n {
        assert!((jac[0][3 * n + k] - p[k] / mass[k / 3]).abs() < 1e-15, "∂H/∂p[{k}]");
        for c in 0..3 {
            assert_eq!(jac[1 + c][k], 0.0, "∂P/∂q");
            assert_eq!(jac[1 + c][3 * n + k], if k % 3 == c { 1.0 } else { 0.0 }, "∂P/∂p");
        }
    }
    // the half-fields: q̇ = p/m into q's components
    let half = m.partitioned().expect("canonical");
    let mut q_rate = [7.0; DIM];
    half.field_q(&x, &mut q_rate);
    assert_eq!(&q_rate[..3 * n], &dx[..3 * n]);
    assert!(q_rate[3 * n..].iter().all(|&v| v == 7.0));
}
"#;

#[test]
fn a_loop_form_crate_builds_with_plain_cargo() {
    let dir = fresh("loops");
    let out = lasalle_gen(&[
        "models/nbody.lsl",
        "--families",
        "loops",
        "--crate",
        "target/gen-crate-test/loops",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lib = std::fs::read_to_string(dir.join("src/lib.rs")).unwrap();
    assert!(lib.contains("for j in (i + 1)..5 {"), "{lib}");
    std::fs::create_dir_all(dir.join("tests")).unwrap();
    std::fs::write(dir.join("tests/nbody.rs"), NBODY_LOOPS_TEST).unwrap();
    cargo(&dir, "build");
    cargo(&dir, "test");
}

#[test]
fn a_runtime_path_is_written_as_given() {
    let dir = fresh("by-path");
    let out = lasalle_gen(&[
        "kepler",
        "--crate",
        "target/gen-crate-test/by-path",
        "--runtime-path",
        "../../../runtime",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
    assert!(
        manifest.contains("lasalle-runtime = { path = \"../../../runtime\" }"),
        "the path as given: {manifest}"
    );
    assert!(!dir.join("Cargo.lock").exists());
}

#[test]
fn on_request_the_crate_depends_on_the_runtime_by_version() {
    let dir = fresh("by-version");
    let out = lasalle_gen(&[
        "rigid_body",
        "--crate",
        "target/gen-crate-test/by-version",
        "--runtime-registry",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
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
    assert!(!dir.join("Cargo.lock").exists());
    // What to do where crates.io has no such version: the flag or the line, with the path.
    assert!(
        stderr.contains("--runtime-path ../../../runtime")
            && stderr.contains("lasalle-runtime = { path = \"../../../runtime\" }"),
        "{stderr}"
    );
}

#[test]
fn a_runtime_path_without_a_runtime_is_refused() {
    let out = lasalle_gen(&[
        "kepler",
        "--crate",
        "target/gen-crate-test/nowhere",
        "--runtime-path",
        "no/such/runtime",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--runtime-path no/such/runtime") && err.contains("relative to the crate"),
        "{err}"
    );
}
