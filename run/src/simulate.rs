//! [`simulate`]: one run of a model from an initial state as a [`RunSpec`] says.
//!
//! Any model that implements the runtime's traits and [`Declared`] runs — a model loaded
//! from a file at run time ([`lasalle_exec::LoadedModel`]) or one compiled ahead of time.
//! The stepper for the method is built by composing visitors (`projection-` wraps the base
//! stepper in a [`Projection`], `feedback-` integrates the [`FeedbackField`], the adaptive and
//! step-tracking gains wrap the stepper in an [`AdaptiveGain`]), so the inner loop is static
//! code for each (storage, method) pair. Methods that need structure the model does not
//! declare fail with a message ("method `stormer-verlet-a` needs a partitioned model"); the
//! model's guards stop a run that leaves its domain.

use std::fmt;
use std::marker::PhantomData;
use std::time::Instant;

use lasalle_runtime::{
    component_names, real_stability_interval, sample_capacity, scaled_gains, step_gain_target,
    AdaptiveGain, BoundMode, CompiledStep, Composition, Control, Crossing, Declared, DormandPrince,
    DriftBound, Driver, ExplicitRk, FeedbackField, Field, FixedMethod, GainBound, GainError,
    GainPolicy, Invariants, Lyapunov, ModelInfo, Observer, Projection, Recorder, State, StepError,
    Stepper, StormerVerlet, Stride, Tableau, Taylor, TaylorOptions, VerletVariant, Watch,
    FEEDBACK_STEP_INTERVAL,
};

use crate::backward::{self, Backward, BackwardTaylor};
use crate::{
    process_cpu_seconds, Base, EventHit, Method, Recording, RunError, RunSpec, Stability,
    AUTO_SAMPLES,
};

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

/// Integrates `model` from `x0` as `spec` says.
///
/// An integration that blows up, drifts past `spec.max_drift` or leaves the model's domain
/// (a failed guard) still returns the samples up to the failure, with
/// [`Recording::failure`] set; invalid arguments (bad numbers, a method the model cannot use,
/// gains of the wrong count, an initial state outside the domain) are errors.
pub fn simulate<Mdl, X, FV, K>(model: &Mdl, x0: &X, spec: &RunSpec) -> Result<Recording, RunError>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    simulate_with_progress(model, x0, spec, &|_| {})
}

/// [`simulate`], calling `progress` with the time reached about every 2¹⁶ steps (for a
/// progress bar over [0, `spec.t_end`]; the distance |t| for a backward run).
///
/// A negative `spec.t_end` integrates backwards, to t = `spec.t_end`: every method that has a
/// time-reversed form runs the model's reversed field forwards (`backward`'s docs), and the
/// recording's times are the model's, from 0 down to `spec.t_end`.
pub fn simulate_with_progress<Mdl, X, FV, K>(
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
    if !model.delays().is_empty() {
        return crate::delay::delayed_run(model, x0, spec, progress);
    }
    if !model.switches().is_empty() {
        if spec.t_end < 0.0 {
            return Err(RunError::Spec(
                "a discontinuous field (`sign`) integrates forwards only: its switching \
                 surfaces are located as events of the forward flow (give a positive t_end)"
                    .into(),
            ));
        }
        let plain = |x: &X, s: &RunSpec, p: &dyn Fn(f64)| simulate_forward(model, x, s, p);
        return crate::switching::switched_run(model, x0, spec, progress, &plain);
    }
    if spec.t_end >= 0.0 {
        return simulate_forward(model, x0, spec, progress);
    }
    if let Some(why) = backward::refusal(spec.method) {
        return Err(RunError::Spec(why));
    }
    check_start(model, x0, spec)?;
    let reversed = Backward::new(model, x0);
    let forward = spec.reversed();
    let recording = match spec.method {
        Method::Taylor { feedback: false } => {
            let stepper = BackwardTaylor::new(taylor(model, &forward)?);
            drive(&reversed, &reversed, x0, &forward, progress).visit(stepper)
        }
        _ => simulate_forward(&reversed, x0, &forward, progress)?,
    };
    Ok(backward::reverse(recording))
}

/// [`simulate_with_progress`] forwards in time, with the modes of a discontinuous field held
/// fixed.
fn simulate_forward<Mdl, X, FV, K>(
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
    let f = check_start(model, x0, spec)?;
    let name = model.model_name();
    // the innermost visitor on the model's own field
    let on_x = || drive(model, model, x0, spec, progress);
    match spec.method {
        Method::Plain(b) => match compiled_step(model, b, None, spec) {
            Some(step) => Ok(on_x().visit(step)),
            None => Ok(with_base(b, spec, on_x())),
        },
        Method::Projection(b) => {
            let visit = Project {
                inner: on_x(),
                target: f,
                tol: spec.tol,
            };
            Ok(with_base(b, spec, visit))
        }
        Method::Feedback(b) => feedback_run(model, x0, spec, progress, FeedbackStepper::Base(b)),
        Method::StormerVerlet(_) | Method::Symplectic { .. } => {
            let halves = model.partitioned().ok_or_else(|| {
                RunError::Model(format!(
                    "method `{}` needs a partitioned model (q̇ = a(p), ṗ = b(q)); the field of `{name}` is not partitioned",
                    spec.method
                ))
            })?;
            let drive = drive(model, halves, x0, spec, progress);
            Ok(match spec.method {
                Method::StormerVerlet(VerletVariant::A) => drive.visit(StormerVerlet::a()),
                Method::StormerVerlet(VerletVariant::B) => drive.visit(StormerVerlet::b()),
                Method::Symplectic { order: 4 } => drive.visit(Composition::order4()),
                Method::Symplectic { order: 6 } => drive.visit(Composition::order6()),
                _ => drive.visit(Composition::order8()),
            })
        }
        Method::Splitting => {
            let splitting = model.splitting().ok_or_else(|| {
                RunError::Model(format!(
                    "method `splitting` runs the structure-specific splitting a model declares, and `{name}` declares none (e.g. `splitting rigid_body(R, Omega, I);` for the free rigid body)"
                ))
            })?;
            Ok(on_x().visit(splitting))
        }
        Method::Taylor { feedback } => {
            let taylor = taylor(model, spec)?;
            if feedback {
                feedback_run(model, x0, spec, progress, FeedbackStepper::Taylor(taylor))
            } else {
                Ok(on_x().visit(taylor))
            }
        }
        Method::SplitTaylor => {
            let taylor = taylor(model, spec)?.with_split(true);
            feedback_run(model, x0, spec, progress, FeedbackStepper::Taylor(taylor))
        }
    }
}

/// Something that does a run with any stepper for the field `F` (the continuation that
/// [`simulate`] hands the stepper it built).
pub(crate) trait Visit<F: ?Sized, X: State<f64>> {
    /// The result.
    type Out;
    /// Runs with `stepper`.
    fn visit<S: Stepper<f64, X, F>>(self, stepper: S) -> Self::Out;
}

/// Checks the spec and the initial state (finite, inside the model's guards, where the field
/// and the invariants are defined); returns f(x₀).
pub(crate) fn check_start<Mdl, X, FV, K>(
    model: &Mdl,
    x0: &X,
    spec: &RunSpec,
) -> Result<FV, RunError>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    spec.validate()?;
    let name = model.model_name();
    if spec.method.is_feedback() && model.invariant_dim() == 0 {
        return Err(RunError::Model(format!(
            "method `{}` feeds back the deviation of the model's integrals, and `{name}` declares \
             none: use a method without feedback, or declare `integral NAME = …;` in the model",
            spec.method
        )));
    }
    let shown = x0.as_ref();
    if shown.len() != model.state_dim() {
        return Err(RunError::Model(format!(
            "the initial state has {} components but the state of `{name}` has dimension {}",
            shown.len(),
            model.state_dim()
        )));
    }
    if let Some(i) = shown.iter().position(|v| !v.is_finite()) {
        return Err(RunError::Model(format!(
            "initial state component {i} is not finite"
        )));
    }
    // The field and the invariants must be defined at x0 (e.g. Kepler at x = 0 is not).
    let mut dx = x0.clone();
    let mut f = FV::filled(FV::len_for(model.invariant_dim()), 0.0);
    model.field(x0, &mut dx);
    model.invariants(x0, &mut f);
    if let Some(failure) = model.check_guards(x0, 0.0) {
        return Err(RunError::Model(format!(
            "invalid initial state {shown:?}: {failure}"
        )));
    }
    if dx.as_ref().iter().chain(f.as_ref()).any(|v| !v.is_finite()) {
        return Err(RunError::Model(format!(
            "the field or the invariants of `{name}` are not finite at the initial state {shown:?}"
        )));
    }
    Ok(f)
}

/// Moves the progress on, about every 2¹⁶ steps, on the way to `inner`.
struct Progress<'o, O> {
    inner: &'o mut O,
    progress: &'o dyn Fn(f64),
    every: u64,
}

impl<O: Observer<f64, X>, X: ?Sized> Observer<f64, X> for Progress<'_, O> {
    #[inline]
    fn observe(&mut self, step: u64, t: f64, x: &X) -> Control {
        // only every `every`-th step gets here (a Stride): one of them per 2¹⁶ steps
        if step & 0xffff < self.every {
            (self.progress)(t);
        }
        self.inner.observe(step, t, x)
    }

    fn finish(&mut self, step: u64, t: f64, x: &X) {
        self.inner.finish(step, t, x)
    }

    fn next_wanted(&self, step: u64) -> u64 {
        self.inner.next_wanted(step)
    }
}

/// The recorder, and the drift check on what it records: a sample's invariant errors are
/// the drifts [`DriftBound`] bounds, so each sample evaluates the invariants once. A sample
/// past the bound ends the run with [`StepError::Diverged`], as the driver's check would,
/// and is not recorded.
struct Checked<'o, R, D> {
    rec: &'o mut R,
    drift: Option<&'o D>,
    diverged: Option<StepError>,
}

impl<Mdl, X, FV> Checked<'_, Recorder<'_, Mdl, f64, X, FV>, DriftBound<'_, Mdl, f64, FV>>
where
    Mdl: Invariants<f64, X, FV> + ModelInfo + ?Sized,
    X: State<f64>,
    FV: State<f64>,
{
    /// Checks the sample the recorder took at `step`, if it took one.
    fn check(&mut self, samples_before: usize, step: u64, t: f64, x: &X) -> Control {
        let (Some(drift), true) = (self.drift, self.rec.len() > samples_before && step > 0) else {
            return Control::Continue;
        };
        match drift.check_errors(self.rec.errors_at(samples_before)) {
            None => Control::Continue,
            Some(message) => {
                self.rec.pop();
                self.diverged = Some(StepError::Diverged {
                    t,
                    step,
                    message,
                    state: x.as_ref().to_vec(),
                });
                Control::Stop
            }
        }
    }
}

impl<Mdl, X, FV> Observer<f64, X>
    for Checked<'_, Recorder<'_, Mdl, f64, X, FV>, DriftBound<'_, Mdl, f64, FV>>
where
    Mdl: Invariants<f64, X, FV> + ModelInfo + ?Sized,
    X: State<f64>,
    FV: State<f64>,
{
    fn observe(&mut self, step: u64, t: f64, x: &X) -> Control {
        let before = self.rec.len();
        self.rec.observe(step, t, x);
        self.check(before, step, t, x)
    }

    fn finish(&mut self, step: u64, t: f64, x: &X) {
        if self.diverged.is_none() {
            let before = self.rec.len();
            self.rec.finish(step, t, x);
            self.check(before, step, t, x);
        }
    }

    fn next_wanted(&self, step: u64) -> u64 {
        self.rec.next_wanted(step)
    }
}

/// The innermost visitor: integrates `field` with the stepper and records the model's
/// invariants.
pub(crate) struct Drive<'a, Mdl, F: ?Sized, X, FV> {
    model: &'a Mdl,
    field: &'a F,
    x0: X,
    spec: &'a RunSpec,
    progress: &'a dyn Fn(f64),
    invariants: PhantomData<FV>,
}

impl<Mdl, F, X, FV> Visit<F, X> for Drive<'_, Mdl, F, X, FV>
where
    Mdl: Invariants<f64, X, FV> + ModelInfo + Declared<f64, X>,
    X: State<f64>,
    FV: State<f64>,
    F: ?Sized,
{
    type Out = Recording;

    fn visit<S: Stepper<f64, X, F>>(self, mut stepper: S) -> Recording {
        let spec = self.spec;
        let every = spec.record_every();
        // the stride forwards every `every`-th step; the recorder keeps all it is given
        let mut rec = Recorder::new(
            self.model,
            &self.x0,
            1,
            sample_capacity(spec.steps(), every),
        );
        let drift = DriftBound::new(self.model, &self.x0, spec.max_drift);
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
        // without `record_events`, only a model with a `stop` event needs the watch
        let events = model.events();
        let watched = !spec.t_eval.is_empty()
            || if spec.record_events {
                !events.is_empty()
            } else {
                events.iter().any(|e| e.terminal)
            };
        // a stepper that checks the guards itself leaves the driver the initial state's check
        let guard_every = if stepper.checks_guards() { u64::MAX } else { 1 };
        driver = driver.guard(guard_every, move |x: &X| {
            model.check_guards(x, h).map(|g| g.to_string())
        });
        // a watched run records output times and crossings, not steps: the driver checks
        // the drift there; otherwise it checks the samples, as the recorder computes them
        if watched {
            let drift = &drift;
            driver = driver.divergence(every, move |x: &X| drift.check(x));
        }
        if let Some(stop) = &spec.interrupt {
            driver = driver.interrupt(move || stop.is_stopped());
        }
        let mut checked = Checked {
            rec: &mut rec,
            drift: (!watched).then_some(&drift),
            diverged: None,
        };
        let progress = Progress {
            inner: &mut checked,
            progress: self.progress,
            every,
        };
        // an adaptive run's step count is unknown: sampled every step at first, ever more
        // sparsely after, so that a long run's samples fit in memory
        let mut obs = if spec.method.is_adaptive() && spec.every == 0 {
            Stride::widening(progress, every, AUTO_SAMPLES)
        } else {
            Stride::new(progress, every)
        };
        let (start, cpu_start) = (Instant::now(), process_cpu_seconds());
        let mut hits = Vec::new();
        let result = if watched {
            watched_run(
                model,
                &driver,
                &mut stepper,
                self.field,
                &self.x0,
                spec,
                &mut obs,
                &mut hits,
            )
        } else {
            driver.run(&mut stepper, self.field, &self.x0, &mut obs)
        };
        let result = match checked.diverged {
            Some(diverged) => Err(diverged),
            None => result,
        };
        let wall_seconds = start.elapsed().as_secs_f64();
        let cpu_seconds = process_cpu_seconds()
            .zip(cpu_start)
            .map(|(end, start)| end - start);
        let counts = match result {
            Ok(s) => Ok((s.steps, s.evaluations, s.rejections)),
            Err(e) => Err(e),
        };
        let stepper = (stepper.name(), stepper.counters());
        let mut recording = recording(
            self.model,
            spec,
            stepper,
            rec,
            (wall_seconds, cpu_seconds),
            counts,
        );
        if watched {
            attach_events(self.model, &mut recording, hits);
        }
        recording
    }
}

/// A run that watches the model's events and samples the output times `spec.t_eval` on
/// each step's continuous extension ([`Watch`]); `hits` receives the crossings, the terminal
/// one (which ends the run, recorded as the last sample) last.
#[allow(clippy::too_many_arguments)]
fn watched_run<Mdl, F, X, FV, S, O>(
    model: &Mdl,
    driver: &Driver<'_, f64, X>,
    stepper: &mut S,
    field: &F,
    x0: &X,
    spec: &RunSpec,
    obs: &mut Stride<Progress<'_, O>>,
    hits: &mut Vec<(Crossing<X>, bool)>,
) -> Result<lasalle_runtime::Summary<f64, X>, StepError>
where
    Mdl: Invariants<f64, X, FV> + ModelInfo + Declared<f64, X>,
    F: ?Sized,
    X: State<f64>,
    FV: State<f64>,
    S: Stepper<f64, X, F>,
    O: Observer<f64, X>,
{
    let grid = !spec.t_eval.is_empty();
    let mut watch = Watch::new(
        model.events().to_vec(),
        Box::new(move |x: &X, t, g: &mut [f64]| model.event_values(x, t, g)),
        Box::new(move |x: &X, dx: &mut X| model.field(x, dx)),
        spec.t_eval.clone(),
        0.0,
        x0,
    );
    // output times go straight to the recorder, numbered in order
    let mut k = 0u64;
    let mut terminal = None;
    let summary = driver.run_stepwise(stepper, field, x0, |s, step, t, x| {
        let mut on_grid = |tg: f64, xg: &X| {
            obs.inner.inner.observe(k, tg, xg);
            k += 1;
        };
        if step == 0 {
            watch.start(&mut on_grid);
        } else {
            terminal = watch.after_step(s.dense_output(), t, x, &mut on_grid);
            hits.extend(watch.take_crossings().into_iter().map(|c| (c, false)));
        }
        if !grid && terminal.is_none() && obs.observe(step, t, x) == Control::Stop {
            return Control::Stop;
        }
        if terminal.is_some() || (grid && watch.grid_done() && model.events().is_empty()) {
            Control::Stop
        } else {
            Control::Continue
        }
    })?;
    let t_last = terminal.as_ref().map_or(summary.t, |c| c.t);
    hits.extend(watch.finish(t_last).into_iter().map(|c| (c, false)));
    hits.sort_by(|a, b| a.0.t.total_cmp(&b.0.t));
    match terminal {
        Some(c) => {
            obs.inner.inner.observe(k, c.t, &c.x);
            hits.push((c, true));
        }
        None if !grid => obs.finish(summary.steps, summary.t, &summary.x),
        None => {}
    }
    Ok(summary)
}

/// The crossings of a watched run into `rec`, with the invariants' values there.
fn attach_events<Mdl, X, FV>(model: &Mdl, rec: &mut Recording, hits: Vec<(Crossing<X>, bool)>)
where
    Mdl: Invariants<f64, X, FV> + ModelInfo + Declared<f64, X>,
    X: State<f64>,
    FV: State<f64>,
{
    let specs = model.events();
    let mut f = FV::filled(FV::len_for(model.invariant_dim()), 0.0);
    rec.invariant_names = component_names(
        &model
            .invariant_infos()
            .iter()
            .map(|i| i.slot)
            .collect::<Vec<_>>(),
    );
    rec.invariant_names
        .resize_with(model.invariant_dim(), String::new);
    for (c, terminal) in hits {
        model.invariants(&c.x, &mut f);
        let hit = EventHit {
            name: specs[c.event].name.to_string(),
            t: c.t,
            x: c.x.as_ref().to_vec(),
            invariants: f.as_ref().to_vec(),
            rising: c.rising,
            touch: c.touch,
        };
        if terminal {
            rec.stopped_by = Some(hit);
        } else {
            rec.events.push(hit);
        }
    }
}

/// The [`Recording`] of a run: what `rec` recorded, with the run's counters (or its failure).
pub(crate) fn recording<Mdl, X, FV>(
    model: &Mdl,
    spec: &RunSpec,
    (stepper, counters): (String, Vec<(&'static str, f64)>),
    rec: Recorder<'_, Mdl, f64, X, FV>,
    (wall_seconds, cpu_seconds): (f64, Option<f64>),
    counts: Result<(u64, u64, u64), StepError>,
) -> Recording
where
    Mdl: Invariants<f64, X, FV> + ModelInfo + ?Sized,
    X: State<f64>,
    FV: State<f64>,
{
    let mut names = component_names(model.state_slots());
    names.resize_with(model.state_dim(), String::new);
    let ((steps, evaluations, rejections), failure) = match counts {
        Ok(c) => (c, None),
        Err(e) => {
            let rejected = match &e {
                StepError::MaxSteps { rejected, .. } => *rejected,
                _ => 0,
            };
            ((e.step().unwrap_or(0), 0, rejected), Some(e))
        }
    };
    Recording {
        method: spec.method.to_string(),
        stepper,
        state_names: names,
        blocks: rec.blocks().iter().map(|(n, _)| n.to_string()).collect(),
        x: rec.x,
        t: rec.t,
        errors: rec.errors,
        wall_seconds,
        cpu_seconds,
        steps,
        evaluations,
        rejections,
        counters,
        gains_initial: None,
        gains_final: None,
        failure,
        every: if spec.t_eval.is_empty() {
            spec.record_every()
        } else {
            0
        },
        invariant_names: Vec::new(),
        events: Vec::new(),
        stopped_by: None,
        stability: None,
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

    fn visit<S: Stepper<f64, X, F>>(self, stepper: S) -> V::Out {
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
        S: Stepper<f64, X, FeedbackField<'a, Mdl, FV, K>>,
    {
        self.inner.visit(
            AdaptiveGain::new(stepper, self.unit, self.every)
                .c(self.c)
                .safety(self.safety),
        )
    }
}

/// The step of a fixed-step base method compiled whole by the model's back end, on the field
/// or on X − ∇V with fixed `feedback` targets and gains, if the back end compiles one
/// ([`Declared::compiled_step`]): bitwise the generic stepper's run.
fn compiled_step<X: State<f64>>(
    model: &impl Declared<f64, X>,
    base: Base,
    feedback: Option<(&[f64], &[f64])>,
    spec: &RunSpec,
) -> Option<CompiledStep> {
    fn compile<const S: usize, X: State<f64>>(
        model: &impl Declared<f64, X>,
        t: Tableau<S>,
        feedback: Option<(&[f64], &[f64])>,
        dt: f64,
    ) -> Option<CompiledStep> {
        let a: Vec<&[f64]> = t.a.iter().map(|row| &row[..]).collect();
        let method = FixedMethod {
            name: t.name,
            order: t.order,
            a: &a,
            b: &t.b,
        };
        model.compiled_step(&method, feedback, dt)
    }
    match base {
        Base::Euler => compile(model, Tableau::euler(), feedback, spec.dt),
        Base::Heun => compile(model, Tableau::heun(), feedback, spec.dt),
        Base::Rk4 => compile(model, Tableau::rk4(), feedback, spec.dt),
        Base::Dopri5 => None,
    }
}

/// Hands `visit` the explicit Runge–Kutta stepper `base`.
pub(crate) fn with_base<F, V, X>(base: Base, spec: &RunSpec, visit: V) -> V::Out
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
pub(crate) fn drive<'a, Mdl, F: ?Sized, X: Clone, FV>(
    model: &'a Mdl,
    field: &'a F,
    x0: &X,
    spec: &'a RunSpec,
    progress: &'a dyn Fn(f64),
) -> Drive<'a, Mdl, F, X, FV> {
    Drive {
        model,
        field,
        x0: x0.clone(),
        spec,
        progress,
        invariants: PhantomData,
    }
}

/// The Taylor integrator of `model` with tolerance `spec.rtol`, over its kernels
/// ([`Declared::taylor_kernels`]).
fn taylor<Mdl, X, FV, K>(model: &Mdl, spec: &RunSpec) -> Result<Taylor<Mdl>, RunError>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let opts = TaylorOptions::with_tol(spec.rtol);
    let bad = |e: &dyn fmt::Display| RunError::Model(format!("method `{}`: {e}", spec.method));
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
    progress: &dyn Fn(f64),
    stepper: FeedbackStepper<Mdl>,
) -> Result<Recording, RunError>
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
    // a fixed-step base method: the bounded gains feed back after each step (h·k·L capped
    // against explicit Euler's interval); other gains are watched against the method's
    let bound = match &stepper {
        FeedbackStepper::Base(b) if *b != Base::Dopri5 => {
            let inner = drive(model, &fb, x0, spec, progress);
            match spec.gains.clone().resolve(false) {
                GainPolicy::Bounded { c } => Some(Bound {
                    inner,
                    mode: BoundMode::Cap {
                        model: plan.initial.clone(),
                        theta: c * FEEDBACK_STEP_INTERVAL,
                    },
                    limit: FEEDBACK_STEP_INTERVAL,
                }),
                _ => real_stability_interval(b.order()).map(|limit| Bound {
                    inner,
                    mode: BoundMode::Watch,
                    limit,
                }),
            }
        }
        _ => None,
    };
    let mut rec = match (bound, stepper) {
        (Some(bound), FeedbackStepper::Base(b)) => {
            feedback_bounded(model, spec, b, &fb, &plan, bound)
        }
        (_, stepper) => {
            let inner = drive(model, &fb, x0, spec, progress);
            feedback_plain(model, spec, stepper, &fb, &plan, inner)
        }
    };
    rec.gains_initial = Some(plan.initial.as_ref().to_vec());
    rec.gains_final = Some(fb.gains().as_ref().to_vec());
    rec.stability = Stability::from_counters(&rec.counters);
    Ok(rec)
}

/// A feedback run without a stability bound (adaptive methods): the adaptive gain's wrapper if
/// the plan has one, else a step compiled whole on X − ∇V where the back end compiles one.
fn feedback_plain<'a, Mdl, X, FV, K, V>(
    model: &'a Mdl,
    spec: &RunSpec,
    stepper: FeedbackStepper<Mdl>,
    fb: &FeedbackField<'a, Mdl, FV, K>,
    plan: &GainPlan<K>,
    inner: V,
) -> Recording
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
    V: Visit<FeedbackField<'a, Mdl, FV, K>, X, Out = Recording>,
    Taylor<Mdl>: Stepper<f64, X, FeedbackField<'a, Mdl, FV, K>>,
{
    match plan.wrap(inner) {
        Gained::Adaptive(adapt) => stepper.visit(spec, adapt),
        Gained::Fixed(inner) => {
            let feedback = Some((fb.target().as_ref(), plan.initial.as_ref()));
            match &stepper {
                FeedbackStepper::Base(b) => match compiled_step(model, *b, feedback, spec) {
                    Some(step) => inner.visit(step),
                    None => stepper.visit(spec, inner),
                },
                FeedbackStepper::Taylor(_) => stepper.visit(spec, inner),
            }
        }
    }
}

/// A fixed-step feedback run inside [`GainBound`]: the feedback step after the generic stepper; fixed
/// gains watched on the step compiled whole where the back end compiles one; the adaptive
/// gain's wrapper watched from outside.
fn feedback_bounded<'a, Mdl, X, FV, K, V>(
    model: &'a Mdl,
    spec: &RunSpec,
    b: Base,
    fb: &FeedbackField<'a, Mdl, FV, K>,
    plan: &GainPlan<K>,
    bound: Bound<V, K>,
) -> Recording
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
    V: Visit<FeedbackField<'a, Mdl, FV, K>, X, Out = Recording>,
{
    if let BoundMode::Cap { .. } = bound.mode {
        // the generic stepper on X alone, the gains of the feedback step chosen after each step
        return with_base(b, spec, bound);
    }
    let (mode, limit) = (bound.mode, bound.limit);
    match plan.wrap(bound.inner) {
        Gained::Adaptive(adapt) => with_base(
            b,
            spec,
            Adapt {
                inner: Bound {
                    inner: adapt.inner,
                    mode,
                    limit,
                },
                unit: adapt.unit,
                every: adapt.every,
                c: adapt.c,
                safety: adapt.safety,
            },
        ),
        Gained::Fixed(inner) => {
            let bound = Bound { inner, mode, limit };
            let feedback = Some((fb.target().as_ref(), plan.initial.as_ref()));
            match compiled_step(model, b, feedback, spec) {
                Some(step) => bound.visit(step),
                None => with_base(b, spec, bound),
            }
        }
    }
}

/// Wraps the stepper in [`GainBound`] (the capped or watched h·k·L of a fixed-step feedback
/// run).
struct Bound<V, K> {
    inner: V,
    mode: BoundMode<K>,
    limit: f64,
}

impl<'a, Mdl, V, X, FV, K> Visit<FeedbackField<'a, Mdl, FV, K>, X> for Bound<V, K>
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
        S: Stepper<f64, X, FeedbackField<'a, Mdl, FV, K>>,
    {
        self.inner
            .visit(GainBound::new(stepper, self.mode, self.limit))
    }
}

/// The gains of a feedback run: the initial ones and, for the adaptive policies, how the
/// [`AdaptiveGain`] wrapper keeps choosing them.
pub(crate) struct GainPlan<K> {
    pub(crate) initial: K,
    /// (re-estimation period, c, safety factor) of the wrapper.
    pub(crate) adapt: Option<(u64, f64, f64)>,
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
/// is adaptive, `step` to the target h·k·L = [`step_gain_target`] with the tolerance `rtol`.
pub(crate) fn plan_gains<Mdl, X, FV, K>(
    model: &Mdl,
    x0: &X,
    spec: &RunSpec,
    order: u32,
) -> Result<GainPlan<K>, RunError>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let located = |e: GainError| {
        RunError::Model(format!(
            "{e} (model `{}` has gains {})",
            model.model_name(),
            model.gain_names().join(", ")
        ))
    };
    match spec.gains.clone().resolve(spec.method.is_adaptive()) {
        GainPolicy::Step { c, every } => {
            let target = step_gain_target(c, spec.rtol, order);
            let unit = K::filled(K::len_for(model.gain_names().len()), 1.0);
            // the first step is `dt`, else DOPRI5's starting step on X; the wrapper rescales
            // to the step actually proposed
            let h = if spec.dt > 0.0 {
                spec.dt
            } else {
                DormandPrince::<f64, X>::with_tolerances(spec.rtol, spec.atol)
                    .initial_step(model, 0.0, x0, spec.t_end)
                    .ok_or_else(|| RunError::Spec("no starting step: give --dt".into()))?
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
