//! Families kept as loops: one body per family with its index tuples as data, instead of one
//! copy of the body per tuple.
//!
//! With [`Families::Loops`] (or [`Families::Auto`] above [`AUTO_MIN_TUPLES`] index tuples), a
//! `sum(i in 0..n, j in i+1..n: body)` whose body reads members of indexed state and
//! parameters (`q[i]`, `q[i + 1]`, `m[j]`) is lowered once: each member component the body
//! reads is a *slot*, and for every index tuple the slot records the flat state (or parameter)
//! index it reads (a *gather* column). Conditions and triangular ranges only decide which
//! tuples there are. The model's expressions read the family's value as an auxiliary symbol.
//!
//! [`LoopModel::tapes`] then builds [`LoopTape`]s: a plain [`Tape`] of everything outside the
//! families, plus one [`Region`] per family a function uses. A region is a tape over the slots
//! (its body runs once per tuple) with, for every output of that body, a *scatter* column: the
//! output of the whole function it is added to, per tuple. So
//! - a sum in an integral or an equation is a reduction (its scatter column is constant);
//! - Hamilton's equations of `H = h₀ + Σ c·family` are `J∇h₀` plus, per family, the body's
//!   gradient with respect to its state slots, taken once symbolically, each partial scattered
//!   to the partner component (`∂g/∂q[i]` to `ṗ[i]` with the sign −c, `∂g/∂p[i]` to `q̇[i]` with +c).
//!
//! A region's code and instruction count are independent of the number of tuples; its tables
//! are linear in it. Outputs are accumulated in tuple order, output after output, after the
//! plain tape: every back end adds in this order, so they agree bit for bit; the unrolled form
//! sums in another order and agrees to rounding.
//!
//! The derived functions are loop tapes too ([`LoopModel::jacobian`], [`LoopModel::feedback`],
//! [`LoopModel::partition`], in `derived`): Df of the integrals (each family term's partials
//! by its state slots, scattered to `row·N + gather`), the half-fields (the field's loop tape
//! restricted to each half), and V, ∇V and X − ∇V in three stages ([`LoopFeedback`]): one
//! pass over each family's tuples giving the family sums S that V reads and carrying C, the
//! families' parts of ∇S and of the field, then V and `w = ∂V/∂S` from `[x, S]`, then
//! `∂V/∂x|_S` plus, per state member, a loop combining C with w, from `[x, S, C, w]`. The
//! integrals are proved on the families' bodies
//! ([`LoopModel::check`]).
//!
//! What the loop form does not do (yet) is refused rather than approximated: a family whose
//! value enters the field or an integral other than linearly with a constant coefficient, a
//! Hamiltonian family under a Lie–Poisson structure, a family that adds to both halves of a
//! partitioned field. The field's Taylor program has a loop form ([`LoopTape::taylor`],
//! [`taylor`]: the body's coefficient recurrences once per tuple, on the coefficients gathered
//! from the state's), and so has the Taylor program of X − ∇V ([`LoopFeedback::taylor`],
//! [`feedback_taylor`]: the three stages propagated as Taylor series — the coefficients of S
//! and C from x's in one pass, w's from x's and S's, then X − ∇V's from x's, S's, C's and w's —
//! on one table). The emitted
//! Rust writes the field, the invariants and the derived functions as loops from these tapes,
//! with the index structure of [`index`] (`lasalle_codegen::generate_source_with`).
//!
//! The variational equations and the chaos indicators have a loop form ([`LoopModel::extend`],
//! in [`variational`]): A·w is, per family, the body's directional derivative along the tangent
//! (its components gathered as slots of a copy of the family), taken once and scattered to the
//! tangent rows. The variational field (X, A·Φ) is one loop tape; the indicators' field, whose
//! rates read λ = u·Au/(u·u), is staged as V's functions are (A·u, then λ and the rates, then X
//! with them), and its Taylor program is that of [`feedback_taylor`] on its stages.

use crate::error::{Diagnostic, Error, Span};
use crate::ir::{FxHashMap, Graph, Id, Input, Node};
use crate::model::{Model, Structure};
use crate::tape::{Dims, Tape, TapeError};

/// Families with at least this many index tuples are loops under [`Families::Auto`].
pub const AUTO_MIN_TUPLES: u64 = 64;

/// How families are lowered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Families {
    /// Loops for sums of at least [`AUTO_MIN_TUPLES`] tuples, unrolled below.
    #[default]
    Auto,
    /// Every qualifying sum is a loop.
    Loops,
    /// Every family is unrolled (the model is an ordinary [`Model`]).
    Unrolled,
}

impl Families {
    /// The least number of tuples of a loop family, `None` when every family is unrolled.
    pub fn min_tuples(self) -> Option<u64> {
        match self {
            Families::Auto => Some(AUTO_MIN_TUPLES),
            Families::Loops => Some(1),
            Families::Unrolled => None,
        }
    }

    /// `auto`, `loops` or `unrolled`.
    pub fn parse(s: &str) -> Option<Families> {
        match s {
            "auto" => Some(Families::Auto),
            "loops" => Some(Families::Loops),
            "unrolled" => Some(Families::Unrolled),
            _ => None,
        }
    }
}

/// The first auxiliary symbol of the loop families (below are the guards' and events' symbols).
const SYMBOL_BASE: u32 = 1 << 24;

/// Collects the loop families while a model is lowered.
pub(crate) struct Collector {
    pub(crate) min_tuples: u64,
    pub(crate) families: Vec<Family>,
    next: u32,
}

impl Collector {
    pub(crate) fn new(min_tuples: u64) -> Collector {
        Collector {
            min_tuples,
            families: Vec::new(),
            next: SYMBOL_BASE,
        }
    }

    /// A fresh auxiliary symbol.
    pub(crate) fn symbol(&mut self) -> u32 {
        self.next += 1;
        self.next - 1
    }
}

/// Where a slot reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Source {
    /// The flat state.
    State,
    /// The parameter slots.
    Param,
}

/// One member component a family's body reads.
#[derive(Clone, Debug)]
pub struct Slot {
    pub(crate) symbol: u32,
    /// Where it reads.
    pub source: Source,
    /// The index it reads, per tuple.
    pub column: Vec<u32>,
    /// The same as an expression of the indices, where one reproduces `column`.
    pub index: Option<index::SlotIndex>,
}

/// A sum kept as a loop.
#[derive(Clone, Debug)]
pub struct Family {
    /// Index tuples.
    pub count: usize,
    /// The member components the body reads.
    pub slots: Vec<Slot>,
    pub(crate) body: Vec<Id>,
    pub(crate) placeholders: Vec<u32>,
    /// The body in the model file.
    pub span: Span,
    /// The head's ranges and conditions, where they reproduce the tuples (see [`index`]).
    pub clauses: Option<Vec<index::LoopClause>>,
}

/// A model lowered with its large families kept as loops. Its functions exist only as
/// [`LoopTape`]s ([`LoopModel::tapes`]).
#[derive(Clone)]
pub struct LoopModel {
    model: Model,
    families: Vec<Family>,
}

impl std::fmt::Debug for LoopModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoopModel")
            .field("name", &self.model.name)
            .field("families", &self.families.len())
            .finish_non_exhaustive()
    }
}

/// The tapes of a [`LoopModel`].
#[derive(Clone, Debug)]
pub struct LoopTapes {
    /// X(x): N outputs.
    pub field: LoopTape,
    /// f(x), the stacked invariants: M outputs.
    pub invariants: LoopTape,
}

/// A function as a plain tape plus loop regions whose outputs are added to its outputs.
#[derive(Clone, Debug)]
pub struct LoopTape {
    /// Everything outside the loop families that is not the constant 0 (its dims are the
    /// function's).
    pub base: Tape,
    /// The function output of each output of `base`, increasing; outputs not listed start at 0.
    pub base_at: Vec<u32>,
    /// Number of outputs of the function.
    pub outputs: usize,
    /// The families, run in order after `base`.
    pub regions: Vec<Region>,
}

/// One family in a function: a tape over its slots, run once per tuple, each output added to
/// the function's output its scatter column names.
#[derive(Clone, Debug)]
pub struct Region {
    /// The body: its state is the slots; its parameters are the model's.
    pub tape: Tape,
    /// Where each slot reads.
    pub sources: Vec<Source>,
    /// Tuple-major: `gather[t·slots + k]` is the index slot k reads for tuple t.
    pub gather: Vec<u32>,
    /// Tuple-major: `scatter[t·outputs + o]` is the function output body output o adds to.
    pub scatter: Vec<u32>,
    /// Index tuples.
    pub count: usize,
    /// The family ([`LoopModel::families`]) the region runs.
    pub family: usize,
}

impl LoopModel {
    /// Parses and lowers a model, keeping families as loops as `families` says.
    pub fn from_source(path: &str, text: &str, families: Families) -> Result<LoopModel, Error> {
        let source = std::sync::Arc::new(crate::error::Source {
            path: path.to_string(),
            text: text.to_string(),
        });
        let ast = crate::parse::parse(&source)?;
        let (model, families) = crate::model::lower_with(&ast, source, families.min_tuples())?;
        Ok(LoopModel { model, families })
    }

    /// The same model with every family unrolled, lowered again from its source: what the
    /// stages without a loop form (the Taylor program of the indicators' field, the lanes on
    /// X − ∇V, a derived function the loop form refuses) need, built only when one of them is
    /// asked for.
    pub fn unrolled(&self) -> Result<Model, Error> {
        let source = &self.model.source;
        crate::lower_source(&source.path, &source.text)
    }

    /// The lowered model whose family sums are auxiliary symbols: its declarations (state,
    /// parameters, invariants, gains, points, presets, guards, events) are the unrolled
    /// model's; its expressions are not (evaluate its functions through the loop tapes).
    pub fn declarations(&self) -> &Model {
        &self.model
    }

    /// The families kept as loops.
    pub fn families(&self) -> &[Family] {
        &self.families
    }

    /// The lowered model, whose family sums are auxiliary symbols: for its declarations (state,
    /// parameters, invariants, gains, points), not to evaluate its functions.
    pub fn lowered(&self) -> &Model {
        &self.model
    }

    /// The model's name.
    pub fn name(&self) -> &str {
        &self.model.name
    }

    /// State components N.
    pub fn dim(&self) -> usize {
        self.model.dim()
    }

    /// Number M of stacked invariant components.
    pub fn invariant_dim(&self) -> usize {
        self.model.invariant_dim()
    }

    /// The default parameter slots.
    pub fn default_params(&self) -> Vec<f64> {
        self.model.default_params()
    }

    /// The field and the invariants as loop tapes. A family whose value enters a function
    /// other than as a term with a constant coefficient, or a Hamiltonian family under a
    /// Lie–Poisson structure, is refused with a located message. V, ∇V and X − ∇V (which read
    /// the invariants) are staged loop tapes of their own ([`LoopModel::feedback`]).
    pub fn tapes(&self) -> Result<LoopTapes, Error> {
        let mut b = Builder::new(self);
        let m = &self.model;
        let dims = Dims {
            state: m.dim(),
            params: m.param_slots(),
            targets: 0,
            gains: 0,
        };
        let (roots, field) = b.field()?;
        let field = b.tape(&roots, dims, field)?;
        let mut inv = Outputs::default();
        let mut roots = Vec::new();
        for f in &m.invariants {
            for (c, &id) in f.value.ids.iter().enumerate() {
                let o = (f.offset + c) as u32;
                roots.push(b.split(id, o, &f.span, &mut inv)?);
            }
        }
        let invariants = b.tape(&roots, dims, inv)?;
        Ok(LoopTapes { field, invariants })
    }
}

/// The family terms of a Hamiltonian under a canonical structure.
pub(crate) struct HamiltonTerms {
    /// The terms `c·body` as reductions into output 0, per family.
    pub(crate) terms: Outputs,
    /// The same terms as `(family, component, c)`.
    pub(crate) coefficients: Vec<(usize, usize, f64)>,
    /// The canonical pairs.
    pub(crate) q: Vec<usize>,
    pub(crate) p: Vec<usize>,
}

/// Per family, the region outputs: (expression, scatter column).
pub(crate) type Outputs = std::collections::BTreeMap<usize, Vec<(Id, Vec<u32>)>>;

/// Builds the loop tapes on a copy of the model's graph.
pub(crate) struct Builder<'a> {
    lm: &'a LoopModel,
    g: Graph,
    /// Placeholder symbol → (family, component).
    placeholder: FxHashMap<u32, (usize, usize)>,
}

impl<'a> Builder<'a> {
    fn new(lm: &'a LoopModel) -> Builder<'a> {
        let mut placeholder = FxHashMap::default();
        for (f, fam) in lm.families.iter().enumerate() {
            for (c, &s) in fam.placeholders.iter().enumerate() {
                placeholder.insert(s, (f, c));
            }
        }
        Builder {
            lm,
            g: lm.model.graph.clone(),
            placeholder,
        }
    }

    /// The field's plain part (per component) and the family outputs of the field.
    fn field(&mut self) -> Result<(Vec<Id>, Outputs), Error> {
        let (roots, mut field, hamiltonian) = self.field_parts()?;
        if let Some(h) = hamiltonian {
            self.hamilton(&h.terms, &h.q, &h.p, &mut field)?;
        }
        Ok((roots, field))
    }

    /// The field's plain part, the family outputs of its explicit part (the reductions it
    /// reads), and the Hamiltonian's family terms whose equations it adds, if any (under a
    /// canonical structure; refused under a Lie–Poisson one).
    pub(crate) fn field_parts(
        &mut self,
    ) -> Result<(Vec<Id>, Outputs, Option<HamiltonTerms>), Error> {
        // The field: explicit part plus reductions, plus Hamilton's equations of the families.
        let lm = self.lm;
        let m = &lm.model;
        let mut field = Outputs::default();
        let mut roots = Vec::with_capacity(m.field.len());
        for (c, &f) in m.field.iter().enumerate() {
            roots.push(self.split(f, c as u32, &m.field_spans[c], &mut field)?);
        }
        let mut hamiltonian = None;
        if let Some(h) = &m.hamiltonian {
            let span = m
                .invariants
                .iter()
                .find(|f| f.name == h.name)
                .map_or_else(|| m.field_spans[0].clone(), |f| f.span.clone());
            let mut terms = Outputs::default();
            self.split(h.h, 0, &span, &mut terms)?;
            if !terms.is_empty() {
                let Structure::Canonical { q, p } = &h.structure else {
                    return Err(self.refuse(
                        &span,
                        "a Lie–Poisson Hamiltonian with a family kept as a loop",
                        "load the model with its families unrolled",
                    ));
                };
                let coefficients = self.coefficients(h.h);
                hamiltonian = Some(HamiltonTerms {
                    terms,
                    coefficients,
                    q: q.clone(),
                    p: p.clone(),
                });
            }
        }
        Ok((roots, field, hamiltonian))
    }

    /// The family terms `(family, component, c)` of `e = e₀ + Σ c·sum`, in symbol order (that of
    /// [`Builder::split`]'s terms), for an `e` that `split` accepts.
    pub(crate) fn coefficients(&mut self, e: Id) -> Vec<(usize, usize, f64)> {
        let used = self.placeholders_in(e);
        let vars: Vec<Input> = used.iter().map(|&s| Input::Symbol(s)).collect();
        let grad = crate::ir::gradient(&mut self.g, e, &vars);
        used.iter()
            .zip(&grad)
            .filter_map(|(s, &d)| {
                let (f, c) = self.placeholder[s];
                self.g.as_num(d).map(|k| (f, c, k))
            })
            .collect()
    }

    /// The family placeholders `e` reads, in the order of [`Graph::reachable`].
    fn placeholders_in(&self, e: Id) -> Vec<u32> {
        self.g
            .reachable(&[e])
            .into_iter()
            .filter_map(|id| match self.g.node(id) {
                Node::Input(Input::Symbol(s)) if self.placeholder.contains_key(s) => Some(*s),
                _ => None,
            })
            .collect()
    }

    fn refuse(&self, span: &Span, what: &str, help: &str) -> Error {
        Error::Model(vec![Diagnostic::new(
            span,
            format!("{what}: it cannot be kept as a loop"),
        )
        .help(help.to_string())])
    }

    fn reads_families(&self, id: Id) -> bool {
        self.g
            .depends_on(id, |i| matches!(i, Input::Symbol(s) if s >= SYMBOL_BASE))
    }

    /// Splits `e` into its part outside the families, returned, and `Σ c·family` terms, added
    /// to `out` as reductions into output `o`.
    fn split(&mut self, e: Id, o: u32, span: &Span, out: &mut Outputs) -> Result<Id, Error> {
        if !self.reads_families(e) {
            return Ok(e);
        }
        let used = self.placeholders_in(e);
        if used.len() != self.g.reachable(&[e]).iter().filter(|&&id| {
            matches!(self.g.node(id), Node::Input(Input::Symbol(s)) if *s >= SYMBOL_BASE)
        }).count()
        {
            return Err(self.refuse(
                span,
                "this expression reads a family's member outside its sum",
                "load the model with its families unrolled",
            ));
        }
        let vars: Vec<Input> = used.iter().map(|&s| Input::Symbol(s)).collect();
        let grad = crate::ir::gradient(&mut self.g, e, &vars);
        for (&s, &d) in used.iter().zip(&grad) {
            let Some(c) = self.g.as_num(d) else {
                return Err(self.refuse(
                    span,
                    "a family's sum enters this expression other than as a term with a constant coefficient",
                    "write the sum as a term of its own, or load the model with its families unrolled",
                ));
            };
            let (f, comp) = self.placeholder[&s];
            let count = self.lm.families[f].count;
            let body = self.lm.families[f].body[comp];
            let coeff = self.g.num(c);
            let term = self.g.mul(&[coeff, body]);
            out.entry(f).or_default().push((term, vec![o; count]));
        }
        let zero = self.g.num(0.0);
        let placeholder = &self.placeholder;
        let e0 = self.g.rebuild(&[e], |_, node| match node {
            Node::Input(Input::Symbol(s)) if placeholder.contains_key(s) => Some(zero),
            _ => None,
        })[0];
        Ok(e0)
    }

    /// Hamilton's equations of the family terms `terms` of H (reductions into output 0 with
    /// their coefficients): each body's gradient with respect to its state slots, once,
    /// scattered to the partner components.
    pub(crate) fn hamilton(
        &mut self,
        terms: &Outputs,
        q: &[usize],
        p: &[usize],
        field: &mut Outputs,
    ) -> Result<(), Error> {
        // partner[s] = (output, sign) for a state component s of the structure.
        let n = self.lm.model.dim();
        let mut partner: Vec<Option<(u32, f64)>> = vec![None; n];
        for (&qa, &pa) in q.iter().zip(p) {
            partner[qa] = Some((pa as u32, -1.0));
            partner[pa] = Some((qa as u32, 1.0));
        }
        for (&f, outs) in terms {
            let fam = &self.lm.families[f];
            for &(term, _) in outs {
                // term = c·body: its gradient w.r.t. the slots is c·∇body.
                let state: Vec<&Slot> = fam
                    .slots
                    .iter()
                    .filter(|s| s.source == Source::State)
                    .collect();
                let vars: Vec<Input> = state.iter().map(|s| Input::Symbol(s.symbol)).collect();
                let grad = crate::ir::gradient(&mut self.g, term, &vars);
                for (slot, &d) in state.iter().zip(&grad) {
                    if self.g.as_num(d) == Some(0.0) {
                        continue;
                    }
                    let mut column = Vec::with_capacity(fam.count);
                    let mut sign = None;
                    for &s in &slot.column {
                        let Some((o, sg)) = partner[s as usize] else {
                            return Err(self.refuse(
                                &fam.span,
                                "this family's body reads state outside the canonical pairs",
                                "load the model with its families unrolled",
                            ));
                        };
                        if *sign.get_or_insert(sg) != sg {
                            return Err(self.refuse(
                                &fam.span,
                                "a member of this family is a position for some indices, a momentum for others",
                                "load the model with its families unrolled",
                            ));
                        }
                        column.push(o);
                    }
                    let sg = self.g.num(sign.unwrap_or(1.0));
                    let rate = self.g.mul(&[sg, d]);
                    field.entry(f).or_default().push((rate, column));
                }
            }
        }
        Ok(())
    }

    /// The loop tape of the plain `roots` and the family outputs `outs`.
    fn tape(&mut self, roots: &[Id], dims: Dims, outs: Outputs) -> Result<LoopTape, Error> {
        let internal = |e: TapeError| Error::Internal(format!("loop tape: {e}"));
        // Outputs that are 0 outside the families (most of a family model's) are not lowered.
        let base_at: Vec<u32> = (0..roots.len() as u32)
            .filter(|&o| self.g.as_num(roots[o as usize]) != Some(0.0))
            .collect();
        let nonzero: Vec<Id> = base_at.iter().map(|&o| roots[o as usize]).collect();
        let base = Tape::from_graph(&self.g, &nonzero, dims).map_err(internal)?;
        let mut regions = Vec::with_capacity(outs.len());
        for (f, outs) in outs {
            let fam = &self.lm.families[f];
            let exprs: Vec<Id> = outs.iter().map(|(e, _)| *e).collect();
            let (graph, local_roots, sources, gather) = self.region_graph(fam, &exprs)?;
            let rdims = Dims {
                state: sources.len(),
                params: dims.params,
                targets: 0,
                gains: 0,
            };
            let tape = Tape::from_graph(&graph, &local_roots, rdims).map_err(internal)?;
            let mut scatter = Vec::with_capacity(fam.count * outs.len());
            for t in 0..fam.count {
                scatter.extend(outs.iter().map(|(_, col)| col[t]));
            }
            regions.push(Region {
                tape,
                sources,
                gather,
                scatter,
                count: fam.count,
                family: f,
            });
        }
        Ok(LoopTape {
            base,
            base_at,
            outputs: roots.len(),
            regions,
        })
    }

    /// The region's expressions in a graph of their own, where state input k is slot k; the
    /// slots' sources and the tuple-major gather table.
    #[allow(clippy::type_complexity)]
    fn region_graph(
        &self,
        fam: &Family,
        exprs: &[Id],
    ) -> Result<(Graph, Vec<Id>, Vec<Source>, Vec<u32>), Error> {
        let mut local: FxHashMap<Input, Input> = FxHashMap::default();
        let mut sources = Vec::new();
        let mut columns: Vec<std::borrow::Cow<'_, [u32]>> = Vec::new();
        for (k, s) in fam.slots.iter().enumerate() {
            local.insert(Input::Symbol(s.symbol), Input::State(k as u32));
            sources.push(s.source);
            columns.push(std::borrow::Cow::Borrowed(&s.column));
        }
        let mut g = Graph::new();
        let mut new: FxHashMap<Id, Id> = FxHashMap::default();
        for id in self.g.reachable(exprs) {
            let n = match self.g.node(id).clone() {
                Node::Num(b) => g.num(f64::from_bits(b)),
                Node::Input(Input::Param(p)) => g.input(Input::Param(p)),
                Node::Input(i @ Input::State(s)) => {
                    // State outside the family: a slot reading the same index every tuple.
                    let l = *local.entry(i).or_insert_with(|| {
                        sources.push(Source::State);
                        columns.push(std::borrow::Cow::Owned(vec![s; fam.count]));
                        Input::State(sources.len() as u32 - 1)
                    });
                    g.input(l)
                }
                Node::Input(i) => match local.get(&i) {
                    Some(&l) => g.input(l),
                    None => {
                        return Err(self.refuse(
                            &fam.span,
                            "this family's body reads another family or an input of V",
                            "load the model with its families unrolled",
                        ))
                    }
                },
                Node::Add(c) => g.add(&c.iter().map(|k| new[k]).collect::<Vec<_>>()),
                Node::Mul(c) => g.mul(&c.iter().map(|k| new[k]).collect::<Vec<_>>()),
                Node::Pow(b, e) => g.pow(new[&b], e),
                Node::Func(f, a) => g.func(f, new[&a]),
                Node::Func2(f, [x, m]) => g.func2(f, new[&x], new[&m]),
            };
            new.insert(id, n);
        }
        let roots = exprs.iter().map(|e| new[e]).collect();
        let mut gather = Vec::with_capacity(fam.count * columns.len());
        for t in 0..fam.count {
            gather.extend(columns.iter().map(|c| c[t]));
        }
        Ok((g, roots, sources, gather))
    }
}

impl Region {
    /// The same region, running family `family`.
    pub(crate) fn with_family(mut self, family: usize) -> Region {
        self.family = family;
        self
    }
}

impl LoopTape {
    /// Input sizes (those of the plain tape).
    pub fn dims(&self) -> Dims {
        self.base.dims
    }

    /// Number of outputs.
    pub fn n_outputs(&self) -> usize {
        self.outputs
    }

    /// Instructions of the code: the plain body and every region's body (independent of the
    /// number of tuples).
    pub fn instructions(&self) -> usize {
        self.base.body.len()
            + self
                .regions
                .iter()
                .map(|r| r.tape.body.len())
                .sum::<usize>()
    }

    /// Checks the plain tape and the regions: every tape well formed, the tables of the right
    /// lengths, every gathered index inside the state or the parameters and every scattered
    /// one inside the outputs (back ends index with them unchecked).
    pub fn validate(&self) -> Result<(), TapeError> {
        self.base.validate()?;
        let d = self.base.dims;
        let bad = |s: String| Err(TapeError::Malformed(s));
        if self.base_at.len() != self.base.outputs.len()
            || self.base_at.windows(2).any(|w| w[0] >= w[1])
            || self
                .base_at
                .last()
                .is_some_and(|&o| o as usize >= self.outputs)
        {
            return bad("the plain outputs' places are not increasing inside the outputs".into());
        }
        for (i, r) in self.regions.iter().enumerate() {
            r.tape.validate()?;
            let (k, o) = (r.sources.len(), r.tape.outputs.len());
            if r.tape.dims.state != k
                || r.tape.dims.params != d.params
                || r.tape.dims.targets != 0
                || r.tape.dims.gains != 0
            {
                return bad(format!("region {i}: its dims do not match its slots"));
            }
            if r.gather.len() != r.count * k || r.scatter.len() != r.count * o {
                return bad(format!("region {i}: tables of the wrong length"));
            }
            for t in 0..r.count {
                for (s, &at) in r.sources.iter().zip(&r.gather[t * k..(t + 1) * k]) {
                    let len = match s {
                        Source::State => d.state,
                        Source::Param => d.params,
                    };
                    if at as usize >= len {
                        return bad(format!("region {i}: tuple {t} gathers index {at} of {len}"));
                    }
                }
            }
            if let Some(&at) = r
                .scatter
                .iter()
                .find(|&&at| at as usize >= self.n_outputs())
            {
                return bad(format!("region {i}: scatters to output {at}"));
            }
        }
        Ok(())
    }

    /// Evaluates the function in f64 directly from the tapes (the reference the back ends
    /// agree with bit for bit).
    pub fn eval(&self, params: &[f64], state: &[f64]) -> Result<Vec<f64>, TapeError> {
        self.eval_with(params, state, &[], &[])
    }

    /// [`LoopTape::eval`] of a function that also reads targets and gains (in its plain part).
    pub fn eval_with(
        &self,
        params: &[f64],
        state: &[f64],
        targets: &[f64],
        gains: &[f64],
    ) -> Result<Vec<f64>, TapeError> {
        self.validate()?;
        let mut out = vec![0.0; self.outputs];
        let plain = self.base.eval(params, state, targets, gains)?;
        for (&o, v) in self.base_at.iter().zip(plain) {
            out[o as usize] = v;
        }
        for r in &self.regions {
            let hoisted = r.tape.hoist(params)?;
            let k = r.sources.len();
            let o = r.tape.outputs.len();
            let mut local = vec![0.0; k];
            for t in 0..r.count {
                for (j, s) in r.sources.iter().enumerate() {
                    let at = r.gather[t * k + j] as usize;
                    local[j] = match s {
                        Source::State => state[at],
                        Source::Param => params[at],
                    };
                }
                let v = r.tape.eval_body(&hoisted, &local, &[], &[])?;
                for (j, x) in v.into_iter().enumerate() {
                    out[r.scatter[t * o + j] as usize] += x;
                }
            }
        }
        Ok(out)
    }
}

mod check;
mod derived;
pub mod feedback_taylor;
pub mod index;
pub mod taylor;
pub mod variational;
pub use derived::{LoopFeedback, LoopPartition};
#[cfg(test)]
mod tests;

pub use feedback_taylor::FeedbackTaylorProgram;
pub use taylor::LoopTaylorProgram;
pub use variational::{ExtendedField, LoopExtension};
