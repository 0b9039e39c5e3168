//! Large models generate without error (no stack overflow, no quadratic blow-up that would make
//! these tests time out): 20 000 `let`s, and a field that is a flat sum of 10 000 terms.
//! Timings: `cargo run --release -p lasalle-codegen --example scale`.

use lasalle_codegen::generate_source;
use std::fmt::Write as _;

#[test]
fn twenty_thousand_lets_generate() {
    let n = 20_000;
    let mut text =
        String::from("model Chain {\n    state x: scalar, v: scalar;\n    let a0 = x;\n");
    for i in 1..n {
        let _ = writeln!(text, "    let a{i} = sin(a{}) + x / {i};", i - 1);
    }
    let _ = writeln!(text, "    d/dt x = v;\n    d/dt v = -a{};\n}}", n - 1);
    let m = generate_source("chain.lsl", &text).unwrap_or_else(|e| panic!("{e}"));
    assert!(m.code.contains(&format!("let a{} = ", n - 1)));
}

#[test]
fn a_ten_thousand_term_sum_generates() {
    let n = 10_000;
    let mut text = String::from("model Sum {\n    state x: scalar;\n");
    for i in 0..n {
        let _ = writeln!(text, "    let a{i} = sin({} * x);", i + 1);
    }
    let terms: Vec<String> = (0..n).map(|i| format!("a{i}")).collect();
    let _ = writeln!(text, "    d/dt x = {};\n}}", terms.join(" + "));
    let m = generate_source("sum.lsl", &text).unwrap_or_else(|e| panic!("{e}"));
    assert!(m.code.contains(&format!("a{}", n - 1)));
}

#[test]
fn a_ten_thousand_term_sum_of_pairwise_shared_factors_generates() {
    // b0·b1 + b1·b2 + …: factoring takes one round per term.
    let n = 10_000;
    let mut text = String::from("model Pairs {\n    state x: scalar;\n");
    for i in 0..=n {
        let _ = writeln!(text, "    let b{i} = sin({} * x);", i + 1);
    }
    let terms: Vec<String> = (0..n).map(|i| format!("b{i} * b{}", i + 1)).collect();
    let _ = writeln!(text, "    d/dt x = {};\n}}", terms.join(" + "));
    let m = generate_source("pairs.lsl", &text).unwrap_or_else(|e| panic!("{e}"));
    assert!(m.code.contains(&format!("b{n}")));
}
