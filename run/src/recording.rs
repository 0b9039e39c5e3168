//! [`Recording`]: what a run leaves — sampled times, states and invariant errors, counters,
//! timings, and the failure that stopped it early — with its CSV and JSON writers.

use std::io::Write;
use std::path::Path;

use lasalle_runtime::{Csv, StepError};

use crate::EventHit;
use serde_json::json;

/// The sampled output of a run.
#[derive(Clone, Debug)]
pub struct Recording {
    /// The method, as [`Method`](crate::Method) writes it (`feedback-rk4`).
    pub method: String,
    /// The stepper's own name, e.g. `projection(euler)`.
    pub stepper: String,
    /// Names of the state components (`R[0,0]`, …, `Omega[2]`).
    pub state_names: Vec<String>,
    /// Names of the invariant blocks whose errors are recorded.
    pub blocks: Vec<String>,
    /// Sample times.
    pub t: Vec<f64>,
    /// Sampled states, `state_names.len()` per sample.
    pub x: Vec<f64>,
    /// Invariant errors ‖fᵢ(x) − fᵢ(x₀)‖, `blocks.len()` per sample.
    pub errors: Vec<f64>,
    /// Wall-clock time of the integration (including the sampling), in seconds.
    pub wall_seconds: f64,
    /// CPU time of the process during the integration, in seconds (None where the platform
    /// has no process clock).
    pub cpu_seconds: Option<f64>,
    /// Accepted steps.
    pub steps: u64,
    /// Field evaluations reported by the stepper.
    pub evaluations: u64,
    /// Rejected steps (adaptive methods).
    pub rejections: u64,
    /// The stepper's counters ([`Stepper::counters`](lasalle_runtime::Stepper::counters):
    /// Newton iterations of a projection, the last spectral norm estimate of an adaptive
    /// gain).
    pub counters: Vec<(&'static str, f64)>,
    /// Gains at the start (feedback methods).
    pub gains_initial: Option<Vec<f64>>,
    /// Gains at the end (differ from the initial ones for adaptive gains).
    pub gains_final: Option<Vec<f64>>,
    /// Why the run stopped early, if it did: the step, the time and the state in the error
    /// (diverged, blew up, left the model's guards, ran out of steps).
    pub failure: Option<StepError>,
    /// Recorded every this many steps (0: at the output times [`RunSpec::t_eval`](crate::RunSpec::t_eval)).
    pub every: u64,
    /// Names of the invariants' components (`H`, `L[0]`, …), as in [`EventHit::invariants`].
    pub invariant_names: Vec<String>,
    /// The crossings of the model's non-terminal events, in time order.
    pub events: Vec<EventHit>,
    /// The crossing of a terminal (`stop`) event that ended the run, if one did: the run
    /// succeeded, and its last sample is that crossing.
    pub stopped_by: Option<EventHit>,
    /// Where h·k·L stood against the base method's stability interval (fixed-step feedback
    /// methods).
    pub stability: Option<Stability>,
}

/// h·k·L of a fixed-step feedback run against the real stability interval (−β, 0] of its
/// base method ([`GainBound`](lasalle_runtime::GainBound)): h the step, k·L the largest
/// eigenvalue of the Hessian of V (estimated before every step).
#[derive(Clone, Debug, PartialEq)]
pub struct Stability {
    /// β: 2 for Euler and Heun, 2.785 for RK4.
    pub interval: f64,
    /// The largest estimate of h·k·L over the run's steps.
    pub max_h_k_l: f64,
    /// Steps that started with h·k·L past β (0: the run stayed inside).
    pub steps_outside: u64,
    /// The time of the first of them.
    pub first_outside_t: Option<f64>,
    /// With bounded gains (`--gains bounded`): the steps whose gains were scaled down, and the
    /// smallest factor applied to the model's gains.
    pub capped: Option<(u64, f64)>,
}

impl Stability {
    /// Whether some step left the stability interval.
    pub fn left_interval(&self) -> bool {
        self.steps_outside > 0
    }

    /// Read from the counters of a [`GainBound`](lasalle_runtime::GainBound) (None without
    /// them).
    pub fn from_counters(counters: &[(&'static str, f64)]) -> Option<Stability> {
        let get = |name: &str| counters.iter().find(|(n, _)| *n == name).map(|(_, v)| *v);
        let first = get("first_outside_stability_t")?;
        Some(Stability {
            interval: get("stability_interval")?,
            max_h_k_l: get("max_h_k_L")?,
            steps_outside: get("steps_outside_stability")? as u64,
            first_outside_t: (!first.is_nan()).then_some(first),
            capped: get("capped_steps")
                .zip(get("min_gain_factor"))
                .map(|(n, f)| (n as u64, f)),
        })
    }

    /// The warning a command line prints for a run that left the interval (None if it did not).
    pub fn warning(&self) -> Option<String> {
        self.left_interval().then(|| {
            format!(
                "warning: the feedback gains left the base method's stability interval: h·k·L \
                 reached {:.3e} > {:.4} in {} steps from t = {}; the invariants' errors may be \
                 larger than the base method's (use the default `--gains bounded`, smaller \
                 gains or a smaller --dt)",
                self.max_h_k_l,
                self.interval,
                self.steps_outside,
                self.first_outside_t.unwrap_or(f64::NAN)
            )
        })
    }

    /// As JSON: `interval`, `max_h_k_L`, `left_interval`, `steps_outside`,
    /// `first_outside_t`, `capped_steps`, `min_gain_factor`.
    pub fn to_json(&self) -> serde_json::Value {
        json!({
            "interval": self.interval,
            "max_h_k_L": json_number(self.max_h_k_l),
            "left_interval": self.left_interval(),
            "steps_outside": self.steps_outside,
            "first_outside_t": self.first_outside_t,
            "capped_steps": self.capped.map(|c| c.0),
            "min_gain_factor": self.capped.map(|c| json_number(c.1)),
        })
    }
}

impl Recording {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// No samples (never the case for a recording of a run: it has the initial state).
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The state dimension.
    pub fn dim(&self) -> usize {
        self.state_names.len()
    }

    /// The state of sample `i`.
    pub fn state(&self, i: usize) -> &[f64] {
        let n = self.dim();
        &self.x[i * n..(i + 1) * n]
    }

    /// The final recorded state.
    pub fn last_state(&self) -> &[f64] {
        self.state(self.len() - 1)
    }

    /// The time of the last sample (0 for an empty recording).
    pub fn t_final(&self) -> f64 {
        self.t.last().copied().unwrap_or(0.0)
    }

    /// The index of the invariant block `name`.
    pub fn block(&self, name: &str) -> Option<usize> {
        self.blocks.iter().position(|b| b == name)
    }

    /// The error series of block `b`.
    pub fn error_series(&self, b: usize) -> Vec<f64> {
        let nb = self.blocks.len();
        self.errors
            .iter()
            .skip(b)
            .step_by(nb.max(1))
            .copied()
            .collect()
    }

    /// The error of block `b` at the last sample.
    pub fn final_error(&self, b: usize) -> f64 {
        let nb = self.blocks.len();
        self.errors[(self.len() - 1) * nb + b]
    }

    /// The largest sampled error of block `b` (NaN if any sample is NaN).
    pub fn max_error(&self, b: usize) -> f64 {
        self.error_series(b).into_iter().fold(0.0, nan_max)
    }

    /// The largest sampled error of any invariant (NaN if any sample is NaN; 0 for a model
    /// without invariants).
    pub fn max_invariant_error(&self) -> f64 {
        self.errors.iter().copied().fold(0.0, nan_max)
    }

    /// The error of block `name` at the end, by name (panics on an unknown name).
    pub fn final_of(&self, name: &str) -> f64 {
        self.final_error(
            self.block(name)
                .unwrap_or_else(|| panic!("no invariant `{name}`")),
        )
    }

    /// The largest sampled error of block `name` (panics on an unknown name).
    pub fn max_of(&self, name: &str) -> f64 {
        self.max_error(
            self.block(name)
                .unwrap_or_else(|| panic!("no invariant `{name}`")),
        )
    }

    /// A stepper counter by name.
    pub fn counter(&self, name: &str) -> Option<f64> {
        self.counters
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| *v)
    }

    /// Writes the samples as CSV to the file `path` (see [`Recording::write_csv_to`]).
    pub fn write_csv(&self, path: impl AsRef<Path>) -> std::io::Result<()> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|e| {
            std::io::Error::new(e.kind(), format!("cannot create {}: {e}", path.display()))
        })?;
        self.write_csv_to(file)
    }

    /// Writes the samples as CSV to `out`: `t`, the state components, one `|Δname|` column
    /// per invariant (Frobenius norm for a matrix constraint); one line per sample.
    pub fn write_csv_to(&self, out: impl Write) -> std::io::Result<()> {
        let mut csv = Csv::new(std::io::BufWriter::new(out));
        let header = std::iter::once("t".to_string())
            .chain(self.state_names.iter().cloned())
            .chain(self.blocks.iter().map(|b| format!("|Δ{b}|")));
        csv.record(header)?;
        let nb = self.blocks.len();
        for i in 0..self.len() {
            let row = std::iter::once(&self.t[i])
                .chain(self.state(i))
                .chain(&self.errors[i * nb..(i + 1) * nb]);
            csv.record(row)?;
        }
        csv.into_inner()?;
        Ok(())
    }

    /// The run's summary as JSON: counters, wall and CPU time, maximal and final invariant
    /// errors, final state, gains and their stability, failure. Non-finite numbers are strings
    /// ([`json_number`]).
    pub fn summary_json(&self) -> serde_json::Value {
        let invariants: serde_json::Map<String, serde_json::Value> = self
            .blocks
            .iter()
            .enumerate()
            .map(|(b, name)| {
                (
                    name.clone(),
                    json!({
                        "max": json_number(self.max_error(b)),
                        "final": json_number(self.final_error(b)),
                    }),
                )
            })
            .collect();
        let counters: serde_json::Map<String, serde_json::Value> = self
            .counters
            .iter()
            .map(|(n, v)| (n.to_string(), json_number(*v)))
            .collect();
        json!({
            "method": self.method,
            "stepper": self.stepper,
            "t_final": json_number(self.t_final()),
            "steps": self.steps,
            "evaluations": self.evaluations,
            "rejections": self.rejections,
            "wall_seconds": self.wall_seconds,
            "cpu_seconds": self.cpu_seconds,
            "samples": self.len(),
            "record_every": self.every,
            "invariant_errors": invariants,
            "final_state": self.last_state().iter().map(|v| json_number(*v)).collect::<Vec<_>>(),
            "gains_initial": self.gains_initial,
            "gains_final": self.gains_final,
            "stability": self.stability.as_ref().map(Stability::to_json),
            "stats": counters,
            "events": self.events_json(),
            "failure": self.failure.as_ref().map(|e| json!({
                "message": e.to_string(),
                "t": e.time(),
                "step": e.step(),
                "state": e.state(),
            })),
        })
    }
}

/// The larger of two numbers, NaN if either is.
fn nan_max(m: f64, e: f64) -> f64 {
    if e.is_nan() || m.is_nan() {
        f64::NAN
    } else {
        m.max(e)
    }
}

/// A finite number as JSON, anything else as a string (JSON has no NaN or ∞).
pub fn json_number(v: f64) -> serde_json::Value {
    if v.is_finite() {
        json!(v)
    } else {
        json!(v.to_string())
    }
}
