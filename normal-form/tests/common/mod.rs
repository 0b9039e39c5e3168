//! Shared by the integration tests: the DSL models of the workspace, loaded once.
#![allow(dead_code)]

use lasalle_model::Model;
use lasalle_normal_form::{
    normalize_model, ModelHamiltonian, ModelPoint, NormalForm, NormalFormError, Options,
};
use std::path::PathBuf;
use std::sync::OnceLock;

/// A file of the workspace (`models/…`).
pub fn workspace_file(rel: &str) -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(rel)
}

fn load(rel: &str) -> Model {
    lasalle_model::load_model(workspace_file(rel)).expect("model loads")
}

/// `models/cr3bp.lsl`.
pub fn cr3bp_model() -> &'static Model {
    static M: OnceLock<Model> = OnceLock::new();
    M.get_or_init(|| load("models/cr3bp.lsl"))
}

/// `models/coupled_oscillators.lsl`.
pub fn oscillators_model() -> &'static Model {
    static M: OnceLock<Model> = OnceLock::new();
    M.get_or_init(|| load("models/coupled_oscillators.lsl"))
}

/// The CR3BP Hamiltonian of the model file at mass ratio μ.
pub fn cr3bp(mu: f64) -> ModelHamiltonian<'static> {
    ModelHamiltonian::new(cr3bp_model(), &[("mu".to_string(), mu)]).expect("cr3bp")
}

/// The model's point L4 at mass ratio μ, in z = (q, p).
pub fn l4(mu: f64) -> Vec<f64> {
    cr3bp(mu).point("L4").expect("point L4")
}

/// The normal form of the CR3BP model at L4.
pub fn l4_normal_form(mu: f64, options: &Options) -> Result<NormalForm, NormalFormError> {
    normalize_model(
        cr3bp_model(),
        &[("mu".to_string(), mu)],
        &ModelPoint::Named("L4".into()),
        options,
    )
}

/// `models/cr3bp_spatial.lsl`.
pub fn cr3bp_spatial_model() -> &'static Model {
    static M: OnceLock<Model> = OnceLock::new();
    M.get_or_init(|| load("models/cr3bp_spatial.lsl"))
}

/// The spatial CR3BP Hamiltonian of the model file at mass ratio μ.
pub fn cr3bp_spatial(mu: f64) -> ModelHamiltonian<'static> {
    ModelHamiltonian::new(cr3bp_spatial_model(), &[("mu".to_string(), mu)]).expect("cr3bp_spatial")
}

/// The normal form of the spatial CR3BP model at L4.
pub fn spatial_l4_normal_form(mu: f64, options: &Options) -> Result<NormalForm, NormalFormError> {
    normalize_model(
        cr3bp_spatial_model(),
        &[("mu".to_string(), mu)],
        &ModelPoint::Named("L4".into()),
        options,
    )
}
