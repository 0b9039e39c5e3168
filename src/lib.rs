//! # lasalle
//!
//! Structure-preserving simulation from symbolic models. Models in `models/` are compiled by
//! `build.rs` (through [`lasalle_codegen`]) into the modules of [`models`]; each implements
//! the traits of the runtime ([`Field`], [`Invariants`], [`Lyapunov`], …), which the steppers
//! re-exported here integrate.
#![warn(missing_docs)]

pub use lasalle_exec as exec;
pub use lasalle_exec::{Backend, FeedbackLanes, LaneField, Lanes, LoadError, LoadedModel};
pub use lasalle_runtime::*;

pub mod closed_forms;
include!(concat!(env!("OUT_DIR"), "/model_files.rs"));

pub mod stability;

/// The models generated from `models/*.lsl` at build time.
#[allow(missing_docs)]
pub mod models {
    include!(concat!(env!("OUT_DIR"), "/models.rs"));
}
