//! Lowering of expressions: names, operators, calls, with their shapes checked.

use super::lower::{Ctx, Kind, Lowerer, Symbol, L};
use super::{Shape, Value};
use crate::error::{Diagnostic, DiagnosticKind};
use crate::ir::{Func2, Graph, Id, Input, Node, Rational};
use crate::parse::ast::*;
use crate::vocabulary::{self, Builtin, Lowering, BUILTINS};

/// Products with this many operators or more are multiplied at once (see [`Lowerer::chain`]).
const LONG_CHAIN: usize = 32;

impl Lowerer {
    pub(super) fn lookup(&self, name: &Ident, ctx: Ctx) -> L<Symbol> {
        match self.symbols.get(&name.name) {
            Some(sym) => {
                let allowed = match ctx {
                    Ctx::Constant => false,
                    Ctx::Model => sym.kind != Kind::Gain,
                    Ctx::Lyapunov => true,
                };
                if !allowed {
                    let help = if ctx == Ctx::Constant {
                        "parameter defaults and gains must be constants: numbers or earlier parameters".to_string()
                    } else {
                        "gains may appear only in `lyapunov`".to_string()
                    };
                    return Err(Diagnostic::new(
                        &name.span,
                        format!(
                            "{} `{}` cannot be used here",
                            sym.kind.describe(),
                            name.name
                        ),
                    )
                    .help(help)
                    .kind(DiagnosticKind::NotAllowedHere));
                }
                Ok(sym.clone())
            }
            None if self.poisoned.contains(&name.name) => {
                Err(Diagnostic::already_reported(&name.span))
            }
            None if self.gain_names.contains(&name.name) => Err(Diagnostic::new(
                &name.span,
                format!("gain `{}` cannot be used here", name.name),
            )
            .help("gains may appear only in `lyapunov`")
            .kind(DiagnosticKind::NotAllowedHere)),
            None => {
                let mut d = Diagnostic::new(&name.span, format!("unknown symbol `{}`", name.name))
                    .kind(DiagnosticKind::UnknownName);
                if let Some(s) = self.suggest(&name.name) {
                    d = d.help(format!("did you mean `{s}`?"));
                } else {
                    d = d.help("declare it with `state`, `param` or `let` before this line");
                }
                Err(d)
            }
        }
    }

    pub(super) fn suggest(&self, name: &str) -> Option<String> {
        let lower = name.to_lowercase();
        let mut best: Option<(usize, &String)> = None;
        for k in self.symbols.keys() {
            let d = if k.to_lowercase() == lower {
                0
            } else {
                edit_distance(&k.to_lowercase(), &lower)
            };
            if d <= 2.max(name.len() / 3)
                && best.is_none_or(|(bd, bk)| d < bd || (d == bd && k < bk))
            {
                best = Some((d, k));
            }
        }
        best.map(|(_, k)| k.clone())
    }

    pub(super) fn expect_scalar(&self, v: &Value, e: &Expr, what: &str) -> L<Id> {
        if v.shape == Shape::Scalar {
            Ok(v.ids[0])
        } else {
            Err(Diagnostic::new(
                &e.span,
                format!("{what} must be a scalar, this is a {}", v.shape),
            ))
        }
    }

    pub(super) fn constant(&mut self, e: &Expr, what: &str) -> L<f64> {
        let v = self.expr(e, Ctx::Constant).map_err(|d| {
            if d.kind == DiagnosticKind::UnknownName && matches!(&e.kind, ExprKind::Name(_)) {
                d.help("a constant here is a number, a parameter, or an index bound by `sum(i in …: …)`, `[i in …: …]` or `for i in …:`")
            } else if matches!(
                d.kind,
                DiagnosticKind::NotAllowedHere | DiagnosticKind::UnknownName
            ) {
                Diagnostic::new(&e.span, format!("{what} must be a constant number"))
                    .help("write a number, e.g. `2` or `1/2`")
            } else {
                d
            }
        })?;
        let id = self.expect_scalar(&v, e, what)?;
        self.g
            .as_num(id)
            .ok_or_else(|| Diagnostic::new(&e.span, format!("{what} must be a constant number")))
    }

    pub(super) fn index(&mut self, e: &Expr, len: usize) -> L<usize> {
        let k = self.constant(e, "an index")?;
        if k.fract() != 0.0 || k < 0.0 || k >= len as f64 {
            return Err(
                Diagnostic::new(&e.span, format!("index {k} is out of range 0..{len}"))
                    .help("indices are whole numbers counted from 0"),
            );
        }
        Ok(k as usize)
    }

    /// Lowers an expression; a constant that folds to ±∞ or NaN is reported at the smallest
    /// expression that produced it (`1/0`, `log(0)`, `1e400`), never passed on to emission.
    pub(super) fn expr(&mut self, e: &Expr, ctx: Ctx) -> L<Value> {
        let v = self.expr_inner(e, ctx)?;
        self.check_finite(&v, e)?;
        Ok(v)
    }

    /// Fails if `v` is a constant that is not finite, or if lowering `e` put a non-finite
    /// number into the graph. Each node is evaluated once, in creation order (children
    /// first), so the check costs O(1) per node over the whole model.
    fn check_finite(&mut self, v: &Value, e: &Expr) -> L<()> {
        let bad = self.sweep_constants().or_else(|| {
            v.ids
                .iter()
                .filter_map(|id| self.constants[id.index()])
                .find(|x| !x.is_finite())
        });
        match bad {
            None => Ok(()),
            Some(x) => {
                let text = e
                    .span
                    .text()
                    .split_whitespace()
                    .collect::<Vec<_>>()
                    .join(" ");
                let text = if text.chars().count() > 60 {
                    format!("{}…", text.chars().take(59).collect::<String>())
                } else {
                    text
                };
                Err(Diagnostic::new(
                    &e.span,
                    format!("constant expression `{text}` is not finite (it is {x})"),
                )
                .help("generated code computes in finite floating point: check for a division by zero, the log or square root of a non-positive number, or a number beyond ±1.8e308")
                .kind(DiagnosticKind::NotFinite))
            }
        }
    }

    /// Evaluates the constant nodes created since the last sweep (in creation order, so
    /// children first); returns a non-finite number among the new nodes, if one was created.
    pub(super) fn sweep_constants(&mut self) -> Option<f64> {
        let mut bad = None;
        for k in self.constants.len()..self.g.len() {
            let id = Id(k as u32);
            let c = |k: &Id| self.constants[k.index()];
            let value = match self.g.node(id) {
                Node::Num(b) => Some(f64::from_bits(*b)),
                Node::Input(_) => None,
                Node::Add(ch) => ch.iter().map(c).sum::<Option<f64>>(),
                Node::Mul(ch) => ch.iter().map(c).product::<Option<f64>>(),
                Node::Pow(b, r) if r.is_int() => c(b).map(|x| x.powi(r.num)),
                Node::Pow(b, r) => c(b).map(|x| x.powf(r.to_f64())),
                Node::Func(f, a) => c(a).map(|x| f.apply(x)),
                Node::Func2(f, [x, m]) => c(x).zip(c(m)).map(|(x, m)| f.apply(x, m)),
            };
            if matches!(self.g.node(id), Node::Num(_)) && value.is_some_and(|x| !x.is_finite()) {
                bad = value;
            }
            self.constants.push(value);
        }
        bad
    }

    fn expr_inner(&mut self, e: &Expr, ctx: Ctx) -> L<Value> {
        match &e.kind {
            ExprKind::Num(x) => Ok(Value::scalar(self.g.num(*x))),
            ExprKind::Name(name) if self.index_value(&name.name).is_some() => {
                if self.slot_index(&name.name)
                    && !self.slot.as_ref().is_some_and(|s| s.in_subscript)
                {
                    self.slot_fail("an index used as a number");
                }
                let v = self.index_value(&name.name).unwrap_or_default();
                Ok(Value::scalar(self.g.num(v as f64)))
            }
            ExprKind::Name(name) => {
                if ctx == Ctx::Constant {
                    if let Some(sym) = self
                        .symbols
                        .get(&name.name)
                        .filter(|s| s.kind == Kind::Param)
                    {
                        let ids = sym.value.ids.clone();
                        let folded = ids
                            .iter()
                            .map(|&id| match *self.g.node(id) {
                                Node::Input(Input::Param(k)) => {
                                    self.g.num(self.param_defaults[k as usize])
                                }
                                _ => id,
                            })
                            .collect();
                        return Ok(Value {
                            shape: sym.value.shape,
                            ids: folded,
                        });
                    }
                }
                Ok(self.lookup(name, ctx)?.value)
            }
            ExprKind::Neg(inner) => {
                let v = self.expr(inner, ctx)?;
                Ok(self.map(&v, |g, x| g.neg(x)))
            }
            ExprKind::Binary(op, a, b) => self.binary(*op, a, b, e, ctx),
            ExprKind::Chain(first, rest) => self.chain(first, rest, ctx),
            ExprKind::Call(f, args) => self.call(f, args, e, ctx),
            ExprKind::Family(op, head, body) => self.family(*op, head, body, e, ctx),
            ExprKind::Comprehension(head, body) => self.comprehension(head, body, e, ctx),
            ExprKind::Index(base, idx) => {
                let v = self.expr(base, ctx)?;
                if let Some(member) = self.slot_member(base, &v, idx)? {
                    return Ok(member);
                }
                if let Some(member) = self.member(base, &v, idx)? {
                    return Ok(member);
                }
                match (v.shape, idx.len()) {
                    (Shape::Vector(n), 1) => {
                        let i = self.index(&idx[0], n)?;
                        Ok(Value::scalar(v.ids[i]))
                    }
                    (Shape::Matrix(r, c), 2) => {
                        let i = self.index(&idx[0], r)?;
                        let j = self.index(&idx[1], c)?;
                        Ok(Value::scalar(v.at(i, j)))
                    }
                    (Shape::Matrix(..), _) => {
                        Err(Diagnostic::new(&e.span, "a matrix takes two indices")
                            .help("write `R[i, j]` (row, column, counted from 0)"))
                    }
                    (Shape::Vector(_), _) => {
                        Err(Diagnostic::new(&e.span, "a vector takes one index")
                            .help("write `x[i]`"))
                    }
                    (Shape::Scalar, _) => Err(Diagnostic::new(&base.span, "cannot index a scalar")),
                }
            }
            ExprKind::List(elems) => self.list(elems, e, ctx),
        }
    }

    pub(super) fn list(&mut self, elems: &[Expr], e: &Expr, ctx: Ctx) -> L<Value> {
        let vals: Vec<Value> = elems.iter().map(|x| self.expr(x, ctx)).collect::<L<_>>()?;
        self.list_of(vals, e)
    }

    /// The list of `vals`: scalars make a vector, equal-length vectors the rows of a matrix.
    pub(super) fn list_of(&mut self, vals: Vec<Value>, e: &Expr) -> L<Value> {
        let span_of = |k: usize| match &e.kind {
            ExprKind::List(elems) => elems[k].span.clone(),
            _ => e.span.clone(),
        };
        if vals.iter().all(|v| v.shape == Shape::Scalar) {
            return Ok(Value {
                shape: Shape::Vector(vals.len()),
                ids: vals.iter().map(|v| v.ids[0]).collect(),
            });
        }
        // Rows of a matrix.
        let first = vals[0].shape;
        let Shape::Vector(c) = first else {
            return Err(Diagnostic::new(
                &e.span,
                "a list holds scalars (a vector) or equal-length rows (a matrix)",
            ));
        };
        if let Some((k, v)) = vals.iter().enumerate().find(|(_, v)| v.shape != first) {
            return Err(Diagnostic::new(
                &span_of(k),
                format!("row {k} is a {}, the first row is a {first}", v.shape),
            ));
        }
        let r = vals.len();
        let mut ids = Vec::with_capacity(r * c);
        for j in 0..c {
            for row in &vals {
                ids.push(row.ids[j]);
            }
        }
        Ok(Value {
            shape: Shape::Matrix(r, c),
            ids,
        })
    }

    pub(super) fn map(&mut self, v: &Value, mut f: impl FnMut(&mut Graph, Id) -> Id) -> Value {
        Value {
            shape: v.shape,
            ids: v.ids.iter().map(|&x| f(&mut self.g, x)).collect(),
        }
    }

    /// A flat chain `a op b op c …`, lowered in a loop: a sum becomes one n-ary sum per
    /// component (linear in the number of terms), a product of scalars one n-ary product;
    /// other products are multiplied left to right.
    pub(super) fn chain(&mut self, first: &Expr, rest: &[(BinOp, Expr)], ctx: Ctx) -> L<Value> {
        let acc = self.expr(first, ctx)?;
        if matches!(rest[0].0, BinOp::Add | BinOp::Sub) {
            let mut terms: Vec<Vec<Id>> = acc.ids.iter().map(|&id| vec![id]).collect();
            for (op, b) in rest {
                let vb = self.expr(b, ctx)?;
                if vb.shape != acc.shape {
                    let verb = if *op == BinOp::Add { "add" } else { "subtract" };
                    return Err(Diagnostic::new(
                        &first.span.to(&b.span),
                        format!("cannot {verb} a {} and a {}", acc.shape, vb.shape),
                    )
                    .help("both sides of `+` and `-` must have the same shape"));
                }
                for (t, &y) in terms.iter_mut().zip(&vb.ids) {
                    t.push(if *op == BinOp::Sub { self.g.neg(y) } else { y });
                }
            }
            let ids = terms.iter().map(|t| self.g.add(t)).collect();
            return Ok(Value {
                shape: acc.shape,
                ids,
            });
        }
        // Short chains are multiplied left to right, as `(a·b)·c`: their prefix products are
        // nodes of the DAG, which the emitted code's term order depends on. In a long chain a
        // run of scalar factors is collected and multiplied once, so a product of n scalars
        // costs O(n), not O(n²).
        let mut acc = acc;
        let mut pending: Vec<Id> = Vec::new();
        let long = rest.len() >= LONG_CHAIN && rest.iter().all(|(op, _)| *op != BinOp::Rem);
        for (op, b) in rest {
            let vb = self.expr(b, ctx)?;
            if long && acc.shape == Shape::Scalar && vb.shape == Shape::Scalar {
                if pending.is_empty() {
                    pending.push(acc.ids[0]);
                }
                pending.push(if *op == BinOp::Div {
                    self.g.pow(vb.ids[0], Rational::int(-1))
                } else {
                    vb.ids[0]
                });
                continue;
            }
            if !pending.is_empty() {
                acc = Value::scalar(self.g.mul(&pending));
                pending.clear();
            }
            acc = self.apply(*op, acc, vb, &first.span.to(&b.span), &b.span)?;
        }
        if !pending.is_empty() {
            acc = Value::scalar(self.g.mul(&pending));
        }
        Ok(acc)
    }

    pub(super) fn binary(&mut self, op: BinOp, a: &Expr, b: &Expr, e: &Expr, ctx: Ctx) -> L<Value> {
        let va = self.expr(a, ctx)?;
        if op == BinOp::Pow {
            if va.shape != Shape::Scalar {
                return Err(Diagnostic::new(
                    &a.span,
                    format!("cannot raise a {} to a power", va.shape),
                )
                .help("`^` applies to scalars; use matrix products for matrices"));
            }
            let p = self.constant(b, "an exponent")?;
            let Some(r) = Rational::from_f64(p) else {
                return Err(Diagnostic::new(
                    &b.span,
                    format!("exponent {p} is not a simple fraction"),
                )
                .help(
                    "exponents are integers or fractions with denominators up to 12, e.g. `3/2`",
                ));
            };
            return Ok(Value::scalar(self.g.pow(va.ids[0], r)));
        }
        let vb = self.expr(b, ctx)?;
        self.apply(op, va, vb, &e.span, &b.span)
    }

    /// `va op vb` for `+ - * /`, with shapes checked; `span` is the whole operation's,
    /// `b_span` the right operand's.
    pub(super) fn apply(
        &mut self,
        op: BinOp,
        va: Value,
        vb: Value,
        span: &crate::Span,
        b_span: &crate::Span,
    ) -> L<Value> {
        let (sa, sb) = (va.shape, vb.shape);
        match op {
            BinOp::Add | BinOp::Sub => {
                if sa != sb {
                    let verb = if op == BinOp::Add { "add" } else { "subtract" };
                    return Err(
                        Diagnostic::new(span, format!("cannot {verb} a {sa} and a {sb}"))
                            .help("both sides of `+` and `-` must have the same shape"),
                    );
                }
                let ids = va
                    .ids
                    .iter()
                    .zip(&vb.ids)
                    .map(|(&x, &y)| {
                        if op == BinOp::Add {
                            self.g.add(&[x, y])
                        } else {
                            self.g.sub(x, y)
                        }
                    })
                    .collect();
                Ok(Value { shape: sa, ids })
            }
            BinOp::Mul => {
                if sa == Shape::Scalar {
                    return Ok(self.map(&vb, |g, y| g.mul(&[va.ids[0], y])));
                }
                if sb == Shape::Scalar {
                    return Ok(self.map(&va, |g, x| g.mul(&[x, vb.ids[0]])));
                }
                if let (Shape::Vector(_), Shape::Vector(_)) = (sa, sb) {
                    return Err(
                        Diagnostic::new(span, format!("cannot multiply a {sa} by a {sb}"))
                            .help("use `dot(a, b)` or `cross(a, b)`"),
                    );
                }
                let ((r1, c1), (r2, c2)) = (sa.dims(), sb.dims());
                if c1 != r2 {
                    return Err(Diagnostic::new(span, format!("cannot multiply a {sa} by a {sb}: inner dimensions {c1} and {r2} differ")));
                }
                let mut ids = Vec::with_capacity(r1 * c2);
                for j in 0..c2 {
                    for i in 0..r1 {
                        let terms: Vec<Id> = (0..c1)
                            .map(|k| {
                                let (x, y) = (va.at(i, k), vb.at(k, j));
                                self.g.mul(&[x, y])
                            })
                            .collect();
                        ids.push(self.g.add(&terms));
                    }
                }
                Ok(Value {
                    shape: Shape::from_dims(r1, c2),
                    ids,
                })
            }
            BinOp::Div => {
                if sb != Shape::Scalar {
                    return Err(Diagnostic::new(b_span, format!("cannot divide by a {sb}"))
                        .help("divide by scalars only; use `inv(M)` for parameter matrices"));
                }
                Ok(self.map(&va, |g, x| g.div(x, vb.ids[0])))
            }
            BinOp::Rem => {
                let (x, y) = (
                    (sa == Shape::Scalar)
                        .then(|| self.g.as_num(va.ids[0]))
                        .flatten(),
                    (sb == Shape::Scalar)
                        .then(|| self.g.as_num(vb.ids[0]))
                        .flatten(),
                );
                match (x, y) {
                    (Some(x), Some(y)) if x.fract() == 0.0 && y.fract() == 0.0 && y != 0.0 => {
                        Ok(Value::scalar(self.g.num(x.rem_euclid(y))))
                    }
                    _ => Err(Diagnostic::new(
                        span,
                        "`%` takes two constant whole numbers, the second not 0",
                    )
                    .help("`%` computes indices, e.g. the neighbour `q[(i + 1) % n]` of a periodic chain")),
                }
            }
            BinOp::Pow => unreachable!("handled above"),
        }
    }

    pub(super) fn cross(&mut self, a: &[Id], b: &[Id]) -> Vec<Id> {
        let c = |g: &mut Graph, i: usize, j: usize| {
            let p = g.mul(&[a[i], b[j]]);
            let q = g.mul(&[a[j], b[i]]);
            g.sub(p, q)
        };
        vec![
            c(&mut self.g, 1, 2),
            c(&mut self.g, 2, 0),
            c(&mut self.g, 0, 1),
        ]
    }

    pub(super) fn diag_args(&mut self, args: &[Expr], e: &Expr, ctx: Ctx) -> L<Value> {
        let entries: Vec<Id> = if args.len() == 1 {
            let v = self.expr(&args[0], ctx)?;
            match v.shape {
                Shape::Vector(_) => v.ids,
                s => {
                    return Err(Diagnostic::new(
                        &args[0].span,
                        format!("diag takes a vector or several scalars, not a {s}"),
                    ))
                }
            }
        } else {
            let mut ids = Vec::new();
            for a in args {
                let v = self.expr(a, ctx)?;
                ids.push(self.expect_scalar(&v, a, "each argument of `diag`")?);
            }
            ids
        };
        if entries.is_empty() {
            return Err(Diagnostic::new(&e.span, "diag needs at least one entry"));
        }
        let n = entries.len();
        let zero = self.g.num(0.0);
        let mut ids = vec![zero; n * n];
        for (i, &d) in entries.iter().enumerate() {
            ids[i * n + i] = d;
        }
        Ok(Value {
            shape: Shape::Matrix(n, n),
            ids,
        })
    }

    /// A call of a built-in function (see [`vocabulary::BUILTINS`]).
    pub(super) fn call(&mut self, f: &Ident, args: &[Expr], e: &Expr, ctx: Ctx) -> L<Value> {
        let Some(builtin) = vocabulary::builtin(&f.name) else {
            let near = BUILTINS
                .iter()
                .map(|b| b.name)
                .min_by_key(|k| edit_distance(k, &f.name))
                .filter(|k| edit_distance(k, &f.name) <= 2);
            let names: Vec<&str> = BUILTINS.iter().map(|b| b.name).collect();
            return Err(
                Diagnostic::new(&f.span, format!("unknown function `{}`", f.name))
                    .help(match near {
                        Some(k) => format!("did you mean `{k}`?"),
                        None => format!("known functions: {}", names.join(", ")),
                    })
                    .kind(DiagnosticKind::UnknownName),
            );
        };
        if !builtin.arity.accepts(args.len()) {
            let (at_least, n) = match builtin.arity {
                vocabulary::Arity::Exactly(n) => ("", n),
                vocabulary::Arity::AtLeast(n) => ("at least ", n),
            };
            return Err(Diagnostic::new(
                &e.span,
                format!(
                    "`{}` takes {at_least}{n} argument{}, {} given",
                    f.name,
                    if n == 1 { "" } else { "s" },
                    args.len()
                ),
            )
            .help(format!("write `{}`", builtin.call)));
        }
        let y = match builtin.lowering {
            Lowering::Sqrt => {
                let x = self.scalar_argument(builtin, args, 0, ctx)?;
                self.g.sqrt(x)
            }
            Lowering::Func(func) => {
                let x = self.scalar_argument(builtin, args, 0, ctx)?;
                if func.takes_parameter() {
                    self.elliptic_parameter(builtin, &args[0], x)?;
                }
                self.g.func(func, x)
            }
            Lowering::Func2(func) => {
                let (x, m) = self.elliptic_arguments(builtin, args, ctx)?;
                self.g.func2(func, x, m)
            }
            Lowering::Quotient(p, q) => {
                let (u, m) = self.elliptic_arguments(builtin, args, ctx)?;
                let part = |g: &mut Graph, f: Option<Func2>| match f {
                    Some(f) => g.func2(f, u, m),
                    None => g.num(1.0),
                };
                let (p, q) = (part(&mut self.g, p), part(&mut self.g, q));
                self.g.div(p, q)
            }
            Lowering::Structural => return self.structural(f, args, e, ctx),
            Lowering::Sign => {
                let g = self.scalar_argument(builtin, args, 0, ctx)?;
                self.sign(g, &args[0])?
            }
            Lowering::Delay => {
                let x = self.scalar_argument(builtin, args, 0, ctx)?;
                let r = self.scalar_argument(builtin, args, 1, ctx)?;
                self.delay(x, r, e, args)?
            }
        };
        Ok(Value::scalar(y))
    }

    /// The `k`-th argument of a scalar built-in.
    fn scalar_argument(&mut self, b: &Builtin, args: &[Expr], k: usize, ctx: Ctx) -> L<Id> {
        let v = self.expr(&args[k], ctx)?;
        let what = if args.len() == 1 {
            format!("the argument of `{}`", b.name)
        } else {
            format!("argument {} of `{}`", k + 1, b.name)
        };
        self.expect_scalar(&v, &args[k], &what)
    }

    /// (x, m) of an elliptic function, m checked as [`Lowerer::elliptic_parameter`] does.
    fn elliptic_arguments(&mut self, b: &Builtin, args: &[Expr], ctx: Ctx) -> L<(Id, Id)> {
        let x = self.scalar_argument(b, args, 0, ctx)?;
        let m = self.scalar_argument(b, args, 1, ctx)?;
        self.elliptic_parameter(b, &args[1], m)?;
        Ok((x, m))
    }

    /// The parameter m = k² of an elliptic function must not depend on the state (its
    /// derivatives are not implemented, see `derive`), and a constant m must lie in [0, 1].
    fn elliptic_parameter(&self, b: &Builtin, arg: &Expr, m: Id) -> L<()> {
        if self.g.depends_on(m, |i| matches!(i, Input::State(_))) {
            return Err(Diagnostic::new(
                &arg.span,
                format!("the parameter m of `{}` depends on the state", b.name),
            )
            .help("build m = k² from parameters and numbers: the generator differentiates with respect to the state, and derivatives in m (which need elliptic integrals of the second kind) are not implemented")
            .kind(DiagnosticKind::StateDependentParameter));
        }
        match self.g.as_num(m) {
            Some(v) if !(0.0..=1.0).contains(&v) => Err(Diagnostic::new(
                &arg.span,
                format!("the parameter m of `{}` is {v}, outside [0, 1]", b.name),
            )
            .help("m is the parameter k² (not the modulus k), 0 ≤ m ≤ 1")),
            _ => Ok(()),
        }
    }

    /// The built-ins with their own lowering ([`Lowering::Structural`]); the arity is checked.
    fn structural(&mut self, f: &Ident, args: &[Expr], e: &Expr, ctx: Ctx) -> L<Value> {
        match f.name.as_str() {
            "norm" => {
                let v = self.expr(&args[0], ctx)?;
                let sq: Vec<Id> = v
                    .ids
                    .iter()
                    .map(|&x| self.g.pow(x, Rational::int(2)))
                    .collect();
                let s = self.g.add(&sq);
                Ok(Value::scalar(self.g.sqrt(s)))
            }
            "dot" => {
                let a = self.expr(&args[0], ctx)?;
                let b = self.expr(&args[1], ctx)?;
                if a.shape != b.shape || !matches!(a.shape, Shape::Vector(_)) {
                    return Err(Diagnostic::new(
                        &e.span,
                        format!(
                            "dot needs two vectors of the same length, got a {} and a {}",
                            a.shape, b.shape
                        ),
                    ));
                }
                let terms: Vec<Id> = a
                    .ids
                    .iter()
                    .zip(&b.ids)
                    .map(|(&x, &y)| self.g.mul(&[x, y]))
                    .collect();
                Ok(Value::scalar(self.g.add(&terms)))
            }
            "cross" => {
                let a = self.expr(&args[0], ctx)?;
                let b = self.expr(&args[1], ctx)?;
                for (v, arg) in [(&a, &args[0]), (&b, &args[1])] {
                    if v.shape != Shape::Vector(3) {
                        return Err(Diagnostic::new(
                            &arg.span,
                            format!("cross needs vec3 arguments, this is a {}", v.shape),
                        ));
                    }
                }
                let ids = self.cross(&a.ids, &b.ids);
                Ok(Value {
                    shape: Shape::Vector(3),
                    ids,
                })
            }
            "hat" => {
                let a = self.expr(&args[0], ctx)?;
                if a.shape != Shape::Vector(3) {
                    return Err(Diagnostic::new(
                        &args[0].span,
                        format!("hat takes a vec3, this is a {}", a.shape),
                    ));
                }
                // hat(a) b = a × b:  [[0, −a3, a2], [a3, 0, −a1], [−a2, a1, 0]]
                let z = self.g.num(0.0);
                let n: Vec<Id> = a.ids.iter().map(|&x| self.g.neg(x)).collect();
                let rows = [
                    [z, n[2], a.ids[1]],
                    [a.ids[2], z, n[0]],
                    [n[1], a.ids[0], z],
                ];
                let ids = (0..3)
                    .flat_map(|j| (0..3).map(move |i| rows[i][j]))
                    .collect();
                Ok(Value {
                    shape: Shape::Matrix(3, 3),
                    ids,
                })
            }
            "transpose" => {
                let a = self.expr(&args[0], ctx)?;
                let (r, c) = a.shape.dims();
                let ids = (0..r)
                    .flat_map(|i| (0..c).map(move |j| (i, j)))
                    .map(|(i, j)| a.at(i, j))
                    .collect();
                Ok(Value {
                    shape: if a.shape == Shape::Scalar {
                        Shape::Scalar
                    } else {
                        Shape::Matrix(c, r)
                    },
                    ids,
                })
            }
            "trace" => {
                let a = self.expr(&args[0], ctx)?;
                let (r, c) = a.shape.dims();
                if r != c || !matches!(a.shape, Shape::Matrix(..)) {
                    return Err(Diagnostic::new(
                        &args[0].span,
                        format!("trace needs a square matrix, this is a {}", a.shape),
                    ));
                }
                let d: Vec<Id> = (0..r).map(|i| a.at(i, i)).collect();
                Ok(Value::scalar(self.g.add(&d)))
            }
            "inv" => {
                let a = self.expr(&args[0], ctx)?;
                self.inverse(&a, &args[0])
            }
            "eye" => {
                let n = self.constant(&args[0], "the size of `eye`")?;
                if n.fract() != 0.0 || !(1.0..=64.0).contains(&n) {
                    return Err(Diagnostic::new(
                        &args[0].span,
                        format!("eye({n}): the size must be a whole number from 1 to 64"),
                    ));
                }
                let n = n as usize;
                let (zero, one) = (self.g.num(0.0), self.g.num(1.0));
                let ids = (0..n * n)
                    .map(|k| if k % (n + 1) == 0 { one } else { zero })
                    .collect();
                Ok(Value {
                    shape: Shape::Matrix(n, n),
                    ids,
                })
            }
            "diag" => self.diag_args(args, e, ctx),
            "target" => {
                if ctx != Ctx::Lyapunov {
                    return Err(Diagnostic::new(
                        &f.span,
                        "`target` can only be used in `lyapunov`",
                    )
                    .help("target(f) is the value f(x₀) of an invariant at the initial point"));
                }
                let ExprKind::Name(name) = &args[0].kind else {
                    return Err(Diagnostic::new(
                        &args[0].span,
                        "target takes the name of an integral or constraint",
                    ));
                };
                let sym = self.lookup(name, ctx)?;
                if !matches!(sym.kind, Kind::Invariant | Kind::Hamiltonian) {
                    return Err(Diagnostic::new(
                        &name.span,
                        format!(
                            "`{}` is a {}, not an invariant",
                            name.name,
                            sym.kind.describe()
                        ),
                    ));
                }
                self.target_of(name)
            }
            other => Err(Diagnostic::new(
                &f.span,
                format!("internal error: built-in `{other}` has no lowering"),
            )),
        }
    }

    /// `target(f)`: the target inputs of invariant `f`, found by its declaration order.
    pub(super) fn target_of(&mut self, name: &Ident) -> L<Value> {
        let (offset, shape) = self.invariant_offsets[&name.name];
        let ids = (0..shape.len())
            .map(|k| self.g.input(Input::Target((offset + k) as u32)))
            .collect();
        Ok(Value { shape, ids })
    }

    pub(super) fn inverse(&mut self, a: &Value, arg: &Expr) -> L<Value> {
        let (r, c) = a.shape.dims();
        if r != c || !matches!(a.shape, Shape::Matrix(..)) || r > 3 {
            return Err(Diagnostic::new(
                &arg.span,
                format!("inv takes a 1×1, 2×2 or 3×3 matrix, this is a {}", a.shape),
            ));
        }
        if a.ids
            .iter()
            .any(|&id| self.g.depends_on(id, |i| matches!(i, Input::State(_))))
        {
            return Err(Diagnostic::new(
                &arg.span,
                "inv of a state-dependent matrix is not supported",
            )
            .help("`inv` takes parameter matrices, e.g. `inv(I)` for an inertia tensor"));
        }
        let m = |i: usize, j: usize| a.at(i, j);
        let g = &mut self.g;
        let mut det2 = |g: &mut Graph, a: Id, b: Id, c: Id, d: Id| {
            let ad = g.mul(&[a, d]);
            let bc = g.mul(&[b, c]);
            g.sub(ad, bc)
        };
        // Adjugate (cofactor transpose) over the determinant.
        let (adj, det): (Vec<Vec<Id>>, Id) = match r {
            1 => (vec![vec![g.num(1.0)]], m(0, 0)),
            2 => {
                let (n01, n10) = (g.neg(m(0, 1)), g.neg(m(1, 0)));
                (
                    vec![vec![m(1, 1), n01], vec![n10, m(0, 0)]],
                    det2(g, m(0, 0), m(0, 1), m(1, 0), m(1, 1)),
                )
            }
            _ => {
                let cof =
                    |g: &mut Graph,
                     i: usize,
                     j: usize,
                     det2: &mut dyn FnMut(&mut Graph, Id, Id, Id, Id) -> Id| {
                        let rows: Vec<usize> = (0..3).filter(|&k| k != i).collect();
                        let cols: Vec<usize> = (0..3).filter(|&k| k != j).collect();
                        let d = det2(
                            g,
                            m(rows[0], cols[0]),
                            m(rows[0], cols[1]),
                            m(rows[1], cols[0]),
                            m(rows[1], cols[1]),
                        );
                        if (i + j) % 2 == 1 {
                            g.neg(d)
                        } else {
                            d
                        }
                    };
                let mut c = vec![vec![Id(0); 3]; 3];
                for (i, row) in c.iter_mut().enumerate() {
                    for (j, x) in row.iter_mut().enumerate() {
                        *x = cof(g, i, j, &mut det2);
                    }
                }
                let terms: Vec<Id> = (0..3).map(|j| g.mul(&[m(0, j), c[0][j]])).collect();
                let det = g.add(&terms);
                // adj = cofactorᵀ
                (
                    (0..3).map(|i| (0..3).map(|j| c[j][i]).collect()).collect(),
                    det,
                )
            }
        };
        if self.g.as_num(det) == Some(0.0) {
            return Err(
                Diagnostic::new(&arg.span, "this matrix is singular").help("its determinant is 0")
            );
        }
        let ids = (0..r)
            .flat_map(|j| (0..r).map(move |i| (i, j)))
            .map(|(i, j)| self.g.div(adj[i][j], det))
            .collect();
        Ok(Value {
            shape: a.shape,
            ids,
        })
    }
}

/// Levenshtein distance, for "did you mean" suggestions.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}
