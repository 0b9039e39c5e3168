//! Every malformed model fails with a message that names file:line:col; no input panics.

use lasalle_codegen::{generate_source, DiagnosticKind};

/// The Kepler model file without its preset's explicit gains, whose count the mutations below
/// would change.
static KEPLER: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
    include_str!("../../models/kepler.lsl").replace(" gains = [4, 2];", "")
});

/// Generates `text` as `path` and returns the error message (panics if it succeeds).
fn error_of(text: &str) -> String {
    match generate_source("models/test.lsl", text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// The kinds of the diagnostics `text` fails with.
fn kinds_of(text: &str) -> Vec<DiagnosticKind> {
    match generate_source("models/test.lsl", text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.diagnostics().iter().map(|d| d.kind).collect(),
    }
}

/// The message names this line and column and holds all the `needles`.
fn assert_error(text: &str, line: usize, col: usize, needles: &[&str]) {
    let msg = error_of(text);
    let loc = format!("models/test.lsl:{line}:{col}");
    assert!(msg.contains(&loc), "expected {loc} in:\n{msg}");
    for n in needles {
        assert!(msg.contains(n), "expected `{n}` in:\n{msg}");
    }
}

#[test]
fn syntax_error_names_the_place() {
    let text = "model M {\n    state x: scalar;\n    d/dt x = 2 * ;\n}\n";
    assert_error(
        text,
        3,
        18,
        &["expected an expression, found `;`", "d/dt x = 2 * ;", "^"],
    );
}

#[test]
fn missing_semicolon_points_after_the_previous_token() {
    let text = "model M {\n    state x: scalar;\n    d/dt x = -x\n}\n";
    assert_error(text, 3, 16, &["expected `;`", "every item ends with `;`"]);
}

#[test]
fn unknown_symbol_suggests_a_name() {
    let text = KEPLER.replace("d/dt x = v;", "d/dt x = vv;");
    let line = text.lines().position(|l| l.contains("vv")).unwrap() + 1;
    let col = text.lines().nth(line - 1).unwrap().find("vv").unwrap() + 1;
    assert_error(
        &text,
        line,
        col,
        &["unknown symbol `vv`", "did you mean `v`?"],
    );
}

#[test]
fn unknown_function_suggests_a_name() {
    let text = KEPLER.replace("let r = norm(x);", "let r = nrm(x);");
    assert_error(
        &text,
        7,
        13,
        &["unknown function `nrm`", "did you mean `norm`?"],
    );
}

#[test]
fn shape_mismatch_names_both_shapes() {
    let text = KEPLER.replace("d/dt x = v;", "d/dt x = v + mu;");
    assert_error(&text, 9, 14, &["cannot add a vec3 and a scalar"]);
    let text = KEPLER.replace("d/dt x = v;", "d/dt x = x * v;");
    assert_error(
        &text,
        9,
        14,
        &["cannot multiply a vec3 by a vec3", "dot(a, b)"],
    );
    let text = KEPLER.replace("d/dt x = v;", "d/dt x = dot(x, v);");
    assert_error(&text, 9, 14, &["d/dt x is a scalar but `x` is a vec3"]);
}

#[test]
fn an_integral_that_is_not_conserved_is_named() {
    let text = KEPLER.replace(
        "    point paper",
        "    integral bad = x[0];\n    point paper",
    );
    let line = text
        .lines()
        .position(|l| l.contains("integral bad"))
        .unwrap()
        + 1;
    let msg = error_of(&text);
    assert!(msg.contains("integral `bad` is not conserved"), "{msg}");
    assert!(msg.contains(&format!("models/test.lsl:{line}:5")), "{msg}");
    assert!(
        msg.contains("at x = (x = ["),
        "the message shows the state: {msg}"
    );
    assert_eq!(kinds_of(&text), [DiagnosticKind::FailedCheck]);
}

#[test]
fn a_constraint_the_field_leaves_is_named() {
    // |x|² − 1 is not kept by the Kepler flow.
    let text = KEPLER.replace(
        "    point paper",
        "    constraint sphere = dot(x, x) - 1;\n    point paper",
    );
    let msg = error_of(&text);
    assert!(
        msg.contains("constraint `sphere` is not conserved"),
        "{msg}"
    );
    assert_eq!(kinds_of(&text), [DiagnosticKind::FailedCheck]);
}

#[test]
fn missing_equation_and_duplicates() {
    let text = "model M {\n    state x: scalar, y: scalar;\n    d/dt x = y;\n}\n";
    assert_error(text, 2, 22, &["state `y` has no equation"]);
    let text = "model M {\n    state x: scalar;\n    param x = 1;\n    d/dt x = 1;\n}\n";
    assert_error(text, 3, 11, &["`x` is already defined"]);
}

#[test]
fn parameters_that_map_to_one_rust_field() {
    let text = "model M {\n    state x: scalar;\n    param Mu = 1;\n    param mu = 2;\n    param match = 3;\n    d/dt x = -Mu * mu * match * x;\n}\n";
    assert_error(
        text,
        4,
        5,
        &["parameters `mu` and `Mu` would both be the Rust field `mu`"],
    );
    let ok = "model M {\n    state x: scalar;\n    param match = 3;\n    d/dt x = -match * x;\n}\n";
    let code = generate_source("m.lsl", ok).unwrap().code;
    assert!(
        code.contains("pub match_: T"),
        "a keyword parameter becomes `match_`"
    );
}

#[test]
fn gains_and_targets_only_in_lyapunov() {
    let text = KEPLER.replace("d/dt x = v;", "d/dt x = k1 * v;");
    assert_error(&text, 9, 14, &["gain `k1` cannot be used here"]);
    assert_eq!(kinds_of(&text), [DiagnosticKind::NotAllowedHere]);
}

#[test]
fn all_errors_are_reported_at_once() {
    let text = KEPLER
        .replace("d/dt x = v;", "d/dt x = vv;")
        .replace("let r = norm(x);", "let r = nrm(x);");
    let msg = error_of(&text);
    assert!(
        msg.contains("unknown symbol `vv`") && msg.contains("unknown function `nrm`"),
        "{msg}"
    );
    assert!(msg.contains("aborting due to 2 errors"), "{msg}");
    assert_eq!(kinds_of(&text), [DiagnosticKind::UnknownName; 2]);
}

#[test]
fn explicit_lyapunov_must_vanish_on_the_invariant_set() {
    let text = KEPLER.replace(
        "    point paper",
        "    lyapunov V = k1 / 2 * norm(L)^2;\n    point paper",
    );
    let msg = error_of(&text);
    assert!(
        msg.contains("V does not vanish on the invariant set"),
        "{msg}"
    );
    assert_eq!(kinds_of(&text), [DiagnosticKind::FailedCheck]);
}

#[test]
fn deep_nesting_and_huge_exponents_are_errors_not_crashes() {
    let deep = format!(
        "model M {{\n    state x: scalar;\n    d/dt x = {}x{};\n}}\n",
        "(".repeat(100_000),
        ")".repeat(100_000)
    );
    let msg = error_of(&deep);
    // Each parenthesis opens two levels (expression, operand): the 100th is too deep.
    assert!(
        msg.contains("models/test.lsl:3:114") && msg.contains("nested more than 200 levels deep"),
        "{}",
        &msg[..200]
    );
    let minus = format!(
        "model M {{\n    state x: scalar;\n    d/dt x = {}x;\n}}\n",
        "-".repeat(100_000)
    );
    assert!(
        error_of(&minus).contains("nested more than 200 levels deep"),
        "a chain of unary minus"
    );
    // (x^999999)^999999 overflows the exponent arithmetic: kept unfolded, never a panic.
    let text =
        "model M {\n    state x: scalar;\n    d/dt x = (x^999999)^999999 - (x^999999)^999999;\n}\n";
    assert!(generate_source("m.lsl", text).is_ok());
}

/// Mutations of every model file (deleted, duplicated and replaced characters) never make the
/// generator panic: each input either generates or fails with a diagnostic.
#[test]
fn no_input_makes_the_generator_panic() {
    let models = ["kepler", "perturbed_kepler", "rigid_body"].map(|m| {
        std::fs::read_to_string(format!("{}/../models/{m}.lsl", env!("CARGO_MANIFEST_DIR")))
            .unwrap()
    });
    let replacements = [
        '(', ')', '[', ']', ';', '^', '*', '/', '-', '0', 'x', ' ', '{', '}', ',', '=',
    ];
    let mut rng = lasalle_testkit::Rng::new(12345);
    let mut next = |n: usize| rng.below(n.max(1));
    for text in &models {
        let chars: Vec<char> = text.chars().collect();
        for _ in 0..150 {
            let mut c = chars.clone();
            for _ in 0..1 + next(3) {
                let i = next(c.len());
                match next(3) {
                    0 => {
                        c.remove(i);
                    }
                    1 => c.insert(i, replacements[next(replacements.len())]),
                    _ => c[i] = replacements[next(replacements.len())],
                }
            }
            let mutated: String = c.into_iter().collect();
            let result =
                std::panic::catch_unwind(|| generate_source("mutated.lsl", &mutated).map(|_| ()));
            match result {
                Err(_) => panic!("the generator panicked on:\n{mutated}"),
                Ok(Err(e)) => assert!(!e.to_string().is_empty()),
                Ok(Ok(())) => {}
            }
        }
    }
}

#[test]
fn reserved_model_names_are_refused_at_the_name() {
    for name in [
        "T", "Default", "Self", "fn", "_", "self", "Field", "Float", "Option", "f64", "lit",
    ] {
        let text = format!("model {name} {{\n    state x: scalar;\n    d/dt x = -x;\n}}\n");
        assert_error(
            &text,
            1,
            7,
            &[
                &format!("`{name}` cannot name a model"),
                "help: the model's name",
            ],
        );
    }
}

#[test]
fn raw_identifiers_are_not_names() {
    let text = "model M {\n    state x: scalar;\n    let r#fn = x;\n    d/dt x = -x;\n}\n";
    assert_error(text, 3, 10, &["unexpected character `#`"]);
}

#[test]
fn file_stems_that_are_keywords_name_valid_modules() {
    let ok = "model Decay {\n    state x: scalar;\n    d/dt x = -x;\n}\n";
    for (path, module) in [
        ("models/fn.lsl", "fn_"),
        ("models/self.lsl", "self_"),
        ("models/1d.lsl", "v1d"),
        ("models/_.lsl", "v_"),
    ] {
        assert_eq!(generate_source(path, ok).unwrap().module, module);
    }
}

#[test]
fn points_that_map_to_one_method_are_refused() {
    let text = "model M {\n    state x: scalar;\n    d/dt x = -x;\n    point A { x = 1; }\n    point a { x = 2; }\n}\n";
    assert_error(
        text,
        5,
        11,
        &["point `a` would be the method `point_a` of the point `A` on line 4"],
    );
}

#[test]
fn non_finite_constants_are_located_errors_not_panics() {
    let field = |rhs: &str| format!("model M {{\n    state x: scalar;\n    d/dt x = {rhs};\n}}\n");
    for (rhs, col, text) in [
        ("x + 1/0", 18, "1/0"),
        ("x * (0/0)", 18, "(0/0)"),
        ("x + 1e400", 18, "1e400"),
        ("x + log(0)", 18, "log(0)"),
        ("x * sqrt(-1)", 18, "sqrt(-1)"),
        ("x + 1e308 * 10", 18, "1e308 * 10"),
        ("x + 1e300 * x * 1e300", 18, "1e300 * x * 1e300"),
    ] {
        assert_error(
            &field(rhs),
            3,
            col,
            &[&format!("constant expression `{text}` is not finite")],
        );
    }
    // In a parameter default, a `let`, a point and a gain.
    let text =
        "model M {\n    state x: scalar;\n    param mu = 2 / (1 - 1);\n    d/dt x = -mu * x;\n}\n";
    assert_error(
        text,
        3,
        16,
        &["constant expression `2 / (1 - 1)` is not finite"],
    );
    let text = "model M {\n    state x: scalar;\n    let r = exp(1000) * x;\n    d/dt x = -r;\n}\n";
    assert_error(
        text,
        3,
        13,
        &["constant expression `exp(1000)` is not finite"],
    );
    let text = "model M {\n    state x: scalar;\n    d/dt x = -x;\n    point p { x = 1/0; }\n}\n";
    assert_error(text, 4, 19, &["constant expression `1/0` is not finite"]);
    let text =
        "model M {\n    state x: scalar;\n    d/dt x = 0;\n    integral I = 1 gain 1/0;\n}\n";
    assert_error(text, 4, 25, &["constant expression `1/0` is not finite"]);
    // A derivative that overflows where the model's constants did not.
    let text = "model M {\n    state q: scalar, p: scalar;\n    hamiltonian H = p^2 / 2 + 1e308 * q^4;\n    structure canonical(q, p);\n}\n";
    assert_error(
        text,
        4,
        5,
        &["the equations of this structure have a constant that is not finite (-inf)"],
    );
    let text =
        "model M {\n    state x: scalar;\n    d/dt x = 0;\n    integral E = 1e308 * x^4;\n}\n";
    assert_error(
        text,
        4,
        5,
        &["this item, or its derivative, has a constant that is not finite (inf)"],
    );
}

#[test]
fn long_flat_chains_and_deep_indexing_do_not_overflow_the_stack() {
    // 10 000 terms and factors in one expression: flat chains, not 10 000-deep trees.
    let sum: Vec<String> = (1..=10_000).map(|i| format!("x*{i}")).collect();
    let text = format!(
        "model M {{\n    state x: scalar;\n    d/dt x = {};\n}}\n",
        sum.join(" + ")
    );
    let code = generate_source("m.lsl", &text).unwrap().code;
    assert!(
        code.contains("dx[0] = lit::<T>(50005000.0) * x_2;"),
        "{code}"
    );
    let product = vec!["x"; 10_000].join(" * ");
    let text = format!("model M {{\n    state x: scalar;\n    d/dt x = {product} / x^9999;\n}}\n");
    assert!(generate_source("m.lsl", &text).is_ok());
    // x[0][0]…: indexing nests, so it is bounded like parentheses.
    let text = format!(
        "model M {{\n    state x: vec1;\n    d/dt x = [x{}];\n}}\n",
        "[0]".repeat(100_000)
    );
    assert!(error_of(&text).contains("nested more than 200 levels deep"));
}

#[test]
fn huge_powers_of_sums_give_up_the_proof_not_the_time() {
    // Expanding (q² + p²)^99999 to prove H conserved would take minutes: the expansion budget
    // gives up at once and the conservation check samples instead.
    let text = "model M {\n    state q: scalar, p: scalar;\n    hamiltonian H = (q^2 + p^2)^99999 / 1e9;\n    structure canonical(q, p);\n}\n";
    let start = std::time::Instant::now();
    let result = generate_source("m.lsl", text);
    assert!(
        start.elapsed() < std::time::Duration::from_secs(60),
        "{:?}",
        result.map(|_| ())
    );
}

/// The loop form writes guards and events as straight-line code: one that reads a family's
/// sum is refused at its line under `--families loops`, and `auto` emits the model unrolled.
#[test]
fn a_guard_reading_a_family_sum_has_no_emitted_loop_form() {
    use lasalle_codegen::{generate_source_with, Families};
    let text = "model Chain {
    param n = 80;
    state q: scalar[n], p: scalar[n];
    hamiltonian H = sum(i in 0..n: p[i]^2 / 2 + q[i]^2 / 2);
    structure canonical(q, p);
    guard small: sum(i in 0..n: q[i]^2) < 100;
}
";
    let msg = match generate_source_with("models/chain.lsl", text, Families::Loops) {
        Ok(_) => panic!("the guard reads a family's sum"),
        Err(e) => e.to_string(),
    };
    for needle in [
        "models/chain.lsl:6:",
        "reads a family's sum",
        "--families unrolled",
    ] {
        assert!(msg.contains(needle), "expected `{needle}` in:\n{msg}");
    }
    let auto = generate_source_with("models/chain.lsl", text, Families::Auto).unwrap();
    assert!(!auto.code.contains("fn lyapunov_sums"), "unrolled");
    assert!(auto.code.contains("fn check_guards"));
    // without the guard the same model is emitted as loops
    let plain = text.replace("    guard small: sum(i in 0..n: q[i]^2) < 100;\n", "");
    let loops = generate_source_with("models/chain.lsl", &plain, Families::Auto).unwrap();
    assert!(loops.code.contains("fn lyapunov_sums"));
    assert!(loops.code.contains("for i in 0..80 {"));
}
