//! DSL models (`lasalle_codegen::Model`) as Hamiltonians: the expression DAG is evaluated
//! over jets through `Graph::eval`, so any model with `structure canonical(q, p)` goes
//! through the same path as a [`HamiltonianFn`] written in Rust. Jets and double-doubles
//! implement the generator's `ir::Scalar` themselves, so nothing is adapted in between.

use crate::error::NormalFormError;
use crate::hamiltonian::HamiltonianFn;
use crate::normal_form::{normalize, NormalForm, Options, Point};
use lasalle_codegen::ir::{Func, Id, Input, Node, Scalar};
use lasalle_codegen::model::{Model, Structure};
use std::path::Path;

/// The Hamiltonian of a lowered DSL model with `structure canonical(q, p)`, with its
/// parameter values fixed.
#[derive(Clone)]
pub struct ModelHamiltonian<'a> {
    model: &'a Model,
    h: Id,
    /// position in z = (q, p) of each flat state index
    slot: Vec<usize>,
    n: usize,
    params: Vec<f64>,
}

impl<'a> ModelHamiltonian<'a> {
    /// The model's Hamiltonian with its default parameters overridden by `params`
    /// (`name = value`, scalar parameters only).
    pub fn new(model: &'a Model, params: &[(String, f64)]) -> Result<Self, NormalFormError> {
        let ham = model.hamiltonian.as_ref().ok_or_else(|| {
            NormalFormError::Model(format!("model `{}` has no `hamiltonian`", model.name))
        })?;
        let (q, p) = match &ham.structure {
            Structure::Canonical { q, p } => (q, p),
            _ => {
                return Err(NormalFormError::Model(format!(
                    "model `{}`: normal forms need `structure canonical(q, p)`",
                    model.name
                )))
            }
        };
        let g = &model.graph;
        let elliptic = |id| matches!(g.node(id), Node::Func2(..) | Node::Func(Func::EllipK, _));
        if g.reachable(&[ham.h]).into_iter().any(elliptic) {
            return Err(NormalFormError::Model(format!(
                "model `{}`: the Hamiltonian calls elliptic functions (sn, cn, dn, their quotients, ellipk, ellipf), which normal forms do not expand into series",
                model.name
            )));
        }
        let n = q.len();
        if p.len() != n || model.dim() != 2 * n {
            return Err(NormalFormError::Model(format!(
                "model `{}`: the state must consist of exactly q and p ({} + {} components, state has {})",
                model.name,
                q.len(),
                p.len(),
                model.dim()
            )));
        }
        let mut slot = vec![usize::MAX; 2 * n];
        for (k, &i) in q.iter().enumerate() {
            slot[i] = k;
        }
        for (k, &i) in p.iter().enumerate() {
            slot[i] = n + k;
        }
        let mut values = model.default_params();
        for (name, v) in params {
            let par = model.param(name).ok_or_else(|| {
                let known: Vec<&str> = model.params.iter().map(|p| p.name.as_str()).collect();
                NormalFormError::Model(format!(
                    "unknown parameter `{name}` (the model has: {})",
                    known.join(", ")
                ))
            })?;
            if par.slots() != 1 {
                return Err(NormalFormError::Model(format!(
                    "parameter `{name}` is not a scalar"
                )));
            }
            values[par.offset] = *v;
        }
        Ok(ModelHamiltonian {
            model,
            h: ham.h,
            slot,
            n,
            params: values,
        })
    }
    /// The parameter slots in use.
    pub fn params(&self) -> &[f64] {
        &self.params
    }
    /// Names of the model's points.
    pub fn point_names(&self) -> Vec<String> {
        self.model.points.iter().map(|p| p.name.clone()).collect()
    }
    /// The named point in z = (q, p) order, evaluated with the current parameters.
    pub fn point(&self, name: &str) -> Option<Vec<f64>> {
        let flat = self.model.point_values(name, &self.params)?;
        let mut z = vec![0.0; 2 * self.n];
        for (i, &x) in flat.iter().enumerate() {
            z[self.slot[i]] = x;
        }
        Some(z)
    }
}

impl HamiltonianFn for ModelHamiltonian<'_> {
    fn n_dof(&self) -> usize {
        self.n
    }
    fn eval<S: Scalar>(&self, z: &[S]) -> S {
        let params = &self.params;
        let slot = &self.slot;
        let mut input = |i: Input| -> S {
            match i {
                Input::State(k) => z[slot[k as usize]].clone(),
                Input::Param(k) => S::from_f64(params[k as usize]),
                _ => S::from_f64(f64::NAN),
            }
        };
        let mut out = self.model.graph.eval(&[self.h], &mut input);
        out.pop().expect("one output")
    }
    fn name(&self) -> String {
        let ps: Vec<String> = self
            .model
            .params
            .iter()
            .filter(|p| p.slots() == 1)
            .map(|p| format!("{}={}", p.name, self.params[p.offset]))
            .collect();
        if ps.is_empty() {
            self.model.name.clone()
        } else {
            format!("{}({})", self.model.name, ps.join(", "))
        }
    }
    fn coordinate_names(&self) -> Vec<String> {
        let mut names = vec![String::new(); 2 * self.n];
        for sv in &self.model.state {
            let len = sv.shape.len();
            for c in 0..len {
                let name = if len == 1 {
                    sv.name.clone()
                } else {
                    format!("{}[{c}]", sv.name)
                };
                names[self.slot[sv.offset + c]] = name;
            }
        }
        names
    }
}

/// Where to normalise a model.
#[derive(Clone, Debug, PartialEq)]
pub enum ModelPoint {
    /// The model's point of that name (a starting point for Newton).
    Named(String),
    /// Explicit coordinates in the model's flat state order (a starting point for Newton).
    Values(Vec<f64>),
    /// The model's only point, or its first one.
    Auto,
}

/// Loads a model file and computes its normal form: the entry point of
/// `lasalle normal-form model.lsl --param mu=… --order N [--precision dd] [--resonant]`.
pub fn normalize_model_file(
    path: impl AsRef<Path>,
    params: &[(String, f64)],
    point: &ModelPoint,
    options: &Options,
) -> Result<NormalForm, NormalFormError> {
    let model = lasalle_codegen::load_model(path.as_ref())
        .map_err(|e| NormalFormError::Model(e.to_string()))?;
    normalize_model(&model, params, point, options)
}

/// The normal form of a lowered model (see [`normalize_model_file`]).
pub fn normalize_model(
    model: &Model,
    params: &[(String, f64)],
    point: &ModelPoint,
    options: &Options,
) -> Result<NormalForm, NormalFormError> {
    let h = ModelHamiltonian::new(model, params)?;
    let start = match point {
        ModelPoint::Named(name) => h.point(name).ok_or_else(|| {
            NormalFormError::Model(format!(
                "no point `{name}` (the model has: {})",
                h.point_names().join(", ")
            ))
        })?,
        ModelPoint::Values(v) => {
            if v.len() != model.dim() {
                return Err(NormalFormError::Invalid(format!(
                    "point has {} components, the state has {}",
                    v.len(),
                    model.dim()
                )));
            }
            let mut z = vec![0.0; v.len()];
            for (i, &x) in v.iter().enumerate() {
                z[h.slot[i]] = x;
            }
            z
        }
        ModelPoint::Auto => {
            let name = h.point_names().into_iter().next().ok_or_else(|| {
                NormalFormError::Model(format!(
                    "model `{}` declares no point: give one with `--at POINT|x1,x2,…`",
                    model.name
                ))
            })?;
            h.point(&name).expect("declared point")
        }
    };
    normalize(&h, &Point::Newton(start), options)
}
