//! Families from the command line: the Pleiades written as a family reproduce the IVP test
//! set's reference solution as the model written pair by pair does, the FPUT chain of
//! `models/fput.lsl` conserves its energy, the heat equation's first mode decays as its closed
//! form, and the N-body family of `models/nbody.lsl` loads and runs at a size given by
//! editing its `param n` line.

mod common;

use std::path::PathBuf;

use common::lasalle;
use lasalle_testkit::PLEIADES_AT_3;

const PLEIADES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/models/pleiades.lsl");

/// The Pleiades as a family: the layout q = (x₁…x₇, y₁…y₇) and point of the written model.
const PLEIADES_FAMILY: &str = "model PleiadesFamily {
    param n = 7;
    state q: scalar[2 * n], p: scalar[2 * n];
    hamiltonian H = sum(i in 0..n: (p[i]^2 + p[n + i]^2) / (2 * (i + 1)))
        - sum(i in 0..n, j in i+1..n: (i + 1) * (j + 1) / sqrt((q[i] - q[j])^2 + (q[n + i] - q[n + j])^2));
    structure canonical(q, p);
    integral P = [sum(i in 0..n: p[i]), sum(i in 0..n: p[n + i])];
    integral L = sum(i in 0..n: q[i] * p[n + i] - q[n + i] * p[i]);
    point start { q = [3, 3, -1, -3, 2, -2, 2, 3, -3, 2, 0, 0, -4, 4]; p = [0, 0, 0, 0, 0, 10.5, -10.5, 0, 0, 0, -5, 5, 0, 0]; }
}";

fn dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("families")
        .join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `text` as `name.lsl` in a directory of its own.
fn model_file(name: &str, text: &str) -> String {
    let path = dir(name).join(format!("{name}.lsl"));
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// `lasalle run` with `args`: its summary.json (the run must succeed).
fn run(name: &str, args: &[&str]) -> serde_json::Value {
    let out = dir(name).join("out");
    let out = out.to_str().unwrap();
    let mut all = vec!["run"];
    all.extend(args);
    all.extend(["--format", "json", "--out", out]);
    let o = lasalle(&all);
    assert!(
        o.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_str(&std::fs::read_to_string(format!("{out}/summary.json")).unwrap()).unwrap()
}

fn final_state(s: &serde_json::Value) -> Vec<f64> {
    s["final_state"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect()
}

fn max_error(s: &serde_json::Value, invariant: &str) -> f64 {
    s["invariant_errors"][invariant]["max"].as_f64().unwrap()
}

#[test]
fn pleiades_family_meets_the_ivp_test_set_as_the_written_model() {
    let family = model_file("pleiades_family", PLEIADES_FAMILY);
    let args = |m: &str| -> Vec<String> {
        [
            m, "-m", "taylor", "--rtol", "1e-13", "--t-end", "3", "--init", "start",
        ]
        .map(String::from)
        .to_vec()
    };
    let a: Vec<String> = args(&family);
    let b: Vec<String> = args(PLEIADES);
    let s_family = run(
        "pleiades_family",
        &a.iter().map(String::as_str).collect::<Vec<_>>(),
    );
    let s_written = run(
        "pleiades_written",
        &b.iter().map(String::as_str).collect::<Vec<_>>(),
    );
    let (x, y) = (final_state(&s_family), final_state(&s_written));
    for (i, (&r, (&xi, &yi))) in PLEIADES_AT_3.iter().zip(x.iter().zip(&y)).enumerate() {
        // velocities are p / m, m_i = i
        let v = if i < 14 {
            xi
        } else {
            xi / ((i % 7) + 1) as f64
        };
        assert!((v - r).abs() < 1e-8, "component {i}: {v} against {r}");
        assert_eq!(xi.to_bits(), yi.to_bits(), "component {i}: {xi} {yi}");
    }
    assert!(max_error(&s_family, "H") < 1e-9);
}

#[test]
fn fput_conserves_its_energy() {
    // the model's preset: Störmer–Verlet, dt = 0.05, to t = 1000
    let s = run("fput", &["fput"]);
    let e = max_error(&s, "H");
    // the energy of the first mode: ω₁² Σ sin²(π(i+1)/(n+1)) / 2 = ω₁² (n+1) / 4 ≈ 0.037
    assert!(e > 0.0 && e < 1e-4, "|ΔH| = {e:e}");
    let s = run(
        "fput-dopri",
        &["fput", "-m", "dopri5", "--rtol", "1e-12", "--t-end", "100"],
    );
    // an explicit method drifts, slowly at this tolerance (|ΔH| / H ≈ 5e-9 at t = 100)
    assert!(max_error(&s, "H") < 1e-9, "{}", max_error(&s, "H"));
}

#[test]
fn heat_equation_first_mode_decays_as_its_closed_form() {
    let text = "model Heat {
        param n = 32;
        state u: scalar[n];
        param kappa = 1;
        let h = 1 / (n + 1);
        for i in 1..n-1: d/dt u[i] = kappa * (u[i-1] - 2 * u[i] + u[i+1]) / h^2;
        d/dt u[0] = kappa * (u[1] - 2 * u[0]) / h^2;
        d/dt u[n-1] = kappa * (u[n-2] - 2 * u[n-1]) / h^2;
        point mode1 { u = [i in 0..n: sin(3.141592653589793 * (i + 1) / (n + 1))]; }
    }";
    let file = model_file("heat", text);
    let t = 0.05;
    let s = run(
        "heat",
        &[
            &file, "-m", "dopri5", "--rtol", "1e-12", "--atol", "1e-14", "--t-end", "0.05",
            "--init", "mode1",
        ],
    );
    let u = final_state(&s);
    let n = 32;
    let h = 1.0 / (n + 1) as f64;
    let pi = std::f64::consts::PI;
    let lambda = 4.0 / (h * h) * (pi * h / 2.0).sin().powi(2);
    // the semi-discrete decay rate is the continuous one, π², to O(h²)
    assert!((lambda - pi * pi).abs() < pi.powi(4) * h * h / 12.0 * 1.01);
    for (i, ui) in u.iter().enumerate() {
        let exact = (-lambda * t).exp() * (pi * (i + 1) as f64 * h).sin();
        assert!(
            (ui - exact).abs() < 1e-10,
            "u[{i}] = {ui}, closed form {exact}"
        );
    }
}

#[test]
fn nbody_size_is_one_line() {
    let text = include_str!("../models/nbody.lsl");
    assert_eq!(text.matches("param n = 5;").count(), 1);
    let file = model_file("nbody16", &text.replace("param n = 5;", "param n = 16;"));
    let s = run(
        "nbody16",
        &[&file, "-m", "dopri5", "--rtol", "1e-12", "--t-end", "1"],
    );
    assert_eq!(final_state(&s).len(), 96);
    // dopri5 at rtol 1e-12 conserves none of them exactly; P (a sum of the field) to rounding
    for (name, bound) in [("H", 1e-8), ("P", 1e-12), ("L", 1e-10)] {
        let e = max_error(&s, name);
        assert!(e < bound, "{name}: {e:e}");
    }
    // the size is a constant of the model, not a run-time parameter
    let o = lasalle(&["run", &file, "--param", "n=3", "--t-end", "0.1"]);
    assert!(!o.status.success());
}

/// The Pleiades with their masses as a parameter family, so that both sums of H are loops
/// (`--families loops`): the explicit method on the loop field meets the IVP test set's
/// reference, as the unrolled model does.
#[test]
fn pleiades_as_loops_meet_the_ivp_test_set() {
    let file = model_file("pleiades_loops", &pleiades_loops_text());
    let args = |families| {
        [
            file.as_str(),
            "-m",
            "dopri5",
            "--rtol",
            "1e-14",
            "--atol",
            "1e-14",
            "--t-end",
            "3",
            "--init",
            "start",
            "--families",
            families,
        ]
    };
    let loops = final_state(&run("pleiades_loops", &args("loops")));
    let unrolled = final_state(&run("pleiades_unrolled", &args("unrolled")));
    meets_reference(&loops, &unrolled);
}

/// The Taylor method on the loop form of the field (`-m taylor --families loops`): the
/// Pleiades meet the IVP test set's reference, and the unrolled model's Taylor run to 1e-9.
#[test]
fn pleiades_taylor_as_loops_meets_the_ivp_test_set() {
    let file = model_file("pleiades_taylor_loops", &pleiades_loops_text());
    let args = |families| {
        [
            file.as_str(),
            "-m",
            "taylor",
            "--rtol",
            "1e-14",
            "--t-end",
            "3",
            "--init",
            "start",
            "--families",
            families,
        ]
    };
    let loops = run("pleiades_taylor_loops", &args("loops"));
    let unrolled = run("pleiades_taylor_unrolled", &args("unrolled"));
    // the same orders and steps: the coefficients differ by rounding only
    assert_eq!(loops["steps"], unrolled["steps"]);
    meets_reference(&final_state(&loops), &final_state(&unrolled));
}

/// The Pleiades with their masses as a parameter family, so that both sums of H are loops.
fn pleiades_loops_text() -> String {
    let text = PLEIADES_FAMILY
        .replace("model PleiadesFamily {", "model PleiadesLoops {")
        .replace(
            "state q: scalar[2 * n], p: scalar[2 * n];",
            "state q: scalar[2 * n], p: scalar[2 * n];\n    param m: scalar[n] = [i in 0..n: i + 1];",
        )
        .replace("/ (2 * (i + 1))", "/ (2 * m[i])")
        .replace("(i + 1) * (j + 1) / sqrt", "m[i] * m[j] / sqrt");
    assert!(text.contains("m[i] * m[j]"));
    text
}

/// Final states of the loop form and the unrolled model (x, y, p_x, p_y) against the IVP test
/// set's reference (positions and velocities) and each other.
fn meets_reference(loops: &[f64], unrolled: &[f64]) {
    for (i, &r) in PLEIADES_AT_3.iter().enumerate() {
        let v = |x: &[f64]| {
            if i < 14 {
                x[i]
            } else {
                x[i] / ((i % 7) + 1) as f64
            }
        };
        assert!(
            (v(loops) - r).abs() < 1e-9,
            "component {i}: {} against {r}",
            v(loops)
        );
        assert!((v(loops) - v(unrolled)).abs() < 1e-9, "component {i}");
    }
}

/// A sum the loop form cannot take (squared) is refused with its place, not approximated.
#[test]
fn a_sum_the_loop_form_cannot_take_is_refused() {
    let text = "model Squared {\n    param n = 4;\n    state q: scalar[n], p: scalar[n];\n    \
                hamiltonian H = sum(i in 0..n: p[i]^2 / 2 + q[i]^2 / 2);\n    \
                structure canonical(q, p);\n    integral S = sum(i in 0..n: q[i] * p[i])^2;\n    \
                point start { q = [i in 0..n: 1]; p = [i in 0..n: 0]; }\n}\n";
    let file = model_file("squared", text);
    let o = lasalle(&[
        "run",
        &file,
        "-m",
        "rk4",
        "--dt",
        "0.1",
        "--t-end",
        "1",
        "--families",
        "loops",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("squared.lsl:6") && err.contains("constant coefficient"),
        "{err}"
    );
}

/// The N-body family loaded with its families as loops integrates with the methods that need
/// its derived functions — X − ∇V (feedback-euler, feedback-rk4), the half-fields
/// (stormer-verlet-b) and Df (projection-rk4, which projects onto the integrals' level set
/// along Df) — as the unrolled model does, to rounding; and each does what it is for: the
/// feedback keeps the integrals far closer than the plain method, the projection keeps them to
/// rounding.
#[test]
fn nbody_as_loops_integrates_with_its_derived_functions() {
    let text = include_str!("../models/nbody.lsl").replace("param n = 5;", "param n = 6;");
    let file = model_file("nbody6", &text);
    let summary = |method: &str, families: &str| {
        let mut args = vec![
            file.as_str(),
            "-m",
            method,
            "--dt",
            "1e-3",
            "--t-end",
            "1",
            "--families",
            families,
        ];
        if method.starts_with("feedback") {
            args.extend(["--gains", "10,10,10"]);
        }
        run(&format!("nbody6_{method}_{families}"), &args)
    };
    let euler_h = max_error(&summary("euler", "loops"), "H");
    assert!(euler_h > 1e-5, "{euler_h}");
    for method in [
        "feedback-euler",
        "feedback-rk4",
        "stormer-verlet-b",
        "projection-rk4",
    ] {
        let (loops, unrolled) = (summary(method, "loops"), summary(method, "unrolled"));
        let (a, b) = (final_state(&loops), final_state(&unrolled));
        assert_eq!(a.len(), 36);
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!(
                (x - y).abs() <= 1e-12 * y.abs().max(1.0),
                "{method}, component {i}: loops {x}, unrolled {y}"
            );
        }
        for inv in ["H", "P", "L"] {
            let (x, y) = (max_error(&loops, inv), max_error(&unrolled, inv));
            assert!(
                (x - y).abs() <= 1e-6 * y + 1e-14,
                "{method}, {inv}: loops {x}, unrolled {y}"
            );
            if method == "projection-rk4" {
                assert!(x < 1e-13, "{method}, {inv}: {x}");
            }
        }
        if method == "feedback-euler" {
            assert!(max_error(&loops, "H") < euler_h / 3.0);
        }
    }
}

/// The Taylor method on X − ∇V with its program in loop form (`-m feedback-taylor --families
/// loops`, the three stages of X − ∇V propagated as Taylor series): the 6-body family and an
/// FPUT chain take the unrolled model's steps (to one, at the end) and end at its final state to
/// the tolerance, with the integrals kept as tightly.
#[test]
fn feedback_taylor_as_loops_is_the_unrolled_run() {
    let nbody = include_str!("../models/nbody.lsl").replace("param n = 5;", "param n = 6;");
    let fput = include_str!("../models/fput.lsl")
        .replace("param n = 16;", "param n = 12;")
        .replace("param beta = 0;", "param beta = 0.7;");
    for (name, text, t_end, invariants) in [
        ("nbody6_fbtaylor", nbody, "2", &["H", "P", "L"][..]),
        ("fput12_fbtaylor", fput, "5", &["H"][..]),
    ] {
        let file = model_file(name, &text);
        let summary = |families: &str| {
            let args = [
                file.as_str(),
                "-m",
                "feedback-taylor",
                "--rtol",
                "1e-13",
                "--t-end",
                t_end,
                "--families",
                families,
            ];
            run(&format!("{name}_{families}"), &args)
        };
        let (loops, unrolled) = (summary("loops"), summary("unrolled"));
        assert_eq!(loops["method"], "feedback-taylor");
        // the step sizes differ by rounding, so a step may fall on either side of t_end
        let steps = |s: &serde_json::Value| s["steps"].as_i64().unwrap();
        assert!(
            (steps(&loops) - steps(&unrolled)).abs() <= 1,
            "{name}: steps"
        );
        let (a, b) = (final_state(&loops), final_state(&unrolled));
        assert_eq!(a.len(), b.len());
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!(
                (x - y).abs() <= 1e-11 * y.abs().max(1.0),
                "{name}, component {i}: loops {x}, unrolled {y}"
            );
        }
        for inv in invariants {
            let (x, y) = (max_error(&loops, inv), max_error(&unrolled, inv));
            assert!(
                x < 1e-11 && y < 1e-11,
                "{name}, {inv}: loops {x}, unrolled {y}"
            );
        }
    }
}

/// `--families` is one flag with one help text on every subcommand that loads a model file,
/// and it takes effect there: `bench-eval --families loops` times the loop kernel of X − ∇V,
/// `--families unrolled` the unrolled tape.
#[test]
fn families_is_the_same_flag_on_every_subcommand_that_loads_a_model() {
    let help = |sub: &str| {
        let o = lasalle(&[sub, "--help"]);
        assert!(o.status.success(), "{sub}");
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let start = text
            .find("--families <FAMILIES>")
            .unwrap_or_else(|| panic!("`{sub}` has no --families:\n{text}"));
        let rest = &text[start..];
        let end = rest
            .find("[default: auto]")
            .unwrap_or_else(|| panic!("`{sub}`: --families has no default:\n{rest}"));
        rest[..end].to_string()
    };
    let run = help("run");
    for value in ["auto:", "loops:", "unrolled:"] {
        assert!(run.contains(value), "{run}");
    }
    for sub in ["sweep", "stability", "bench-eval", "section"] {
        assert_eq!(help(sub), run, "{sub}");
    }
    let text = include_str!("../models/nbody.lsl").replace("param n = 5;", "param n = 4;");
    let file = model_file("nbody4_bench", &text);
    let what = |families: &str| {
        let o = lasalle(&[
            "bench-eval",
            &file,
            "--families",
            families,
            "--lanes",
            "1",
            "--states",
            "4",
            "--repeat",
            "1",
            "--seconds",
            "0.01",
            "--format",
            "json",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert!(v["ns_per_state"]["1"].as_f64().unwrap() > 0.0);
        v["what"].as_str().unwrap().to_string()
    };
    assert!(what("loops").contains("families as loops"));
    assert!(!what("unrolled").contains("loops"));
}
