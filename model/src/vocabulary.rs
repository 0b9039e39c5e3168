//! The model language's vocabulary, declared once: the built-in functions ([`BUILTINS`]) and
//! the keywords ([`KEYWORDS`]).
//!
//! Lowering looks functions up here (arity, and the lowering of every scalar function), the
//! reserved-name check refuses these names, the parser lists the item keywords in its
//! messages, derivatives come from the [`Func`]/[`Func2`] a row lowers to, and the tables of
//! `docs/dsl.md` are [`functions_markdown`] and [`keywords_markdown`] (a test compares them).

use crate::ir::{Func, Func2};

/// How many arguments a built-in takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arity {
    /// Exactly n.
    Exactly(usize),
    /// n or more.
    AtLeast(usize),
}

impl Arity {
    /// Does `n` arguments fit?
    pub fn accepts(self, n: usize) -> bool {
        match self {
            Arity::Exactly(k) => n == k,
            Arity::AtLeast(k) => n >= k,
        }
    }
}

/// How a call is lowered onto the DAG.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lowering {
    /// √x of a scalar (a power ½ in the DAG).
    Sqrt,
    /// f(x) of a scalar.
    Func(Func),
    /// f(x, m) of two scalars; m must not depend on the state.
    Func2(Func2),
    /// Glaisher's quotient p(u | m)/q(u | m) of two Jacobi functions, `None` standing for 1
    /// (the letter n): ns = 1/sn, sc = sn/cn, … (A&S 16.3); m must not depend on the state.
    Quotient(Option<Func2>, Option<Func2>),
    /// Lowered by its own code in `model::expr` (shapes other than scalars, names as arguments).
    Structural,
    /// sign(g) of a scalar of the state: the mode of the switching surface g = 0, a state
    /// component the run keeps constant between switches (`model::switching`).
    Sign,
    /// delay(x, r): the state component x read at t − r, for a positive constant r (the
    /// method of steps over a constant history, `model::delay`).
    Delay,
}

/// One built-in function of the model language.
#[derive(Clone, Copy, Debug)]
pub struct Builtin {
    /// The name in model files.
    pub name: &'static str,
    /// The call with named arguments, for the docs: `sn(u, m)`.
    pub call: &'static str,
    /// How many arguments.
    pub arity: Arity,
    /// Argument and result shapes: `scalar, scalar → scalar`.
    pub shapes: &'static str,
    /// What it computes.
    pub doc: &'static str,
    /// Its derivative, as the generator takes it.
    pub derivative: &'static str,
    /// How it is lowered.
    pub lowering: Lowering,
}

const fn func(f: Func, call: &'static str, doc: &'static str, derivative: &'static str) -> Builtin {
    Builtin {
        name: f.name(),
        call,
        arity: Arity::Exactly(1),
        shapes: "scalar → scalar",
        doc,
        derivative,
        lowering: Lowering::Func(f),
    }
}

const JACOBI: &str = "scalars u, m → scalar";

const fn jacobi(
    f: Func2,
    call: &'static str,
    doc: &'static str,
    derivative: &'static str,
) -> Builtin {
    Builtin {
        name: f.name(),
        call,
        arity: Arity::Exactly(2),
        shapes: if matches!(f, Func2::EllipF) {
            "scalars φ, m → scalar"
        } else {
            JACOBI
        },
        doc,
        derivative,
        lowering: Lowering::Func2(f),
    }
}

const fn quotient(
    name: &'static str,
    call: &'static str,
    p: Option<Func2>,
    q: Option<Func2>,
    doc: &'static str,
) -> Builtin {
    Builtin {
        name,
        call,
        arity: Arity::Exactly(2),
        shapes: JACOBI,
        doc,
        derivative: "that of the quotient; m as for sn",
        lowering: Lowering::Quotient(p, q),
    }
}

const fn structural(
    name: &'static str,
    call: &'static str,
    arity: Arity,
    shapes: &'static str,
    doc: &'static str,
) -> Builtin {
    Builtin {
        name,
        call,
        arity,
        shapes,
        doc,
        derivative: "of its expansion into sums and products",
        lowering: Lowering::Structural,
    }
}

const SN: Option<Func2> = Some(Func2::Sn);
const CN: Option<Func2> = Some(Func2::Cn);
const DN: Option<Func2> = Some(Func2::Dn);

/// Every built-in function, in the order of the docs.
pub const BUILTINS: &[Builtin] = &[
    Builtin {
        name: "sqrt",
        call: "sqrt(x)",
        arity: Arity::Exactly(1),
        shapes: "scalar → scalar",
        doc: "√x (a power ½: `sqrt(x)^2` is `x`)",
        derivative: "1/(2√x)",
        lowering: Lowering::Sqrt,
    },
    func(Func::Exp, "exp(x)", "eˣ", "eˣ"),
    func(Func::Ln, "log(x)", "natural logarithm", "1/x"),
    func(Func::Sin, "sin(x)", "sine", "cos x"),
    func(Func::Cos, "cos(x)", "cosine", "−sin x"),
    Builtin {
        name: "sign",
        call: "sign(g)",
        arity: Arity::Exactly(1),
        shapes: "scalar of the state → scalar",
        doc: "−1, 0 or 1 as g < 0, g = 0, g > 0: a discontinuous field, switching on g = 0 (classical or Filippov solutions, [switching.md](switching.md))",
        derivative: "0 (g = 0 is located as an event)",
        lowering: Lowering::Sign,
    },
    Builtin {
        name: "delay",
        call: "delay(x, r)",
        arity: Arity::Exactly(2),
        shapes: "state component, positive constant → scalar",
        doc: "x(t − r): a delay equation, integrated by the method of steps from the constant history x(t) = x(0) for t ≤ 0 ([delay.md](delay.md))",
        derivative: "0 (x(t − r) is read from the solution's past)",
        lowering: Lowering::Delay,
    },
    structural(
        "norm",
        "norm(a)",
        Arity::Exactly(1),
        "vector → scalar; matrix → scalar",
        "Euclidean norm; Frobenius norm of a matrix",
    ),
    structural(
        "dot",
        "dot(a, b)",
        Arity::Exactly(2),
        "two vectors of one length → scalar",
        "a · b",
    ),
    structural(
        "cross",
        "cross(a, b)",
        Arity::Exactly(2),
        "vec3, vec3 → vec3",
        "a × b",
    ),
    structural(
        "hat",
        "hat(a)",
        Arity::Exactly(1),
        "vec3 → mat3",
        "the matrix with hat(a) b = a × b",
    ),
    structural(
        "transpose",
        "transpose(M)",
        Arity::Exactly(1),
        "matrix → matrix",
        "Mᵀ",
    ),
    structural(
        "trace",
        "trace(M)",
        Arity::Exactly(1),
        "square matrix → scalar",
        "Σ Mᵢᵢ",
    ),
    structural(
        "inv",
        "inv(M)",
        Arity::Exactly(1),
        "1×1, 2×2 or 3×3 matrix of parameters → matrix",
        "M⁻¹ (adjugate over determinant)",
    ),
    structural(
        "eye",
        "eye(n)",
        Arity::Exactly(1),
        "constant n → n×n matrix",
        "identity matrix",
    ),
    structural(
        "diag",
        "diag(a, b, c), diag(v)",
        Arity::AtLeast(1),
        "scalars or a vector → square matrix",
        "diagonal matrix",
    ),
    structural(
        "target",
        "target(f)",
        Arity::Exactly(1),
        "an invariant's name → its shape",
        "in `lyapunov` only: f(x₀), the value of the invariant f at the initial point",
    ),
    jacobi(
        Func2::Sn,
        "sn(u, m)",
        "Jacobi sn(u | m), **parameter m = k²**, 0 ≤ m ≤ 1",
        "∂/∂u = cn dn; m must not depend on the state",
    ),
    jacobi(
        Func2::Cn,
        "cn(u, m)",
        "Jacobi cn(u | m), parameter m = k²",
        "∂/∂u = −sn dn; m as for sn",
    ),
    jacobi(
        Func2::Dn,
        "dn(u, m)",
        "Jacobi dn(u | m), parameter m = k²",
        "∂/∂u = −m sn cn; m as for sn",
    ),
    quotient("ns", "ns(u, m)", None, SN, "1/sn"),
    quotient("nc", "nc(u, m)", None, CN, "1/cn"),
    quotient("nd", "nd(u, m)", None, DN, "1/dn"),
    quotient("sc", "sc(u, m)", SN, CN, "sn/cn"),
    quotient("sd", "sd(u, m)", SN, DN, "sn/dn"),
    quotient("cs", "cs(u, m)", CN, SN, "cn/sn"),
    quotient("cd", "cd(u, m)", CN, DN, "cn/dn"),
    quotient("ds", "ds(u, m)", DN, SN, "dn/sn"),
    quotient("dc", "dc(u, m)", DN, CN, "dn/cn"),
    Builtin {
        arity: Arity::Exactly(1),
        shapes: "scalar m → scalar",
        ..func(
            Func::EllipK,
            "ellipk(m)",
            "complete elliptic integral of the first kind K(m) = F(π/2 | m), parameter m = k²",
            "none: m must not depend on the state",
        )
    },
    jacobi(
        Func2::EllipF,
        "ellipf(phi, m)",
        "incomplete elliptic integral of the first kind F(φ | m) = ∫₀^φ dθ/√(1 − m sin²θ), parameter m = k²",
        "∂/∂φ = 1/√(1 − m sin²φ); m as for sn",
    ),
];

/// The built-in called `name`, if any.
pub fn builtin(name: &str) -> Option<&'static Builtin> {
    BUILTINS.iter().find(|b| b.name == name)
}

/// One keyword of the model language.
#[derive(Clone, Copy, Debug)]
pub struct Keyword {
    /// The word (`d/dt` is written as three tokens).
    pub name: &'static str,
    /// Does it start an item inside `model … { }`?
    pub starts_item: bool,
    /// What it declares.
    pub doc: &'static str,
}

const fn item(name: &'static str, doc: &'static str) -> Keyword {
    Keyword {
        name,
        starts_item: true,
        doc,
    }
}

/// Every keyword, items in the order the parser lists them.
pub const KEYWORDS: &[Keyword] = &[
    Keyword {
        name: "model",
        starts_item: false,
        doc: "`model Name { … }`: the file's one model",
    },
    item("state", "state variables and their shapes"),
    item("param", "a parameter with its default"),
    item("let", "a named subexpression"),
    item("d/dt", "the equation of a state variable"),
    item("integral", "a first integral, checked to be conserved"),
    item(
        "constraint",
        "a manifold condition f₀ = 0, checked to be invariant",
    ),
    Keyword {
        name: "gain",
        starts_item: false,
        doc: "after an invariant: its feedback gain",
    },
    item("lyapunov", "an explicit Lyapunov function"),
    item("hamiltonian", "a Hamiltonian, with a `structure`"),
    item("structure", "the Poisson structure of the Hamiltonian"),
    item("point", "a named state"),
    item("run", "a run preset"),
    item("guard", "a domain condition checked during runs"),
    item(
        "event",
        "a crossing g = 0 located during runs (`rising`, `falling`, `stop`)",
    ),
    item(
        "splitting",
        "a structure-specific splitting the model admits",
    ),
    item(
        "for",
        "`for i in 0..n: d/dt q[i] = …;`: the equation of every member of a family",
    ),
    Keyword {
        name: "in",
        starts_item: false,
        doc: "`i in a..b`: an index running over a, a + 1, …, b − 1",
    },
    Keyword {
        name: "sum",
        starts_item: false,
        doc: "`sum(i in 0..n, j in i+1..n: …)`: the sum of a term over index tuples (with conditions such as `i != j`)",
    },
    Keyword {
        name: "prod",
        starts_item: false,
        doc: "`prod(i in 0..n: …)`: the product of a scalar term over index tuples",
    },
];

/// Is `name` reserved (a keyword or a built-in function), so that it cannot name a symbol?
pub fn is_reserved(name: &str) -> bool {
    KEYWORDS.iter().any(|k| k.name == name) || builtin(name).is_some()
}

/// The function table of `docs/dsl.md`.
pub fn functions_markdown() -> String {
    let mut out =
        String::from("| function | shapes | value | derivative |\n| --- | --- | --- | --- |\n");
    // `|` inside a cell (sn(u | m)) is written `\|`
    let cell = |s: &str| s.replace('|', "\\|");
    for b in BUILTINS {
        out.push_str(&format!(
            "| `{}` | {} | {} | {} |\n",
            b.call,
            cell(b.shapes),
            cell(b.doc),
            cell(b.derivative)
        ));
    }
    out
}

/// The keyword table of `docs/dsl.md`.
pub fn keywords_markdown() -> String {
    let mut out = String::from("| keyword | declares |\n| --- | --- |\n");
    for k in KEYWORDS {
        out.push_str(&format!("| `{}` | {} |\n", k.name, k.doc));
    }
    out
}
