//! The lowered model: the syntax tree resolved into shaped values over one DAG.

mod canonical;
mod declare;
mod delay;
mod expr;
mod family;
mod family_loop;
mod lower;
mod structure;
mod switching;
mod value;

pub use canonical::{CanonicalHamiltonian, NotCanonical};
pub use delay::{Delay, MAX_DELAYS};
pub use lower::lower;
pub(crate) use lower::lower_with;
pub use switching::Switch;
pub use value::{Shape, Value};

use crate::error::{Source, Span};
use crate::ir::{Graph, Id};
use std::sync::Arc;

/// A state variable and its place in the flat state x ∈ Rᴺ.
#[derive(Clone, Debug)]
pub struct StateVar {
    /// Name in the model file.
    pub name: String,
    /// Shape.
    pub shape: Shape,
    /// Index of its first component in x.
    pub offset: usize,
    /// Where it is declared.
    pub span: Span,
}

/// A parameter with its default value, stored in scalar slots.
#[derive(Clone, Debug)]
pub struct Param {
    /// Name in the model file.
    pub name: String,
    /// Shape of the value it stands for.
    pub shape: Shape,
    /// Declared as `diag(…)`: only the diagonal is stored (and overridable).
    pub diagonal: bool,
    /// First scalar slot.
    pub offset: usize,
    /// Default values of its slots (column-major; the diagonal for `diag`).
    pub defaults: Vec<f64>,
    /// Where it is declared.
    pub span: Span,
}

impl Param {
    /// Number of scalar slots.
    pub fn slots(&self) -> usize {
        self.defaults.len()
    }
}

pub use lasalle_layout::InvariantKind;

/// A constraint or first integral, a block of the stacked f ∈ Rᴹ.
#[derive(Clone, Debug)]
pub struct Invariant {
    /// Name.
    pub name: String,
    /// Constraint or integral.
    pub kind: InvariantKind,
    /// Its value.
    pub value: Value,
    /// Index of its first component in f.
    pub offset: usize,
    /// Index of its gain.
    pub gain: usize,
    /// Added by the generator (Hamiltonian, Casimir) rather than written.
    pub automatic: bool,
    /// Where it is declared (or the item that implied it).
    pub span: Span,
}

/// A gain kᵢ: a runtime input of V with a default.
#[derive(Clone, Debug)]
pub struct Gain {
    /// Name (`k1`, or `k_<invariant>` when not named).
    pub name: String,
    /// Default value.
    pub default: f64,
}

/// How a Hamiltonian becomes a field.
#[derive(Clone, Debug)]
pub enum Structure {
    /// q̇ = ∂H/∂p, ṗ = −∂H/∂q, with q and p given as flat state indices.
    Canonical {
        /// Position components.
        q: Vec<usize>,
        /// Momentum components.
        p: Vec<usize>,
    },
    /// Ṗ = P × ∇H on so(3)*, P given as three flat state indices.
    LiePoissonSo3 {
        /// The momentum components.
        p: Vec<usize>,
    },
}

/// `hamiltonian H = …` with its structure.
#[derive(Clone, Debug)]
pub struct Hamiltonian {
    /// The name (`H`).
    pub name: String,
    /// H(x).
    pub h: Id,
    /// The Poisson structure.
    pub structure: Structure,
}

/// A named point (an equilibrium, an initial condition) as expressions of the parameters.
#[derive(Clone, Debug)]
pub struct Point {
    /// Name.
    pub name: String,
    /// The flat state, component by component.
    pub values: Vec<Id>,
    /// Where it is declared.
    pub span: Span,
}

/// A run preset (`run paper { method = feedback_euler; dt = 0.005; … }`): the settings a
/// command-line run uses unless a flag overrides them. Every setting is optional.
#[derive(Clone, Debug)]
pub struct Preset {
    /// Name.
    pub name: String,
    /// The method, as the command line spells it (`feedback-euler`; `_` and `-` agree).
    pub method: Option<String>,
    /// Step size (the initial step of adaptive methods).
    pub dt: Option<f64>,
    /// End time.
    pub t_end: Option<f64>,
    /// Record every n-th step.
    pub every: Option<u64>,
    /// The named point to start from.
    pub init: Option<String>,
    /// Gains of feedback methods, one per gain of the model.
    pub gains: Option<Vec<f64>>,
    /// Parameter values (`c1 = 4;`), each parameter's slots in the order of `--param`.
    pub params: Vec<(String, Vec<f64>)>,
    /// Where it is declared.
    pub span: Span,
}

/// A domain guard (`guard collision: norm(x) > 1e-6;`): a condition every state of a run must
/// satisfy; a run stops with an error naming the guard when it fails.
#[derive(Clone, Debug)]
pub struct Guard {
    /// Name.
    pub name: String,
    /// The margin: lhs − rhs for `>`/`>=`, rhs − lhs for `<`/`<=`; the guard holds when it is
    /// positive (`strict`) or non-negative. It may depend on the state, the parameters and
    /// the step size [`GUARD_STEP`].
    pub margin: Id,
    /// `>`/`<` (true) or `>=`/`<=` (false).
    pub strict: bool,
    /// The condition as written in the model file.
    pub condition: String,
    /// Where it is declared.
    pub span: Span,
}

/// The step size `dt` in a guard's condition (0 for adaptive methods).
pub const GUARD_STEP: crate::ir::Input = crate::ir::Input::Symbol(0);

/// Which crossings of zero an [`Event`] counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Both (the default).
    Both,
    /// `rising`: from negative to positive.
    Rising,
    /// `falling`: from positive to negative.
    Falling,
}

/// An event (`event pericentre: dot(x, v) = 0 rising;`): the times where a scalar of the state,
/// the parameters and the time crosses zero, located during runs; a `stop` event ends the run.
#[derive(Clone, Debug)]
pub struct Event {
    /// Name.
    pub name: String,
    /// The scalar g whose zeros are the event, of the state, the parameters and the time
    /// [`EVENT_TIME`].
    pub value: Id,
    /// Which crossings count.
    pub direction: Direction,
    /// Does the event end the run?
    pub terminal: bool,
    /// The expression as written in the model file.
    pub expr: String,
    /// Where it is declared.
    pub span: Span,
}

/// The time `t` in an event's expression.
pub const EVENT_TIME: crate::ir::Input = crate::ir::Input::Symbol(1);

/// A `let` binding, kept so generated code can name its temporaries after it.
#[derive(Clone, Debug)]
pub struct Binding {
    /// Name.
    pub name: String,
    /// Value.
    pub value: Value,
    /// The item's span.
    pub span: Span,
}

/// A model resolved into one expression DAG.
#[derive(Clone)]
pub struct Model {
    /// The name after `model`.
    pub name: String,
    /// The file it came from.
    pub source: Arc<Source>,
    /// All expressions.
    pub graph: Graph,
    /// State variables in declaration order.
    pub state: Vec<StateVar>,
    /// Parameters in declaration order.
    pub params: Vec<Param>,
    /// `let` bindings in order.
    pub lets: Vec<Binding>,
    /// X(x), one node per state component.
    pub field: Vec<Id>,
    /// For each state component, the span of the item that defines its derivative.
    pub field_spans: Vec<Span>,
    /// Constraints and integrals in declaration order.
    pub invariants: Vec<Invariant>,
    /// Gains in the order of the gains array.
    pub gains: Vec<Gain>,
    /// V(x).
    pub lyapunov: Id,
    /// The `lyapunov` item, if V was written explicitly.
    pub lyapunov_span: Option<Span>,
    /// The Hamiltonian, if the model has one.
    pub hamiltonian: Option<Hamiltonian>,
    /// Named points.
    pub points: Vec<Point>,
    /// Run presets, in declaration order (the first is the default).
    pub presets: Vec<Preset>,
    /// Domain guards.
    pub guards: Vec<Guard>,
    /// Events, in declaration order.
    pub events: Vec<Event>,
    /// The structure-specific splitting the model admits, if any.
    pub splitting: Option<crate::splitting::Splitting>,
    /// The switching surfaces of its `sign(g)`s, in order of appearance (`model::switching`).
    pub switches: Vec<Switch>,
    /// The delayed states of its `delay(x, r)`s, in order of appearance (`model::delay`).
    pub delays: Vec<Delay>,
}

impl Model {
    /// Dimension N of the flat state.
    pub fn dim(&self) -> usize {
        self.state.iter().map(|s| s.shape.len()).sum()
    }

    /// Number M of stacked invariant components.
    pub fn invariant_dim(&self) -> usize {
        self.invariants.iter().map(|f| f.value.shape.len()).sum()
    }

    /// Number of scalar parameter slots.
    pub fn param_slots(&self) -> usize {
        self.params.iter().map(Param::slots).sum()
    }

    /// The default parameter slots.
    pub fn default_params(&self) -> Vec<f64> {
        self.params
            .iter()
            .flat_map(|p| p.defaults.iter().copied())
            .collect()
    }

    /// The stacked invariant nodes f(x).
    pub fn invariant_ids(&self) -> Vec<Id> {
        self.invariants
            .iter()
            .flat_map(|f| f.value.ids.iter().copied())
            .collect()
    }

    /// The parameter called `name`.
    pub fn param(&self, name: &str) -> Option<&Param> {
        self.params.iter().find(|p| p.name == name)
    }

    /// The point called `name`, evaluated with the given parameter slots.
    pub fn point_values(&self, name: &str, params: &[f64]) -> Option<Vec<f64>> {
        let point = self.points.iter().find(|p| p.name == name)?;
        Some(self.graph.eval_f64(&point.values, &mut |i| match i {
            crate::ir::Input::Param(k) => params[k as usize],
            _ => f64::NAN,
        }))
    }
}
