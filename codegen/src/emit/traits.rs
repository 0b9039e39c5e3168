//! The runtime-trait impls of a model: `Field`, `Invariants`, `Lyapunov`, `Partitioned`,
//! `Declared`.

use super::body::{Body, Output, Place};
use super::{file_name, note_for, u, Emitter};
use crate::ir::{Id, Input};
use lasalle_model::Splitting;
use proc_macro2::Literal;
use proc_macro2::TokenStream;
use quote::quote;

fn is_state(i: &Input) -> bool {
    matches!(i, Input::State(_))
}
fn is_target(i: &Input) -> bool {
    matches!(i, Input::Target(_))
}
fn is_gain(i: &Input) -> bool {
    matches!(i, Input::Gain(_))
}

/// An indexed place: `dx[3]`, `f[0]`.
fn place(array: &str, k: usize) -> TokenStream {
    let array = quote::format_ident!("{}", array);
    let k = u(k);
    quote!(#array[#k])
}

impl Emitter<'_> {
    /// `dx[k] = X_k` for the components where `only(k)`, each under its model line.
    fn field_outputs(&self, ids: &[Id], only: impl Fn(usize) -> bool) -> Vec<Output> {
        ids.iter()
            .enumerate()
            .filter(|(k, _)| only(*k))
            .map(|(k, &id)| Output {
                place: Place::Assign(place("dx", k)),
                id,
                note: Some(note_for(self.model, &self.model.field_spans[k])),
            })
            .collect()
    }

    /// The note of the invariant that stacked component k belongs to.
    fn invariant_note(&self, k: usize) -> String {
        let f = self
            .model
            .invariants
            .iter()
            .find(|f| (f.offset..f.offset + f.value.shape.len()).contains(&k))
            .expect("row");
        note_for(self.model, &f.span)
    }

    /// `impl Field` (on the prepared model, as every trait impl), and the body's operation
    /// count.
    pub fn field_impl(&mut self) -> (TokenStream, u64) {
        let outputs = self.field_outputs(&self.model.field, |_| true);
        let body = self.body(&outputs, &["x", "dx"]);
        let (prep, n) = (&self.prepared_ty, u(self.n));
        let x = body.arg("x", is_state);
        let tokens = &body.tokens;
        (
            quote! {
                impl<T: Float> Field<T, [T; #n]> for #prep<T> {
                    fn field(&self, #x: &[T; #n], dx: &mut [T; #n]) { #tokens }
                }

            },
            body.ops,
        )
    }

    /// `impl Invariants`, and the operation counts of f and Df.
    pub fn invariants_impl(&mut self) -> (TokenStream, u64, u64, Vec<Id>) {
        let f_ids = self.model.invariant_ids();
        let outputs: Vec<Output> = f_ids
            .iter()
            .enumerate()
            .map(|(k, &id)| Output {
                place: Place::Assign(place("f", k)),
                id,
                note: Some(self.invariant_note(k)),
            })
            .collect();
        let inv = self.body(&outputs, &["x", "f"]);
        let mut jac_outputs = Vec::new();
        let mut jac_ids = Vec::new();
        for (c, row) in self.d.jacobian.iter().enumerate() {
            for (i, &id) in row.iter().enumerate() {
                if self.model.graph.as_num(id) != Some(0.0) {
                    let (cu, iu) = (u(c), u(i));
                    jac_outputs.push(Output {
                        place: Place::Assign(quote!(jac[#cu][#iu])),
                        id,
                        note: Some(self.invariant_note(c)),
                    });
                    jac_ids.push(id);
                }
            }
        }
        let jac = self.body(&jac_outputs, &["x", "jac"]);
        let (prep, n, m) = (&self.prepared_ty, u(self.n), u(self.m));
        let jac_init = if jac_outputs.len() < self.n * self.m {
            quote!(*jac = [[T::zero(); #n]; #m];)
        } else {
            quote!()
        };
        let (ix, jx) = (inv.arg("x", is_state), jac.arg("x", is_state));
        // a model without invariants (a dissipative field) writes nothing into f and Df
        let (f, df) = if self.m == 0 {
            (quote!(_f), quote!(_jac))
        } else {
            (quote!(f), quote!(jac))
        };
        let (inv_tokens, jac_tokens) = (&inv.tokens, &jac.tokens);
        let tokens = quote! {
            impl<T: Float> Invariants<T, [T; #n], [T; #m]> for #prep<T> {
                fn invariants(&self, #ix: &[T; #n], #f: &mut [T; #m]) { #inv_tokens }

                fn invariants_jacobian(&self, #jx: &[T; #n], #df: &mut [[T; #n]; #m]) {
                    #jac_init
                    #jac_tokens
                }
            }

        };
        (tokens, inv.ops, jac.ops, jac_ids)
    }

    /// `impl Lyapunov`, and the operation counts of V, ∇V and X − ∇V.
    pub fn lyapunov_impl(&mut self) -> (TokenStream, [u64; 3]) {
        let model = self.model;
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
        let v = self.body(
            &[Output {
                place: Place::Return,
                id: model.lyapunov,
                note: Some(v_note),
            }],
            &["x", "target", "gains"],
        );
        let grad_outputs: Vec<Output> = self
            .d
            .lyapunov_gradient
            .iter()
            .enumerate()
            .map(|(k, &id)| Output {
                place: Place::Assign(place("grad", k)),
                id,
                note: Some(format!("∂V/∂x[{k}] ({})", self.leaves.state_name(k))),
            })
            .collect();
        let grad = self.body(&grad_outputs, &["x", "target", "gains", "grad"]);
        let fb_outputs: Vec<Output> = self
            .d
            .feedback
            .iter()
            .enumerate()
            .map(|(k, &id)| Output {
                place: Place::Assign(place("dx", k)),
                id,
                note: Some(format!(
                    "{} − ∂V/∂x[{k}]",
                    note_for(model, &model.field_spans[k])
                )),
            })
            .collect();
        let fb = self.body(&fb_outputs, &["x", "target", "gains", "dx"]);
        let prep = &self.prepared_ty;
        let (n, m, ng) = (u(self.n), u(self.m), u(self.gains()));
        let sig = |b: &Body| {
            (
                b.arg("x", is_state),
                b.arg("target", is_target),
                b.arg("gains", is_gain),
            )
        };
        let ((vx, vt, vg), (gx, gt, gg), (fx, ft, fg)) = (sig(&v), sig(&grad), sig(&fb));
        let (v_tokens, grad_tokens, fb_tokens) = (&v.tokens, &grad.tokens, &fb.tokens);
        let tokens = quote! {
            impl<T: Float> Lyapunov<T, [T; #n], [T; #m], [T; #ng]> for #prep<T> {
                fn lyapunov(&self, #vx: &[T; #n], #vt: &[T; #m], #vg: &[T; #ng]) -> T {
                    #v_tokens
                }

                fn lyapunov_gradient(&self, #gx: &[T; #n], #gt: &[T; #m], #gg: &[T; #ng], grad: &mut [T; #n]) {
                    #grad_tokens
                }

                fn feedback_field(&self, #fx: &[T; #n], #ft: &[T; #m], #fg: &[T; #ng], dx: &mut [T; #n]) {
                    #fb_tokens
                }
            }

        };
        (tokens, [v.ops, grad.ops, fb.ops])
    }

    /// `impl Partitioned` for fields q̇ = a(p), ṗ = b(q): Störmer–Verlet's half-fields.
    pub fn partitioned_impl(&mut self) -> TokenStream {
        let Some(is_q) = self.d.partition.clone() else {
            return TokenStream::new();
        };
        let q = self.body(
            &self.field_outputs(&self.model.field, |k| is_q[k]),
            &["x", "dx"],
        );
        let p = self.body(
            &self.field_outputs(&self.model.field, |k| !is_q[k]),
            &["x", "dx"],
        );
        let (prep, n) = (&self.prepared_ty, u(self.n));
        let (qx, px) = (q.arg("x", is_state), p.arg("x", is_state));
        let (q_tokens, p_tokens) = (&q.tokens, &p.tokens);
        quote! {
            impl<T: Float> Partitioned<T, [T; #n]> for #prep<T> {
                fn is_q(&self) -> &[bool] {
                    &[#(#is_q),*]
                }

                fn field_q(&self, #qx: &[T; #n], dx: &mut [T; #n]) { #q_tokens }

                fn field_p(&self, #px: &[T; #n], dx: &mut [T; #n]) { #p_tokens }
            }
        }
    }

    /// The `Declared` functions of the model's events (`event NAME: g = 0 …;`): their list and
    /// g(x, t).
    fn events(&mut self) -> TokenStream {
        let model = self.model;
        if model.events.is_empty() {
            return TokenStream::new();
        }
        let n = u(self.n);
        let outputs: Vec<Output> = model
            .events
            .iter()
            .enumerate()
            .map(|(i, e)| Output {
                place: Place::Assign(place("g", i)),
                id: e.value,
                note: Some(note_for(model, &e.span)),
            })
            .collect();
        let body = self.body(&outputs, &["x", "t", "g"]);
        let x = body.arg("x", is_state);
        let t = body.arg("t", |i| *i == lasalle_model::EVENT_TIME);
        let tokens = &body.tokens;
        let specs = model.events.iter().map(|e| {
            let name = &e.name;
            let direction = match e.direction {
                lasalle_model::Direction::Both => quote!(EventDirection::Both),
                lasalle_model::Direction::Rising => quote!(EventDirection::Rising),
                lasalle_model::Direction::Falling => quote!(EventDirection::Falling),
            };
            let terminal = e.terminal;
            quote!(EventSpec { name: #name, direction: #direction, terminal: #terminal })
        });
        let switches = model.switches.iter().map(|s| {
            let (surface, mode, slide, event) = (&s.text, s.mode, s.slide, s.event);
            quote!(SwitchSpec { surface: #surface, mode: #mode, slide: #slide, event: #event })
        });
        let switches = if model.switches.is_empty() {
            TokenStream::new()
        } else {
            quote! {
                fn switches(&self) -> &'static [SwitchSpec] {
                    &[#(#switches),*]
                }
            }
        };
        let list = quote! {
            fn events(&self) -> &'static [EventSpec] {
                &[#(#specs),*]
            }
            #switches
        };
        quote! {
            #list
            fn event_values(&self, #x: &[T; #n], #t: T, g: &mut [T]) {
                #tokens
            }
        }
    }

    /// `impl Declared`: the model file's run presets, guards and structure-specific steppers.
    pub fn declared_impl(&mut self) -> TokenStream {
        let model = self.model;
        let n = u(self.n);
        let presets = model.presets.iter().map(|p| {
            let name = &p.name;
            let opt_str = |v: &Option<String>| match v {
                Some(s) => quote!(Some(#s)),
                None => quote!(None),
            };
            let opt_f64 = |v: Option<f64>| match v {
                Some(x) => {
                    let l = Literal::f64_unsuffixed(x);
                    quote!(Some(#l))
                }
                None => quote!(None),
            };
            let (method, init) = (opt_str(&p.method), opt_str(&p.init));
            let (dt, t_end) = (opt_f64(p.dt), opt_f64(p.t_end));
            let every = match p.every {
                Some(k) => {
                    let k = Literal::u64_unsuffixed(k);
                    quote!(Some(#k))
                }
                None => quote!(None),
            };
            let gains = match &p.gains {
                Some(g) => {
                    let g = g.iter().map(|x| Literal::f64_unsuffixed(*x));
                    quote!(Some(&[#(#g),*]))
                }
                None => quote!(None),
            };
            let params = p.params.iter().map(|(name, values)| {
                let values = values.iter().map(|x| Literal::f64_unsuffixed(*x));
                quote!((#name, &[#(#values),*]))
            });
            quote! {
                Preset { name: #name, method: #method, dt: #dt, t_end: #t_end, every: #every, init: #init, gains: #gains, params: &[#(#params),*] }
            }
        });
        let presets = if model.presets.is_empty() {
            TokenStream::new()
        } else {
            quote! {
                fn presets(&self) -> &'static [Preset] {
                    &[#(#presets),*]
                }
            }
        };
        let guards = if model.guards.is_empty() {
            TokenStream::new()
        } else {
            let k = u(model.guards.len());
            let outputs: Vec<Output> = model
                .guards
                .iter()
                .enumerate()
                .map(|(i, g)| Output {
                    place: Place::Assign(place("margin", i)),
                    id: g.margin,
                    note: Some(note_for(model, &g.span)),
                })
                .collect();
            let body = self.body(&outputs, &["x", "dt", "margin"]);
            let x = body.arg("x", is_state);
            let dt = body.arg("dt", |i| *i == lasalle_model::GUARD_STEP);
            let tokens = &body.tokens;
            let checks = model.guards.iter().enumerate().map(|(i, g)| {
                let (name, condition, iu, strict) = (&g.name, &g.condition, u(i), g.strict);
                quote!(GuardFailure::check(#name, #condition, margin[#iu], #strict))
            });
            let mut checks = checks.collect::<Vec<_>>().into_iter();
            let first = checks.next().expect("at least one guard");
            let rest = checks.map(|c| quote!(.or_else(|| #c)));
            quote! {
                fn check_guards(&self, #x: &[T; #n], #dt: T) -> Option<GuardFailure> {
                    let mut margin = [T::zero(); #k];
                    #tokens
                    #first #(#rest)*
                }
            }
        };
        let events = self.events();
        let delays = model.delays.iter().map(|d| {
            let (text, location) = (&d.text, d.span.location());
            let (component, slot, clock) = (d.component, d.slot, d.clock);
            quote!(DelaySpec { text: #text, location: #location, component: #component, slot: #slot, clock: #clock })
        });
        let delays = if model.delays.is_empty() {
            TokenStream::new()
        } else {
            quote! {
                fn delays(&self) -> &'static [DelaySpec] {
                    &[#(#delays),*]
                }
            }
        };
        let partitioned = if self.d.partition.is_some() {
            quote! {
                fn partitioned(&self) -> Option<&dyn Partitioned<T, [T; #n]>> {
                    Some(self)
                }
            }
        } else {
            TokenStream::new()
        };
        let splitting = match &model.splitting {
            Some(Splitting { kind, params }) => {
                let values = params.iter().map(|&k| self.leaves.input(Input::Param(k)).1);
                quote! {
                    fn splitting(&self) -> Option<Splitting<T>> {
                        Splitting::declared(#kind, &[#(#values),*])
                    }
                }
            }
            None => TokenStream::new(),
        };
        let taylor = self.taylor_hook();
        let prep = &self.prepared_ty;
        quote! {
            impl<T: Float> Declared<T, [T; #n]> for #prep<T> {
                #presets
                #guards
                #events
                #delays
                #partitioned
                #splitting
                #taylor
            }
        }
    }
}
