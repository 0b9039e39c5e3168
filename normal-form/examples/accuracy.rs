//! Accuracy of the L4 normal form coefficients: f64 vs double-double, and double-double vs
//! double-double in a rotated normal basis (an error estimate independent of the precision).
//!
//! `cargo run -p lasalle-normal-form --release --example accuracy [mu] [order]`
use lasalle_normal_form::{normalize_model, ModelPoint, Options, Precision};

fn main() {
    let mu: f64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.001);
    let order: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(12);
    let model =
        lasalle_codegen::load_model(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl"))
            .expect("model");
    let params = [("mu".to_string(), mu)];
    let l4 = ModelPoint::Named("L4".into());
    let normalize = |opts: &Options| normalize_model(&model, &params, &l4, opts);
    let base = Options::with_order(order)
        .error_estimate(false)
        .transform(false);
    let f = normalize(&base.clone().precision(Precision::F64)).unwrap();
    let d = normalize(&base.clone().precision(Precision::DoubleDouble)).unwrap();
    let mut rot = base.clone().precision(Precision::DoubleDouble);
    rot.basis_rotation = vec![0.7, -1.3];
    let dr = normalize(&rot).unwrap();
    let mut rotf = base.clone();
    rotf.basis_rotation = vec![0.7, -1.3];
    let fr = normalize(&rotf).unwrap();
    println!(
        "mu = {mu}, order {order}, omega = {:?}",
        d.frequencies_linear()
    );
    println!(
        "{:>8} {:>26} {:>11} {:>11} {:>11}",
        "I^a", "h_a (dd)", "rel f64", "rel f64rot", "rel dd-rot"
    );
    let mut worst = [0.0f64; 3];
    for ((tf, td), (tdr, tfr)) in f
        .hamiltonian
        .iter()
        .zip(&d.hamiltonian)
        .zip(dr.hamiltonian.iter().zip(&fr.hamiltonian))
    {
        let v = td.coeff.value + td.coeff.lo;
        let rel = |x: f64, lo: f64| (((x - td.coeff.value) + (lo - td.coeff.lo)) / v).abs();
        let (a, b, c) = (
            rel(tf.coeff.value, 0.0),
            rel(tfr.coeff.value, 0.0),
            rel(tdr.coeff.value, tdr.coeff.lo),
        );
        worst = [worst[0].max(a), worst[1].max(b), worst[2].max(c)];
        println!(
            "{:>8} {:>26.17e} {:>11.2e} {:>11.2e} {:>11.2e}",
            format!("{:?}", tf.exponents),
            v,
            a,
            b,
            c
        );
    }
    println!(
        "worst relative: f64 {:.2e}, f64 rotated basis {:.2e}, dd rotated basis {:.2e}",
        worst[0], worst[1], worst[2]
    );
}
