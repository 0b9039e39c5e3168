//! Writes one function body: inputs bound once, shared subexpressions in named temporaries
//! (common-subexpression elimination falls out of the hash-consed DAG), every output assigned
//! under a comment that points at the model line it comes from.

use super::names::Scope;
use crate::ir::{Func, Graph, Id, Input, Node, Rational};
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};
use std::collections::{HashMap, HashSet};

use super::leaves::Leaves;
use super::prepared::{describe, Prepared};

/// What a function does with one of its values.
pub enum Place {
    /// `place = value;`, e.g. `dx[3] = …;`.
    Assign(TokenStream),
    /// The function's tail expression (the last output).
    Return,
    /// `let name = value;` ([`Body::values`] holds the identifiers, made unique).
    Let(String),
    /// An element of an array the caller writes ([`Body::values`] holds the expressions).
    Element,
}

/// One value of the function, optionally under a note.
pub struct Output {
    /// Where it goes.
    pub place: Place,
    /// The value.
    pub id: Id,
    /// A comment line shown above it (shown once for consecutive equal notes).
    pub note: Option<String>,
}

/// A comment in generated code: a marker statement replaced by `// …` after formatting
/// (token streams cannot carry comments).
pub fn note(text: &str) -> TokenStream {
    let lit = Literal::string(text);
    quote!(lasalle_note!(#lit);)
}

/// Precedence of a rendered expression: what it can stand inside without parentheses.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Prec {
    Sum,
    Product,
    Unary,
    Atom,
}

struct Writer<'a> {
    g: &'a Graph,
    named: HashMap<Id, TokenStream>,
    parameter_only: &'a HashSet<Id>,
    scope: Scope,
}

/// A function body and what it needs.
pub struct Body {
    /// The statements.
    pub tokens: TokenStream,
    /// Operations it executes.
    pub ops: u64,
    /// The inputs it reads.
    inputs: Vec<Input>,
    /// The identifiers of the [`Place::Let`] outputs and the expressions of the
    /// [`Place::Element`] outputs, in order.
    pub values: Vec<TokenStream>,
}

impl Body {
    /// The argument `name`, with a leading underscore if the body reads no input of its kind
    /// (generated code has no unused-variable warnings).
    pub fn arg(&self, name: &str, kind: fn(&Input) -> bool) -> proc_macro2::Ident {
        if self.inputs.iter().any(kind) {
            format_ident!("{}", name)
        } else {
            format_ident!("_{}", name)
        }
    }
}

/// Where a function's parameter-only values come from.
pub enum Hoisting<'h> {
    /// A per-call function of the prepared model: the maximal parameter-only subexpressions
    /// are fields of the prepared model (`self.<name>`), registered in the [`Prepared`] list.
    Read(&'h mut Prepared),
    /// A function of the parameters alone (a named point), computed in place.
    Inline,
    /// The body of `prepare()`: the outputs are parameter-only values of the graph as the
    /// functions rewrote it, computed as they are (no rewriting, or the values would differ
    /// from the tapes' preludes).
    Prepare,
}

/// The statements of a function computing `outputs`, with `reserved` names (arguments) taken.
/// Except in [`Hoisting::Prepare`], the outputs are first rewritten for emission (factored
/// sums, shared roots and reciprocals, grouped parameter-only factors, shared products) in
/// `g`.
pub fn body(
    g: &mut Graph,
    leaves: &Leaves,
    outputs: &[Output],
    reserved: &[&str],
    mut hoisting: Hoisting,
) -> Body {
    let ids: Vec<Id> = outputs.iter().map(|o| o.id).collect();
    let roots = match hoisting {
        Hoisting::Prepare => ids,
        _ => g.optimize_for_emission(&ids),
    };
    let g: &Graph = g;
    let parameter_only = g.parameter_only(&g.reachable(&roots));
    let read = matches!(hoisting, Hoisting::Read(_));
    // A negation −a of a sum's term is written as a subtraction (`Writer::signed`).
    let negated = |id: Id| match g.node(id) {
        Node::Mul(fs) if fs.len() == 2 && g.as_num(fs[0]) == Some(-1.0) => Some(fs[1]),
        _ => None,
    };
    // The parameter-only values read from the prepared model: not the leaves, and not −μ.
    let hoisted = |id: Id| {
        read && parameter_only.contains(&id)
            && !g.children(id).is_empty()
            && negated(id).is_none_or(|a| !g.children(a).is_empty())
    };
    let order = reachable_until(g, &roots, hoisted);
    let ops = order
        .iter()
        .filter(|&&id| !hoisted(id))
        .map(|&id| g.node_ops(id))
        .sum();
    let inputs: Vec<Input> = order
        .iter()
        .filter_map(|&id| match g.node(id) {
            Node::Input(i) => Some(*i),
            _ => None,
        })
        .collect();
    let mut uses: HashMap<Id, usize> = HashMap::new();
    let mut term_uses: HashMap<Id, usize> = HashMap::new();
    for &id in order.iter().filter(|&&id| !hoisted(id)) {
        // A parameter-only product divides by its negative powers: it uses their bases.
        let divides = parameter_only.contains(&id) && matches!(g.node(id), Node::Mul(_));
        let sum = matches!(g.node(id), Node::Add(_));
        for &c in g.children(id) {
            let used = match *g.node(c) {
                Node::Pow(b, e) if divides && e.num < 0 => b,
                _ => c,
            };
            *uses.entry(used).or_default() += 1;
            if sum && negated(c).is_some() && !hoisted(c) {
                *term_uses.entry(c).or_default() += 1;
            }
        }
    }
    for r in &roots {
        *uses.entry(*r).or_default() += 1;
    }
    // A sum subtracts a negated term −a: it uses a, and −a is a value only if something else
    // uses it.
    for (&c, &terms) in &term_uses {
        let a = negated(c).expect("a negation");
        let other = uses[&c] - terms;
        uses.insert(c, other);
        *uses.entry(a).or_default() += if other > 0 { terms } else { terms - 1 };
    }
    let mut w = Writer {
        g,
        named: HashMap::new(),
        parameter_only: &parameter_only,
        scope: Scope::with(reserved),
    };
    // A local `lit` would shadow the function that writes literals (`lit::<T>(2.0)`);
    // `partial_sum` is the accumulator of long sums.
    w.scope.take("lit");
    w.scope.take("partial_sum");
    let mut stmts = Vec::new();
    // Leaves, each read once: the array arguments destructured (`let [theta, omega] = *x;`),
    // the parameters one by one; then the prepared values.
    let mut arrays: Vec<(&str, Vec<Option<proc_macro2::Ident>>)> = Vec::new();
    for &id in &order {
        let Node::Input(i) = g.node(id) else {
            continue;
        };
        if let Some((array, k, len)) = leaves.array(*i) {
            let ident = format_ident!("{}", w.scope.fresh(&leaves.input(*i).0));
            let slots = match arrays.iter().position(|(a, _)| *a == array) {
                Some(p) => &mut arrays[p].1,
                None => {
                    arrays.push((array, vec![None; len]));
                    &mut arrays.last_mut().expect("pushed").1
                }
            };
            slots[k] = Some(ident.clone());
            w.named.insert(id, quote!(#ident));
        }
    }
    for (array, slots) in &arrays {
        let pattern = array_pattern(slots);
        let array = format_ident!("{}", array);
        stmts.push(quote!(let [#pattern] = *#array;));
    }
    for &id in &order {
        if let Node::Input(i) = g.node(id) {
            if leaves.array(*i).is_some() {
                continue;
            }
            let (name, source) = leaves.input(*i);
            if source.to_string() == name {
                // an argument read as it is (the step size of a guard): no copy
                w.named.insert(id, source);
                continue;
            }
            let name = w.scope.fresh(&name);
            let ident = format_ident!("{}", name);
            stmts.push(quote!(let #ident = #source;));
            w.named.insert(id, quote!(#ident));
        }
    }
    if let Hoisting::Read(prepared) = &mut hoisting {
        for &id in order.iter().filter(|&&id| hoisted(id)) {
            let field = format_ident!("{}", prepared.field(g, leaves, id));
            let ident = format_ident!("{}", w.scope.fresh(&field.to_string()));
            stmts.push(quote!(let #ident = self.#field;));
            w.named.insert(id, quote!(#ident));
        }
    }
    // Values bound by name (the fields of `prepare()`).
    let bound: HashMap<Id, &str> = outputs
        .iter()
        .zip(&roots)
        .filter_map(|(o, &r)| match &o.place {
            Place::Let(name) => Some((r, name.as_str())),
            _ => None,
        })
        .collect();
    // Shared or named subexpressions become temporaries, in topological order.
    let mut temp = 0usize;
    let mut last_note: Option<String> = None;
    for &id in &order {
        if matches!(g.node(id), Node::Num(_) | Node::Input(_)) || hoisted(id) {
            continue;
        }
        let shared = uses.get(&id).copied().unwrap_or(0) >= 2;
        let let_name = leaves.let_name(id);
        let bound_name = bound.get(&id);
        if !(shared || let_name.is_some() || bound_name.is_some()) {
            continue;
        }
        let name = match (bound_name, let_name) {
            (Some(name), _) => w.scope.fresh(name),
            (None, Some((n, note_text))) => {
                if last_note.as_deref() != Some(note_text) {
                    stmts.push(note(note_text));
                    last_note = Some(note_text.clone());
                }
                w.scope.fresh(n)
            }
            (None, None) => match describe(g, leaves, id) {
                Some(name) => w.scope.fresh(&name),
                None => {
                    temp += 1;
                    w.scope.fresh(&format!("t{temp}"))
                }
            },
        };
        let value = w.render(id).0;
        let ident = format_ident!("{}", name);
        stmts.push(quote!(let #ident = #value;));
        w.named.insert(id, quote!(#ident));
    }
    // Outputs.
    let mut values = Vec::new();
    for (o, &root) in outputs.iter().zip(&roots) {
        if let Some(n) = &o.note {
            if last_note.as_deref() != Some(n) {
                stmts.push(note(n));
                last_note = Some(n.clone());
            }
        }
        let value = w.reference(root).0;
        match &o.place {
            Place::Assign(place) => stmts.push(quote!(#place = #value;)),
            Place::Return => stmts.push(value), // the function's tail expression
            Place::Let(_) | Place::Element => values.push(value),
        }
    }
    Body {
        tokens: quote!(#(#stmts)*),
        ops,
        inputs,
        values,
    }
}

/// The pattern of a destructured array, `_` for the unused components and `..` for the
/// longest run of them at the end (or else at the start): `theta, _, ..`.
fn array_pattern(slots: &[Option<proc_macro2::Ident>]) -> TokenStream {
    let trailing = slots.iter().rev().take_while(|s| s.is_none()).count();
    let leading = slots.iter().take_while(|s| s.is_none()).count();
    let (start, end) = if trailing >= 2 || (trailing > 0 && trailing >= leading) {
        (0, slots.len() - trailing)
    } else if leading >= 2 {
        (leading, slots.len())
    } else {
        (0, slots.len())
    };
    let names = slots[start..end].iter().map(|s| match s {
        Some(ident) => quote!(#ident),
        None => quote!(_),
    });
    match (start > 0, end < slots.len()) {
        (true, _) => quote!(.., #(#names),*),
        (_, true) => quote!(#(#names,)* ..),
        _ => quote!(#(#names),*),
    }
}

/// The nodes reachable from `roots` without going below a node where `stop` holds (those are
/// included), in ascending (topological) order.
fn reachable_until(g: &Graph, roots: &[Id], stop: impl Fn(Id) -> bool) -> Vec<Id> {
    let mut seen: HashSet<Id> = HashSet::new();
    let mut stack: Vec<Id> = roots.to_vec();
    while let Some(id) = stack.pop() {
        if seen.insert(id) && !stop(id) {
            stack.extend_from_slice(g.children(id));
        }
    }
    let mut out: Vec<Id> = seen.into_iter().collect();
    out.sort_unstable();
    out
}

/// Longest sum written as one expression; longer ones are split into partial sums.
const SUM_CHUNK: usize = 256;

/// A numeric literal as `T`.
pub fn literal(x: f64) -> TokenStream {
    // Lowering and `emit::check_finite` reject non-finite constants with a located error;
    // should one get here anyway, it is still valid Rust (proc-macro2 panics on ±∞ and NaN).
    if x.is_nan() {
        return quote!(T::nan());
    }
    if x.is_infinite() {
        return if x > 0.0 {
            quote!(T::infinity())
        } else {
            quote!(T::neg_infinity())
        };
    }
    if x == 0.0 {
        return quote!(T::zero());
    }
    if x == 1.0 {
        return quote!(T::one());
    }
    // A value that is exactly a named constant (√2 from `sqrt(2)`, π) is written by name.
    let magnitude = match NAMED_CONSTANTS.iter().find(|(_, v)| *v == x.abs()) {
        Some((name, _)) => {
            let name = format_ident!("{}", name);
            quote!(core::f64::consts::#name)
        }
        None => {
            let l = Literal::f64_unsuffixed(x.abs());
            quote!(#l)
        }
    };
    if x < 0.0 {
        quote!(lit::<T>(-#magnitude))
    } else {
        quote!(lit::<T>(#magnitude))
    }
}

/// The constants of `core::f64::consts` that folded literals may hit exactly.
const NAMED_CONSTANTS: &[(&str, f64)] = {
    use core::f64::consts::*;
    &[
        ("PI", PI),
        ("TAU", TAU),
        ("E", E),
        ("SQRT_2", SQRT_2),
        ("FRAC_1_SQRT_2", FRAC_1_SQRT_2),
        ("FRAC_PI_2", FRAC_PI_2),
        ("FRAC_PI_3", FRAC_PI_3),
        ("FRAC_PI_4", FRAC_PI_4),
        ("FRAC_PI_6", FRAC_PI_6),
        ("FRAC_PI_8", FRAC_PI_8),
        ("FRAC_1_PI", FRAC_1_PI),
        ("FRAC_2_PI", FRAC_2_PI),
        ("FRAC_2_SQRT_PI", FRAC_2_SQRT_PI),
        ("LN_2", LN_2),
        ("LN_10", LN_10),
        ("LOG2_E", LOG2_E),
        ("LOG10_E", LOG10_E),
        ("LOG2_10", LOG2_10),
        ("LOG10_2", LOG10_2),
    ]
};

impl Writer<'_> {
    fn wrap(&self, (ts, p): (TokenStream, Prec), min: Prec) -> TokenStream {
        if p < min {
            quote!((#ts))
        } else {
            ts
        }
    }

    /// A reference to a node: its name if it has one, else its rendering.
    fn reference(&self, id: Id) -> (TokenStream, Prec) {
        if let Some(n) = self.named.get(&id) {
            return (n.clone(), Prec::Atom);
        }
        self.render(id)
    }

    fn render(&self, id: Id) -> (TokenStream, Prec) {
        match self.g.node(id) {
            Node::Num(b) => {
                let x = f64::from_bits(*b);
                (literal(x), Prec::Atom)
            }
            Node::Input(_) => self.reference(id),
            Node::Add(terms) => self.sum(terms),
            Node::Mul(factors) => self.product(factors),
            Node::Pow(b, e) => self.power(*b, *e),
            Node::Func(f, a) => {
                let a = self.wrap(self.reference(*a), Prec::Atom);
                let ts = match f {
                    Func::Exp => quote!(#a.exp()),
                    Func::Ln => quote!(#a.ln()),
                    Func::Sin => quote!(#a.sin()),
                    Func::Cos => quote!(#a.cos()),
                    Func::EllipK => quote!(lasalle_runtime::elliptic::generic::ellipk(#a)),
                };
                (ts, Prec::Atom)
            }
            Node::Func2(f, [x, m]) => {
                let (x, m) = (self.reference(*x).0, self.reference(*m).0);
                let name = format_ident!("{}", f.name());
                (
                    quote!(lasalle_runtime::elliptic::generic::#name(#x, #m)),
                    Prec::Atom,
                )
            }
        }
    }

    /// A term's sign and magnitude: `−3xy → (true, 3xy)`. A negation `−a` is subtracted even
    /// when it has a name of its own (`b - a`, not `b + neg_a`: the same IEEE operation).
    fn signed(&self, id: Id) -> (bool, TokenStream, Prec) {
        // (A named parameter-only value is read, not recomputed: its parts may not be bound.)
        let read = self.named.contains_key(&id) && self.parameter_only.contains(&id);
        if let Node::Mul(fs) = self.g.node(id) {
            if fs.len() == 2 && self.g.as_num(fs[0]) == Some(-1.0) && !read {
                let (ts, p) = self.reference(fs[1]);
                return (true, ts, p);
            }
        }
        if !self.named.contains_key(&id) {
            match self.g.node(id) {
                Node::Num(b) if f64::from_bits(*b) < 0.0 => {
                    return (true, literal(-f64::from_bits(*b)), Prec::Atom);
                }
                Node::Mul(fs) => {
                    if let Some(c) = self.g.as_num(fs[0]).filter(|c| *c < 0.0) {
                        let (ts, p) = self.product_with(-c, &fs[1..]);
                        return (true, ts, p);
                    }
                }
                _ => {}
            }
        }
        let (ts, p) = self.reference(id);
        (false, ts, p)
    }

    fn sum(&self, terms: &[Id]) -> (TokenStream, Prec) {
        let mut parts: Vec<(bool, TokenStream, Prec)> =
            terms.iter().map(|&t| self.signed(t)).collect();
        // Positive terms first reads best: `a + b − c` rather than `−c + a + b`.
        parts.sort_by_key(|(neg, ..)| *neg);
        if parts.len() > SUM_CHUNK {
            return (self.long_sum(parts), Prec::Atom);
        }
        let mut out = TokenStream::new();
        for (k, (neg, ts, p)) in parts.into_iter().enumerate() {
            let t = self.wrap((ts, p), Prec::Product);
            // Extended in place: rebuilding `#out + #t` would copy the sum for every term.
            out.extend(match (k, neg) {
                (0, false) => t,
                (0, true) => quote!(-#t),
                (_, false) => quote!(+ #t),
                (_, true) => quote!(- #t),
            });
        }
        (out, Prec::Sum)
    }

    /// A sum of more than [`SUM_CHUNK`] terms as a block of partial sums,
    /// `{ let partial_sum = a + b + …; let partial_sum = partial_sum + c + …; partial_sum + … }`:
    /// the same additions in the same order, but no expression nests deeper than a chunk (a
    /// 10 000-term `a + b + …` is a 10 000-deep tree that overflows the parser's stack).
    fn long_sum(&self, parts: Vec<(bool, TokenStream, Prec)>) -> TokenStream {
        let mut chunks: Vec<TokenStream> = Vec::new();
        let mut parts = parts.into_iter().enumerate().peekable();
        while parts.peek().is_some() {
            let mut out = if chunks.is_empty() {
                TokenStream::new()
            } else {
                quote!(partial_sum)
            };
            for (k, (neg, ts, p)) in parts.by_ref().take(SUM_CHUNK) {
                let t = self.wrap((ts, p), Prec::Product);
                out.extend(match (k, neg) {
                    (0, false) => t,
                    (0, true) => quote!(-#t),
                    (_, false) => quote!(+ #t),
                    (_, true) => quote!(- #t),
                });
            }
            chunks.push(out);
        }
        let last = chunks.pop().expect("a long sum has chunks");
        quote!({ #(let partial_sum = #chunks;)* #last })
    }

    fn product(&self, factors: &[Id]) -> (TokenStream, Prec) {
        match self.g.as_num(factors[0]) {
            Some(c) if c < 0.0 => {
                let inner = self.product_with(-c, &factors[1..]);
                let inner = self.wrap(inner, Prec::Unary);
                (quote!(-#inner), Prec::Unary)
            }
            Some(c) => self.product_with(c, &factors[1..]),
            None => self.product_with(1.0, factors),
        }
    }

    /// c · Π factors, with negative powers written as divisions, unless the factor is a value
    /// of its own (a temporary, or a parameter-only value computed once) that the product
    /// multiplies; in a parameter-only product always as divisions, so that a parameter-only
    /// value does not depend on the function it is computed for (the tapes' preludes compute
    /// it the same way: see `tape::Lowering::product_with`).
    fn product_with(&self, c: f64, factors: &[Id]) -> (TokenStream, Prec) {
        let mut num: Vec<TokenStream> = Vec::new();
        let mut den: Vec<TokenStream> = Vec::new();
        if c != 1.0 {
            num.push(literal(c));
        }
        let parameter_only = factors.iter().all(|f| self.parameter_only.contains(f));
        for &f in factors {
            let own_value = self.named.contains_key(&f) || self.parameter_only.contains(&f);
            match self.g.node(f) {
                Node::Pow(b, e) if e.num < 0 && (parameter_only || !own_value) => {
                    let pos = Rational {
                        num: -e.num,
                        den: e.den,
                    };
                    den.push(self.wrap(self.power_positive(*b, pos), Prec::Atom));
                }
                _ => num.push(self.wrap(self.reference(f), Prec::Unary)),
            }
        }
        if num.is_empty() {
            num.push(quote!(T::one()));
        }
        let mut ts = num[0].clone();
        for n in &num[1..] {
            ts.extend(quote!(* #n));
        }
        for d in &den {
            ts.extend(quote!(/ #d));
        }
        let p = if num.len() == 1 && den.is_empty() {
            Prec::Atom
        } else {
            Prec::Product
        };
        (ts, p)
    }

    fn power(&self, b: Id, e: Rational) -> (TokenStream, Prec) {
        if e.num < 0 {
            let pos = self.wrap(
                self.power_positive(
                    b,
                    Rational {
                        num: -e.num,
                        den: e.den,
                    },
                ),
                Prec::Atom,
            );
            return (quote!(T::one() / #pos), Prec::Product);
        }
        self.power_positive(b, e)
    }

    /// bᵉ for e > 0.
    fn power_positive(&self, b: Id, e: Rational) -> (TokenStream, Prec) {
        // Reuse a named bᵉ or √b when one exists in this function.
        if let Some(id) = self.g.find(&Node::Pow(b, e)) {
            if let Some(n) = self.named.get(&id) {
                return (n.clone(), Prec::Atom);
            }
        }
        let base = self.wrap(self.reference(b), Prec::Atom);
        if e.is_int() {
            let n = Literal::i32_unsuffixed(e.num);
            if e.num == 1 {
                return (base, Prec::Atom);
            }
            if e.num == 2 && self.named.contains_key(&b) {
                return (quote!(#base * #base), Prec::Product);
            }
            return (quote!(#base.powi(#n)), Prec::Atom);
        }
        if e.den == 2 {
            let root = self
                .g
                .find(&Node::Pow(b, Rational::new(1, 2)))
                .and_then(|id| self.named.get(&id).cloned())
                .unwrap_or_else(|| quote!(#base.sqrt()));
            return match e.num {
                1 => (root, Prec::Atom),
                n => {
                    let n = Literal::i32_unsuffixed(n);
                    (quote!(#root.powi(#n)), Prec::Atom)
                }
            };
        }
        if e == Rational::new(1, 3) {
            return (quote!(#base.cbrt()), Prec::Atom);
        }
        let p = literal(e.to_f64());
        (quote!(#base.powf(#p)), Prec::Atom)
    }
}
