//! How a function reads its leaves: state components, parameters, targets and gains, each
//! under a readable name (`x_0`, `mu`, `r_0_2`, `k1`, `l0_2`), and which nodes carry names of
//! their own: `let` bindings (`r`) and the components of the invariants (`l_2`, `c_0_1`).
//!
//! An invariant's components are named as its state-like blocks are (`e`, `l_2`, `c_0_1`);
//! its target f(x₀), an input of V, as the value at x₀ is written by hand (`e0`, `l0_2`,
//! `c0_0_1`); the deviation of a component from its target, where it is a value of its own,
//! gets a `d` (`de`, `dl_2`, see [`super::prepared::describe`]).

use super::names::{identifier, snake, Scope};
use super::{note_at, u, LineIndex};
use crate::ir::{Id, Input};
use lasalle_model::{Model, Shape};
use proc_macro2::TokenStream;
use quote::{format_ident, quote};
use std::collections::HashMap;

/// Names of a model's leaves and `let` bindings in generated code.
pub struct Leaves<'a> {
    model: &'a Model,
    /// Rust field name of each parameter.
    pub fields: Vec<String>,
    /// Nodes bound by `let`: their name and the note quoting the binding.
    let_names: HashMap<Id, (String, String)>,
    /// The components of the invariants: `l_2`, `c_0_1`.
    invariant_names: HashMap<Id, String>,
}

/// The name of component `j` of a block called `base`: `x_0`, `r_1_2` (row 1, column 2; the
/// separator keeps (1, 10) and (11, 0) apart).
fn component(base: &str, shape: Shape, j: usize) -> String {
    match shape {
        Shape::Scalar => base.to_string(),
        Shape::Vector(_) => format!("{base}_{j}"),
        Shape::Matrix(r, _) => format!("{base}_{}_{}", j % r, j / r),
    }
}

impl<'a> Leaves<'a> {
    /// The leaves of `model`; fails if two parameters would share a Rust field name.
    pub fn new(model: &'a Model) -> Result<Self, crate::Diagnostic> {
        let mut scope = Scope::with(&[]);
        let mut fields = Vec::new();
        for p in &model.params {
            let name = scope.fresh(&snake(&p.name));
            if name != identifier(&snake(&p.name)) {
                let other = model
                    .params
                    .iter()
                    .find(|q| identifier(&snake(&q.name)) == identifier(&snake(&p.name)));
                return Err(crate::Diagnostic::new(
                    &p.span,
                    format!(
                        "parameters `{}` and `{}` would both be the Rust field `{}`",
                        p.name,
                        other.map_or("", |q| q.name.as_str()),
                        identifier(&snake(&p.name))
                    ),
                )
                .help("rename one of them"));
            }
            fields.push(name);
        }
        let mut let_names = HashMap::new();
        let lines = LineIndex::new(&model.source.text);
        for b in &model.lets {
            let note = note_at(model, &b.span, lines.line(b.span.start));
            let base = snake(&b.name);
            for (j, &id) in b.value.ids.iter().enumerate() {
                if model.graph.children(id).is_empty() {
                    continue; // a let that is just a leaf or a number needs no temporary
                }
                let_names
                    .entry(id)
                    .or_insert_with(|| (component(&base, b.value.shape, j), note.clone()));
            }
        }
        let mut invariant_names = HashMap::new();
        for f in &model.invariants {
            for (j, &id) in f.value.ids.iter().enumerate() {
                if !model.graph.children(id).is_empty() {
                    invariant_names
                        .entry(id)
                        .or_insert_with(|| component(&snake(&f.name), f.value.shape, j));
                }
            }
        }
        Ok(Leaves {
            model,
            fields,
            let_names,
            invariant_names,
        })
    }

    /// The name of a node that is a component of an invariant (`l_2`, `c_0_1`).
    pub fn invariant_name(&self, id: Id) -> Option<&str> {
        self.invariant_names.get(&id).map(String::as_str)
    }

    /// The invariant that stacked component k belongs to, and k's index in it.
    fn invariant_of(&self, k: usize) -> (&lasalle_model::Invariant, usize) {
        let f = self
            .model
            .invariants
            .iter()
            .find(|f| (f.offset..f.offset + f.value.shape.len()).contains(&k))
            .expect("an invariant component");
        (f, k - f.offset)
    }

    /// The name of component k of the stacked invariants (`e`, `l_2`, `c_0_1`), whose target
    /// is `target[k]`.
    pub fn invariant_component(&self, k: usize) -> String {
        let (f, j) = self.invariant_of(k);
        component(&snake(&f.name), f.value.shape, j)
    }

    /// The name and note of a node bound by `let`.
    pub fn let_name(&self, id: Id) -> Option<&(String, String)> {
        self.let_names.get(&id)
    }

    /// The name of state component k (`x_0`, `r_1_2`, `theta`).
    pub fn state_name(&self, k: usize) -> String {
        let s = self
            .model
            .state
            .iter()
            .find(|s| (s.offset..s.offset + s.shape.len()).contains(&k))
            .expect("in range");
        component(&snake(&s.name), s.shape, k - s.offset)
    }

    /// For an input read from an array argument (state `x`, `target`, `gains`): the array's
    /// name, the index and the array's length.
    pub fn array(&self, i: Input) -> Option<(&'static str, usize, usize)> {
        let m = self.model;
        match i {
            Input::State(k) => Some(("x", k as usize, m.dim())),
            Input::Target(k) => Some(("target", k as usize, m.invariant_dim())),
            Input::Gain(k) => Some(("gains", k as usize, m.gains.len())),
            Input::Param(_) | Input::Symbol(_) => None,
        }
    }

    /// The name of an input and the expression that reads it.
    pub fn input(&self, i: Input) -> (String, TokenStream) {
        let model = self.model;
        match i {
            Input::State(k) => {
                let k = k as usize;
                let ku = u(k);
                (self.state_name(k), quote!(x[#ku]))
            }
            Input::Param(k) => {
                let k = k as usize;
                let (pi, p) = model
                    .params
                    .iter()
                    .enumerate()
                    .find(|(_, p)| (p.offset..p.offset + p.slots()).contains(&k))
                    .expect("slot");
                let field = format_ident!("{}", self.fields[pi]);
                let j = k - p.offset;
                match (p.shape, p.diagonal) {
                    (Shape::Scalar, _) => (self.fields[pi].clone(), quote!(self.#field)),
                    (Shape::Vector(_), _) | (_, true) => {
                        let ju = u(j);
                        (format!("{}_{j}", self.fields[pi]), quote!(self.#field[#ju]))
                    }
                    (Shape::Matrix(r, _), false) => {
                        let (i, c) = (j % r, j / r);
                        let (iu, cu) = (u(i), u(c));
                        (
                            format!("{}_{i}_{c}", self.fields[pi]),
                            quote!(self.#field[#iu][#cu]),
                        )
                    }
                }
            }
            Input::Target(k) => {
                let k = k as usize;
                let (f, j) = self.invariant_of(k);
                let name = component(&format!("{}0", snake(&f.name)), f.value.shape, j);
                let ku = u(k);
                (name, quote!(target[#ku]))
            }
            Input::Gain(k) => {
                let ku = u(k as usize);
                (snake(&model.gains[k as usize].name), quote!(gains[#ku]))
            }
            // The only symbol that reaches emission: the step size in a guard.
            Input::Symbol(_) => ("dt".to_string(), quote!(dt)),
        }
    }
}
