//! # lasalle
//!
//! Structure-preserving simulation from symbolic models. Models in `models/` are compiled by
//! `build.rs` (through [`lasalle_codegen`]) into the modules of [`models`]; each implements
//! the traits of the runtime ([`Field`], [`Invariants`], [`Lyapunov`], …), which the steppers
//! re-exported here integrate.
#![warn(missing_docs)]

pub use lasalle_exec as exec;
pub use lasalle_exec::{Backend, FeedbackLanes, LaneField, Lanes, LoadError, LoadedModel};
pub use lasalle_run as run;
pub use lasalle_run::{
    find_preset, initial_state, json_number, parse_numbers, process_cpu_seconds, simulate,
    simulate_lanes, simulate_many, simulate_with_progress, Base, Ensemble, Init, Member, Method,
    ModelSource, Recording, RunError, RunModel, RunSpec, RunSpecBuilder, AUTO_SAMPLES,
    DEFAULT_MAX_STEPS,
};
pub use lasalle_runtime::*;

pub mod closed_forms;
include!(concat!(env!("OUT_DIR"), "/model_files.rs"));

pub mod stability;

/// The models generated from `models/*.lsl` at build time.
#[allow(missing_docs)]
pub mod models {
    include!(concat!(env!("OUT_DIR"), "/models.rs"));
}
