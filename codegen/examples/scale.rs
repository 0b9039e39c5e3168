//! Generation time against model size: many `let`s, and long flat sums.
//!
//! `cargo run --release -p lasalle-codegen --example scale [sizes…]` prints, for each family
//! and size, the wall time of the whole pipeline (parse → lower → derive → check → emit →
//! format) and the size of the generated code.

use std::fmt::Write as _;
use std::time::Instant;

/// A field through a chain of `n` lets: a₀ = x, aᵢ = sin(aᵢ₋₁) + x/i.
fn let_chain(n: usize) -> String {
    let mut s = String::from("model Chain {\n    state x: scalar, v: scalar;\n    let a0 = x;\n");
    for i in 1..n {
        let _ = writeln!(s, "    let a{i} = sin(a{}) + x / {i};", i - 1);
    }
    let _ = writeln!(s, "    d/dt x = v;\n    d/dt v = -a{};\n}}", n - 1);
    s
}

/// A Hamiltonian through a chain of `n` lets: aᵢ = 0.999·aᵢ₋₁ + 0.001·sin(aᵢ₋₁). Its reverse-mode
/// gradient multiplies n chain-rule factors, which flat products hold in O(n²) nodes.
fn hamiltonian_chain(n: usize) -> String {
    let mut s = String::from("model Chain {\n    state q: scalar, p: scalar;\n    let a0 = q;\n");
    for i in 1..n {
        let _ = writeln!(
            s,
            "    let a{i} = 0.999 * a{} + 0.001 * sin(a{});",
            i - 1,
            i - 1
        );
    }
    let _ = writeln!(
        s,
        "    hamiltonian H = p^2 / 2 + a{};\n    structure canonical(q, p);\n}}",
        n - 1
    );
    s
}

/// A field that is a flat sum of `n` lets: ẋ = a₀ + a₁ + … with aᵢ = sin(i·x).
fn let_sum(n: usize) -> String {
    let mut s = String::from("model Sum {\n    state x: scalar;\n");
    for i in 0..n {
        let _ = writeln!(s, "    let a{i} = sin({} * x);", i + 1);
    }
    let terms: Vec<String> = (0..n).map(|i| format!("a{i}")).collect();
    let _ = writeln!(s, "    d/dt x = {};\n}}", terms.join(" + "));
    s
}

/// A field that is a flat sum of `n` distinct terms written inline: ẋ = x·y + x²·y + …
fn term_sum(n: usize) -> String {
    let terms: Vec<String> = (1..=n).map(|i| format!("x^{i} * y")).collect();
    format!(
        "model Terms {{\n    state x: scalar, y: scalar;\n    d/dt x = {};\n    d/dt y = -x;\n}}\n",
        terms.join(" + ")
    )
}

/// A field that is a flat sum of `n` products sharing factors pairwise: ẋ = b₀b₁ + b₁b₂ + …,
/// with bᵢ = sin((i+1)·x): factoring groups one factor per round.
fn pair_sum(n: usize) -> String {
    let mut s = String::from("model Pairs {\n    state x: scalar;\n");
    for i in 0..=n {
        let _ = writeln!(s, "    let b{i} = sin({} * x);", i + 1);
    }
    let terms: Vec<String> = (0..n).map(|i| format!("b{i} * b{}", i + 1)).collect();
    let _ = writeln!(s, "    d/dt x = {};\n}}", terms.join(" + "));
    s
}

fn time(family: &str, n: usize, text: &str) {
    let start = Instant::now();
    match lasalle_codegen::generate_source("scale.lsl", text) {
        Ok(m) => println!(
            "{family:>9} n = {n:>6}: {:>9.3} s, {} lines",
            start.elapsed().as_secs_f64(),
            m.report.lines
        ),
        Err(e) => println!("{family:>9} n = {n:>6}: error: {e}"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let only = |family: &str| args.is_empty() || args.iter().any(|a| a == family);
    let sizes = |default: &[usize]| -> Vec<usize> {
        let given: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
        if given.is_empty() {
            default.to_vec()
        } else {
            given
        }
    };
    if only("lets") {
        for n in sizes(&[1_000, 5_000, 20_000, 50_000]) {
            time("let-chain", n, &let_chain(n));
        }
    }
    if only("hamiltonian") {
        for n in sizes(&[100, 200, 400]) {
            time("ham-chain", n, &hamiltonian_chain(n));
        }
    }
    if only("sums") {
        for n in sizes(&[1_000, 3_000, 10_000]) {
            time("let-sum", n, &let_sum(n));
        }
        for n in sizes(&[1_000, 3_000, 10_000]) {
            time("term-sum", n, &term_sum(n));
        }
        for n in sizes(&[1_000, 3_000, 10_000]) {
            time("pair-sum", n, &pair_sum(n));
        }
    }
}
