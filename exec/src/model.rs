//! A model loaded from its file at run time: parsed, differentiated, checked and compiled to
//! kernels in milliseconds, then integrated by the same runtime as compiled models.
//!
//! [`LoadedModel`] implements the runtime's traits ([`Field`], [`Invariants`], [`Lyapunov`],
//! [`Partitioned`], [`ModelInfo`], [`Parameters`], [`Declared`]) with `Vec<f64>` storage, so
//! every stepper, the driver, the feedback field, gain selection, projection and the recorder
//! run it unchanged (see `lasalle_runtime::State` for why one code path serves both).
//!
//! ```
//! use lasalle_exec::{Backend, LoadedModel};
//! use lasalle_runtime::{integrate, ExplicitRk, FeedbackField, Parameters};
//!
//! let text = "model Osc { state q: scalar, p: scalar; param w = 2;
//!             d/dt q = p; d/dt p = -w^2 * q; integral E = p^2/2 + w^2 * q^2/2 gain 10;
//!             point start { q = 1; p = 0; } }";
//! let m = LoadedModel::from_source("osc.lsl", text, Backend::default()).unwrap();
//! let x0 = m.point("start").unwrap();
//! let fb = FeedbackField::from_initial(&m, &x0, vec![10.0]);
//! let end = integrate(&mut ExplicitRk::euler(), &fb, &x0, 0.0, 10.0, 1e-3, &mut ()).unwrap();
//! let energy = end.x[1].powi(2) / 2.0 + 2.0 * end.x[0].powi(2);
//! assert!((energy - 2.0).abs() < 1e-3);
//! ```

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use lasalle_model::ir::{Id, Input};
use lasalle_model::loops::{Families, LoopModel};
use lasalle_model::tape::step::rk_step;
use lasalle_model::tape::{Dims, ModelTapes, Tape, TapeBuilder, TapeError};
use lasalle_model::Conservation;
use lasalle_model::Model;
use lasalle_model::{derive, Derived};
use lasalle_model::{Direction, EVENT_TIME, GUARD_STEP};
use lasalle_runtime::{
    CompiledStep, Declared, DelaySpec, EventDirection, EventSpec, Field, FixedMethod, GuardFailure,
    InvariantInfo, Invariants, Lyapunov, ModelInfo, ParamError, Parameters, Partitioned, Preset,
    Shape, Slot, Splitting, SwitchSpec,
};

use crate::{intern, Backend, ExecError, Kernel};

/// Why a model could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The model file has errors (syntax, names, shapes, a non-conserved integral), or cannot
    /// be read; the message names file:line:col.
    #[error(transparent)]
    Model(#[from] lasalle_model::Error),
    /// A function could not be compiled.
    #[error("cannot compile the model's functions: {0}")]
    Exec(#[from] ExecError),
    /// A function could not be linearised into a tape.
    #[error("cannot linearise the model's functions: {0}")]
    Tape(#[from] lasalle_model::tape::TapeError),
}

/// A compiled function with the values its prelude computed for the current parameters.
///
/// Every call of the runtime's traits comes through [`Compiled::eval`], so it is kept short:
/// the lengths are compared with the tape's (fixed at load), and then the JIT's code is called
/// directly through its function pointer (no virtual call, no `Result`), or the kernel's
/// unchecked entry point.
struct Compiled {
    kernel: Box<dyn Kernel>,
    /// `kernel.raw_eval()`: valid while `kernel` is alive, which is as long as `self`.
    raw: Option<crate::RawEval>,
    /// The kernel's parameter-only values. Its length is the one the kernel expects, fixed
    /// when the model is loaded: only [`Compiled::rehoist`] replaces it, with one as long.
    hoisted: Box<[f64]>,
    /// Lengths of state, target, gains and out that the kernel expects.
    lens: [usize; 4],
}

impl Compiled {
    fn new(backend: Backend, tape: &Tape, params: &[f64]) -> Result<Compiled, ExecError> {
        Compiled::of(backend.compile(tape)?, params)
    }

    fn of(kernel: Box<dyn Kernel>, params: &[f64]) -> Result<Compiled, ExecError> {
        let hoisted = kernel.hoist(params)?.into_boxed_slice();
        let d = kernel.dims();
        let lens = [d.state, d.targets, d.gains, kernel.n_outputs()];
        let raw = kernel.raw_eval();
        Ok(Compiled {
            kernel,
            raw,
            hoisted,
            lens,
        })
    }

    /// Recomputes the parameter-only values (keeping their length).
    fn rehoist(&mut self, params: &[f64]) -> Result<(), ExecError> {
        let h = self.kernel.hoist(params)?;
        if h.len() != self.hoisted.len() {
            return Err(TapeError::WrongLength {
                kind: "hoisted",
                expected: self.hoisted.len(),
                given: h.len(),
            }
            .into());
        }
        self.hoisted.copy_from_slice(&h);
        Ok(())
    }

    /// Evaluates; on an argument of the wrong length (impossible through `LoadedModel`, whose
    /// lengths are fixed when the model is loaded) the outputs are NaN, which the driver
    /// reports as a blow-up.
    #[inline]
    fn eval(&self, state: &[f64], target: &[f64], gains: &[f64], out: &mut [f64]) {
        let [ns, nt, ng, no] = self.lens;
        if state.len() != ns || target.len() != nt || gains.len() != ng || out.len() != no {
            return nan(out);
        }
        let h = &self.hoisted[..];
        // SAFETY: every length was just compared with what the kernel expects, and `hoisted`
        // has the kernel's length by the field's invariant; `raw` belongs to `kernel`, alive
        // as long as `self`.
        unsafe {
            match self.raw {
                Some(f) => f(
                    h.as_ptr(),
                    state.as_ptr(),
                    target.as_ptr(),
                    gains.as_ptr(),
                    out.as_mut_ptr(),
                ),
                None => self.kernel.eval_unchecked(h, state, target, gains, out),
            }
        }
    }
}

#[cold]
#[inline(never)]
fn nan(out: &mut [f64]) {
    out.iter_mut().for_each(|v| *v = f64::NAN);
}

/// The compiled functions of a model.
struct Kernels {
    field: Compiled,
    invariants: Compiled,
    jacobian: Compiled,
    lyapunov: Compiled,
    lyapunov_gradient: Compiled,
    feedback: Compiled,
    /// q̇ = a(p) and ṗ = b(q) for partitioned fields, with the q components.
    partition: Option<(Compiled, Compiled, Vec<bool>)>,
    /// The margins of the guards, with the step size as the tape's one gain.
    guards: Option<Compiled>,
    /// The event functions, with the time as the tape's one gain.
    events: Option<Compiled>,
}

impl Kernels {
    fn all_mut(&mut self) -> impl Iterator<Item = &mut Compiled> {
        let partition = self
            .partition
            .as_mut()
            .map(|(q, p, _)| [q, p])
            .into_iter()
            .flatten();
        [
            &mut self.field,
            &mut self.invariants,
            &mut self.jacobian,
            &mut self.lyapunov,
            &mut self.lyapunov_gradient,
            &mut self.feedback,
        ]
        .into_iter()
        .chain(partition)
        .chain(self.guards.as_mut())
        .chain(self.events.as_mut())
    }
}

/// The model's description in the runtime's terms. The names and tables live as long as the
/// process, so that [`ModelInfo`] can hand out `'static` tables as compiled models do; they are
/// interned ([`crate::intern`]), so loading the same model again adds nothing.
struct Info {
    name: &'static str,
    state: &'static [Slot],
    invariants: &'static [InvariantInfo],
    gain_names: &'static [&'static str],
    default_gains: &'static [f64],
    params: &'static [Slot],
    points: &'static [&'static str],
    presets: &'static [Preset],
    guards: Vec<(&'static str, &'static str, bool)>,
    events: &'static [EventSpec],
    switches: &'static [SwitchSpec],
    delays: &'static [DelaySpec],
}

impl Info {
    fn new(model: &Model) -> Info {
        let slot = |name: &str, shape: Shape, offset: usize| Slot {
            name: intern::name(name),
            shape,
            offset,
        };
        Info {
            name: intern::name(&model.name),
            state: intern::table(
                model
                    .state
                    .iter()
                    .map(|s| slot(&s.name, s.shape, s.offset))
                    .collect(),
            ),
            invariants: intern::table(
                model
                    .invariants
                    .iter()
                    .map(|f| InvariantInfo {
                        slot: slot(&f.name, f.value.shape, f.offset),
                        kind: f.kind,
                        gain: f.gain,
                    })
                    .collect(),
            ),
            gain_names: intern::table(model.gains.iter().map(|g| intern::name(&g.name)).collect()),
            default_gains: intern::table(model.gains.iter().map(|g| g.default).collect()),
            params: intern::table(
                model
                    .params
                    .iter()
                    .map(|p| {
                        let s = if p.diagonal {
                            Shape::Vector(p.slots())
                        } else {
                            p.shape
                        };
                        slot(&p.name, s, p.offset)
                    })
                    .collect(),
            ),
            points: intern::table(model.points.iter().map(|p| intern::name(&p.name)).collect()),
            presets: intern::table(
                model
                    .presets
                    .iter()
                    .map(|p| Preset {
                        name: intern::name(&p.name),
                        method: p.method.as_deref().map(intern::name),
                        dt: p.dt,
                        t_end: p.t_end,
                        every: p.every,
                        init: p.init.as_deref().map(intern::name),
                        gains: p.gains.clone().map(intern::table),
                        params: intern::table(
                            p.params
                                .iter()
                                .map(|(n, v)| (intern::name(n), intern::table(v.clone())))
                                .collect(),
                        ),
                    })
                    .collect(),
            ),
            guards: model
                .guards
                .iter()
                .map(|g| (intern::name(&g.name), intern::name(&g.condition), g.strict))
                .collect(),
            events: intern::table(
                model
                    .events
                    .iter()
                    .map(|e| EventSpec {
                        name: intern::name(&e.name),
                        direction: match e.direction {
                            Direction::Both => EventDirection::Both,
                            Direction::Rising => EventDirection::Rising,
                            Direction::Falling => EventDirection::Falling,
                        },
                        terminal: e.terminal,
                    })
                    .collect(),
            ),
            switches: intern::table(
                model
                    .switches
                    .iter()
                    .map(|s| SwitchSpec {
                        surface: intern::name(&s.text),
                        mode: s.mode,
                        slide: s.slide,
                        event: s.event,
                    })
                    .collect(),
            ),
            delays: intern::table(
                model
                    .delays
                    .iter()
                    .map(|d| DelaySpec {
                        text: intern::name(&d.text),
                        location: intern::name(&d.span.location()),
                        component: d.component,
                        slot: d.slot,
                        clock: d.clock,
                    })
                    .collect(),
            ),
        }
    }
}

/// The lowered model: unrolled, or with families kept as loops and the unrolled model built
/// at its first use.
enum Lowered {
    Unrolled(Arc<Derived>),
    Loops(Arc<crate::deferred::LazyTapes>),
}

/// The unrolled tapes of the field and of X − ∇V.
enum StepTapes {
    /// Built when the model was loaded.
    Built {
        field: Box<Tape>,
        feedback: Box<Tape>,
    },
    /// A model loaded with its families kept as loops: no unrolled field (steps use the loop
    /// kernel); X − ∇V from the unrolled model at its first use, unless it is a loop kernel
    /// (`looped`), which the steppers call instead of a compiled step.
    Deferred {
        lazy: Arc<crate::deferred::LazyTapes>,
        looped: bool,
    },
}

/// A compiled step tape, shared by the steppers that call it.
type StepKernel = Arc<Box<dyn Kernel>>;

/// A model compiled at run time from its file; see the [module docs](crate::model).
pub struct LoadedModel {
    lowered: Lowered,
    conservation: Vec<Conservation>,
    backend: Backend,
    params: Vec<f64>,
    kernels: Kernels,
    /// The tapes of the field and of X − ∇V, for compiled steps and the lanes of feedback
    /// ensembles ([`crate::FeedbackLanes`]), which compile them on demand.
    step_tapes: StepTapes,
    /// The tape of the guards' margins, for compiled steps.
    guards_tape: Option<Tape>,
    /// The field in loop form, for the loop form of its Taylor program (a model loaded with
    /// its families kept as loops): a loop tape, or staged (the chaos indicators' field of an
    /// extension, [`LoadedModel::extended`]).
    loop_field: Option<Box<lasalle_model::loops::ExtendedField>>,
    /// V, ∇V and X − ∇V in loop form, for the loop form of the Taylor program of X − ∇V
    /// (where the loop form takes them).
    loop_feedback: Option<Box<lasalle_model::loops::LoopFeedback>>,
    /// The compiled steps built so far, by method name and whether on X − ∇V
    /// ([`Declared::compiled_step`]).
    steps: Mutex<HashMap<(&'static str, bool), StepKernel>>,
    info: Info,
    load_time: Duration,
}

impl std::fmt::Debug for LoadedModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoadedModel")
            .field("name", &self.info.name)
            .field("backend", &self.backend)
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

impl LoadedModel {
    /// Loads a model from its text: parse, lower, derive, check every declared invariant,
    /// linearise every function into a tape and compile it with `backend`. `path` names the
    /// file in messages.
    pub fn from_source(path: &str, text: &str, backend: Backend) -> Result<LoadedModel, LoadError> {
        let start = Instant::now();
        Self::compile(lasalle_model::lower_source(path, text)?, backend, start)
    }

    /// Loads a lowered model, e.g. one built by a transformation of the front end
    /// ([`lasalle_model::variational`]): derive, check, linearise and compile as
    /// [`LoadedModel::from_source`] does.
    pub fn from_model(model: Model, backend: Backend) -> Result<LoadedModel, LoadError> {
        Self::compile(model, backend, Instant::now())
    }

    fn compile(model: Model, backend: Backend, start: Instant) -> Result<LoadedModel, LoadError> {
        let derived = derive(model);
        let conservation = lasalle_model::check(&derived)?.into_conservation();
        let tapes = ModelTapes::new(&derived)?;
        let params = derived.model.default_params();
        let c = |tape: &Tape| Compiled::new(backend, tape, &params);
        let (guards, events) = guards_and_events(&derived.model, backend, &params)?;
        let kernels = Kernels {
            field: c(&tapes.field)?,
            invariants: c(&tapes.invariants)?,
            jacobian: c(&tapes.jacobian)?,
            lyapunov: c(&tapes.lyapunov)?,
            lyapunov_gradient: c(&tapes.lyapunov_gradient)?,
            feedback: c(&tapes.feedback)?,
            partition: match &tapes.partition {
                Some(p) => Some((c(&p.field_q)?, c(&p.field_p)?, p.is_q.clone())),
                None => None,
            },
            guards: guards.as_ref().map(c).transpose()?,
            events,
        };
        let info = Info::new(&derived.model);
        Ok(LoadedModel {
            lowered: Lowered::Unrolled(Arc::new(derived)),
            conservation,
            backend,
            params,
            kernels,
            step_tapes: StepTapes::Built {
                field: Box::new(tapes.field),
                feedback: Box::new(tapes.feedback),
            },
            guards_tape: guards,
            loop_field: None,
            loop_feedback: None,
            steps: Mutex::default(),
            info,
            load_time: start.elapsed(),
        })
    }

    /// [`LoadedModel::from_source`], with the model's families lowered as `families` says
    /// ([`lasalle_model::loops`]). When some family is kept as a loop, the field, the
    /// integrals, their Jacobian and the half-fields are loop kernels ([`crate::LoopKernel`]),
    /// V, ∇V and X − ∇V staged loop kernels ([`crate::StagedKernel`]), the Taylor kernels of
    /// the field and of X − ∇V the loop forms of their programs ([`crate::LoopTaylorTape`],
    /// [`crate::LoopFeedbackTaylor`]), and the integrals are checked on the families' terms. A
    /// function the loop form refuses and the compiled steps on X − ∇V are built from the
    /// unrolled model at their first use; the unrolled model itself is lowered and derived only then (or at the first call of
    /// [`LoadedModel::model`]), never at load. Otherwise the model loads as with
    /// [`LoadedModel::from_source`]; so does a model the loop form refuses (a sum that enters
    /// the field or an integral other than as a term with a constant coefficient, an integral
    /// it finds not conserved) under [`Families::Auto`], while [`Families::Loops`] reports the
    /// refusal.
    pub fn from_source_with(
        path: &str,
        text: &str,
        backend: Backend,
        families: Families,
    ) -> Result<LoadedModel, LoadError> {
        let start = Instant::now();
        if families == Families::Unrolled {
            return Self::from_source(path, text, backend);
        }
        let lm = LoopModel::from_source(path, text, families)?;
        if lm.families().is_empty() {
            return Self::compile(lm.unrolled()?, backend, start);
        }
        let checked = lm.check().and_then(|c| Ok((c, lm.tapes()?)));
        let (conservation, tapes) = match checked {
            Ok(ct) => ct,
            // `auto` falls back to the unrolled model, which checks on its own terms
            Err(_) if families == Families::Auto => {
                return Self::compile(lm.unrolled()?, backend, start)
            }
            Err(e) => return Err(e.into()),
        };
        let lm = Arc::new(lm);
        let lazy = Arc::new(crate::deferred::LazyTapes::new(
            crate::deferred::Unrolled::new(lm.clone()),
        ));
        let model = lm.declarations();
        let params = model.default_params();
        // guards and events that read a family's sum are built from the unrolled model
        let (guards, events) = match guards_and_events(model, backend, &params) {
            Ok(ge) => ge,
            Err(_) => guards_and_events(&lazy.unrolled().get()?.model, backend, &params)?,
        };
        let looped = |t: &lasalle_model::loops::LoopTape| -> Result<Compiled, ExecError> {
            Compiled::of(Box::new(crate::LoopKernel::new(t, backend)?), &params)
        };
        let (n, m) = (model.dim(), model.invariant_dim());
        let plain = Dims {
            state: n,
            params: model.param_slots(),
            targets: 0,
            gains: 0,
        };
        let full = Dims {
            targets: m,
            gains: model.gains.len(),
            ..plain
        };
        let deferred = |pick: crate::deferred::Pick, dims: Dims, outputs: usize| {
            let k = crate::deferred::Deferred::new(lazy.clone(), pick, backend, dims, outputs);
            Compiled::of(Box::new(k), &params)
        };
        // Each derived function in loop form where it has one, else from the unrolled model.
        let jacobian = match lm.jacobian() {
            Ok(t) => looped(&t)?,
            Err(_) => deferred(|t| Some(&t.jacobian), plain, m * n)?,
        };
        let staged =
            |fb: &lasalle_model::loops::LoopFeedback, stage| -> Result<Compiled, ExecError> {
                Compiled::of(
                    Box::new(crate::StagedKernel::new(fb, stage, backend)?),
                    &params,
                )
            };
        let loop_feedback = lm.feedback().ok();
        let (lyapunov, lyapunov_gradient, feedback) = match &loop_feedback {
            Some(fb) => (
                staged(fb, crate::Stage::Lyapunov)?,
                staged(fb, crate::Stage::Gradient)?,
                staged(fb, crate::Stage::Feedback)?,
            ),
            None => (
                deferred(|t| Some(&t.lyapunov), full, 1)?,
                deferred(|t| Some(&t.lyapunov_gradient), full, n)?,
                deferred(|t| Some(&t.feedback), full, n)?,
            ),
        };
        let feedback_looped = loop_feedback.is_some();
        let partition = match lm.partition() {
            Ok(Some(p)) => Some((looped(&p.field_q)?, looped(&p.field_p)?, p.is_q)),
            Ok(None) => None,
            Err(_) => match &lazy.unrolled().get()?.derivatives.partition {
                Some(is_q) => {
                    let q = is_q.iter().filter(|&&b| b).count();
                    Some((
                        deferred(|t| t.partition.as_ref().map(|p| &p.field_q), plain, q)?,
                        deferred(|t| t.partition.as_ref().map(|p| &p.field_p), plain, n - q)?,
                        is_q.clone(),
                    ))
                }
                None => None,
            },
        };
        let kernels = Kernels {
            field: looped(&tapes.field)?,
            invariants: looped(&tapes.invariants)?,
            jacobian,
            lyapunov,
            lyapunov_gradient,
            feedback,
            partition,
            guards: guards
                .as_ref()
                .map(|t| Compiled::new(backend, t, &params))
                .transpose()?,
            events,
        };
        let info = Info::new(model);
        Ok(LoadedModel {
            lowered: Lowered::Loops(lazy.clone()),
            conservation,
            backend,
            params,
            kernels,
            step_tapes: StepTapes::Deferred {
                lazy,
                looped: feedback_looped,
            },
            guards_tape: guards,
            loop_field: Some(Box::new(lasalle_model::loops::ExtendedField::Loop(
                tapes.field,
            ))),
            loop_feedback: loop_feedback.map(Box::new),
            steps: Mutex::default(),
            info,
            load_time: start.elapsed(),
        })
    }

    /// The model extended by `extension` (the variational equations or the chaos indicators)
    /// in loop form ([`lasalle_model::loops::variational`]), for a model loaded with its
    /// families kept as loops: its field is a loop kernel (the variational equations) or a
    /// staged loop kernel (the indicators, whose peak event is one too), its invariants and
    /// their Jacobian loop kernels of the extended state, with this model's conservation;
    /// the Taylor program of the field is its loop form (that of a loop tape, or the staged
    /// program of [`crate::LoopFeedbackTaylor`] for the indicators' staged field);
    /// V, ∇V, X − ∇V and [`LoadedModel::model`] come from the unrolled extension ([`Extension::apply`](lasalle_model::variational::Extension::apply)
    /// of the unrolled model) at their first use. The functions have the model file's
    /// parameter values (set this model's on it). It declares no partition (the tangent's
    /// rates read the tangent).
    ///
    /// `None` for a model without loop families (apply the extension to
    /// [`LoadedModel::model`] and load it with [`LoadedModel::from_model`]); an error where the
    /// loop form refuses (a model with events of its own, guards that read a family's sum).
    pub fn extended(
        &self,
        extension: lasalle_model::variational::Extension,
    ) -> Option<Result<LoadedModel, LoadError>> {
        let Lowered::Loops(lazy) = &self.lowered else {
            return None;
        };
        Some(self.extend_loops(lazy.unrolled().loops(), extension))
    }

    fn extend_loops(
        &self,
        lm: &LoopModel,
        extension: lasalle_model::variational::Extension,
    ) -> Result<LoadedModel, LoadError> {
        use lasalle_model::loops::ExtendedField;
        let start = Instant::now();
        let backend = self.backend;
        let le = lm.extend(extension)?;
        let model = le.declarations();
        let params = model.default_params();
        let of = |k: Box<dyn Kernel>| Compiled::of(k, &params);
        let looped = |t: &lasalle_model::loops::LoopTape| -> Result<Compiled, ExecError> {
            of(Box::new(crate::LoopKernel::new(t, backend)?))
        };
        let loop_field = le.field()?;
        let field = match &loop_field {
            ExtendedField::Loop(t) => looped(t)?,
            ExtendedField::Staged(s) => of(Box::new(crate::StagedKernel::new(
                s,
                crate::Stage::Feedback,
                backend,
            )?))?,
        };
        let events = match le.peak()? {
            Some(p) => Some(of(Box::new(crate::StagedKernel::new(
                &p,
                crate::Stage::Lyapunov,
                backend,
            )?))?),
            None => None,
        };
        let mut no_events = model.clone();
        no_events.events.clear();
        let (guards, _) = guards_and_events(&no_events, backend, &params)?;
        let lazy = Arc::new(crate::deferred::LazyTapes::new(
            crate::deferred::Unrolled::extended(Arc::new(le.loops().clone()), extension),
        ));
        let (n, m) = (model.dim(), model.invariant_dim());
        let full = Dims {
            state: n,
            params: model.param_slots(),
            targets: m,
            gains: model.gains.len(),
        };
        let deferred = |pick: crate::deferred::Pick, outputs: usize| {
            let k = crate::deferred::Deferred::new(lazy.clone(), pick, backend, full, outputs);
            of(Box::new(k))
        };
        let kernels = Kernels {
            field,
            invariants: looped(&le.invariants()?)?,
            jacobian: looped(&le.jacobian()?)?,
            lyapunov: deferred(|t| Some(&t.lyapunov), 1)?,
            lyapunov_gradient: deferred(|t| Some(&t.lyapunov_gradient), n)?,
            feedback: deferred(|t| Some(&t.feedback), n)?,
            partition: None,
            guards: guards
                .as_ref()
                .map(|t| Compiled::new(backend, t, &params))
                .transpose()?,
            events,
        };
        let info = Info::new(model);
        Ok(LoadedModel {
            lowered: Lowered::Loops(lazy.clone()),
            conservation: self.conservation.clone(),
            backend,
            params,
            kernels,
            step_tapes: StepTapes::Deferred {
                lazy,
                looped: false,
            },
            guards_tape: guards,
            loop_field: Some(Box::new(loop_field)),
            // X − ∇V of the extension comes from the unrolled extension (`kernels.feedback`)
            loop_feedback: None,
            steps: Mutex::default(),
            info,
            load_time: start.elapsed(),
        })
    }

    /// Reads and loads a model file.
    pub fn load(
        path: impl AsRef<std::path::Path>,
        backend: Backend,
    ) -> Result<LoadedModel, LoadError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| lasalle_model::Error::Io {
            path: path.display().to_string(),
            source: e,
        })?;
        Self::from_source(&path.display().to_string(), &text, backend)
    }

    /// The lowered model (its DAG, names and declarations). For a model loaded with families
    /// kept as loops, the unrolled model, lowered and derived at the first call of this or of
    /// [`LoadedModel::derived`]; the error says why it did not lower (it does whenever the
    /// loop form did: the same source through the same checks).
    pub fn model(&self) -> Result<&Model, LoadError> {
        Ok(&self.derived()?.model)
    }

    /// The model with its derivatives (for a model loaded with families kept as loops, built
    /// at the first call, as [`LoadedModel::model`] says).
    pub fn derived(&self) -> Result<&Derived, LoadError> {
        match &self.lowered {
            Lowered::Unrolled(d) => Ok(d),
            Lowered::Loops(lazy) => Ok(lazy.unrolled().get()?),
        }
    }

    /// The model's declarations (names, shapes, parameters, points, presets), without
    /// building the unrolled model of a model loaded with families kept as loops.
    fn declarations(&self) -> &Model {
        match &self.lowered {
            Lowered::Unrolled(d) => &d.model,
            Lowered::Loops(lazy) => lazy.unrolled().loops().declarations(),
        }
    }

    /// How each declared invariant was shown to be conserved.
    pub fn conservation(&self) -> &[Conservation] {
        &self.conservation
    }

    /// The back end the functions were compiled with.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// Wall time of parse → derive → check → compile.
    pub fn load_time(&self) -> Duration {
        self.load_time
    }

    /// The dimension N of the state.
    pub fn dim(&self) -> usize {
        self.declarations().dim()
    }

    /// The current parameter slots.
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    /// A preset by name.
    pub fn preset(&self, name: &str) -> Option<&'static Preset> {
        self.info.presets.iter().find(|p| p.name == name)
    }

    /// The compiled step tape of `method` on the field or on X − ∇V (built and compiled at
    /// its first use, then shared), on the back ends that hand out their code
    /// ([`Kernel::raw_eval`]: the JIT).
    fn step_kernel(&self, method: &FixedMethod<'_>, feedback: bool) -> Option<StepKernel> {
        if self.backend != Backend::Jit {
            return None;
        }
        let mut steps = self.steps.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(k) = steps.get(&(method.name, feedback)) {
            return Some(k.clone());
        }
        let field = match (&self.step_tapes, feedback) {
            (StepTapes::Built { field, .. }, false) => field,
            (StepTapes::Built { feedback, .. }, true) => feedback,
            // the loop kernel steps the field through the generic steppers
            (StepTapes::Deferred { .. }, false) => return None,
            // X − ∇V in loop form: the steppers call its staged kernel
            (StepTapes::Deferred { looped: true, .. }, true) => return None,
            (StepTapes::Deferred { lazy, .. }, true) => &lazy.get().ok()?.feedback,
        };
        let tape = rk_step(field, method.a, method.b, self.guards_tape.as_ref()).ok()?;
        let strict: Vec<bool> = self.info.guards.iter().map(|g| g.2).collect();
        let kernel = self.backend.compile_step(&tape, self.dim(), &strict);
        let kernel = Arc::new(kernel.ok()?);
        steps.insert((method.name, feedback), kernel.clone());
        Some(kernel)
    }

    /// The field in loop form (a loop tape, or staged), the stages of X − ∇V in loop form
    /// (where the loop form takes them) and the unrolled model's tapes, for a model loaded with
    /// its families kept as loops.
    #[allow(clippy::type_complexity)]
    pub(crate) fn loop_taylor(
        &self,
    ) -> Option<(
        &lasalle_model::loops::ExtendedField,
        Option<&lasalle_model::loops::LoopFeedback>,
        Arc<crate::deferred::LazyTapes>,
    )> {
        match (&self.loop_field, &self.step_tapes) {
            (Some(field), StepTapes::Deferred { lazy, .. }) => {
                Some((field, self.loop_feedback.as_deref(), lazy.clone()))
            }
            _ => None,
        }
    }

    /// The tape of X − ∇V (for a model with families kept as loops, built now if not yet).
    pub(crate) fn feedback_tape(&self) -> Result<&Tape, ExecError> {
        match &self.step_tapes {
            StepTapes::Built { feedback, .. } => Ok(feedback),
            StepTapes::Deferred { lazy, .. } => Ok(&lazy.get()?.feedback),
        }
    }

    /// The guards at k states in lanes ([`crate::LaneField`]), `x` the first N·k components of
    /// a state of the lanes: the first failure, in lane order, then guard order.
    pub(crate) fn check_guards_lanes(&self, k: usize, x: &[f64], dt: f64) -> Option<GuardFailure> {
        let guards = self.kernels.guards.as_ref()?;
        let n = self.info.guards.len();
        // after every step: no allocation for a few guards on up to 8 lanes
        let mut stack = [0.0; 64];
        let mut heap;
        let margins: &mut [f64] = if n * k <= stack.len() {
            &mut stack[..n * k]
        } else {
            heap = vec![0.0; n * k];
            &mut heap
        };
        if guards
            .kernel
            .eval_lanes(k, &guards.hoisted, x, &[], &[dt], margins)
            .is_err()
        {
            nan(margins);
        }
        (0..k).find_map(|l| {
            self.info
                .guards
                .iter()
                .enumerate()
                .find_map(|(g, &(name, condition, strict))| {
                    GuardFailure::check(name, condition, margins[g * k + l], strict)
                })
        })
    }

    /// Does the model declare guards (`guard …;`)?
    pub fn has_guards(&self) -> bool {
        self.kernels.guards.is_some()
    }

    /// Recomputes every kernel's parameter-only values after a parameter change.
    fn rehoist(&mut self) -> Result<(), ExecError> {
        let params = &self.params;
        self.kernels.all_mut().try_for_each(|c| c.rehoist(params))
    }
}

impl LoadedModel {
    /// The field at k states in lanes ([`crate::Lanes`]); NaN on lengths that do not fit.
    pub(crate) fn field_lanes(&self, k: usize, x: &[f64], dx: &mut [f64]) {
        let c = &self.kernels.field;
        if c.kernel.eval_lanes(k, &c.hoisted, x, &[], &[], dx).is_err() {
            nan(dx);
        }
    }
}

impl Field<f64, Vec<f64>> for LoadedModel {
    #[inline]
    fn field(&self, x: &Vec<f64>, dx: &mut Vec<f64>) {
        self.kernels.field.eval(x, &[], &[], dx)
    }
}

impl Invariants<f64, Vec<f64>, Vec<f64>> for LoadedModel {
    fn invariant_dim(&self) -> usize {
        self.declarations().invariant_dim()
    }

    #[inline]
    fn invariants(&self, x: &Vec<f64>, f: &mut Vec<f64>) {
        self.kernels.invariants.eval(x, &[], &[], f)
    }

    fn invariants_jacobian(&self, x: &Vec<f64>, jac: &mut Vec<Vec<f64>>) {
        // the tape writes Df row-major; the rows are separate vectors
        // (no allocation for Jacobians up to 512 entries: projection calls this every step)
        let n = x.len();
        let mut stack = [0.0; 512];
        let mut heap;
        let flat: &mut [f64] = if jac.len() * n <= stack.len() {
            &mut stack[..jac.len() * n]
        } else {
            heap = vec![0.0; jac.len() * n];
            &mut heap
        };
        self.kernels.jacobian.eval(x, &[], &[], flat);
        for (row, values) in jac.iter_mut().zip(flat.chunks_exact(n.max(1))) {
            row.copy_from_slice(values);
        }
    }
}

impl Lyapunov<f64, Vec<f64>, Vec<f64>, Vec<f64>> for LoadedModel {
    fn lyapunov(&self, x: &Vec<f64>, target: &Vec<f64>, gains: &Vec<f64>) -> f64 {
        let mut v = [0.0];
        self.kernels.lyapunov.eval(x, target, gains, &mut v);
        v[0]
    }

    fn lyapunov_gradient(
        &self,
        x: &Vec<f64>,
        target: &Vec<f64>,
        gains: &Vec<f64>,
        grad: &mut Vec<f64>,
    ) {
        self.kernels.lyapunov_gradient.eval(x, target, gains, grad)
    }

    #[inline]
    fn feedback_field(&self, x: &Vec<f64>, target: &Vec<f64>, gains: &Vec<f64>, dx: &mut Vec<f64>) {
        self.kernels.feedback.eval(x, target, gains, dx)
    }
}

/// The half-fields of a partitioned model. For a model whose field is not partitioned
/// ([`Declared::partitioned`] is `None`), `is_q` is empty and the half-fields write NaN.
impl Partitioned<f64, Vec<f64>> for LoadedModel {
    fn is_q(&self) -> &[bool] {
        self.kernels.partition.as_ref().map_or(&[], |(_, _, q)| q)
    }

    fn field_q(&self, x: &Vec<f64>, dx: &mut Vec<f64>) {
        self.half_field(x, dx, true)
    }

    fn field_p(&self, x: &Vec<f64>, dx: &mut Vec<f64>) {
        self.half_field(x, dx, false)
    }
}

impl LoadedModel {
    /// Writes q̇ = a(p) (`q`) or ṗ = b(q) into their components of `dx`.
    fn half_field(&self, x: &[f64], dx: &mut [f64], q: bool) {
        let Some((fq, fp, is_q)) = &self.kernels.partition else {
            dx.iter_mut().for_each(|v| *v = f64::NAN);
            return;
        };
        // the tape's outputs are the components of one group, in order
        let mut out = [0.0; 64];
        let k = is_q.iter().filter(|&&b| b == q).count();
        let mut heap;
        let out: &mut [f64] = if k <= out.len() {
            &mut out[..k]
        } else {
            heap = vec![0.0; k];
            &mut heap
        };
        (if q { fq } else { fp }).eval(x, &[], &[], out);
        for (slot, v) in (0..x.len()).filter(|&i| is_q[i] == q).zip(out.iter()) {
            dx[slot] = *v;
        }
    }
}

impl ModelInfo for LoadedModel {
    fn model_name(&self) -> &'static str {
        self.info.name
    }
    fn state_slots(&self) -> &'static [Slot] {
        self.info.state
    }
    fn invariant_infos(&self) -> &'static [InvariantInfo] {
        self.info.invariants
    }
    fn gain_names(&self) -> &'static [&'static str] {
        self.info.gain_names
    }
    fn default_gain_values(&self) -> &'static [f64] {
        self.info.default_gains
    }
    fn param_slots(&self) -> &'static [Slot] {
        self.info.params
    }
}

impl Parameters for LoadedModel {
    fn set_param(&mut self, name: &str, values: &[f64]) -> Result<(), ParamError> {
        let Some(p) = self.declarations().params.iter().find(|p| p.name == name) else {
            let known: Vec<String> = self
                .declarations()
                .params
                .iter()
                .map(|p| format!("`{}`", p.name))
                .collect();
            return Err(ParamError::Unknown {
                name: name.to_string(),
                known: known.join(", "),
            });
        };
        let (offset, slots) = (p.offset, p.slots());
        if values.len() != slots {
            return Err(ParamError::WrongLength {
                name: name.to_string(),
                expected: slots,
                given: values.len(),
            });
        }
        self.params[offset..offset + slots].copy_from_slice(values);
        // hoisting only evaluates the preludes, whose lengths were fixed at load
        if self.rehoist().is_err() {
            for c in self.kernels.all_mut() {
                c.hoisted.iter_mut().for_each(|v| *v = f64::NAN);
            }
        }
        Ok(())
    }

    fn param(&self, name: &str) -> Option<Vec<f64>> {
        let p = self.declarations().params.iter().find(|p| p.name == name)?;
        Some(self.params[p.offset..p.offset + p.slots()].to_vec())
    }

    fn point_names(&self) -> &'static [&'static str] {
        self.info.points
    }

    fn point(&self, name: &str) -> Option<Vec<f64>> {
        self.declarations().point_values(name, &self.params)
    }
}

impl Declared<f64, Vec<f64>> for LoadedModel {
    fn presets(&self) -> &'static [Preset] {
        self.info.presets
    }

    fn compiled_step(
        &self,
        method: &FixedMethod<'_>,
        feedback: Option<(&[f64], &[f64])>,
        guard_step: f64,
    ) -> Option<CompiledStep> {
        let kernel = self.step_kernel(method, feedback.is_some())?;
        let (targets, gains) = feedback.unwrap_or((&[], &[]));
        let d = kernel.dims();
        if targets.len() != d.targets || gains.len() + 2 != d.gains {
            return None;
        }
        let hoisted = kernel.hoist(&self.params).ok()?;
        let code = kernel.raw_eval()?;
        let batch = kernel.raw_batch();
        let guards = self.info.guards.clone();
        // SAFETY: the kernel computes `rk_step`'s tape on this model's field (or X − ∇V) and
        // guards: it reads its hoisted values (just computed), N state components, the
        // targets and gains whose lengths were just compared with its own, plus the two step
        // sizes, and writes N values and one margin per guard; `kernel` owns the code and goes
        // into the stepper.
        let step = unsafe {
            CompiledStep::new(
                method,
                code,
                kernel,
                hoisted,
                self.dim(),
                targets.to_vec(),
                gains,
                guards,
                guard_step,
            )
        };
        // SAFETY: `compile_step` compiled the batch as the loop around this `code` (the JIT's
        // `with_batch`), in the same module lifetime as `code`.
        Some(match batch {
            Some(batch) => unsafe { step.with_batch(batch) },
            None => step,
        })
    }

    fn check_guards(&self, x: &Vec<f64>, dt: f64) -> Option<GuardFailure> {
        let guards = self.kernels.guards.as_ref()?;
        // the guards run after every step: no allocation for the usual handful
        let mut stack = [0.0; 16];
        let mut heap;
        let n = self.info.guards.len();
        let margins: &mut [f64] = if n <= stack.len() {
            &mut stack[..n]
        } else {
            heap = vec![0.0; n];
            &mut heap
        };
        guards.eval(x, &[], &[dt], margins);
        self.info
            .guards
            .iter()
            .zip(margins.iter())
            .find_map(|(&(name, condition, strict), &m)| {
                GuardFailure::check(name, condition, m, strict)
            })
    }

    fn events(&self) -> &'static [EventSpec] {
        self.info.events
    }

    fn switches(&self) -> &'static [SwitchSpec] {
        self.info.switches
    }

    fn delays(&self) -> &'static [DelaySpec] {
        self.info.delays
    }

    fn event_values(&self, x: &Vec<f64>, t: f64, g: &mut [f64]) {
        if let Some(events) = &self.kernels.events {
            events.eval(x, &[], &[t], g);
        }
    }

    fn partitioned(&self) -> Option<&dyn Partitioned<f64, Vec<f64>>> {
        self.kernels.partition.as_ref().map(|_| self as _)
    }

    /// The interpreted kernels ([`crate::TaylorTape`]) of the field and of X − ∇V.
    fn taylor_kernels(
        &self,
        max_order: u32,
    ) -> Result<lasalle_runtime::TaylorKernels<Self>, lasalle_runtime::TaylorError> {
        self.taylor_tapes(max_order)
    }

    fn splitting(&self) -> Option<Splitting<f64>> {
        let s = self.declarations().splitting.as_ref()?;
        let values: Vec<f64> = s.params.iter().map(|&k| self.params[k as usize]).collect();
        Splitting::declared(s.kind, &values)
    }
}

/// The tapes of the guards' margins (the step size as the one gain) and the compiled event
/// functions (the time as the one gain), if the model declares any.
fn guards_and_events(
    model: &Model,
    backend: Backend,
    params: &[f64],
) -> Result<(Option<Tape>, Option<Compiled>), LoadError> {
    let c = |tape: &Tape| Compiled::new(backend, tape, params);
    let guards = if model.guards.is_empty() {
        None
    } else {
        let margins: Vec<_> = model.guards.iter().map(|g| g.margin).collect();
        Some(with_one_gain(model, &margins, GUARD_STEP)?)
    };
    let events = if model.events.is_empty() {
        None
    } else {
        let values: Vec<_> = model.events.iter().map(|e| e.value).collect();
        Some(c(&with_one_gain(model, &values, EVENT_TIME)?)?)
    };
    Ok((guards, events))
}

/// The tape of `outputs` with the input `gain` (the guards' step size, the events' time) as
/// its one gain.
fn with_one_gain(model: &Model, outputs: &[Id], gain: Input) -> Result<Tape, TapeError> {
    let mut graph = model.graph.clone();
    let outputs = graph.rename_inputs(outputs, |i| if i == gain { Input::Gain(0) } else { i });
    let dims = Dims {
        state: model.dim(),
        params: model.param_slots(),
        targets: 0,
        gains: 1,
    };
    TapeBuilder::new(graph, dims).build(&outputs)
}
