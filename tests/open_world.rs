//! Any model file runs from the command line, loaded and compiled at run time, with the same
//! flags as the built-in models; and the runtime integrates a loaded model exactly as
//! it integrates the same model compiled ahead of time (one code path, `Vec<f64>` storage
//! instead of `[f64; N]`).

use std::path::PathBuf;

use lasalle::models::{kepler::Kepler, rigid_body::RigidBody};
use lasalle::{
    integrate, Backend, DormandPrince, ExplicitRk, FeedbackField, LoadedModel, Parameters,
    Projection, Recorder,
};

mod common;
use common::lasalle;
use lasalle_testkit::{assert_same, same};

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `text` to `<dir>/<file>`, runs `lasalle run` on it and returns the summary.
fn run_file(dir: &std::path::Path, file: &str, text: &str, args: &[&str]) -> serde_json::Value {
    let path = dir.join(file);
    std::fs::write(&path, text).unwrap();
    let out = dir.join("out");
    let o = lasalle(
        &[
            &["run", path.to_str().unwrap()][..],
            args,
            &["-q", "--out", out.to_str().unwrap()],
        ]
        .concat(),
    );
    assert!(
        o.status.success(),
        "lasalle run {file} {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn max_error(s: &serde_json::Value, name: &str) -> f64 {
    s["invariant_errors"][name]["max"]
        .as_f64()
        .expect("max error")
}

const HENON_HEILES: &str = "
// Hénon & Heiles (1964)
model HenonHeiles {
    state q: vec2, p: vec2;
    param lambda = 1;
    hamiltonian H = (p[0]^2 + p[1]^2 + q[0]^2 + q[1]^2) / 2
                  + lambda * (q[0]^2 * q[1] - q[1]^3 / 3);
    structure canonical(q, p);
    // models/henon_heiles.lsl's point: E = 1/8 on the section q₀ = 0, in the chaotic sea
    point chaotic { q = [0, -0.1]; p = [sqrt(0.25 - 0.01 - 0.002 / 3), 0]; }
}
";

const LOTKA_VOLTERRA: &str = "
model LotkaVolterra {
    state u: scalar, v: scalar;
    param a = 2; param b = 1; param c = 1; param d = 1;
    d/dt u = u * (a - b * v);
    d/dt v = v * (d * u - c);
    integral I = d * u - c * log(u) + b * v - a * log(v) gain 1;
    guard positive: u > 0;
    point start { u = 2; v = 1; }
    run start { method = feedback_rk4; dt = 0.01; t_end = 20; init = start; }
}
";

const TODA: &str = "
// the periodic Toda lattice with three particles: H = Σ p²/2 + Σ exp(q_i − q_{i+1})
model Toda {
    state q: vec3, p: vec3;
    hamiltonian H = (p[0]^2 + p[1]^2 + p[2]^2) / 2
                  + exp(q[0] - q[1]) + exp(q[1] - q[2]) + exp(q[2] - q[0]);
    structure canonical(q, p);
    integral P = p[0] + p[1] + p[2];
    point start { q = [0, 0.3, -0.2]; p = [0.5, -0.1, -0.4]; }
}
";

/// Three models nobody here has seen run with the flags of the built-in ones, and keep their
/// integrals; a fourth declares its own preset and guard.
#[test]
fn unseen_models_run_from_their_files() {
    let dir = scratch("open-world");
    let hh = run_file(
        &dir,
        "henon_heiles.lsl",
        HENON_HEILES,
        &[
            "-m",
            "feedback-rk4",
            "--init",
            "chaotic",
            "--dt",
            "0.01",
            "--t-end",
            "100",
        ],
    );
    assert!(max_error(&hh, "H") < 1e-9, "H: {}", max_error(&hh, "H"));
    assert_eq!(hh["steps"], 10_000);
    assert!(hh["load_seconds"].as_f64().unwrap() < 5.0);

    let toda = run_file(
        &dir,
        "toda.lsl",
        TODA,
        &[
            "-m",
            "stormer-verlet-b",
            "--init",
            "start",
            "--dt",
            "0.01",
            "--t-end",
            "50",
        ],
    );
    assert!(max_error(&toda, "H") < 1e-4, "H: {}", max_error(&toda, "H"));
    assert!(
        max_error(&toda, "P") < 1e-12,
        "P: {}",
        max_error(&toda, "P")
    );

    // the preset supplies method, step, end time and initial point
    let lv = run_file(&dir, "lotka_volterra.lsl", LOTKA_VOLTERRA, &[]);
    assert_eq!(lv["method"], "feedback-rk4");
    assert_eq!(lv["preset"], "start");
    assert!(max_error(&lv, "I") < 1e-7, "I: {}", max_error(&lv, "I"));

    // the same through the interpreter: identical numbers, bit for bit
    let lv_interp = run_file(
        &dir,
        "lotka_volterra.lsl",
        LOTKA_VOLTERRA,
        &["--backend", "interpreter"],
    );
    assert_eq!(lv_interp["backend"], "interpreter");
    let numbers = |v: &serde_json::Value| -> Vec<f64> {
        let all = v.as_array().expect("an array of numbers");
        all.iter().map(|x| x.as_f64().expect("a number")).collect()
    };
    let (a, b) = (
        numbers(&lv_interp["final_state"]),
        numbers(&lv["final_state"]),
    );
    assert!(!a.is_empty() && a.len() == b.len());
    assert!(
        a.iter().zip(&b).all(|(&u, &v)| same(u, v)),
        "{a:?} vs {b:?}"
    );
}

/// The Taylor method (adaptive order and step, from the model's tapes) through the command
/// line: ten Kepler periods at e = 0.8 keep L and A to 1e-13.
#[test]
fn taylor_through_the_command_line() {
    let dir = scratch("open-world-taylor");
    let o = lasalle(&[
        "run",
        "kepler",
        "-m",
        "taylor",
        "--rtol",
        "1e-15",
        "--t-end",
        "702.481",
        "-q",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["method"], "taylor");
    for name in ["L", "A"] {
        assert!(
            max_error(&s, name) < 1e-13,
            "{name}: {}",
            max_error(&s, name)
        );
    }
    // far fewer steps than a fixed step of the preset's 0.005 would take
    assert!(s["steps"].as_u64().unwrap() < 2_000, "{}", s["steps"]);
}

/// A guard declared in the model file stops a run that leaves the domain, naming the guard.
#[test]
fn a_declared_guard_stops_the_run() {
    let dir = scratch("open-world-guard");
    let path = dir.join("lv.lsl");
    std::fs::write(&path, LOTKA_VOLTERRA).unwrap();
    // a huge explicit Euler step throws u below 0
    let o = lasalle(&[
        "run",
        path.to_str().unwrap(),
        "-m",
        "euler",
        "--dt",
        "0.9",
        "--init",
        "0.1,5",
        "--t-end",
        "10",
        "-q",
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        e.contains("guard `positive` violated: u > 0 does not hold"),
        "{e}"
    );
}

/// A model file with an error is reported with its place, not run.
#[test]
fn a_broken_model_file_is_a_located_error() {
    let dir = scratch("open-world-broken");
    let path = dir.join("broken.lsl");
    std::fs::write(
        &path,
        "model B { state x: scalar; d/dt x = y; point p { x = 1; } }",
    )
    .unwrap();
    let o = lasalle(&["run", path.to_str().unwrap(), "--dt", "0.1", "--t-end", "1"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        e.contains("broken.lsl:1:") && e.contains("unknown symbol `y`"),
        "{e}"
    );
}

fn loaded(stem: &str, backend: Backend) -> LoadedModel {
    let path = format!("{}/models/{stem}.lsl", env!("CARGO_MANIFEST_DIR"));
    LoadedModel::load(path, backend).expect("the model loads")
}

/// The runtime integrates the loaded model (JIT and interpreter, `Vec<f64>` storage) and the
/// compiled one (`[f64; N]` storage) to the same bits: feedback-Euler, RK4 with projection and
/// adaptive DOPRI5 on Kepler, feedback-RK4 on the rigid body.
#[test]
fn loaded_and_compiled_models_integrate_identically() {
    let compiled = Kepler::<f64>::default().prepare();
    let x0 = compiled.point_paper();
    let fb = FeedbackField::from_initial(&compiled, &x0, [4.0, 2.0]);
    let want_fb = integrate(
        &mut ExplicitRk::euler(),
        &fb,
        &x0,
        0.0,
        20.0,
        0.005,
        &mut (),
    )
    .unwrap();
    let mut proj = Projection::from_initial(ExplicitRk::rk4(), &compiled, &x0, 1e-10);
    let want_proj = integrate(&mut proj, &compiled, &x0, 0.0, 20.0, 0.01, &mut ()).unwrap();
    let mut dp = DormandPrince::with_tolerances(1e-10, 1e-10);
    let want_dp = integrate(&mut dp, &compiled, &x0, 0.0, 20.0, 0.0, &mut ()).unwrap();

    let rb = RigidBody::<f64>::default().prepare();
    let y0 = rb.point_paper();
    let rb_fb = FeedbackField::from_initial(&rb, &y0, [50.0, 100.0, 50.0]);
    let mut rec = Recorder::new(&rb, &y0, 10, 200);
    let want_rb = integrate(
        &mut ExplicitRk::rk4(),
        &rb_fb,
        &y0,
        0.0,
        1.0,
        1e-3,
        &mut rec,
    )
    .unwrap();

    for backend in Backend::available() {
        let m = loaded("kepler", *backend);
        let x0: Vec<f64> = m.point("paper").unwrap();
        let fb = FeedbackField::from_initial(&m, &x0, vec![4.0, 2.0]);
        let got = integrate(
            &mut ExplicitRk::euler(),
            &fb,
            &x0,
            0.0,
            20.0,
            0.005,
            &mut (),
        )
        .unwrap();
        assert_same(&got.x, &want_fb.x, format!("{backend:?} feedback-Euler"));
        assert_eq!(got.steps, want_fb.steps);
        let mut proj = Projection::from_initial(ExplicitRk::rk4(), &m, &x0, 1e-10);
        let got = integrate(&mut proj, &m, &x0, 0.0, 20.0, 0.01, &mut ()).unwrap();
        assert_same(&got.x, &want_proj.x, format!("{backend:?} projection"));
        assert!(proj.newton_iterations() > 0);
        let mut dp = DormandPrince::with_tolerances(1e-10, 1e-10);
        let got = integrate(&mut dp, &m, &x0, 0.0, 20.0, 0.0, &mut ()).unwrap();
        assert_same(&got.x, &want_dp.x, format!("{backend:?} DOPRI5"));
        assert_eq!(got.rejections, want_dp.rejections);

        let m = loaded("rigid_body", *backend);
        let y0: Vec<f64> = m.point("paper").unwrap();
        let fb = FeedbackField::from_initial(&m, &y0, vec![50.0, 100.0, 50.0]);
        let mut got_rec = Recorder::new(&m, &y0, 10, 200);
        let got = integrate(
            &mut ExplicitRk::rk4(),
            &fb,
            &y0,
            0.0,
            1.0,
            1e-3,
            &mut got_rec,
        )
        .unwrap();
        assert_same(&got.x, &want_rb.x, format!("{backend:?} rigid body"));
        assert_same(
            &got_rec.errors,
            &rec.errors,
            format!("{backend:?} recorded invariant errors"),
        );
    }
}

/// Parameters set by name reach every compiled function (the hoisted parameter-only values
/// are recomputed).
#[test]
fn parameters_of_a_loaded_model_take_effect() {
    let mut m = loaded("kepler", Backend::default());
    let x0: Vec<f64> = m.point("paper").unwrap();
    let mut dx = vec![0.0; 6];
    lasalle::Field::field(&m, &x0, &mut dx);
    assert_eq!(dx[3], -1.0);
    m.set_param("mu", &[2.5]).unwrap();
    lasalle::Field::field(&m, &x0, &mut dx);
    assert_eq!(dx[3], -2.5);
    assert_eq!(m.param("mu"), Some(vec![2.5]));
    assert!(m.set_param("mu", &[1.0, 2.0]).is_err());
    assert!(m.set_param("nu", &[1.0]).is_err());
}

/// `sweep` runs a parameter grid in parallel into one table; three shards merged give the same
/// rows, and a missing shard is an error.
#[test]
fn sweep_shards_merge_to_the_whole_sweep() {
    let dir = scratch("open-world-sweep");
    let table = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let common = [
        "cr3bp",
        "--grid",
        "mu=0.001:0.03:7",
        "--t-end",
        "5",
        "--init",
        "near_L4",
    ];
    let run = |extra: &[&str], out: &str| {
        let o = lasalle(&[&["sweep"][..], &common, extra, &["--out", out]].concat());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&[], &table("all.csv"));
    for i in 0..3 {
        run(
            &["--shard", &format!("{i}/3")],
            &table(&format!("s{i}.csv")),
        );
    }
    let o = lasalle(&[
        "sweep-merge",
        &table("s0.csv"),
        &table("s1.csv"),
        &table("s2.csv"),
        "--out",
        &table("merged.csv"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // the same runs: every column but the wall time
    let strip = |path: String| -> Vec<String> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                [&c[..5], &c[6..]].concat().join(",")
            })
            .collect()
    };
    let (all, merged) = (strip(table("all.csv")), strip(table("merged.csv")));
    assert_eq!(all.len(), 8);
    assert_eq!(all, merged);
    assert!(all[1].starts_with("0,0.001,"), "{}", all[1]);
    let o = lasalle(&[
        "sweep-merge",
        &table("s0.csv"),
        &table("s2.csv"),
        "--out",
        &table("m.csv"),
    ]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("row 1 is missing"));
}

/// Rows that share their parameters run together in lanes, and each gets the result it gets
/// alone: a grid over initial-state components (some runs stop at Kepler's guard, which sends
/// their group back to one run per row), run with `--lanes 8` and `--lanes 1`, gives the same
/// table but for the wall time, with the field and with the feedback field (each lane with
/// its own targets). An axis that names nothing in the model is an error.
#[test]
fn sweep_lanes_give_each_row_its_lone_result() {
    let dir = scratch("open-world-sweep-lanes");
    let table = |method: &str, lanes: &str| -> Vec<String> {
        let out = dir.join(format!("{method}-{lanes}.csv"));
        let o = lasalle(&[
            "sweep",
            "kepler",
            "-m",
            method,
            "--dt",
            "0.01",
            "--t-end",
            "10",
            "--grid",
            "v[1]=0.01:1.3:12",
            "--grid",
            "x[0]=0.9,1",
            "--grid",
            "mu=1,1.2",
            "--lanes",
            lanes,
            "--out",
            out.to_str().unwrap(),
        ]);
        // the runs that stop at the guard make the sweep exit with 1, after the whole table
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("of 48 runs failed"), "{err}");
        let text = std::fs::read_to_string(out).unwrap();
        text.lines()
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                [&c[..7], &c[8..]].concat().join(",") // all but wall_seconds
            })
            .collect()
    };
    for method in ["rk4", "feedback-rk4"] {
        let (alone, together) = (table(method, "1"), table(method, "8"));
        assert_eq!(alone.len(), 49);
        assert!(alone[0].starts_with("row,v[1],x[0],mu,"), "{}", alone[0]);
        assert!(alone
            .iter()
            .any(|r| r.contains("guard `resolved` violated")));
        assert!(
            alone.iter().filter(|r| r.ends_with(',')).count() > 24,
            "most runs succeed"
        );
        assert_eq!(alone, together, "{method}");
    }
    let o = lasalle(&[
        "sweep",
        "kepler",
        "--grid",
        "w=1,2",
        "--t-end",
        "1",
        "--out",
        dir.join("bad.csv").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && err.contains("`w` is neither a parameter of `Kepler` nor a component of its state")
            && err.contains("state components: x[0], x[1]"),
        "{err}"
    );
}

/// A table is CSV a reader can parse: matrix component names (`g[0,1]`) and failure
/// messages are quoted, so every row has as many fields as the header.
#[test]
fn sweep_tables_quote_fields_with_commas() {
    let dir = scratch("open-world-sweep-quoting");
    let out = dir.join("rb.csv");
    let o = lasalle(&[
        "sweep",
        "so3_type_i",
        "--grid",
        // c₁ = 10⁻³⁰⁰: the second run fails, with a message full of commas
        "c1=2,1e-300",
        "--dt",
        "0.01",
        "--t-end",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("1 of 2 runs failed (rows 1"), "{err}");
    // RFC 4180 fields of one line (no quoted line breaks in these tables)
    let fields = |line: &str| -> Vec<String> {
        let (mut fields, mut field, mut quoted) = (Vec::new(), String::new(), false);
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            match c {
                '"' if quoted && chars.peek() == Some(&'"') => {
                    field.push('"');
                    chars.next();
                }
                '"' => quoted = !quoted,
                ',' if !quoted => fields.push(std::mem::take(&mut field)),
                c => field.push(c),
            }
        }
        fields.push(field);
        fields
    };
    let text = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<String>> = text.lines().map(fields).collect();
    assert_eq!(rows.len(), 3, "{text}");
    assert!(rows[0].iter().any(|h| h == "g[0,1](T)"), "{:?}", rows[0]);
    for row in &rows {
        assert_eq!(row.len(), rows[0].len(), "{row:?}");
    }
    assert_eq!(rows[1].last().unwrap(), "", "the first run succeeds");
    assert!(
        rows[2].last().unwrap().contains("rejected steps"),
        "{:?}",
        rows[2]
    );
}
