//! Ensembles within a core: k states of one loaded model advanced together, in lanes.
//!
//! [`Lanes`] is a loaded model's field X for k states at once, as a field of the runtime on the
//! storage `Vec<f64>` of length k·N in structure-of-arrays order (component i of state l at
//! `i*k + l`, the layout of [`Kernel::eval_lanes`](crate::Kernel::eval_lanes)). A fixed-step
//! stepper of the runtime that combines states component by component — the explicit
//! Runge–Kutta methods — then advances k independent solutions per step, **each bitwise equal
//! to the run of that state alone**: the kernel's lanes equal its scalar calls bitwise, and the
//! stepper's arithmetic on component `i*k + l` is its arithmetic on component i of the lone
//! run. What changes is the cost: one kernel call per stage for k states, with the JIT's lane
//! loop doing two lanes per vector instruction (see `docs/performance.md`).
//!
//! Where lanes do not apply, and why:
//! - adaptive steppers (DOPRI5, Taylor): their error norm, hence their step, would be shared
//!   by the lanes, so a lane would no longer be the run of its state alone;
//! - the feedback field X − ∇V: the targets f(x₀) are shared by the lanes of one kernel call,
//!   while an ensemble's initial states have their own;
//! - a run that fails (a guard, a blow-up) stops all its lanes: callers that need each state's
//!   own failure rerun the states of a failed group alone (as `lasalle sweep` does).
//!
//! Parameters are shared by the lanes (the hoisted values are computed once per parameter
//! set); an ensemble over parameter sets runs one group per set.
//!
//! ```
//! use lasalle_exec::{Backend, LoadedModel};
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

use crate::LoadedModel;
use lasalle_runtime::Field;

/// A loaded model's field for k states at once (see the [module docs](self)).
#[derive(Clone, Copy, Debug)]
pub struct Lanes<'m> {
    model: &'m LoadedModel,
    k: usize,
}

/// A state given to [`Lanes::pack`] that does not fit.
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
}

impl<'m> Lanes<'m> {
    /// The number of lanes k.
    pub fn k(&self) -> usize {
        self.k
    }

    /// The model.
    pub fn model(&self) -> &'m LoadedModel {
        self.model
    }

    /// The k states (one per lane) as one state of the lanes: component i of state l at
    /// `i*k + l`.
    pub fn pack<S: AsRef<[f64]>>(&self, states: &[S]) -> Result<Vec<f64>, PackError> {
        let (k, n) = (self.k, self.model.dim());
        if states.len() != k {
            return Err(PackError::Count {
                given: states.len(),
                lanes: k,
            });
        }
        let mut x = vec![0.0; n * k];
        for (l, s) in states.iter().enumerate() {
            let s = s.as_ref();
            if s.len() != n {
                return Err(PackError::Dim {
                    index: l,
                    len: s.len(),
                    dim: n,
                });
            }
            for (i, &v) in s.iter().enumerate() {
                x[i * k + l] = v;
            }
        }
        Ok(x)
    }

    /// The state of lane `l` out of a state of the lanes.
    ///
    /// # Panics
    ///
    /// If `l ≥ k` or `x` is not k·N long.
    pub fn unpack(&self, x: &[f64], l: usize) -> Vec<f64> {
        assert!(l < self.k, "lane {l} of {}", self.k);
        assert_eq!(
            x.len(),
            self.k * self.model.dim(),
            "not a state of the lanes"
        );
        x.iter().skip(l).step_by(self.k).copied().collect()
    }
}

impl Field<f64, Vec<f64>> for Lanes<'_> {
    /// X at the k states; NaN if `x` is not k·N long (the driver reports a blow-up).
    fn field(&self, x: &Vec<f64>, dx: &mut Vec<f64>) {
        self.model.field_lanes(self.k, x, dx);
    }
}
