//! Accuracy of the L4 normal form coefficients: f64 (with and without the compensated low
//! degrees) vs double-double, and double-double vs double-double in a rotated normal basis
//! (an error estimate independent of the precision).
//!
//! `cargo run -p lasalle-normal-form --release --example accuracy [mu] [order]`: the table;
//! `… --example accuracy -- --scan [order]`: the worst relative f64 error through `order`
//! for 12 mass ratios μ = μ_EM·(1 + 7·10⁻⁴ k), k = 0…11, plain f64 vs compensated.
use lasalle_model::Model;
use lasalle_normal_form::validate::EARTH_MOON_MU;
use lasalle_normal_form::{normalize_model, ModelPoint, NormalForm, Options, Precision};

fn run(model: &Model, mu: f64, opts: &Options) -> NormalForm {
    let params = [("mu".to_string(), mu)];
    normalize_model(model, &params, &ModelPoint::Named("L4".into()), opts).unwrap()
}

/// |(x − reference)/reference| per coefficient of H̄.
fn rel(x: &NormalForm, reference: &NormalForm) -> Vec<f64> {
    x.hamiltonian
        .iter()
        .zip(&reference.hamiltonian)
        .map(|(a, r)| {
            let v = r.coeff.value + r.coeff.lo;
            (((a.coeff.value - r.coeff.value) + (a.coeff.lo - r.coeff.lo)) / v).abs()
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let model =
        lasalle_model::load_model(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl"))
            .expect("model");
    let num = |i: usize| args.get(i).and_then(|s| s.parse::<f64>().ok());
    if args.first().map(String::as_str) == Some("--scan") {
        let order = num(1).unwrap_or(8.0) as usize;
        let base = Options::with_order(order)
            .error_estimate(false)
            .transform(false);
        for (label, comp) in [("plain f64", 0), ("compensated", base.compensated_degree)] {
            let mut worst = Vec::new();
            for k in 0..12 {
                let mu = EARTH_MOON_MU * (1.0 + 7e-4 * k as f64);
                let d = run(&model, mu, &base.clone().precision(Precision::DoubleDouble));
                let mut o = base.clone();
                o.compensated_degree = comp;
                worst.push(
                    rel(&run(&model, mu, &o), &d)
                        .into_iter()
                        .fold(0.0, f64::max),
                );
            }
            let mut s = worst.clone();
            s.sort_by(f64::total_cmp);
            println!(
                "{label:>12}: median {:.2e}, max {:.2e}  ({})",
                s[s.len() / 2],
                s[s.len() - 1],
                worst
                    .iter()
                    .map(|x| format!("{x:.1e}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            );
        }
        return;
    }
    let mu = num(0).unwrap_or(0.001);
    let order = num(1).unwrap_or(12.0) as usize;
    let base = Options::with_order(order)
        .error_estimate(false)
        .transform(false);
    let d = run(&model, mu, &base.clone().precision(Precision::DoubleDouble));
    let f = run(&model, mu, &base);
    let mut plain = base.clone();
    plain.compensated_degree = 0;
    let fp = run(&model, mu, &plain);
    let mut rot = base.clone();
    rot.basis_rotation = vec![0.7, -1.3];
    let fr = run(&model, mu, &rot);
    let dr = run(&model, mu, &rot.clone().precision(Precision::DoubleDouble));
    println!(
        "mu = {mu}, order {order}, omega = {:?}",
        d.frequencies_linear()
    );
    println!(
        "{:>8} {:>26} {:>11} {:>11} {:>11} {:>11}",
        "I^a", "h_a (dd)", "rel f64", "plain f64", "f64 rot.", "dd rot."
    );
    let cols = [rel(&f, &d), rel(&fp, &d), rel(&fr, &d), rel(&dr, &d)];
    let mut worst = [0.0f64; 4];
    for (i, t) in d.hamiltonian.iter().enumerate() {
        print!(
            "{:>8} {:>26.17e}",
            format!("{:?}", t.exponents),
            t.coeff.value + t.coeff.lo
        );
        for (w, c) in worst.iter_mut().zip(&cols) {
            *w = w.max(c[i]);
            print!(" {:>11.2e}", c[i]);
        }
        println!();
    }
    println!(
        "worst relative: f64 {:.2e}, plain f64 {:.2e}, f64 rotated basis {:.2e}, dd rotated basis {:.2e}",
        worst[0], worst[1], worst[2], worst[3]
    );
}
