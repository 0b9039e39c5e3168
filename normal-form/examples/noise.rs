//! How well the error estimates track the real rounding error, per degree of H̄, at a mass
//! ratio of the CR3BP:
//! `cargo run -p lasalle-normal-form --release --example noise -- 0.01215058560962404 24`.
//! Columns: degree, max |h| (dd), real f64 error max |f64 − dd| / max |h|, the same per
//! coefficient (max |f64 − dd| / |h|), the rotation estimate max |f64 − f64 rotated| / max |h|
//! and per coefficient, f64 max |Im h| / max |h| (structurally ~0: not an error measure).

use lasalle_normal_form::{normalize_model_file, ModelPoint, NormalForm, Options, Precision};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mu: f64 = args
        .get(1)
        .map_or(0.01215058560962404, |s| s.parse().unwrap());
    let order: usize = args.get(2).map_or(24, |s| s.parse().unwrap());
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl");
    let params = [("mu".to_string(), mu)];
    let at = ModelPoint::Named("L4".into());
    let run = |p: Precision, rot: Vec<f64>| {
        let t = std::time::Instant::now();
        let mut o = Options::with_order(order)
            .precision(p)
            .error_estimate(false)
            .transform(false)
            .max_relative_error(None);
        o.basis_rotation = rot;
        let nf = normalize_model_file(model, &params, &at, &o).unwrap();
        eprintln!("{p}: {:.3} s", t.elapsed().as_secs_f64());
        nf
    };
    let f = run(Precision::F64, vec![]);
    let r = run(Precision::F64, vec![0.7, -1.3]);
    let d = run(Precision::DoubleDouble, vec![]);
    let diff = |a: &NormalForm, b: &NormalForm, k: usize, rel: bool| {
        a.hamiltonian
            .iter()
            .zip(&b.hamiltonian)
            .filter(|(x, _)| x.degree == k)
            .map(|(x, y)| {
                let e = (x.coeff.value - y.coeff.value - y.coeff.lo + x.coeff.lo).abs();
                if rel {
                    e / y.coeff.value.abs()
                } else {
                    e
                }
            })
            .fold(0.0, f64::max)
    };
    for nf in &f.diagnostics.hbar_degrees {
        let k = nf.degree;
        let max = d
            .hamiltonian
            .iter()
            .filter(|t| t.degree == k)
            .map(|t| t.coeff.value.abs())
            .fold(0.0, f64::max);
        println!(
            "{k:>3} {max:>10.3e} {:>10.3e} {:>10.3e} {:>10.3e} {:>10.3e} {:>10.3e}",
            diff(&f, &d, k, false) / max,
            diff(&f, &d, k, true),
            diff(&f, &r, k, false) / max,
            diff(&f, &r, k, true),
            nf.max_imag / nf.max_coeff.max(f64::MIN_POSITIVE)
        );
    }
}
