//! Lowering: resolves names, checks shapes and builds the DAG for every expression.

use super::*;
use crate::error::{Diagnostic, DiagnosticKind, Error};
use crate::ir::{Input, Node, Rational};
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
}

pub(super) type L<T> = Result<T, Diagnostic>;

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
        constants: Vec::new(),
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
        if crate::vocabulary::is_reserved(&name.name) {
            self.errors.push(
                Diagnostic::new(
                    &name.span,
                    format!(
                        "`{}` is reserved and cannot name a {}",
                        name.name,
                        kind.describe()
                    ),
                )
                .help("choose another name")
                .kind(DiagnosticKind::Reserved),
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
        // The model's name becomes a Rust type: keywords and names the emitted code uses
        // itself are refused (a renamed struct would surprise whoever imports it).
        if let Some(why) = crate::emit::names::reserved_type_name(&ast.name.name) {
            self.errors.push(
                Diagnostic::new(
                    &ast.name.span,
                    format!("`{}` cannot name a model: {why}", ast.name.name),
                )
                .help(format!(
                    "the model's name is the generated struct's; choose another, e.g. `{}Model`",
                    ast.name.name.trim_matches('_')
                )),
            );
        }
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
        let mut presets = Vec::new();
        let mut guards = Vec::new();
        let mut splitting_decl: Option<(&Ident, &Vec<Ident>, Span)> = None;
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
                Item::Point(name, values) => {
                    let method = crate::emit::snake(&name.name);
                    match points
                        .iter()
                        .find(|p: &&Point| crate::emit::snake(&p.name) == method)
                    {
                        Some(prev) => {
                            let (line, _) = prev.span.line_col();
                            Err(Diagnostic::new(
                                &name.span,
                                format!(
                                    "point `{}` would be the method `point_{method}` of the point `{}` on line {line}",
                                    name.name, prev.name
                                ),
                            )
                            .help("give each point its own name"))
                        }
                        None => self
                            .point(name, values, &state, &it.span)
                            .map(|p| points.push(p)),
                    }
                }
                Item::Run(name, values) => {
                    self.preset(name, values, &it.span).map(|p| presets.push(p))
                }
                Item::Guard { name, lhs, op, rhs } => self
                    .guard(name, lhs, *op, rhs, &it.span)
                    .map(|g| guards.push(g)),
                Item::Splitting(kind, args) => {
                    if splitting_decl.is_some() {
                        Err(Diagnostic::new(&it.span, "a second `splitting`")
                            .help("a model admits one structure-specific splitting"))
                    } else {
                        splitting_decl = Some((kind, args, it.span.clone()));
                        Ok(())
                    }
                }
            };
            if let Err(d) = result {
                if d.kind != DiagnosticKind::AlreadyReported {
                    self.errors.push(d);
                }
            }
        }

        // The Hamiltonian route.
        let hamiltonian = match (hamiltonian, structure) {
            (Some((name, h, _)), Some((s, span))) => {
                let result = self.structure(s, &span, h, &mut field, &mut invariants, &mut gains);
                // The equations are derivatives of H: they can overflow where H did not.
                let result = result.and_then(|s| match self.sweep_constants() {
                    Some(x) => Err(Diagnostic::new(
                        &span,
                        format!("the equations of this structure have a constant that is not finite ({x})"),
                    )
                    .help("they are derivatives of the Hamiltonian: rescale constants near ±1.8e308")
                    .kind(DiagnosticKind::NotFinite)),
                    None => Ok(s),
                });
                match result {
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

        if let Err(d) = self.check_presets(&presets, &points, &params, gains.len()) {
            self.errors.push(d);
        }
        if !self.errors.is_empty() {
            return None;
        }
        let (field, field_spans): (Vec<Id>, Vec<Span>) =
            field.into_iter().map(|f| f.expect("checked above")).unzip();
        let splitting = match splitting_decl {
            Some((kind, args, span)) => {
                match self.splitting(kind, args, &span, &state, &params, &field) {
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
            splitting,
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
}
