//! Variational runs and chaos indicators: the state-transition matrix Φ(t) of a run, the
//! Lyapunov spectrum (Benettin, Galgani, Giorgilli & Strelcyn 1980), and the maximal
//! Lyapunov exponent, the FLI and MEGNO of one run.
//!
//! Every function here runs a model extended by the front end
//! ([`lasalle_model::variational::Extension`]): the variational field (X, DX·Φ), or the unit
//! tangent vector with the integrals of its growth rate, derived symbolically and compiled by
//! the model's back end like any other field. [`extend`] builds that model from a loaded one
//! (same back end, same parameters; in loop form for a model loaded with its families kept
//! as loops, [`lasalle_model::loops::variational`]); [`simulate`](crate::simulate) then runs it as any model.
//!
//! The methods that apply are those that integrate the extended field itself: `euler`, `heun`,
//! `rk4`, `dopri5` and `taylor`. The feedback, projection, symplectic and splitting methods
//! change x by something other than X (or need a partitioned field) and would leave Φ out of
//! step with x: they are refused.

use lasalle_exec::LoadedModel;
pub use lasalle_model::variational::{Extension, Indicators, PEAK_EVENT};
use lasalle_runtime::{ModelInfo, Parameters};

use crate::{simulate_with_progress, KernelPool, Method, Recording, Reusing, RunError, RunSpec};

/// A model extended by `extension`, compiled by `model`'s back end, with `model`'s current
/// parameter values. A model loaded with its families kept as loops is extended in loop form
/// ([`LoadedModel::extended`], without unrolling it) unless the loop form refuses it (a model
/// with events of its own), which is extended as an unrolled model is.
pub fn extend(model: &LoadedModel, extension: Extension) -> Result<LoadedModel, RunError> {
    let mut out = match model.extended(extension) {
        Some(Ok(out)) => out,
        _ => {
            let unrolled = model.model().map_err(|e| RunError::Load(e.to_string()))?;
            let lowered = extension
                .apply(unrolled)
                .map_err(|e| RunError::Model(e.to_string()))?;
            LoadedModel::from_model(lowered, model.backend())
                .map_err(|e| RunError::Load(e.to_string()))?
        }
    };
    for slot in model.param_slots() {
        if let Some(values) = model.param(slot.name) {
            out.set_param(slot.name, &values)
                .map_err(|e| RunError::Model(e.to_string()))?;
        }
    }
    Ok(out)
}

/// Refuses the methods that do not integrate the extended field as it is (see the
/// [module docs](self)).
pub fn check_method(method: Method) -> Result<(), RunError> {
    match method {
        Method::Plain(_) | Method::Taylor { feedback: false } => Ok(()),
        m => Err(RunError::Spec(format!(
            "`{m}` does not integrate the variational equations (it changes the state by \
             something other than the field): use euler, heun, rk4, dopri5 or taylor"
        ))),
    }
}

/// Refuses a backward run (a negative end time) for `what`, whose clock runs forwards.
fn forward_only(spec: &RunSpec, what: &str) -> Result<(), RunError> {
    if spec.t_end < 0.0 {
        return Err(RunError::Spec(format!(
            "{what} measure growth forwards in time: give a positive end time, not {}",
            spec.t_end
        )));
    }
    Ok(())
}

/// A run with the state-transition matrix: its recording (of the extended state) and
/// Φ(t_end).
#[derive(Clone, Debug)]
pub struct Transition {
    /// The run of the extended model (x, Φ): every sample holds x and Φ, column by column.
    pub recording: Recording,
    /// The final state x(t).
    pub x: Vec<f64>,
    /// Φ(t) = ∂x(t)/∂x(0), by rows: `phi[i][j]` = ∂xᵢ(t)/∂xⱼ(0).
    pub phi: Vec<Vec<f64>>,
}

/// Integrates `model` (its current parameters) from `x0` as `spec` says, with the
/// variational equations Φ̇ = DX·Φ, Φ(0) = I.
pub fn state_transition(
    model: &LoadedModel,
    x0: &[f64],
    spec: &RunSpec,
) -> Result<Transition, RunError> {
    state_transition_with_progress(model, x0, spec, &|_| {})
}

/// [`state_transition`], calling `progress` with the time reached (as
/// [`simulate_with_progress`] does).
pub fn state_transition_with_progress(
    model: &LoadedModel,
    x0: &[f64],
    spec: &RunSpec,
    progress: &dyn Fn(f64),
) -> Result<Transition, RunError> {
    check_method(spec.method)?;
    let n = model.dim();
    let ext = Extension::Variational { tangents: n };
    let extended = extend(model, ext)?;
    let recording = simulate_with_progress(&extended, &ext.extend_state(x0), spec, progress)?;
    let last = recording.last_state();
    let x = last[..n].to_vec();
    let phi = (0..n)
        .map(|i| (0..n).map(|j| last[n * (1 + j) + i]).collect())
        .collect();
    Ok(Transition { recording, x, phi })
}

/// Integrates `model` from `x0` as `spec` says with a unit tangent vector (starting along
/// (1, …, 1)/√N) and returns the run (of the extended state) with the maximal Lyapunov
/// exponent and MEGNO at its end, and the FLI, the supremum of ln‖w‖ over the run (the run
/// records its events whatever [`RunSpec::record_events`] says: the peaks are among them).
pub fn indicators(
    model: &LoadedModel,
    x0: &[f64],
    spec: &RunSpec,
) -> Result<(Recording, Indicators), RunError> {
    indicators_with_progress(model, x0, spec, &|_| {})
}

/// [`indicators`], calling `progress` with the time reached (as [`simulate_with_progress`]
/// does).
pub fn indicators_with_progress(
    model: &LoadedModel,
    x0: &[f64],
    spec: &RunSpec,
    progress: &dyn Fn(f64),
) -> Result<(Recording, Indicators), RunError> {
    check_method(spec.method)?;
    forward_only(spec, "the chaos indicators")?;
    let extended = extend(model, Extension::Indicators)?;
    let spec = RunSpec {
        record_events: true,
        ..spec.clone()
    };
    let x0 = Extension::Indicators.extend_state(x0);
    let recording = simulate_with_progress(&extended, &x0, &spec, progress)?;
    let found = read_indicators(&recording, model.dim())
        .ok_or_else(|| RunError::Model("the run recorded no final state".into()))?;
    Ok((recording, found))
}

/// The indicators of a run of an [`Extension::Indicators`] model (of a model of dimension
/// `n`): MEGNO and the maximal exponent at its end, the FLI the largest of 0, ℓ at the end and
/// ℓ at the crossings of [`PEAK_EVENT`] the run recorded (all of them if it recorded its
/// events: then the supremum over the run). `None` if the final state is not an extended one.
pub fn read_indicators(rec: &Recording, n: usize) -> Option<Indicators> {
    let found = Extension::Indicators.indicators(n, rec.last_state())?;
    // the transform's event: the longest name that is PEAK_EVENT with `_`s appended (it takes
    // the first such name the model leaves free)
    let peak = rec
        .events
        .iter()
        .map(|e| e.name.as_str())
        .filter(|name| name.trim_end_matches('_') == PEAK_EVENT)
        .max_by_key(|name| name.len());
    let slot = lasalle_model::variational::IndicatorSlots { n }.log_growth();
    Some(
        found.with_peaks(
            rec.events
                .iter()
                .filter(|e| Some(e.name.as_str()) == peak)
                .filter_map(|e| e.x.get(slot).copied()),
        ),
    )
}

/// The Lyapunov spectrum of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrum {
    /// The exponents in decreasing order.
    pub exponents: Vec<f64>,
    /// The same exponents in the order of the Gram–Schmidt columns they were accumulated in:
    /// the k-th is the growth rate of the k-volume spanned by the first k tangent vectors
    /// over that of the first k − 1. Benettin et al. show this order tends to the decreasing
    /// one as t → ∞ (their §3), so where it still differs from [`Spectrum::exponents`] the
    /// averages have not converged: pairs ±λ of a Hamiltonian flow, for one, come out of
    /// order over a run too short to separate them from the zero exponents.
    pub qr_order: Vec<f64>,
    /// The time they were averaged over.
    pub t: f64,
    /// The number of QR re-orthonormalisations.
    pub renormalisations: u64,
    /// The steps taken, over all intervals.
    pub steps: u64,
}

/// The Lyapunov spectrum by Benettin et al.'s method: the variational equations of N tangent
/// vectors integrated over intervals of length `interval`, after each of which the vectors
/// are re-orthonormalised (QR by modified Gram–Schmidt) and ln |Rᵢᵢ| accumulated; the
/// exponents are the sums divided by the time. The last interval ends at `spec.t_end`.
pub fn lyapunov_spectrum(
    model: &LoadedModel,
    x0: &[f64],
    spec: &RunSpec,
    interval: f64,
) -> Result<Spectrum, RunError> {
    lyapunov_spectrum_with_progress(model, x0, spec, interval, &|_| {})
}

/// [`lyapunov_spectrum`], calling `progress` with the time reached: after every interval and,
/// within a long one, as [`simulate_with_progress`] does.
pub fn lyapunov_spectrum_with_progress(
    model: &LoadedModel,
    x0: &[f64],
    spec: &RunSpec,
    interval: f64,
    progress: &dyn Fn(f64),
) -> Result<Spectrum, RunError> {
    check_method(spec.method)?;
    forward_only(spec, "the Lyapunov spectrum")?;
    if !(interval > 0.0 && interval.is_finite()) {
        return Err(RunError::Spec(format!(
            "the re-orthonormalisation interval must be a positive number, not {interval}"
        )));
    }
    let n = model.dim();
    let ext = Extension::Variational { tangents: n };
    let extended = extend(model, ext)?;
    let mut state = ext.extend_state(x0);
    let mut sums = vec![0.0; n];
    let (mut t, mut renormalisations, mut steps) = (0.0, 0u64, 0u64);
    // the step budget is the whole run's: accepted and rejected steps of every interval
    let mut spent = 0u64;
    let mut chunk = spec.clone();
    chunk.every = u64::MAX;
    // the Taylor kernels are built once, not once per interval
    let pool = KernelPool::new();
    let reusing = Reusing::new(&extended, &pool);
    while t < spec.t_end {
        let h = interval.min(spec.t_end - t);
        chunk.t_end = h;
        chunk.max_steps = spec.max_steps.saturating_sub(spent);
        if chunk.max_steps == 0 {
            return Err(RunError::Model(format!(
                "the variational run spent its step budget of {} steps at t = {t} (raise it \
                 with --max-steps)",
                spec.max_steps
            )));
        }
        let at_t = |s| progress(t + s);
        let rec = if spec.method.is_taylor() {
            simulate_with_progress(&reusing, &state, &chunk, &at_t)?
        } else {
            simulate_with_progress(&extended, &state, &chunk, &at_t)?
        };
        if let Some(e) = &rec.failure {
            return Err(RunError::Model(format!(
                "the variational run stopped at t = {}: {e}",
                t + rec.t_final()
            )));
        }
        steps += rec.steps;
        spent = spent.saturating_add(rec.steps + rec.rejections);
        state = rec.last_state().to_vec();
        let mut columns: Vec<Vec<f64>> = (0..n)
            .map(|j| state[n * (1 + j)..n * (2 + j)].to_vec())
            .collect();
        for (j, r) in gram_schmidt(&mut columns).into_iter().enumerate() {
            if !(r > 0.0 && r.is_finite()) {
                return Err(RunError::Model(format!(
                    "tangent vector {j} degenerated (|R_jj| = {r}) at t = {}: shorten the \
                     re-orthonormalisation interval",
                    t + h
                )));
            }
            sums[j] += r.ln();
        }
        for (j, c) in columns.iter().enumerate() {
            state[n * (1 + j)..n * (2 + j)].copy_from_slice(c);
        }
        t += h;
        renormalisations += 1;
        progress(t);
    }
    let qr_order: Vec<f64> = sums.iter().map(|s| s / t).collect();
    let mut exponents = qr_order.clone();
    exponents.sort_by(|a, b| b.total_cmp(a));
    Ok(Spectrum {
        exponents,
        qr_order,
        t,
        renormalisations,
        steps,
    })
}

/// Orthonormalises `columns` in place (modified Gram–Schmidt) and returns the diagonal of R.
fn gram_schmidt(columns: &mut [Vec<f64>]) -> Vec<f64> {
    let mut diag = Vec::with_capacity(columns.len());
    for j in 0..columns.len() {
        let (done, rest) = columns.split_at_mut(j);
        let v = &mut rest[0];
        for q in done.iter() {
            let r: f64 = q.iter().zip(v.iter()).map(|(a, b)| a * b).sum();
            for (vi, qi) in v.iter_mut().zip(q) {
                *vi -= r * qi;
            }
        }
        let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
        diag.push(norm);
        if norm > 0.0 {
            for vi in v.iter_mut() {
                *vi /= norm;
            }
        }
    }
    diag
}

#[cfg(test)]
mod tests {
    use super::gram_schmidt;

    #[test]
    fn gram_schmidt_gives_r_diagonal_and_orthonormal_q() {
        // A = [[3, 1], [4, 2]] by columns (3,4), (1,2): R₁₁ = 5, R₂₂ = |det A| / 5 = 2/5
        let mut c = vec![vec![3.0, 4.0], vec![1.0, 2.0]];
        let r = gram_schmidt(&mut c);
        assert!((r[0] - 5.0).abs() < 1e-15 && (r[1] - 0.4).abs() < 1e-15);
        let dot: f64 = c[0].iter().zip(&c[1]).map(|(a, b)| a * b).sum();
        assert!(dot.abs() < 1e-15);
    }
}
