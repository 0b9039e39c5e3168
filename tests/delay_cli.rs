//! `lasalle run models/delay.lsl`: LaSalle's delay equation ẋ = a x + b x(t − r) grows for
//! a = 0.5, b = 0.3 and decays for a = −0.5, at the rate of the characteristic root; the
//! compiled model (`build.rs`) runs the same delay as the loaded one; the errors are located
//! and exit with code 2.

use lasalle::models::delay::Delay;
use lasalle::run::{simulate, RunSpec};
use lasalle::{Declared, LoadedModel};
use std::process::{Command, Output};

/// Runs the `lasalle` binary.
fn lasalle(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lasalle"))
        .args(args)
        .output()
        .expect("the lasalle binary runs")
}

/// Runs the `lasalle` binary: (success, standard output, standard error).
fn lasalle_text(args: &[&str]) -> (bool, String, String) {
    let out = lasalle(args);
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn model_file() -> String {
    format!("{}/models/delay.lsl", env!("CARGO_MANIFEST_DIR"))
}

/// The rate the summary prints: `…: grows, rate 0.655720 (…`.
fn rate(stdout: &str, verdict: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.contains(&format!(": {verdict}, rate ")))
        .unwrap_or_else(|| panic!("no `{verdict}` in:\n{stdout}"));
    let after = line.split("rate ").nth(1).expect("a rate");
    after.split_whitespace().next().unwrap().parse().unwrap()
}

#[test]
fn the_summary_says_grows_or_decays_at_the_characteristic_rate() {
    let dir = std::env::temp_dir().join(format!("lasalle-delay-cli-{}", std::process::id()));
    let out = dir.to_str().unwrap();
    let file = model_file();
    for (a, verdict, root) in [
        ("a=0.5", "grows", 0.655_720_397_737),
        ("a=-0.5", "decays", -0.151_074_877_065),
    ] {
        let args = ["run", &file, "--param", a, "--t-end", "10", "--out", out];
        let (ok, stdout, stderr) = lasalle_text(&args);
        assert!(ok, "{stderr}");
        assert!(
            stdout.contains("method of steps: `delay(x, r)` with delay 1"),
            "{stdout}"
        );
        let r = rate(&stdout, verdict);
        assert!((r - root).abs() < 1e-5, "{a}: {r}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_compiled_model_runs_the_same_delay() {
    let mut compiled = Delay::<f64>::default().prepare();
    let mut loaded = LoadedModel::load(model_file(), lasalle::Backend::Jit).unwrap();
    let key = |d: &lasalle::DelaySpec| (d.text, d.component, d.slot, d.clock);
    let c: Vec<_> = Declared::<f64, [f64; 3]>::delays(&compiled)
        .iter()
        .map(key)
        .collect();
    let l: Vec<_> = Declared::<f64, Vec<f64>>::delays(&loaded)
        .iter()
        .map(key)
        .collect();
    assert_eq!(c, l);
    assert_eq!(c, [("delay(x, r)", 0, 2, 1)]);
    let grid = [1.0, 2.0, 5.0];
    let preset = loaded.preset("steps").cloned();
    let b = || {
        RunSpec::from_preset(preset.as_ref())
            .rtol(1e-12)
            .atol(1e-14)
            .t_eval(grid.to_vec())
    };
    let (spec, x0) = b().prepare(&mut loaded).unwrap();
    let want = simulate(&loaded, &x0, &spec).unwrap();
    let (spec, y0) = b().prepare(&mut compiled).unwrap();
    let y0: [f64; 3] = y0.try_into().unwrap();
    let got = simulate(&compiled, &y0, &spec).unwrap();
    for (i, t) in grid.iter().enumerate() {
        let (w, g) = (want.x[i * 3], got.x[i * 3]);
        assert!((w - g).abs() < 1e-12 * w.abs(), "t = {t}: {w} vs {g}");
    }
    // x(1) = (1 + b/a) e^{a} − b/a with a = 0.5, b = 0.3
    let exact = 1.6 * 0.5f64.exp() - 0.6;
    assert!((got.x[0] - exact).abs() < 1e-10, "{}", got.x[0]);
}

#[test]
fn delay_errors_are_located_and_exit_2() {
    let file = model_file();
    let rows: &[(&[&str], &str)] = &[
        (
            &["-m", "rk4", "--dt", "0.01"],
            "has none here: give -m dopri5",
        ),
        (&["-m", "taylor"], "has none here: give -m dopri5"),
        (&["--param", "r=0"], "must be a positive constant"),
        (&["--t-end", "-1"], "integrates forwards"),
    ];
    for (extra, message) in rows {
        let mut args = vec!["run", file.as_str()];
        args.extend_from_slice(extra);
        let out = lasalle(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {stderr}");
        assert!(
            stderr.contains("delay.lsl:16:26") && stderr.contains(message),
            "{extra:?}: {stderr}"
        );
    }
}
