//! The dump formats: JSON parses, CSV has a row per number, the table has the sections, the
//! emitted Rust compiles and agrees with the library.

mod common;

use lasalle_normal_form::validate::EARTH_MOON_MU;
use lasalle_normal_form::{NormalForm, Options};

fn nf() -> NormalForm {
    common::l4_normal_form(EARTH_MOON_MU, &Options::with_order(8)).unwrap()
}

#[test]
fn json_csv_table() {
    let nf = nf();
    let v: serde_json::Value = serde_json::from_str(&nf.to_json()).unwrap();
    assert_eq!(v["order"], 8);
    assert_eq!(
        v["hamiltonian"].as_array().unwrap().len(),
        nf.hamiltonian.len()
    );
    assert!(v["d4"]["d4"]["value"].as_f64().unwrap() < 0.0);
    let csv = nf.to_csv();
    let hbar_rows = csv.lines().filter(|l| l.starts_with("hbar,")).count();
    assert_eq!(hbar_rows, nf.hamiltonian.len());
    assert!(csv.lines().all(|l| l.split(',').count() == 7));
    let table = nf.to_table();
    for s in [
        "equilibrium",
        "linear frequencies",
        "normal form",
        "Arnold-Moser",
        "small divisors",
        "generating function",
    ] {
        assert!(table.contains(s), "missing {s}");
    }
}

#[test]
fn emitted_rust_compiles_and_agrees() {
    let nf = nf();
    let code = nf.to_rust().unwrap();
    let dir = std::env::temp_dir().join(format!("lasalle-nf-emit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let z0 = nf.from_normal(&[0.01, 0.0, 0.0, 0.01]).unwrap();
    let main = format!(
        "mod nf {{\n{code}\n}}\nfn main() {{\n let z0 = {z0:?};\n let z = nf::flow(&[z0[0], z0[1], z0[2], z0[3]], 7.5);\n let i = nf::actions(&[z0[0], z0[1], z0[2], z0[3]]);\n let nu = nf::frequencies(&i);\n println!(\"{{:?}} {{:?}} {{:?}} {{:?}}\", z, i, nu, nf::hbar(&i));\n}}\n"
    );
    let src = dir.join("main.rs");
    std::fs::write(&src, main).unwrap();
    let exe = dir.join("emitted");
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let status = std::process::Command::new(rustc)
        .args(["--edition", "2021", "-O", "-o"])
        .arg(&exe)
        .arg(&src)
        .status()
        .unwrap();
    assert!(status.success(), "emitted code does not compile");
    let out = String::from_utf8(std::process::Command::new(&exe).output().unwrap().stdout).unwrap();
    let nums: Vec<f64> = out
        .replace(['[', ']', ','], " ")
        .split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect();
    let z = nf.flow(&z0, 7.5).unwrap();
    let i = nf.actions(&z0).unwrap();
    let nu = nf.frequencies(&i);
    let expected: Vec<f64> = z
        .iter()
        .chain(&i)
        .chain(&nu)
        .copied()
        .chain([nf.energy_at(&i)])
        .collect();
    assert_eq!(nums.len(), expected.len());
    for (a, b) in nums.iter().zip(&expected) {
        assert!((a - b).abs() <= 1e-14 * b.abs().max(1e-3), "{a} vs {b}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
