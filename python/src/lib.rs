//! The native part of the Python package `lasalle` (`lasalle._lasalle`): a loaded model, one
//! run, an ensemble, the chaos indicators (`chaos`) and the normal form, over the run engine
//! ([`lasalle_run`]). The Python
//! package (`lasalle/__init__.py`) gives it the public API: `Model`, `Solution`, `Solutions`,
//! executors and pickling.
//!
//! Every entry point returns a Python exception, never panics on user input: bad arguments
//! are `ValueError`, a model that does not load is `lasalle.ModelError` (with its file, line
//! and column), an initial state outside the model's guards is `lasalle.GuardError`. Runs and
//! ensembles release the GIL for their whole duration.

use std::collections::HashMap;
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

use lasalle_exec::{Backend, LoadError, LoadedModel};
use lasalle_run::{
    normalise, simulate, simulate_many, Interrupt, KernelPool, LookupError, Member, Method,
    ModelSource, Recording, Reusing, RunError, RunSpec,
};
use lasalle_runtime::{
    component_names, Declared, GainPolicy, ModelInfo, Parameters, Shape, Slot, StepError,
};
use numpy::{IntoPyArray, PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

mod chaos;

create_exception!(
    lasalle,
    LasalleError,
    PyException,
    "The base class of lasalle's exceptions."
);
create_exception!(
    lasalle,
    ModelError,
    LasalleError,
    "A model that does not load: a syntax error, an unknown name, a declared invariant that is \
     not conserved. Attributes: file, line, column (None where the problem has no place) and \
     diagnostic, the message as the command line prints it."
);
create_exception!(
    lasalle,
    GuardError,
    LasalleError,
    "A state outside the model's domain: a guard (`guard collision: norm(x) > 1e-6;`) fails. \
     Attributes: guard (its name), t and state."
);

/// The names of the built-in models (the repository's `models/*.lsl`).
#[pyfunction]
fn builtin_models() -> Vec<&'static str> {
    lasalle_run::builtin_models()
}

/// The path (for messages) and text of a model given as a path or the name of a built-in one
/// ([`lasalle_run::model_text`]): an unreadable path is `OSError`, an unknown name
/// `ValueError`.
#[pyfunction]
fn model_text(arg: &str) -> PyResult<(String, String)> {
    match lasalle_run::model_text(arg) {
        Ok(found) => Ok((found.path, found.text)),
        Err(e @ LookupError::Unreadable { .. }) => Err(PyOSError::new_err(e.to_string())),
        Err(e) => Err(PyValueError::new_err(e.to_string())),
    }
}

fn backend(name: &str) -> PyResult<Backend> {
    match normalise(name).as_str() {
        "jit" => Ok(Backend::Jit),
        "interpreter" => Ok(Backend::Interpreter),
        _ => Err(PyValueError::new_err(format!(
            "unknown backend `{name}`: `jit` (native code, the default) or `interpreter`"
        ))),
    }
}

fn backend_name(b: Backend) -> &'static str {
    match b {
        Backend::Jit => "jit",
        Backend::Interpreter => "interpreter",
    }
}

/// A `ModelError` with the location of the first diagnostic.
fn model_error(py: Python<'_>, e: LoadError) -> PyErr {
    let text = e.to_string();
    let located = match &e {
        LoadError::Model(lasalle_model::Error::Io { .. }) => {
            return PyOSError::new_err(text);
        }
        LoadError::Model(lasalle_model::Error::Model(diagnostics)) => diagnostics
            .iter()
            .find_map(|d| d.span.as_ref())
            .map(|s| (s.source.path.clone(), s.line_col())),
        _ => None,
    };
    let err = ModelError::new_err(text.trim_end().to_string());
    let value = err.value(py);
    let (file, line, col) = match located {
        Some((f, (l, c))) => (Some(f), Some(l), Some(c)),
        None => (None, None, None),
    };
    // setting attributes on a fresh exception instance cannot fail
    let _ = value.setattr("file", file);
    let _ = value.setattr("line", line);
    let _ = value.setattr("column", col);
    let _ = value.setattr("diagnostic", text);
    err
}

/// A `GuardError` for the guard `guard` failing at (`t`, `state`).
fn guard_error(py: Python<'_>, message: String, guard: &str, t: f64, state: &[f64]) -> PyErr {
    let err = GuardError::new_err(message);
    let value = err.value(py);
    let _ = value.setattr("guard", guard);
    let _ = value.setattr("t", t);
    let _ = value.setattr("state", state.to_vec().into_pyarray(py));
    err
}

/// A run's arguments that are not its model's parameters or initial state.
struct Options {
    method: Method,
    t_end: f64,
    dt: Option<f64>,
    rtol: Option<f64>,
    atol: Option<f64>,
    gains: GainPolicy,
    every: Option<u64>,
    max_steps: Option<u64>,
    max_drift: Option<f64>,
    /// Output times, from the run's start (t = 0).
    t_eval: Option<Vec<f64>>,
}

impl Options {
    #[allow(clippy::too_many_arguments)]
    fn new(
        method: &str,
        t_end: f64,
        dt: Option<f64>,
        rtol: Option<f64>,
        atol: Option<f64>,
        gains: &Bound<'_, PyAny>,
        every: Option<u64>,
        max_steps: Option<u64>,
        max_drift: Option<f64>,
        t_eval: Option<Vec<f64>>,
    ) -> PyResult<Options> {
        let method: Method = method.parse().map_err(run_error)?;
        let gains = if let Ok(text) = gains.extract::<String>() {
            text.parse::<GainPolicy>()
                .map_err(|e| PyValueError::new_err(format!("gains={text:?}: {e}")))?
        } else {
            let values: Vec<f64> = gains.extract().map_err(|_| {
                PyValueError::new_err(
                    "gains: a policy (`default`, `model`, `auto`, `fixed:c`, `adaptive:m:c`, \
                     `step:c:m`) or a sequence of numbers",
                )
            })?;
            GainPolicy::Explicit(values)
        };
        Ok(Options {
            method,
            t_end,
            dt,
            rtol,
            atol,
            gains,
            every,
            max_steps,
            max_drift,
            t_eval,
        })
    }

    /// The spec, checked.
    fn spec(&self) -> PyResult<RunSpec> {
        let mut b = RunSpec::builder()
            .method(self.method)
            .t_end(self.t_end)
            .gains(self.gains.clone());
        if let Some(dt) = self.dt {
            b = b.dt(dt);
        }
        if let Some(r) = self.rtol {
            b = b.rtol(r);
        }
        if let Some(a) = self.atol {
            b = b.atol(a);
        }
        if let Some(e) = self.every {
            b = b.every(e);
        }
        if let Some(m) = self.max_steps {
            b = b.max_steps(m);
        }
        if let Some(d) = self.max_drift {
            b = b.max_drift(d);
        }
        if let Some(t) = &self.t_eval {
            b = b.t_eval(t.clone());
        }
        b.build().map_err(|e| match e {
            RunError::Missing("dt") => PyValueError::new_err(format!(
                "method `{}` takes fixed steps: give dt=",
                self.method
            )),
            e => run_error(e),
        })
    }
}

/// How often a run asks the interpreter for pending signals (Ctrl-C).
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// A signal raised while a run was going on (`KeyboardInterrupt`), kept for the caller.
type Pending = Arc<Mutex<Option<PyErr>>>;

/// The pending signal's exception, if one stopped the run.
fn take(pending: &Pending) -> Option<PyErr> {
    pending.lock().unwrap_or_else(|p| p.into_inner()).take()
}

/// An interrupt for a run on the calling (main) thread with the GIL released: at most every
/// [`SIGNAL_POLL`] it takes the GIL and runs the interpreter's signal handlers; an exception
/// (Ctrl-C's `KeyboardInterrupt`) stops the run and waits in the returned slot.
fn signal_poll() -> (Interrupt, Pending) {
    let pending: Pending = Arc::default();
    let slot = pending.clone();
    let last = Mutex::new(Instant::now());
    let interrupt = Interrupt::with_poll(move || {
        let mut last = last.lock().unwrap_or_else(|p| p.into_inner());
        if last.elapsed() < SIGNAL_POLL {
            return false;
        }
        *last = Instant::now();
        match Python::with_gil(|py| py.check_signals()) {
            Ok(()) => false,
            Err(e) => {
                *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                true
            }
        }
    });
    (interrupt, pending)
}

/// Runs `work` on a scoped thread with the GIL released while this (main) thread runs the
/// interpreter's signal handlers every 20 ms; an exception there (Ctrl-C) stops `interrupt`,
/// waits for `work` to wind down and is returned.
fn watched<T: Send>(
    py: Python<'_>,
    interrupt: &Interrupt,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    py.allow_threads(|| {
        std::thread::scope(|s| {
            let (tx, rx) = mpsc::channel();
            s.spawn(move || {
                let _ = tx.send(work());
            });
            loop {
                match rx.recv_timeout(Duration::from_millis(20)) {
                    Ok(out) => return Ok(out),
                    Err(mpsc::RecvTimeoutError::Timeout) => {
                        if let Err(e) = Python::with_gil(|py| py.check_signals()) {
                            interrupt.stop();
                            // the runs stop within a few hundred steps; nothing is left behind
                            let _ = rx.recv();
                            return Err(e);
                        }
                    }
                    Err(mpsc::RecvTimeoutError::Disconnected) => {
                        return Err(PyException::new_err("the ensemble's thread failed"))
                    }
                }
            }
        })
    })
}

/// The command line's flags in the run engine's messages and what Python calls them, in the
/// order they are replaced (a flag with its value before the flag alone).
const KEYWORDS: &[(&str, &str)] = &[
    ("--gains step", "gains=\"step:c:m\""),
    ("--gains adaptive", "gains=\"adaptive:m:c\""),
    ("(--dt)", "(dt=)"),
    ("the end time --t-end ", "the span t1 - t0 = "),
    ("--t-end ", "the span t1 - t0 = "),
    ("--projection-tol ", ""),
    ("--rtol alone", "rtol= alone"),
    ("--dt ", "dt="),
    ("--rtol ", "rtol="),
    ("--atol ", "atol="),
    ("--t-eval ", "t_eval="),
    ("--init ", "y0="),
    ("--dt", "dt="),
    ("--rtol", "rtol="),
    ("--atol", "atol="),
    ("--gains", "gains="),
    ("--max-steps", "max_steps="),
    ("--max-drift", "max_drift="),
    ("--t-eval", "t_eval="),
    ("--init", "y0="),
];

/// A message of the run engine (which names the command line's flags, `--dt 0.1`) with
/// Python's keywords (`dt=0.1`).
fn keyword_message(message: &str) -> String {
    KEYWORDS
        .iter()
        .fold(message.to_string(), |m, (flag, key)| m.replace(flag, key))
}

/// A [`RunError`] as Python's `ValueError`, its message naming Python's keywords.
fn run_error(e: RunError) -> PyErr {
    match e {
        RunError::Inapplicable { setting, method } => PyValueError::new_err(format!(
            "{}= {}",
            setting.name(),
            method.refuses(setting).unwrap_or_default()
        )),
        e => PyValueError::new_err(keyword_message(&e.to_string())),
    }
}

/// The guard's name in a guard failure's message (``guard `name` violated: …``).
fn guard_name(message: &str) -> Option<&str> {
    let rest = message.split("guard `").nth(1)?;
    rest.split('`').next()
}

/// What stopped a run: kind, message, time, state, the guard.
fn failure_dict<'py>(py: Python<'py>, e: &StepError) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let kind = match e {
        StepError::NonFinite { .. } => "blow-up",
        StepError::StepSizeTooSmall { .. } => "step-size",
        StepError::TooManyRejections { .. } => "rejections",
        StepError::MaxSteps { .. } => "max-steps",
        StepError::ProjectionNotConverged { .. } => "projection",
        StepError::Guard { .. } => "guard",
        StepError::Diverged { .. } => "diverged",
        StepError::Interrupted { .. } => "interrupted",
        _ => "invalid",
    };
    d.set_item("kind", kind)?;
    d.set_item("message", keyword_message(&e.to_string()))?;
    d.set_item("t", e.time())?;
    d.set_item("state", e.state().map(|s| s.to_vec().into_pyarray(py)))?;
    d.set_item("step", e.step())?;
    let guard = match e {
        StepError::Guard { message, .. } => guard_name(message).map(str::to_string),
        _ => None,
    };
    d.set_item("guard", guard)?;
    Ok(d)
}

/// The crossings of the model's events (`events`, the declared names in order), scipy's way:
/// `t_events` a list of arrays (k,) and `y_events` a list of arrays (k, n), one per declared
/// event, the terminal crossing included; `stopped_by` the terminal event's name, time and
/// state, or None. Times shifted by `t0`.
fn events_into(
    py: Python<'_>,
    d: &Bound<'_, PyDict>,
    rec: &Recording,
    t0: f64,
    events: &[&str],
) -> PyResult<()> {
    let n = rec.dim();
    let mut ts: Vec<Vec<f64>> = vec![Vec::new(); events.len()];
    let mut ys: Vec<Vec<f64>> = vec![Vec::new(); events.len()];
    for hit in rec.events.iter().chain(&rec.stopped_by) {
        if let Some(k) = events.iter().position(|e| *e == hit.name) {
            ts[k].push(hit.t + t0);
            ys[k].extend_from_slice(&hit.x);
        }
    }
    let t_events = PyList::empty(py);
    let y_events = PyList::empty(py);
    for (t, y) in ts.into_iter().zip(ys) {
        let k = t.len();
        t_events.append(t.into_pyarray(py))?;
        y_events.append(y.into_pyarray(py).reshape([k, n])?)?;
    }
    d.set_item("t_events", t_events)?;
    d.set_item("y_events", y_events)?;
    match &rec.stopped_by {
        None => d.set_item("stopped_by", py.None())?,
        Some(hit) => {
            let s = PyDict::new(py);
            s.set_item("event", &hit.name)?;
            s.set_item("t", hit.t + t0)?;
            s.set_item("state", hit.x.clone().into_pyarray(py))?;
            d.set_item("stopped_by", s)?;
        }
    }
    Ok(())
}

/// One run as a dict of the Python `Solution`'s fields; times shifted by `t0`; `events` the
/// model's declared events, in order.
fn recording_dict<'py>(
    py: Python<'py>,
    rec: &Recording,
    t0: f64,
    events: &[&str],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let (n, nt, m) = (rec.dim(), rec.len(), rec.blocks.len());
    let t: Vec<f64> = rec.t.iter().map(|t| t + t0).collect();
    let mut y = vec![0.0; n * nt];
    for (k, sample) in rec.x.chunks_exact(n.max(1)).enumerate() {
        for (i, v) in sample.iter().enumerate() {
            y[i * nt + k] = *v;
        }
    }
    let mut inv = vec![0.0; m * nt];
    for (k, sample) in rec.errors.chunks_exact(m.max(1)).enumerate() {
        for (b, v) in sample.iter().enumerate() {
            inv[b * nt + k] = *v;
        }
    }
    let max_drift: Vec<f64> = (0..m).map(|b| rec.max_error(b)).collect();
    d.set_item("t", t.into_pyarray(py))?;
    d.set_item("y", y.into_pyarray(py).reshape([n, nt])?)?;
    d.set_item("invariants", inv.into_pyarray(py).reshape([m, nt])?)?;
    d.set_item("max_drift", max_drift.into_pyarray(py))?;
    d.set_item("success", rec.failure.is_none())?;
    d.set_item("nfev", rec.evaluations)?;
    d.set_item("steps", rec.steps)?;
    d.set_item("rejections", rec.rejections)?;
    d.set_item("method", &rec.method)?;
    d.set_item("stepper", &rec.stepper)?;
    d.set_item("wall_seconds", rec.wall_seconds)?;
    d.set_item("cpu_seconds", rec.cpu_seconds)?;
    d.set_item("gains_initial", rec.gains_initial.clone())?;
    d.set_item("gains_final", rec.gains_final.clone())?;
    let counters = PyDict::new(py);
    for (name, v) in &rec.counters {
        counters.set_item(name, v)?;
    }
    d.set_item("counters", counters)?;
    match &rec.stability {
        None => d.set_item("stability", py.None())?,
        Some(s) => {
            let sd = PyDict::new(py);
            sd.set_item("interval", s.interval)?;
            sd.set_item("max_h_k_L", s.max_h_k_l)?;
            sd.set_item("left_interval", s.left_interval())?;
            sd.set_item("steps_outside", s.steps_outside)?;
            sd.set_item("first_outside_t", s.first_outside_t)?;
            sd.set_item("capped_steps", s.capped.map(|c| c.0))?;
            sd.set_item("min_gain_factor", s.capped.map(|c| c.1))?;
            d.set_item("stability", sd)?;
        }
    }
    match &rec.failure {
        None => d.set_item("failure", py.None())?,
        Some(e) => d.set_item("failure", failure_dict(py, e)?)?,
    }
    events_into(py, &d, rec, t0, events)?;
    Ok(d)
}

/// A parameter's values as Python sees them: a float, or an array of its shape.
fn param_value<'py>(py: Python<'py>, slot: &Slot, values: Vec<f64>) -> PyResult<Bound<'py, PyAny>> {
    Ok(match slot.shape {
        Shape::Scalar => values[0].into_pyobject(py)?.into_any(),
        Shape::Vector(_) => values.into_pyarray(py).into_any(),
        // column-major in the model: the transpose of the row-major (c, r) array
        Shape::Matrix(r, c) => values
            .into_pyarray(py)
            .reshape([c, r])?
            .transpose()?
            .into_any(),
    })
}

/// A loaded model (the native half of `lasalle.Model`).
#[pyclass(module = "lasalle._lasalle", name = "NativeModel")]
struct NativeModel {
    source: ModelSource,
    model: LoadedModel,
    /// The Taylor kernels of its runs, built at the first Taylor run of each order.
    kernels: std::sync::Arc<KernelPool>,
}

impl NativeModel {
    fn slot(&self, name: &str) -> PyResult<Slot> {
        self.model
            .param_slots()
            .iter()
            .find(|s| s.name == name)
            .copied()
            .ok_or_else(|| {
                let known: Vec<&str> = self.model.param_slots().iter().map(|s| s.name).collect();
                PyValueError::new_err(format!(
                    "unknown parameter `{name}`; the model `{}` has: {}",
                    self.model.model_name(),
                    known.join(", ")
                ))
            })
    }

    /// The current values of every parameter.
    fn all_params(&self) -> Vec<(String, Vec<f64>)> {
        self.model
            .param_slots()
            .iter()
            .filter_map(|s| Some((s.name.to_string(), self.model.param(s.name)?)))
            .collect()
    }

    fn check_state(&self, py: Python<'_>, y0: &[f64], spec: &RunSpec, t0: f64) -> PyResult<()> {
        let n = self.model.state_dim();
        if y0.len() != n {
            return Err(PyValueError::new_err(format!(
                "y0 has {} components but the state of `{}` has dimension {n} ({})",
                y0.len(),
                self.model.model_name(),
                component_names(self.model.state_slots()).join(", ")
            )));
        }
        let h = if spec.method.is_adaptive() {
            0.0
        } else {
            spec.dt
        };
        if let Some(g) = self.model.check_guards(&y0.to_vec(), h) {
            return Err(guard_error(
                py,
                format!("the initial state is outside the model's domain: {g}"),
                g.name,
                t0,
                y0,
            ));
        }
        Ok(())
    }
}

#[pymethods]
impl NativeModel {
    /// Loads a model from its text; `path` names it in messages.
    #[new]
    #[pyo3(signature = (text, path, backend_name = "jit"))]
    fn new(py: Python<'_>, text: String, path: String, backend_name: &str) -> PyResult<Self> {
        let backend = backend(backend_name)?;
        let source = ModelSource::new(path, text, backend);
        let model = py
            .allow_threads(|| LoadedModel::from_source(&source.path, &source.text, backend))
            .map_err(|e| model_error(py, e))?;
        Ok(NativeModel {
            source,
            model,
            kernels: KernelPool::new(),
        })
    }

    #[getter]
    fn name(&self) -> &'static str {
        self.model.model_name()
    }

    #[getter]
    fn path(&self) -> &str {
        &self.source.path
    }

    #[getter]
    fn text(&self) -> &str {
        &self.source.text
    }

    #[getter]
    fn backend(&self) -> &'static str {
        backend_name(self.source.backend)
    }

    #[getter]
    fn state_names(&self) -> Vec<String> {
        component_names(self.model.state_slots())
    }

    #[getter]
    fn param_names(&self) -> Vec<&'static str> {
        self.model.param_slots().iter().map(|s| s.name).collect()
    }

    #[getter]
    fn integrals(&self) -> Vec<&'static str> {
        self.model
            .invariant_infos()
            .iter()
            .map(|i| i.slot.name)
            .collect()
    }

    #[getter]
    fn gain_names(&self) -> Vec<&'static str> {
        self.model.gain_names().to_vec()
    }

    /// The declared events' names, in declaration order.
    #[getter]
    fn event_names(&self) -> Vec<&'static str> {
        self.model.events().iter().map(|e| e.name).collect()
    }

    /// The declared events' terminal flags (`stop`), in declaration order.
    #[getter]
    fn event_terminal(&self) -> Vec<bool> {
        self.model.events().iter().map(|e| e.terminal).collect()
    }

    #[getter]
    fn point_names(&self) -> Vec<&'static str> {
        self.model.point_names().to_vec()
    }

    #[getter]
    fn dim(&self) -> usize {
        self.model.state_dim()
    }

    /// The load time (parse, derive, check, compile) in seconds.
    #[getter]
    fn load_seconds(&self) -> f64 {
        self.model.load_time().as_secs_f64()
    }

    /// A named point, evaluated with the current parameters.
    fn point<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.model
            .point(name)
            .map(|p| p.into_pyarray(py))
            .ok_or_else(|| {
                PyValueError::new_err(format!(
                    "unknown point `{name}`; the model has: {}",
                    self.model.point_names().join(", ")
                ))
            })
    }

    /// A parameter's current value (a float, or an array of its shape).
    fn get_param<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let slot = self.slot(name)?;
        let values = self.model.param(name).unwrap_or_default();
        param_value(py, &slot, values)
    }

    /// The shape of a parameter: () for a scalar, (n,) or (r, c).
    fn param_shape(&self, name: &str) -> PyResult<Vec<usize>> {
        Ok(match self.slot(name)?.shape {
            Shape::Scalar => vec![],
            Shape::Vector(n) => vec![n],
            Shape::Matrix(r, c) => vec![r, c],
        })
    }

    /// Sets a parameter from its flat values (matrices column-major).
    fn set_param(&mut self, name: &str, values: Vec<f64>) -> PyResult<()> {
        self.slot(name)?;
        if let Some(v) = values.iter().find(|v| !v.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "parameter `{name}`: {v} is not a finite number"
            )));
        }
        self.model
            .set_param(name, &values)
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// The run presets, as dicts.
    fn presets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let out = PyDict::new(py);
        for p in self.model.presets() {
            let d = PyDict::new(py);
            d.set_item("method", p.method.map(|m| m.replace('_', "-")))?;
            d.set_item("dt", p.dt)?;
            d.set_item("t_end", p.t_end)?;
            d.set_item("every", p.every)?;
            d.set_item("init", p.init)?;
            d.set_item("gains", p.gains.map(|g| g.to_vec()))?;
            let params = PyDict::new(py);
            for (name, values) in p.params {
                params.set_item(name, values.to_vec())?;
            }
            d.set_item("params", params)?;
            out.set_item(p.name, d)?;
        }
        Ok(out)
    }

    /// One run from `y0` over [t0, t1]; `params` overrides parameters for this run only.
    #[pyo3(signature = (y0, t0, t1, method, dt, rtol, atol, gains, params, every, max_steps, max_drift, t_eval, main_thread=false))]
    #[allow(clippy::too_many_arguments)]
    fn solve<'py>(
        &mut self,
        py: Python<'py>,
        y0: PyReadonlyArray1<'py, f64>,
        t0: f64,
        t1: f64,
        method: &str,
        dt: Option<f64>,
        rtol: Option<f64>,
        atol: Option<f64>,
        gains: &Bound<'py, PyAny>,
        params: HashMap<String, Vec<f64>>,
        every: Option<u64>,
        max_steps: Option<u64>,
        max_drift: Option<f64>,
        t_eval: Option<Vec<f64>>,
        main_thread: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let opts = Options::new(
            method,
            t1 - t0,
            dt,
            rtol,
            atol,
            gains,
            every,
            max_steps,
            max_drift,
            t_eval,
        )?;
        let mut spec = opts.spec()?;
        // Ctrl-C: only the main thread runs the interpreter's signal handlers
        let signal = main_thread.then(|| {
            let (interrupt, signal) = signal_poll();
            spec.interrupt = Some(interrupt);
            signal
        });
        let y0: Vec<f64> = y0.as_array().iter().copied().collect();
        // the overrides for this run, then the model's values back
        let saved = self.all_params();
        for (name, values) in &params {
            if let Err(e) = self.set_param(name, values.clone()) {
                self.restore(&saved);
                return Err(e);
            }
        }
        let result = self.check_state(py, &y0, &spec, t0).and_then(|()| {
            let model = &self.model;
            let reusing = Reusing::new(model, &self.kernels);
            py.allow_threads(|| {
                if spec.method.is_taylor() {
                    simulate(&reusing, &y0, &spec)
                } else {
                    simulate(model, &y0, &spec)
                }
            })
            .map_err(run_error)
        });
        self.restore(&saved);
        if let Some(e) = signal.as_ref().and_then(take) {
            return Err(e);
        }
        recording_dict(py, &result?, t0, &self.event_names())
    }

    /// Runs of the rows of `y0s` (B, n) with per-row parameters `params` (name → (B, k)
    /// flat values), on `threads` threads (0: one per core), `lanes` rows at a time in lanes.
    #[pyo3(signature = (y0s, t0, t1, method, dt, rtol, atol, gains, params, every, max_steps, max_drift, t_eval, threads, lanes, main_thread=false))]
    #[allow(clippy::too_many_arguments)]
    fn solve_many<'py>(
        &self,
        py: Python<'py>,
        y0s: PyReadonlyArray2<'py, f64>,
        t0: f64,
        t1: f64,
        method: &str,
        dt: Option<f64>,
        rtol: Option<f64>,
        atol: Option<f64>,
        gains: &Bound<'py, PyAny>,
        params: HashMap<String, PyReadonlyArray2<'py, f64>>,
        every: Option<u64>,
        max_steps: Option<u64>,
        max_drift: Option<f64>,
        t_eval: Option<Vec<f64>>,
        threads: usize,
        lanes: usize,
        main_thread: bool,
    ) -> PyResult<Bound<'py, PyList>> {
        let opts = Options::new(
            method,
            t1 - t0,
            dt,
            rtol,
            atol,
            gains,
            every,
            max_steps,
            max_drift,
            t_eval,
        )?;
        let mut spec = opts.spec()?;
        let interrupt = Interrupt::new();
        spec.interrupt = Some(interrupt.clone());
        let members = self.members(&y0s, &params)?;
        let source = &self.source;
        let run = || simulate_many(source, &members, &spec, threads, lanes);
        // Ctrl-C: only the main thread runs the interpreter's signal handlers
        let ensemble = if main_thread {
            watched(py, &interrupt, run)?
        } else {
            py.allow_threads(run)
        }
        .map_err(run_error)?;
        let out = PyList::empty(py);
        let events = self.event_names();
        for r in &ensemble.recordings {
            match r {
                Ok(rec) => out.append(recording_dict(py, rec, t0, &events)?)?,
                Err(e) => out.append(keyword_message(&e.to_string()))?,
            }
        }
        Ok(out)
    }

    /// The Birkhoff normal form at an elliptic equilibrium, as the JSON text of
    /// `lasalle normal-form --format json`.
    #[pyo3(signature = (order, precision, params, at, resonant, resonance_tol, max_rel_error, error_estimate))]
    #[allow(clippy::too_many_arguments)]
    fn normal_form(
        &self,
        py: Python<'_>,
        order: usize,
        precision: &str,
        params: HashMap<String, f64>,
        at: Option<&Bound<'_, PyAny>>,
        resonant: bool,
        resonance_tol: f64,
        max_rel_error: f64,
        error_estimate: &str,
    ) -> PyResult<String> {
        use lasalle_normal_form::{
            normalize_model, ErrorEstimate, ModelPoint, Options, Precision, MAX_ORDER,
        };
        if !(2..=MAX_ORDER).contains(&order) {
            return Err(PyValueError::new_err(format!(
                "order={order}: the truncation degree must be between 2 and {MAX_ORDER}"
            )));
        }
        if !(max_rel_error > 0.0 && max_rel_error <= 1.0) {
            return Err(PyValueError::new_err(format!(
                "max_rel_error={max_rel_error}: must be in (0, 1]"
            )));
        }
        if !(resonance_tol >= 0.0 && resonance_tol.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "resonance_tol={resonance_tol}: must be a finite number >= 0"
            )));
        }
        let (precision, auto) = match normalise(precision).as_str() {
            "auto" => (Precision::F64, true),
            "f64" | "double" => (Precision::F64, false),
            "dd" | "doubledouble" => (Precision::DoubleDouble, false),
            _ => {
                return Err(PyValueError::new_err(format!(
                    "precision={precision:?}: `auto`, `f64` or `dd`"
                )))
            }
        };
        let estimate = match (normalise(error_estimate).as_str(), precision) {
            ("none", _) => ErrorEstimate::None,
            ("cheap", Precision::F64) => ErrorEstimate::Rotation,
            ("cheap", _) | ("rerun", _) => ErrorEstimate::OtherPrecision,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "error_estimate={error_estimate:?}: `cheap`, `rerun` or `none`"
                )))
            }
        };
        let point = match at {
            None => ModelPoint::Auto,
            Some(a) => {
                if let Ok(name) = a.extract::<String>() {
                    ModelPoint::Named(name)
                } else {
                    ModelPoint::Values(a.extract::<Vec<f64>>().map_err(|_| {
                        PyValueError::new_err("at: a point's name or a sequence of numbers")
                    })?)
                }
            }
        };
        // the model's current scalar parameters, then the overrides
        let mut values: Vec<(String, f64)> = self
            .all_params()
            .into_iter()
            .filter(|(_, v)| v.len() == 1)
            .map(|(n, v)| (n, v[0]))
            .collect();
        for (name, v) in params {
            let slot = self.slot(&name)?;
            if slot.shape.len() != 1 {
                return Err(PyValueError::new_err(format!(
                    "parameter `{name}` is not a scalar"
                )));
            }
            values.retain(|(n, _)| *n != name);
            values.push((name, v));
        }
        let options = Options {
            order,
            precision,
            auto_precision: auto,
            max_relative_error: Some(max_rel_error),
            resonant,
            resonance_tol,
            error_estimate: estimate,
            ..Options::default()
        };
        let source = &self.source;
        let result = py.allow_threads(|| {
            let model = lasalle_model::lower_source(&source.path, &source.text)
                .map_err(|e| e.to_string())?;
            normalize_model(&model, &values, &point, &options)
                .map(|nf| nf.to_json())
                .map_err(|e| format!("{}: {e}", source.path))
        });
        result.map_err(PyValueError::new_err)
    }

    /// The stability analysis the model's structure chooses, with the current parameters,
    /// as the JSON text of `lasalle stability --format json`; `file` names the model file.
    #[pyo3(signature = (file, casimir, at, range, levels, lyapunov, radius, time_bound, order, for_time, outer_ratio, remainder_degree, metric, equilibrium, validate, horizon, certified))]
    #[allow(clippy::too_many_arguments)]
    fn stability(
        &self,
        py: Python<'_>,
        file: &str,
        casimir: Option<f64>,
        at: Option<Vec<f64>>,
        range: Option<(f64, f64)>,
        levels: usize,
        lyapunov: Option<String>,
        radius: Option<f64>,
        time_bound: Vec<(f64, f64)>,
        order: Option<usize>,
        for_time: Vec<f64>,
        outer_ratio: Option<f64>,
        remainder_degree: Option<usize>,
        metric: &str,
        equilibrium: Option<&Bound<'_, PyAny>>,
        validate: bool,
        horizon: f64,
        certified: bool,
    ) -> PyResult<String> {
        use lasalle_analysis::canonical::{Validation, SEARCH_MAX_ORDER};
        use lasalle_analysis::stability::{analyse, StabilityKind, StabilityOptions};
        use lasalle_normal_form::{bound::Metric, ModelPoint};
        let kind = StabilityKind::of(&self.model)
            .map_err(|e| PyValueError::new_err(keywords(&e.message("with at=[x1, x2]"))))?;
        let given = |name: &str, set: bool, kinds: &[StabilityKind]| {
            if set && !kinds.contains(&kind) {
                Err(PyValueError::new_err(format!(
                    "{name}= does not apply: `{}` gets the {} analysis",
                    self.model.model_name(),
                    match kind {
                        StabilityKind::LiePoisson => "Lie–Poisson (energy–Casimir)",
                        StabilityKind::Canonical => "canonical (normal-form)",
                        StabilityKind::Attraction => "domain-of-attraction",
                    }
                )))
            } else {
                Ok(())
            }
        };
        use StabilityKind::{Attraction, Canonical, LiePoisson};
        given("casimir", casimir.is_some(), &[LiePoisson])?;
        given("range", range.is_some(), &[LiePoisson])?;
        given("at", at.is_some(), &[LiePoisson, Attraction])?;
        given("lyapunov", lyapunov.is_some(), &[Attraction])?;
        given("radius", radius.is_some(), &[Attraction])?;
        let canonical_set = !time_bound.is_empty()
            || order.is_some()
            || !for_time.is_empty()
            || outer_ratio.is_some()
            || remainder_degree.is_some()
            || equilibrium.is_some()
            || validate
            || certified;
        given(
            "time_bound/order/for_time/outer_ratio/remainder_degree/equilibrium/validate/certified",
            canonical_set,
            &[Canonical],
        )?;
        if validate && time_bound.is_empty() {
            return Err(PyValueError::new_err(
                "validate=True needs time_bound=[(d0, d1)]",
            ));
        }
        if certified && time_bound.is_empty() && for_time.is_empty() {
            return Err(PyValueError::new_err(
                "certified=True needs time_bound=[(d0, d1)] or for_time=[T]",
            ));
        }
        if !(horizon > 0.0 && horizon.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "horizon={horizon}: must be a positive finite time"
            )));
        }
        let metric = match normalise(metric).as_str() {
            "euclidean" => Metric::Euclidean,
            "linearnormal" => Metric::LinearNormal,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "metric={metric:?}: `euclidean` or `linear-normal`"
                )))
            }
        };
        let point = match equilibrium {
            None => ModelPoint::Auto,
            Some(a) => match a.extract::<String>() {
                Ok(name) => ModelPoint::Named(name),
                Err(_) => ModelPoint::Values(a.extract::<Vec<f64>>().map_err(|_| {
                    PyValueError::new_err("equilibrium: a point's name or a sequence of numbers")
                })?),
            },
        };
        let mut opts = StabilityOptions {
            casimir,
            at,
            range,
            levels,
            lyapunov,
            radius,
            ..StabilityOptions::default()
        };
        let c = &mut opts.canonical;
        c.point = point;
        c.tubes = time_bound;
        c.max_order = order.unwrap_or(SEARCH_MAX_ORDER);
        c.optimal = order.is_none();
        c.for_time = for_time;
        c.outer_ratio = outer_ratio.unwrap_or(2.0);
        c.remainder_degree = remainder_degree;
        c.metric = metric;
        c.validate = validate.then(|| Validation {
            horizon,
            ..Validation::default()
        });
        c.certified = certified;
        let model = &self.model;
        let report = py.allow_threads(|| analyse(model, file, &opts));
        match report {
            Ok(r) => serde_json::to_string(&r.to_json())
                .map_err(|e| PyValueError::new_err(e.to_string())),
            Err(e) => Err(PyValueError::new_err(keywords(
                &e.message("with at=[x1, x2]"),
            ))),
        }
    }
}

/// A message of the analyses with the command line's flags named as Python's keywords.
fn keywords(message: &str) -> String {
    [
        ("--time-bound ", "time_bound="),
        ("--for-time ", "for_time="),
        ("--outer-ratio ", "outer_ratio="),
        ("--order ", "order="),
        ("--at ", "at="),
        ("--equilibrium ", "equilibrium="),
        ("--metric linear-normal", "metric=\"linear-normal\""),
        ("--resonant", "resonant=True"),
    ]
    .iter()
    .fold(message.to_string(), |m, (flag, key)| m.replace(flag, key))
}

impl NativeModel {
    /// The members of an ensemble: the rows of `y0s` (B, n), each with the model's current
    /// parameters but those of `params` (name → (B, k) flat values), row by row.
    fn members(
        &self,
        y0s: &PyReadonlyArray2<'_, f64>,
        params: &HashMap<String, PyReadonlyArray2<'_, f64>>,
    ) -> PyResult<Vec<Member>> {
        let y0s = y0s.as_array();
        let (b, n) = (y0s.nrows(), y0s.ncols());
        if n != self.model.state_dim() {
            return Err(PyValueError::new_err(format!(
                "y0s has {n} columns but the state of `{}` has dimension {} ({})",
                self.model.model_name(),
                self.model.state_dim(),
                component_names(self.model.state_slots()).join(", ")
            )));
        }
        let base = self.all_params();
        let mut columns: Vec<(String, usize, Vec<f64>)> = Vec::new();
        for (name, values) in params {
            let slot = self.slot(name)?;
            let values = values.as_array();
            if values.nrows() != b || values.ncols() != slot.shape.len() {
                return Err(PyValueError::new_err(format!(
                    "params[{name:?}] has shape ({}, {}) but {b} rows of {} values are needed",
                    values.nrows(),
                    values.ncols(),
                    slot.shape.len()
                )));
            }
            if let Some(v) = values.iter().find(|v| !v.is_finite()) {
                return Err(PyValueError::new_err(format!(
                    "params[{name:?}]: {v} is not a finite number"
                )));
            }
            columns.push((
                name.clone(),
                slot.shape.len(),
                values.iter().copied().collect(),
            ));
        }
        Ok((0..b)
            .map(|row| {
                let mut m = Member::at(y0s.row(row).iter().copied().collect());
                for (name, values) in &base {
                    if !params.contains_key(name) {
                        m = m.param(name.clone(), values.clone());
                    }
                }
                for (name, k, values) in &columns {
                    m = m.param(name.clone(), values[row * k..(row + 1) * k].to_vec());
                }
                m
            })
            .collect())
    }

    fn restore(&mut self, saved: &[(String, Vec<f64>)]) {
        for (name, values) in saved {
            // the values were read from the model itself: they fit
            let _ = self.model.set_param(name, values);
        }
    }
}

/// The native module `lasalle._lasalle`.
#[pymodule]
fn _lasalle(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<NativeModel>()?;
    m.add_function(wrap_pyfunction!(model_text, m)?)?;
    m.add_function(wrap_pyfunction!(builtin_models, m)?)?;
    m.add("LasalleError", py.get_type::<LasalleError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("GuardError", py.get_type::<GuardError>())?;
    m.add("known_methods", Method::known())?;
    chaos::register(m)?;
    Ok(())
}
