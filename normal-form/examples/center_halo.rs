//! The halo bifurcation on the centre manifold of Earth–Moon L1/L2 (scratch exploration).

use lasalle_normal_form::center::poincare::{
    fixed_point, halo_bifurcation, planar_orbit, solve_p3, ReducedField,
};
use lasalle_normal_form::center::{center_manifold_model, CenterOptions};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let point = args.get(1).cloned().unwrap_or("L1".into());
    let order: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(16);
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp_spatial.lsl");
    let model = lasalle_model::load_model(std::path::Path::new(file)).unwrap();
    let o = CenterOptions {
        order,
        transform: false,
        birkhoff: false,
        ..CenterOptions::default()
    };
    let cm = center_manifold_model(&model, &[], &point, &o).unwrap();
    let g = cm.gamma.unwrap().value;
    let g2 = g * g;
    let f = ReducedField::new(&cm.reduced_poly).unwrap();
    let wv = cm.omega[1].value;
    for hg in [0.05, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8, 1.0, 1.2] {
        let h = hg * g2;
        match planar_orbit(&f, h, 2.0 * g, 400) {
            Some(o) => println!(
                "h/g2 = {hg}: q2/g = {:.5} T = {:.5} trace = {:.6}",
                o.q2 / g,
                o.period,
                o.vertical_trace
            ),
            None => println!("h/g2 = {hg}: none"),
        }
    }
    let hm = lasalle_normal_form::ModelHamiltonian::new(&model, &[]).unwrap();
    let eq: Vec<f64> = cm.equilibrium.iter().map(|v| v.value).collect();
    let t0 = std::time::Instant::now();
    let full = lasalle_normal_form::center::lyapunov::full_halo_bifurcation(
        &hm,
        &eq,
        cm.omega[0].value,
        cm.omega[1].value,
        0.02 * g,
        -1.0,
        1e-13,
    )
    .unwrap();
    println!(
        "full model: dx/g = {:.9} energy/g2 = {:.9} energy = {:.12e} trace = {:.12} T = {:.9} ({:.1} s)",
        full.dx / g,
        full.energy / g2,
        full.energy,
        full.vertical_trace,
        full.period,
        t0.elapsed().as_secs_f64()
    );
    let hb = halo_bifurcation(&f, 0.1 * g2, 0.6 * g2, 2.0 * g, 1e-9);
    println!("bifurcation h = {hb:?}, h/g2 = {:?}", hb.map(|h| h / g2));
    for hg in [0.2, 0.4, 0.6, 0.8] {
        let h = hg * g2;
        let period = 2.0 * std::f64::consts::PI / wv;
        let dt = period / 200.0;
        let p_max = 4.0 * (2.0 * h / wv).sqrt();
        let r = (2.0 * h / cm.omega[0].value).sqrt();
        let mut found: Vec<[f64; 2]> = Vec::new();
        let mut fails = 0;
        let n = 9;
        for i in 0..n {
            for j in 0..n {
                let x = [
                    r * (2.0 * (i as f64 + 0.5) / n as f64 - 1.0),
                    r * (2.0 * (j as f64 + 0.5) / n as f64 - 1.0),
                ];
                if solve_p3(&f, x[0], x[1], h, p_max).is_none() {
                    fails += 1;
                    continue;
                }
                if let Some(fp) = fixed_point(&f, h, x, dt, p_max, 1e-7 * g, 1e-11 * g) {
                    if !found
                        .iter()
                        .any(|p| (p[0] - fp.point[0]).hypot(p[1] - fp.point[1]) < 1e-6 * g)
                    {
                        println!(
                            "h/g2 = {hg}: fixed point ({:.6}, {:.6}) /g, trace {:.5}, res {:.1e}",
                            fp.point[0] / g,
                            fp.point[1] / g,
                            fp.trace,
                            fp.residual
                        );
                        found.push(fp.point);
                    }
                }
            }
        }
        println!("h/g2 = {hg}: {fails} seeds without a lift");
    }
}
