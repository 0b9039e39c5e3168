//! The syntax tree of a model file, with a span on every node.

use crate::error::Span;

/// A name with its place in the file.
#[derive(Clone, Debug)]
pub struct Ident {
    /// The name.
    pub name: String,
    /// Where it is written.
    pub span: Span,
}

/// An expression.
#[derive(Clone, Debug)]
pub struct Expr {
    /// What kind of expression.
    pub kind: ExprKind,
    /// The whole expression's extent.
    pub span: Span,
}

/// Binary operators, by precedence class.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*` (scalar product, matrix–vector or matrix–matrix product)
    Mul,
    /// `/` (by a scalar)
    Div,
    /// `^` (scalar to a constant power)
    Pow,
    /// `%` (the non-negative remainder of two constant whole numbers: `(i + 1) % n`)
    Rem,
}

/// The forms an expression takes.
#[derive(Clone, Debug)]
pub enum ExprKind {
    /// A numeric literal.
    Num(f64),
    /// A name: state, parameter, `let`, invariant or gain.
    Name(Ident),
    /// `-e`
    Neg(Box<Expr>),
    /// `a ^ b` (the only binary operator not parsed as a [`ExprKind::Chain`]).
    Binary(BinOp, Box<Expr>, Box<Expr>),
    /// A left-associative chain `a op₁ b op₂ c …` of one precedence class (`+ -` or `* /`),
    /// with at least one operator: the first operand, then each operator with its operand.
    /// Chains are flat so that a sum of 10 000 terms is no 10 000-deep tree.
    Chain(Box<Expr>, Vec<(BinOp, Expr)>),
    /// `f(a, b, …)`
    Call(Ident, Vec<Expr>),
    /// `e[i]` or `e[i, j]`
    Index(Box<Expr>, Vec<Expr>),
    /// `[a, b, c]` (a vector) or `[[a, b], [c, d]]` (a matrix, by rows)
    List(Vec<Expr>),
    /// `sum(i in 0..n, j in i+1..n: body)` or `prod(…: body)`: one term per index tuple.
    Family(FamilyOp, FamilyHead, Box<Expr>),
    /// `[i in 0..n: body]`: the list of the body's values, one element per index tuple.
    Comprehension(FamilyHead, Box<Expr>),
}

/// What a family expression does with its terms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FamilyOp {
    /// `sum(…)`
    Sum,
    /// `prod(…)`
    Prod,
}

/// The indices of a family: ranges and conditions, in order (`i in 0..n, j in 0..n, i != j`).
#[derive(Clone, Debug)]
pub struct FamilyHead {
    /// Ranges and conditions; a condition may use the indices bound before it.
    pub clauses: Vec<Clause>,
    /// From the first clause to the last.
    pub span: Span,
}

/// One clause of a [`FamilyHead`].
#[derive(Clone, Debug)]
pub enum Clause {
    /// `i in start..end`: i runs over start, start + 1, …, end − 1.
    Range {
        /// The index.
        var: Ident,
        /// First value.
        start: Expr,
        /// One past the last value.
        end: Expr,
    },
    /// `lhs op rhs`: only index tuples that satisfy it.
    Cond {
        /// Left side.
        lhs: Expr,
        /// The comparison.
        op: IndexComparison,
        /// Right side.
        rhs: Expr,
    },
}

/// A comparison of whole numbers in a family's condition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IndexComparison {
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Less,
    /// `<=`
    LessEq,
    /// `>`
    Greater,
    /// `>=`
    GreaterEq,
}

impl IndexComparison {
    /// Does `a op b` hold?
    pub fn holds(self, a: i64, b: i64) -> bool {
        match self {
            IndexComparison::Eq => a == b,
            IndexComparison::Ne => a != b,
            IndexComparison::Less => a < b,
            IndexComparison::LessEq => a <= b,
            IndexComparison::Greater => a > b,
            IndexComparison::GreaterEq => a >= b,
        }
    }
}

/// A declared shape in `state x: vec3`, or a family `state q: vec3[n]`.
#[derive(Clone, Debug)]
pub struct TypeName {
    /// The written name (`scalar`, `vec3`, `mat3`, …).
    pub name: String,
    /// Where it is written (with the count, if any).
    pub span: Span,
    /// The number of members of a family (`[n]`), a constant expression.
    pub count: Option<Expr>,
}

/// The structure that turns a Hamiltonian into a vector field.
#[derive(Clone, Debug)]
pub enum StructureDecl {
    /// `structure canonical(q, p)`: q̇ = ∂H/∂p, ṗ = −∂H/∂q.
    Canonical(Ident, Ident),
    /// `structure lie_poisson_so3(P)`: Ṗ = P × ∇H.
    LiePoissonSo3(Ident),
}

/// Whether an invariant is a constraint f₀ or a first integral.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InvariantDeclKind {
    /// `constraint`
    Constraint,
    /// `integral`
    Integral,
}

/// `gain 4` or `gain k1 = 4`.
#[derive(Clone, Debug)]
pub struct GainDecl {
    /// The gain's name, if given.
    pub name: Option<Ident>,
    /// Its default value.
    pub value: Expr,
}

/// One item in the model body.
#[derive(Clone, Debug)]
pub enum Item {
    /// `state x: vec3, v: vec3;`
    State(Vec<(Ident, TypeName)>),
    /// `param mu = 1.0;` or `param m: scalar[n] = 1;` (with a declared shape)
    Param(Ident, Option<TypeName>, Expr),
    /// `let r = norm(x);`
    Let(Ident, Expr),
    /// `d/dt x = v;`
    Derivative(Ident, Expr),
    /// `integral L = cross(x, v) gain 4;` or `constraint C = … gain …;`
    Invariant {
        /// Constraint or integral.
        kind: InvariantDeclKind,
        /// Its name.
        name: Ident,
        /// Its value f(x).
        value: Expr,
        /// Its gain, if written.
        gain: Option<GainDecl>,
    },
    /// `lyapunov V = …;`
    Lyapunov(Ident, Expr),
    /// `hamiltonian H = …;`
    Hamiltonian(Ident, Expr),
    /// `structure canonical(q, p);`
    Structure(StructureDecl, Span),
    /// `point L4 { q = […]; p = […]; }`
    Point(Ident, Vec<(Ident, Expr)>),
    /// `run NAME { key = value; … }`: a run preset.
    Run(Ident, Vec<(Ident, Expr)>),
    /// `guard NAME: lhs (<|<=|>|>=) rhs;`: a domain condition every state must satisfy.
    Guard {
        /// The guard's name.
        name: Ident,
        /// Left side of the comparison.
        lhs: Expr,
        /// The comparison.
        op: Comparison,
        /// Right side of the comparison.
        rhs: Expr,
    },
    /// `event NAME: expr = 0 [rising | falling] [stop];`: a crossing to locate during runs.
    Event {
        /// The event's name.
        name: Ident,
        /// The scalar whose zeros are the event.
        expr: Expr,
        /// The zero after `=`, as written (it must be 0).
        zero: Expr,
        /// `rising`, `falling` or neither (both directions), with where it is written.
        direction: Option<Ident>,
        /// `stop`, if written: the event ends the run.
        stop: Option<Ident>,
    },
    /// `splitting KIND(args…);`: a structure-specific splitting method the model admits.
    Splitting(Ident, Vec<Ident>),
    /// `d/dt q[i] = …;`: the equation of one member of a family (or one component).
    ElementDerivative(Ident, Vec<Expr>, Expr),
    /// `for i in 0..n: d/dt q[i] = …;`: the item once per index tuple of the head.
    For(FamilyHead, Box<Spanned>),
}

/// A comparison in a `guard`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Comparison {
    /// `<`
    Less,
    /// `<=`
    LessEq,
    /// `>`
    Greater,
    /// `>=`
    GreaterEq,
}

/// An item with the span of its whole text (for error messages and generated comments).
#[derive(Clone, Debug)]
pub struct Spanned {
    /// The item.
    pub item: Item,
    /// From its keyword to its `;` or `}`.
    pub span: Span,
}

/// A parsed model file.
#[derive(Clone, Debug)]
pub struct ModelAst {
    /// The name after `model`.
    pub name: Ident,
    /// The items in order.
    pub items: Vec<Spanned>,
}
