//! Ensembles within a core: k states of one loaded model advanced together, in lanes.
//!
//! [`Lanes`] is a loaded model's field X for k states at once, as a field of the runtime on the
//! storage `Vec<f64>` in structure-of-arrays order (component i of state l at `i*k + l`, the
//! layout of [`Kernel::eval_lanes`]); [`FeedbackLanes`] is the
//! feedback field X − ∇V likewise. A fixed-step stepper of the runtime that combines states
//! component by component — the explicit Runge–Kutta methods — then advances k independent
//! solutions per step, **each bitwise equal to the run of that state alone**: the kernel's
//! lanes equal its scalar calls bitwise, and the stepper's arithmetic on component `i*k + l` is
//! its arithmetic on component i of the lone run. What changes is the cost: one kernel call per
//! stage for k states, with the JIT's lane loop doing two lanes per vector instruction (see
//! `docs/performance.md`).
//!
//! # Each lane's own targets
//!
//! A kernel's lanes share its targets f(x₀), but the states of an ensemble each have their own.
//! [`FeedbackLanes`] therefore integrates the augmented system (x, c)′ = (X(x) − ∇V(x; c), 0):
//! the targets c are components of the state with derivative zero (written −0.0, so that
//! c + h·(−0.0) = c for every c, signed zeros included, with the non-negative weights of
//! Euler, Heun and RK4), and the tape of X − ∇V reads them as state components (its
//! [`Op::Target`] instructions become [`Op::State`]), compiled
//! on demand by [`LoadedModel::feedback_lanes`]. The gains stay shared: an ensemble whose states
//! need different gains runs one group per gain vector.
//!
//! # Where lanes do not apply
//!
//! - adaptive steppers (DOPRI5, Taylor): their error norm, hence their step, would be shared
//!   by the lanes, so a lane would no longer be the run of its state alone;
//! - gains that change during a run (adaptive gains), for the same reason;
//! - a run that fails (a guard, a blow-up) stops all its lanes: callers that need each state's
//!   own failure rerun the states of a failed group alone (as `lasalle sweep` does).
//!
//! Parameters are shared by the lanes (the hoisted values are computed once per parameter
//! set); an ensemble over parameter sets runs one group per set.
//!
//! ```
//! use lasalle_exec::{Backend, LaneField, LoadedModel};
//! use lasalle_runtime::{Driver, ExplicitRk};
//!
//! let text = "model Osc { state q: scalar, p: scalar; param w = 2;
//!             d/dt q = p; d/dt p = -w^2 * q; integral E = p^2/2 + w^2 * q^2/2; }";
//! let model = LoadedModel::from_source("osc.lsl", text, Backend::default()).unwrap();
//! let starts = [vec![1.0, 0.0], vec![0.5, 0.25], vec![-0.2, 1.0]];
//! let lanes = model.lanes(starts.len());
//! let x0 = lanes.pack(&starts).unwrap();
//! let driver = Driver::new(0.0, 1.0, 0.01);
//! let mut rk4 = ExplicitRk::<f64, 4, Vec<f64>>::rk4();
//! let end = driver.run(&mut rk4, &lanes, &x0, &mut ()).unwrap();
//! // each lane is the run of its state alone, bitwise
//! for (l, x) in starts.iter().enumerate() {
//!     let alone = driver.run(&mut rk4, &model, x, &mut ()).unwrap();
//!     assert_eq!(lanes.unpack(&end.x, l), alone.x);
//! }
//! ```

use crate::{ExecError, Kernel, LoadedModel, Op, Tape};
use lasalle_runtime::{Field, GuardFailure, Invariants};

/// A field of k states of a loaded model at once, on a state that packs them in lanes.
pub trait LaneField: Field<f64, Vec<f64>> {
    /// The number of lanes k.
    fn k(&self) -> usize;

    /// The model.
    fn model(&self) -> &LoadedModel;

    /// The components per lane (N, or N + M with the targets).
    fn width(&self) -> usize;

    /// The state of the lanes for one initial state per lane.
    fn pack<S: AsRef<[f64]>>(&self, states: &[S]) -> Result<Vec<f64>, PackError>;

    /// The first failed guard of the model (`guard …;`) at the lanes' states after a step of
    /// size `dt` (what [`Declared::check_guards`](lasalle_runtime::Declared::check_guards)
    /// says for each lane alone, without unpacking them).
    fn check_guards(&self, x: &[f64], dt: f64) -> Option<GuardFailure> {
        let nk = self.model().dim() * self.k();
        self.model().check_guards_lanes(self.k(), x.get(..nk)?, dt)
    }

    /// The model's state in lane `l` of a state of the lanes.
    ///
    /// # Panics
    ///
    /// If `l ≥ k` or `x` is not the length of a state of the lanes.
    fn unpack(&self, x: &[f64], l: usize) -> Vec<f64> {
        let k = self.k();
        assert!(l < k, "lane {l} of {k}");
        assert_eq!(x.len(), k * self.width(), "not a state of the lanes");
        (0..self.model().dim()).map(|i| x[i * k + l]).collect()
    }
}

/// A loaded model's field X for k states at once (see the [module docs](self)).
#[derive(Clone, Copy, Debug)]
pub struct Lanes<'m> {
    model: &'m LoadedModel,
    k: usize,
}

/// The feedback field X − ∇V of a loaded model for k states at once, each lane with its own
/// targets f(x₀) (see the [module docs](self#each-lanes-own-targets)).
pub struct FeedbackLanes<'m> {
    model: &'m LoadedModel,
    k: usize,
    kernel: Box<dyn Kernel>,
    hoisted: Vec<f64>,
    gains: Vec<f64>,
}

/// A state given to [`LaneField::pack`] that does not fit.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PackError {
    /// Not one state per lane.
    #[error("{given} states for {lanes} lanes: give one state per lane")]
    Count {
        /// States given.
        given: usize,
        /// Lanes.
        lanes: usize,
    },
    /// A state of the wrong dimension.
    #[error("state {index} has {len} components; the model's state has {dim}")]
    Dim {
        /// Which state.
        index: usize,
        /// Its length.
        len: usize,
        /// The model's state dimension.
        dim: usize,
    },
}

impl LoadedModel {
    /// The field of this model for `k ≥ 1` states at once (see [`Lanes`]).
    pub fn lanes(&self, k: usize) -> Lanes<'_> {
        Lanes {
            model: self,
            k: k.max(1),
        }
    }

    /// The feedback field of this model for `k ≥ 1` states at once, with the given gains
    /// (see [`FeedbackLanes`]): compiles the tape of X − ∇V with the targets read as state
    /// components, with this model's back end and parameters.
    pub fn feedback_lanes(&self, k: usize, gains: &[f64]) -> Result<FeedbackLanes<'_>, ExecError> {
        let tape = targets_as_state(self.feedback_tape()?);
        lasalle_model::tape::expect_len("gains", tape.dims.gains, gains.len())?;
        let kernel = self.backend().compile(&tape)?;
        let hoisted = kernel.hoist(self.params())?;
        Ok(FeedbackLanes {
            model: self,
            k: k.max(1),
            kernel,
            hoisted,
            gains: gains.to_vec(),
        })
    }
}

/// The tape with its targets read as the state components after the model's own.
fn targets_as_state(tape: &Tape) -> Tape {
    let n = tape.dims.state as u32;
    let mut t = tape.clone();
    for op in &mut t.body {
        if let Op::Target(i) = *op {
            *op = Op::State(n + i);
        }
    }
    t.dims.state += t.dims.targets;
    t.dims.targets = 0;
    t
}

/// Packs `rows(l)` (each `width` long) for lanes l = 0..k.
fn pack_rows(k: usize, width: usize, row: impl Fn(usize, &mut [f64])) -> Vec<f64> {
    let mut x = vec![0.0; width * k];
    let mut buf = vec![0.0; width];
    for l in 0..k {
        row(l, &mut buf);
        for (i, &v) in buf.iter().enumerate() {
            x[i * k + l] = v;
        }
    }
    x
}

/// Checks one state per lane, each N long.
fn check_states<S: AsRef<[f64]>>(k: usize, n: usize, states: &[S]) -> Result<(), PackError> {
    if states.len() != k {
        return Err(PackError::Count {
            given: states.len(),
            lanes: k,
        });
    }
    match states.iter().position(|s| s.as_ref().len() != n) {
        Some(index) => Err(PackError::Dim {
            index,
            len: states[index].as_ref().len(),
            dim: n,
        }),
        None => Ok(()),
    }
}

impl LaneField for Lanes<'_> {
    fn k(&self) -> usize {
        self.k
    }

    fn model(&self) -> &LoadedModel {
        self.model
    }

    fn width(&self) -> usize {
        self.model.dim()
    }

    fn pack<S: AsRef<[f64]>>(&self, states: &[S]) -> Result<Vec<f64>, PackError> {
        check_states(self.k, self.model.dim(), states)?;
        Ok(pack_rows(self.k, self.width(), |l, row| {
            row.copy_from_slice(states[l].as_ref())
        }))
    }
}

impl Field<f64, Vec<f64>> for Lanes<'_> {
    /// X at the k states; NaN if `x` is not k·N long (the driver reports a blow-up).
    fn field(&self, x: &Vec<f64>, dx: &mut Vec<f64>) {
        self.model.field_lanes(self.k, x, dx);
    }
}

impl FeedbackLanes<'_> {
    /// The gains.
    pub fn gains(&self) -> &[f64] {
        &self.gains
    }
}

impl LaneField for FeedbackLanes<'_> {
    fn k(&self) -> usize {
        self.k
    }

    fn model(&self) -> &LoadedModel {
        self.model
    }

    fn width(&self) -> usize {
        self.model.dim() + self.model.invariant_dim()
    }

    /// Each lane's state followed by its targets f(x₀) (as [`lasalle_runtime::FeedbackField`]
    /// computes them).
    fn pack<S: AsRef<[f64]>>(&self, states: &[S]) -> Result<Vec<f64>, PackError> {
        let n = self.model.dim();
        check_states(self.k, n, states)?;
        Ok(pack_rows(self.k, self.width(), |l, row| {
            let (x, c) = row.split_at_mut(n);
            x.copy_from_slice(states[l].as_ref());
            let mut f = vec![0.0; c.len()];
            self.model.invariants(&x.to_vec(), &mut f);
            c.copy_from_slice(&f);
        }))
    }
}

impl Field<f64, Vec<f64>> for FeedbackLanes<'_> {
    /// X − ∇V at the k states with their targets, and −0.0 for the targets' derivatives; NaN
    /// if `x` is not k·(N + M) long (the driver reports a blow-up).
    fn field(&self, x: &Vec<f64>, dx: &mut Vec<f64>) {
        let nk = self.model.dim() * self.k;
        if dx.len() != x.len() || x.len() != self.width() * self.k {
            dx.iter_mut().for_each(|v| *v = f64::NAN);
            return;
        }
        let (moving, fixed) = dx.split_at_mut(nk);
        if self
            .kernel
            .eval_lanes(self.k, &self.hoisted, x, &[], &self.gains, moving)
            .is_err()
        {
            moving.iter_mut().for_each(|v| *v = f64::NAN);
        }
        fixed.iter_mut().for_each(|v| *v = -0.0);
    }
}
