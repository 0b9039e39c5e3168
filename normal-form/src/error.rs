//! The crate's error type.

use std::fmt;
use thiserror::Error;

/// A complex number for error reports, `re ± i·im`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Eigenvalue {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl fmt::Display for Eigenvalue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:.12} {} {:.12}i",
            self.re,
            if self.im < 0.0 { '-' } else { '+' },
            self.im.abs()
        )
    }
}

fn list(eigs: &[Eigenvalue]) -> String {
    eigs.iter()
        .map(|e| e.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

fn ivec(m: &[i32]) -> String {
    format!(
        "({})",
        m.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// Why a normal form could not be computed.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum NormalFormError {
    /// The linearisation has eigenvalues off the imaginary axis, or repeated ones.
    #[error("equilibrium is not elliptic: eigenvalues {}{}", list(.eigenvalues), if *.repeated { " (not distinct)" } else { "" })]
    NotElliptic {
        /// All eigenvalues of the linearised field J·S.
        eigenvalues: Vec<Eigenvalue>,
        /// True when they are on the imaginary axis but not distinct.
        repeated: bool,
    },
    /// Assumption 1′ fails: |m·ω| below the resonance tolerance for some 0 < |m| ≤ N.
    #[error("resonance m = {} at order {order}: m·ω = {m_dot_omega:.3e} (ω = {}); use `--resonant` to keep resonant terms", ivec(.m), list_f(.omega))]
    Resonance {
        /// Integer vector m (relative to the positive frequencies ω).
        m: Vec<i32>,
        /// m·ω
        m_dot_omega: f64,
        /// |m|₁, the lowest degree at which the small divisor appears.
        order: usize,
        /// The frequencies ω.
        omega: Vec<f64>,
    },
    /// Newton's method for ∇H = 0 did not converge.
    #[error("newton iteration for the equilibrium failed after {iterations} iterations (|∇H| = {residual:.3e})")]
    NewtonFailed {
        /// Iterations done.
        iterations: usize,
        /// Final gradient norm.
        residual: f64,
    },
    /// The given point is not an equilibrium.
    #[error("the point is not an equilibrium: |∇H| = {gradient_norm:.3e}")]
    NotAnEquilibrium {
        /// |∇H| at the point.
        gradient_norm: f64,
    },
    /// A size or option is out of range.
    #[error("invalid input: {0}")]
    Invalid(String),
    /// The series produced NaN or ∞ (e.g. a singular Hamiltonian at the point).
    #[error("non-finite coefficients in {0}")]
    NonFinite(&'static str),
    /// The model could not be loaded or is not a canonical Hamiltonian system.
    #[error("model: {0}")]
    Model(String),
}

fn list_f(w: &[f64]) -> String {
    w.iter()
        .map(|x| format!("{x:.12}"))
        .collect::<Vec<_>>()
        .join(", ")
}
