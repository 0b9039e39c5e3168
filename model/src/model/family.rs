//! Families: index ranges (`i in 0..n`), sums and products over them with conditions
//! (`sum(i in 0..n, j in 0..n, i != j: …)`), lists built from them (`[i in 0..n: …]`), indexed
//! state and parameters (`state q: vec3[n]`, `param m: scalar[n] = …`) and indexed equations
//! (`for i in 0..n: d/dt q[i] = …;`).
//!
//! A family is unrolled as it is lowered: the indices are whole numbers bound while the body is
//! lowered once per index tuple, so `q[i]` is a component (or a column) of `q` like `q[2]`, and
//! a sum is one flat n-ary node per component. A family of n members of shape `vecK` is a
//! K×n matrix (member i is column i, so the members lie one after another in the flat state);
//! a family of scalars is a vector of length n.
//!
//! A parameter used as a size (in a shape's count or a range's bound) is a constant of the
//! model: every use of it is its value, and it has no run-time slot.

use super::lower::{Ctx, Lowerer, L};
use super::{Shape, Value};
use crate::error::{Diagnostic, DiagnosticKind};
use crate::ir::Id;
use crate::parse::ast::*;
use std::collections::HashSet;

/// Index tuples a single family may have (a guard against a typo such as `0..1e9`).
const MAX_TUPLES: u64 = 50_000_000;

impl Lowerer {
    /// The value of the index `name`, if one is bound (the innermost binding).
    pub(super) fn index_value(&self, name: &str) -> Option<i64> {
        self.indices
            .iter()
            .rev()
            .find(|(n, _)| n == name)
            .map(|&(_, v)| v)
    }

    /// A constant whole number (a range bound, a size, an index in a condition).
    pub(super) fn integer(&mut self, e: &Expr, what: &str) -> L<i64> {
        let x = self.constant(e, what)?;
        if x.fract() != 0.0 || x.abs() > 1e15 {
            return Err(Diagnostic::new(
                &e.span,
                format!("{what} must be a whole number, this is {x}"),
            ));
        }
        Ok(x as i64)
    }

    /// The shape declared by `ty` (`vec3`, or a family `vec3[n]`); for a family, also the
    /// shape of one member.
    pub(super) fn declared_shape(&mut self, ty: &TypeName) -> L<(Shape, Option<Shape>)> {
        let Some(shape) = Shape::from_name(&ty.name) else {
            return Err(
                Diagnostic::new(&ty.span, format!("unknown shape `{}`", ty.name))
                    .help("shapes are `scalar`, `vecN` (e.g. `vec3`), `matN` or `matRxC`, and families of scalars or vectors: `vec3[n]`"),
            );
        };
        let Some(count) = &ty.count else {
            return Ok((shape, None));
        };
        let n = self.integer(count, "the size of a family")?;
        if n < 1 {
            return Err(Diagnostic::new(
                &count.span,
                format!("a family has at least one member, this one has {n}"),
            ));
        }
        let n = n as usize;
        match shape {
            Shape::Scalar => Ok((Shape::Vector(n), Some(shape))),
            Shape::Vector(k) => Ok((Shape::Matrix(k, n), Some(shape))),
            Shape::Matrix(..) => Err(Diagnostic::new(
                &ty.span,
                format!("a family's members are scalars or vectors, not a {shape}"),
            )
            .help("declare one family per column, or a `matRxC`")),
        }
    }

    /// The names used as sizes or range bounds anywhere in the model: parameters among them
    /// are constants of the model (see the module docs).
    pub(super) fn size_names(ast: &ModelAst) -> HashSet<String> {
        let mut out = HashSet::new();
        for it in &ast.items {
            size_names_item(&it.item, &mut out);
        }
        out
    }

    /// Runs `f` once per index tuple of `head` (clauses `k..`), the indices bound; an error
    /// inside says at which indices it happened.
    pub(super) fn for_each(
        &mut self,
        head: &FamilyHead,
        k: usize,
        count: &mut u64,
        f: &mut dyn FnMut(&mut Self) -> L<()>,
    ) -> L<()> {
        let Some(clause) = head.clauses.get(k) else {
            *count += 1;
            if *count > MAX_TUPLES {
                return Err(Diagnostic::new(
                    &head.span,
                    format!("this family has more than {MAX_TUPLES} index tuples"),
                )
                .help("check the ranges' bounds"));
            }
            return f(self).map_err(|d| self.locate_in_family(d));
        };
        match clause {
            Clause::Range { var, start, end } => {
                if self.symbols.contains_key(&var.name) || self.index_value(&var.name).is_some() {
                    let what = match self.symbols.get(&var.name) {
                        Some(sym) => format!("the {} `{}`", sym.kind.describe(), var.name),
                        None => format!("the enclosing index `{}`", var.name),
                    };
                    return Err(Diagnostic::new(
                        &var.span,
                        format!("index `{}` would hide {what}", var.name),
                    )
                    .help("give the index another name (`i`, `j`, `k`, …)"));
                }
                if crate::vocabulary::is_reserved(&var.name) {
                    return Err(Diagnostic::new(
                        &var.span,
                        format!("`{}` is reserved and cannot name an index", var.name),
                    )
                    .kind(DiagnosticKind::Reserved));
                }
                let a = self.integer(start, "a range's start")?;
                let b = self.integer(end, "a range's end")?;
                for v in a..b {
                    self.indices.push((var.name.clone(), v));
                    let r = self.for_each(head, k + 1, count, f);
                    self.indices.pop();
                    r?;
                }
                Ok(())
            }
            Clause::Cond { lhs, op, rhs } => {
                let a = self.integer(lhs, "a condition's side")?;
                let b = self.integer(rhs, "a condition's side")?;
                if op.holds(a, b) {
                    self.for_each(head, k + 1, count, f)
                } else {
                    Ok(())
                }
            }
        }
    }

    /// Appends the bound indices to a message from inside a family (once, innermost first).
    pub(super) fn locate_in_family(&self, mut d: Diagnostic) -> Diagnostic {
        if d.kind != DiagnosticKind::AlreadyReported
            && !d.message.contains(" (where ")
            && !self.indices.is_empty()
        {
            let at: Vec<String> = self
                .indices
                .iter()
                .map(|(n, v)| format!("{n} = {v}"))
                .collect();
            d.message = format!("{} (where {})", d.message, at.join(", "));
        }
        d
    }

    /// `sum(head: body)`, `prod(head: body)`: one flat sum (product) per component.
    pub(super) fn family(
        &mut self,
        op: FamilyOp,
        head: &FamilyHead,
        body: &Expr,
        e: &Expr,
        ctx: Ctx,
    ) -> L<Value> {
        if let Some(v) = self.loop_family(op, head, body, ctx)? {
            return Ok(v);
        }
        let mut shape: Option<Shape> = None;
        let mut terms: Vec<Vec<Id>> = Vec::new();
        let mut count = 0;
        self.for_each(head, 0, &mut count, &mut |lw| {
            let v = lw.expr(body, ctx)?;
            match shape {
                None => {
                    if op == FamilyOp::Prod && v.shape != Shape::Scalar {
                        return Err(Diagnostic::new(
                            &body.span,
                            format!("`prod` multiplies scalars, this is a {}", v.shape),
                        ));
                    }
                    shape = Some(v.shape);
                    terms = v.ids.iter().map(|&id| vec![id]).collect();
                }
                Some(s) if s != v.shape => {
                    return Err(Diagnostic::new(
                        &body.span,
                        format!("this term is a {}, an earlier term was a {s}", v.shape),
                    )
                    .help("every term of a family has one shape"));
                }
                Some(_) => {
                    for (t, &id) in terms.iter_mut().zip(&v.ids) {
                        t.push(id);
                    }
                }
            }
            Ok(())
        })?;
        let Some(shape) = shape else {
            // No index tuple: the empty sum is 0, the empty product 1.
            let empty = if op == FamilyOp::Sum { 0.0 } else { 1.0 };
            let _ = e;
            return Ok(Value::scalar(self.g.num(empty)));
        };
        let ids = terms
            .iter()
            .map(|t| match op {
                FamilyOp::Sum => self.g.add(t),
                FamilyOp::Prod => self.g.mul(t),
            })
            .collect();
        Ok(Value { shape, ids })
    }

    /// `[head: body]`: as the list of the body's values (scalars: a vector; vectors: the rows
    /// of a matrix).
    pub(super) fn comprehension(
        &mut self,
        head: &FamilyHead,
        body: &Expr,
        e: &Expr,
        ctx: Ctx,
    ) -> L<Value> {
        self.slot_fail("a list inside a loop family");
        let mut vals: Vec<Value> = Vec::new();
        let mut count = 0;
        self.for_each(head, 0, &mut count, &mut |lw| {
            let v = lw.expr(body, ctx)?;
            if let Some(first) = vals.first() {
                if first.shape != v.shape {
                    return Err(Diagnostic::new(
                        &body.span,
                        format!(
                            "this element is a {}, the first element is a {}",
                            v.shape, first.shape
                        ),
                    ));
                }
            }
            vals.push(v);
            Ok(())
        })?;
        if vals.is_empty() {
            return Err(Diagnostic::new(&e.span, "this list has no elements")
                .help("check the ranges' bounds"));
        }
        self.list_of(vals, e)
    }

    /// `x[i]` of a family `x` of vectors (a K×n matrix): its member i, column i. `None` when
    /// `base` is not such a family or more than one index is given.
    pub(super) fn member(&mut self, base: &Expr, v: &Value, idx: &[Expr]) -> L<Option<Value>> {
        let ExprKind::Name(name) = &base.kind else {
            return Ok(None);
        };
        let Some(member) = self.families.get(&name.name).copied() else {
            return Ok(None);
        };
        let Shape::Matrix(k, n) = v.shape else {
            return Ok(None);
        };
        if idx.len() != 1 {
            return Err(Diagnostic::new(
                &idx[1].span,
                format!(
                    "`{}` is a family of {n} {member}s: it takes one index",
                    name.name
                ),
            )
            .help(format!(
                "write `{0}[i]` for a member, `{0}[i][k]` for its component k",
                name.name
            )));
        }
        let i = self.index(&idx[0], n)?;
        Ok(Some(Value {
            shape: member,
            ids: v.ids[i * k..(i + 1) * k].to_vec(),
        }))
    }

    /// A value given for a family of vectors (a K×n matrix): a list literal or a
    /// comprehension is read member by member (its rows are the members), anything else as
    /// it is.
    pub(super) fn family_value(&mut self, shape: Shape, e: &Expr, v: Value) -> Value {
        let Shape::Matrix(k, n) = shape else {
            return v;
        };
        let literal = matches!(e.kind, ExprKind::List(_) | ExprKind::Comprehension(..));
        if literal && v.shape == Shape::Matrix(n, k) {
            // Rows are members: the transpose, column-major, is member after member.
            let ids = (0..n)
                .flat_map(|i| (0..k).map(move |c| (i, c)))
                .map(|(i, c)| v.at(i, c))
                .collect();
            return Value { shape, ids };
        }
        if v.shape == Shape::Vector(k) {
            // One vector for every member.
            let ids = (0..n).flat_map(|_| v.ids.iter().copied()).collect();
            return Value { shape, ids };
        }
        v
    }
}

fn size_names_item(item: &Item, out: &mut HashSet<String>) {
    let ty = |t: &TypeName, out: &mut HashSet<String>| {
        if let Some(c) = &t.count {
            names_in(c, out);
        }
    };
    match item {
        Item::State(decls) => decls.iter().for_each(|(_, t)| ty(t, out)),
        Item::Param(_, t, e) => {
            if let Some(t) = t {
                ty(t, out);
            }
            heads_in(e, out);
        }
        Item::Let(_, e)
        | Item::Derivative(_, e)
        | Item::Lyapunov(_, e)
        | Item::Hamiltonian(_, e) => heads_in(e, out),
        Item::Invariant { value, .. } => heads_in(value, out),
        Item::ElementDerivative(_, idx, e) => {
            idx.iter().for_each(|i| heads_in(i, out));
            heads_in(e, out);
        }
        Item::For(head, inner) => {
            head_names(head, out);
            size_names_item(&inner.item, out);
        }
        Item::Point(_, values) | Item::Run(_, values) => {
            values.iter().for_each(|(_, e)| heads_in(e, out));
        }
        Item::Guard { lhs, rhs, .. } => {
            heads_in(lhs, out);
            heads_in(rhs, out);
        }
        Item::Event { expr, .. } => heads_in(expr, out),
        Item::Structure(..) | Item::Splitting(..) => {}
    }
}

/// The names in the heads of the families inside `e`.
fn heads_in(e: &Expr, out: &mut HashSet<String>) {
    match &e.kind {
        ExprKind::Num(_) | ExprKind::Name(_) => {}
        ExprKind::Neg(a) => heads_in(a, out),
        ExprKind::Binary(_, a, b) => {
            heads_in(a, out);
            heads_in(b, out);
        }
        ExprKind::Chain(a, rest) => {
            heads_in(a, out);
            rest.iter().for_each(|(_, b)| heads_in(b, out));
        }
        ExprKind::Call(_, args) | ExprKind::List(args) => {
            args.iter().for_each(|a| heads_in(a, out));
        }
        ExprKind::Index(a, idx) => {
            heads_in(a, out);
            idx.iter().for_each(|i| heads_in(i, out));
        }
        ExprKind::Family(_, head, body) | ExprKind::Comprehension(head, body) => {
            head_names(head, out);
            heads_in(body, out);
        }
    }
}

fn head_names(head: &FamilyHead, out: &mut HashSet<String>) {
    for c in &head.clauses {
        match c {
            Clause::Range { start, end, .. } => {
                names_in(start, out);
                names_in(end, out);
            }
            Clause::Cond { lhs, rhs, .. } => {
                names_in(lhs, out);
                names_in(rhs, out);
            }
        }
    }
}

/// Every name in `e`.
fn names_in(e: &Expr, out: &mut HashSet<String>) {
    match &e.kind {
        ExprKind::Num(_) => {}
        ExprKind::Name(n) => {
            out.insert(n.name.clone());
        }
        ExprKind::Neg(a) => names_in(a, out),
        ExprKind::Binary(_, a, b) => {
            names_in(a, out);
            names_in(b, out);
        }
        ExprKind::Chain(a, rest) => {
            names_in(a, out);
            rest.iter().for_each(|(_, b)| names_in(b, out));
        }
        ExprKind::Call(_, args) | ExprKind::List(args) => {
            args.iter().for_each(|a| names_in(a, out));
        }
        ExprKind::Index(a, idx) => {
            names_in(a, out);
            idx.iter().for_each(|i| names_in(i, out));
        }
        ExprKind::Family(_, head, body) | ExprKind::Comprehension(head, body) => {
            head_names(head, out);
            names_in(body, out);
        }
    }
}

/// Does `e` mention any of `names`?
pub(super) fn mentions(e: &Expr, names: &[String]) -> bool {
    let mut all = HashSet::new();
    names_in(e, &mut all);
    names.iter().any(|n| all.contains(n))
}
