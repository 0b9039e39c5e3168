//! Frequencies of the normal form at orders 2…16 against frequencies measured along a DOPRI5
//! orbit of the full CR3BP near L4 (Earth–Moon). `… --example freq [amplitude]`
use lasalle_normal_form::validate::*;
use lasalle_normal_form::*;
fn main() {
    let model =
        lasalle_model::load_model(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl"))
            .expect("model");
    let h = ModelHamiltonian::new(&model, &[("mu".to_string(), EARTH_MOON_MU)]).unwrap();
    let p = Point::Newton(h.point("L4").unwrap());
    let reference = normalize(&h, &p, &Options::with_order(16).error_estimate(false)).unwrap();
    let amp: f64 = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(0.01);
    let w0 = [amp, 0.0, 0.0, amp];
    let z0 = reference.from_normal(&w0).unwrap();
    let t0 = std::time::Instant::now();
    let nu = measure_frequencies(&h, &reference, &z0, 2000.0, 0.5, 1e-13).unwrap();
    println!("measured {:?} in {:?}", nu, t0.elapsed());
    for order in [2, 4, 6, 8, 10, 12, 14, 16] {
        let nf = normalize(&h, &p, &Options::with_order(order).error_estimate(false)).unwrap();
        let i = nf.actions(&z0).unwrap_or(vec![amp * amp / 2.0; 2]);
        let f = nf.frequencies(&i);
        println!(
            "order {order:2}: {:?} err {:.3e} {:.3e}",
            f,
            f[0] - nu[0],
            f[1] - nu[1]
        );
    }
    let mx: f64 = reference
        .to_normal_map
        .as_ref()
        .unwrap()
        .components
        .iter()
        .flat_map(|p| p.terms().map(|t| t.2.abs()))
        .fold(0.0, f64::max);
    println!(
        "max transform coeff {mx:e}, imag {}",
        reference.diagnostics.transform_imag_residual
    );
}
