//! Events, output times and Poincaré sections end to end: `lasalle run` writes `events.csv`
//! and samples `--t-eval`, a terminal event ends a run successfully, `lasalle section` puts
//! its points on the energy level and on the section plane, and every mistake is one located
//! line with exit code 2.

mod common;

use common::lasalle_text;

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("lasalle-events-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn read_csv(path: &std::path::Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = split(lines.next().unwrap());
    (header, lines.map(split).collect())
}

/// Splits a CSV line, honouring quotes (`"q[0,1]"`).
fn split(line: &str) -> Vec<String> {
    let (mut out, mut cell, mut quoted) = (Vec::new(), String::new(), false);
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cell)),
            c => cell.push(c),
        }
    }
    out.push(cell);
    out
}

/// Hénon–Heiles' Hamiltonian, written out here independently of the model file.
fn henon_heiles(q0: f64, q1: f64, p0: f64, p1: f64) -> f64 {
    (p0 * p0 + p1 * p1 + q0 * q0 + q1 * q1) / 2.0 + q0 * q0 * q1 - q1.powi(3) / 3.0
}

#[test]
fn section_points_lie_on_the_level_and_the_plane() {
    let dir = scratch("section");
    let out = dir.to_str().unwrap();
    let (ok, stdout, stderr) = lasalle_text(&[
        "section",
        "henon_heiles",
        "--event",
        "section",
        "--energy",
        "0.125",
        "--solve",
        "p[0]",
        "--grid",
        "q[1]=-0.3:0.5:5",
        "--grid",
        "p[1]=0,0.1",
        "--axes",
        "q[1],p[1]",
        "--t-end",
        "300",
        "--out",
        out,
    ]);
    assert!(ok, "{stdout}\n{stderr}");
    assert!(stdout.contains("10 orbits"), "{stdout}");
    let (header, rows) = read_csv(&dir.join("section.csv"));
    assert_eq!(header, ["orbit", "t", "q[0]", "q[1]", "p[0]", "p[1]", "H"]);
    assert!(rows.len() > 300, "{} points", rows.len());
    let mut orbits = std::collections::BTreeSet::new();
    for row in &rows {
        let v: Vec<f64> = row[1..].iter().map(|c| c.parse().unwrap()).collect();
        let (q0, q1, p0, p1) = (v[1], v[2], v[3], v[4]);
        assert!(q0.abs() < 1e-12, "q0 = {q0:e}: off the plane");
        assert!(p0 > 0.0, "p0 = {p0}: crossed downwards");
        let e = henon_heiles(q0, q1, p0, p1);
        assert!((e - 0.125).abs() < 1e-10, "H = {e}");
        orbits.insert(row[0].clone());
    }
    assert_eq!(orbits.len(), 10);
    for figure in ["section.svg", "section.png"] {
        assert!(std::fs::metadata(dir.join(figure)).unwrap().len() > 1000);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn run_writes_events_and_samples_output_times() {
    let dir = scratch("run");
    let out = dir.to_str().unwrap();
    let (ok, stdout, stderr) = lasalle_text(&[
        "run",
        "henon_heiles",
        "-m",
        "dopri5",
        "--rtol",
        "1e-12",
        "--atol",
        "1e-12",
        "--t-end",
        "50",
        "--t-eval",
        "0:50:101",
        "--out",
        out,
    ]);
    assert!(ok, "{stdout}\n{stderr}");
    assert!(stdout.contains("event crossings (events.csv)"), "{stdout}");
    let (header, rows) = read_csv(&dir.join("events.csv"));
    assert_eq!(header, ["event", "t", "q[0]", "q[1]", "p[0]", "p[1]", "H"]);
    assert!(rows.len() >= 5, "{rows:?}");
    for row in &rows {
        assert_eq!(row[0], "section");
        let q0: f64 = row[2].parse().unwrap();
        assert!(q0.abs() < 1e-12);
    }
    let (_, trace) = read_csv(&dir.join("trace.csv"));
    let times: Vec<f64> = trace.iter().map(|r| r[0].parse().unwrap()).collect();
    assert_eq!(times.len(), 101);
    for (k, t) in times.iter().enumerate() {
        assert!((t - 0.5 * k as f64).abs() < 1e-12, "{t}");
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["events"]["counts"]["section"], rows.len());
    assert!(summary["events"]["stopped_by"].is_null());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The oscillator x = cos t with a terminal event at x = −1/2 going down (t = 2π/3): exit 0,
/// the event and its time in summary.json, the trace ending there.
#[test]
fn a_terminal_event_is_a_successful_end() {
    let dir = scratch("stop");
    let model = dir.join("osc.lsl");
    std::fs::write(
        &model,
        "model Osc {\n    state x: scalar, v: scalar;\n    d/dt x = v;\n    d/dt v = -x;\n    \
         event low: x + 0.5 = 0 falling stop;\n    point start { x = 1; v = 0; }\n}\n",
    )
    .unwrap();
    let out = dir.join("out");
    let (ok, stdout, stderr) = lasalle_text(&[
        "run",
        model.to_str().unwrap(),
        "-m",
        "taylor",
        "--rtol",
        "1e-15",
        "--t-end",
        "10",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stdout}\n{stderr}");
    assert!(stdout.contains("stopped by event `low`"), "{stdout}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let t = summary["events"]["stopped_by"]["t"].as_f64().unwrap();
    assert_eq!(summary["events"]["stopped_by"]["event"], "low");
    assert!((t - 2.0 * std::f64::consts::PI / 3.0).abs() < 1e-13, "{t}");
    assert_eq!(summary["t_final"].as_f64().unwrap(), t);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Mistakes in the model file and on the command line: one line, located, exit code 2 for
/// the command line.
#[test]
fn mistakes_are_refused_with_a_located_message() {
    let dir = scratch("mistakes");
    let base =
        "model Osc {\n    state x: vec2;\n    d/dt x = -x;\n    point start { x = [1, 0]; }\n";
    let cases = [
        ("event e: x = 0;", "scalar"),
        ("event e: y[0] = 0;", "`y`"),
        ("event e: x[0] = 1;", "right side must be 0"),
        (
            "event e: x[0] = 0 upwards;",
            "`rising`, `falling`, `stop` or `;`",
        ),
        (
            "event e: x[0] = 0;\n    event e: x[1] = 0;",
            "a second event `e`",
        ),
        (
            "event e: x[0] = 0 stop rising;",
            "`rising`, `falling`, `stop` or `;`",
        ),
    ];
    for (k, (item, message)) in cases.iter().enumerate() {
        let path = dir.join(format!("bad{k}.lsl"));
        std::fs::write(&path, format!("{base}    {item}\n}}\n")).unwrap();
        let (ok, _, stderr) = lasalle_text(&[
            "run",
            path.to_str().unwrap(),
            "-m",
            "rk4",
            "--dt",
            "0.1",
            "--t-end",
            "1",
        ]);
        assert!(!ok, "{item}");
        assert!(stderr.contains(message), "{item}: {stderr}");
        // the second of two items is on line 6
        let line = if item.contains('\n') { 6 } else { 5 };
        assert!(
            stderr.contains(&format!("bad{k}.lsl:{line}:")),
            "{item}: not located: {stderr}"
        );
    }
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    for (args, message) in [
        (
            &["run", "henon_heiles", "--t-eval", "0:1", "--out", out][..],
            "--t-eval",
        ),
        (
            &["run", "henon_heiles", "--t-eval", "5,1", "--out", out],
            "increase",
        ),
        (
            &["run", "henon_heiles", "--t-eval", "0:200:3", "--out", out],
            "outside",
        ),
        (
            &[
                "run",
                "henon_heiles",
                "--t-eval",
                "0:1:3",
                "--every",
                "2",
                "--out",
                out,
            ],
            "--every",
        ),
        (
            &[
                "section",
                "henon_heiles",
                "--event",
                "section",
                "--grid",
                "q[1]=-0.4:0.6:1",
                "--axes",
                "q[1],p[1]",
                "--t-end",
                "1",
                "--out",
                out,
            ],
            // the message of `sweep --grid` (tests/cli.rs): one parser
            "invalid --grid `q[1]=-0.4:0.6:1`: one value from -0.4 to 0.6: give start = stop, or the value alone",
        ),
        (
            &[
                "section",
                "henon_heiles",
                "--event",
                "nope",
                "--axes",
                "q[1],p[1]",
                "--t-end",
                "1",
                "--out",
                out,
            ],
            "declares no event `nope`; its events: section",
        ),
        (
            &[
                "section",
                "henon_heiles",
                "--event",
                "section",
                "--energy",
                "0.1",
                "--axes",
                "q[1],p[1]",
                "--t-end",
                "1",
                "--out",
                out,
            ],
            "--energy and --solve",
        ),
        (
            &[
                "section",
                "henon_heiles",
                "--event",
                "section",
                "--energy",
                "0.1",
                "--solve",
                "p[9]",
                "--axes",
                "q[1],p[1]",
                "--t-end",
                "1",
                "--out",
                out,
            ],
            "--solve `p[9]`",
        ),
        (
            &[
                "section",
                "henon_heiles",
                "--event",
                "section",
                "--axes",
                "q[1]",
                "--t-end",
                "1",
                "--out",
                out,
            ],
            "--axes",
        ),
        (
            &[
                "section",
                "henon_heiles",
                "--event",
                "section",
                "--energy",
                "-1",
                "--solve",
                "p[0]",
                "--grid",
                "q[1]=0",
                "--axes",
                "q[1],p[1]",
                "--t-end",
                "1",
                "--out",
                out,
            ],
            "reaches the level",
        ),
    ] {
        let (ok, _, stderr) = lasalle_text(args);
        assert!(!ok, "{args:?}");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The emitted Rust of a compiled model computes its event functions bitwise as the JIT and
/// the interpreter do, and declares the same events.
#[test]
fn emitted_jit_and_interpreter_event_values_agree_bitwise() {
    use lasalle::models::cr3bp::CR3BP;
    use lasalle::{Backend, Declared, LoadedModel};
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/cr3bp.lsl");
    let jit = LoadedModel::load(path, Backend::Jit).unwrap();
    let interp = LoadedModel::load(path, Backend::Interpreter).unwrap();
    let emitted = CR3BP::<f64>::default().prepare();
    assert_eq!(Declared::<f64, [f64; 4]>::events(&emitted), jit.events());
    assert_eq!(jit.events().len(), 1);
    for k in 0..100 {
        let x = [
            (k as f64 * 0.31).sin(),
            (k as f64 * 0.17).cos() - 0.5,
            k as f64 * 0.01,
            -(k as f64 * 0.07).sin(),
        ];
        let t = k as f64 * 0.37;
        let (mut a, mut b, mut c) = ([0.0], vec![0.0], vec![0.0]);
        emitted.event_values(&x, t, &mut a);
        jit.event_values(&x.to_vec(), t, &mut b);
        interp.event_values(&x.to_vec(), t, &mut c);
        assert!(lasalle_testkit::same(a[0], b[0]) && lasalle_testkit::same(b[0], c[0]));
        assert_eq!(a[0], x[1]);
    }
}
