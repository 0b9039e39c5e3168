//! Fuzzes the whole generator (parse → lower → derive → check → emit → format) with random
//! models: grammar-built files using every item, operator and function of the language, half
//! of them then mutated character by character. Any panic, or an input taking more than the
//! time limit, fails with the input printed.
//!
//! ```sh
//! cargo run --release -p lasalle-codegen --example fuzz -- 1000000        # a long run
//! cargo run --release -p lasalle-codegen --example fuzz -- 2000 7         # CI: 2000 inputs, seed 7
//! ```

use std::time::{Duration, Instant};

use lasalle_testkit::Rng;

/// A random scalar expression over `names` (scalars), at most `depth` deep.
fn expr(r: &mut Rng, names: &[String], depth: u32) -> String {
    if depth == 0 || r.chance(0.25) {
        return match r.below(4) {
            0 => format!("{}", r.below(5) as f64 * 0.5 + 0.5),
            1 => r
                .pick(&["1e-3", "2", "0", "1/3", "1e300", "0.1"])
                .to_string(),
            _ => r.pick(names).clone(),
        };
    }
    let a = expr(r, names, depth - 1);
    let b = expr(r, names, depth - 1);
    match r.below(14) {
        0 => format!("{a} + {b}"),
        1 => format!("{a} - {b}"),
        2 => format!("({a}) * ({b})"),
        3 => format!("({a}) / ({b})"),
        4 => format!(
            "({a})^{}",
            r.pick(&["2", "3", "-1", "(1/2)", "(3/2)", "-2", "(1/3)"])
        ),
        5 => format!("-({a})"),
        6 => format!("{}({a})", r.pick(&["sqrt", "exp", "log", "sin", "cos"])),
        7 => format!("norm([{a}, {b}])"),
        8 => format!("dot([{a}, {b}], [{b}, {a}])"),
        9 => format!("cross([{a}, {b}, 1], [1, {a}, {b}])[{}]", r.below(3)),
        10 => format!("trace(hat([{a}, {b}, 0]) * transpose(hat([1, {a}, {b}])))"),
        // elliptic functions; a parameter m that depends on the state or lies outside [0, 1]
        // is a located error, which the fuzzer checks too
        12 | 13 => {
            let m = if r.chance(0.25) {
                b
            } else {
                r.pick(&["0", "0.5", "1"]).to_string()
            };
            let f = r.pick(&[
                "sn", "cn", "dn", "ns", "nc", "nd", "sc", "sd", "cs", "cd", "ds", "dc", "ellipf",
            ]);
            if r.chance(0.1) {
                format!("ellipk({m})")
            } else {
                format!("{f}({a}, {m})")
            }
        }
        _ => format!("({a} + {b} + {a} * {b})"),
    }
}

/// A random model text using every kind of item.
fn model(r: &mut Rng) -> String {
    let n = 1 + r.below(4);
    let mut names: Vec<String> = (0..n).map(|i| format!("s{i}")).collect();
    let mut text = format!("model Fuzz{} {{\n    state ", r.below(1000));
    text.push_str(
        &names
            .iter()
            .map(|s| format!("{s}: scalar"))
            .collect::<Vec<_>>()
            .join(", "),
    );
    text.push_str(", w: vec3;\n");
    for i in 0..r.below(3) {
        let p = format!("c{i}");
        text.push_str(&format!(
            "    param {p} = {};\n",
            expr(r, &["1".into(), "2".into()], 1)
        ));
        names.push(p);
    }
    for i in 0..r.below(3) {
        let l = format!("l{i}");
        text.push_str(&format!("    let {l} = {};\n", expr(r, &names, 3)));
        names.push(l);
    }
    if r.chance(0.3) {
        text.push_str(&format!(
            "    hamiltonian H = {};\n    structure lie_poisson_so3(w);\n",
            expr(r, &["w[0]".into(), "w[1]".into(), "w[2]".into()], 2)
        ));
    } else {
        text.push_str("    d/dt w = cross(w, [1, 2, 3]);\n");
    }
    for i in 0..n {
        text.push_str(&format!("    d/dt s{i} = {};\n", expr(r, &names, 3)));
    }
    if r.chance(0.5) {
        text.push_str(&format!(
            "    integral I = {} gain {};\n",
            expr(r, &names, 2),
            r.below(5)
        ));
    }
    if r.chance(0.5) {
        text.push_str("    integral W = dot(w, w) / 2;\n");
    }
    if r.chance(0.3) {
        text.push_str(&format!(
            "    guard g: {} > {};\n",
            expr(r, &names, 2),
            expr(r, &names, 1)
        ));
    }
    let zeros: Vec<String> = (0..n).map(|i| format!("s{i} = {};", r.below(3))).collect();
    text.push_str(&format!(
        "    point p {{ {} w = [1, 0, 0]; }}\n",
        zeros.join(" ")
    ));
    if r.chance(0.4) {
        text.push_str("    run p { method = feedback_rk4; dt = 0.01; t_end = 1; init = p; }\n");
    }
    text.push_str("}\n");
    text
}

/// Replaces, deletes or duplicates a few characters.
fn mutate(r: &mut Rng, text: &str) -> String {
    let mut c: Vec<char> = text.chars().collect();
    for _ in 0..1 + r.below(4) {
        if c.is_empty() {
            break;
        }
        let i = r.below(c.len());
        match r.below(3) {
            0 => {
                c.remove(i);
            }
            1 => {
                let ch = c[i];
                c.insert(i, ch);
            }
            _ => {
                c[i] = *r.pick(&[
                    '(', ')', '[', ']', ';', '{', '}', '^', '/', '0', '-', 'x', ',', '<', '.',
                ])
            }
        }
    }
    c.into_iter().collect()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let count: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1000);
    let seed: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    let limit = Duration::from_secs(1);
    let mut r = Rng::new(seed);
    // the generator's errors are values; only panics are failures here
    std::panic::set_hook(Box::new(|_| {}));
    let start = Instant::now();
    let (mut ok, mut errors, mut slowest) = (0u64, 0u64, Duration::ZERO);
    for i in 0..count {
        let text = model(&mut r);
        let text = if r.chance(0.5) {
            mutate(&mut r, &text)
        } else {
            text
        };
        let t0 = Instant::now();
        let result =
            std::panic::catch_unwind(|| lasalle_codegen::generate_source("fuzz.lsl", &text));
        let took = t0.elapsed();
        slowest = slowest.max(took);
        match result {
            Err(_) => {
                eprintln!("input {i} (seed {seed}) panicked the generator:\n{text}");
                std::process::exit(1);
            }
            Ok(Ok(_)) => ok += 1,
            Ok(Err(e)) => {
                if e.to_string().trim().is_empty() {
                    eprintln!("input {i} gave an empty error:\n{text}");
                    std::process::exit(1);
                }
                errors += 1
            }
        }
        if took > limit {
            eprintln!("input {i} (seed {seed}) took {took:?} > {limit:?}:\n{text}");
            std::process::exit(1);
        }
    }
    println!(
        "fuzz: {count} inputs (seed {seed}) in {:.1} s: {ok} generated, {errors} refused with a diagnostic, 0 panics, slowest {:.1} ms",
        start.elapsed().as_secs_f64(),
        slowest.as_secs_f64() * 1e3
    );
}
