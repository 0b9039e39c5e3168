//! Structure-specific splittings: `splitting KIND(ARGS);` in a model file.
//!
//! A splitting integrates one particular structure exactly piece by piece (the free rigid
//! body's three rotations), so the generator must check that the model really has that
//! structure before it lets `-m splitting` run. Each kind lives in its own module with its
//! check, and [`SPLITTINGS`] lists them, as `vocabulary.rs` lists the language. The rest of
//! the pipeline is generic over the kinds: a model carries a [`Splitting`] (its kind's name
//! and the parameter slots its runtime stepper takes), the back ends pass the parameters'
//! current values to `lasalle_runtime::Splitting::declared`, and that builds the stepper.
//!
//! Adding a kind touches three places: a module here with its check, a row of [`SPLITTINGS`],
//! and a stepper in the runtime with its arm in `Splitting::declared`.

mod rigid_body;

use crate::error::{Diagnostic, Span};
use crate::ir::{Graph, Id};
use crate::model::{Param, StateVar};
use crate::parse::ast::Ident;

/// A structure-specific splitting a model admits, checked against its field.
#[derive(Clone, Debug, PartialEq)]
pub struct Splitting {
    /// The kind, as written after `splitting` (a name of [`SPLITTINGS`]).
    pub kind: &'static str,
    /// The parameter slots the kind's stepper is built from, in its order (for `rigid_body`:
    /// the principal moments I₁, I₂, I₃).
    pub params: Vec<u32>,
}

/// What a `splitting` item declares, for a kind's check.
pub(crate) struct Declaration<'a> {
    /// The arguments, as written.
    pub args: &'a [Ident],
    /// The whole item.
    pub span: &'a Span,
    /// The model's state variables, parameters and field (one node per state component).
    pub state: &'a [StateVar],
    pub params: &'a [Param],
    pub field: &'a [Id],
    pub graph: &'a Graph,
}

/// One kind of splitting: its name, its arguments, what it integrates and its check.
pub struct SplittingKind {
    /// The name after `splitting`.
    pub name: &'static str,
    /// The arguments' roles, for messages and docs.
    pub args: &'static [&'static str],
    /// What the splitting integrates, for messages and docs.
    pub doc: &'static str,
    check: fn(&Declaration) -> Result<Vec<u32>, Diagnostic>,
}

/// Every splitting kind the language knows.
pub const SPLITTINGS: &[SplittingKind] = &[SplittingKind {
    name: "rigid_body",
    args: &["R", "Omega", "I"],
    doc: "the free rigid body Ṙ = RΩ̂, Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω), by three exact rotations",
    check: rigid_body::check,
}];

impl SplittingKind {
    /// `rigid_body(R, Omega, I)`.
    pub fn signature(&self) -> String {
        format!("{}({})", self.name, self.args.join(", "))
    }
}

/// Checks `splitting KIND(ARGS);` against the model: the kind exists, takes these arguments
/// and the model has its structure.
pub(crate) fn declare(kind: &Ident, decl: &Declaration) -> Result<Splitting, Diagnostic> {
    let Some(k) = SPLITTINGS.iter().find(|k| k.name == kind.name) else {
        let known: Vec<String> = SPLITTINGS
            .iter()
            .map(|k| format!("`{}`", k.signature()))
            .collect();
        return Err(
            Diagnostic::new(&kind.span, format!("unknown splitting `{}`", kind.name))
                .help(format!("known splittings: {}", known.join(", "))),
        );
    };
    if decl.args.len() != k.args.len() {
        return Err(Diagnostic::new(
            decl.span,
            format!(
                "`{}` takes {} arguments ({}), {} given",
                k.name,
                k.args.len(),
                k.args.join(", "),
                decl.args.len()
            ),
        ));
    }
    Ok(Splitting {
        kind: k.name,
        params: (k.check)(decl)?,
    })
}
