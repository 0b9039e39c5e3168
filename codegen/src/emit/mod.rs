//! Stage 5: emission. Builds the Rust items of a model with `quote`, formats them with
//! `prettyplease`, and turns the note markers into comments that point at the model file.

mod body;
mod names;

pub use names::snake;

use crate::check::{Conservation, Verdict};
use crate::derive::Derivatives;
use crate::ir::{Id, Input, OpCount};
use crate::model::{InvariantKind, Model, Shape};
use body::{body, literal, Leaves, Output};
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};
use std::collections::HashMap;

/// Operation counts of one emitted function.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ops {
    /// As an expression tree (every use of a shared subexpression counted again).
    pub tree: u64,
    /// After common-subexpression elimination (the hash-consed DAG).
    pub cse: u64,
    /// As emitted: after CSE, factoring of sums and sharing of sub-products.
    pub emitted: u64,
}

impl Ops {
    fn new(counts: OpCount, emitted: u64) -> Ops {
        Ops {
            tree: counts.tree,
            cse: counts.dag,
            emitted,
        }
    }
}

/// Operation counts of the emitted functions.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    /// X(x).
    pub field: Ops,
    /// f(x).
    pub invariants: Ops,
    /// Df(x).
    pub jacobian: Ops,
    /// V(x).
    pub lyapunov: Ops,
    /// ∇V(x).
    pub lyapunov_gradient: Ops,
    /// X − ∇V, computed together.
    pub feedback_field: Ops,
}

/// The emitted items of one model.
pub struct Emitted {
    /// The items (struct and impls), unformatted.
    pub items: TokenStream,
    /// One-paragraph summary for module docs.
    pub summary: String,
    /// Operation counts.
    pub stats: Stats,
}

/// An index or size as an unsuffixed literal (`3`, not `3usize`).
fn u(k: usize) -> Literal {
    Literal::usize_unsuffixed(k)
}

fn shape_tokens(shape: Shape) -> TokenStream {
    match shape {
        Shape::Scalar => quote!(Shape::Scalar),
        Shape::Vector(n) => {
            let n = u(n);
            quote!(Shape::Vector(#n))
        }
        Shape::Matrix(r, c) => {
            let (r, c) = (u(r), u(c));
            quote!(Shape::Matrix(#r, #c))
        }
    }
}

fn file_name(model: &Model) -> String {
    std::path::Path::new(&model.source.path)
        .file_name()
        .map_or_else(
            || model.source.path.clone(),
            |f| f.to_string_lossy().into_owned(),
        )
}

/// `kepler.lsl:9: d/dt v = -mu * x / r^3;` for the item at `span`.
fn note_for(model: &Model, span: &crate::Span) -> String {
    let (line, _) = span.line_col();
    let text = span.text().split_whitespace().collect::<Vec<_>>().join(" ");
    let text = if text.chars().count() > 90 {
        format!("{}…", text.chars().take(89).collect::<String>())
    } else {
        text
    };
    format!("{}:{line}: {text}", file_name(model))
}

/// Rust field names of the parameters, or the pair that collides.
fn param_fields(model: &Model) -> Result<Vec<String>, crate::Diagnostic> {
    let mut scope = names::Scope::with(&[]);
    let mut out = Vec::new();
    for p in &model.params {
        let name = snake(&p.name);
        let fresh = scope.fresh(&name);
        if fresh != name && !matches!(name.as_str(), "type" | "fn" | "self") {
            let other = model
                .params
                .iter()
                .find(|q| snake(&q.name) == name)
                .map_or("", |q| q.name.as_str());
            return Err(crate::Diagnostic::new(
                &p.span,
                format!(
                    "parameters `{}` and `{other}` would both be the Rust field `{name}`",
                    p.name
                ),
            )
            .help("rename one of them"));
        }
        out.push(fresh);
    }
    Ok(out)
}

/// Emits the struct and trait impls of a model, given its derivatives and the conservation
/// verdicts (quoted in the docs).
pub fn emit(
    model: &Model,
    d: &Derivatives,
    conservation: &[Conservation],
) -> crate::Result<Emitted> {
    let g = &model.graph;
    // Emission rewrites (factoring, shared products) go into a copy of the graph.
    let mut ge = model.graph.clone();
    let ty = format_ident!("{}", model.name);
    let (n, m, ng) = (model.dim(), model.invariant_dim(), model.gains.len());
    let fields = param_fields(model)?;
    let (nl, ml) = (u(n), u(m));

    // Leaves: state components by name, parameters from `self`, targets and gains by index.
    let state_name = |k: usize| -> String {
        let s = model
            .state
            .iter()
            .find(|s| (s.offset..s.offset + s.shape.len()).contains(&k))
            .expect("in range");
        let base = snake(&s.name);
        let j = k - s.offset;
        match s.shape {
            Shape::Scalar => base,
            Shape::Vector(_) => format!("{base}_{j}"),
            Shape::Matrix(r, _) => format!("{base}_{}{}", j % r, j / r),
        }
    };
    let param_source = |k: usize| -> (String, TokenStream) {
        let (pi, p) = model
            .params
            .iter()
            .enumerate()
            .find(|(_, p)| (p.offset..p.offset + p.slots()).contains(&k))
            .expect("slot");
        let field = format_ident!("{}", fields[pi]);
        let j = k - p.offset;
        match (p.shape, p.diagonal) {
            (Shape::Scalar, _) => (fields[pi].clone(), quote!(self.#field)),
            (Shape::Vector(_), _) | (_, true) => (format!("{}_{j}", fields[pi]), {
                let j = u(j);
                quote!(self.#field[#j])
            }),
            (Shape::Matrix(r, _), false) => {
                let (i, c) = (j % r, j / r);
                (format!("{}_{i}{c}", fields[pi]), {
                    let (i, c) = (u(i), u(c));
                    quote!(self.#field[#i][#c])
                })
            }
        }
    };
    let gain_name = |k: usize| snake(&model.gains[k].name);
    let input_fn = |i: Input| -> (String, TokenStream) {
        match i {
            Input::State(k) => {
                let k = k as usize;
                (state_name(k), {
                    let k = u(k);
                    quote!(x[#k])
                })
            }
            Input::Param(k) => param_source(k as usize),
            Input::Target(k) => {
                let k = k as usize;
                let f = model
                    .invariants
                    .iter()
                    .find(|f| (f.offset..f.offset + f.value.shape.len()).contains(&k))
                    .expect("target");
                let j = k - f.offset;
                let name = if f.value.shape.len() == 1 {
                    format!("{}_0", snake(&f.name))
                } else {
                    format!("{}_0_{j}", snake(&f.name))
                };
                (name, {
                    let k = u(k);
                    quote!(target[#k])
                })
            }
            Input::Gain(k) => {
                let k = k as usize;
                (gain_name(k), {
                    let k = u(k);
                    quote!(gains[#k])
                })
            }
        }
    };
    let mut let_names: HashMap<Id, (String, String)> = HashMap::new();
    for b in &model.lets {
        let base = snake(&b.name);
        for (j, &id) in b.value.ids.iter().enumerate() {
            let name = match b.value.shape {
                Shape::Scalar => base.clone(),
                Shape::Vector(_) => format!("{base}_{j}"),
                Shape::Matrix(r, _) => format!("{base}_{}{}", j % r, j / r),
            };
            if g.children(id).is_empty() {
                continue; // a let that is just a leaf or a number needs no temporary
            }
            let_names
                .entry(id)
                .or_insert((name, note_for(model, &b.span)));
        }
    }
    let leaves = Leaves {
        input: &input_fn,
        let_names: &let_names,
    };

    let field_outputs = |ids: &[Id],
                         place: &dyn Fn(usize) -> TokenStream,
                         only: &dyn Fn(usize) -> bool|
     -> Vec<Output> {
        ids.iter()
            .enumerate()
            .filter(|(k, _)| only(*k))
            .map(|(k, &id)| Output {
                place: place(k),
                id,
                note: Some(note_for(model, &model.field_spans[k])),
            })
            .collect()
    };
    let dx_place = |k: usize| {
        let k = u(k);
        quote!(dx[#k])
    };
    let all = |_: usize| true;

    // Field.
    let (field_body, field_ops) = body(
        &mut ge,
        &leaves,
        &field_outputs(&model.field, &dx_place, &all),
        &["x", "dx"],
    );

    // Invariants and their Jacobian.
    let invariant_note = |k: usize| {
        let f = model
            .invariants
            .iter()
            .find(|f| (f.offset..f.offset + f.value.shape.len()).contains(&k))
            .expect("row");
        note_for(model, &f.span)
    };
    let f_ids = model.invariant_ids();
    let inv_outputs: Vec<Output> = f_ids
        .iter()
        .enumerate()
        .map(|(k, &id)| Output {
            place: {
                let k = u(k);
                quote!(f[#k])
            },
            id,
            note: Some(invariant_note(k)),
        })
        .collect();
    let (inv_body, inv_ops) = body(&mut ge, &leaves, &inv_outputs, &["x", "f"]);
    let mut jac_outputs = Vec::new();
    for (c, row) in d.jacobian.iter().enumerate() {
        for (i, &id) in row.iter().enumerate() {
            if g.as_num(id) != Some(0.0) {
                jac_outputs.push(Output {
                    place: {
                        let (c, i) = (u(c), u(i));
                        quote!(jac[#c][#i])
                    },
                    id,
                    note: Some(invariant_note(c)),
                });
            }
        }
    }
    let (jac_body, jac_ops) = body(&mut ge, &leaves, &jac_outputs, &["x", "jac"]);

    // V, ∇V and X − ∇V.
    let v_note = model
        .lyapunov_span
        .as_ref()
        .map(|s| note_for(model, s))
        .unwrap_or_else(|| {
            format!(
                "{}: V = Σ k/2 |f − f(x₀)|² over the invariants",
                file_name(model)
            )
        });
    let (v_body, v_ops) = body(
        &mut ge,
        &leaves,
        &[Output {
            place: TokenStream::new(),
            id: model.lyapunov,
            note: Some(v_note),
        }],
        &["x", "target", "gains"],
    );
    let grad_outputs: Vec<Output> = d
        .lyapunov_gradient
        .iter()
        .enumerate()
        .map(|(k, &id)| Output {
            place: {
                let k = u(k);
                quote!(grad[#k])
            },
            id,
            note: Some(format!("∂V/∂x[{k}] ({})", state_name(k))),
        })
        .collect();
    let (grad_body, grad_ops) = body(
        &mut ge,
        &leaves,
        &grad_outputs,
        &["x", "target", "gains", "grad"],
    );
    let fb_outputs: Vec<Output> = d
        .feedback
        .iter()
        .enumerate()
        .map(|(k, &id)| Output {
            place: {
                let k = u(k);
                quote!(dx[#k])
            },
            id,
            note: Some(format!(
                "{} − ∂V/∂x[{k}]",
                note_for(model, &model.field_spans[k])
            )),
        })
        .collect();
    let (fb_body, fb_ops) = body(
        &mut ge,
        &leaves,
        &fb_outputs,
        &["x", "target", "gains", "dx"],
    );

    // Unused arguments get a leading underscore (no warnings in generated code).
    let uses =
        |ids: &[Id], pred: &dyn Fn(Input) -> bool| ids.iter().any(|&id| g.depends_on(id, pred));
    let arg = |used: bool, name: &str| {
        if used {
            format_ident!("{}", name)
        } else {
            format_ident!("_{}", name)
        }
    };
    let is_target = |i: Input| matches!(i, Input::Target(_));
    let is_gain = |i: Input| matches!(i, Input::Gain(_));
    let is_state = |i: Input| matches!(i, Input::State(_));
    let (v_t, v_g) = (
        arg(uses(&[model.lyapunov], &is_target), "target"),
        arg(uses(&[model.lyapunov], &is_gain), "gains"),
    );
    let v_x = arg(uses(&[model.lyapunov], &is_state), "x");
    let (gr_t, gr_g) = (
        arg(uses(&d.lyapunov_gradient, &is_target), "target"),
        arg(uses(&d.lyapunov_gradient, &is_gain), "gains"),
    );
    let gr_x = arg(uses(&d.lyapunov_gradient, &is_state), "x");
    let (fb_t, fb_g) = (
        arg(uses(&d.feedback, &is_target), "target"),
        arg(uses(&d.feedback, &is_gain), "gains"),
    );
    let fb_x = arg(uses(&d.feedback, &is_state), "x");
    let f_x = arg(uses(&model.field, &is_state), "x");
    let i_x = arg(uses(&f_ids, &is_state), "x");
    let j_x = arg(
        jac_outputs.iter().any(|o| g.depends_on(o.id, is_state)),
        "x",
    );
    let jac_init = if jac_outputs.len() < n * m {
        quote!(*jac = [[T::zero(); #nl]; #ml];)
    } else {
        quote!()
    };

    // Partitioned fields get Störmer–Verlet's half-fields.
    let partitioned = d.partition.as_ref().map(|is_q| {
        let (q_body, _) = body(
            &mut ge,
            &leaves,
            &field_outputs(&model.field, &dx_place, &|k| is_q[k]),
            &["x", "dx"],
        );
        let (p_body, _) = body(
            &mut ge,
            &leaves,
            &field_outputs(&model.field, &dx_place, &|k| !is_q[k]),
            &["x", "dx"],
        );
        let q_ids: Vec<Id> = (0..n)
            .filter(|&k| is_q[k])
            .map(|k| model.field[k])
            .collect();
        let p_ids: Vec<Id> = (0..n)
            .filter(|&k| !is_q[k])
            .map(|k| model.field[k])
            .collect();
        let (qx, px) = (
            arg(uses(&q_ids, &is_state), "x"),
            arg(uses(&p_ids, &is_state), "x"),
        );
        quote! {
            impl<T: Float> Partitioned<T, #nl> for #ty<T> {
                const IS_Q: [bool; #nl] = [#(#is_q),*];
                fn field_q(&self, #qx: &[T; #nl], dx: &mut [T; #nl]) { #q_body }
                fn field_p(&self, #px: &[T; #nl], dx: &mut [T; #nl]) { #p_body }
            }
        }
    });

    // The parameter struct.
    let struct_fields = model.params.iter().zip(&fields).map(|(p, f)| {
        let f = format_ident!("{}", f);
        let t: TokenStream = if p.diagonal {
            format!("[T; {}]", p.slots())
        } else {
            p.shape.rust_type()
        }
        .parse()
        .expect("type");
        let doc = format!(
            " `{}` ({}{}), default {}: `{}`",
            p.name,
            p.shape,
            if p.diagonal {
                ", stored as its diagonal"
            } else {
                ""
            },
            fmt_values(&p.defaults),
            p.span
                .text()
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" ")
        );
        quote!(#[doc = #doc] pub #f: #t)
    });
    let struct_defaults = model.params.iter().zip(&fields).map(|(p, f)| {
        let f = format_ident!("{}", f);
        let value = match (p.shape, p.diagonal) {
            (Shape::Scalar, _) => literal(p.defaults[0]),
            (Shape::Vector(_), _) | (_, true) => {
                let v = p.defaults.iter().map(|&x| literal(x));
                quote!([#(#v),*])
            }
            (Shape::Matrix(r, c), false) => {
                let rows = (0..r).map(|i| {
                    let v = (0..c).map(|j| literal(p.defaults[j * r + i]));
                    quote!([#(#v),*])
                });
                quote!([#(#rows),*])
            }
        };
        quote!(#f: #value)
    });

    // Named points.
    let point_fns = model
        .points
        .iter()
        .map(|pt| {
            let fname = format_ident!("point_{}", snake(&pt.name));
            let outputs: Vec<Output> = pt
                .values
                .iter()
                .enumerate()
                .map(|(k, &id)| Output {
                    place: {
                        let k = u(k);
                        quote!(out[#k])
                    },
                    id,
                    note: None,
                })
                .collect();
            let (b, _) = body(&mut ge, &leaves, &outputs, &["out"]);
            let doc = format!(" The point `{}` ({}).", pt.name, note_for(model, &pt.span));
            quote! {
                #[doc = #doc]
                pub fn #fname(&self) -> [T; #nl] {
                    let mut out = [T::zero(); #nl];
                    #b
                    out
                }
            }
        })
        .collect::<Vec<_>>();
    let point_names: Vec<&str> = model.points.iter().map(|p| p.name.as_str()).collect();
    let point_arms = model.points.iter().map(|pt| {
        let name = &pt.name;
        let fname = format_ident!("point_{}", snake(&pt.name));
        quote!(#name => Some(self.#fname().to_vec()))
    });

    // Parameters by name.
    let set_arms = model.params.iter().zip(&fields).map(|(p, f)| {
        let name = &p.name;
        let fi = format_ident!("{}", f);
        let len = u(p.slots());
        let assign = match (p.shape, p.diagonal) {
            (Shape::Scalar, _) => quote!(self.#fi = values[0];),
            (Shape::Vector(_), _) | (_, true) => quote!(self.#fi.copy_from_slice(values);),
            (Shape::Matrix(r, c), false) => { let (r, c) = (u(r), u(c)); quote! {
                for j in 0..#c { for i in 0..#r { self.#fi[i][j] = values[j * #r + i]; } }
            } },
        };
        quote! {
            #name => {
                if values.len() != #len {
                    return Err(ParamError::WrongLength { name: name.to_string(), expected: #len, given: values.len() });
                }
                #assign
                Ok(())
            }
        }
    });
    let get_arms = model.params.iter().zip(&fields).map(|(p, f)| {
        let name = &p.name;
        let fi = format_ident!("{}", f);
        match (p.shape, p.diagonal) {
            (Shape::Scalar, _) => quote!(#name => Some(vec![self.#fi])),
            (Shape::Vector(_), _) | (_, true) => quote!(#name => Some(self.#fi.to_vec())),
            (Shape::Matrix(r, c), false) => { let (r, c) = (u(r), u(c)); quote!(#name => Some((0..#c).flat_map(|j| (0..#r).map(move |i| (i, j))).map(|(i, j)| self.#fi[i][j]).collect())) },
        }
    });
    let known_params = model
        .params
        .iter()
        .map(|p| format!("`{}`", p.name))
        .collect::<Vec<_>>()
        .join(", ");
    let known_params = if known_params.is_empty() {
        "(none)".to_string()
    } else {
        known_params
    };

    // Static layout.
    let state_slots = model.state.iter().map(|s| {
        let (name, shape, off) = (&s.name, shape_tokens(s.shape), u(s.offset));
        quote!(Slot { name: #name, shape: #shape, offset: #off })
    });
    let param_slots = model.params.iter().map(|p| {
        let shape = if p.diagonal {
            Shape::Vector(p.slots())
        } else {
            p.shape
        };
        let (name, shape, off) = (&p.name, shape_tokens(shape), u(p.offset));
        quote!(Slot { name: #name, shape: #shape, offset: #off })
    });
    let inv_infos = model.invariants.iter().map(|f| {
        let (name, shape, off, gain) = (&f.name, shape_tokens(f.value.shape), u(f.offset), u(f.gain));
        let kind = match f.kind {
            InvariantKind::Constraint => quote!(InvariantKind::Constraint),
            InvariantKind::Integral => quote!(InvariantKind::Integral),
        };
        quote!(InvariantInfo { slot: Slot { name: #name, shape: #shape, offset: #off }, kind: #kind, gain: #gain })
    });
    let gain_names = model.gains.iter().map(|k| k.name.as_str());
    let gain_defaults: Vec<Literal> = model
        .gains
        .iter()
        .map(|k| Literal::f64_unsuffixed(k.default))
        .collect();
    let gain_lits = model.gains.iter().map(|k| literal(k.default));

    // Accessors: nalgebra views of the state blocks.
    let mut acc_scope = names::Scope::with(&["default_gains", "targets"]);
    let accessors = model.state.iter().map(|s| {
        let name = acc_scope.fresh(&snake(&s.name));
        let (get, get_mut) = (format_ident!("{}", name), format_ident!("{}_mut", name));
        let (a, b) = (u(s.offset), u(s.offset + s.shape.len()));
        let doc = format!(" The state block `{}` ({}) of a flat state, as a nalgebra view.", s.name, s.shape);
        let scalar_doc = format!(" The state component `{}` of a flat state.", s.name);
        let (r, c) = s.shape.dims();
        let (rd, cd) = (format_ident!("U{}", r), format_ident!("U{}", c));
        match s.shape {
            Shape::Scalar => quote! {
                #[doc = #scalar_doc]
                pub fn #get(x: &[T; #nl]) -> T { x[#a] }
            },
            _ => quote! {
                #[doc = #doc]
                pub fn #get(x: &[T; #nl]) -> nalgebra::MatrixView<'_, T, nalgebra::#rd, nalgebra::#cd> {
                    nalgebra::MatrixView::<'_, T, nalgebra::#rd, nalgebra::#cd>::from_slice(&x[#a..#b])
                }
                #[doc = #doc]
                pub fn #get_mut(x: &mut [T; #nl]) -> nalgebra::MatrixViewMut<'_, T, nalgebra::#rd, nalgebra::#cd> {
                    nalgebra::MatrixViewMut::<'_, T, nalgebra::#rd, nalgebra::#cd>::from_slice(&mut x[#a..#b])
                }
            },
        }
    });

    let stats = Stats {
        field: Ops::new(g.op_count(&model.field), field_ops),
        invariants: Ops::new(g.op_count(&f_ids), inv_ops),
        jacobian: Ops::new(
            g.op_count(&jac_outputs.iter().map(|o| o.id).collect::<Vec<_>>()),
            jac_ops,
        ),
        lyapunov: Ops::new(g.op_count(&[model.lyapunov]), v_ops),
        lyapunov_gradient: Ops::new(g.op_count(&d.lyapunov_gradient), grad_ops),
        feedback_field: Ops::new(g.op_count(&d.feedback), fb_ops),
    };
    let summary = summary(model, d, conservation, &stats);
    let name_str = &model.name;
    let struct_doc = format!(" Parameters of the model `{}`: state dimension N = {n}, invariant components M = {m}, gains G = {ng}.", model.name);

    let (n, m, ng) = (u(n), u(m), u(ng));
    let items = quote! {
        #[allow(unused_imports)]
        use lasalle_runtime::num_traits::{Float, One, Zero};
        #[allow(unused_imports)]
        use lasalle_runtime::{lit, nalgebra, Field, InvariantInfo, InvariantKind, Invariants, Lyapunov, ModelInfo, ParamError, Parameters, Partitioned, Shape, Slot};

        #[doc = #struct_doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct #ty<T = f64> {
            #(#struct_fields,)*
        }

        impl<T: Float> Default for #ty<T> {
            fn default() -> Self {
                #ty { #(#struct_defaults,)* }
            }
        }

        impl<T> #ty<T> {
            /// Dimension N of the flat state.
            pub const N: usize = #n;
            /// Number M of stacked invariant components.
            pub const M: usize = #m;
            /// Number G of gains.
            pub const G: usize = #ng;
        }

        impl<T: Float> #ty<T> {
            /// The gains as written in the model file.
            pub fn default_gains() -> [T; #ng] {
                [#(#gain_lits),*]
            }

            /// The target f(x₀) of the feedback field: the invariants at the initial state.
            pub fn targets(&self, x0: &[T; #n]) -> [T; #m] {
                let mut f = [T::zero(); #m];
                self.invariants(x0, &mut f);
                f
            }

            #(#point_fns)*
        }

        impl<T: Float + nalgebra::Scalar> #ty<T> {
            #(#accessors)*
        }

        impl<T: Float> Field<T, #n> for #ty<T> {
            fn field(&self, #f_x: &[T; #n], dx: &mut [T; #n]) { #field_body }
        }

        impl<T: Float> Invariants<T, #n, #m> for #ty<T> {
            fn invariants(&self, #i_x: &[T; #n], f: &mut [T; #m]) { #inv_body }
            fn invariants_jacobian(&self, #j_x: &[T; #n], jac: &mut [[T; #n]; #m]) {
                #jac_init
                #jac_body
            }
        }

        impl<T: Float> Lyapunov<T, #n, #m, #ng> for #ty<T> {
            fn lyapunov(&self, #v_x: &[T; #n], #v_t: &[T; #m], #v_g: &[T; #ng]) -> T {
                #v_body
            }
            fn lyapunov_gradient(&self, #gr_x: &[T; #n], #gr_t: &[T; #m], #gr_g: &[T; #ng], grad: &mut [T; #n]) { #grad_body }
            fn feedback_field(&self, #fb_x: &[T; #n], #fb_t: &[T; #m], #fb_g: &[T; #ng], dx: &mut [T; #n]) { #fb_body }
        }

        #partitioned

        impl<T> ModelInfo for #ty<T> {
            const NAME: &'static str = #name_str;
            const STATE: &'static [Slot] = &[#(#state_slots),*];
            const INVARIANTS: &'static [InvariantInfo] = &[#(#inv_infos),*];
            const GAIN_NAMES: &'static [&'static str] = &[#(#gain_names),*];
            const DEFAULT_GAINS: &'static [f64] = &[#(#gain_defaults),*];
            const PARAMS: &'static [Slot] = &[#(#param_slots),*];
        }

        impl Parameters for #ty<f64> {
            fn set_param(&mut self, name: &str, values: &[f64]) -> Result<(), ParamError> {
                match name {
                    #(#set_arms)*
                    _ => Err(ParamError::Unknown { name: name.to_string(), known: #known_params.to_string() }),
                }
            }
            fn param(&self, name: &str) -> Option<Vec<f64>> {
                match name {
                    #(#get_arms,)*
                    _ => None,
                }
            }
            fn point_names(&self) -> &'static [&'static str] {
                &[#(#point_names),*]
            }
            fn point(&self, name: &str) -> Option<Vec<f64>> {
                match name {
                    #(#point_arms,)*
                    _ => None,
                }
            }
        }
    };
    Ok(Emitted {
        items,
        summary,
        stats,
    })
}

fn fmt_values(v: &[f64]) -> String {
    if v.len() == 1 {
        format!("{}", v[0])
    } else {
        format!(
            "[{}]",
            v.iter()
                .map(|x| format!("{x}"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    }
}

fn summary(model: &Model, d: &Derivatives, conservation: &[Conservation], s: &Stats) -> String {
    let mut out = format!(
        "The model `{}` from `{}`, generated by lasalle-codegen.\n\n",
        model.name,
        file_name(model)
    );
    out.push_str("State (flat, matrices column-major):\n");
    for v in &model.state {
        out.push_str(&format!(
            "- `{}`: {} at x[{}..{}]\n",
            v.name,
            v.shape,
            v.offset,
            v.offset + v.shape.len()
        ));
    }
    out.push_str("\nInvariants (stacked f):\n");
    for f in &model.invariants {
        let how = conservation.iter().find(|c| c.name == f.name).map(|c| match &c.verdict {
            Verdict::Proved => "conservation proved symbolically".to_string(),
            Verdict::Sampled { samples, worst_relative } => {
                format!("conserved at {samples} random states (worst relative residual {worst_relative:.1e})")
            }
        });
        let kind = if f.kind == InvariantKind::Constraint {
            "constraint"
        } else {
            "integral"
        };
        out.push_str(&format!(
            "- `{}`: {kind}, {} at f[{}..{}], gain `{}` = {}{}\n",
            f.name,
            f.value.shape,
            f.offset,
            f.offset + f.value.shape.len(),
            model.gains[f.gain].name,
            model.gains[f.gain].default,
            how.map(|h| format!("; {h}")).unwrap_or_default()
        ));
    }
    if d.partition.is_some() {
        out.push_str("\nThe field is partitioned (q̇ = a(p), ṗ = b(q)): Störmer–Verlet applies.\n");
    }
    out.push_str(&format!(
        "\nOperations (as a tree → after CSE → as emitted): {}.\n",
        [
            ("X", s.field),
            ("f", s.invariants),
            ("Df", s.jacobian),
            ("V", s.lyapunov),
            ("∇V", s.lyapunov_gradient),
            ("X − ∇V", s.feedback_field)
        ]
        .map(|(name, o)| format!("{name} {} → {} → {}", o.tree, o.cse, o.emitted))
        .join(", ")
    ));
    out
}

/// Formats items with prettyplease and turns note markers into `//` comments.
pub fn format(items: &TokenStream) -> crate::Result<String> {
    let file: syn::File = syn::parse2(items.clone())
        .map_err(|e| crate::Error::Internal(format!("emitted code does not parse: {e}")))?;
    let text = prettyplease::unparse(&file);
    Ok(replace_notes(&text))
}

fn replace_notes(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        let trimmed = line.trim_start();
        if !trimmed.starts_with("lasalle_note!(") {
            out.push_str(line);
            out.push('\n');
            continue;
        }
        // prettyplease may break a long marker over several lines.
        let mut call = trimmed.to_string();
        while !call.ends_with(");") {
            match lines.next() {
                Some(more) => call.push_str(more.trim()),
                None => break,
            }
        }
        let inner = call
            .trim_start_matches("lasalle_note!(")
            .trim_end_matches(");")
            .trim()
            .trim_end_matches(',');
        let lit: syn::LitStr = syn::parse_str(inner).expect("a string literal we emitted");
        out.push_str(&line[..line.len() - trimmed.len()]);
        out.push_str("// ");
        out.push_str(&lit.value());
        out.push('\n');
    }
    out
}
