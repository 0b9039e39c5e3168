//! Run-time access to a generated model's parameters and named points, by name.
//!
//! This is the dynamic face of a model (for CLIs and configuration files); the hot path never
//! goes through it.

/// Why a parameter could not be set.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParamError {
    /// No parameter has this name.
    #[error("unknown parameter `{name}`; the model's parameters are: {known}")]
    Unknown {
        /// The name asked for.
        name: String,
        /// The model's parameter names, comma-separated.
        known: String,
    },
    /// The number of values does not match the parameter's slots.
    #[error("parameter `{name}` takes {expected} value(s), {given} given")]
    WrongLength {
        /// The parameter.
        name: String,
        /// Its number of slots (a `diag(…)` parameter takes its diagonal).
        expected: usize,
        /// The number of values given.
        given: usize,
    },
}

/// Parameters and named points of a generated model, as f64 by name.
pub trait Parameters {
    /// Sets a parameter from its slot values (column-major for matrices, the diagonal for a
    /// parameter declared with `diag(…)`).
    fn set_param(&mut self, name: &str, values: &[f64]) -> Result<(), ParamError>;
    /// The slot values of a parameter.
    fn param(&self, name: &str) -> Option<Vec<f64>>;
    /// The named points of the model (`point paper { … }`).
    fn point_names(&self) -> &'static [&'static str];
    /// A named point's flat state, evaluated with the current parameters.
    fn point(&self, name: &str) -> Option<Vec<f64>>;
}
