//! # lasalle-runtime
//!
//! The traits that lasalle-generated models implement ([`Field`], [`Invariants`],
//! [`Lyapunov`], [`Partitioned`]) and the steppers, observers and outputs that integrate them.
#![warn(missing_docs)]

mod field;

pub use field::{
    lit, Field, InvariantInfo, InvariantKind, Invariants, Lyapunov, ModelInfo, Partitioned, Shape,
    Slot,
};
pub use nalgebra;
pub use num_traits;
