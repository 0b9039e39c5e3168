//! The model's own items: the parameter struct, its inherent methods (gains, targets, named
//! points, nalgebra views of the state), and the `ModelInfo` and `Parameters` impls.

use super::body::{literal, Output, Place};
use super::names::{snake, Scope};
use super::{note_for, u, Emitter};
use lasalle_model::{InvariantKind, Shape};
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

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

impl Emitter<'_> {
    /// The parameter struct, `Default`, the size constants and the inherent methods.
    pub fn struct_items(&mut self) -> TokenStream {
        let model = self.model;
        let points = self.point_fns();
        let (ty, prep) = (&self.ty, &self.prepared_ty);
        let (n, m, ng) = (u(self.n), u(self.m), u(self.gains()));
        // no invariants (a dissipative field): an empty array, no zero-length repeat
        let targets_init = if self.m == 0 {
            quote!(let mut f: [T; 0] = [];)
        } else {
            quote!(let mut f = [T::zero(); #m];)
        };
        let fields: Vec<_> = self
            .leaves
            .fields
            .iter()
            .map(|f| format_ident!("{}", f))
            .collect();
        let struct_fields = model.params.iter().zip(&fields).map(|(p, f)| {
            let t: TokenStream = if p.diagonal {
                format!("[T; {}]", p.slots())
            } else {
                rust_type(p.shape)
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
        let gain_lits = model.gains.iter().map(|k| literal(k.default));
        let struct_doc = format!(
            " Parameters of the model `{}`: state dimension N = {}, invariant components M = {}, gains G = {}.",
            model.name,
            self.n,
            self.m,
            self.gains()
        );
        // A model without parameters still has a `T` (the traits are generic over it): a
        // marker field uses it, or the struct would not compile (E0392).
        let (marker, marker_default) = if model.params.is_empty() {
            (
                quote! {
                    #[doc = " The model has no parameters; this marker carries the number type `T`."]
                    pub _marker: core::marker::PhantomData<T>,
                },
                quote!(_marker: core::marker::PhantomData,),
            )
        } else {
            (TokenStream::new(), TokenStream::new())
        };
        quote! {
            #[doc = #struct_doc]
            #[derive(Clone, Copy, Debug, PartialEq)]
            pub struct #ty<T = f64> {
                #(#struct_fields,)*
                #marker
            }

            impl<T: Float> Default for #ty<T> {
                fn default() -> Self {
                    #ty { #(#struct_defaults,)* #marker_default }
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

                #(#points)*
            }

            impl<T: Float> #prep<T> {
                /// The target f(x₀) of the feedback field: the invariants at the initial state.
                pub fn targets(&self, x0: &[T; #n]) -> [T; #m] {
                    #targets_init
                    self.invariants(x0, &mut f);
                    f
                }
            }
        }
    }

    /// `point_<name>()` for each named point, evaluated from the parameters.
    fn point_fns(&mut self) -> Vec<TokenStream> {
        let n = u(self.n);
        let model = self.model;
        model
            .points
            .iter()
            .map(|pt| {
                let fname = format_ident!("point_{}", snake(&pt.name));
                let outputs: Vec<Output> = pt
                    .values
                    .iter()
                    .map(|&id| Output {
                        place: Place::Element,
                        id,
                        note: None,
                    })
                    .collect();
                let body = self.inline_body(&outputs, &[]);
                let (tokens, values) = (&body.tokens, &body.values);
                let doc = format!(" The point `{}` ({}).", pt.name, note_for(model, &pt.span));
                quote! {
                    #[doc = #doc]
                    pub fn #fname(&self) -> [T; #n] {
                        #tokens
                        [#(#values),*]
                    }
                }
            })
            .collect()
    }

    /// nalgebra views of the state blocks: `Kepler::x(&state)`, `Kepler::x_mut(&mut state)`.
    pub fn accessors(&self) -> TokenStream {
        let (ty, n) = (&self.ty, u(self.n));
        let mut scope = Scope::with(&["default_gains", "targets"]);
        let accessors = self.model.state.iter().map(|s| {
            // `x` and `x_mut` are both taken: a state `x_mut` must not meet `x`'s setter.
            // (`type_` for a keyword gives `type_mut`).
            let (name, name_mut) = loop {
                let name = scope.fresh(&snake(&s.name));
                let name_mut = if name.ends_with('_') {
                    format!("{name}mut")
                } else {
                    format!("{name}_mut")
                };
                if !scope.contains(&name_mut) {
                    scope.take(&name_mut);
                    break (name, name_mut);
                }
            };
            let (get, get_mut) = (format_ident!("{}", name), format_ident!("{}", name_mut));
            let (a, b) = (u(s.offset), u(s.offset + s.shape.len()));
            let (r, c) = s.shape.dims();
            let (rd, cd) = (format_ident!("U{}", r), format_ident!("U{}", c));
            match s.shape {
                Shape::Scalar => {
                    let doc = format!(" The state component `{}` of a flat state.", s.name);
                    quote! {
                        #[doc = #doc]
                        pub fn #get(x: &[T; #n]) -> T { x[#a] }
                    }
                }
                _ => {
                    let doc = format!(
                        " The state block `{}` ({}) of a flat state, as a nalgebra view.",
                        s.name, s.shape
                    );
                    quote! {
                        #[doc = #doc]
                        pub fn #get(x: &[T; #n]) -> MatrixView<'_, T, #rd, #cd> {
                            MatrixView::from_slice_generic(&x[#a..#b], #rd, #cd)
                        }

                        #[doc = #doc]
                        pub fn #get_mut(x: &mut [T; #n]) -> MatrixViewMut<'_, T, #rd, #cd> {
                            MatrixViewMut::from_slice_generic(&mut x[#a..#b], #rd, #cd)
                        }
                    }
                }
            }
        });
        quote! {
            impl<T: Float + Scalar> #ty<T> {
                #(#accessors)*
            }
        }
    }

    /// `impl ModelInfo`: names, shapes and offsets.
    pub fn model_info_impl(&self) -> TokenStream {
        let model = self.model;
        let (ty, name) = (&self.ty, &model.name);
        let slot = |name: &str, shape: Shape, offset: usize| {
            let (shape, off) = (shape_tokens(shape), u(offset));
            quote!(Slot { name: #name, shape: #shape, offset: #off })
        };
        let state_slots = model.state.iter().map(|s| slot(&s.name, s.shape, s.offset));
        let param_slots = model.params.iter().map(|p| {
            slot(
                &p.name,
                if p.diagonal {
                    Shape::Vector(p.slots())
                } else {
                    p.shape
                },
                p.offset,
            )
        });
        let inv_infos = model.invariants.iter().map(|f| {
            let s = slot(&f.name, f.value.shape, f.offset);
            let gain = u(f.gain);
            let kind = match f.kind {
                InvariantKind::Constraint => quote!(InvariantKind::Constraint),
                InvariantKind::Integral => quote!(InvariantKind::Integral),
            };
            quote!(InvariantInfo { slot: #s, kind: #kind, gain: #gain })
        });
        let gain_names = model.gains.iter().map(|k| k.name.as_str());
        let gain_defaults = model
            .gains
            .iter()
            .map(|k| Literal::f64_unsuffixed(k.default));
        let prep = &self.prepared_ty;
        let consts = quote!(#ty::<T>);
        quote! {
            impl<T> #ty<T> {
                /// The model's name.
                pub const NAME: &'static str = #name;
                /// The state variables with their offsets in the flat state.
                pub const STATE: &'static [Slot] = &[#(#state_slots),*];
                /// The invariants with their offsets in the stacked f.
                pub const INVARIANTS: &'static [InvariantInfo] = &[#(#inv_infos),*];
                /// The names of the gains.
                pub const GAIN_NAMES: &'static [&'static str] = &[#(#gain_names),*];
                /// The gains as written in the model file.
                pub const DEFAULT_GAINS: &'static [f64] = &[#(#gain_defaults),*];
                /// The parameters with their offsets in the parameter slots.
                pub const PARAMS: &'static [Slot] = &[#(#param_slots),*];
            }

            impl<T> ModelInfo for #prep<T> {
                fn model_name(&self) -> &'static str { #consts::NAME }
                fn state_slots(&self) -> &'static [Slot] { #consts::STATE }
                fn invariant_infos(&self) -> &'static [InvariantInfo] { #consts::INVARIANTS }
                fn gain_names(&self) -> &'static [&'static str] { #consts::GAIN_NAMES }
                fn default_gain_values(&self) -> &'static [f64] { #consts::DEFAULT_GAINS }
                fn param_slots(&self) -> &'static [Slot] { #consts::PARAMS }
            }
        }
    }

    /// `impl Parameters`: parameters and points by name, for command lines and configs.
    pub fn parameters_impl(&self) -> TokenStream {
        let model = self.model;
        let fields: Vec<_> = self
            .leaves
            .fields
            .iter()
            .map(|f| format_ident!("{}", f))
            .collect();
        let set_arms = model.params.iter().zip(&fields).map(|(p, fi)| {
            let name = &p.name;
            let len = u(p.slots());
            let assign = match (p.shape, p.diagonal) {
                (Shape::Scalar, _) => quote!(self.model.#fi = values[0];),
                (Shape::Vector(_), _) | (_, true) => {
                    quote!(self.model.#fi.copy_from_slice(values);)
                }
                (Shape::Matrix(r, c), false) => {
                    let (r, c) = (u(r), u(c));
                    quote! {
                        for j in 0..#c { for i in 0..#r { self.model.#fi[i][j] = values[j * #r + i]; } }
                    }
                }
            };
            quote! {
                #name => {
                    if values.len() != #len {
                        return Err(ParamError::WrongLength { name: name.to_string(), expected: #len, given: values.len() });
                    }
                    #assign
                }
            }
        });
        let get_arms = model.params.iter().zip(&fields).map(|(p, fi)| {
            let name = &p.name;
            match (p.shape, p.diagonal) {
                (Shape::Scalar, _) => quote!(#name => Some(vec![self.#fi])),
                (Shape::Vector(_), _) | (_, true) => quote!(#name => Some(self.#fi.to_vec())),
                (Shape::Matrix(r, c), false) => {
                    let (r, c) = (u(r), u(c));
                    quote!(#name => Some((0..#c).flat_map(|j| (0..#r).map(move |i| (i, j))).map(|(i, j)| self.#fi[i][j]).collect()))
                }
            }
        });
        let known = model
            .params
            .iter()
            .map(|p| format!("`{}`", p.name))
            .collect::<Vec<_>>()
            .join(", ");
        let known = if known.is_empty() {
            "(none)".to_string()
        } else {
            known
        };
        let point_names = model.points.iter().map(|p| p.name.as_str());
        let point_arms = model.points.iter().map(|pt| {
            let name = &pt.name;
            let fname = format_ident!("point_{}", snake(&pt.name));
            quote!(#name => Some(self.#fname().to_vec()))
        });
        let unknown =
            quote!(Err(ParamError::Unknown { name: name.to_string(), known: #known.to_string() }));
        // Without parameters (or points) the lookups are a plain miss: a `match` with only
        // `_` and an unused `values` would not be clippy-clean.
        let (set_param, param) = if model.params.is_empty() {
            (
                quote! {
                    fn set_param(&mut self, name: &str, _values: &[f64]) -> Result<(), ParamError> {
                        #unknown
                    }
                    fn param(&self, _name: &str) -> Option<Vec<f64>> {
                        None
                    }
                },
                TokenStream::new(),
            )
        } else {
            (
                quote! {
                    fn set_param(&mut self, name: &str, values: &[f64]) -> Result<(), ParamError> {
                        match name {
                            #(#set_arms)*
                            _ => return #unknown,
                        }
                        *self = self.model.prepare();
                        Ok(())
                    }
                },
                quote! {
                    fn param(&self, name: &str) -> Option<Vec<f64>> {
                        match name {
                            #(#get_arms,)*
                            _ => None,
                        }
                    }
                },
            )
        };
        let point = if model.points.is_empty() {
            quote! {
                fn point(&self, _name: &str) -> Option<Vec<f64>> {
                    None
                }
            }
        } else {
            quote! {
                fn point(&self, name: &str) -> Option<Vec<f64>> {
                    match name {
                        #(#point_arms,)*
                        _ => None,
                    }
                }
            }
        };
        let prep = &self.prepared_ty;
        quote! {
            /// Parameters and points by name; setting a parameter prepares the model again.
            impl Parameters for #prep<f64> {
                #set_param
                #param
                fn point_names(&self) -> &'static [&'static str] {
                    &[#(#point_names),*]
                }
                #point
            }
        }
    }
}

/// The Rust type of a value of this shape over `T` (parameters, accessors).
fn rust_type(shape: Shape) -> String {
    match shape {
        Shape::Scalar => "T".into(),
        Shape::Vector(n) => format!("[T; {n}]"),
        Shape::Matrix(r, c) => format!("[[T; {c}]; {r}]"),
    }
}
