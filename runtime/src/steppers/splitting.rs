//! The structure-specific splittings a model may declare (`splitting KIND(ARGS);`), as one
//! stepper: [`Splitting`] holds the kind's own stepper and forwards to it.
//!
//! The front end checks a declaration against the model (`lasalle_model::splitting`, one
//! module per kind) and records the kind's name and parameter slots; compiled and loaded models
//! hand the parameters' current values to [`Splitting::declared`] from
//! [`Declared::splitting`](crate::Declared::splitting). A new kind is a stepper of its own and
//! an arm here.

use num_traits::Float;

use super::{RigidBodySplitting, StepOutcome, Stepper};
use crate::error::StepError;
use crate::state::State;

/// A structure-specific splitting, ready to step.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub enum Splitting<T> {
    /// `rigid_body(R, Omega, I)`: the free rigid body by three exact rotations.
    RigidBody(RigidBodySplitting<T>),
}

impl<T: Float> Splitting<T> {
    /// The splitting of kind `kind` (the name after `splitting` in the model file) built from
    /// its parameters' values, in the order the front end records them. `None` for a kind this
    /// runtime does not know or the wrong number of parameters.
    pub fn declared(kind: &str, params: &[T]) -> Option<Self> {
        match (kind, params) {
            ("rigid_body", &[i1, i2, i3]) => {
                Some(Splitting::RigidBody(RigidBodySplitting::new([i1, i2, i3])))
            }
            _ => None,
        }
    }

}

impl<T: Float, X: State<T>, F: ?Sized> Stepper<T, X, F> for Splitting<T> {
    fn step(&mut self, field: &F, t: T, x: &mut X, h: T) -> Result<StepOutcome<T>, StepError> {
        match self {
            Splitting::RigidBody(s) => s.step(field, t, x, h),
        }
    }

    fn order(&self) -> u32 {
        match self {
            Splitting::RigidBody(s) => Stepper::<T, X, F>::order(s),
        }
    }

    fn name(&self) -> String {
        match self {
            Splitting::RigidBody(s) => Stepper::<T, X, F>::name(s),
        }
    }
}
