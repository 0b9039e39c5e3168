//! # lasalle
//!
//! Structure-preserving simulation from symbolic models. Models in `models/` are compiled by
//! `build.rs` (through [`lasalle_codegen`]) into the modules of [`models`]; each implements
//! the traits of the runtime ([`Field`], [`Invariants`], [`Lyapunov`], …), which the steppers
//! re-exported here integrate.
//!
//! The run engine ([`lasalle_run`], re-exported here) does what `lasalle run` does: this is
//! `lasalle run kepler -m feedback-rk4 --t-end 702.481`, as in the README (whose Rust blocks
//! are doctests too):
//!
//! ```
//! use lasalle::{simulate, Backend, LoadedModel, RunSpec};
//!
//! let mut model = LoadedModel::load("models/kepler.lsl", Backend::Jit)?;
//! let (spec, x0) = RunSpec::from_preset(model.preset("paper")) // feedback-Euler, dt = 0.005, one period
//!     .method("feedback-rk4".parse()?)                         // overrides: the method
//!     .t_end(702.481)                                          // and ten periods
//!     .prepare(&mut model)?;                                   // the preset's parameters and point
//! let rec = simulate(&model, &x0, &spec)?;
//! assert!(rec.failure.is_none() && rec.max_invariant_error() < 1e-7);
//! println!("{} steps, max |ΔA| = {:.1e}", rec.steps, rec.max_of("A"));
//! println!("{}", rec.summary_json()); // rec.write_csv("trace.csv") writes the samples
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

pub use lasalle_exec as exec;
pub use lasalle_exec::{Backend, FeedbackLanes, LaneField, Lanes, LoadError, LoadedModel};
pub use lasalle_run as run;
pub use lasalle_run::{
    find_preset, initial_state, json_number, parse_numbers, process_cpu_seconds, simulate,
    simulate_lanes, simulate_many, simulate_with_progress, Base, Ensemble, Init, Member, Method,
    MethodSetting, ModelSource, Recording, RunError, RunModel, RunSpec, RunSpecBuilder,
    AUTO_SAMPLES, DEFAULT_MAX_STEPS, MODEL_FILES,
};
pub use lasalle_runtime::*;

/// The README, whose Rust blocks `cargo test --doc` compiles and runs as it does this crate's.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// The models generated from `models/*.lsl` at build time.
#[allow(missing_docs)]
pub mod models {
    include!(concat!(env!("OUT_DIR"), "/models.rs"));
}
