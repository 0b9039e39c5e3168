//! The variational equations and chaos indicators of the Python package: `Model.solve(…,
//! variational=, lyapunov_spectrum=, megno=, fli=)` and `Model.solve_many(…, megno=, fli=)`.
//!
//! Both go through the run engine's [`lasalle_run::chaos`], as the command line does, so each
//! value is bitwise the command line's: `solve`'s extended runs are those of `lasalle run
//! --variational --lyapunov-spectrum --megno --fli` (each a run of its own extended model from
//! the run's initial state, with the run's method, tolerances and step budget, recording the
//! start and the end only), and `solve_many`'s rows those of `lasalle sweep --indicator` (each
//! row one run of the model extended by the indicators' equations, [`Extension::Indicators`],
//! locating the peaks of ln‖w‖ only when the FLI is asked for).
//!
//! A method that does not integrate the extended field, a backward span for the indicators or
//! a bad `renormalise_every` is a `ValueError`, and an extended run that fails (its step
//! budget spent, a blow-up, a degenerate tangent vector) a `lasalle.LasalleError`; both name
//! the keyword argument that asked for the run.

use std::collections::HashMap;
use std::time::Instant;

use lasalle_run::chaos::{self, Extension, Indicators, Spectrum, Transition};
use lasalle_run::{simulate_many, Interrupt, Method, Recording, RunError, RunSpec};
use lasalle_runtime::ModelInfo;
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::{
    keyword_message, recording_dict, signal_poll, take, watched, LasalleError, NativeModel, Options,
};

/// The extended runs a `solve` call asks for, by keyword.
#[derive(Clone, Copy, Debug)]
struct Asked {
    variational: bool,
    /// The re-orthonormalisation interval, if the spectrum is asked for.
    lyapunov_spectrum: Option<f64>,
    megno: bool,
    fli: bool,
}

impl Asked {
    /// The keywords given, as Python writes them.
    fn keywords(&self) -> Vec<&'static str> {
        [
            (self.variational, "variational=True"),
            (self.lyapunov_spectrum.is_some(), "lyapunov_spectrum=True"),
            (self.megno, "megno=True"),
            (self.fli, "fli=True"),
        ]
        .into_iter()
        .filter_map(|(given, k)| given.then_some(k))
        .collect()
    }

    /// The keywords of the runs that measure growth forwards in time.
    fn forward_keywords(&self) -> Vec<&'static str> {
        let mut k = self.keywords();
        k.retain(|k| *k != "variational=True");
        k
    }
}

/// Refuses what no extended run can do, before any run: a method that does not integrate the
/// extended field (`keywords` the indicators asked for), a backward span for the indicators
/// and the spectrum (`forward` those of them asked for), a re-orthonormalisation interval that
/// is not a positive number.
fn refuse(
    method: &str,
    keywords: &[&str],
    t_span: (f64, f64),
    forward: &[&str],
    renormalise_every: Option<f64>,
) -> PyResult<()> {
    let method: Method = method
        .parse()
        .map_err(|e: RunError| PyValueError::new_err(keyword_message(&e.to_string())))?;
    if keywords.is_empty() {
        return Ok(());
    }
    let named = keywords.join(", ");
    chaos::check_method(method).map_err(|e| PyValueError::new_err(format!("{named}: {e}")))?;
    if t_span.1 < t_span.0 && !forward.is_empty() {
        return Err(PyValueError::new_err(format!(
            "{}: the chaos indicators measure growth forwards in time; give t_span = (t0, t1) \
             with t1 > t0",
            forward.join(", ")
        )));
    }
    if let Some(h) = renormalise_every {
        if !(h > 0.0 && h.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "renormalise_every={h}: the time between two re-orthonormalisations of the \
                 Lyapunov spectrum must be a positive finite number"
            )));
        }
    }
    Ok(())
}

/// A failed extended run as Python's exception, naming the keyword that asked for it: a
/// `ValueError` for settings, `lasalle.LasalleError` for a run that could not be built or did
/// not end.
fn chaos_error(keyword: &str, e: RunError) -> PyErr {
    let message = format!("{keyword}: {}", keyword_message(&e.to_string()));
    match e {
        RunError::Model(_) | RunError::Load(_) | RunError::Interrupted => {
            LasalleError::new_err(message)
        }
        _ => PyValueError::new_err(message),
    }
}

/// A recording's failure as the error of the run `keyword` asked for.
fn failed(keyword: &'static str, rec: &Recording) -> Result<(), (&'static str, RunError)> {
    match &rec.failure {
        None => Ok(()),
        Some(e) => Err((
            keyword,
            RunError::Model(format!("the extended run stopped: {e}")),
        )),
    }
}

/// What the extended runs of a `solve` call found, with the seconds and steps of each.
#[derive(Default)]
struct Found {
    transition: Option<Transition>,
    spectrum: Option<Spectrum>,
    indicators: Option<Indicators>,
    runs: Vec<(&'static str, f64, u64)>,
}

/// The extended runs `asked` for, one after the other, from `x0` as `spec` says (the command
/// line's `extend_summary`), on `model` with its current parameters.
fn extended_runs(
    model: &lasalle_exec::LoadedModel,
    x0: &[f64],
    spec: &RunSpec,
    asked: Asked,
) -> Result<Found, (&'static str, RunError)> {
    let mut found = Found::default();
    if asked.variational {
        let start = Instant::now();
        let k = "variational=True";
        let tr = chaos::state_transition(model, x0, spec).map_err(|e| (k, e))?;
        failed(k, &tr.recording)?;
        let seconds = start.elapsed().as_secs_f64();
        found
            .runs
            .push(("variational", seconds, tr.recording.steps));
        found.transition = Some(tr);
    }
    if let Some(interval) = asked.lyapunov_spectrum {
        let start = Instant::now();
        let k = "lyapunov_spectrum=True";
        let sp = chaos::lyapunov_spectrum(model, x0, spec, interval).map_err(|e| (k, e))?;
        found
            .runs
            .push(("lyapunov_spectrum", start.elapsed().as_secs_f64(), sp.steps));
        found.spectrum = Some(sp);
    }
    if asked.megno || asked.fli {
        let start = Instant::now();
        let k = match (asked.megno, asked.fli) {
            (true, true) => "megno=True, fli=True",
            (true, false) => "megno=True",
            _ => "fli=True",
        };
        let (rec, ind) = chaos::indicators(model, x0, spec).map_err(|e| (k, e))?;
        failed(k, &rec)?;
        found
            .runs
            .push(("indicators", start.elapsed().as_secs_f64(), rec.steps));
        found.indicators = Some(ind);
    }
    Ok(found)
}

/// What [`Found`] holds as the entries of the Python `Solution` (those not asked for None).
fn found_dict<'py>(py: Python<'py>, found: Found, asked: Asked) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    match found.transition {
        Some(tr) => {
            let n = tr.x.len();
            let phi: Vec<f64> = tr.phi.into_iter().flatten().collect();
            d.set_item("stm", phi.into_pyarray(py).reshape([n, n])?)?;
        }
        None => d.set_item("stm", py.None())?,
    }
    match found.spectrum {
        Some(sp) => {
            d.set_item("lyapunov_spectrum", sp.exponents.into_pyarray(py))?;
            d.set_item("lyapunov_spectrum_qr_order", sp.qr_order.into_pyarray(py))?;
            d.set_item("renormalisations", sp.renormalisations)?;
        }
        None => {
            for key in [
                "lyapunov_spectrum",
                "lyapunov_spectrum_qr_order",
                "renormalisations",
            ] {
                d.set_item(key, py.None())?;
            }
        }
    }
    let ind = found.indicators;
    let value = |wanted: bool, f: fn(&Indicators) -> f64| ind.as_ref().filter(|_| wanted).map(f);
    d.set_item("megno", value(asked.megno, |i| i.megno_mean))?;
    d.set_item("megno_y", value(asked.megno, |i| i.megno))?;
    d.set_item("fli", value(asked.fli, |i| i.fli))?;
    d.set_item("mle", value(true, |i| i.mle))?;
    let runs = PyDict::new(py);
    for (name, seconds, steps) in found.runs {
        let r = PyDict::new(py);
        r.set_item("seconds", seconds)?;
        r.set_item("steps", steps)?;
        runs.set_item(name, r)?;
    }
    d.set_item("extended_runs", runs)?;
    Ok(d)
}

/// Refuses, before the plain run, what the extended runs of `solve` cannot do (see
/// [`refuse`]).
#[pyfunction]
#[pyo3(signature = (method, t0, t1, variational, lyapunov_spectrum, renormalise_every, megno, fli))]
#[allow(clippy::too_many_arguments)]
fn check_extended(
    method: &str,
    t0: f64,
    t1: f64,
    variational: bool,
    lyapunov_spectrum: bool,
    renormalise_every: f64,
    megno: bool,
    fli: bool,
) -> PyResult<()> {
    let asked = Asked {
        variational,
        lyapunov_spectrum: lyapunov_spectrum.then_some(renormalise_every),
        megno,
        fli,
    };
    refuse(
        method,
        &asked.keywords(),
        (t0, t1),
        &asked.forward_keywords(),
        asked.lyapunov_spectrum,
    )
}

/// The extended runs of one `solve` call from `y0` over [t0, t1] (the settings as `solve`
/// takes them; `params` for these runs only), as the dict of the `Solution`'s entries: `stm`,
/// `lyapunov_spectrum`, `lyapunov_spectrum_qr_order`, `renormalisations`, `megno`, `megno_y`,
/// `fli`, `mle` and `extended_runs`. The GIL is released while they run.
#[pyfunction]
#[pyo3(signature = (native, y0, t0, t1, method, dt, rtol, atol, gains, params, max_steps, max_drift, variational, lyapunov_spectrum, renormalise_every, megno, fli, main_thread=false))]
#[allow(clippy::too_many_arguments)]
fn solve_extended<'py>(
    py: Python<'py>,
    mut native: PyRefMut<'py, NativeModel>,
    y0: PyReadonlyArray1<'py, f64>,
    t0: f64,
    t1: f64,
    method: &str,
    dt: Option<f64>,
    rtol: Option<f64>,
    atol: Option<f64>,
    gains: &Bound<'py, PyAny>,
    params: HashMap<String, Vec<f64>>,
    max_steps: Option<u64>,
    max_drift: Option<f64>,
    variational: bool,
    lyapunov_spectrum: bool,
    renormalise_every: f64,
    megno: bool,
    fli: bool,
    main_thread: bool,
) -> PyResult<Bound<'py, PyDict>> {
    check_extended(
        method,
        t0,
        t1,
        variational,
        lyapunov_spectrum,
        renormalise_every,
        megno,
        fli,
    )?;
    let asked = Asked {
        variational,
        lyapunov_spectrum: lyapunov_spectrum.then_some(renormalise_every),
        megno,
        fli,
    };
    // the command line's extended runs record the start and the end only
    let every = Some(u64::MAX);
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
        None,
    )?;
    let mut spec = opts.spec()?;
    let signal = main_thread.then(|| {
        let (interrupt, signal) = signal_poll();
        spec.interrupt = Some(interrupt);
        signal
    });
    let y0: Vec<f64> = y0.as_array().iter().copied().collect();
    let saved = native.all_params();
    for (name, values) in &params {
        if let Err(e) = native.set_param(name, values.clone()) {
            native.restore(&saved);
            return Err(e);
        }
    }
    let result = native.check_state(py, &y0, &spec, t0).map(|()| {
        let model = &native.model;
        py.allow_threads(|| extended_runs(model, &y0, &spec, asked))
    });
    native.restore(&saved);
    if let Some(e) = signal.as_ref().and_then(take) {
        return Err(e);
    }
    let found = result?.map_err(|(k, e)| chaos_error(k, e))?;
    found_dict(py, found, asked)
}

/// The runs of the rows of `y0s` (B, n) on the model extended by the indicators' equations,
/// as `lasalle sweep --indicator` runs them: each row's dict as `solve_many` gives it, with
/// `y` and the events' states those of the extended model (the caller keeps the model's own
/// components), and `megno`, `megno_y`, `mle` and `fli` (None for a failed row; `fli` None
/// unless `fli`, whose runs locate the peaks of ln‖w‖). The GIL is released while they run.
#[pyfunction]
#[pyo3(signature = (native, y0s, t0, t1, method, dt, rtol, atol, gains, params, every, max_steps, max_drift, t_eval, threads, lanes, fli, main_thread=false))]
#[allow(clippy::too_many_arguments)]
fn solve_many_indicators<'py>(
    py: Python<'py>,
    native: PyRef<'py, NativeModel>,
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
    fli: bool,
    main_thread: bool,
) -> PyResult<Bound<'py, PyList>> {
    let keyword = if fli { "fli=True" } else { "megno=True" };
    refuse(method, &[keyword], (t0, t1), &[keyword], None)?;
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
    // the peaks of ln‖w‖ are located for the FLI only, as the sweep's FLI map does
    spec.record_events = fli;
    let interrupt = Interrupt::new();
    spec.interrupt = Some(interrupt.clone());
    let n = native.model.state_dim();
    let members: Vec<_> = native
        .members(&y0s, &params)?
        .into_iter()
        .map(|mut m| {
            if let lasalle_run::Init::State(x) = &m.init {
                m.init = lasalle_run::Init::State(Extension::Indicators.extend_state(x));
            }
            m
        })
        .collect();
    let source = native.source.clone().extended(Extension::Indicators);
    let run = || simulate_many(&source, &members, &spec, threads, lanes);
    let ensemble = if main_thread {
        watched(py, &interrupt, run)?
    } else {
        py.allow_threads(run)
    }
    .map_err(|e| chaos_error(keyword, e))?;
    let out = PyList::empty(py);
    let events = native.event_names();
    for r in &ensemble.recordings {
        match r {
            Ok(rec) => {
                let d = recording_dict(py, rec, t0, &events)?;
                let ind = chaos::read_indicators(rec, n).filter(|_| rec.failure.is_none());
                d.set_item("megno", ind.map(|i| i.megno_mean))?;
                d.set_item("megno_y", ind.map(|i| i.megno))?;
                d.set_item("mle", ind.map(|i| i.mle))?;
                d.set_item("fli", ind.filter(|_| fli).map(|i| i.fli))?;
                out.append(d)?;
            }
            Err(e) => out.append(keyword_message(&e.to_string()))?,
        }
    }
    Ok(out)
}

/// Adds the module's functions to the native module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(check_extended, m)?)?;
    m.add_function(wrap_pyfunction!(solve_extended, m)?)?;
    m.add_function(wrap_pyfunction!(solve_many_indicators, m)?)?;
    Ok(())
}
