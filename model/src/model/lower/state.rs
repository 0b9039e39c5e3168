//! Pass 1: state variables and parameters, which may be used anywhere in the model.

use super::{Ctx, Kind, Lowerer, L};
use crate::error::Diagnostic;
use crate::ir::Input;
use crate::model::{Param, Shape, StateVar, Value};
use crate::parse::ast::*;

impl Lowerer {
    /// Declares the state and the parameters in file order and notes the gains' names;
    /// returns them with the dimension N of the flat state.
    pub(super) fn state_and_params(
        &mut self,
        ast: &ModelAst,
    ) -> (Vec<StateVar>, Vec<Param>, usize) {
        let mut state = Vec::new();
        let mut params: Vec<Param> = Vec::new();
        let mut n = 0usize;
        for it in &ast.items {
            match &it.item {
                Item::State(decls) => {
                    for (name, ty) in decls {
                        let (shape, member) = match self.declared_shape(ty) {
                            Ok(s) => s,
                            Err(d) => {
                                self.errors.push(d);
                                continue;
                            }
                        };
                        if let Some(m @ Shape::Vector(_)) = member {
                            self.families.insert(name.name.clone(), m);
                        }
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
                Item::Param(name, ty, e) => {
                    if let Some(p) = self.param(name, ty.as_ref(), e, it) {
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
        (state, params, n)
    }

    pub(super) fn param(
        &mut self,
        name: &Ident,
        ty: Option<&TypeName>,
        e: &Expr,
        it: &Spanned,
    ) -> Option<Param> {
        if self.sizes.contains(&name.name) {
            self.size_param(name, ty, e);
            return None;
        }
        let offset = self.param_defaults.len();
        let (value, diagonal) = match &e.kind {
            ExprKind::Call(f, args) if f.name == "diag" && ty.is_none() => {
                (self.diag_args(args, e, Ctx::Constant), true)
            }
            _ => (self.expr(e, Ctx::Constant), false),
        };
        let value = match value.and_then(|v| match ty {
            Some(ty) => self.typed_default(name, ty, e, v),
            None => Ok(v),
        }) {
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
}

impl Lowerer {
    /// A parameter used as a size or a range bound: a constant of the model, with no slot.
    fn size_param(&mut self, name: &Ident, ty: Option<&TypeName>, e: &Expr) {
        if let Some(ty) = ty.filter(|t| t.name != "scalar" || t.count.is_some()) {
            self.errors.push(
                Diagnostic::new(
                    &ty.span,
                    format!("`{}` is used as a size, so it is a scalar", name.name),
                )
                .help(format!("declare it as `param {} = 16;`", name.name)),
            );
            return;
        }
        match self.integer(e, "a size") {
            Ok(k) => {
                let id = self.g.num(k as f64);
                self.declare(name, Kind::Param, Value::scalar(id));
            }
            Err(d) => {
                self.errors.push(d.help(format!(
                    "`{}` is used as a size or a range bound: it is a whole number",
                    name.name
                )));
                self.poisoned.insert(name.name.clone());
            }
        }
    }

    /// The default `v` (written `e`) of a parameter declared with a shape: a family takes a
    /// list of its members or one value for all of them (a scalar for a family of scalars, a
    /// vector for a family of vectors).
    fn typed_default(&mut self, name: &Ident, ty: &TypeName, e: &Expr, v: Value) -> L<Value> {
        let (shape, member) = self.declared_shape(ty)?;
        let mut v = v;
        if let Some(member) = member {
            if let Shape::Vector(_) = member {
                self.families.insert(name.name.clone(), member);
            }
            v = self.family_value(shape, e, v);
            if v.shape == Shape::Scalar && member == Shape::Scalar {
                v = Value {
                    shape,
                    ids: vec![v.ids[0]; shape.len()],
                };
            }
        }
        if v.shape != shape {
            return Err(Diagnostic::new(
                &e.span,
                format!(
                    "parameter `{}` is declared a {} but its default is a {}",
                    name.name,
                    ty.span.text(),
                    v.shape
                ),
            )
            .help(match member {
                Some(m) => format!(
                    "give one {m} for every member (`[…, …]` or `[i in 0..n: …]`), or one {m} for all"
                ),
                None => "the default must have the declared shape".to_string(),
            }));
        }
        Ok(v)
    }
}
