//! DSL models (`lasalle_model::Model`) as Hamiltonians, through the generator's read-only
//! view [`CanonicalHamiltonian`] (H as a function of z = (q, p), evaluated over any
//! [`Scalar`]): any model with `structure canonical(q, p)` goes through the same path as a
//! [`HamiltonianFn`] written in Rust. Jets and double-doubles implement the generator's
//! `Scalar` themselves, so nothing is adapted in between.

use crate::error::NormalFormError;
use crate::hamiltonian::HamiltonianFn;
use crate::normal_form::{normalize, NormalForm, Options, Point};
use lasalle_model::ir::Scalar;
use lasalle_model::{CanonicalHamiltonian, Model};
use std::path::Path;

/// The Hamiltonian of a lowered DSL model with `structure canonical(q, p)`, with its
/// parameter values fixed.
#[derive(Clone)]
pub struct ModelHamiltonian<'a> {
    model: &'a Model,
    h: CanonicalHamiltonian<'a>,
    params: Vec<f64>,
}

impl<'a> ModelHamiltonian<'a> {
    /// The model's Hamiltonian with its default parameters overridden by `params`
    /// (`name = value`, scalar parameters only).
    pub fn new(model: &'a Model, params: &[(String, f64)]) -> Result<Self, NormalFormError> {
        let h = model
            .canonical_hamiltonian()
            .map_err(|e| NormalFormError::Model(e.to_string()))?;
        if h.calls_elliptic() {
            return Err(NormalFormError::Model(format!(
                "model `{}`: the Hamiltonian calls elliptic functions (sn, cn, dn, their quotients, ellipk, ellipf), which normal forms do not expand into series",
                model.name
            )));
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
            h,
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
        Some(self.to_z(&self.model.point_values(name, &self.params)?))
    }
    /// A flat state of the model in z = (q, p) order.
    pub(crate) fn to_z(&self, flat: &[f64]) -> Vec<f64> {
        let mut z = vec![0.0; flat.len()];
        for (&x, &at) in flat.iter().zip(self.h.z_index()) {
            z[at] = x;
        }
        z
    }
}

impl HamiltonianFn for ModelHamiltonian<'_> {
    fn n_dof(&self) -> usize {
        self.h.n_dof()
    }
    fn eval<S: Scalar>(&self, z: &[S]) -> S {
        self.h.eval(z, &self.params)
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
        let mut names = vec![String::new(); 2 * self.h.n_dof()];
        for sv in &self.model.state {
            let len = sv.shape.len();
            for c in 0..len {
                let name = if len == 1 {
                    sv.name.clone()
                } else {
                    format!("{}[{c}]", sv.name)
                };
                names[self.h.z_index()[sv.offset + c]] = name;
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
    let model = lasalle_model::load_model(path.as_ref()).map_err(NormalFormError::load)?;
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
    let start = model_start(&h, model, point)?;
    normalize(&h, &Point::Newton(start), options)
}

/// The starting point of Newton's method for `point`.
fn model_start(
    h: &ModelHamiltonian<'_>,
    model: &Model,
    point: &ModelPoint,
) -> Result<Vec<f64>, NormalFormError> {
    Ok(match point {
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
            h.to_z(v)
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
    })
}

/// The normal forms of a lowered model at several orders from one normalisation
/// ([`crate::normalize_orders`]: `orders` = [(N, M), …], each result to `on_form` as soon as
/// it is complete, which returns whether to go on).
pub fn normalize_model_orders(
    model: &Model,
    params: &[(String, f64)],
    point: &ModelPoint,
    options: &Options,
    orders: &[(usize, usize)],
    on_form: &mut dyn FnMut(NormalForm) -> bool,
) -> Result<(), NormalFormError> {
    let h = ModelHamiltonian::new(model, params)?;
    let start = model_start(&h, model, point)?;
    crate::normalize_orders(&h, &Point::Newton(start), options, orders, on_form)
}
