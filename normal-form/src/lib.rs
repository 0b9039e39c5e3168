//! lasalle-normal-form
#![warn(missing_docs)]

mod complex;
mod dd;
mod emit;
mod error;
mod hamiltonian;
pub mod jet;
mod lie;
pub mod linalg;
mod linear;
pub mod models;
pub mod model;
mod monomial;
mod normal_form;
mod output;
pub mod poly;
pub mod validate;
mod scalar;

pub use complex::Complex;
pub use dd::Dd;
pub use error::{Eigenvalue, NormalFormError};
pub use hamiltonian::{find_equilibrium, taylor, Equilibrium, HamiltonianFn};
pub use jet::{Jet, Scalar};
pub use monomial::{binomial, MonomialTable};
pub use normal_form::{
    normalize, ActionTerm, ArnoldMoser, Diagnostics, NormalForm, Options, Point, PolyMap, Precision, ResonantTerm,
    SmallDivisor, Term, Timings, Value,
};
pub use poly::Poly;
pub use scalar::{Coeff, Real};
pub use model::{normalize_model, normalize_model_file, ModelHamiltonian, ModelPoint};
