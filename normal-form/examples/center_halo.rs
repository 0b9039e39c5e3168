//! The halo bifurcation at Earth–Moon L1 and L2, two ways: the energy at which the planar
//! Lyapunov orbit's vertical monodromy trace passes 2 in the reduced flow on the centre
//! manifold (degrees 8, 12, 16), and the same along the planar Lyapunov family of the full
//! model found by differential correction; then the halo fixed points of the section
//! Q₃ = 0 at a few energies:
//! `cargo run -p lasalle-normal-form --release --example center_halo -- [L1|L2 …]`.

use lasalle_normal_form::center::lyapunov::full_halo_bifurcation;
use lasalle_normal_form::center::poincare::{
    fixed_point, halo_bifurcation, planar_orbit, ReducedField,
};
use lasalle_normal_form::center::{center_manifold_model, CenterOptions};
use lasalle_normal_form::ModelHamiltonian;

fn main() {
    let points: Vec<String> = std::env::args().skip(1).collect();
    let points = if points.is_empty() {
        vec!["L1".to_string(), "L2".to_string()]
    } else {
        points
    };
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp_spatial.lsl");
    let model = lasalle_model::load_model(std::path::Path::new(file)).unwrap();
    let hm = ModelHamiltonian::new(&model, &[]).unwrap();
    println!("| point | how | h/γ² at the bifurcation | relative to the full model | Jacobi constant C | period |");
    println!("|---|---|---:|---:|---:|---:|");
    for point in &points {
        let cm = |order: usize| {
            let o = CenterOptions {
                order,
                transform: false,
                birkhoff: false,
                ..CenterOptions::default()
            };
            center_manifold_model(&model, &[], point, &o).unwrap()
        };
        let c16 = cm(16);
        let g = c16.gamma.unwrap().value;
        let g2 = g * g;
        let e0 = c16.energy.value;
        let eq: Vec<f64> = c16.equilibrium.iter().map(|v| v.value).collect();
        let (wp, wv) = (c16.omega[0].value, c16.omega[1].value);
        let full = full_halo_bifurcation(&hm, &eq, wp, wv, 0.02 * g, -1.0, 1e-13).unwrap();
        println!(
            "| {point} | full model, differential correction (x₀ − x_L = {:.6}γ) | {:.9} | — | {:.9} | {:.9} |",
            full.dx / g,
            full.energy / g2,
            -2.0 * (e0 + full.energy),
            full.period
        );
        for order in [8, 12, 16] {
            let c = if order == 16 { c16.clone() } else { cm(order) };
            let f = ReducedField::new(&c.reduced_poly).unwrap();
            let h = halo_bifurcation(&f, 0.1 * g2, 0.6 * g2, 2.0 * g, 1e-11).unwrap();
            let o = planar_orbit(&f, h, 2.0 * g, 400).unwrap();
            println!(
                "| {point} | reduced flow, degree {order} | {:.9} | {:.1e} | {:.9} | {:.9} |",
                h / g2,
                (h - full.energy) / full.energy,
                -2.0 * (e0 + h),
                o.period
            );
        }
    }
    println!();
    println!("| point | h/γ² | vertical Lyapunov (Q₂, P₂)/γ | halo (Q₂, P₂)/γ | trace of the map there |");
    println!("|---|---:|---|---|---:|");
    for point in &points {
        let c = center_manifold_model(
            &model,
            &[],
            point,
            &CenterOptions {
                transform: false,
                birkhoff: false,
                ..CenterOptions::default()
            },
        )
        .unwrap();
        let g = c.gamma.unwrap().value;
        let f = ReducedField::new(&c.reduced_poly).unwrap();
        let wv = c.omega[1].value;
        for hg in [0.2, 0.4, 0.6, 0.8] {
            let h = hg * g * g;
            let o = planar_orbit(&f, h, 2.0 * g, 400).unwrap();
            let p_max = 4.0 * (2.0 * h / wv).sqrt();
            let dt = 2.0 * std::f64::consts::PI / wv / 200.0;
            let newton = |x: [f64; 2]| fixed_point(&f, h, x, dt, p_max, 1e-7 * g, 1e-11 * g);
            let v = newton([0.0, 0.0]).unwrap();
            let mut halo = None;
            let seeds = [0.6, 0.75, 0.85, 0.92, 0.97, 0.985, 0.995];
            for x in seeds
                .iter()
                .map(|s| [s * o.q2, 0.0])
                .chain(seeds.iter().map(|s| [s * o.q2, v.point[1]]))
            {
                if let Some(fp) = newton(x) {
                    if (fp.point[0] - v.point[0]).abs() > 0.05 * o.q2 {
                        halo = Some(fp);
                        break;
                    }
                }
            }
            println!(
                "| {point} | {hg} | ({:.6}, {:.6}) | {} | {} |",
                v.point[0] / g,
                v.point[1] / g,
                halo.as_ref().map_or("none".to_string(), |p| format!(
                    "(±{:.6}, {:.6})",
                    p.point[0] / g,
                    p.point[1] / g
                )),
                halo.as_ref()
                    .map_or("—".to_string(), |p| format!("{:.5}", p.trace))
            );
        }
    }
    println!();
    println!(
        "| point | degree | vertical trace of the planar orbit at h/γ² = 0.2 | 0.6 | 1.0 | 1.2 |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    for point in &points {
        for order in [8, 12, 16] {
            let o = CenterOptions {
                order,
                transform: false,
                birkhoff: false,
                ..CenterOptions::default()
            };
            let c = center_manifold_model(&model, &[], point, &o).unwrap();
            let g = c.gamma.unwrap().value;
            let f = ReducedField::new(&c.reduced_poly).unwrap();
            let row: Vec<String> = [0.2, 0.6, 1.0, 1.2]
                .iter()
                .map(|hg| {
                    planar_orbit(&f, hg * g * g, 2.0 * g, 400)
                        .map_or("—".to_string(), |o| format!("{:.6}", o.vertical_trace))
                })
                .collect();
            println!("| {point} | {order} | {} |", row.join(" | "));
        }
    }
}
