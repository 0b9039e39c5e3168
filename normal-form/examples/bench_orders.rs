//! Timings of the L4 normal form (Earth–Moon) per order and precision: the normal form alone
//! (H̄ and the generators) and with the coordinate transformations, the dd/f64 ratios, and
//! the phases of the dd run. Best of several repetitions.
//!
//! `cargo run -p lasalle-normal-form --release --example bench_orders [orders…] [--reps N]
//! [--f64 | --dd] [--no-transform]` (`--f64`/`--dd`/`--no-transform`: one run per order,
//! for profilers).
use lasalle_normal_form::validate::EARTH_MOON_MU;
use lasalle_normal_form::{normalize_model, ModelPoint, NormalForm, Options, Precision};
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
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut orders = Vec::new();
    let mut reps_arg = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--reps" {
            reps_arg = it.next().and_then(|s| s.parse::<usize>().ok());
        } else if let Ok(n) = a.parse::<usize>() {
            orders.push(n);
        }
    }
    if orders.is_empty() {
        orders = vec![8, 12, 16, 20, 24, 28, 32];
    }
    let has = |f: &str| args.iter().any(|a| a == f);
    let model =
        lasalle_model::load_model(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl"))
            .expect("model");
    let params = [("mu".to_string(), EARTH_MOON_MU)];
    let point = ModelPoint::Named("L4".into());
    let time = |order: usize, precision: Precision, transform: bool| -> (f64, NormalForm) {
        let opts = Options::with_order(order)
            .precision(precision)
            .error_estimate(false)
            .transform(transform);
        let reps = reps_arg.unwrap_or(match order {
            0..=12 => 20,
            13..=20 => 5,
            _ => 2,
        });
        let mut best = f64::INFINITY;
        let mut nf = None;
        for _ in 0..reps.max(1) {
            let t = Instant::now();
            nf = Some(normalize_model(&model, &params, &point, &opts).expect("normal form"));
            best = best.min(t.elapsed().as_secs_f64());
        }
        (best, nf.unwrap())
    };
    if has("--f64") || has("--dd") {
        let precision = if has("--dd") {
            Precision::DoubleDouble
        } else {
            Precision::F64
        };
        for &order in &orders {
            let (t, nf) = time(order, precision, !has("--no-transform"));
            let p = &nf.diagnostics.timings;
            println!(
                "order {order} {precision}: {t:.4} s (lie {:.4}, transform {:.4})",
                p.lie, p.transform
            );
        }
        return;
    }
    println!("        normal form alone [s]          with transformation [s]        dd phases [s]");
    println!(
        "order      f64        dd  ratio        f64        dd  ratio      lie  real+maps  peak RSS[MiB]"
    );
    for &order in &orders {
        let (f_nf, _) = time(order, Precision::F64, false);
        let (d_nf, _) = time(order, Precision::DoubleDouble, false);
        let (f_tr, _) = time(order, Precision::F64, true);
        let (d_tr, nf) = time(order, Precision::DoubleDouble, true);
        let p = &nf.diagnostics.timings;
        println!(
            "{order:5} {f_nf:9.4} {d_nf:9.4} {:6.2} {f_tr:10.4} {d_tr:9.4} {:6.2} {:8.4} {:10.4} {:14.1}",
            d_nf / f_nf,
            d_tr / f_tr,
            p.lie,
            p.transform,
            peak_rss_kib().unwrap_or(0) as f64 / 1024.0
        );
    }
}
