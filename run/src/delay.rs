//! Runs of delay equations (`delay(x, r)` in a model file): the method of steps.
//!
//! ẋ(t) = f(x(t), x(t − r₁), …) with constant delays rⱼ > 0 and the constant history
//! x(t) = x(0) for t ≤ 0. With r = min rⱼ, on each interval [kr, (k + 1)r] every delayed
//! time t − rⱼ ≤ kr lies in the past already computed, so the equation there is an ordinary
//! one (Bellman and Cooke's method of steps). Each interval is an ordinary run
//! ([`simulate`](crate::simulate)'s machinery) with DOPRI5, whose field is the model's with
//! the lag slots ([`DelaySpec`]) filled in from the *history*: the continuous extension of
//! every accepted step so far (DOPRI5's quartic interpolant, HNW I §II.6, kept as its values
//! at five points of the step, which determine it). The intervals end at the breakpoints kr,
//! where the solution's derivatives jump, so no step straddles one.
//!
//! Only DOPRI5 runs a delay equation here: the other methods have no continuous extension
//! of their own ([`refusal`]).

use std::cell::RefCell;

use lasalle_runtime::{
    DelaySpec, DenseOutput, DormandPrince, Field, State, StepError, StepOutcome, Stepper,
};

use crate::simulate::{drive, RunModel, Visit};
use crate::{Base, Method, Recording, RunError, RunSpec};

/// The points θ ∈ [0, 1] of a step at which the history keeps the continuous extension: five
/// equidistant ones, which determine DOPRI5's quartic interpolant.
const NODES: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];

/// The most intervals [kr, (k + 1)r] one run may take.
pub const MAX_DELAY_INTERVALS: u64 = 1_000_000;

/// The reason `method` cannot run the delay `d`, if it cannot.
pub fn refusal(method: Method, d: &DelaySpec) -> Option<String> {
    (method != Method::Plain(Base::Dopri5)).then(|| {
        format!(
            "{}: `{}` reads the solution's past through a continuous extension of each step, \
             and method `{method}` has none here: give -m dopri5 (the method of steps with \
             DOPRI5's dense output, docs/delay.md)",
            d.location, d.text
        )
    })
}

/// The delays rⱼ of `model`'s [`DelaySpec`]s: the fields of their lag slots at `x0`, each a
/// positive finite number.
pub fn lags<Mdl, X, FV, K>(model: &Mdl, x0: &X) -> Result<Vec<f64>, RunError>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let mut dx = x0.clone();
    model.field(x0, &mut dx);
    model
        .delays()
        .iter()
        .map(|d| {
            let r = dx[d.slot];
            if r > 0.0 && r.is_finite() {
                Ok(r)
            } else {
                Err(RunError::Model(format!(
                    "{}: the delay of `{}` is {r}, and a delay must be a positive constant: \
                     give its parameter a positive value (--param)",
                    d.location, d.text
                )))
            }
        })
        .collect()
}

/// The solution's past: the continuous extension of each accepted step, at [`NODES`], for the
/// delayed components.
struct History {
    /// The delayed state components.
    components: Vec<usize>,
    /// Their constant history x(0), for t ≤ 0.
    initial: Vec<f64>,
    /// The steps' start times (on the clock), increasing.
    starts: Vec<f64>,
    /// Their sizes.
    sizes: Vec<f64>,
    /// Per step, `NODES.len()` values per delayed component, node-major.
    values: Vec<f64>,
}

impl History {
    fn new(components: Vec<usize>, x0: &[f64]) -> History {
        let initial = components.iter().map(|&c| x0[c]).collect();
        History {
            components,
            initial,
            starts: Vec::new(),
            sizes: Vec::new(),
            values: Vec::new(),
        }
    }

    /// The `k`-th delayed component (index into `components`) at time `s`.
    fn at(&self, k: usize, s: f64) -> f64 {
        if s <= 0.0 || self.starts.is_empty() {
            return self.initial[k];
        }
        let i = self.starts.partition_point(|&t0| t0 <= s).max(1) - 1;
        let theta = (s - self.starts[i]) / self.sizes[i];
        let m = self.components.len();
        let base = i * NODES.len() * m;
        NODES
            .iter()
            .enumerate()
            .map(|(a, &ta)| {
                let weight: f64 = NODES
                    .iter()
                    .enumerate()
                    .filter(|&(b, _)| b != a)
                    .map(|(_, &tb)| (theta - tb) / (ta - tb))
                    .product();
                weight * self.values[base + a * m + k]
            })
            .sum()
    }
}

/// The model's field with the lag slots filled in from the history (the field of each slot
/// itself 0).
struct Lagged<'a, Mdl, X> {
    model: &'a Mdl,
    specs: &'static [DelaySpec],
    /// Per spec, its index in the history's components.
    index: Vec<usize>,
    lags: Vec<f64>,
    history: &'a RefCell<History>,
    scratch: RefCell<X>,
}

impl<Mdl, X> Field<f64, X> for Lagged<'_, Mdl, X>
where
    Mdl: Field<f64, X>,
    X: State<f64>,
{
    fn field(&self, x: &X, dx: &mut X) {
        let mut y = self.scratch.borrow_mut();
        y.as_mut().copy_from_slice(x.as_ref());
        let history = self.history.borrow();
        for ((d, &k), &r) in self.specs.iter().zip(&self.index).zip(&self.lags) {
            y[d.slot] = history.at(k, x[d.clock] - r);
        }
        self.model.field(&y, dx);
        for d in self.specs {
            dx[d.slot] = 0.0;
        }
    }
}

/// A stepper that adds each accepted step's continuous extension to the history.
struct Recorded<'a, S> {
    inner: S,
    history: &'a RefCell<History>,
    clock: usize,
    /// The state after the last accepted step.
    last: Option<Vec<f64>>,
}

impl<X, F, S> Stepper<f64, X, F> for Recorded<'_, S>
where
    X: State<f64>,
    F: ?Sized,
    S: Stepper<f64, X, F>,
{
    fn step(
        &mut self,
        field: &F,
        t: f64,
        x: &mut X,
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        let outcome = self.inner.step(field, t, x, h)?;
        let dense = self
            .inner
            .dense_output()
            .expect("DOPRI5 has a continuous extension");
        let (ta, tb) = dense.dense_interval().expect("a step was accepted");
        let mut out = x.clone();
        let mut history = self.history.borrow_mut();
        let mut start = None;
        for theta in NODES {
            dense.interpolate(ta + theta * (tb - ta), &mut out);
            start.get_or_insert(out[self.clock]);
            for k in 0..history.components.len() {
                let c = history.components[k];
                history.values.push(out[c]);
            }
        }
        history.starts.push(start.expect("five nodes"));
        history.sizes.push(tb - ta);
        self.last = Some(x.as_ref().to_vec());
        Ok(outcome)
    }
    fn order(&self) -> u32 {
        self.inner.order()
    }
    fn name(&self) -> String {
        self.inner.name()
    }
    fn is_adaptive(&self) -> bool {
        self.inner.is_adaptive()
    }
    fn initial_step(&mut self, field: &F, t0: f64, x0: &X, t_end: f64) -> Option<f64> {
        self.inner.initial_step(field, t0, x0, t_end)
    }
    fn reset(&mut self) {
        self.inner.reset()
    }
    fn dense_output(&self) -> Option<&dyn DenseOutput<f64, X>> {
        self.inner.dense_output()
    }
    fn counters(&self) -> Vec<(&'static str, f64)> {
        self.inner.counters()
    }
}

/// A run of the delay equation `model` from the constant history `x0` (its clock and lag slots
/// are set here), interval by interval (see the module docs).
pub(crate) fn delayed_run<Mdl, X, FV, K>(
    model: &Mdl,
    x0: &X,
    spec: &RunSpec,
    progress: &dyn Fn(f64),
) -> Result<Recording, RunError>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let specs = model.delays();
    if let Some(why) = specs.iter().find_map(|d| refusal(spec.method, d)) {
        return Err(RunError::Spec(why));
    }
    if spec.t_end <= 0.0 || spec.t_end.is_nan() {
        return Err(RunError::Spec(format!(
            "{}: a delay equation integrates forwards from its history: give a positive t_end",
            specs[0].location
        )));
    }
    let lags = lags(model, x0)?;
    let mut x = x0.clone();
    let mut components: Vec<usize> = specs.iter().map(|d| d.component).collect();
    components.sort_unstable();
    components.dedup();
    let index = specs
        .iter()
        .map(|d| {
            components
                .iter()
                .position(|&c| c == d.component)
                .expect("listed")
        })
        .collect();
    let clock = specs[0].clock;
    x[clock] = 0.0;
    for d in specs {
        x[d.slot] = x0[d.component];
    }
    let history = RefCell::new(History::new(components, x.as_ref()));
    let lagged = Lagged {
        model,
        specs,
        index,
        lags: lags.clone(),
        history: &history,
        scratch: RefCell::new(x.clone()),
    };
    let r = lags.iter().copied().fold(f64::INFINITY, f64::min);
    if spec.t_end / r > MAX_DELAY_INTERVALS as f64 {
        return Err(RunError::Spec(format!(
            "{}: a run to t = {} takes more than {MAX_DELAY_INTERVALS} intervals of the \
             smallest delay {r}: shorten the run or lengthen the delay",
            specs[0].location, spec.t_end
        )));
    }
    let mut total: Option<Recording> = None;
    for k in 0..=MAX_DELAY_INTERVALS {
        let t0 = k as f64 * r;
        let mut t1 = (k + 1) as f64 * r;
        if t1 >= spec.t_end * (1.0 - 1e-14) {
            t1 = spec.t_end;
        }
        let seg = interval(spec, t0, t1, total.is_none());
        let shifted = |t: f64| progress(t0 + t);
        let mut stepper = Recorded {
            inner: DormandPrince::<f64, X>::with_tolerances(spec.rtol, spec.atol),
            history: &history,
            clock,
            last: None,
        };
        let mut rec = drive(model, &lagged, &x, &seg, &shifted).visit(&mut stepper);
        rec.t.iter_mut().for_each(|t| *t += t0);
        let hits = rec.events.iter_mut().chain(rec.stopped_by.as_mut());
        hits.for_each(|h| h.t += t0);
        if !spec.t_eval.is_empty() && seg.t_eval.is_empty() {
            // no output time in the interval: an empty grid means every step to the driver
            clear_samples(&mut rec);
        } else if total.is_some() && spec.t_eval.is_empty() {
            drop_first(&mut rec);
        }
        let done = rec.failure.is_some() || rec.stopped_by.is_some() || t1 >= spec.t_end;
        total = Some(crate::switching::merge(total, rec));
        if done {
            break;
        }
        let last = stepper
            .last
            .ok_or_else(|| RunError::Spec(format!("the interval [{t0}, {t1}] took no step")))?;
        x.as_mut().copy_from_slice(&last);
        x[clock] = t1;
    }
    let mut rec = total.expect("at least one interval");
    fill_lags(&mut rec, specs, &lags, &history.borrow());
    Ok(rec)
}

/// The spec of the interval [t0, t1], its times counted from t0.
fn interval(spec: &RunSpec, t0: f64, t1: f64, first: bool) -> RunSpec {
    let mut seg = spec.clone();
    seg.t_end = t1 - t0;
    if !spec.t_eval.is_empty() {
        seg.t_eval = spec
            .t_eval
            .iter()
            .filter(|&&t| (if first { t >= t0 } else { t > t0 }) && t <= t1)
            .map(|&t| (t - t0).clamp(0.0, seg.t_end))
            .collect();
    }
    seg
}

/// Drops an interval's first sample, the previous interval's last.
fn drop_first(rec: &mut Recording) {
    if rec.t.is_empty() {
        return;
    }
    rec.t.remove(0);
    let n = rec.state_names.len();
    rec.x.drain(..n);
    let b = rec.blocks.len();
    rec.errors.drain(..b.min(rec.errors.len()));
}

/// Drops all of an interval's samples.
fn clear_samples(rec: &mut Recording) {
    rec.t.clear();
    rec.x.clear();
    rec.errors.clear();
}

/// The recorded lag slots set to the delayed values x(t − r) they stood for.
fn fill_lags(rec: &mut Recording, specs: &[DelaySpec], lags: &[f64], history: &History) {
    let n = rec.state_names.len();
    for (i, &t) in rec.t.iter().enumerate() {
        for (d, &r) in specs.iter().zip(lags) {
            let k = history
                .components
                .iter()
                .position(|&c| c == d.component)
                .expect("listed");
            rec.x[i * n + d.slot] = history.at(k, t - r);
        }
    }
}

/// How a delay run's solution ends: ‖x‖ over the model's own components (the clock and the lag
/// slots left out) at the start and the end, and its exponential rate over the run's second
/// half, (ln‖x(T)‖ − ln‖x(T/2)‖)/(T − T/2) with T/2 the first sample from half way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Growth {
    /// ‖x(0)‖.
    pub initial: f64,
    /// ‖x(T)‖.
    pub last: f64,
    /// The rate.
    pub rate: f64,
}

impl Growth {
    /// `grows`, `decays` or `stays` (a rate within 1e-9 of 0).
    pub fn verdict(&self) -> &'static str {
        if self.rate > 1e-9 {
            "grows"
        } else if self.rate < -1e-9 {
            "decays"
        } else {
            "stays"
        }
    }
}

/// The [`Growth`] of a delay run's recording (`None` without two samples).
pub fn growth(rec: &Recording, specs: &[DelaySpec]) -> Option<Growth> {
    let clock = specs.first()?.clock;
    let n = rec.state_names.len();
    let norm = |i: usize| {
        rec.x[i * n..i * n + clock]
            .iter()
            .map(|v| v * v)
            .sum::<f64>()
            .sqrt()
    };
    let last = rec.t.len().checked_sub(1).filter(|&l| l > 0)?;
    let (t_end, t_start) = (rec.t[last], rec.t[0]);
    let half = rec
        .t
        .partition_point(|&t| t < (t_start + t_end) / 2.0)
        .min(last - 1);
    let rate = (norm(last).ln() - norm(half).ln()) / (t_end - rec.t[half]);
    Some(Growth {
        initial: norm(0),
        last: norm(last),
        rate,
    })
}
