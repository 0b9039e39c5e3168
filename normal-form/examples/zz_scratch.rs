use lasalle_normal_form::bound::{tube_radii, Bound, Metric, Norm};
use lasalle_normal_form::{normalize_model_file, ModelPoint, Options};
use std::time::Instant;
fn main() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl");
    let params = [("mu".to_string(), 0.01215058560962404)];
    for n in [4, 6, 8, 10, 12, 14, 16] {
        let t = Instant::now();
        let nf = normalize_model_file(model, &params, &ModelPoint::Named("L4".into()), &Options::with_order(n).remainder_degree(2 * n).error_estimate(false)).unwrap();
        let el = t.elapsed().as_secs_f64();
        let rem = nf.remainder.as_ref().unwrap();
        let g = Bound::new(rem, Norm::Gradient);
        let r = Bound::new(rem, Norm::Radial);
        print!("N={n} ({el:.2}s) low={:?} coef[..3]={:?}", g.lowest_degree(), &g.coefficients[..3]);
        for d0 in [1e-3, 3e-3, 1e-2, 3e-2] {
            let t = Instant::now();
            let tr = tube_radii(&nf, d0, 2.0 * d0, Metric::LinearNormal).unwrap();
            let el = t.elapsed().as_secs_f64();
            print!("\n   d0={d0:e} rho0={:.6e} rho1={:.6e} ({el:.2}s) Tg={:.3e} Tr={:.3e}", tr.rho0, tr.rho1, g.time(tr.rho0, tr.rho1).lower, r.time(tr.rho0, tr.rho1).lower);
        }
        let tr = tube_radii(&nf, 1e-3, 2e-3, Metric::Euclidean).unwrap();
        println!("\n   eucl rho0 {:e} rho1 {:e}", tr.rho0, tr.rho1);
    }
}
