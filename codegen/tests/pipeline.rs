//! The paper models go through the whole pipeline; the gradient of V stays a small multiple
//! of V's cost (reverse mode, ≤ 4×). Prints the per-model statistics.

#[test]
fn paper_models_generate_with_cheap_gradients() {
    for name in [
        "kepler",
        "perturbed_kepler",
        "rigid_body",
        "cr3bp",
        "so3_type_i",
    ] {
        let path = format!("{}/../models/{name}.lsl", env!("CARGO_MANIFEST_DIR"));
        let m = lasalle_codegen::generate_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let s = &m.report.stats;
        eprintln!(
            "{name}: {:.1} ms, {} lines, {} bytes\n  {s:?}\n  {:?}",
            m.report.time.as_secs_f64() * 1e3,
            m.report.lines,
            m.report.bytes,
            m.report.conservation
        );
        assert!(
            s.lyapunov_gradient.emitted <= 4 * s.lyapunov.cse,
            "{name}: ∇V costs {} ops, V {}",
            s.lyapunov_gradient.emitted,
            s.lyapunov.cse
        );
        assert!(s.feedback_field.emitted <= s.feedback_field.cse);
    }
}
