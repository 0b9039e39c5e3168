//! The execution IR: a linear register tape lowered from the DAG the way the emitter writes
//! Rust, so that an interpreter or a JIT computes what the generated code computes.
//!
//! A [`Tape`] has two sections of single-assignment instructions: every [`Op`] defines one new
//! register whose index is the instruction's index in its section, and reads only earlier
//! registers of the same section.
//! - `prelude` holds the instructions that depend on parameters and constants only; it runs
//!   once per parameter set. `hoisted` lists the prelude registers the body needs.
//! - `body` runs per call: it reads the state, the targets, the gains, the hoisted values
//!   ([`Op::Hoisted`]) and constants, never a parameter. `outputs` are body registers.
//!
//! # Lowering
//!
//! [`TapeBuilder::build`] first runs the emitter's rewrites
//! ([`Graph::optimize_for_emission`]: factored sums, one root and one reciprocal per base,
//! grouped parameter-only factors, shared sub-products), then writes each node exactly as
//! `lasalle_codegen`'s `emit::body` renders it:
//! - a sum is a left fold with the positive terms first (`a + b - c`, stable order); a term is
//!   negative when it is a negative number or a product with a negative coefficient that is not
//!   a shared temporary; a leading negative term is negated (`-c + a`);
//! - a product `c·f₁·f₂·g₁⁻ⁿ` is the left fold `c * f₁ * f₂ / g₁ⁿ` (factors with a negative
//!   exponent become divisions unless they are values of their own, shared temporaries or
//!   parameter-only values, which are multiplied; in a parameter-only product they are always
//!   divisions, so a prelude value does not depend on the function); a negative coefficient
//!   negates the product of its magnitude;
//! - `xⁿ` is [`Op::Powi`], `x^(n/2)` is `Powi(Sqrt(x), n)`, `x^(1/3)` is [`Op::Cbrt`], other
//!   rationals are [`Op::Powf`], and a lone negative power is `1 / x^|e|`.
//!
//! Hence, for every op, evaluating the tape in f64 is **bitwise** equal to the emitted Rust
//! evaluated in f64: each tape instruction is one IEEE operation or one call of the same `std`
//! function (or `lasalle_runtime::elliptic` kernel, for K, sn, cn, dn, F) the emitted code calls (`x - y` and `x + (-y)` are the same IEEE operation, so a
//! negative term may be subtracted or added negated; `Powi` is the binary exponentiation that
//! `f64::powi` performs, see [`powi`]). For bitwise equality the builder must start from the
//! graph the emitter starts from (the [`Derived`](crate::Derived) model) and lower the functions in
//! the emitter's order, as [`ModelTapes::new`] does: the rewrites add nodes, and new nodes' Ids
//! decide the order of sums. With another graph or order the values may differ by rounding
//! (a few ulps relative to the size of the terms of a sum), never more.
//!
//! The lowering differs from [`Graph::eval`] (the DAG evaluated as is, without the emission
//! rewrites) in the order of sums and products, in `x^(n/2)` (`Powi(Sqrt)` here, `powf` there
//! for n ≠ ±1) and in `x^(1/3)` (`cbrt` here, `powf` there: they differ for x < 0, where
//! `powf` is NaN).
//!
//! `tests/tape_vs_emitted.rs` (root crate) checks the bitwise claim against the emitted code
//! of every model in `models/`, for every function, on the tape and on both back ends of
//! `lasalle-exec`.
//!
//! [`Graph::eval`] stays the plain DAG walk and is not a wrapper over a tape: a tape that
//! matches the emitter needs the emission rewrites, which extend the graph (`&mut`, or a clone
//! per call), and it would change which [`Scalar`] operations run (`sqrt` then `powi` for
//! `x^(3/2)` where `Graph::eval` calls `powf`), hence the truncated power series of the
//! normal-form crate; and for those series the arithmetic dominates, so a tape built per call
//! would only add work. Use [`Tape::eval`] for values that must match the emitted code.
//!
//! Every instruction is computed once: equal instructions are numbered once (value numbering),
//! each DAG node is lowered once, constants are pooled per section, and every instruction
//! whose operands are all parameters or constants goes to the prelude (hoisting works at the
//! level of instructions, so the parameter-only prefix `c * mu` of `c * mu * x` is hoisted).

mod model;
pub mod step;
pub mod taylor;

pub use model::{ModelTapes, Partition};

use crate::ir::{Func, Func2, Graph, Id, Input, Node, Rational, Scalar};
use crate::ir::{FxHashMap as HashMap, FxHashSet as HashSet};
use std::fmt;
use std::time::Duration;

/// A register: the index of the instruction that defines it, in its section.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Reg(pub u32);

impl Reg {
    /// The index as usize.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// One instruction. Leaves read an input; the others combine earlier registers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
    /// Component of the state (body only).
    State(u32),
    /// Parameter slot (prelude only).
    Param(u32),
    /// Component of the target f(x₀) (body only).
    Target(u32),
    /// Gain slot (body only).
    Gain(u32),
    /// Value of the prelude register `hoisted[i]` (body only).
    Hoisted(u32),
    /// A constant.
    Const(f64),
    /// a + b
    Add(Reg, Reg),
    /// a − b
    Sub(Reg, Reg),
    /// a · b
    Mul(Reg, Reg),
    /// a / b
    Div(Reg, Reg),
    /// −a
    Neg(Reg),
    /// aⁿ by binary exponentiation, exactly as `f64::powi` ([`powi`]); n < 0 gives 1/a^|n|.
    Powi(Reg, i32),
    /// √a (correctly rounded)
    Sqrt(Reg),
    /// ∛a, as `f64::cbrt`
    Cbrt(Reg),
    /// aᵖ, as `f64::powf(p as f64)`
    Powf(Reg, Rational),
    /// eᵃ
    Exp(Reg),
    /// ln a
    Ln(Reg),
    /// sin a
    Sin(Reg),
    /// cos a
    Cos(Reg),
    /// K(m), as `lasalle_runtime::elliptic::ellipk`
    EllipK(Reg),
    /// f(x, m) of [`Func2`]: sn, cn, dn (one `ellipj` call each) or F, as
    /// `lasalle_runtime::elliptic`
    Func2(Func2, Reg, Reg),
}

impl Op {
    /// The registers the instruction reads.
    pub fn operands(&self) -> impl Iterator<Item = Reg> {
        let (a, b) = match *self {
            Op::State(_)
            | Op::Param(_)
            | Op::Target(_)
            | Op::Gain(_)
            | Op::Hoisted(_)
            | Op::Const(_) => (None, None),
            Op::Add(a, b) | Op::Sub(a, b) | Op::Mul(a, b) | Op::Div(a, b) | Op::Func2(_, a, b) => {
                (Some(a), Some(b))
            }
            Op::Neg(a)
            | Op::Powi(a, _)
            | Op::Sqrt(a)
            | Op::Cbrt(a)
            | Op::Powf(a, _)
            | Op::Exp(a)
            | Op::Ln(a)
            | Op::Sin(a)
            | Op::Cos(a)
            | Op::EllipK(a) => (Some(a), None),
        };
        a.into_iter().chain(b)
    }

    /// A hashable identity of the instruction (constants by their bits).
    fn key(&self) -> (u8, u64, u64) {
        let r = |r: Reg| u64::from(r.0);
        match *self {
            Op::State(i) => (0, i.into(), 0),
            Op::Param(i) => (1, i.into(), 0),
            Op::Target(i) => (2, i.into(), 0),
            Op::Gain(i) => (3, i.into(), 0),
            Op::Hoisted(i) => (4, i.into(), 0),
            Op::Const(c) => (5, c.to_bits(), 0),
            Op::Add(a, b) => (6, r(a), r(b)),
            Op::Sub(a, b) => (7, r(a), r(b)),
            Op::Mul(a, b) => (8, r(a), r(b)),
            Op::Div(a, b) => (9, r(a), r(b)),
            Op::Neg(a) => (10, r(a), 0),
            Op::Powi(a, n) => (11, r(a), u64::from(n as u32)),
            Op::Sqrt(a) => (12, r(a), 0),
            Op::Cbrt(a) => (13, r(a), 0),
            Op::Powf(a, p) => (
                14,
                r(a),
                (u64::from(p.num as u32) << 32) | u64::from(p.den as u32),
            ),
            Op::Exp(a) => (15, r(a), 0),
            Op::Ln(a) => (16, r(a), 0),
            Op::Sin(a) => (17, r(a), 0),
            Op::Cos(a) => (18, r(a), 0),
            Op::EllipK(a) => (19, r(a), 0),
            Op::Func2(f, a, b) => (20 + f as u8, r(a), r(b)),
        }
    }
}

/// `xⁿ` by binary exponentiation: the algorithm of compiler-rt's `__powidf2` and of LLVM's
/// expansion of `llvm.powi` with a constant exponent, hence bitwise equal to `f64::powi`.
///
/// The squares x, x², x⁴, … are multiplied into the result in increasing order, the first one
/// without a multiplication; a negative exponent takes the reciprocal at the end. `powi(x, 0)`
/// is 1.
pub fn powi(x: f64, n: i32) -> f64 {
    let mut bits = n.unsigned_abs();
    let mut square = x;
    let mut result: Option<f64> = None;
    while bits != 0 {
        if bits & 1 == 1 {
            result = Some(result.map_or(square, |r| r * square));
        }
        bits >>= 1;
        if bits != 0 {
            square *= square;
        }
    }
    let r = result.unwrap_or(1.0);
    if n < 0 {
        1.0 / r
    } else {
        r
    }
}

/// Sizes of the inputs of a tape.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Dims {
    /// State components N.
    pub state: usize,
    /// Parameter slots.
    pub params: usize,
    /// Target components M.
    pub targets: usize,
    /// Gains.
    pub gains: usize,
}

/// What can go wrong building or evaluating a tape.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TapeError {
    /// The expression reads an auxiliary symbol, which has no value at run time.
    #[error("the expression reads the auxiliary symbol s{0}, which has no run-time value")]
    Symbol(u32),
    /// An input index beyond the declared sizes.
    #[error("{kind}[{index}] is out of range: the tape has {len}")]
    InputOutOfRange {
        /// `state`, `param`, `target`, `gain` or `hoisted`.
        kind: &'static str,
        /// The index read.
        index: u32,
        /// The declared size.
        len: usize,
    },
    /// An input slice of the wrong length.
    #[error("{kind} has length {given}, the tape expects {expected}")]
    WrongLength {
        /// `state`, `params`, `target`, `gains`, `hoisted` or `out`.
        kind: &'static str,
        /// Expected length.
        expected: usize,
        /// Given length.
        given: usize,
    },
    /// A malformed tape (built by hand): an instruction reads a later register, a leaf is in the
    /// wrong section, or a register list points past its section.
    #[error("malformed tape: {0}")]
    Malformed(String),
    /// More registers than fit in a `u32`, or than a back end addresses (the interpreter:
    /// 2²¹ slots).
    #[error("the tape is too large: more than 2³² instructions, or 2²¹ slots for the interpreter")]
    TooLarge,
}

/// A function of (state; parameters, targets, gains) as two linear instruction sections.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tape {
    /// Parameter- and constant-only instructions, run once per parameter set.
    pub prelude: Vec<Op>,
    /// Prelude registers whose values the body reads as [`Op::Hoisted`]`(i)`.
    pub hoisted: Vec<Reg>,
    /// Per-call instructions; never [`Op::Param`].
    pub body: Vec<Op>,
    /// Body registers holding the outputs, in order.
    pub outputs: Vec<Reg>,
    /// Input sizes.
    pub dims: Dims,
}

impl fmt::Display for Tape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, op) in self.prelude.iter().enumerate() {
            writeln!(f, "p{i} = {op:?}")?;
        }
        for (i, op) in self.body.iter().enumerate() {
            writeln!(f, "b{i} = {op:?}")?;
        }
        let outs: Vec<String> = self.outputs.iter().map(|r| format!("b{}", r.0)).collect();
        write!(f, "out = [{}]", outs.join(", "))
    }
}

impl Tape {
    /// The tape of `roots` in `graph` (a clone is rewritten for emission; see [`TapeBuilder`]).
    pub fn from_graph(graph: &Graph, roots: &[Id], dims: Dims) -> Result<Tape, TapeError> {
        TapeBuilder::new(graph.clone(), dims).build(roots)
    }

    /// Checks that the tape is well formed: single assignment with operands defined earlier in
    /// their section, leaves in their section and in range, hoisted and output registers
    /// inside their sections. Tapes from [`TapeBuilder`] always are.
    pub fn validate(&self) -> Result<(), TapeError> {
        let d = self.dims;
        let range = |kind, index: u32, len: usize| {
            if (index as usize) < len {
                Ok(())
            } else {
                Err(TapeError::InputOutOfRange { kind, index, len })
            }
        };
        let bad = |s: String| Err(TapeError::Malformed(s));
        for (section, ops) in [("prelude", &self.prelude), ("body", &self.body)] {
            if u32::try_from(ops.len()).is_err() {
                return Err(TapeError::TooLarge);
            }
            let body = section == "body";
            for (i, op) in ops.iter().enumerate() {
                if let Some(r) = op.operands().find(|r| r.index() >= i) {
                    return bad(format!("{section}[{i}] reads register {} ≥ {i}", r.0));
                }
                match *op {
                    Op::Param(k) if !body => range("param", k, d.params)?,
                    Op::State(k) if body => range("state", k, d.state)?,
                    Op::Target(k) if body => range("target", k, d.targets)?,
                    Op::Gain(k) if body => range("gain", k, d.gains)?,
                    Op::Hoisted(k) if body => range("hoisted", k, self.hoisted.len())?,
                    Op::Param(_) | Op::State(_) | Op::Target(_) | Op::Gain(_) | Op::Hoisted(_) => {
                        return bad(format!("{section}[{i}] = {op:?} is not allowed there"))
                    }
                    _ => {}
                }
            }
        }
        if let Some(r) = self
            .hoisted
            .iter()
            .find(|r| r.index() >= self.prelude.len())
        {
            return bad(format!("hoisted register {} is past the prelude", r.0));
        }
        if let Some(r) = self.outputs.iter().find(|r| r.index() >= self.body.len()) {
            return bad(format!("output register {} is past the body", r.0));
        }
        Ok(())
    }

    /// Runs the prelude: the values of the hoisted registers for these parameters.
    pub fn hoist<S: Scalar>(&self, params: &[S]) -> Result<Vec<S>, TapeError> {
        self.validate()?;
        expect_len("params", self.dims.params, params.len())?;
        let regs = run(&self.prelude, |op| match op {
            Op::Param(k) => params[k as usize].clone(),
            _ => unreachable!("validated: only parameters in the prelude"),
        });
        Ok(self
            .hoisted
            .iter()
            .map(|r| regs[r.index()].clone())
            .collect())
    }

    /// Runs the body with hoisted values from [`Tape::hoist`]: the outputs.
    pub fn eval_body<S: Scalar>(
        &self,
        hoisted: &[S],
        state: &[S],
        target: &[S],
        gains: &[S],
    ) -> Result<Vec<S>, TapeError> {
        self.validate()?;
        let d = self.dims;
        expect_len("hoisted", self.hoisted.len(), hoisted.len())?;
        expect_len("state", d.state, state.len())?;
        expect_len("target", d.targets, target.len())?;
        expect_len("gains", d.gains, gains.len())?;
        let regs = run(&self.body, |op| match op {
            Op::State(k) => state[k as usize].clone(),
            Op::Target(k) => target[k as usize].clone(),
            Op::Gain(k) => gains[k as usize].clone(),
            Op::Hoisted(k) => hoisted[k as usize].clone(),
            _ => unreachable!("validated: no parameter in the body"),
        });
        Ok(self
            .outputs
            .iter()
            .map(|r| regs[r.index()].clone())
            .collect())
    }

    /// Evaluates the outputs over any [`Scalar`]: prelude, then body.
    pub fn eval<S: Scalar>(
        &self,
        params: &[S],
        state: &[S],
        target: &[S],
        gains: &[S],
    ) -> Result<Vec<S>, TapeError> {
        let hoisted = self.hoist(params)?;
        self.eval_body(&hoisted, state, target, gains)
    }

    /// Instructions of the body that compute something (not leaves or constants).
    pub fn body_ops(&self) -> usize {
        self.body
            .iter()
            .filter(|op| op.operands().next().is_some())
            .count()
    }
}

/// Checks a slice length.
pub fn expect_len(kind: &'static str, expected: usize, given: usize) -> Result<(), TapeError> {
    if expected == given {
        Ok(())
    } else {
        Err(TapeError::WrongLength {
            kind,
            expected,
            given,
        })
    }
}

/// Runs a validated section; `leaf` gives the value of an input instruction.
fn run<S: Scalar>(ops: &[Op], leaf: impl Fn(Op) -> S) -> Vec<S> {
    let mut regs: Vec<S> = Vec::with_capacity(ops.len());
    for &op in ops {
        let r = |k: Reg| &regs[k.index()];
        let v = match op {
            Op::Const(c) => S::from_f64(c),
            Op::Add(a, b) => r(a).add(r(b)),
            Op::Sub(a, b) => r(a).sub(r(b)),
            Op::Mul(a, b) => r(a).mul(r(b)),
            Op::Div(a, b) => r(a).div(r(b)),
            Op::Neg(a) => r(a).neg(),
            Op::Powi(a, n) => r(a).powi(n),
            Op::Sqrt(a) => r(a).sqrt(),
            Op::Cbrt(a) => r(a).cbrt(),
            Op::Powf(a, p) => r(a).powf(p),
            Op::Exp(a) => r(a).exp(),
            Op::Ln(a) => r(a).ln(),
            Op::Sin(a) => r(a).sin(),
            Op::Cos(a) => r(a).cos(),
            Op::EllipK(a) => r(a).ellipk(),
            Op::Func2(f, a, b) => f.eval(r(a), r(b)),
            leaf_op => leaf(leaf_op),
        };
        regs.push(v);
    }
    regs
}

/// A value during lowering: a constant (materialised where used), or a register of a section.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Val {
    Const(f64),
    Pre(u32),
    Body(u32),
}

/// The two sections under construction, with value numbering and hoisting.
#[derive(Default)]
struct Sections {
    prelude: Vec<Op>,
    body: Vec<Op>,
    pre_index: HashMap<(u8, u64, u64), u32>,
    body_index: HashMap<(u8, u64, u64), u32>,
    hoisted: Vec<Reg>,
    /// Index in `hoisted` of each hoisted prelude register.
    hoisted_index: HashMap<u32, u32>,
}

impl Sections {
    fn push(&mut self, body: bool, op: Op) -> Result<u32, TapeError> {
        let (ops, index) = if body {
            (&mut self.body, &mut self.body_index)
        } else {
            (&mut self.prelude, &mut self.pre_index)
        };
        if let Some(&r) = index.get(&op.key()) {
            return Ok(r);
        }
        let r = u32::try_from(ops.len()).map_err(|_| TapeError::TooLarge)?;
        ops.push(op);
        index.insert(op.key(), r);
        Ok(r)
    }

    /// The register of `v` in the prelude (`v` is a constant or a prelude value).
    fn pre_reg(&mut self, v: Val) -> Result<Reg, TapeError> {
        match v {
            Val::Const(c) => self.push(false, Op::Const(c)).map(Reg),
            Val::Pre(r) => Ok(Reg(r)),
            Val::Body(_) => Err(TapeError::Malformed(
                "a body value used in the prelude".into(),
            )),
        }
    }

    /// The register of `v` in the body (a hoisted prelude value is read by `Op::Hoisted`).
    fn body_reg(&mut self, v: Val) -> Result<Reg, TapeError> {
        match v {
            Val::Const(c) => self.push(true, Op::Const(c)).map(Reg),
            Val::Body(r) => Ok(Reg(r)),
            Val::Pre(r) => {
                let i = match self.hoisted_index.get(&r) {
                    Some(&i) => i,
                    None => {
                        let i =
                            u32::try_from(self.hoisted.len()).map_err(|_| TapeError::TooLarge)?;
                        self.hoisted.push(Reg(r));
                        self.hoisted_index.insert(r, i);
                        i
                    }
                };
                self.push(true, Op::Hoisted(i)).map(Reg)
            }
        }
    }

    /// Appends `make(operands)` to the body if an operand lives there, else to the prelude.
    fn inst(&mut self, args: &[Val], make: impl Fn(&[Reg]) -> Op) -> Result<Val, TapeError> {
        let body = args.iter().any(|v| matches!(v, Val::Body(_)));
        let regs = args
            .iter()
            .map(|&v| {
                if body {
                    self.body_reg(v)
                } else {
                    self.pre_reg(v)
                }
            })
            .collect::<Result<Vec<Reg>, _>>()?;
        let r = self.push(body, make(&regs))?;
        Ok(if body { Val::Body(r) } else { Val::Pre(r) })
    }

    fn un(&mut self, a: Val, make: fn(Reg) -> Op) -> Result<Val, TapeError> {
        self.inst(&[a], |r| make(r[0]))
    }

    fn bin(&mut self, a: Val, b: Val, make: fn(Reg, Reg) -> Op) -> Result<Val, TapeError> {
        self.inst(&[a, b], |r| make(r[0], r[1]))
    }
}

/// The time [`ModelTapes::timed`] spent in each half of building the tapes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TapeTimes {
    /// The rewrites for emission (factoring, shared roots, shared products and sums).
    pub rewrite: Duration,
    /// Lowering the rewritten graphs to instructions.
    pub lower: Duration,
}

/// Builds tapes from one graph, applying the emitter's rewrites to it tape after tape (so a
/// sequence of builds sees the node Ids the emitter sees for the same sequence of bodies).
#[derive(Clone)]
pub struct TapeBuilder<'c> {
    graph: Graph,
    lets: HashSet<Id>,
    dims: Dims,
    /// The clock of [`ModelTapes::timed`], if timed.
    clock: Option<&'c dyn Fn() -> Duration>,
    times: TapeTimes,
}

impl TapeBuilder<'_> {
    /// A builder owning (a copy of) the graph.
    pub fn new(graph: Graph, dims: Dims) -> Self {
        TapeBuilder {
            graph,
            lets: HashSet::default(),
            dims,
            clock: None,
            times: TapeTimes::default(),
        }
    }

    /// Nodes the emitter names after a `let` binding: like shared nodes, they are computed as
    /// a value of their own even when used once, which decides signs and divisions.
    pub fn with_lets(mut self, lets: impl IntoIterator<Item = Id>) -> Self {
        self.lets.extend(lets);
        self
    }

    /// The input sizes of the next tapes.
    pub fn set_dims(&mut self, dims: Dims) {
        self.dims = dims;
    }

    /// The graph as rewritten so far.
    pub fn graph(&self) -> &Graph {
        &self.graph
    }

    /// The tape of `roots`: rewritten for emission, then lowered (see the module docs).
    pub fn build(&mut self, roots: &[Id]) -> Result<Tape, TapeError> {
        let now = || self.clock.map(|c| c()).unwrap_or_default();
        let start = now();
        let roots = self.graph.optimize_for_emission(roots);
        let rewritten = now();
        let tape = self.lower(&roots);
        let end = now();
        self.times.rewrite += rewritten.saturating_sub(start);
        self.times.lower += end.saturating_sub(rewritten);
        tape
    }

    /// The tape of `roots` as they are, without the emission rewrites.
    pub fn lower(&self, roots: &[Id]) -> Result<Tape, TapeError> {
        let g = &self.graph;
        let order = g.reachable(roots);
        let mut uses: HashMap<Id, usize> = HashMap::default();
        for &id in &order {
            for &c in g.children(id) {
                *uses.entry(c).or_default() += 1;
            }
        }
        for r in roots {
            *uses.entry(*r).or_default() += 1;
        }
        let named = order
            .iter()
            .copied()
            .filter(|&id| {
                !g.children(id).is_empty()
                    && (uses.get(&id).copied().unwrap_or(0) >= 2 || self.lets.contains(&id))
            })
            .collect();
        let mut l = Lowering {
            g,
            dims: self.dims,
            parameter_only: g.parameter_only(&order).into_iter().collect(),
            named,
            memo: HashMap::default(),
            s: Sections::default(),
        };
        // Bottom-up, so that the recursion below stays shallow: children are memoised first.
        for &id in &order {
            if l.named.contains(&id) {
                l.reference(id)?;
            }
        }
        let outs = roots
            .iter()
            .map(|&r| l.reference(r))
            .collect::<Result<Vec<Val>, _>>()?;
        let outputs = outs
            .into_iter()
            .map(|v| l.s.body_reg(v))
            .collect::<Result<Vec<Reg>, _>>()?;
        let tape = Tape {
            prelude: l.s.prelude,
            hoisted: l.s.hoisted,
            body: l.s.body,
            outputs,
            dims: self.dims,
        };
        debug_assert_eq!(tape.validate(), Ok(()));
        Ok(tape)
    }
}

/// The lowering of one tape: `lasalle_codegen`'s `emit::body::Writer` with instructions instead
/// of tokens.
struct Lowering<'a> {
    g: &'a Graph,
    dims: Dims,
    /// Nodes the emitter binds to a temporary (shared, or named by a `let`).
    named: HashSet<Id>,
    /// Nodes computed once per parameter set.
    parameter_only: HashSet<Id>,
    memo: HashMap<Id, Val>,
    s: Sections,
}

impl Lowering<'_> {
    /// The value of a node, lowered once.
    fn reference(&mut self, id: Id) -> Result<Val, TapeError> {
        if let Some(&v) = self.memo.get(&id) {
            return Ok(v);
        }
        let v = self.render(id)?;
        self.memo.insert(id, v);
        Ok(v)
    }

    fn leaf(&mut self, i: Input) -> Result<Val, TapeError> {
        let d = self.dims;
        let check = |kind, k: u32, len| {
            if (k as usize) < len {
                Ok(())
            } else {
                Err(TapeError::InputOutOfRange {
                    kind,
                    index: k,
                    len,
                })
            }
        };
        let (body, op) = match i {
            Input::State(k) => (check("state", k, d.state).map(|_| true)?, Op::State(k)),
            Input::Param(k) => (check("param", k, d.params).map(|_| false)?, Op::Param(k)),
            Input::Target(k) => (check("target", k, d.targets).map(|_| true)?, Op::Target(k)),
            Input::Gain(k) => (check("gain", k, d.gains).map(|_| true)?, Op::Gain(k)),
            Input::Symbol(k) => return Err(TapeError::Symbol(k)),
        };
        let r = self.s.push(body, op)?;
        Ok(if body { Val::Body(r) } else { Val::Pre(r) })
    }

    fn render(&mut self, id: Id) -> Result<Val, TapeError> {
        match self.g.node(id) {
            Node::Num(b) => Ok(Val::Const(f64::from_bits(*b))),
            Node::Input(i) => self.leaf(*i),
            Node::Add(terms) => self.sum(terms),
            Node::Mul(factors) => self.product(factors),
            &Node::Pow(b, e) => self.power(b, e),
            &Node::Func(f, a) => {
                let a = self.reference(a)?;
                let make: fn(Reg) -> Op = match f {
                    Func::Exp => Op::Exp,
                    Func::Ln => Op::Ln,
                    Func::Sin => Op::Sin,
                    Func::Cos => Op::Cos,
                    Func::EllipK => Op::EllipK,
                };
                self.s.un(a, make)
            }
            &Node::Func2(f, [x, m]) => {
                let (x, m) = (self.reference(x)?, self.reference(m)?);
                self.s.inst(&[x, m], |r| Op::Func2(f, r[0], r[1]))
            }
        }
    }

    /// A term of a sum as (negative, magnitude), as `Writer::signed` splits it.
    fn signed(&mut self, id: Id) -> Result<(bool, Val), TapeError> {
        if !self.named.contains(&id) {
            match self.g.node(id) {
                Node::Num(b) if f64::from_bits(*b) < 0.0 => {
                    return Ok((true, Val::Const(-f64::from_bits(*b))));
                }
                Node::Mul(fs) => {
                    if let Some(c) = self.g.as_num(fs[0]).filter(|c| *c < 0.0) {
                        return Ok((true, self.product_with(-c, &fs[1..])?));
                    }
                }
                _ => {}
            }
        }
        Ok((false, self.reference(id)?))
    }

    fn sum(&mut self, terms: &[Id]) -> Result<Val, TapeError> {
        let mut parts = terms
            .iter()
            .map(|&t| self.signed(t))
            .collect::<Result<Vec<_>, _>>()?;
        parts.sort_by_key(|(neg, _)| *neg); // stable: positive terms first
        let (neg0, first) = parts[0];
        let mut acc = if neg0 {
            self.s.un(first, Op::Neg)?
        } else {
            first
        };
        for &(neg, t) in &parts[1..] {
            acc = self.s.bin(acc, t, if neg { Op::Sub } else { Op::Add })?;
        }
        Ok(acc)
    }

    fn product(&mut self, factors: &[Id]) -> Result<Val, TapeError> {
        match self.g.as_num(factors[0]) {
            Some(c) if c < 0.0 => {
                let inner = self.product_with(-c, &factors[1..])?;
                self.s.un(inner, Op::Neg)
            }
            Some(c) => self.product_with(c, &factors[1..]),
            None => self.product_with(1.0, factors),
        }
    }

    /// c · Π factors, `c * f1 * f2 / d1 / d2`, as `Writer::product_with` writes it: a factor
    /// with a negative exponent is a division, unless it is a value of its own (a shared
    /// temporary, or a parameter-only value computed once) that the product multiplies; in a
    /// parameter-only product it is always a division (so that a parameter-only value does not
    /// depend on which of its parts the function happens to share).
    fn product_with(&mut self, c: f64, factors: &[Id]) -> Result<Val, TapeError> {
        let mut num = Vec::new();
        let mut den = Vec::new();
        if c != 1.0 {
            num.push(Val::Const(c));
        }
        let parameter_only = factors.iter().all(|f| self.parameter_only.contains(f));
        for &f in factors {
            let own_value = self.named.contains(&f) || self.parameter_only.contains(&f);
            match *self.g.node(f) {
                Node::Pow(b, e) if e.num < 0 && (parameter_only || !own_value) => {
                    den.push(self.power_positive(b, negate(e))?);
                }
                _ => num.push(self.reference(f)?),
            }
        }
        let mut acc = num.first().copied().unwrap_or(Val::Const(1.0));
        for &n in num.iter().skip(1) {
            acc = self.s.bin(acc, n, Op::Mul)?;
        }
        for &d in &den {
            acc = self.s.bin(acc, d, Op::Div)?;
        }
        Ok(acc)
    }

    fn power(&mut self, b: Id, e: Rational) -> Result<Val, TapeError> {
        if e.num < 0 {
            let pos = self.power_positive(b, negate(e))?;
            return self.s.bin(Val::Const(1.0), pos, Op::Div);
        }
        self.power_positive(b, e)
    }

    /// bᵉ for e > 0.
    fn power_positive(&mut self, b: Id, e: Rational) -> Result<Val, TapeError> {
        let base = self.reference(b)?;
        if e.is_int() {
            if e.num == 1 {
                return Ok(base);
            }
            return self.s.inst(&[base], |r| Op::Powi(r[0], e.num));
        }
        if e.den == 2 {
            let root = self.s.un(base, Op::Sqrt)?;
            if e.num == 1 {
                return Ok(root);
            }
            return self.s.inst(&[root], |r| Op::Powi(r[0], e.num));
        }
        if e == Rational::new(1, 3) {
            return self.s.un(base, Op::Cbrt);
        }
        self.s.inst(&[base], |r| Op::Powf(r[0], e))
    }
}

/// −e for an exponent (exponents come from `Rational::reduce`, so −num fits).
fn negate(e: Rational) -> Rational {
    Rational {
        num: e.num.saturating_neg(),
        den: e.den,
    }
}

#[cfg(test)]
mod tests;
