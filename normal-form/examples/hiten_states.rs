//! Are hiten's centre-manifold states on the centre manifold? Reads the CSV of
//! `scripts/hiten_states.py` and prints, for each state as hiten gives it and with the signs
//! of y and vx flipped, lasalle's hyperbolic coordinates max(|Q1'|, |P1'|) at t = 0 and after
//! integrating the model for t = 2 (DOPRI5, tolerance 1e-13), and the centre coordinates
//! lasalle reads from the state, in hiten's units and gauge (lengths / γ, the planar pair
//! rotated by π):
//! `cargo run -p lasalle-normal-form --release --example hiten_states -- hiten_states.csv`.

use lasalle_normal_form::center::{center_manifold_model, CenterOptions};
use lasalle_normal_form::validate::orbit;
use lasalle_normal_form::ModelHamiltonian;

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("the CSV of scripts/hiten_states.py");
    let text = std::fs::read_to_string(&path).expect("readable CSV");
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp_spatial.lsl");
    let model = lasalle_model::load_model(std::path::Path::new(file)).unwrap();
    let h = ModelHamiltonian::new(&model, &[]).unwrap();
    println!("| point | hiten's (q2, p2, q3, p3) | hiten's state: t = 0 | t = 2 | its (q2, p2, q3, p3) by lasalle | y, vx flipped: t = 0 | t = 2 | its (q2, p2, q3, p3) by lasalle |");
    println!("|---|---|---:|---:|---|---:|---:|---|");
    for line in text.lines().filter(|l| l.starts_with('L')) {
        let f: Vec<&str> = line.split(',').collect();
        let v: Vec<f64> = f[1..].iter().map(|x| x.parse().unwrap()).collect();
        let cm = center_manifold_model(&model, &[], f[0], &CenterOptions::with_order(12)).unwrap();
        let hyp = |z: &[f64]| {
            let w = cm.to_normal(z).unwrap();
            w[0].abs().max(w[3].abs())
        };
        let state = |s: &[f64]| -> Vec<f64> {
            // synodic velocities → momenta p = v + ω × q
            vec![s[0], s[1], s[2], s[3] - s[1], s[4] + s[0], s[5]]
        };
        let s = &v[4..10];
        let given = state(s);
        let flipped = state(&[s[0], -s[1], s[2], -s[3], s[4], s[5]]);
        let run = |z: &[f64]| {
            let o = orbit(&h, z, &[0.0, 2.0], 1e-13).unwrap();
            (hyp(&o[0]), hyp(&o[1]))
        };
        let (a0, a1) = run(&given);
        let (b0, b1) = run(&flipped);
        // lasalle's centre coordinates of the state, in hiten's units and gauge
        // (lengths / γ, the planar pair rotated by π)
        let g = cm.gamma.as_ref().map_or(1.0, |g| g.value);
        let centre = |z: &[f64]| {
            let w = cm.to_normal(z).unwrap();
            format!(
                "({:.6}, {:.6}, {:.6}, {:.6})",
                -w[1] / g,
                -w[4] / g,
                w[2] / g,
                w[5] / g
            )
        };
        println!(
            "| {} | ({}, {}, {}, {}) | {a0:.1e} | {a1:.1e} | {} | {b0:.1e} | {b1:.1e} | {} |",
            f[0],
            v[0],
            v[1],
            v[2],
            v[3],
            centre(&given),
            centre(&flipped)
        );
    }
}
