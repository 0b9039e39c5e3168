//! Ensembles: many runs of one model file, across threads ([`simulate_many`]) and, within a
//! thread, several states in lanes ([`simulate_lanes`]) — each run's result bitwise the one
//! it gets alone.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

use lasalle_exec::{Backend, LaneField, LoadedModel};
use lasalle_model::loops::Families;
use lasalle_model::variational::Extension;
use lasalle_runtime::{
    Declared, DriftBound, Driver, LaneRuns, ModelInfo, Observer, Parameters, Recorder, Stepper,
    TaylorLanes, TaylorOptions,
};
use rayon::prelude::*;

use crate::simulate::{check_start, recording, with_base, Visit};
use crate::RunSpec;
use crate::{
    initial_state, process_cpu_seconds, simulate, Base, KernelPool, Method, Recording, Reusing,
    RunError,
};

/// Integrates the states `x0s` of a loaded model together, in lanes
/// ([`lasalle_exec::Lanes`], [`lasalle_exec::FeedbackLanes`]: one kernel call per stage for
/// all of them), as [`simulate`] integrates each alone: each recording equals the lone run's
/// except for the wall and CPU time, the group's divided by the number of lanes.
///
/// `None` where lanes do not apply — fewer than two states, a method other than a fixed-step
/// Runge–Kutta method on X (a feedback run's gains are bounded step by step, state by
/// state), samples between the first and the last state (`spec.every` below the run's step
/// count), output times or events to watch (a model that declares events), an initial state
/// that [`simulate`] refuses, a run that fails (its guards or a blow-up stop every lane) — and
/// then the caller runs each state alone, which gives each its own result.
pub fn simulate_lanes(
    model: &LoadedModel,
    x0s: &[Vec<f64>],
    spec: &RunSpec,
) -> Option<Vec<Recording>> {
    // a fixed-step feedback run estimates h·k·L before every step, state by state, and caps
    // or watches its gains ([`lasalle_runtime::GainBound`]): each runs alone
    let Method::Plain(base) = spec.method else {
        return None;
    };
    // backward runs go alone, each through its reversed model
    if spec.t_end < 0.0 {
        return None;
    }
    // lanes watch no events and sample no output times: such runs go alone
    let events = Declared::<f64, Vec<f64>>::events(model);
    let watched =
        !spec.t_eval.is_empty() || events.iter().any(|e| e.terminal || spec.record_events);
    if base == Base::Dopri5
        || watched
        || x0s.len() < 2
        || spec.record_every() < spec.steps()
        || x0s.iter().any(|x0| check_start(model, x0, spec).is_err())
    {
        return None;
    }
    with_base(
        base,
        spec,
        DriveLanes {
            lanes: model.lanes(x0s.len()),
            x0s,
            spec,
        },
    )
}

/// The visitor of [`simulate_lanes`].
struct DriveLanes<'a, L> {
    lanes: L,
    x0s: &'a [Vec<f64>],
    spec: &'a RunSpec,
}

impl<L: LaneField> Visit<L, Vec<f64>> for DriveLanes<'_, L> {
    type Out = Option<Vec<Recording>>;

    fn visit<S: Stepper<f64, Vec<f64>, L>>(self, mut stepper: S) -> Self::Out {
        let (lanes, spec) = (&self.lanes, self.spec);
        let model = lanes.model();
        let mut driver = Driver::new(0.0, spec.t_end, spec.dt).max_steps(spec.max_steps);
        if model.has_guards() {
            driver = driver.guard(1, move |x: &Vec<f64>| {
                lanes.check_guards(x, spec.dt).map(|g| g.to_string())
            });
        }
        if let Some(stop) = &spec.interrupt {
            driver = driver.interrupt(move || stop.is_stopped());
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
        let stepper = (stepper.name(), stepper.counters());
        let recordings = self.x0s.iter().enumerate().map(|(l, x0)| {
            // the samples of the lone run with `every = u64::MAX`: the first and the last
            let mut rec = Recorder::new(model, x0, spec.record_every(), 2);
            rec.observe(0, 0.0, x0);
            rec.finish(end.steps, end.t, &lanes.unpack(&end.x, l));
            let counts = Ok((end.steps, end.evaluations, end.rejections));
            recording(model, spec, stepper.clone(), rec, (wall, cpu), counts)
        });
        Some(recordings.collect())
    }
}

/// Integrates the states `x0s` of a loaded model with the Taylor method in lanes
/// ([`TaylorLanes`]: one kernel call computes the coefficients of several
/// orbits, each with its own steps; an orbit that ends leaves its lane to the next), as
/// [`simulate`] integrates each alone: each recording equals the lone run's except for the
/// wall and CPU time, the batch's divided by the number of runs. The batch kernel comes from
/// `pool` (built once per order) and goes back to it.
///
/// `None` where lanes do not apply — a method other than `taylor` on X, fewer than two
/// states, samples between the first and the last state (`spec.every` below the step
/// budget), output times or events to watch, a backward run, a model without a batch kernel
/// ([`LoadedModel::taylor_batch`]). Within `Some`, `None` for each run that does not start
/// ([`simulate`] refuses it), fails or diverges: the caller runs it alone, which gives its
/// failure where and as it happens.
fn simulate_taylor_lanes(
    model: &LoadedModel,
    pool: &KernelPool,
    x0s: &[Vec<f64>],
    spec: &RunSpec,
) -> Option<Vec<Option<Recording>>> {
    let events = Declared::<f64, Vec<f64>>::events(model);
    let watched =
        !spec.t_eval.is_empty() || events.iter().any(|e| e.terminal || spec.record_events);
    if spec.method != (Method::Taylor { feedback: false })
        || spec.t_end < 0.0
        || watched
        || x0s.len() < 2
        || spec.every < spec.max_steps
    {
        return None;
    }
    let opts = TaylorOptions::with_tol(spec.rtol);
    let order = opts.checked_order().ok()?;
    let kernel = pool.take_batch(order, || model.taylor_batch(order).ok().flatten())?;
    let mut lanes = TaylorLanes::new(kernel, opts).ok()?;
    let starting: Vec<usize> = (0..x0s.len())
        .filter(|&k| check_start(model, &x0s[k], spec).is_ok())
        .collect();
    let starts: Vec<Vec<f64>> = starting.iter().map(|&k| x0s[k].clone()).collect();
    // the lone run's guards, with the step size 0 of adaptive methods
    let guards = |x: &[f64]| model.check_guards(&x.to_vec(), 0.0).is_none();
    let stop = || spec.interrupt.as_ref().is_some_and(|i| i.is_stopped());
    let runs = LaneRuns {
        t_end: spec.t_end,
        h0: spec.dt,
        max_steps: spec.max_steps,
        guards: model.has_guards().then_some(&guards as _),
        stop: Some(&stop),
    };
    let (start, cpu_start) = (Instant::now(), process_cpu_seconds());
    let ends = lanes.run(model, &starts, &runs);
    let k = starts.len().max(1) as f64;
    let wall = start.elapsed().as_secs_f64() / k;
    let cpu = process_cpu_seconds()
        .zip(cpu_start)
        .map(|(end, start)| (end - start) / k);
    let name = format!("taylor({})", lanes.order());
    pool.put_batch(order, lanes.into_kernel());
    let mut out: Vec<Option<Recording>> = vec![None; x0s.len()];
    for (&at, end) in starting.iter().zip(ends) {
        let x0 = &x0s[at];
        let Some(end) = end else { continue };
        // a run whose end diverged fails alone, where the failure is reported with its step
        if DriftBound::new(model, x0, spec.max_drift)
            .check(&end.x)
            .is_some()
        {
            continue;
        }
        // the samples of the lone run with `every` above its steps: the first and the last
        let mut rec = Recorder::new(model, x0, spec.record_every(), 2);
        rec.observe(0, 0.0, x0);
        rec.finish(end.steps, end.t, &end.x);
        let counts = Ok((end.steps, end.evaluations, 0));
        out[at] = Some(recording(
            model,
            spec,
            (name.clone(), Vec::new()),
            rec,
            (wall, cpu),
            counts,
        ));
    }
    Some(out)
}

/// A model file's text, to load once per thread of an ensemble.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModelSource {
    /// The path to show in messages.
    pub path: String,
    /// The model file's text.
    pub text: String,
    /// The back end that runs the model's functions.
    pub backend: Backend,
    /// What the front end extends the model with before it is compiled (the variational
    /// equations, the chaos indicators), if anything.
    pub extension: Option<Extension>,
    /// How the model's families are lowered ([`lasalle_model::loops`]); `Unrolled` unless
    /// [`ModelSource::families`] says otherwise.
    pub families: Families,
}

impl ModelSource {
    /// The model text `text`, shown in messages as `path`.
    pub fn new(path: impl Into<String>, text: impl Into<String>, backend: Backend) -> Self {
        ModelSource {
            path: path.into(),
            text: text.into(),
            backend,
            extension: None,
            families: Families::Unrolled,
        }
    }

    /// The same model with its families lowered as `families` says (an extended model with
    /// families kept as loops is extended in loop form, [`crate::chaos::extend`]).
    pub fn families(mut self, families: Families) -> Self {
        self.families = families;
        self
    }

    /// The same model extended by the front end ([`lasalle_model::variational`]): members'
    /// initial states are then states of the extended model
    /// ([`Extension::extend_state`]).
    pub fn extended(mut self, extension: Extension) -> Self {
        self.extension = Some(extension);
        self
    }

    /// The model file at `path`.
    pub fn read(path: impl AsRef<Path>, backend: Backend) -> Result<Self, RunError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| {
            RunError::Load(format!("cannot read model file `{}`: {e}", path.display()))
        })?;
        Ok(ModelSource::new(path.display().to_string(), text, backend))
    }

    /// Parses, derives, checks and compiles the model.
    pub fn load(&self) -> Result<LoadedModel, RunError> {
        let loaded = match self.extension {
            None => {
                LoadedModel::from_source_with(&self.path, &self.text, self.backend, self.families)
            }
            Some(ext) if self.families != Families::Unrolled => {
                let base = LoadedModel::from_source_with(
                    &self.path,
                    &self.text,
                    self.backend,
                    self.families,
                )
                .map_err(|e| RunError::Load(e.to_string()))?;
                return crate::chaos::extend(&base, ext);
            }
            Some(ext) => {
                let lowered = lasalle_model::lower_source(&self.path, &self.text)
                    .and_then(|m| ext.apply(&m))
                    .map_err(|e| RunError::Load(e.to_string()))?;
                LoadedModel::from_model(lowered, self.backend)
            }
        };
        loaded.map_err(|e| RunError::Load(e.to_string()))
    }
}

/// Where a member of an ensemble starts.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Init {
    /// The model's first named point, evaluated with the member's parameters.
    #[default]
    First,
    /// A named point of the model, evaluated with the member's parameters, or comma-separated
    /// numbers ([`initial_state`]).
    Text(String),
    /// The state itself, in the flat state order.
    State(Vec<f64>),
}

/// One run of an ensemble: parameter values (on top of the model file's defaults), the
/// initial state, and components of the initial state to set after it is resolved (a sweep
/// over initial conditions).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Member {
    /// Parameters to set, as [`Parameters::set_param`] takes them; the others keep the model
    /// file's values.
    pub params: Vec<(String, Vec<f64>)>,
    /// The initial state.
    pub init: Init,
    /// Components of the initial state to set: (index in the flat state, value).
    pub set: Vec<(usize, f64)>,
}

impl Member {
    /// A member starting from `init`, with the model file's parameters.
    pub fn new(init: Init) -> Self {
        Member {
            init,
            ..Member::default()
        }
    }

    /// A member starting from the state `x0`.
    pub fn at(x0: Vec<f64>) -> Self {
        Member::new(Init::State(x0))
    }

    /// Sets a parameter (its slot values).
    pub fn param(mut self, name: impl Into<String>, values: impl Into<Vec<f64>>) -> Self {
        self.params.push((name.into(), values.into()));
        self
    }

    /// Sets component `i` of the initial state.
    pub fn set(mut self, i: usize, value: f64) -> Self {
        self.set.push((i, value));
        self
    }

    /// The member's parameters bitwise, to group members that share them.
    fn key(&self) -> Vec<(&str, Vec<u64>)> {
        self.params
            .iter()
            .map(|(n, v)| (n.as_str(), v.iter().map(|x| x.to_bits()).collect()))
            .collect()
    }

    /// The initial state, with the member's parameters already set on `model`.
    fn start(&self, model: &LoadedModel) -> Result<Vec<f64>, RunError> {
        let mut x0 = match &self.init {
            Init::First => {
                let first = model.point_names().first().ok_or_else(|| {
                    RunError::Model("the model has no named point: give --init x1,x2,…".into())
                })?;
                initial_state(model, first)?
            }
            Init::Text(text) => initial_state(model, text)?,
            Init::State(x) => x.clone(),
        };
        for &(i, v) in &self.set {
            let n = x0.len();
            *x0.get_mut(i).ok_or_else(|| {
                RunError::Model(format!(
                    "state component {i} does not exist (the state has dimension {n})"
                ))
            })? = v;
        }
        Ok(x0)
    }
}

/// The results of [`simulate_many`].
#[derive(Debug)]
pub struct Ensemble {
    /// One result per member, in the members' order.
    pub recordings: Vec<Result<Recording, RunError>>,
    /// The threads the runs were spread over.
    pub threads: usize,
}

/// A model of one thread of [`simulate_many`], with the model file's parameter values.
struct ThreadModel {
    model: LoadedModel,
    defaults: Vec<(&'static str, Vec<f64>)>,
    /// The Taylor kernels of the thread's runs, built once.
    kernels: std::sync::Arc<KernelPool>,
}

impl ThreadModel {
    fn load(source: &ModelSource) -> Result<ThreadModel, RunError> {
        let model = source.load()?;
        let defaults = model
            .param_slots()
            .iter()
            .filter_map(|s| Some((s.name, model.param(s.name)?)))
            .collect();
        Ok(ThreadModel {
            model,
            defaults,
            kernels: KernelPool::new(),
        })
    }

    /// Sets the parameters of `member` and the model file's values of the others.
    fn set_params(&mut self, member: &Member) -> Result<(), RunError> {
        for (name, values) in &self.defaults {
            let given = member.params.iter().any(|(n, _)| n == name);
            let same = || {
                self.model.param(name).is_some_and(|v| {
                    v.iter()
                        .zip(values)
                        .all(|(a, b)| a.to_bits() == b.to_bits())
                })
            };
            if !given && !same() {
                self.model
                    .set_param(name, values)
                    .map_err(|e| RunError::Model(e.to_string()))?;
            }
        }
        for (name, values) in &member.params {
            self.model
                .set_param(name, values)
                .map_err(|e| RunError::Model(e.to_string()))?;
        }
        Ok(())
    }

    /// The runs of a group of members with the same parameters: together in lanes where that
    /// applies, else one by one.
    fn run_group(&mut self, group: &[&Member], spec: &RunSpec) -> Vec<Result<Recording, RunError>> {
        if let Err(e) = self.set_params(group[0]) {
            return vec![Err(e); group.len()];
        }
        let model = &self.model;
        let starts: Result<Vec<Vec<f64>>, RunError> =
            group.iter().map(|m| m.start(model)).collect();
        let reusing = Reusing::new(model, &self.kernels);
        let alone = |m: &Member| {
            let x0 = m.start(model)?;
            if spec.method.is_taylor() {
                simulate(&reusing, &x0, spec)
            } else {
                simulate(model, &x0, spec)
            }
        };
        let Ok(x0s) = starts else {
            return group.iter().map(|m| alone(m)).collect();
        };
        if let Some(recordings) = simulate_lanes(model, &x0s, spec) {
            return recordings.into_iter().map(Ok).collect();
        }
        match simulate_taylor_lanes(model, &self.kernels, &x0s, spec) {
            Some(done) => group
                .iter()
                .zip(done)
                .map(|(m, rec)| rec.map_or_else(|| alone(m), Ok))
                .collect(),
            None => group.iter().map(|m| alone(m)).collect(),
        }
    }
}

/// Runs every member of an ensemble of one model file as `spec` says, on `threads` threads
/// (0: one per core), each with its own copy of the model; within a thread, members with the
/// same parameters run up to `lanes` at a time in lanes ([`simulate_lanes`], where it
/// applies; 1 runs every member alone). Each member's recording is bitwise the one
/// [`simulate`] gives it alone (but for the timings), and a member that fails to start
/// (unknown parameter or point, initial state outside the domain) fails alone.
///
/// Recordings of runs sampled only at the start and the end (`spec.every` at least the run's
/// step count, e.g. `u64::MAX`) are what lanes need and what a large ensemble wants to keep;
/// with `spec.every = 0` each member keeps about [`AUTO_SAMPLES`](crate::AUTO_SAMPLES)
/// samples.
pub fn simulate_many(
    source: &ModelSource,
    members: &[Member],
    spec: &RunSpec,
    threads: usize,
    lanes: usize,
) -> Result<Ensemble, RunError> {
    spec.validate()?;
    // groups of at most `lanes` members with the same parameters, in the members' order
    let mut groups: Vec<Vec<(usize, &Member)>> = Vec::new();
    let mut open: HashMap<Vec<(&str, Vec<u64>)>, usize> = HashMap::new();
    for (k, member) in members.iter().enumerate() {
        let key = member.key();
        match open.get(&key) {
            Some(&g) if groups[g].len() < lanes.max(1) => groups[g].push((k, member)),
            _ => {
                open.insert(key, groups.len());
                groups.push(vec![(k, member)]);
            }
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| RunError::Load(format!("cannot start threads: {e}")))?;
    // one model per thread, loaded by its first group (`map_init` would load one per rayon
    // job, which for short runs costs more than the runs)
    let models: Vec<Mutex<Option<Result<ThreadModel, RunError>>>> = (0..pool.current_num_threads())
        .map(|_| Mutex::new(None))
        .collect();
    let results: Vec<Vec<Result<Recording, RunError>>> = pool.install(|| {
        groups
            .par_iter()
            .map(|group| {
                if spec.interrupt.as_ref().is_some_and(|i| i.is_stopped()) {
                    return vec![Err(RunError::Interrupted); group.len()];
                }
                let slot = &models[rayon::current_thread_index().unwrap_or(0)];
                let mut slot = slot.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
                match slot.get_or_insert_with(|| ThreadModel::load(source)) {
                    Ok(m) => {
                        let group: Vec<&Member> = group.iter().map(|&(_, m)| m).collect();
                        m.run_group(&group, spec)
                    }
                    Err(e) => vec![Err(e.clone()); group.len()],
                }
            })
            .collect()
    });
    let mut done: Vec<(usize, Result<Recording, RunError>)> = groups
        .iter()
        .zip(results)
        .flat_map(|(group, results)| group.iter().map(|&(k, _)| k).zip(results))
        .collect();
    done.sort_by_key(|(k, _)| *k);
    Ok(Ensemble {
        recordings: done.into_iter().map(|(_, r)| r).collect(),
        threads: pool.current_num_threads(),
    })
}
