//! The read-only view of a model that analyses of canonical Hamiltonian systems (normal forms,
//! stability) use: H as a function of z = (q, p) that they evaluate over their own number
//! types, without walking the generator's graph themselves.

use super::{Model, Structure};
use crate::ir::{Func, Id, Input, Node, Scalar};

/// Why a model has no [`CanonicalHamiltonian`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NotCanonical {
    /// No `hamiltonian` item.
    #[error("model `{0}` has no `hamiltonian`")]
    NoHamiltonian(String),
    /// A Hamiltonian with another structure (Lie–Poisson).
    #[error("model `{0}`: normal forms need `structure canonical(q, p)`")]
    OtherStructure(String),
    /// The state holds more than q and p.
    #[error("model `{name}`: the state must consist of exactly q and p ({q} + {p} components, state has {dim})")]
    ExtraState {
        /// The model.
        name: String,
        /// Components of q.
        q: usize,
        /// Components of p.
        p: usize,
        /// Components of the state.
        dim: usize,
    },
}

/// A model's Hamiltonian H(q, p) with `structure canonical(q, p)`, in z = (q, p) order
/// ([`Model::canonical_hamiltonian`]).
#[derive(Clone)]
pub struct CanonicalHamiltonian<'m> {
    model: &'m Model,
    h: Id,
    /// The position in z of each flat state component.
    z_index: Vec<usize>,
}

impl Model {
    /// The Hamiltonian as a function of z = (q, p), if the model declares one with canonical
    /// structure and its state is exactly (q, p).
    pub fn canonical_hamiltonian(&self) -> Result<CanonicalHamiltonian<'_>, NotCanonical> {
        let ham = self
            .hamiltonian
            .as_ref()
            .ok_or_else(|| NotCanonical::NoHamiltonian(self.name.clone()))?;
        let Structure::Canonical { q, p } = &ham.structure else {
            return Err(NotCanonical::OtherStructure(self.name.clone()));
        };
        if p.len() != q.len() || self.dim() != q.len() + p.len() {
            return Err(NotCanonical::ExtraState {
                name: self.name.clone(),
                q: q.len(),
                p: p.len(),
                dim: self.dim(),
            });
        }
        let n = q.len();
        let mut z_index = vec![0; 2 * n];
        for (k, &i) in q.iter().chain(p).enumerate() {
            z_index[i] = k;
        }
        Ok(CanonicalHamiltonian {
            model: self,
            h: ham.h,
            z_index,
        })
    }
}

impl<'m> CanonicalHamiltonian<'m> {
    /// The model.
    pub fn model(&self) -> &'m Model {
        self.model
    }

    /// Degrees of freedom n (z has 2n components).
    pub fn n_dof(&self) -> usize {
        self.z_index.len() / 2
    }

    /// The position in z = (q, p) of each component of the model's flat state.
    pub fn z_index(&self) -> &[usize] {
        &self.z_index
    }

    /// Does H call an elliptic function (sn, cn, dn, their quotients, K, F)? Those have no
    /// expansion over truncated power series here ([`Scalar::jacobi`] is NaN by default).
    pub fn calls_elliptic(&self) -> bool {
        let g = &self.model.graph;
        g.reachable(&[self.h])
            .into_iter()
            .any(|id| matches!(g.node(id), Node::Func2(..) | Node::Func(Func::EllipK, _)))
    }

    /// H at z = (q, p) with the parameter slots `params`, over any [`Scalar`].
    pub fn eval<S: Scalar>(&self, z: &[S], params: &[f64]) -> S {
        let at = &self.z_index;
        let mut input = |i: Input| -> S {
            match i {
                Input::State(k) => z[at[k as usize]].clone(),
                Input::Param(k) => S::from_f64(params[k as usize]),
                _ => S::from_f64(f64::NAN),
            }
        };
        let mut out = self.model.graph.eval(&[self.h], &mut input);
        out.pop().expect("one output")
    }
}
