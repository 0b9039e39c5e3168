//! Stage 2: the hash-consed expression DAG.
//!
//! A [`Graph`] is an arena of [`Node`]s. Adding a node that already exists returns the existing
//! [`Id`], so equal subexpressions are shared from the start (egg's `EGraph::add`). Children are
//! always added before their parents, hence `child < parent` for every edge and ascending Id
//! order is a topological order.
//!
//! Nodes are built only through the smart constructors ([`Graph::add`], [`Graph::mul`],
//! [`Graph::pow`], …) which keep every node in canonical form:
//! - `Add` and `Mul` are n-ary, flattened, with children sorted by Id;
//! - numbers are folded, `x + 0 → x`, `x·1 → x`, `x·0 → 0`;
//! - like terms collect: `2x + 3x → 5x`, `x·x³ → x⁴`, `x·x⁻¹ → 1`;
//! - integer powers distribute over products and compose: `(ab)² → a²b²`, `(x^½)² → x`.
//!
//! For example `x*5 + x` becomes `Mul[Num(6), x]`.

mod count;
mod diff;
mod eval;
mod expand;
mod factor;
mod func;
mod hash;

pub use count::OpCount;
pub use diff::{diff, gradient, jacobian};
pub use eval::Scalar;
pub use factor::LARGE_GRAPH;
pub use func::{Func, Func2};
pub(crate) use hash::{FxHashMap, FxHashSet};

use std::collections::{HashMap, HashSet};
use std::fmt;

/// Index of a node in a [`Graph`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Id(pub u32);

impl Id {
    /// The index as usize.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A leaf that is not a number: a value supplied when the expression is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Input {
    /// Component of the flat state vector.
    State(u32),
    /// Scalar parameter slot.
    Param(u32),
    /// Component of the target f(x₀) (in Lyapunov functions).
    Target(u32),
    /// Gain slot (in Lyapunov functions).
    Gain(u32),
    /// An auxiliary symbol introduced by a rewrite (ρ = √s in a conservation proof); never
    /// part of a model's expressions.
    Symbol(u32),
}

/// A rational exponent p/q in lowest terms, q > 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Rational {
    /// Numerator.
    pub num: i32,
    /// Denominator, positive.
    pub den: i32,
}

impl Rational {
    /// p/q reduced to lowest terms.
    pub fn new(num: i32, den: i32) -> Rational {
        assert!(den != 0, "zero denominator");
        Rational::reduce(num.into(), den.into()).expect("a reduced i32 fraction fits in i32")
    }
    /// An integer.
    pub fn int(n: i32) -> Rational {
        Rational { num: n, den: 1 }
    }
    /// Is it an integer?
    pub fn is_int(self) -> bool {
        self.den == 1
    }
    /// As f64.
    pub fn to_f64(self) -> f64 {
        self.num as f64 / self.den as f64
    }
    /// The rational with denominator ≤ 12 equal to `x`, if any (`1.5 → 3/2`).
    pub fn from_f64(x: f64) -> Option<Rational> {
        (1..=12).find_map(|den| {
            let num = x * den as f64;
            (num.round() == num && num.abs() < 1e6).then(|| Rational::new(num as i32, den))
        })
    }
}

impl Rational {
    /// p/q from 64-bit parts, if it fits.
    fn reduce(num: i64, den: i64) -> Option<Rational> {
        let g = gcd(num.unsigned_abs(), den.unsigned_abs()).max(1) as i64;
        let s = if den < 0 { -1 } else { 1 };
        let (num, den) = (s * num / g, s * den / g);
        Some(Rational {
            num: i32::try_from(num).ok()?,
            den: i32::try_from(den).ok()?,
        })
    }

    /// The sum, or `None` if it overflows (absurd exponents never panic the generator).
    pub fn checked_add(self, o: Rational) -> Option<Rational> {
        let (a, b, c, d) = (self.num as i64, self.den as i64, o.num as i64, o.den as i64);
        Rational::reduce(a * d + c * b, b * d)
    }

    /// The product, or `None` if it overflows.
    pub fn checked_mul(self, o: Rational) -> Option<Rational> {
        Rational::reduce(
            self.num as i64 * o.num as i64,
            self.den as i64 * o.den as i64,
        )
    }
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

impl fmt::Display for Rational {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.den == 1 {
            write!(f, "{}", self.num)
        } else {
            write!(f, "{}/{}", self.num, self.den)
        }
    }
}

/// One node of the DAG. Numbers are stored by their bits so nodes can be hashed.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// A constant (never NaN, never −0).
    Num(u64),
    /// A value supplied at evaluation time.
    Input(Input),
    /// Sum of ≥ 2 terms, sorted by Id, at most one number.
    Add(Box<[Id]>),
    /// Product of ≥ 2 factors: an optional numeric coefficient first, then the other factors
    /// sorted by Id.
    Mul(Box<[Id]>),
    /// base ^ exponent, exponent ∉ {0, 1}.
    Pow(Id, Rational),
    /// f(x).
    Func(Func, Id),
    /// f(x, m): the elliptic functions, parameter m second.
    Func2(Func2, [Id; 2]),
}

/// The arena of interned nodes.
#[derive(Clone, Default)]
pub struct Graph {
    nodes: Vec<Node>,
    index: FxHashMap<Node, Id>,
}

impl Graph {
    /// An empty graph.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when no node has been added.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The node behind an Id.
    pub fn node(&self, id: Id) -> &Node {
        &self.nodes[id.index()]
    }

    /// Interns a node as is (no simplification): returns the existing Id if present.
    fn intern(&mut self, node: Node) -> Id {
        let next = Id(self.nodes.len() as u32);
        match self.index.entry(node) {
            std::collections::hash_map::Entry::Occupied(e) => *e.get(),
            std::collections::hash_map::Entry::Vacant(e) => {
                self.nodes.push(e.key().clone());
                e.insert(next);
                next
            }
        }
    }

    /// A numeric constant.
    pub fn num(&mut self, x: f64) -> Id {
        let x = if x == 0.0 { 0.0 } else { x }; // no −0
        self.intern(Node::Num(x.to_bits()))
    }

    /// A leaf.
    pub fn input(&mut self, input: Input) -> Id {
        self.intern(Node::Input(input))
    }

    /// The Id of a node if it is already in the graph (no insertion).
    pub fn find(&self, node: &Node) -> Option<Id> {
        self.index.get(node).copied()
    }

    /// The value of a numeric node.
    pub fn as_num(&self, id: Id) -> Option<f64> {
        match self.node(id) {
            Node::Num(bits) => Some(f64::from_bits(*bits)),
            _ => None,
        }
    }

    /// Splits a term into (numeric coefficient, rest): `3xy → (3, xy)`.
    fn split_coefficient(&mut self, id: Id) -> (f64, Option<Id>) {
        match self.node(id).clone() {
            Node::Num(b) => (f64::from_bits(b), None),
            Node::Mul(fs) => match self.as_num(fs[0]) {
                Some(c) => {
                    let rest = if fs.len() == 2 {
                        fs[1]
                    } else {
                        self.intern(Node::Mul(fs[1..].into()))
                    };
                    (c, Some(rest))
                }
                None => (1.0, Some(id)),
            },
            _ => (1.0, Some(id)),
        }
    }

    /// Canonical sum of `terms`.
    pub fn add(&mut self, terms: &[Id]) -> Id {
        let mut constant = 0.0;
        // term → coefficient, in first-seen order for determinism
        let mut coeffs: Vec<(Id, f64)> = Vec::new();
        let mut position: HashMap<Id, usize> = HashMap::new();
        let mut stack: Vec<Id> = terms.iter().rev().copied().collect();
        while let Some(t) = stack.pop() {
            if let Node::Add(inner) = self.node(t) {
                stack.extend(inner.iter().rev());
                continue;
            }
            match self.split_coefficient(t) {
                (c, None) => constant += c,
                (c, Some(rest)) => match position.get(&rest) {
                    Some(&k) => coeffs[k].1 += c,
                    None => {
                        position.insert(rest, coeffs.len());
                        coeffs.push((rest, c));
                    }
                },
            }
        }
        let mut out: Vec<Id> = Vec::with_capacity(coeffs.len() + 1);
        for (rest, c) in coeffs {
            if c != 0.0 {
                let k = self.num(c);
                out.push(self.mul(&[k, rest]));
            }
        }
        if constant != 0.0 {
            out.push(self.num(constant));
        }
        match out.len() {
            0 => self.num(0.0),
            1 => out[0],
            _ => {
                out.sort();
                self.intern(Node::Add(out.into()))
            }
        }
    }

    /// Canonical product of `factors`.
    pub fn mul(&mut self, factors: &[Id]) -> Id {
        let mut constant = 1.0;
        let mut exps: Vec<(Id, Rational)> = Vec::new();
        let mut position: HashMap<Id, usize> = HashMap::new();
        let mut stack: Vec<(Id, Rational)> = factors
            .iter()
            .rev()
            .map(|&f| (f, Rational::int(1)))
            .collect();
        while let Some((f, e)) = stack.pop() {
            match self.node(f).clone() {
                Node::Num(b) if e.is_int() => constant *= f64::from_bits(b).powi(e.num),
                Node::Mul(inner) if e.is_int() => stack.extend(inner.iter().rev().map(|&g| (g, e))),
                // (b^e2)^e = b^(e2·e) holds for integer e; (b²)^½ = |b| does not fold.
                Node::Pow(base, e2) if e.is_int() && e2.checked_mul(e).is_some() => {
                    stack.push((base, e2.checked_mul(e).expect("checked")))
                }
                _ => match position.get(&f) {
                    Some(&k) => match exps[k].1.checked_add(e) {
                        Some(sum) => exps[k].1 = sum,
                        None => exps.push((f, e)), // too large to merge: keep apart
                    },
                    None => {
                        position.insert(f, exps.len());
                        exps.push((f, e));
                    }
                },
            }
        }
        if constant == 0.0 {
            return self.num(0.0);
        }
        let mut out: Vec<Id> = Vec::with_capacity(exps.len() + 1);
        for (base, e) in exps {
            if e.num != 0 {
                out.push(self.pow_raw(base, e));
            }
        }
        out.sort();
        if constant != 1.0 || out.is_empty() {
            // The coefficient goes first, so `split_coefficient` finds it in O(1).
            out.insert(0, self.num(constant));
        }
        match out.len() {
            1 => out[0],
            _ => self.intern(Node::Mul(out.into())),
        }
    }

    /// `base ^ e` for a base that is no number, product or power (already reduced).
    fn pow_raw(&mut self, base: Id, e: Rational) -> Id {
        if e == Rational::int(1) {
            base
        } else {
            self.intern(Node::Pow(base, e))
        }
    }

    /// Canonical `base ^ e`.
    pub fn pow(&mut self, base: Id, e: Rational) -> Id {
        if e.num == 0 {
            return self.num(1.0);
        }
        if let Some(b) = self.as_num(base) {
            let v = b.powf(e.to_f64());
            if v.is_finite() {
                return self.num(v);
            }
        }
        // mul() distributes integer powers over products and composes powers.
        match self.node(base) {
            Node::Mul(_) | Node::Pow(..) => {
                let mut g = self.clone_shallow_pow(base, e);
                g.sort();
                self.mul(&g)
            }
            _ => self.pow_raw(base, e),
        }
    }

    /// Helper for [`Graph::pow`]: the factor list whose product is `base^e`.
    fn clone_shallow_pow(&mut self, base: Id, e: Rational) -> Vec<Id> {
        match self.node(base).clone() {
            Node::Mul(fs) if e.is_int() => fs.iter().map(|&f| self.pow(f, e)).collect(),
            Node::Pow(b, e2) if e.is_int() => match e2.checked_mul(e) {
                Some(p) => vec![self.pow(b, p)],
                None => vec![self.pow_raw(base, e)],
            },
            _ => vec![self.pow_raw(base, e)],
        }
    }

    /// a − b.
    pub fn sub(&mut self, a: Id, b: Id) -> Id {
        let nb = self.neg(b);
        self.add(&[a, nb])
    }

    /// −a.
    pub fn neg(&mut self, a: Id) -> Id {
        let m = self.num(-1.0);
        self.mul(&[m, a])
    }

    /// a / b.
    pub fn div(&mut self, a: Id, b: Id) -> Id {
        let r = self.pow(b, Rational::int(-1));
        self.mul(&[a, r])
    }

    /// √a.
    pub fn sqrt(&mut self, a: Id) -> Id {
        self.pow(a, Rational::new(1, 2))
    }

    /// f(a), folded on numbers.
    pub fn func(&mut self, f: Func, a: Id) -> Id {
        if let Some(x) = self.as_num(a) {
            let v = f.apply(x);
            if v.is_finite() {
                return self.num(v);
            }
        }
        match (f, self.node(a)) {
            (Func::Ln, Node::Func(Func::Exp, inner)) => *inner,
            (Func::Exp, Node::Func(Func::Ln, inner)) => *inner,
            _ => self.intern(Node::Func(f, a)),
        }
    }

    /// f(x, m), folded on numbers.
    pub fn func2(&mut self, f: Func2, x: Id, m: Id) -> Id {
        if let (Some(xv), Some(mv)) = (self.as_num(x), self.as_num(m)) {
            let v = f.apply(xv, mv);
            if v.is_finite() {
                return self.num(v);
            }
        }
        self.intern(Node::Func2(f, [x, m]))
    }

    /// The `roots` with every input `i` replaced by `rename(i)`, rebuilt through the smart
    /// constructors (in topological order, so deep expressions cannot overflow the stack).
    pub fn rename_inputs(&mut self, roots: &[Id], rename: impl Fn(Input) -> Input) -> Vec<Id> {
        let mut new: HashMap<Id, Id> = HashMap::new();
        for id in self.reachable(roots) {
            let n = match self.node(id).clone() {
                Node::Num(_) => id,
                Node::Input(i) => self.input(rename(i)),
                Node::Add(c) => {
                    let c: Vec<Id> = c.iter().map(|k| new[k]).collect();
                    self.add(&c)
                }
                Node::Mul(c) => {
                    let c: Vec<Id> = c.iter().map(|k| new[k]).collect();
                    self.mul(&c)
                }
                Node::Pow(b, e) => self.pow(new[&b], e),
                Node::Func(f, a) => self.func(f, new[&a]),
                Node::Func2(f, [x, m]) => self.func2(f, new[&x], new[&m]),
            };
            new.insert(id, n);
        }
        roots.iter().map(|r| new[r]).collect()
    }

    /// The children of a node.
    pub fn children(&self, id: Id) -> &[Id] {
        match self.node(id) {
            Node::Num(_) | Node::Input(_) => &[],
            Node::Add(c) | Node::Mul(c) => c,
            Node::Pow(b, _) | Node::Func(_, b) => std::slice::from_ref(b),
            Node::Func2(_, args) => args,
        }
    }

    /// Every node reachable from `roots`, in ascending (topological) order.
    ///
    /// Costs O(r log r) for r reachable nodes (plus clearing one bit per node of the graph),
    /// not a scan of the whole graph: it is called for every expression checked and emitted.
    pub fn reachable(&self, roots: &[Id]) -> Vec<Id> {
        let mut seen = vec![0u64; self.nodes.len().div_ceil(64)];
        let mut out: Vec<Id> = Vec::new();
        let mut stack: Vec<Id> = roots.to_vec();
        while let Some(id) = stack.pop() {
            let (word, bit) = (id.index() / 64, 1u64 << (id.index() % 64));
            if seen[word] & bit == 0 {
                seen[word] |= bit;
                out.push(id);
                stack.extend_from_slice(self.children(id));
            }
        }
        out.sort_unstable();
        out
    }

    /// The nodes of `order` (ascending, as [`Graph::reachable`] returns it) whose value depends
    /// on parameters and constants only: computed once per parameter set in the emitted code
    /// and in a tape's prelude.
    pub fn parameter_only(&self, order: &[Id]) -> HashSet<Id> {
        let mut out = HashSet::new();
        for &id in order {
            let only = match self.node(id) {
                Node::Num(_) | Node::Input(Input::Param(_)) => true,
                Node::Input(_) => false,
                _ => self.children(id).iter().all(|c| out.contains(c)),
            };
            if only {
                out.insert(id);
            }
        }
        out
    }

    /// Does the expression depend on any input for which `pred` holds?
    pub fn depends_on(&self, root: Id, pred: impl Fn(Input) -> bool) -> bool {
        self.reachable(&[root])
            .into_iter()
            .any(|id| matches!(self.node(id), Node::Input(i) if pred(*i)))
    }

    /// Rebuilds everything reachable from `roots` bottom-up. `rewrite` sees each node with its
    /// children already rebuilt and returns its new Id, or `None` to rebuild it with the
    /// canonical constructors.
    pub fn rebuild(
        &mut self,
        roots: &[Id],
        mut rewrite: impl FnMut(&mut Graph, &Node) -> Option<Id>,
    ) -> Vec<Id> {
        let order = self.reachable(roots);
        let mut new: HashMap<Id, Id> = HashMap::with_capacity(order.len());
        for id in order {
            let node = match self.node(id).clone() {
                Node::Add(c) => Node::Add(c.iter().map(|k| new[k]).collect()),
                Node::Mul(c) => Node::Mul(c.iter().map(|k| new[k]).collect()),
                Node::Pow(b, e) => Node::Pow(new[&b], e),
                Node::Func(f, a) => Node::Func(f, new[&a]),
                Node::Func2(f, [x, m]) => Node::Func2(f, [new[&x], new[&m]]),
                leaf => leaf,
            };
            let rebuilt = match rewrite(self, &node) {
                Some(r) => r,
                None => match node {
                    Node::Num(_) | Node::Input(_) => id,
                    Node::Add(c) => self.add(&c),
                    Node::Mul(c) => self.mul(&c),
                    Node::Pow(b, e) => self.pow(b, e),
                    Node::Func(f, a) => self.func(f, a),
                    Node::Func2(f, [x, m]) => self.func2(f, x, m),
                },
            };
            new.insert(id, rebuilt);
        }
        roots.iter().map(|r| new[r]).collect()
    }

    /// A readable rendering of an expression (for tests and messages).
    pub fn display(&self, id: Id) -> String {
        match self.node(id) {
            Node::Num(b) => format!("{}", f64::from_bits(*b)),
            Node::Input(Input::State(i)) => format!("x{i}"),
            Node::Input(Input::Param(i)) => format!("p{i}"),
            Node::Input(Input::Target(i)) => format!("f0_{i}"),
            Node::Input(Input::Gain(i)) => format!("k{i}"),
            Node::Input(Input::Symbol(i)) => format!("s{i}"),
            Node::Add(c) => format!(
                "({})",
                c.iter()
                    .map(|&k| self.display(k))
                    .collect::<Vec<_>>()
                    .join(" + ")
            ),
            Node::Mul(c) => c
                .iter()
                .map(|&k| self.display(k))
                .collect::<Vec<_>>()
                .join("*"),
            Node::Pow(b, e) => format!(
                "{}^{}",
                self.display(*b),
                if e.is_int() {
                    e.to_string()
                } else {
                    format!("({e})")
                }
            ),
            Node::Func(f, a) => format!("{}({})", f.name(), self.display(*a)),
            Node::Func2(f, [x, m]) => {
                format!("{}({}, {})", f.name(), self.display(*x), self.display(*m))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn xy(g: &mut Graph) -> (Id, Id) {
        (g.input(Input::State(0)), g.input(Input::State(1)))
    }

    #[test]
    fn hash_consing_shares_equal_nodes() {
        let mut g = Graph::new();
        let (x, y) = xy(&mut g);
        let a = g.add(&[x, y]);
        let b = g.add(&[y, x]);
        assert_eq!(a, b);
    }

    #[test]
    fn simplification_rules() {
        let mut g = Graph::new();
        let (x, y) = xy(&mut g);
        let five = g.num(5.0);
        let x5 = g.mul(&[x, five]);
        let e = g.add(&[x5, x]);
        assert_eq!(g.display(e), "6*x0"); // x*5 + x ⇒ 6x
        let zero = g.num(0.0);
        assert_eq!(g.add(&[x, zero]), x); // x + 0 ⇒ x
        let one = g.num(1.0);
        assert_eq!(g.mul(&[x, one]), x); // x·1 ⇒ x
        assert_eq!(g.mul(&[x, zero]), zero); // x·0 ⇒ 0
        let inv = g.div(one, x);
        assert_eq!(g.mul(&[x, inv]), one); // x/x ⇒ 1
        let d = g.sub(e, x5);
        assert_eq!(d, x); // 6x − 5x ⇒ x
        let xy_ = g.mul(&[x, y]);
        let sq = g.pow(xy_, Rational::int(2));
        assert_eq!(g.display(sq), "x0^2*x1^2"); // (xy)² ⇒ x²y²
        let r = g.sqrt(x);
        let r2 = g.pow(r, Rational::int(2));
        assert_eq!(r2, x); // (√x)² ⇒ x
        let r3 = g.pow(r, Rational::int(-3));
        assert_eq!(g.display(r3), "x0^(-3/2)");
        let n = g.num(4.0);
        let s = g.sqrt(n);
        assert_eq!(g.as_num(s), Some(2.0)); // √4 ⇒ 2
    }

    #[test]
    fn half_powers_of_squares_are_not_folded() {
        // (x²)^½ = |x| ≠ x
        let mut g = Graph::new();
        let (x, _) = xy(&mut g);
        let x2 = g.pow(x, Rational::int(2));
        let r = g.sqrt(x2);
        assert_eq!(g.display(r), "x0^2^(1/2)");
    }

    #[test]
    fn children_precede_parents() {
        let mut g = Graph::new();
        let (x, y) = xy(&mut g);
        let s = g.add(&[x, y]);
        let p = g.mul(&[s, x]);
        for id in g.reachable(&[p]) {
            assert!(g.children(id).iter().all(|&c| c < id));
        }
    }
}
