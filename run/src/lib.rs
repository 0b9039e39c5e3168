//! # lasalle-run
//!
//! The run engine of lasalle as a library: what `lasalle run` and `lasalle sweep` do, for any
//! front end (the command line, a Python package). The split follows diffsol's problem and
//! method: a model and an initial state are the problem, a [`RunSpec`] the method that solves
//! it.
//!
//! - [`Method`] (with its [`Base`]): the method grammar, `feedback-rk4`, `projection-euler`,
//!   `split-taylor`, … (`FromStr`/`Display`, as [`GainPolicy`](lasalle_runtime::GainPolicy)
//!   for the gains);
//! - [`RunSpec`]: method, step, end time, gains, tolerances, sampling, step budget and
//!   divergence bound; [`RunSpec::from_preset`] resolves a model's run preset with the
//!   caller's overrides ([`RunSpecBuilder`]), [`RunSpec::validate`] checks it;
//! - [`simulate`] (and [`simulate_with_progress`]): one run of any model — loaded at run time
//!   ([`LoadedModel`](lasalle_exec::LoadedModel)) or compiled — from an initial state;
//! - [`simulate_many`]: an ensemble of [`Member`]s of one model file across threads, members
//!   with equal parameters in lanes ([`simulate_lanes`]), each result bitwise the lone run's;
//! - [`chaos`]: the state-transition matrix of a run ([`chaos::state_transition`]), the
//!   Lyapunov spectrum ([`chaos::lyapunov_spectrum`]), the maximal Lyapunov exponent, FLI and
//!   MEGNO ([`chaos::indicators`]; in ensembles, [`ModelSource::extended`]);
//! - [`Reusing`]: a loaded model whose Taylor kernels a [`KernelPool`] keeps between runs
//!   (ensembles build them once per thread);
//! - [`Recording`]: sampled times, states and invariant errors, the stepper's counters, wall
//!   and CPU time, and the [`failure`](Recording::failure) that stopped a run early, written
//!   as CSV ([`Recording::write_csv`]) and JSON ([`Recording::summary_json`]);
//! - [`model_text`]: a model given as a path or the name of one of the repository's models
//!   (embedded, [`MODEL_FILES`]), for every front end;
//! - [`parse_values`]: values as `start:stop:count` or a comma-separated list (output times,
//!   parameter grids).
//!
//! A run of the Kepler model's preset (feedback-Euler, one period) with ten periods of
//! feedback-RK4 instead:
//!
//! ```
//! use lasalle_exec::{Backend, LoadedModel};
//! use lasalle_run::{simulate, RunSpec};
//!
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/kepler.lsl");
//! let mut model = LoadedModel::load(path, Backend::Jit)?;
//! let (spec, x0) = RunSpec::from_preset(model.preset("paper"))
//!     .method("feedback-rk4".parse()?)
//!     .t_end(702.481)
//!     .prepare(&mut model)?; // the preset's parameters and initial point
//! let rec = simulate(&model, &x0, &spec)?;
//! assert_eq!(rec.steps, 140_497);
//! assert!(rec.failure.is_none() && rec.max_invariant_error() < 1e-6);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The crate depends on the runtime, the front end, the loader and JIT, `serde_json` and `rayon` only: no
//! command-line, terminal or plotting crates.
#![warn(missing_docs)]

mod backward;
mod builtin;
pub mod chaos;
mod clock;
mod delay;
mod ensemble;
mod error;
mod events;
mod input;
mod interrupt;
mod method;
mod recording;
mod reuse;
mod simulate;
mod spec;
mod switching;

pub use builtin::{builtin_models, model_text, normalise, LookupError, ModelText, MODEL_FILES};
pub use clock::process_cpu_seconds;
pub use delay::{growth, lags, Growth, MAX_DELAY_INTERVALS};
pub use ensemble::{simulate_lanes, simulate_many, Ensemble, Init, Member, ModelSource};
pub use error::RunError;
pub use events::{parse_t_eval, EventHit};
pub use input::{initial_state, parse_numbers, parse_values, ValuesError};
pub use interrupt::Interrupt;
pub use method::{Base, Method, MethodSetting};
pub use recording::{json_number, Recording, Stability};
pub use reuse::{KernelPool, Reusing};
pub use simulate::{simulate, simulate_with_progress, RunModel};
pub use spec::{find_preset, RunSpec, RunSpecBuilder, AUTO_SAMPLES, DEFAULT_MAX_STEPS};
pub use switching::{Switching, MAX_SWITCHES_PER_RUN};
