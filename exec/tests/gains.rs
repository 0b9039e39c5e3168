//! The Gauss–Newton norm L = ‖Dfᵀ K Df‖₂ that the scaled and adaptive gains divide by: with
//! fewer invariant components than state components it is taken on the small matrix
//! K^½ Df Dfᵀ K^½, which must give the norm of the N × N matrix.

use lasalle_exec::{Backend, LoadedModel};
use lasalle_runtime::{
    gauss_newton_hessian, gauss_newton_norm, symmetric_spectral_norm, ModelInfo, Parameters,
};

const NBODY: &str = include_str!("../../models/nbody.lsl");

#[test]
fn the_small_gram_matrix_gives_the_norm_of_the_large_one() {
    let text = NBODY.replace(
        NBODY
            .lines()
            .find(|l| l.trim_start().starts_with("param n ="))
            .expect("nbody.lsl sizes itself on a `param n = …;` line"),
        "param n = 5;",
    );
    let m = LoadedModel::from_source("nbody.lsl", &text, Backend::Jit).unwrap();
    let x = m.point("ring").unwrap();
    let (n, k) = (x.len(), m.gain_names().len());
    assert_eq!(n, 30);
    for gains in [vec![1.0; k], (1..=k).map(|g| g as f64 * 0.7).collect()] {
        let small = gauss_newton_norm::<_, f64, Vec<f64>, Vec<f64>>(&m, &x, &gains);
        let h = gauss_newton_hessian::<_, f64, Vec<f64>, Vec<f64>>(&m, &x, &gains);
        let large = symmetric_spectral_norm(&h, 2000, 1e-14);
        assert!(large > 0.0);
        assert!(
            (small - large).abs() <= 1e-7 * large,
            "gains {gains:?}: {small} on the Gram matrix, {large} on H_GN"
        );
    }
}
