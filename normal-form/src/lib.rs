//! lasalle-normal-form
#![warn(missing_docs)]

mod complex;
mod dd;
pub mod jet;
mod monomial;
pub mod poly;
mod scalar;

pub use complex::Complex;
pub use dd::Dd;
pub use jet::{Jet, Scalar};
pub use monomial::{binomial, MonomialTable};
pub use poly::Poly;
pub use scalar::{Coeff, Real};
