//! [`RunError`]: why a run could not start.

use std::fmt;

/// Why a run could not start (or a setting could not be resolved). A run that starts and then
/// fails — blows up, leaves the model's domain, drifts past its bound — is not an error: its
/// [`Recording`](crate::Recording) holds the samples up to the failure and the
/// [`failure`](crate::Recording::failure).
///
/// The message (`Display`) is the whole story; the variants tell front ends what kind of
/// mistake it was.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum RunError {
    /// A method name that is not one of [`Method::known`](crate::Method::known).
    UnknownMethod(String),
    /// A setting that is neither given nor declared by the preset: `"dt"` (fixed-step
    /// methods) or `"t_end"`.
    Missing(&'static str),
    /// Settings out of range or contradicting each other (a negative step, a tolerance of 0,
    /// gains for a method without feedback, …).
    Spec(String),
    /// A setting given for a method it does not apply to: tolerances for a fixed-step method,
    /// gains for a method without feedback ([`Method::refuses`](crate::Method::refuses)).
    Inapplicable {
        /// The setting given.
        setting: crate::MethodSetting,
        /// The method it does not apply to.
        method: crate::Method,
    },
    /// What the model cannot do: a method that needs structure it does not declare, gains of
    /// the wrong count, an unknown parameter or point, an initial state outside its domain.
    Model(String),
    /// The model could not be read or loaded.
    Load(String),
    /// The run was stopped from outside before it started or ended
    /// ([`Interrupt`](crate::Interrupt)).
    Interrupted,
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::UnknownMethod(given) => write!(
                f,
                "unknown method `{given}`; known methods: {}",
                crate::Method::known()
            ),
            RunError::Missing(what) => write!(
                f,
                "no `{what}`: give one, or declare it in the model's run preset \
                 (`run NAME {{ {what} = …; }}`)"
            ),
            RunError::Inapplicable { setting, method } => write!(
                f,
                "`{}` {}",
                setting.name(),
                method.refuses(*setting).unwrap_or_default()
            ),
            RunError::Spec(m) | RunError::Model(m) | RunError::Load(m) => f.write_str(m),
            RunError::Interrupted => f.write_str("interrupted"),
        }
    }
}

impl std::error::Error for RunError {}
