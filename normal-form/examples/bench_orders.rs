//! Timings of the L4 normal form (Earth–Moon) per order and precision, with peak memory.
//!
//! `cargo run -p lasalle-normal-form --release --example bench_orders [orders…]`
use lasalle_normal_form::validate::EARTH_MOON_MU;
use lasalle_normal_form::{normalize_model, ModelPoint, Options, Precision};
use std::time::Instant;

fn peak_rss_kib() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

fn main() {
    let orders: Vec<usize> = {
        let a: Vec<usize> = std::env::args()
            .skip(1)
            .filter_map(|s| s.parse().ok())
            .collect();
        if a.is_empty() {
            vec![8, 12, 16, 20, 24, 28, 32]
        } else {
            a
        }
    };
    let transform = !std::env::args().any(|a| a == "--no-transform");
    let model =
        lasalle_codegen::load_model(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl"))
            .expect("model");
    let params = [("mu".to_string(), EARTH_MOON_MU)];
    let point = ModelPoint::Named("L4".into());
    println!("order  precision  total[s]   taylor   linear      lie  transform   peak RSS[MiB]");
    for &order in &orders {
        for precision in [Precision::F64, Precision::DoubleDouble] {
            let opts = Options::with_order(order)
                .precision(precision)
                .error_estimate(false)
                .transform(transform);
            let reps = if order <= 12 {
                20
            } else if order <= 20 {
                3
            } else {
                1
            };
            let mut best = f64::INFINITY;
            let mut nf = None;
            for _ in 0..reps {
                let t = Instant::now();
                nf = Some(normalize_model(&model, &params, &point, &opts).expect("normal form"));
                best = best.min(t.elapsed().as_secs_f64());
            }
            let t = &nf.as_ref().unwrap().diagnostics.timings;
            println!(
                "{order:5}  {:>9}  {best:8.4}  {:7.4}  {:7.4}  {:7.4}  {:9.4}   {:8.1}",
                precision.to_string(),
                t.taylor,
                t.linear,
                t.lie,
                t.transform,
                peak_rss_kib().unwrap_or(0) as f64 / 1024.0
            );
        }
    }
}
