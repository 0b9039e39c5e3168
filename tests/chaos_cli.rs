//! `lasalle run --variational/--lyapunov-spectrum/--megno/--fli` and `lasalle sweep
//! --indicator`, end to end: the numbers in summary.json, stm.csv and the map's table against
//! closed forms and the indicators' known limits, and the refusals.

mod common;

use std::path::PathBuf;

use common::lasalle_text;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lasalle-chaos-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const OSC: &str = "model Osc { state q: scalar, p: scalar; param w = 1.5;
    d/dt q = p; d/dt p = -w^2 * q; integral E = p^2/2 + w^2 * q^2/2;
    point start { q = 1; p = 0; } }";

fn summary(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// The oscillator: Φ(t) = exp(At) in stm.csv and summary.json, the spectrum (0, 0) summing
/// to the divergence 0, and ⟨Y⟩ → 0 on its isochronous orbits.
#[test]
fn run_writes_the_stm_spectrum_and_megno() {
    let dir = scratch("run");
    let model = dir.join("osc.lsl");
    std::fs::write(&model, OSC).unwrap();
    let out = dir.join("out");
    let (ok, _, err) = lasalle_text(&[
        "run",
        model.to_str().unwrap(),
        "-m",
        "dopri5",
        "--t-end",
        "40",
        "--rtol",
        "1e-12",
        "--atol",
        "1e-12",
        "--variational",
        "--lyapunov-spectrum",
        "--megno",
        "--fli",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "{err}");
    let s = summary(&out);
    let (w, t) = (1.5f64, 40.0f64);
    let exact = [
        [(w * t).cos(), (w * t).sin() / w],
        [-w * (w * t).sin(), (w * t).cos()],
    ];
    for i in 0..2 {
        for j in 0..2 {
            let phi = s["variational"]["phi"][i][j].as_f64().unwrap();
            assert!((phi - exact[i][j]).abs() < 1e-9, "Φ[{i}][{j}] = {phi}");
        }
    }
    let csv = std::fs::read_to_string(out.join("stm.csv")).unwrap();
    let row: Vec<f64> = csv
        .lines()
        .nth(2)
        .unwrap()
        .split(',')
        .skip(1)
        .map(|v| v.parse().unwrap())
        .collect();
    assert!(
        (row[0] - exact[1][0]).abs() < 1e-9 && (row[1] - exact[1][1]).abs() < 1e-9,
        "{csv}"
    );
    let spectrum: Vec<f64> = s["lyapunov_spectrum"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(spectrum.iter().all(|l| l.abs() < 0.05), "{spectrum:?}");
    assert!(spectrum.iter().sum::<f64>().abs() < 1e-9, "{spectrum:?}");
    assert!(s["megno"].as_f64().unwrap().abs() < 0.1, "{}", s["megno"]);
    assert!(s["fli"].as_f64().unwrap().abs() < 2.0, "{}", s["fli"]);
}

/// `--megno --fli` on 5 bodies with `--families loops` (the indicators' field, and with
/// `-m taylor` its Taylor program, in loop form)
/// and `--families unrolled` give the same numbers, to the rounding of the two summation
/// orders.
#[test]
fn loop_families_give_the_unrolled_megno_and_fli() {
    let dir = scratch("loops");
    let run = |method: &str, families: &str| {
        let out = dir.join(format!("{method}_{families}"));
        let (ok, _, err) = lasalle_text(&[
            "run",
            concat!(env!("CARGO_MANIFEST_DIR"), "/models/nbody.lsl"),
            "-m",
            method,
            "--t-end",
            "6",
            "--rtol",
            "1e-12",
            "--atol",
            "1e-12",
            "--megno",
            "--fli",
            "--families",
            families,
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(ok, "{method} {families}: {err}");
        summary(&out)
    };
    // taylor: the staged field's Taylor program in loop form
    for method in ["dopri5", "taylor"] {
        let (a, b) = (run(method, "loops"), run(method, "unrolled"));
        for key in ["megno", "megno_y", "fli", "mle"] {
            let (x, y) = (a[key].as_f64().unwrap(), b[key].as_f64().unwrap());
            assert!(
                y > 0.0 && (x - y).abs() <= 1e-9 * y,
                "{method} {key}: loops {x}, unrolled {y}"
            );
        }
    }
}

/// A method that moves x by something other than the field is refused, with exit code 2 and
/// the methods that apply.
#[test]
fn feedback_methods_are_refused() {
    let dir = scratch("refuse");
    let (ok, _, err) = lasalle_text(&[
        "run",
        "henon_heiles",
        "--megno",
        "--out",
        dir.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(!ok);
    assert!(
        err.contains("feedback-rk4") && err.contains("use euler, heun, rk4, dopri5 or taylor"),
        "{err}"
    );
    let (ok, _, err) = lasalle_text(&[
        "run",
        "henon_heiles",
        "-m",
        "rk4",
        "--megno",
        "--renormalise-every",
        "2",
        "--out",
        dir.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        !ok && err.contains("--renormalise-every applies to --lyapunov-spectrum"),
        "{err}"
    );
}

/// A MEGNO map of Hénon–Heiles on the E = 1/12 section q₀ = 0 along p₁ = 0 (p₀ from the
/// energy): rk4 in lanes and dopri5 give the table's megno column and the figure; the orbits
/// there are regular (Hénon & Heiles 1964, fig. 4: invariant curves), ⟨Y⟩ close to 2 or 0.
#[test]
fn sweep_indicator_writes_the_map() {
    let dir = scratch("sweep");
    let list = dir.join("ics.csv");
    let mut text = String::from("q[1],p[0]\n");
    for k in 0..6 {
        let q1 = -0.3 + 0.1 * k as f64;
        let p0 = (2.0 * (1.0 / 12.0 - q1 * q1 / 2.0 + q1 * q1 * q1 / 3.0)).sqrt();
        text.push_str(&format!("{q1},{p0}\n"));
    }
    std::fs::write(&list, text).unwrap();
    for method in [
        ["-m", "rk4", "--dt", "0.01"],
        ["-m", "dopri5", "--rtol", "1e-10"],
    ] {
        let table = dir.join(format!("map-{}.csv", method[1]));
        let mut args = vec![
            "sweep",
            "henon_heiles",
            "--list",
            list.to_str().unwrap(),
            "--init",
            "0,0,0,0",
            "--t-end",
            "300",
            "--indicator",
            "megno",
            "--out",
            table.to_str().unwrap(),
        ];
        args.extend(method);
        let (ok, _, err) = lasalle_text(&args);
        assert!(ok, "{err}");
        let csv = std::fs::read_to_string(&table).unwrap();
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let col = header.iter().position(|h| *h == "megno").unwrap();
        assert_eq!(header.last(), Some(&"failure"));
        for line in csv.lines().skip(1) {
            let megno: f64 = line.split(',').nth(col).unwrap().parse().unwrap();
            assert!(megno > -0.2 && megno < 2.6, "{line}");
        }
        assert!(dir.join(format!("map-{}.png", method[1])).exists());
    }
}

/// `--indicator fli` fills the `fli` column with the supremum of ln‖w‖ over the run — at least
/// its final value mle·t, and the lone run's `--fli` — and the MEGNO map leaves it empty (its
/// rows do not locate the peaks of ln‖w‖).
#[test]
fn sweep_fli_is_the_supremum() {
    let dir = scratch("sweep-fli");
    let list = dir.join("ics.csv");
    let rows: [(f64, f64); 2] = [(-0.1, 0.0), (0.2, 0.1)];
    let mut text = String::from("q[1],p[1],p[0]\n");
    for (q1, p1) in rows {
        let p0: f64 = (2.0 * (0.125 - q1 * q1 / 2.0 - p1 * p1 / 2.0 + q1 * q1 * q1 / 3.0)).sqrt();
        text.push_str(&format!("{q1},{p1},{p0}\n"));
    }
    std::fs::write(&list, text).unwrap();
    let t_end = 50.0;
    let column = |indicator: &str, name: &str| -> Vec<String> {
        let table = dir.join(format!("{indicator}.csv"));
        let (ok, _, err) = lasalle_text(&[
            "sweep",
            "henon_heiles",
            "--list",
            list.to_str().unwrap(),
            "--init",
            "0,0,0,0",
            "-m",
            "dopri5",
            "--rtol",
            "1e-11",
            "--atol",
            "1e-11",
            "--t-end",
            "50",
            "--indicator",
            indicator,
            "--out",
            table.to_str().unwrap(),
        ]);
        assert!(ok, "{err}");
        let csv = std::fs::read_to_string(&table).unwrap();
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let col = header.iter().position(|h| *h == name).unwrap();
        csv.lines()
            .skip(1)
            .map(|l| l.split(',').nth(col).unwrap().to_string())
            .collect()
    };
    assert!(column("megno", "fli").iter().all(String::is_empty));
    let fli: Vec<f64> = column("fli", "fli")
        .iter()
        .map(|v| v.parse().unwrap())
        .collect();
    let mle: Vec<f64> = column("fli", "mle")
        .iter()
        .map(|v| v.parse().unwrap())
        .collect();
    for (k, (q1, p1)) in rows.iter().enumerate() {
        assert!(fli[k] >= mle[k] * t_end && fli[k] >= 0.0, "{fli:?} {mle:?}");
        let p0: f64 = (2.0 * (0.125 - q1 * q1 / 2.0 - p1 * p1 / 2.0 + q1 * q1 * q1 / 3.0)).sqrt();
        let out = dir.join(format!("run-{k}"));
        let (ok, _, err) = lasalle_text(&[
            "run",
            "henon_heiles",
            "-m",
            "dopri5",
            "--rtol",
            "1e-11",
            "--atol",
            "1e-11",
            "--t-end",
            "50",
            "--init",
            &format!("0,{q1},{p0},{p1}"),
            "--fli",
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(ok, "{err}");
        let alone = summary(&out)["fli"].as_f64().unwrap();
        assert!(
            (alone - fli[k]).abs() < 1e-12,
            "row {k}: {alone} vs {}",
            fli[k]
        );
    }
}

/// The `--list` example of docs/chaos.md as printed: its `printf` line makes the file that its
/// `lasalle sweep` line reads, both rows lie on E = 1/8 (p₀ from the energy), and both run.
#[test]
fn docs_list_example_runs() {
    let doc =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/chaos.md")).unwrap();
    let mut lines = doc.lines().skip_while(|l| !l.starts_with("printf '"));
    let printf = lines.next().expect("the printf line of the --list example");
    let sweep = lines.next().expect("the sweep line after it");
    let text = printf
        .strip_prefix("printf '")
        .and_then(|l| l.strip_suffix("' > ics.csv"))
        .expect("printf '…' > ics.csv")
        .replace("\\n", "\n");
    let dir = scratch("docs-list");
    let (list, table) = (dir.join("ics.csv"), dir.join("map.csv"));
    std::fs::write(&list, &text).unwrap();
    let mut rows = text.lines();
    assert_eq!(rows.next(), Some("q[1],p[1],q[0],p[0]"));
    for row in rows {
        let v: Vec<f64> = row.split(',').map(|x| x.parse().unwrap()).collect();
        let (q1, p1, q0, p0) = (v[0], v[1], v[2], v[3]);
        let h = (p0 * p0 + p1 * p1 + q0 * q0 + q1 * q1) / 2.0 + q0 * q0 * q1 - q1.powi(3) / 3.0;
        assert!((h - 0.125).abs() < 1e-16, "{row}: H = {h}");
    }
    let args: Vec<String> = sweep
        .split_whitespace()
        .skip(1)
        .map(|a| match a {
            "ics.csv" => list.to_str().unwrap().to_string(),
            "map.csv" => table.to_str().unwrap().to_string(),
            a => a.to_string(),
        })
        .collect();
    assert_eq!(args[0], "sweep", "{sweep}");
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (ok, _, err) = lasalle_text(&args);
    assert!(ok, "{sweep}: {err}");
    let csv = std::fs::read_to_string(&table).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "megno").unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    for line in csv.lines().skip(1) {
        let megno: f64 = line.split(',').nth(col).unwrap().parse().unwrap();
        assert!(megno.is_finite() && line.ends_with(','), "{line}");
    }
}
