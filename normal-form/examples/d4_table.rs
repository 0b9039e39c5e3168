//! D₄ at L4 against Deprit & Deprit-Bartholomé, and μ_c by bisection on our D₄.
//!
//! `cargo run -p lasalle-normal-form --release --example d4_table`
use lasalle_model::Model;
use lasalle_normal_form::validate::{deprit_d4, EARTH_MOON_MU};
use lasalle_normal_form::{normalize_model, ModelPoint, Options, Precision};

fn d4(model: &Model, mu: f64, p: Precision) -> (f64, f64, f64, f64) {
    let nf = normalize_model(
        model,
        &[("mu".to_string(), mu)],
        &ModelPoint::Named("L4".into()),
        &Options::with_order(4)
            .precision(p)
            .error_estimate(false)
            .transform(false),
    )
    .unwrap();
    let d = nf.d4.unwrap();
    (d.a.value, d.b.value, d.c.value, d.d4.value + d.d4.lo)
}

fn main() {
    let model =
        &lasalle_model::load_model(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl"))
            .expect("model");
    println!(
        "{:>20} {:>12} {:>12} {:>12} {:>22} {:>22} {:>10} {:>10}",
        "mu", "A", "B", "C", "D4 (ours, dd)", "Deprit (textbook)", "rel f64", "rel dd"
    );
    for mu in [0.001, 0.005, 0.01, EARTH_MOON_MU, 0.02, 0.03] {
        let (a, b, c, dd) = d4(model, mu, Precision::DoubleDouble);
        let (.., f) = d4(model, mu, Precision::F64);
        let r = deprit_d4(mu);
        println!(
            "{mu:>20} {a:>12.8} {b:>12.8} {c:>12.8} {dd:>22.15e} {r:>22.15e} {:>10.1e} {:>10.1e}",
            ((f + r) / r).abs(),
            ((dd + r) / r).abs()
        );
    }
    let (mut lo, mut hi) = (0.0105, 0.0113);
    let f_lo = d4(model, lo, Precision::DoubleDouble).3;
    for _ in 0..60 {
        let m = 0.5 * (lo + hi);
        if d4(model, m, Precision::DoubleDouble).3 * f_lo > 0.0 {
            lo = m
        } else {
            hi = m
        }
    }
    let w = (541.0 - 199_945f64.sqrt()) / 1288.0;
    println!(
        "mu_c = {:.15} (closed form {:.15})",
        0.5 * (lo + hi),
        (1.0 - (1.0 - 16.0 * w / 27.0).sqrt()) / 2.0
    );
}
