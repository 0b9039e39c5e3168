//! The three paper models go through parse → lower → derive → check.

use lasalle_codegen::{check, derive, load_model};

fn models_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models")
}

#[test]
fn paper_models_pass_the_conservation_check() {
    for name in ["kepler", "perturbed_kepler", "rigid_body"] {
        let mut m =
            load_model(models_dir().join(format!("{name}.lsl"))).unwrap_or_else(|e| panic!("{e}"));
        let d = derive::derive(&mut m);
        let verdicts = check::check(&mut m, &d).unwrap_or_else(|e| panic!("{e}"));
        let v_ops = m.graph.op_count(&[m.lyapunov]);
        let g_ops = m.graph.op_count(&d.lyapunov_gradient);
        eprintln!("{name}: {verdicts:?}\n  V ops {v_ops:?}, grad V ops {g_ops:?}");
    }
}
