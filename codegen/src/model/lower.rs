//! Lowering: resolves names, checks shapes and builds the DAG for every expression.

use super::*;
use crate::error::{Diagnostic, Error};
use crate::ir::{Func, Input, Rational};
use crate::parse::ast::*;
use std::collections::HashMap;

/// What a name in the model refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    State,
    Param,
    Let,
    Invariant,
    Gain,
    Hamiltonian,
}

impl Kind {
    fn describe(self) -> &'static str {
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
struct Symbol {
    kind: Kind,
    value: Value,
    span: Span,
}

/// Where an expression is being lowered: what it may refer to.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Ctx {
    /// A parameter default or index: numbers and earlier parameters' defaults only.
    Constant,
    /// Fields, invariants, lets, Hamiltonians, points.
    Model,
    /// An explicit Lyapunov function: also gains and `target(f)`.
    Lyapunov,
}

/// The message of an error that repeats an earlier one (a use of a failed definition).
const POISONED: &str = "(already reported)";

const FUNCTIONS: &[&str] = &[
    "sqrt",
    "exp",
    "log",
    "sin",
    "cos",
    "norm",
    "dot",
    "cross",
    "hat",
    "transpose",
    "trace",
    "inv",
    "eye",
    "diag",
    "target",
];
const KEYWORDS: &[&str] = &[
    "model",
    "state",
    "param",
    "let",
    "integral",
    "constraint",
    "gain",
    "lyapunov",
    "hamiltonian",
    "structure",
    "point",
];

struct Lowerer {
    source: Arc<Source>,
    g: Graph,
    symbols: HashMap<String, Symbol>,
    /// Default values of parameter slots, for constant folding of later defaults.
    param_defaults: Vec<f64>,
    /// Names of the gains written anywhere in the file (for messages about misplaced gains).
    gain_names: std::collections::HashSet<String>,
    /// Names whose definition failed: uses of them are not reported again.
    poisoned: std::collections::HashSet<String>,
    /// Offset and shape of each invariant in the stacked f, for `target(f)`.
    invariant_offsets: HashMap<String, (usize, Shape)>,
    errors: Vec<Diagnostic>,
}

type L<T> = Result<T, Diagnostic>;

/// Lowers a parsed model; reports every problem found, not just the first.
pub fn lower(ast: &ModelAst, source: Arc<Source>) -> Result<Model, Error> {
    let mut lw = Lowerer {
        source: source.clone(),
        g: Graph::new(),
        symbols: HashMap::new(),
        param_defaults: Vec::new(),
        invariant_offsets: HashMap::new(),
        poisoned: Default::default(),
        gain_names: Default::default(),
        errors: Vec::new(),
    };
    let model = lw.model(ast);
    if lw.errors.is_empty() {
        model.ok_or_else(|| Error::Internal("lowering failed without a diagnostic".into()))
    } else {
        Err(Error::Model(lw.errors))
    }
}

impl Lowerer {
    fn declare(&mut self, name: &Ident, kind: Kind, value: Value) {
        if KEYWORDS.contains(&name.name.as_str()) || FUNCTIONS.contains(&name.name.as_str()) {
            self.errors.push(
                Diagnostic::new(
                    &name.span,
                    format!(
                        "`{}` is reserved and cannot name a {}",
                        name.name,
                        kind.describe()
                    ),
                )
                .help("choose another name"),
            );
            return;
        }
        if let Some(prev) = self.symbols.get(&name.name) {
            let (line, _) = prev.span.line_col();
            self.errors.push(
                Diagnostic::new(&name.span, format!("`{}` is already defined", name.name)).help(
                    format!(
                        "it is a {} declared on line {line}; choose another name",
                        prev.kind.describe()
                    ),
                ),
            );
            return;
        }
        self.symbols.insert(
            name.name.clone(),
            Symbol {
                kind,
                value,
                span: name.span.clone(),
            },
        );
    }

    fn model(&mut self, ast: &ModelAst) -> Option<Model> {
        // Pass 1: state and parameters, which may be used anywhere.
        let mut state = Vec::new();
        let mut params: Vec<Param> = Vec::new();
        let mut n = 0usize;
        for it in &ast.items {
            match &it.item {
                Item::State(decls) => {
                    for (name, ty) in decls {
                        let Some(shape) = Shape::from_name(&ty.name) else {
                            self.errors.push(
                                Diagnostic::new(&ty.span, format!("unknown shape `{}`", ty.name))
                                    .help(
                                    "shapes are `scalar`, `vecN` (e.g. `vec3`), `matN` or `matRxC`",
                                ),
                            );
                            continue;
                        };
                        let ids = (0..shape.len())
                            .map(|k| self.g.input(Input::State((n + k) as u32)))
                            .collect();
                        self.declare(name, Kind::State, Value { shape, ids });
                        state.push(StateVar {
                            name: name.name.clone(),
                            shape,
                            offset: n,
                            span: name.span.clone(),
                        });
                        n += shape.len();
                    }
                }
                Item::Param(name, e) => {
                    if let Some(p) = self.param(name, e, it) {
                        params.push(p);
                    }
                }
                Item::Invariant {
                    gain: Some(GainDecl { name: Some(g), .. }),
                    ..
                } => {
                    self.gain_names.insert(g.name.clone());
                }
                _ => {}
            }
        }
        if state.is_empty() && self.errors.is_empty() {
            self.errors.push(
                Diagnostic::new(
                    &ast.name.span,
                    format!("model `{}` declares no state", ast.name.name),
                )
                .help("add e.g. `state x: vec3, v: vec3;`"),
            );
        }

        // Pass 2: everything else, in order.
        let mut field: Vec<Option<(Id, Span)>> = vec![None; n];
        let mut invariants: Vec<Invariant> = Vec::new();
        let mut gains: Vec<Gain> = Vec::new();
        let mut lets = Vec::new();
        let mut lyapunov: Option<(Ident, &Expr, Span)> = None;
        let mut hamiltonian: Option<(Ident, Id, Span)> = None;
        let mut structure: Option<(&StructureDecl, Span)> = None;
        let mut points = Vec::new();
        for it in &ast.items {
            let result: L<()> = match &it.item {
                Item::State(_) | Item::Param(..) => Ok(()),
                Item::Let(name, e) => match self.expr(e, Ctx::Model) {
                    Ok(v) => {
                        lets.push(Binding {
                            name: name.name.clone(),
                            value: v.clone(),
                            span: it.span.clone(),
                        });
                        self.declare(name, Kind::Let, v);
                        Ok(())
                    }
                    Err(d) => {
                        self.poisoned.insert(name.name.clone());
                        Err(d)
                    }
                },
                Item::Derivative(name, e) => self.derivative(name, e, &it.span, &mut field),
                Item::Invariant {
                    kind,
                    name,
                    value,
                    gain,
                } => {
                    let kind = match kind {
                        InvariantDeclKind::Constraint => InvariantKind::Constraint,
                        InvariantDeclKind::Integral => InvariantKind::Integral,
                    };
                    self.expr(value, Ctx::Model).and_then(|v| {
                        self.invariant(
                            name,
                            kind,
                            v,
                            gain.as_ref(),
                            false,
                            &it.span,
                            &mut invariants,
                            &mut gains,
                        )
                    })
                }
                Item::Lyapunov(name, e) => {
                    if let Some((prev, ..)) = &lyapunov {
                        Err(Diagnostic::new(&name.span, "a second `lyapunov` function")
                            .help(format!("V is already defined as `{}`; keep one", prev.name)))
                    } else {
                        lyapunov = Some((name.clone(), e, it.span.clone()));
                        Ok(())
                    }
                }
                Item::Hamiltonian(name, e) => {
                    if hamiltonian.is_some() {
                        Err(Diagnostic::new(&name.span, "a second `hamiltonian`")
                            .help("a model has one Hamiltonian"))
                    } else {
                        self.expr(e, Ctx::Model).and_then(|v| {
                            let h = self.expect_scalar(&v, e, "a Hamiltonian")?;
                            self.invariant(
                                name,
                                InvariantKind::Integral,
                                v.clone(),
                                None,
                                true,
                                &it.span,
                                &mut invariants,
                                &mut gains,
                            )?;
                            hamiltonian = Some((name.clone(), h, it.span.clone()));
                            Ok(())
                        })
                    }
                }
                Item::Structure(s, span) => {
                    if structure.is_some() {
                        Err(Diagnostic::new(span, "a second `structure`")
                            .help("a model has one Poisson structure"))
                    } else {
                        structure = Some((s, it.span.clone()));
                        Ok(())
                    }
                }
                Item::Point(name, values) => self
                    .point(name, values, &state, &it.span)
                    .map(|p| points.push(p)),
            };
            if let Err(d) = result {
                if d.message != POISONED {
                    self.errors.push(d);
                }
            }
        }

        // The Hamiltonian route.
        let hamiltonian = match (hamiltonian, structure) {
            (Some((name, h, _)), Some((s, span))) => {
                match self.structure(s, &span, h, &mut field, &mut invariants, &mut gains) {
                    Ok(structure) => Some(Hamiltonian {
                        name: name.name,
                        h,
                        structure,
                    }),
                    Err(d) => {
                        self.errors.push(d);
                        None
                    }
                }
            }
            (Some((name, _, span)), None) => {
                self.errors.push(
                    Diagnostic::new(
                        &span,
                        format!("hamiltonian `{}` has no `structure`", name.name),
                    )
                    .help("add `structure canonical(q, p);` or `structure lie_poisson_so3(P);`"),
                );
                None
            }
            (None, Some((_, span))) => {
                self.errors.push(
                    Diagnostic::new(&span, "`structure` without a `hamiltonian`")
                        .help("add `hamiltonian H = …;`"),
                );
                None
            }
            (None, None) => None,
        };

        // Every state component needs exactly one equation.
        for s in &state {
            if field[s.offset..s.offset + s.shape.len()]
                .iter()
                .any(Option::is_none)
                && self.errors.is_empty()
            {
                self.errors.push(
                    Diagnostic::new(&s.span, format!("state `{}` has no equation", s.name)).help(
                        format!(
                            "add `d/dt {} = …;` or a Hamiltonian with a structure that covers it",
                            s.name
                        ),
                    ),
                );
            }
        }

        // V: explicit, or Σ kᵢ/2 |fᵢ − fᵢ(x₀)|².
        let (lyapunov, lyapunov_span) = match lyapunov {
            Some((_, e, span)) => match self
                .expr(e, Ctx::Lyapunov)
                .and_then(|v| self.expect_scalar(&v, e, "V"))
            {
                Ok(v) => (v, Some(span)),
                Err(d) => {
                    self.errors.push(d);
                    (self.g.num(0.0), None)
                }
            },
            None => (self.default_lyapunov(&invariants), None),
        };

        if !self.errors.is_empty() {
            return None;
        }
        let (field, field_spans) = field.into_iter().map(|f| f.expect("checked above")).unzip();
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
        })
    }

    fn param(&mut self, name: &Ident, e: &Expr, it: &Spanned) -> Option<Param> {
        let offset = self.param_defaults.len();
        let (value, diagonal) = match &e.kind {
            ExprKind::Call(f, args) if f.name == "diag" => {
                (self.diag_args(args, e, Ctx::Constant), true)
            }
            _ => (self.expr(e, Ctx::Constant), false),
        };
        let value = match value {
            Ok(v) => v,
            Err(d) => {
                self.errors.push(d);
                return None;
            }
        };
        let numbers: Option<Vec<f64>> = value.ids.iter().map(|&id| self.g.as_num(id)).collect();
        let Some(numbers) = numbers else {
            self.errors.push(
                Diagnostic::new(&e.span, format!("default of parameter `{}` is not a constant", name.name))
                    .help("parameter defaults are numbers, `[…]`, `diag(…)` or expressions of earlier parameters"),
            );
            return None;
        };
        let defaults: Vec<f64> = if diagonal {
            let (r, _) = value.shape.dims();
            (0..r).map(|i| numbers[i * r + i]).collect()
        } else {
            numbers
        };
        let mut slot = offset;
        let ids = if diagonal {
            let r = defaults.len();
            let zero = self.g.num(0.0);
            let mut ids = vec![zero; r * r];
            for i in 0..r {
                ids[i * r + i] = self.g.input(Input::Param((offset + i) as u32));
            }
            ids
        } else {
            (0..defaults.len())
                .map(|_| {
                    slot += 1;
                    self.g.input(Input::Param((slot - 1) as u32))
                })
                .collect()
        };
        self.param_defaults.extend(&defaults);
        self.declare(
            name,
            Kind::Param,
            Value {
                shape: value.shape,
                ids,
            },
        );
        Some(Param {
            name: name.name.clone(),
            shape: value.shape,
            diagonal,
            offset,
            defaults,
            span: it.span.clone(),
        })
    }

    fn derivative(
        &mut self,
        name: &Ident,
        e: &Expr,
        span: &Span,
        field: &mut [Option<(Id, Span)>],
    ) -> L<()> {
        let sym = self.lookup(name, Ctx::Model)?;
        if sym.kind != Kind::State {
            return Err(Diagnostic::new(
                &name.span,
                format!(
                    "`{}` is a {}, not a state variable",
                    name.name,
                    sym.kind.describe()
                ),
            )
            .help("`d/dt` takes a variable declared with `state`"));
        }
        let v = self.expr(e, Ctx::Model)?;
        if v.shape != sym.value.shape {
            return Err(Diagnostic::new(
                &e.span,
                format!(
                    "d/dt {} is a {} but `{}` is a {}",
                    name.name, v.shape, name.name, sym.value.shape
                ),
            )
            .help("the right-hand side must have the state variable's shape"));
        }
        for (k, &state_id) in sym.value.ids.iter().enumerate() {
            let Node::Input(Input::State(i)) = *self.g.node(state_id) else {
                unreachable!("state ids are inputs")
            };
            let slot = &mut field[i as usize];
            if let Some((_, prev)) = slot {
                let (line, _) = prev.line_col();
                return Err(Diagnostic::new(
                    &name.span,
                    format!("`{}` already has an equation", name.name),
                )
                .help(format!("see line {line}; keep one")));
            }
            *slot = Some((v.ids[k], span.clone()));
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn invariant(
        &mut self,
        name: &Ident,
        kind: InvariantKind,
        value: Value,
        gain: Option<&GainDecl>,
        automatic: bool,
        span: &Span,
        invariants: &mut Vec<Invariant>,
        gains: &mut Vec<Gain>,
    ) -> L<()> {
        let (gain_name, default) = match gain {
            Some(GainDecl { name: gname, value }) => {
                let v = self.expr(value, Ctx::Constant)?;
                let k = self.expect_scalar(&v, value, "a gain")?;
                let Some(k) = self.g.as_num(k) else {
                    unreachable!("constant context folds")
                };
                if !(k >= 0.0 && k.is_finite()) {
                    return Err(Diagnostic::new(
                        &value.span,
                        format!("gain {k} is not a non-negative number"),
                    )
                    .help("gains weigh |f − f(x₀)|² in V and must be ≥ 0"));
                }
                (
                    gname
                        .as_ref()
                        .map_or_else(|| format!("k_{}", name.name), |n| n.name.clone()),
                    k,
                )
            }
            None => (format!("k_{}", name.name), 1.0),
        };
        if let Some(g) = gain.and_then(|g| g.name.as_ref()) {
            if gains.iter().any(|x| x.name == g.name) || self.symbols.contains_key(&g.name) {
                return Err(
                    Diagnostic::new(&g.span, format!("`{}` is already defined", g.name))
                        .help("give each gain its own name"),
                );
            }
        }
        let offset = invariants.iter().map(|f| f.value.shape.len()).sum();
        self.invariant_offsets
            .insert(name.name.clone(), (offset, value.shape));
        invariants.push(Invariant {
            name: name.name.clone(),
            kind,
            value: value.clone(),
            offset,
            gain: gains.len(),
            automatic,
            span: span.clone(),
        });
        let gain_id = self.g.input(Input::Gain(gains.len() as u32));
        self.symbols.insert(
            gain_name.clone(),
            Symbol {
                kind: Kind::Gain,
                value: Value::scalar(gain_id),
                span: span.clone(),
            },
        );
        gains.push(Gain {
            name: gain_name,
            default,
        });
        self.declare(
            name,
            if automatic {
                Kind::Hamiltonian
            } else {
                Kind::Invariant
            },
            value,
        );
        Ok(())
    }

    fn structure(
        &mut self,
        s: &StructureDecl,
        span: &Span,
        h: Id,
        field: &mut [Option<(Id, Span)>],
        invariants: &mut Vec<Invariant>,
        gains: &mut Vec<Gain>,
    ) -> L<Structure> {
        let state_indices = |lw: &mut Lowerer, id: &Ident| -> L<(Vec<usize>, Shape)> {
            let sym = lw.lookup(id, Ctx::Model)?;
            if sym.kind != Kind::State {
                return Err(Diagnostic::new(
                    &id.span,
                    format!("`{}` is not a state variable", id.name),
                )
                .help("a structure names state variables"));
            }
            let idx = sym.value.ids.iter().map(|&k| match lw.g.node(k) {
                Node::Input(Input::State(i)) => *i as usize,
                _ => unreachable!("state ids are inputs"),
            });
            Ok((idx.collect(), sym.value.shape))
        };
        let mut assign = |i: usize, value: Id, who: &Ident| -> L<()> {
            if field[i].is_some() {
                return Err(Diagnostic::new(
                    &who.span,
                    format!("`{}` has both a `d/dt` equation and a structure", who.name),
                )
                .help("remove the `d/dt` line: the structure gives its equation"));
            }
            field[i] = Some((value, span.clone()));
            Ok(())
        };
        match s {
            StructureDecl::Canonical(qn, pn) => {
                let (q, qs) = state_indices(self, qn)?;
                let (p, ps) = state_indices(self, pn)?;
                if qs != ps {
                    return Err(Diagnostic::new(
                        &pn.span,
                        format!("`{}` is a {qs} but `{}` is a {ps}", qn.name, pn.name),
                    )
                    .help("canonical pairs q, p have the same shape"));
                }
                let vars: Vec<Input> = q
                    .iter()
                    .chain(&p)
                    .map(|&i| Input::State(i as u32))
                    .collect();
                let grad = crate::derive::gradient(&mut self.g, h, &vars);
                let m = q.len();
                for k in 0..m {
                    assign(q[k], grad[m + k], qn)?;
                    let minus = self.g.neg(grad[k]);
                    assign(p[k], minus, pn)?;
                }
                Ok(Structure::Canonical { q, p })
            }
            StructureDecl::LiePoissonSo3(pn) => {
                let (p, ps) = state_indices(self, pn)?;
                if ps != Shape::Vector(3) {
                    return Err(Diagnostic::new(
                        &pn.span,
                        format!("`{}` is a {ps}, lie_poisson_so3 needs a vec3", pn.name),
                    )
                    .help("declare it `state P: vec3;`"));
                }
                let vars: Vec<Input> = p.iter().map(|&i| Input::State(i as u32)).collect();
                let grad = crate::derive::gradient(&mut self.g, h, &vars);
                let pv: Vec<Id> = p
                    .iter()
                    .map(|&i| self.g.input(Input::State(i as u32)))
                    .collect();
                let rate = self.cross(&pv, &grad);
                for k in 0..3 {
                    assign(p[k], rate[k], pn)?;
                }
                let sq: Vec<Id> = pv
                    .iter()
                    .map(|&x| self.g.pow(x, Rational::int(2)))
                    .collect();
                let casimir = self.g.add(&sq);
                let name = Ident {
                    name: "casimir".into(),
                    span: pn.span.clone(),
                };
                self.invariant(
                    &name,
                    InvariantKind::Integral,
                    Value::scalar(casimir),
                    None,
                    true,
                    span,
                    invariants,
                    gains,
                )?;
                Ok(Structure::LiePoissonSo3 { p })
            }
        }
    }

    fn point(
        &mut self,
        name: &Ident,
        values: &[(Ident, Expr)],
        state: &[StateVar],
        span: &Span,
    ) -> L<Point> {
        let n: usize = state.iter().map(|s| s.shape.len()).sum();
        let mut out: Vec<Option<Id>> = vec![None; n];
        for (var, e) in values {
            let Some(s) = state.iter().find(|s| s.name == var.name) else {
                return Err(Diagnostic::new(
                    &var.span,
                    format!("`{}` is not a state variable", var.name),
                )
                .help("a point assigns every state variable"));
            };
            let v = self.expr(e, Ctx::Model)?;
            if v.shape != s.shape {
                return Err(Diagnostic::new(
                    &e.span,
                    format!(
                        "`{}` is a {} but this value is a {}",
                        s.name, s.shape, v.shape
                    ),
                ));
            }
            if v.ids
                .iter()
                .any(|&id| self.g.depends_on(id, |i| matches!(i, Input::State(_))))
            {
                return Err(Diagnostic::new(
                    &e.span,
                    "a point's coordinates may depend on parameters only",
                ));
            }
            for (k, &id) in v.ids.iter().enumerate() {
                out[s.offset + k] = Some(id);
            }
        }
        let missing: Vec<&str> = state
            .iter()
            .filter(|s| out[s.offset].is_none())
            .map(|s| s.name.as_str())
            .collect();
        if !missing.is_empty() {
            return Err(Diagnostic::new(
                &name.span,
                format!("point `{}` does not give {}", name.name, missing.join(", ")),
            )
            .help("assign every state variable, e.g. `x = [1, 0, 0];`"));
        }
        Ok(Point {
            name: name.name.clone(),
            values: out.into_iter().map(Option::unwrap).collect(),
            span: span.clone(),
        })
    }

    fn default_lyapunov(&mut self, invariants: &[Invariant]) -> Id {
        let mut terms = Vec::new();
        for f in invariants {
            let mut squares = Vec::new();
            for (k, &id) in f.value.ids.iter().enumerate() {
                let t = self.g.input(Input::Target((f.offset + k) as u32));
                let d = self.g.sub(id, t);
                squares.push(self.g.pow(d, Rational::int(2)));
            }
            let sum = self.g.add(&squares);
            let k = self.g.input(Input::Gain(f.gain as u32));
            let half = self.g.num(0.5);
            terms.push(self.g.mul(&[half, k, sum]));
        }
        self.g.add(&terms)
    }

    // ---- expressions -------------------------------------------------------------------

    fn lookup(&self, name: &Ident, ctx: Ctx) -> L<Symbol> {
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
                    .help(help));
                }
                Ok(sym.clone())
            }
            None if self.poisoned.contains(&name.name) => {
                Err(Diagnostic::new(&name.span, POISONED))
            }
            None if self.gain_names.contains(&name.name) => Err(Diagnostic::new(
                &name.span,
                format!("gain `{}` cannot be used here", name.name),
            )
            .help("gains may appear only in `lyapunov`")),
            None => {
                let mut d = Diagnostic::new(&name.span, format!("unknown symbol `{}`", name.name));
                if let Some(s) = self.suggest(&name.name) {
                    d = d.help(format!("did you mean `{s}`?"));
                } else {
                    d = d.help("declare it with `state`, `param` or `let` before this line");
                }
                Err(d)
            }
        }
    }

    fn suggest(&self, name: &str) -> Option<String> {
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

    fn expect_scalar(&self, v: &Value, e: &Expr, what: &str) -> L<Id> {
        if v.shape == Shape::Scalar {
            Ok(v.ids[0])
        } else {
            Err(Diagnostic::new(
                &e.span,
                format!("{what} must be a scalar, this is a {}", v.shape),
            ))
        }
    }

    fn constant(&mut self, e: &Expr, what: &str) -> L<f64> {
        let v = self.expr(e, Ctx::Constant).map_err(|d| {
            if d.message.contains("cannot be used here") || d.message.starts_with("unknown symbol")
            {
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

    fn index(&mut self, e: &Expr, len: usize) -> L<usize> {
        let k = self.constant(e, "an index")?;
        if k.fract() != 0.0 || k < 0.0 || k >= len as f64 {
            return Err(
                Diagnostic::new(&e.span, format!("index {k} is out of range 0..{len}"))
                    .help("indices are whole numbers counted from 0"),
            );
        }
        Ok(k as usize)
    }

    fn expr(&mut self, e: &Expr, ctx: Ctx) -> L<Value> {
        match &e.kind {
            ExprKind::Num(x) => Ok(Value::scalar(self.g.num(*x))),
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
            ExprKind::Call(f, args) => self.call(f, args, e, ctx),
            ExprKind::Index(base, idx) => {
                let v = self.expr(base, ctx)?;
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

    fn list(&mut self, elems: &[Expr], e: &Expr, ctx: Ctx) -> L<Value> {
        let vals: Vec<Value> = elems.iter().map(|x| self.expr(x, ctx)).collect::<L<_>>()?;
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
                &elems[k].span,
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

    fn map(&mut self, v: &Value, mut f: impl FnMut(&mut Graph, Id) -> Id) -> Value {
        Value {
            shape: v.shape,
            ids: v.ids.iter().map(|&x| f(&mut self.g, x)).collect(),
        }
    }

    fn binary(&mut self, op: BinOp, a: &Expr, b: &Expr, e: &Expr, ctx: Ctx) -> L<Value> {
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
        let (sa, sb) = (va.shape, vb.shape);
        match op {
            BinOp::Add | BinOp::Sub => {
                if sa != sb {
                    let verb = if op == BinOp::Add { "add" } else { "subtract" };
                    return Err(Diagnostic::new(
                        &e.span,
                        format!("cannot {verb} a {sa} and a {sb}"),
                    )
                    .help("both sides of `+` and `-` must have the same shape"));
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
                    return Err(Diagnostic::new(
                        &e.span,
                        format!("cannot multiply a {sa} by a {sb}"),
                    )
                    .help("use `dot(a, b)` or `cross(a, b)`"));
                }
                let ((r1, c1), (r2, c2)) = (sa.dims(), sb.dims());
                if c1 != r2 {
                    return Err(Diagnostic::new(&e.span, format!("cannot multiply a {sa} by a {sb}: inner dimensions {c1} and {r2} differ")));
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
                    return Err(Diagnostic::new(&b.span, format!("cannot divide by a {sb}"))
                        .help("divide by scalars only; use `inv(M)` for parameter matrices"));
                }
                Ok(self.map(&va, |g, x| g.div(x, vb.ids[0])))
            }
            BinOp::Pow => unreachable!("handled above"),
        }
    }

    fn cross(&mut self, a: &[Id], b: &[Id]) -> Vec<Id> {
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

    fn diag_args(&mut self, args: &[Expr], e: &Expr, ctx: Ctx) -> L<Value> {
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

    fn call(&mut self, f: &Ident, args: &[Expr], e: &Expr, ctx: Ctx) -> L<Value> {
        let arity = |n: usize| -> L<()> {
            if args.len() == n {
                Ok(())
            } else {
                Err(Diagnostic::new(
                    &e.span,
                    format!(
                        "`{}` takes {n} argument{}, {} given",
                        f.name,
                        if n == 1 { "" } else { "s" },
                        args.len()
                    ),
                ))
            }
        };
        match f.name.as_str() {
            "sqrt" | "exp" | "log" | "sin" | "cos" => {
                arity(1)?;
                let v = self.expr(&args[0], ctx)?;
                let x =
                    self.expect_scalar(&v, &args[0], &format!("the argument of `{}`", f.name))?;
                let y = match f.name.as_str() {
                    "sqrt" => self.g.sqrt(x),
                    "exp" => self.g.func(Func::Exp, x),
                    "log" => self.g.func(Func::Ln, x),
                    "sin" => self.g.func(Func::Sin, x),
                    _ => self.g.func(Func::Cos, x),
                };
                Ok(Value::scalar(y))
            }
            "norm" => {
                arity(1)?;
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
                arity(2)?;
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
                arity(2)?;
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
                arity(1)?;
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
                arity(1)?;
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
                arity(1)?;
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
                arity(1)?;
                let a = self.expr(&args[0], ctx)?;
                self.inverse(&a, &args[0])
            }
            "eye" => {
                arity(1)?;
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
                arity(1)?;
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
            other => {
                let mut d = Diagnostic::new(&f.span, format!("unknown function `{other}`"));
                let near = FUNCTIONS
                    .iter()
                    .min_by_key(|k| edit_distance(k, other))
                    .filter(|k| edit_distance(k, other) <= 2);
                d = d.help(match near {
                    Some(k) => format!("did you mean `{k}`?"),
                    None => format!("known functions: {}", FUNCTIONS.join(", ")),
                });
                Err(d)
            }
        }
    }

    /// `target(f)`: the target inputs of invariant `f`, found by its declaration order.
    fn target_of(&mut self, name: &Ident) -> L<Value> {
        let (offset, shape) = self.invariant_offsets[&name.name];
        let ids = (0..shape.len())
            .map(|k| self.g.input(Input::Target((offset + k) as u32)))
            .collect();
        Ok(Value { shape, ids })
    }

    fn inverse(&mut self, a: &Value, arg: &Expr) -> L<Value> {
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

use crate::ir::Node;

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
