//! The prepared model: the parameter-only values of every function, computed once per
//! parameter set.
//!
//! Each per-call function reads the maximal parameter-only subexpressions it needs (`1/I₀`,
//! `(I₁ − I₂)/I₀`, `g/l`) from fields of `<Model>Prepared`, which `<Model>::prepare()` fills.
//! A field is named after what it holds where that is short (`inv_i_0`, `i_1_minus_i_2_over_i_0`,
//! a `let` name), else `p1`, `p2`, ….

use super::body::{Hoisting, Output, Place};
use super::leaves::Leaves;
use super::names::Scope;
use super::Emitter;
use crate::ir::{Graph, Id, Node};
use proc_macro2::TokenStream;
use quote::{format_ident, quote};
use std::collections::HashMap;

/// The fields of the prepared model, registered as the functions are emitted.
pub struct Prepared {
    fields: Vec<(Id, String)>,
    index: HashMap<Id, usize>,
    scope: Scope,
}

impl Prepared {
    /// An empty list; `taken` are names the prepared struct may not use (its `model` and
    /// `kernels` fields, and the parameters, which `Deref` reaches through it).
    pub fn new(taken: &[&str]) -> Self {
        let mut scope = Scope::with(taken);
        scope.take("model");
        scope.take("kernels");
        Prepared {
            fields: Vec::new(),
            index: HashMap::new(),
            scope,
        }
    }

    /// The field holding the value of `id`, registered on first use.
    pub fn field(&mut self, g: &Graph, leaves: &Leaves, id: Id) -> String {
        if let Some(&k) = self.index.get(&id) {
            return self.fields[k].1.clone();
        }
        let base = describe(g, leaves, id).unwrap_or_else(|| format!("p{}", self.fields.len() + 1));
        let name = self.scope.fresh(&base);
        self.index.insert(id, self.fields.len());
        self.fields.push((id, name.clone()));
        name
    }
}

/// Longest name made from what a value holds; longer ones are numbered.
pub const MAX_NAME: usize = 24;

/// A name for a value from its expression, if one is at most [`MAX_NAME`] long: `inv_r`,
/// `sqrt_mu`, `i_1_minus_i_2_over_i_0`, `half_g`, `mu_k2`, or a `let` name.
pub fn describe(g: &Graph, leaves: &Leaves, id: Id) -> Option<String> {
    describe_within(g, leaves, id, MAX_DEPTH)
}

/// The stacked invariant component k of a sum f_k(x) − target[k] (exactly one term is the
/// negated target, and no other term is a target): the deviation V penalises.
fn deviation(g: &Graph, id: Id) -> Option<usize> {
    let Node::Add(ts) = g.node(id) else {
        return None;
    };
    let target = |t: Id| match g.node(t) {
        Node::Input(crate::ir::Input::Target(k)) => Some(*k as usize),
        _ => None,
    };
    let negated_target = |t: Id| match g.node(t) {
        Node::Mul(fs) if fs.len() == 2 && g.as_num(fs[0]) == Some(-1.0) => target(fs[1]),
        _ => None,
    };
    let mut found = None;
    for &t in ts.iter() {
        match negated_target(t) {
            Some(k) if found.is_none() => found = Some(k),
            Some(_) => return None,
            None if target(t).is_some() => return None,
            None => {}
        }
    }
    found
}

/// How deep [`describe`] looks into an expression (a longer name would not fit anyway).
const MAX_DEPTH: usize = 4;

fn describe_within(g: &Graph, leaves: &Leaves, id: Id, depth: usize) -> Option<String> {
    if let Some((name, _)) = leaves.let_name(id) {
        return Some(name.clone());
    }
    if let Some(name) = leaves.invariant_name(id) {
        return Some(name.to_string());
    }
    if let Some(k) = deviation(g, id) {
        return Some(format!("d{}", leaves.invariant_component(k)));
    }
    let depth = depth.checked_sub(1)?;
    let describe = |id: Id| describe_within(g, leaves, id, depth);
    let name = match g.node(id) {
        Node::Num(_) if g.as_num(id) == Some(1.0) => "one".to_string(),
        Node::Num(_) => return None,
        Node::Input(i) => leaves.input(*i).0,
        &Node::Pow(b, e) => {
            let b = describe(b)?;
            match (e.num, e.den) {
                (-1, 1) => format!("inv_{b}"),
                (1, 2) => format!("sqrt_{b}"),
                (-1, 2) => format!("inv_sqrt_{b}"),
                (2, 1) => format!("{b}_sq"),
                (n, 1) if n > 0 => format!("{b}_pow{n}"),
                (n, 1) => format!("inv_{b}_pow{}", -n),
                _ => return None,
            }
        }
        Node::Mul(fs) => {
            let (prefix, rest) = match g.as_num(fs[0]) {
                Some(-1.0) => ("neg_", &fs[1..]),
                Some(0.5) => ("half_", &fs[1..]),
                Some(2.0) => ("twice_", &fs[1..]),
                Some(_) => return None,
                None => ("", &fs[..]),
            };
            // numerator factors, then `over` and the bases of the reciprocals: `g_over_l`
            let (mut num, mut den) = (Vec::new(), Vec::new());
            for &f in rest {
                match *g.node(f) {
                    Node::Pow(b, e) if e == crate::ir::Rational::int(-1) => den.push(describe(b)?),
                    _ => num.push(describe(f)?),
                }
            }
            match (num.is_empty(), den.is_empty()) {
                (_, true) => format!("{prefix}{}", num.join("_")),
                (true, false) => format!("{prefix}inv_{}", den.join("_")),
                (false, false) => format!("{prefix}{}_over_{}", num.join("_"), den.join("_")),
            }
        }
        Node::Add(ts) if ts.len() == 2 => {
            // the positive term first: `one_minus_mu`, not `neg_mu_plus_one`
            let negative = |t: Id| match g.node(t) {
                Node::Mul(fs) => g.as_num(fs[0]).is_some_and(|c| c < 0.0),
                _ => g.as_num(t).is_some_and(|c| c < 0.0),
            };
            let (first, second) = if negative(ts[0]) && !negative(ts[1]) {
                (ts[1], ts[0])
            } else {
                (ts[0], ts[1])
            };
            let a = describe(first)?;
            match g.node(second) {
                Node::Mul(fs) if g.as_num(fs[0]) == Some(-1.0) => {
                    let rest: Option<Vec<String>> = fs[1..].iter().map(|&f| describe(f)).collect();
                    format!("{a}_minus_{}", rest?.join("_"))
                }
                _ if g.as_num(second) == Some(-1.0) => format!("{a}_minus_one"),
                _ => format!("{a}_plus_{}", describe(second)?),
            }
        }
        Node::Add(_) => return None,
        &Node::Func(f, a) => format!("{}_{}", f.name(), describe(a)?),
        &Node::Func2(f, [a, m]) => format!("{}_{}_{}", f.name(), describe(a)?, describe(m)?),
    };
    (name.len() <= MAX_NAME).then_some(name)
}

impl Emitter<'_> {
    /// `<Model>Prepared`, `Deref` to the model, and `<Model>::prepare()`.
    pub fn prepared_items(&mut self) -> TokenStream {
        let (ty, prep) = (&self.ty, &self.prepared_ty);
        let outputs: Vec<Output> = self
            .prepared
            .fields
            .iter()
            .map(|(id, name)| Output {
                place: Place::Let(name.clone()),
                id: *id,
                note: None,
            })
            .collect();
        let body = super::body::body(
            &mut self.graph,
            &self.leaves,
            &outputs,
            &["model", "kernels"],
            Hoisting::Prepare,
        );
        let names: Vec<_> = self
            .prepared
            .fields
            .iter()
            .map(|(_, name)| format_ident!("{}", name))
            .collect();
        let inits = names.iter().zip(&body.values).map(|(name, value)| {
            if *name == value.to_string() {
                quote!(#name)
            } else {
                quote!(#name: #value)
            }
        });
        let struct_doc = format!(
            " The model `{}` with its parameter-only values computed once ([`{ty}::prepare`]): \
             the runtime's traits are implemented on it, and its functions read these values \
             instead of recomputing them at every call. Immutable: to change a parameter, \
             change the model and prepare it again, or call `Parameters::set_param`, which \
             prepares again.",
            self.model.name
        );
        let body_tokens = &body.tokens;
        quote! {
            #[doc = #struct_doc]
            #[derive(Clone, Copy, Debug, PartialEq)]
            pub struct #prep<T = f64> {
                model: #ty<T>,
                #(#names: T,)*
                /// The same values for the machine kernels, per tape and in f64.
                kernels: kernels::Prelude,
            }

            impl<T> Deref for #prep<T> {
                type Target = #ty<T>;

                fn deref(&self) -> &#ty<T> {
                    &self.model
                }
            }

            impl<T: Float> #ty<T> {
                /// The model with its parameter-only values computed, for runs: the runtime's
                /// traits are implemented on the prepared model.
                pub fn prepare(&self) -> #prep<T> {
                    #body_tokens
                    #prep { model: *self, #(#inits,)* kernels: kernels::Prelude::new(&self.slot_values()) }
                }
            }
        }
    }
}
