//! The simulation core shared by `lasalle run` and `lasalle experiment`.
//!
//! A run is a model, a [`Method`] and a [`RunSpec`] (step, end time, gains, tolerances). The
//! command line does not know models: [`simulate`] runs any model that implements the runtime's
//! traits and [`Declared`] — a model loaded from a file at run time
//! ([`lasalle_exec::LoadedModel`]) or one compiled ahead of time (the experiments use those) —
//! and builds the stepper for the method by composing [`Visit`]ors (`projection-` wraps the
//! base stepper in a [`Projection`], `feedback-` integrates the [`FeedbackField`],
//! `--gains adaptive` and `--gains step` wrap the stepper in an [`AdaptiveGain`]), so the inner
//! loop is static code for each (storage, method) pair. Methods that need structure the model
//! does not declare fail with a message ("method `stormer-verlet-a` needs a partitioned
//! model"); the model's guards stop a run that leaves its domain.
//!
//! The result is a [`Trace`]: sampled times, states and invariant errors, wall time and
//! counters, and, if the integration blew up, the [`StepError`] with its time and state.

use std::fmt;
use std::io::IsTerminal;
use std::marker::PhantomData;
use std::path::Path;
use std::str::FromStr;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lasalle::{
    component_names, sample_capacity, scaled_gains, step_gain_target, AdaptiveGain, Control, Csv,
    Declared, DormandPrince, DriftBound, Driver, ExplicitRk, FeedbackField, Field, GainPolicy,
    Invariants, LaneField, LoadedModel, Lyapunov, ModelInfo, Observer, Parameters, Projection,
    Recorder, RigidBodySplitting, State, StepError, Stepper, StormerVerlet, Stride, Taylor,
    TaylorOptions, VerletVariant,
};
use serde_json::json;

use super::CliResult;

/// Lower case without `-` and `_`, so `rigid-body`, `rigid_body` and `RigidBody` agree.
pub fn normalise(s: &str) -> String {
    s.chars()
        .filter(|c| *c != '-' && *c != '_')
        .flat_map(char::to_lowercase)
        .collect()
}

/// An explicit Runge–Kutta base method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Base {
    /// Explicit Euler (order 1).
    Euler,
    /// Heun (order 2).
    Heun,
    /// Classical Runge–Kutta (order 4).
    Rk4,
    /// Adaptive Dormand–Prince 5(4) with `--rtol`/`--atol`.
    Dopri5,
}

impl Base {
    const ALL: [Base; 4] = [Base::Euler, Base::Heun, Base::Rk4, Base::Dopri5];

    /// The order of the method (of the propagated solution for `dopri5`).
    fn order(self) -> u32 {
        match self {
            Base::Euler => 1,
            Base::Heun => 2,
            Base::Rk4 => 4,
            Base::Dopri5 => 5,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Base::Euler => "euler",
            Base::Heun => "heun",
            Base::Rk4 => "rk4",
            Base::Dopri5 => "dopri5",
        }
    }
}

/// A method of the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// A base method on the model's own field X.
    Plain(Base),
    /// A base method on the feedback field X − ∇V (a feedback integrator).
    Feedback(Base),
    /// A base method on X followed by the projection onto {f = f(x₀)} (GNI §IV.4).
    Projection(Base),
    /// Störmer–Verlet A (GNI (3.4)) or B (GNI (3.5)); partitioned models only.
    StormerVerlet(VerletVariant),
    /// The three-rotation splitting of the free rigid body (GNI §VII.5).
    Splitting,
    /// The Taylor method of adaptive order and step (Jorba & Zou 2005) with tolerance
    /// `--rtol`, on X or (`feedback`) on X − ∇V, over the model's Taylor kernels (emitted
    /// for compiled models; for loaded ones compiled by the JIT, or interpreted).
    Taylor {
        /// On the feedback field X − ∇V.
        feedback: bool,
    },
    /// The split step: a Taylor step of X, then one explicit gradient step x ← x − h∇V
    /// (`lasalle_runtime::Taylor::set_split`); a feedback method (the gains apply).
    SplitTaylor,
}

impl Method {
    /// Every accepted spelling, for messages.
    pub fn known() -> String {
        let mut v: Vec<String> = Base::ALL.iter().map(|b| b.name().to_string()).collect();
        v.extend(Base::ALL.iter().map(|b| format!("feedback-{}", b.name())));
        v.extend(Base::ALL.iter().map(|b| format!("projection-{}", b.name())));
        v.extend(
            [
                "stormer-verlet-a",
                "stormer-verlet-b",
                "splitting",
                "taylor",
                "feedback-taylor",
                "split-taylor",
            ]
            .map(String::from),
        );
        v.join(", ")
    }

    /// Is this a feedback integrator (the gains apply)?
    pub fn is_feedback(self) -> bool {
        matches!(
            self,
            Method::Feedback(_) | Method::Taylor { feedback: true } | Method::SplitTaylor
        )
    }

    /// Does the method choose its own step sizes?
    pub fn is_adaptive(self) -> bool {
        matches!(
            self,
            Method::Plain(Base::Dopri5)
                | Method::Feedback(Base::Dopri5)
                | Method::Projection(Base::Dopri5)
                | Method::Taylor { .. }
                | Method::SplitTaylor
        )
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Method::Plain(b) => f.write_str(b.name()),
            Method::Feedback(b) => write!(f, "feedback-{}", b.name()),
            Method::Projection(b) => write!(f, "projection-{}", b.name()),
            Method::StormerVerlet(VerletVariant::A) => f.write_str("stormer-verlet-a"),
            Method::StormerVerlet(VerletVariant::B) => f.write_str("stormer-verlet-b"),
            Method::Splitting => f.write_str("splitting"),
            Method::Taylor { feedback: false } => f.write_str("taylor"),
            Method::Taylor { feedback: true } => f.write_str("feedback-taylor"),
            Method::SplitTaylor => f.write_str("split-taylor"),
        }
    }
}

impl FromStr for Method {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let key = s.trim().to_lowercase().replace('_', "-");
        let base = |b: &str| Base::ALL.into_iter().find(|x| x.name() == b);
        let found = match key.as_str() {
            "stormer-verlet-a" | "sv-a" | "verlet-a" | "stormer-verlet" => {
                Some(Method::StormerVerlet(VerletVariant::A))
            }
            "stormer-verlet-b" | "sv-b" | "verlet-b" => {
                Some(Method::StormerVerlet(VerletVariant::B))
            }
            "splitting" => Some(Method::Splitting),
            "taylor" => Some(Method::Taylor { feedback: false }),
            "feedback-taylor" => Some(Method::Taylor { feedback: true }),
            "split-taylor" => Some(Method::SplitTaylor),
            k => {
                if let Some(rest) = k.strip_prefix("feedback-") {
                    base(rest).map(Method::Feedback)
                } else if let Some(rest) = k.strip_prefix("projection-") {
                    base(rest).map(Method::Projection)
                } else {
                    base(k).map(Method::Plain)
                }
            }
        };
        found.ok_or_else(|| format!("unknown method `{s}`; known methods: {}", Method::known()))
    }
}

/// Everything about a run except the model and the initial state.
#[derive(Clone, Debug)]
pub struct RunSpec {
    /// The method.
    pub method: Method,
    /// Step size (fixed-step methods) or initial step (adaptive methods; 0 = chosen by the
    /// method: Hairer, Nørsett & Wanner's starting step for DOPRI5, Jorba & Zou's for Taylor).
    pub dt: f64,
    /// End time (the run starts at t = 0).
    pub t_end: f64,
    /// Gains of feedback methods.
    pub gains: GainPolicy,
    /// Tolerance of the projection on |f(x) − f(x₀)|₂.
    pub tol: f64,
    /// Relative tolerance of `dopri5`; the tolerance ε of the Taylor method.
    pub rtol: f64,
    /// Absolute tolerance of `dopri5` (the Taylor method has the one tolerance `rtol`).
    pub atol: f64,
    /// An invariant whose error exceeds `max_drift` times its scale ends the run as diverged
    /// ([`DriftBound`]).
    pub max_drift: f64,
    /// Record every `every`-th step (0: about [`AUTO_SAMPLES`] samples).
    pub every: u64,
    /// Show a progress bar (only if standard error is a terminal).
    pub progress: bool,
    /// The most steps the run may take (fixed-step runs longer than this are refused before
    /// they start; adaptive runs stop with an error when they reach it).
    pub max_steps: u64,
}

/// The number of samples a run records when `every` is 0.
pub const AUTO_SAMPLES: u64 = 20_000;

/// The default step budget: 10⁹ steps, minutes at tens of nanoseconds a step.
pub const DEFAULT_MAX_STEPS: u64 = 1_000_000_000;

impl RunSpec {
    /// A spec with the defaults of `lasalle run`: default gains (the model's for fixed-step
    /// methods, the step-tracking rule for adaptive ones), tol = dt, rtol = atol = 1e-10,
    /// divergence past [`lasalle::DEFAULT_MAX_DRIFT`].
    pub fn new(method: Method, dt: f64, t_end: f64) -> Self {
        RunSpec {
            method,
            dt,
            t_end,
            gains: GainPolicy::Default,
            tol: dt,
            rtol: 1e-10,
            atol: 1e-10,
            max_drift: lasalle::DEFAULT_MAX_DRIFT,
            every: 0,
            progress: false,
            max_steps: DEFAULT_MAX_STEPS,
        }
    }

    /// The number of steps of a fixed-step run (an estimate for `dopri5`).
    pub fn steps(&self) -> u64 {
        if self.dt > 0.0 {
            (self.t_end / self.dt).ceil().max(1.0) as u64
        } else {
            1000
        }
    }

    fn record_every(&self) -> u64 {
        if self.every > 0 {
            self.every
        } else {
            (self.steps() / AUTO_SAMPLES).max(1)
        }
    }

    /// Checks the numbers: positive finite step and end time, tolerances in range.
    pub fn validate(&self) -> Result<(), String> {
        let adaptive = self.method.is_adaptive();
        if !(self.dt.is_finite() && (self.dt > 0.0 || (adaptive && self.dt == 0.0))) {
            return Err(format!(
                "step size must be positive and finite, got --dt {}",
                self.dt
            ));
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return Err(format!(
                "end time must be positive and finite, got --t-end {}",
                self.t_end
            ));
        }
        if self.dt > self.t_end {
            return Err(format!(
                "step size --dt {} exceeds the end time --t-end {}",
                self.dt, self.t_end
            ));
        }
        if !(self.tol.is_finite() && self.tol > 0.0) {
            return Err(format!(
                "projection tolerance must be positive, got --tol {}",
                self.tol
            ));
        }
        if !(self.rtol > 0.0 && self.atol > 0.0 && self.rtol.is_finite() && self.atol.is_finite()) {
            return Err(format!(
                "need positive --rtol and --atol, got {} and {}",
                self.rtol, self.atol
            ));
        }
        if !(self.max_drift.is_finite() && self.max_drift > 0.0) {
            return Err(format!(
                "--max-drift must be positive and finite, got {}",
                self.max_drift
            ));
        }
        if !self.method.is_adaptive() && self.t_end / self.dt > self.max_steps as f64 {
            return Err(format!(
                "--t-end {:e} with --dt {} would take {:.3e} steps, more than the limit of {}: \
                 raise it with --max-steps if that is intended",
                self.t_end,
                self.dt,
                self.t_end / self.dt,
                self.max_steps
            ));
        }
        if !self.method.is_feedback() && self.gains != GainPolicy::Default {
            return Err(format!(
                "--gains applies to feedback methods only, not to `{}`",
                self.method
            ));
        }
        if matches!(self.gains, GainPolicy::Step { .. }) && !adaptive {
            return Err(format!(
                "--gains step follows the step of an adaptive method (feedback-dopri5, \
                 feedback-taylor, split-taylor); `{}` takes fixed steps: use --gains adaptive",
                self.method
            ));
        }
        Ok(())
    }
}

/// Counters of a stepper after a run (Newton iterations of a projection, the last spectral
/// norm estimate of an adaptive gain).
pub trait Stats {
    /// Named counters; none by default.
    fn stats(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
}

impl<const S: usize, X> Stats for ExplicitRk<f64, S, X> {}
impl<X> Stats for DormandPrince<f64, X> {}
impl<X> Stats for StormerVerlet<X> {}
impl<M: ?Sized> Stats for Taylor<M> {}
impl Stats for RigidBodySplitting<f64> {}

impl<F: State<f64>, S: Stats, X: State<f64>> Stats for Projection<f64, F, S, X> {
    fn stats(&self) -> Vec<(&'static str, f64)> {
        let mut v = self.base().stats();
        v.push(("newton_iterations", self.newton_iterations() as f64));
        v.push(("projected_steps", self.projections() as f64));
        v
    }
}

impl<S: Stats, K> Stats for AdaptiveGain<S, f64, K> {
    fn stats(&self) -> Vec<(&'static str, f64)> {
        let mut v = self.base().stats();
        v.push(("last_gauss_newton_norm", self.last_norm()));
        v
    }
}

/// Something that does a run with any stepper for the field `F` (the continuation that
/// [`simulate`] hands the stepper it built).
pub trait Visit<F: ?Sized, X: State<f64>> {
    /// The result.
    type Out;
    /// Runs with `stepper`.
    fn visit<S: Stepper<f64, X, F> + Stats>(self, stepper: S) -> Self::Out;
}

/// Everything [`simulate`] needs of a model, with states, invariants and gains stored as
/// `X`, `FV` and `K`: the runtime's traits and the model file's declarations.
pub trait RunModel<X: State<f64>, FV: State<f64>, K: State<f64>>:
    Lyapunov<f64, X, FV, K> + ModelInfo + Declared<f64, X>
{
}

impl<M, X, FV, K> RunModel<X, FV, K> for M
where
    M: Lyapunov<f64, X, FV, K> + ModelInfo + Declared<f64, X>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
}

/// Sampled output of a run.
#[derive(Clone, Debug)]
pub struct Trace {
    /// The method as given.
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
    /// Stepper counters ([`Stats`]).
    pub stats: Vec<(&'static str, f64)>,
    /// Gains at the start (feedback methods).
    pub gains_initial: Option<Vec<f64>>,
    /// Gains at the end (differ from the initial ones for adaptive gains).
    pub gains_final: Option<Vec<f64>>,
    /// Why the run stopped early, if it did.
    pub failure: Option<StepError>,
    /// Recorded every this many steps.
    pub every: u64,
}

impl Trace {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
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
        self.error_series(b).into_iter().fold(0.0, |m: f64, e| {
            if e.is_nan() || m.is_nan() {
                f64::NAN
            } else {
                m.max(e)
            }
        })
    }

    /// The error of block `name` at the end, by name (panics on an unknown name).
    pub fn final_of(&self, name: &str) -> f64 {
        self.final_error(
            self.block(name)
                .unwrap_or_else(|| panic!("no invariant `{name}`")),
        )
    }

    /// The largest sampled error of block `name`.
    pub fn max_of(&self, name: &str) -> f64 {
        self.max_error(
            self.block(name)
                .unwrap_or_else(|| panic!("no invariant `{name}`")),
        )
    }

    /// A stepper counter by name.
    pub fn stat(&self, name: &str) -> Option<f64> {
        self.stats.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
    }

    /// Writes the samples as CSV: `t`, the state components, one `|Δname|` column per
    /// invariant (Frobenius norm for the matrix constraint).
    pub fn write_csv(&self, path: &Path) -> CliResult {
        let file = std::fs::File::create(path)
            .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        self.write_csv_to(file)
    }

    /// Writes the samples as CSV to `out` (see [`Trace::write_csv`]).
    pub fn write_csv_to(&self, out: impl std::io::Write) -> CliResult {
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

    /// The run's summary as JSON: counters, wall time, final and maximal invariant errors,
    /// final state, failure.
    pub fn summary_json(&self) -> serde_json::Value {
        let invariants: serde_json::Map<String, serde_json::Value> = self
            .blocks
            .iter()
            .enumerate()
            .map(|(b, name)| {
                (
                    name.clone(),
                    json!({ "final": num(self.final_error(b)), "max": num(self.max_error(b)) }),
                )
            })
            .collect();
        let stats: serde_json::Map<String, serde_json::Value> = self
            .stats
            .iter()
            .map(|(n, v)| (n.to_string(), num(*v)))
            .collect();
        json!({
            "method": self.method,
            "stepper": self.stepper,
            "t_final": num(*self.t.last().unwrap_or(&0.0)),
            "steps": self.steps,
            "evaluations": self.evaluations,
            "rejections": self.rejections,
            "wall_seconds": self.wall_seconds,
            "cpu_seconds": self.cpu_seconds,
            "samples": self.len(),
            "record_every": self.every,
            "invariant_errors": invariants,
            "final_state": self.last_state().iter().map(|v| num(*v)).collect::<Vec<_>>(),
            "gains_initial": self.gains_initial,
            "gains_final": self.gains_final,
            "stats": stats,
            "failure": self.failure.as_ref().map(|e| json!({
                "message": e.to_string(),
                "t": e.time(),
                "step": e.step(),
                "state": e.state(),
            })),
        })
    }
}

/// The CPU time the process has used, in seconds (`CLOCK_PROCESS_CPUTIME_ID`, the clock of
/// Python's `time.process_time`, so that benchmarks against Python libraries compare alike).
#[cfg(unix)]
pub fn process_cpu_seconds() -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the call only writes it.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

/// No process clock on this platform.
#[cfg(not(unix))]
pub fn process_cpu_seconds() -> Option<f64> {
    None
}

/// A finite number as JSON, anything else as a string (JSON has no NaN).
pub fn num(v: f64) -> serde_json::Value {
    if v.is_finite() {
        json!(v)
    } else {
        json!(v.to_string())
    }
}

/// A progress bar over [0, t_end], drawn on standard error only if it is a terminal.
pub fn progress_bar(enabled: bool, label: &str) -> ProgressBar {
    if !enabled || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(
        "{msg:>28} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(label.to_string());
    bar
}

/// Moves the progress bar, about every 2¹⁶ steps, on the way to `inner`.
struct Progress<'o, O> {
    inner: &'o mut O,
    bar: &'o ProgressBar,
    t_end: f64,
    every: u64,
}

impl<O: Observer<f64, X>, X: ?Sized> Observer<f64, X> for Progress<'_, O> {
    #[inline]
    fn observe(&mut self, step: u64, t: f64, x: &X) -> Control {
        // only every `every`-th step gets here (a Stride): one of them per 2¹⁶ steps
        if step & 0xffff < self.every {
            self.bar.set_position((t / self.t_end * 1000.0) as u64);
        }
        self.inner.observe(step, t, x)
    }

    fn finish(&mut self, step: u64, t: f64, x: &X) {
        self.inner.finish(step, t, x)
    }
}

/// The innermost visitor: integrates `field` with the stepper and records the model's
/// invariants.
struct Drive<'a, Mdl, F: ?Sized, X, FV> {
    model: &'a Mdl,
    field: &'a F,
    x0: X,
    spec: &'a RunSpec,
    invariants: PhantomData<FV>,
}

impl<Mdl, F, X, FV> Visit<F, X> for Drive<'_, Mdl, F, X, FV>
where
    Mdl: Invariants<f64, X, FV> + ModelInfo + Declared<f64, X>,
    X: State<f64>,
    FV: State<f64>,
    F: ?Sized,
{
    type Out = Trace;

    fn visit<S: Stepper<f64, X, F> + Stats>(self, mut stepper: S) -> Trace {
        let spec = self.spec;
        let every = spec.record_every();
        // the stride forwards every `every`-th step; the recorder keeps all it is given
        let mut rec = Recorder::new(
            self.model,
            &self.x0,
            1,
            sample_capacity(spec.steps(), every),
        );
        let bar = progress_bar(spec.progress, &spec.method.to_string());
        let mut driver = Driver::new(0.0, spec.t_end, spec.dt).max_steps(spec.max_steps);
        // the model's guards, with the step size (0 for adaptive methods, which shrink theirs)
        let (model, h) = (
            self.model,
            if spec.method.is_adaptive() {
                0.0
            } else {
                spec.dt
            },
        );
        let drift = DriftBound::new(model, &self.x0, spec.max_drift);
        driver = driver
            .guard(1, move |x: &X| {
                model.check_guards(x, h).map(|g| g.to_string())
            })
            .divergence(every, move |x: &X| drift.check(x));
        let mut obs = Stride::new(
            Progress {
                inner: &mut rec,
                bar: &bar,
                t_end: spec.t_end,
                every,
            },
            every,
        );
        let (start, cpu_start) = (Instant::now(), process_cpu_seconds());
        let result = driver.run(&mut stepper, self.field, &self.x0, &mut obs);
        let wall_seconds = start.elapsed().as_secs_f64();
        let cpu_seconds = process_cpu_seconds()
            .zip(cpu_start)
            .map(|(end, start)| end - start);
        bar.finish_and_clear();
        let counts = match result {
            Ok(s) => Ok((s.steps, s.evaluations, s.rejections)),
            Err(e) => Err(e),
        };
        let stepper = (stepper.name(), stepper.stats());
        trace(
            self.model,
            spec,
            stepper,
            rec,
            (wall_seconds, cpu_seconds),
            counts,
        )
    }
}

/// The [`Trace`] of a run: what `rec` recorded, with the run's counters (or its failure).
fn trace<Mdl, X, FV>(
    model: &Mdl,
    spec: &RunSpec,
    (stepper, stats): (String, Vec<(&'static str, f64)>),
    rec: Recorder<'_, Mdl, f64, X, FV>,
    (wall_seconds, cpu_seconds): (f64, Option<f64>),
    counts: Result<(u64, u64, u64), StepError>,
) -> Trace
where
    Mdl: Invariants<f64, X, FV> + ModelInfo + ?Sized,
    X: State<f64>,
    FV: State<f64>,
{
    let mut names = component_names(model.state_slots());
    names.resize_with(model.state_dim(), String::new);
    let ((steps, evaluations, rejections), failure) = match counts {
        Ok(c) => (c, None),
        Err(e) => ((e.step().unwrap_or(0), 0, 0), Some(e)),
    };
    Trace {
        method: spec.method.to_string(),
        stepper,
        state_names: names,
        blocks: rec.blocks().iter().map(|(n, _)| n.to_string()).collect(),
        x: rec
            .x
            .iter()
            .flat_map(|s| s.as_ref().iter().copied())
            .collect(),
        t: rec.t,
        errors: rec.errors,
        wall_seconds,
        cpu_seconds,
        steps,
        evaluations,
        rejections,
        stats,
        gains_initial: None,
        gains_final: None,
        failure,
        every: spec.record_every(),
    }
}

/// Wraps the base stepper in the projection onto {f = target} (GNI §IV.4).
struct Project<V, FV> {
    inner: V,
    target: FV,
    tol: f64,
}

impl<F, V, X, FV> Visit<F, X> for Project<V, FV>
where
    F: Invariants<f64, X, FV> + ?Sized,
    V: Visit<F, X>,
    X: State<f64>,
    FV: State<f64>,
{
    type Out = V::Out;

    fn visit<S: Stepper<f64, X, F> + Stats>(self, stepper: S) -> V::Out {
        self.inner
            .visit(Projection::new(stepper, self.target, self.tol))
    }
}

/// Wraps the base stepper in the periodic adaptive gain (Bae & Chang) or the step-tracking
/// gain, as [`GainPlan::wrap`] says.
struct Adapt<V, K> {
    inner: V,
    unit: K,
    every: u64,
    c: f64,
    safety: f64,
}

impl<'a, Mdl, V, X, FV, K> Visit<FeedbackField<'a, Mdl, FV, K>, X> for Adapt<V, K>
where
    Mdl: Lyapunov<f64, X, FV, K> + ModelInfo,
    V: Visit<FeedbackField<'a, Mdl, FV, K>, X>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    type Out = V::Out;

    fn visit<S>(self, stepper: S) -> V::Out
    where
        S: Stepper<f64, X, FeedbackField<'a, Mdl, FV, K>> + Stats,
    {
        self.inner.visit(
            AdaptiveGain::new(stepper, self.unit, self.every)
                .c(self.c)
                .safety(self.safety),
        )
    }
}

/// Hands `visit` the explicit Runge–Kutta stepper `base`.
fn with_base<F, V, X>(base: Base, spec: &RunSpec, visit: V) -> V::Out
where
    F: Field<f64, X> + ?Sized,
    V: Visit<F, X>,
    X: State<f64>,
{
    match base {
        Base::Euler => visit.visit(ExplicitRk::<f64, 1, X>::euler()),
        Base::Heun => visit.visit(ExplicitRk::<f64, 2, X>::heun()),
        Base::Rk4 => visit.visit(ExplicitRk::<f64, 4, X>::rk4()),
        Base::Dopri5 => visit.visit(DormandPrince::<f64, X>::with_tolerances(
            spec.rtol, spec.atol,
        )),
    }
}

/// The innermost visitor for `field` (the model itself, its feedback field or its partitioned
/// half-fields), recording the model's invariants.
fn drive<'a, Mdl, F: ?Sized, X: Clone, FV>(
    model: &'a Mdl,
    field: &'a F,
    x0: &X,
    spec: &'a RunSpec,
) -> Drive<'a, Mdl, F, X, FV> {
    Drive {
        model,
        field,
        x0: x0.clone(),
        spec,
        invariants: PhantomData,
    }
}

/// Integrates `model` from `x0` as `spec` says. An integration that blows up or leaves the
/// model's domain (a failed guard) still returns the samples up to the failure, with
/// [`Trace::failure`] set; invalid arguments (bad numbers, a method the model cannot use,
/// gains of the wrong count, an initial state outside the domain) are errors.
pub fn simulate<Mdl, X, FV, K>(model: &Mdl, x0: &X, spec: &RunSpec) -> Result<Trace, String>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let f = check_start(model, x0, spec)?;
    let name = model.model_name();
    match spec.method {
        Method::Plain(b) => Ok(with_base(b, spec, drive(model, model, x0, spec))),
        Method::Projection(b) => {
            let visit = Project {
                inner: drive(model, model, x0, spec),
                target: f,
                tol: spec.tol,
            };
            Ok(with_base(b, spec, visit))
        }
        Method::Feedback(b) => feedback_run(model, x0, spec, FeedbackStepper::Base(b)),
        Method::StormerVerlet(variant) => {
            let halves = model.partitioned().ok_or_else(|| {
                format!(
                    "method `{}` needs a partitioned model (q̇ = a(p), ṗ = b(q)); the field of `{name}` is not partitioned",
                    spec.method
                )
            })?;
            let stepper = match variant {
                VerletVariant::A => StormerVerlet::a(),
                VerletVariant::B => StormerVerlet::b(),
            };
            Ok(drive(model, halves, x0, spec).visit(stepper))
        }
        Method::Splitting => {
            let splitting = model.rigid_body_splitting().ok_or_else(|| {
                format!(
                    "method `splitting` is the free rigid body's three-rotation splitting; `{name}` does not declare `splitting rigid_body(R, Omega, I);`"
                )
            })?;
            Ok(drive(model, model, x0, spec).visit(splitting))
        }
        Method::Taylor { feedback } => {
            let taylor = taylor(model, spec)?;
            if feedback {
                feedback_run(model, x0, spec, FeedbackStepper::Taylor(taylor))
            } else {
                Ok(drive(model, model, x0, spec).visit(taylor))
            }
        }
        Method::SplitTaylor => {
            let taylor = taylor(model, spec)?.with_split(true);
            feedback_run(model, x0, spec, FeedbackStepper::Taylor(taylor))
        }
    }
}

/// Integrates the states `x0s` of a loaded model together, in lanes ([`lasalle::Lanes`],
/// [`lasalle::FeedbackLanes`]), as [`simulate`] integrates each alone: each trace equals the lone run's
/// except for the wall and CPU time, the group's divided by the number of lanes. `None` where
/// lanes do not apply — fewer than two states, a method other than a fixed-step Runge–Kutta
/// method on X or X − ∇V, gains that differ between the states or change during the run,
/// samples between the first and the last state (`spec.every`), an initial state that
/// [`simulate`] refuses, a run that fails (its guards or a blow-up stop every lane) — and then
/// the caller runs each state alone, which gives each its own result.
pub fn simulate_lanes(model: &LoadedModel, x0s: &[Vec<f64>], spec: &RunSpec) -> Option<Vec<Trace>> {
    let (Method::Plain(base) | Method::Feedback(base)) = spec.method else {
        return None;
    };
    if base == Base::Dopri5
        || x0s.len() < 2
        || spec.record_every() < spec.steps()
        || x0s.iter().any(|x0| check_start(model, x0, spec).is_err())
    {
        return None;
    }
    let k = x0s.len();
    if !spec.method.is_feedback() {
        return with_base(
            base,
            spec,
            DriveLanes {
                lanes: model.lanes(k),
                x0s,
                spec,
            },
        );
    }
    // one gain vector for all lanes, fixed during the run
    let mut plans = x0s
        .iter()
        .map(|x0| plan_gains::<_, _, Vec<f64>, Vec<f64>>(model, x0, spec, base.order()).ok());
    let plan = plans.next()??;
    let same = |p: &GainPlan<Vec<f64>>| {
        p.adapt.is_none()
            && p.initial
                .iter()
                .zip(&plan.initial)
                .all(|(a, b)| a.to_bits() == b.to_bits())
    };
    if plan.adapt.is_some() || !plans.all(|p| p.as_ref().is_some_and(same)) {
        return None;
    }
    let lanes = model.feedback_lanes(k, &plan.initial).ok()?;
    let mut traces = with_base(base, spec, DriveLanes { lanes, x0s, spec })?;
    for t in &mut traces {
        t.gains_initial = Some(plan.initial.clone());
        t.gains_final = Some(plan.initial.clone());
    }
    Some(traces)
}

/// The visitor of [`simulate_lanes`].
struct DriveLanes<'a, L> {
    lanes: L,
    x0s: &'a [Vec<f64>],
    spec: &'a RunSpec,
}

impl<L: LaneField> Visit<L, Vec<f64>> for DriveLanes<'_, L> {
    type Out = Option<Vec<Trace>>;

    fn visit<S: Stepper<f64, Vec<f64>, L> + Stats>(self, mut stepper: S) -> Self::Out {
        let (lanes, spec) = (&self.lanes, self.spec);
        let model = lanes.model();
        let mut driver = Driver::new(0.0, spec.t_end, spec.dt).max_steps(spec.max_steps);
        if model.has_guards() {
            driver = driver.guard(1, move |x: &Vec<f64>| {
                lanes.check_guards(x, spec.dt).map(|g| g.to_string())
            });
        }
        let (start, cpu_start) = (Instant::now(), process_cpu_seconds());
        let end = driver
            .run(&mut stepper, lanes, &lanes.pack(self.x0s).ok()?, &mut ())
            .ok()?;
        // a lane that diverged fails alone, where the failure is reported with its step
        let diverged = |(l, x0): (usize, &Vec<f64>)| {
            DriftBound::new(model, x0, spec.max_drift)
                .check(&lanes.unpack(&end.x, l))
                .is_some()
        };
        if self.x0s.iter().enumerate().any(diverged) {
            return None;
        }
        let k = lanes.k() as f64;
        let wall = start.elapsed().as_secs_f64() / k;
        let cpu = process_cpu_seconds()
            .zip(cpu_start)
            .map(|(end, start)| (end - start) / k);
        let stepper = (stepper.name(), stepper.stats());
        let traces = self.x0s.iter().enumerate().map(|(l, x0)| {
            // the samples of the lone run with `every = u64::MAX`: the first and the last
            let mut rec = Recorder::new(model, x0, spec.record_every(), 2);
            rec.observe(0, 0.0, x0);
            rec.finish(end.steps, end.t, &lanes.unpack(&end.x, l));
            let counts = Ok((end.steps, end.evaluations, end.rejections));
            trace(model, spec, stepper.clone(), rec, (wall, cpu), counts)
        });
        Some(traces.collect())
    }
}

/// The Taylor integrator of `model` with tolerance `--rtol`, over its kernels
/// ([`Declared::taylor_kernels`]).
fn taylor<Mdl, X, FV, K>(model: &Mdl, spec: &RunSpec) -> Result<Taylor<Mdl>, String>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let opts = TaylorOptions::with_tol(spec.rtol);
    let bad = |e: &dyn fmt::Display| format!("method `{}`: {e}", spec.method);
    let order = opts.checked_order().map_err(|e| bad(&e))?;
    let kernels = model.taylor_kernels(order).map_err(|e| bad(&e))?;
    Taylor::new(kernels, opts).map_err(|e| bad(&e))
}

/// The stepper of a feedback run.
enum FeedbackStepper<Mdl> {
    /// An explicit Runge–Kutta method.
    Base(Base),
    /// The Taylor method.
    Taylor(Taylor<Mdl>),
}

impl<Mdl> FeedbackStepper<Mdl> {
    /// Hands `visit` the stepper.
    fn visit<F, X, V>(self, spec: &RunSpec, visit: V) -> V::Out
    where
        F: Field<f64, X> + ?Sized,
        X: State<f64>,
        V: Visit<F, X>,
        Taylor<Mdl>: Stepper<f64, X, F>,
    {
        match self {
            FeedbackStepper::Base(b) => with_base(b, spec, visit),
            FeedbackStepper::Taylor(t) => visit.visit(t),
        }
    }
}

/// A run on the feedback field X − ∇V with the gains of `spec` (adapted along the run if it
/// says so).
fn feedback_run<Mdl, X, FV, K>(
    model: &Mdl,
    x0: &X,
    spec: &RunSpec,
    stepper: FeedbackStepper<Mdl>,
) -> Result<Trace, String>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let order = match &stepper {
        FeedbackStepper::Base(b) => b.order(),
        FeedbackStepper::Taylor(t) => <Taylor<Mdl> as Stepper<f64, X, Mdl>>::order(t),
    };
    let plan: GainPlan<K> = plan_gains(model, x0, spec, order)?;
    let fb = FeedbackField::from_initial(model, x0, plan.initial.clone());
    let inner = drive(model, &fb, x0, spec);
    let mut trace = match plan.wrap(inner) {
        Gained::Adaptive(adapt) => stepper.visit(spec, adapt),
        Gained::Fixed(inner) => stepper.visit(spec, inner),
    };
    trace.gains_initial = Some(plan.initial.as_ref().to_vec());
    trace.gains_final = Some(fb.gains().as_ref().to_vec());
    Ok(trace)
}

/// Checks the spec and the initial state (finite, inside the model's guards, where the field
/// and the invariants are defined); returns f(x₀).
fn check_start<Mdl, X, FV, K>(model: &Mdl, x0: &X, spec: &RunSpec) -> Result<FV, String>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    spec.validate()?;
    let name = model.model_name();
    let shown = x0.as_ref();
    if let Some(i) = shown.iter().position(|v| !v.is_finite()) {
        return Err(format!("initial state component {i} is not finite"));
    }
    // The field and the invariants must be defined at x0 (e.g. Kepler at x = 0 is not).
    let mut dx = x0.clone();
    let mut f = FV::filled(FV::len_for(model.invariant_dim()), 0.0);
    model.field(x0, &mut dx);
    model.invariants(x0, &mut f);
    if let Some(failure) = model.check_guards(x0, 0.0) {
        return Err(format!("invalid initial state {shown:?}: {failure}"));
    }
    if dx.as_ref().iter().chain(f.as_ref()).any(|v| !v.is_finite()) {
        return Err(format!(
            "the field or the invariants of `{name}` are not finite at the initial state {shown:?}"
        ));
    }
    Ok(f)
}

/// The gains of a feedback run: the initial ones and, for the adaptive policies, how the
/// [`AdaptiveGain`] wrapper keeps choosing them.
struct GainPlan<K> {
    initial: K,
    /// (re-estimation period, c, safety factor) of the wrapper.
    adapt: Option<(u64, f64, f64)>,
}

/// The innermost visitor of a feedback run, wrapped in the adaptive gain or not.
enum Gained<V, K> {
    Adaptive(Adapt<V, K>),
    Fixed(V),
}

impl<K: State<f64>> GainPlan<K> {
    /// `inner` wrapped in the adaptive gain if the plan has one.
    fn wrap<V>(&self, inner: V) -> Gained<V, K> {
        match self.adapt {
            Some((every, c, safety)) => Gained::Adaptive(Adapt {
                inner,
                unit: K::filled(K::len_for(self.initial.len()), 1.0),
                every,
                c,
                safety,
            }),
            None => Gained::Fixed(inner),
        }
    }
}

/// Resolves `spec.gains` for a feedback method of order `order`: `auto` by whether the method
/// is adaptive, `step` to the target h·k·L = [`step_gain_target`] with the tolerance `--rtol`.
fn plan_gains<Mdl, X, FV, K>(
    model: &Mdl,
    x0: &X,
    spec: &RunSpec,
    order: u32,
) -> Result<GainPlan<K>, String>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let located = |e: lasalle::GainError| {
        format!(
            "{e} (model `{}` has gains {})",
            model.model_name(),
            model.gain_names().join(", ")
        )
    };
    match spec.gains.clone().resolve(spec.method.is_adaptive()) {
        GainPolicy::Step { c, every } => {
            let target = step_gain_target(c, spec.rtol, order);
            let unit = K::filled(K::len_for(model.gain_names().len()), 1.0);
            // the first step is --dt, else DOPRI5's starting step on X; the wrapper rescales
            // to the step actually proposed
            let h = if spec.dt > 0.0 {
                spec.dt
            } else {
                DormandPrince::<f64, X>::with_tolerances(spec.rtol, spec.atol)
                    .initial_step(model, 0.0, x0, spec.t_end)
                    .ok_or("no starting step: give --dt")?
            };
            let initial = scaled_gains(model, x0, &unit, h, target).map_err(located)?;
            Ok(GainPlan {
                initial,
                adapt: Some((every, target, 1.0)),
            })
        }
        policy => {
            let initial = policy.initial_gains(model, x0, spec.dt).map_err(located)?;
            let adapt = match policy {
                GainPolicy::Adaptive { every, c } => Some((every, c, 0.8)),
                _ => None,
            };
            Ok(GainPlan { initial, adapt })
        }
    }
}

/// Applies `name=v1,v2,…` to the model's parameters.
pub fn apply_param<P: Parameters + ?Sized>(model: &mut P, text: &str) -> Result<(), String> {
    let (name, values) = text
        .split_once('=')
        .ok_or_else(|| format!("invalid --param `{text}`: expected `name=value[,value…]`"))?;
    let values = parse_numbers(values).map_err(|e| format!("invalid --param `{text}`: {e}"))?;
    model
        .set_param(name.trim(), &values)
        .map_err(|e| e.to_string())
}

/// Comma-separated finite numbers.
pub fn parse_numbers(text: &str) -> Result<Vec<f64>, String> {
    text.split(',')
        .map(|s| {
            let s = s.trim();
            match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(format!("`{s}` is not a finite number")),
            }
        })
        .collect()
}

/// The initial state from `--init`: a named point of the model (`paper`) or N
/// comma-separated numbers in the flat state order.
pub fn initial_state<Mdl>(model: &Mdl, init: &str) -> Result<Vec<f64>, String>
where
    Mdl: Parameters + ModelInfo,
{
    let n = model.state_dim();
    let looks_numeric = |t: &str| {
        t.contains(',')
            || t.starts_with(|c: char| c.is_ascii_digit() || "+-.".contains(c))
            || t.parse::<f64>().is_ok()
    };
    let values = if let Some(p) = model.point(init.trim()) {
        p
    } else if looks_numeric(init.trim()) {
        parse_numbers(init).map_err(|e| format!("invalid --init: {e}"))?
    } else {
        return Err(format!(
            "unknown point `{init}`; model has points: {} (or give {n} comma-separated numbers)",
            model.point_names().join(", ")
        ));
    };
    if values.len() != n {
        let layout: Vec<String> = model
            .state_slots()
            .iter()
            .map(|s| {
                format!(
                    "{}: {} at [{}..{}]",
                    s.name,
                    s.shape,
                    s.offset,
                    s.offset + s.shape.len()
                )
            })
            .collect();
        return Err(format!(
            "--init has {} numbers but the state of `{}` has dimension {n} ({})",
            values.len(),
            model.model_name(),
            layout.join(", ")
        ));
    }
    Ok(values)
}
