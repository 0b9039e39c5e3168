//! Lowering: resolves names, checks shapes and builds the DAG for every expression.
//!
//! `Lowerer::model` is a short sequence of named passes, each in its own module: the model's
//! name and the symbol table (`symbols`), state and parameters (`state`), every other item in
//! file order (`items`, with `let` bindings in `lets` and named points in `points`), the
//! Hamiltonian route (`hamiltonian`), the check that every state component has an equation
//! (`field`), V (`invariants`), then presets and the splitting. Expressions are lowered in
//! `model::expr`; presets, guards and events in `model::declare`, splittings in `crate::splitting`.

mod field;
mod hamiltonian;
mod invariants;
mod items;
mod lets;
mod points;
mod state;
mod symbols;

use super::*;
use crate::error::{Diagnostic, Error};
use crate::parse::ast::*;
use std::collections::HashMap;

/// What a name in the model refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    State,
    Param,
    Let,
    Invariant,
    Gain,
    Hamiltonian,
}

impl Kind {
    pub(super) fn describe(self) -> &'static str {
        match self {
            Kind::State => "state variable",
            Kind::Param => "parameter",
            Kind::Let => "`let` binding",
            Kind::Invariant => "invariant",
            Kind::Gain => "gain",
            Kind::Hamiltonian => "Hamiltonian",
        }
    }
}

#[derive(Clone)]
pub(super) struct Symbol {
    pub(super) kind: Kind,
    pub(super) value: Value,
    pub(super) span: Span,
}

/// Where an expression is being lowered: what it may refer to.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Ctx {
    /// A parameter default or index: numbers and earlier parameters' defaults only.
    Constant,
    /// Fields, invariants, lets, Hamiltonians, points.
    Model,
    /// An explicit Lyapunov function: also gains and `target(f)`.
    Lyapunov,
}

pub(super) struct Lowerer {
    pub(super) source: Arc<Source>,
    pub(super) g: Graph,
    pub(super) symbols: HashMap<String, Symbol>,
    /// Default values of parameter slots, for constant folding of later defaults.
    pub(super) param_defaults: Vec<f64>,
    /// Names of the gains written anywhere in the file (for messages about misplaced gains).
    pub(super) gain_names: std::collections::HashSet<String>,
    /// Names whose definition failed: uses of them are not reported again.
    pub(super) poisoned: std::collections::HashSet<String>,
    /// Offset and shape of each invariant in the stacked f, for `target(f)`.
    pub(super) invariant_offsets: HashMap<String, (usize, Shape)>,
    pub(super) errors: Vec<Diagnostic>,
    /// The value of every graph node that is a constant (no inputs), by Id; filled in
    /// creation order by `check_finite`.
    pub(super) constants: Vec<Option<f64>>,
    /// The indices bound while a family is unrolled, innermost last (`model::family`).
    pub(super) indices: Vec<(String, i64)>,
    /// The families of vectors among the state and parameters, with their members' shape.
    pub(super) families: HashMap<String, Shape>,
    /// Names used as sizes or range bounds: parameters among them are constants.
    pub(super) sizes: std::collections::HashSet<String>,
    /// The families kept as loops, when loops are on (`crate::loops`).
    pub(super) loops: Option<crate::loops::Collector>,
    /// The family body being lowered with slots (`model::family_loop`).
    pub(super) slot: Option<super::family_loop::SlotMode>,
    /// The switching functions g of the `sign(g)`s met so far (`model::switching`).
    pub(super) switches: Vec<super::switching::Surface>,
    /// The delayed states of the `delay(x, r)`s met so far (`model::delay`).
    pub(super) delays: Vec<super::delay::Lag>,
    /// The number of declared state components: the modes of the switches follow them.
    pub(super) declared_dim: usize,
}

pub(super) type L<T> = Result<T, Diagnostic>;

/// Lowers a parsed model; reports every problem found, not just the first.
pub fn lower(ast: &ModelAst, source: Arc<Source>) -> Result<Model, Error> {
    lower_with(ast, source, None).map(|(m, _)| m)
}

/// [`lower`], keeping the sums of at least `loops` index tuples whose bodies qualify as loop
/// families (`None`: unroll every family). The model's expressions then read each family's
/// value as auxiliary symbols: it is for [`crate::loops`] only.
pub(crate) fn lower_with(
    ast: &ModelAst,
    source: Arc<Source>,
    loops: Option<u64>,
) -> Result<(Model, Vec<crate::loops::Family>), Error> {
    let mut lw = Lowerer {
        source: source.clone(),
        g: Graph::new(),
        symbols: HashMap::new(),
        param_defaults: Vec::new(),
        invariant_offsets: HashMap::new(),
        poisoned: Default::default(),
        gain_names: Default::default(),
        errors: Vec::new(),
        constants: Vec::new(),
        indices: Vec::new(),
        families: HashMap::new(),
        sizes: Lowerer::size_names(ast),
        loops: loops.map(crate::loops::Collector::new),
        slot: None,
        switches: Vec::new(),
        delays: Vec::new(),
        declared_dim: 0,
    };
    let model = lw.model(ast);
    let families = lw.loops.take().map(|c| c.families).unwrap_or_default();
    if lw.errors.is_empty() {
        model
            .map(|m| (m, families))
            .ok_or_else(|| Error::Internal("lowering failed without a diagnostic".into()))
    } else {
        Err(Error::Model(lw.errors))
    }
}

impl Lowerer {
    /// The model, as a sequence of passes; `None` when any reported a problem.
    fn model(&mut self, ast: &ModelAst) -> Option<Model> {
        self.check_model_name(&ast.name);
        // Pass 1: state and parameters, which may be used anywhere.
        let (mut state, params, n) = self.state_and_params(ast);
        self.declared_dim = n;
        // Pass 2: everything else, in order.
        let items::Items {
            mut field,
            mut invariants,
            mut gains,
            lets,
            lyapunov,
            hamiltonian,
            structure,
            points,
            presets,
            guards,
            events,
            splitting: splitting_decl,
        } = self.items(ast, &state, n);
        let hamiltonian = self.hamiltonian_route(
            hamiltonian,
            structure,
            &mut field,
            &mut invariants,
            &mut gains,
        );
        self.check_equations(&state, &field);
        let (lyapunov, lyapunov_span) = self.lyapunov(lyapunov, &invariants);

        if let Err(d) = self.check_presets(&presets, &points, &params, gains.len()) {
            self.errors.push(d);
        }
        if !self.errors.is_empty() {
            return None;
        }
        let (mut field, mut field_spans): (Vec<Id>, Vec<Span>) =
            field.into_iter().map(|f| f.expect("checked above")).unzip();
        let mut events = events;
        let mut points = points;
        let switches = match self.switching(
            &mut state,
            &mut field,
            &mut field_spans,
            &mut events,
            &mut points,
        ) {
            Ok(s) => s,
            Err(d) => {
                self.errors.push(d);
                return None;
            }
        };
        let parts = super::delay::Parts {
            events: &events,
            invariants: &invariants,
            points: &mut points,
            switched: !switches.is_empty(),
        };
        let delays = match self.delaying(&mut state, &mut field, &mut field_spans, parts) {
            Ok(d) => d,
            Err(d) => {
                self.errors.push(d);
                return None;
            }
        };
        let splitting = match splitting_decl {
            Some((kind, args, span)) => {
                let decl = crate::splitting::Declaration {
                    args,
                    span: &span,
                    state: &state,
                    params: &params,
                    field: &field,
                    graph: &self.g,
                };
                match crate::splitting::declare(kind, &decl) {
                    Ok(s) => Some(s),
                    Err(d) => {
                        self.errors.push(d);
                        return None;
                    }
                }
            }
            None => None,
        };
        Some(Model {
            name: ast.name.name.clone(),
            source: self.source.clone(),
            graph: std::mem::take(&mut self.g),
            state,
            params,
            lets,
            field,
            field_spans,
            invariants,
            gains,
            lyapunov,
            lyapunov_span,
            hamiltonian,
            points,
            presets,
            guards,
            events,
            splitting,
            switches,
            delays,
        })
    }
}
