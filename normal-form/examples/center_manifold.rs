//! Timings and linear data of the centre manifolds at Earth–Moon L1/L2/L3:
//! `cargo run -p lasalle-normal-form --release --example center_manifold -- [ORDER] [REPEATS]`.

use lasalle_normal_form::center::{center_manifold_model, CenterOptions};
use lasalle_normal_form::Precision;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let order: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(16);
    let repeats: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/");
    println!("| model | point | precision | lambda | omega | reduced terms | reduction (s) | + Birkhoff (s) | + maps (s) | total (s) |");
    println!("|---|---|---|---:|---|---:|---:|---:|---:|---:|");
    for file in ["cr3bp.lsl", "cr3bp_spatial.lsl"] {
        let model =
            lasalle_model::load_model(std::path::Path::new(&format!("{root}{file}"))).unwrap();
        for point in ["L1", "L2", "L3"] {
            for precision in [Precision::F64, Precision::DoubleDouble] {
                let o = CenterOptions {
                    order,
                    precision,
                    ..CenterOptions::default()
                };
                let mut best: Option<lasalle_normal_form::center::CenterManifold> = None;
                for _ in 0..repeats {
                    let cm = center_manifold_model(&model, &[], point, &o).unwrap();
                    if best
                        .as_ref()
                        .is_none_or(|b| cm.diagnostics.timings.total < b.diagnostics.timings.total)
                    {
                        best = Some(cm);
                    }
                }
                let cm = best.unwrap();
                let t = &cm.diagnostics.timings;
                let nz = cm.reduced.iter().filter(|t| t.coeff.value != 0.0).count();
                println!(
                    "| {file} | {point} | {precision} | {:.12} | {} | {nz} | {:.3} | {:.3} | {:.3} | {:.3} |",
                    cm.lambda.value,
                    cm.omega.iter().map(|w| format!("{:.12}", w.value)).collect::<Vec<_>>().join(", "),
                    t.taylor + t.linear + t.reduction,
                    t.birkhoff,
                    t.transform,
                    t.total
                );
            }
        }
    }
}
