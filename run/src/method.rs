//! The method grammar: [`Method`] and its explicit Runge–Kutta [`Base`], parsed from and
//! written as the names `lasalle run -m` takes (`feedback-rk4`, `projection-euler`,
//! `stormer-verlet-a`, `split-taylor`, …), as [`GainPolicy`](lasalle_runtime::GainPolicy)
//! is from `--gains`.

use std::fmt;
use std::str::FromStr;

use lasalle_runtime::VerletVariant;

use crate::RunError;

/// An explicit Runge–Kutta base method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Base {
    /// Explicit Euler (order 1).
    Euler,
    /// Heun (order 2).
    Heun,
    /// Classical Runge–Kutta (order 4).
    Rk4,
    /// Adaptive Dormand–Prince 5(4) with the tolerances `rtol` and `atol`.
    Dopri5,
}

impl Base {
    /// Every base method.
    pub const ALL: [Base; 4] = [Base::Euler, Base::Heun, Base::Rk4, Base::Dopri5];

    /// The order of the method (of the propagated solution for `dopri5`).
    pub fn order(self) -> u32 {
        match self {
            Base::Euler => 1,
            Base::Heun => 2,
            Base::Rk4 => 4,
            Base::Dopri5 => 5,
        }
    }

    /// The name: `euler`, `heun`, `rk4`, `dopri5`.
    pub fn name(self) -> &'static str {
        match self {
            Base::Euler => "euler",
            Base::Heun => "heun",
            Base::Rk4 => "rk4",
            Base::Dopri5 => "dopri5",
        }
    }
}

impl fmt::Display for Base {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Base {
    type Err = RunError;

    fn from_str(s: &str) -> Result<Self, RunError> {
        let key = s.trim().to_lowercase();
        Base::ALL
            .into_iter()
            .find(|b| b.name() == key)
            .ok_or_else(|| RunError::UnknownMethod(s.to_string()))
    }
}

/// A method: how a run steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// A base method on the model's own field X.
    Plain(Base),
    /// A base method on the feedback field X − ∇V (a feedback integrator).
    Feedback(Base),
    /// A base method on X followed by the projection onto {f = f(x₀)} (GNI §IV.4).
    Projection(Base),
    /// Störmer–Verlet A (GNI (3.4)) or B (GNI (3.5)); partitioned models only.
    StormerVerlet(VerletVariant),
    /// A symmetric composition of Störmer–Verlet of order 4, 6 or 8
    /// ([`lasalle_runtime::Composition`]); partitioned models only.
    Symplectic {
        /// 4, 6 or 8.
        order: u32,
    },
    /// The three-rotation splitting of the free rigid body (GNI §VII.5).
    Splitting,
    /// The Taylor method of adaptive order and step (Jorba & Zou 2005) with tolerance
    /// `rtol`, on X or (`feedback`) on X − ∇V, over the model's Taylor kernels (emitted
    /// for compiled models; for loaded ones compiled by the JIT, or interpreted).
    Taylor {
        /// On the feedback field X − ∇V.
        feedback: bool,
    },
    /// The split step: a Taylor step of X, then one explicit gradient step x ← x − h∇V
    /// (`lasalle_runtime::Taylor::set_split`); a feedback method (the gains apply).
    SplitTaylor,
}

impl Method {
    /// Every accepted spelling, for messages.
    pub fn known() -> String {
        let mut v: Vec<String> = Base::ALL.iter().map(|b| b.name().to_string()).collect();
        v.extend(Base::ALL.iter().map(|b| format!("feedback-{}", b.name())));
        v.extend(Base::ALL.iter().map(|b| format!("projection-{}", b.name())));
        v.extend(
            [
                "stormer-verlet-a",
                "stormer-verlet-b",
                "symplectic4",
                "symplectic6",
                "symplectic8",
                "splitting",
                "taylor",
                "feedback-taylor",
                "split-taylor",
            ]
            .map(String::from),
        );
        v.join(", ")
    }

    /// Is this a feedback integrator (the gains apply)?
    pub fn is_feedback(self) -> bool {
        matches!(
            self,
            Method::Feedback(_) | Method::Taylor { feedback: true } | Method::SplitTaylor
        )
    }

    /// Does the method choose its own step sizes?
    pub fn is_adaptive(self) -> bool {
        matches!(
            self,
            Method::Plain(Base::Dopri5)
                | Method::Feedback(Base::Dopri5)
                | Method::Projection(Base::Dopri5)
                | Method::Taylor { .. }
                | Method::SplitTaylor
        )
    }

    /// Is this a Taylor method (one tolerance ε: `rtol` and `atol` are the same)?
    pub fn is_taylor(self) -> bool {
        matches!(self, Method::Taylor { .. } | Method::SplitTaylor)
    }

    /// Why `setting` does not apply to this method, or `None` where it does: what every front
    /// end refuses, each naming the setting its own way (`--rtol`, `rtol=`).
    pub fn refuses(self, setting: MethodSetting) -> Option<String> {
        match setting {
            MethodSetting::Rtol | MethodSetting::Atol if !self.is_adaptive() => Some(format!(
                "applies to adaptive methods (dopri5, feedback-dopri5, projection-dopri5, taylor, \
                 feedback-taylor, split-taylor); `{self}` takes fixed steps of dt"
            )),
            MethodSetting::Gains if !self.is_feedback() => Some(format!(
                "applies to feedback methods (feedback-*, feedback-taylor, split-taylor), not to \
                 `{self}`"
            )),
            MethodSetting::ProjectionTol if !matches!(self, Method::Projection(_)) => Some(
                format!("applies to the projection methods (projection-*), not to `{self}`"),
            ),
            _ => None,
        }
    }
}

/// A setting that applies to some methods only ([`Method::refuses`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MethodSetting {
    /// The relative tolerance of adaptive methods.
    Rtol,
    /// The absolute tolerance of adaptive methods.
    Atol,
    /// The gains of feedback methods.
    Gains,
    /// The tolerance of the projection methods.
    ProjectionTol,
}

impl MethodSetting {
    /// Every setting, in the order front ends check them.
    pub const ALL: [MethodSetting; 4] = [
        MethodSetting::Rtol,
        MethodSetting::Atol,
        MethodSetting::Gains,
        MethodSetting::ProjectionTol,
    ];

    /// The setting's name, as [`RunSpecBuilder`](crate::RunSpecBuilder)'s setter calls it.
    pub fn name(self) -> &'static str {
        match self {
            MethodSetting::Rtol => "rtol",
            MethodSetting::Atol => "atol",
            MethodSetting::Gains => "gains",
            MethodSetting::ProjectionTol => "projection_tol",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Method::Plain(b) => f.write_str(b.name()),
            Method::Feedback(b) => write!(f, "feedback-{}", b.name()),
            Method::Projection(b) => write!(f, "projection-{}", b.name()),
            Method::StormerVerlet(VerletVariant::A) => f.write_str("stormer-verlet-a"),
            Method::StormerVerlet(VerletVariant::B) => f.write_str("stormer-verlet-b"),
            Method::Symplectic { order } => write!(f, "symplectic{order}"),
            Method::Splitting => f.write_str("splitting"),
            Method::Taylor { feedback: false } => f.write_str("taylor"),
            Method::Taylor { feedback: true } => f.write_str("feedback-taylor"),
            Method::SplitTaylor => f.write_str("split-taylor"),
        }
    }
}

impl FromStr for Method {
    type Err = RunError;

    /// The names of [`Method::known`], in any case, with `_` for `-`; also `sv-a`, `verlet-a`
    /// and `stormer-verlet` for Störmer–Verlet A (`sv-b`, `verlet-b` for B).
    fn from_str(s: &str) -> Result<Self, RunError> {
        let key = s.trim().to_lowercase().replace('_', "-");
        let base = |b: &str| Base::ALL.into_iter().find(|x| x.name() == b);
        let found = match key.as_str() {
            "stormer-verlet-a" | "sv-a" | "verlet-a" | "stormer-verlet" => {
                Some(Method::StormerVerlet(VerletVariant::A))
            }
            "stormer-verlet-b" | "sv-b" | "verlet-b" => {
                Some(Method::StormerVerlet(VerletVariant::B))
            }
            "symplectic4" => Some(Method::Symplectic { order: 4 }),
            "symplectic6" => Some(Method::Symplectic { order: 6 }),
            "symplectic8" => Some(Method::Symplectic { order: 8 }),
            "splitting" => Some(Method::Splitting),
            "taylor" => Some(Method::Taylor { feedback: false }),
            "feedback-taylor" => Some(Method::Taylor { feedback: true }),
            "split-taylor" => Some(Method::SplitTaylor),
            k => {
                if let Some(rest) = k.strip_prefix("feedback-") {
                    base(rest).map(Method::Feedback)
                } else if let Some(rest) = k.strip_prefix("projection-") {
                    base(rest).map(Method::Projection)
                } else {
                    base(k).map(Method::Plain)
                }
            }
        };
        found.ok_or_else(|| RunError::UnknownMethod(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_known_name_parses_back_to_itself() {
        for name in Method::known().split(", ") {
            let m: Method = name.parse().unwrap();
            assert_eq!(m.to_string(), name);
        }
        assert_eq!(
            "Feedback_RK4".parse::<Method>().unwrap(),
            Method::Feedback(Base::Rk4)
        );
        assert_eq!(
            "sv-b".parse::<Method>().unwrap(),
            Method::StormerVerlet(VerletVariant::B)
        );
        assert_eq!("heun".parse::<Base>().unwrap(), Base::Heun);
        let e = "nope".parse::<Method>().unwrap_err();
        assert!(e
            .to_string()
            .starts_with("unknown method `nope`; known methods: euler"));
    }
}
