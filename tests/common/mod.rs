//! What the end-to-end tests share (`mod common;` in each test file): running the `lasalle`
//! binary, bitwise comparison of results, the tapes of a model file.

// each test file uses some of these
#![allow(dead_code)]

use std::process::{Command, Output};

use lasalle_codegen::tape::ModelTapes;

/// Runs the `lasalle` binary (from the package root, as cargo runs the tests).
pub fn lasalle(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lasalle"))
        .args(args)
        .output()
        .expect("the lasalle binary runs")
}

/// Runs the `lasalle` binary under util-linux's `script`, so that its standard streams are a
/// pseudo-terminal, as at a user's terminal; its standard output is discarded, and what the
/// terminal shows (standard error) is the output's `stdout`. `None` where `script` is missing.
pub fn lasalle_on_terminal(args: &[&str]) -> Option<Output> {
    let have_script = Command::new("script")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !have_script {
        return None;
    }
    let quoted: Vec<String> = std::iter::once(env!("CARGO_BIN_EXE_lasalle"))
        .chain(args.iter().copied())
        .map(|a| format!("'{}'", a.replace('\'', "'\\''")))
        .collect();
    let cmd = format!("{} > /dev/null", quoted.join(" "));
    Some(
        Command::new("script")
            .args(["-qec", &cmd, "/dev/null"])
            .output()
            .expect("script runs"),
    )
}

/// Runs the `lasalle` binary: (success, standard output, standard error).
pub fn lasalle_text(args: &[&str]) -> (bool, String, String) {
    let out = lasalle(args);
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The tapes of a model file of `models/`, built as `generate_file` builds the emitted code.
pub fn tapes(file: &str) -> (lasalle_codegen::Model, ModelTapes) {
    let path = format!("{}/models/{file}", env!("CARGO_MANIFEST_DIR"));
    let model = lasalle_codegen::load_model(&path).unwrap();
    let derived = lasalle_codegen::derive(model);
    lasalle_codegen::check(&derived).unwrap();
    let tapes = ModelTapes::new(&derived).unwrap();
    (derived.model, tapes)
}

/// Runs the `lasalle` binary, killed after `seconds` (a hang is a failure, not a stuck test
/// run): `None` if it had to be killed.
pub fn lasalle_within(args: &[&str], seconds: u64) -> Option<Output> {
    use std::time::{Duration, Instant};
    let mut child = Command::new(env!("CARGO_BIN_EXE_lasalle"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the lasalle binary runs");
    let start = Instant::now();
    while child.try_wait().expect("wait for lasalle").is_none() {
        if start.elapsed() > Duration::from_secs(seconds) {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    Some(child.wait_with_output().expect("lasalle's output"))
}
