//! Discontinuous fields: the switching surfaces of `sign(g)`.
//!
//! Each distinct switching function g (the argument of a `sign`) is a surface g = 0 on which
//! the field may jump. `sign(g)` reads a *mode* s ∈ {−1, 0, 1}, a state component the run keeps
//! constant between switches, so that the field within one mode is smooth and the steppers,
//! their continuous extensions and the event machinery work on it unchanged. A second
//! component, the *slide* flag σ ∈ {0, 1}, selects Filippov's sliding motion on the surface:
//! with X⁺ and X⁻ the field with s = +1 and s = −1, and a± = ∇g · X± their normal velocities,
//!
//!   X = (1 − σ) X(s) + σ (a⁻ X⁺ − a⁺ X⁻) / (a⁻ − a⁺),
//!
//! the convex combination of K[X] tangent to the surface (Filippov; Hermes, "Discontinuous
//! vector fields and feedback control", §1). Surfaces are wrapped one after another, so the
//! field sliding on one surface is the field the next one switches. The sliding term is
//! written σ (a⁻X⁺ − a⁺X⁻)(a⁻ − a⁺) / ((a⁻ − a⁺)² + 1 − σ), which is the combination for
//! σ = 1 and exactly 0 for σ = 0 whatever a±.
//!
//! Four events per surface, all `stop` events of the run, tell the run engine when to decide
//! again (`lasalle_run`'s switching loop): the crossing g s² (zero while the run is on the
//! surface), the ends of a Filippov slide σ a⁺ and σ a⁻ (the combination's weight leaving
//! [0, 1]), and the end of a classical slide (1 − s²)(1 − σ) c with c = ∇g · X(s = 0), the
//! normal velocity of the field the surface's own case gives.

use super::lower::{Lowerer, L};
use super::{Direction, Event, Point, StateVar, EVENT_TIME};
use crate::error::{Diagnostic, Span};
use crate::ir::{gradient, Graph, Id, Input, Node};
use crate::model::Shape;
use crate::parse::ast::Expr;

/// The most switching surfaces a model may have (the field grows about fourfold with each).
pub const MAX_SWITCHES: usize = 8;

/// A switching function as lowering meets it.
#[derive(Clone, Debug)]
pub(crate) struct Surface {
    /// g.
    pub(crate) g: Id,
    /// Where its first `sign(g)` is.
    pub(crate) span: Span,
}

/// A switching surface g = 0 of a model, with its mode components and events.
#[derive(Clone, Debug)]
pub struct Switch {
    /// g.
    pub surface: Id,
    /// g as written in the model file.
    pub text: String,
    /// The state component of the mode s = sign(g).
    pub mode: usize,
    /// The state component of the slide flag σ.
    pub slide: usize,
    /// The index of its first event among the model's events: the crossing, then the ends of
    /// a Filippov slide on the + and the − side, then the end of a classical slide.
    pub event: usize,
    /// Where its first `sign(g)` is.
    pub span: Span,
}

impl Lowerer {
    /// `sign(g)`: the mode component of the surface g = 0.
    pub(super) fn sign(&mut self, g: Id, arg: &Expr) -> L<Id> {
        if !self.g.depends_on(
            g,
            |i| matches!(i, Input::State(k) if (k as usize) < self.declared_dim),
        ) {
            return Err(Diagnostic::new(
                &arg.span,
                "`sign` switches on a function of the state, and this argument does not depend on it",
            )
            .help("a constant's sign is known: write −1, 0 or 1"));
        }
        let k = match self.switches.iter().position(|s| s.g == g) {
            Some(k) => k,
            None => {
                if self.switches.len() == MAX_SWITCHES {
                    return Err(Diagnostic::new(
                        &arg.span,
                        format!("a model may switch on at most {MAX_SWITCHES} functions `sign(g)`"),
                    )
                    .help("the field grows about fourfold with each switching surface"));
                }
                self.switches.push(Surface {
                    g,
                    span: arg.span.clone(),
                });
                self.switches.len() - 1
            }
        };
        Ok(self
            .g
            .input(Input::State((self.declared_dim + 2 * k) as u32)))
    }

    /// Appends the modes to the state, the sliding motion to the field and the switching
    /// events to the events (see the module docs).
    pub(super) fn switching(
        &mut self,
        state: &mut Vec<StateVar>,
        field: &mut Vec<Id>,
        field_spans: &mut Vec<Span>,
        events: &mut Vec<Event>,
        points: &mut [Point],
    ) -> L<Vec<Switch>> {
        let surfaces = std::mem::take(&mut self.switches);
        if surfaces.is_empty() {
            return Ok(Vec::new());
        }
        if let Some(e) = events
            .iter()
            .find(|e| self.g.depends_on(e.value, |i| i == EVENT_TIME))
        {
            return Err(Diagnostic::new(
                &e.span,
                "an event of a model with `sign` may not read the time `t`",
            )
            .help("a switching run restarts at each switch; write the event as a function of the state"));
        }
        let n = self.declared_dim;
        let zero = self.g.num(0.0);
        let physical: Vec<Input> = (0..n as u32).map(Input::State).collect();
        let mut switches = Vec::new();
        for (k, surface) in surfaces.iter().enumerate() {
            let (mode, slide) = (n + 2 * k, n + 2 * k + 1);
            for (offset, base) in [(mode, "sign"), (slide, "slide")] {
                let name = fresh(state, &format!("{base}_{k}"));
                state.push(StateVar {
                    name,
                    shape: Shape::Scalar,
                    offset,
                    span: surface.span.clone(),
                });
                field.push(zero);
                field_spans.push(surface.span.clone());
            }
            for p in points.iter_mut() {
                p.values.extend([zero, zero]);
            }
            let text = surface
                .span
                .text()
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" ");
            let g = &mut self.g;
            let grad = gradient(g, surface.g, &physical);
            let fixed = |g: &mut Graph, v: f64| {
                let x = &field[..n];
                substitute(g, x, mode, v)
            };
            let (xp, xm, x0) = (fixed(g, 1.0), fixed(g, -1.0), fixed(g, 0.0));
            let (ap, am, c) = (dot(g, &grad, &xp), dot(g, &grad, &xm), dot(g, &grad, &x0));
            let s = g.input(Input::State(mode as u32));
            let sigma = g.input(Input::State(slide as u32));
            let one = g.num(1.0);
            let not_sliding = g.sub(one, sigma);
            let d = g.sub(am, ap);
            let d2 = g.mul(&[d, d]);
            let denominator = g.add(&[d2, not_sliding]);
            let weight = g.div(d, denominator);
            for j in 0..n {
                let (pj, mj) = (g.mul(&[am, xp[j]]), g.mul(&[ap, xm[j]]));
                let combination = g.sub(pj, mj);
                let sliding = g.mul(&[sigma, combination, weight]);
                let kept = g.mul(&[not_sliding, field[j]]);
                field[j] = g.add(&[kept, sliding]);
            }
            let s2 = g.mul(&[s, s]);
            let off_surface = g.sub(one, s2);
            let values = [
                g.mul(&[surface.g, s2]),
                g.mul(&[sigma, ap]),
                g.mul(&[sigma, am]),
                g.mul(&[off_surface, not_sliding, c]),
            ];
            let event = events.len();
            let names = ["", "_exit_plus", "_exit_minus", "_exit_surface"];
            for (value, suffix) in values.into_iter().zip(names) {
                events.push(Event {
                    name: format!("sign_{k}{suffix}"),
                    value,
                    direction: Direction::Both,
                    terminal: true,
                    expr: text.clone(),
                    span: surface.span.clone(),
                });
            }
            switches.push(Switch {
                surface: surface.g,
                text,
                mode,
                slide,
                event,
                span: surface.span.clone(),
            });
        }
        Ok(switches)
    }
}

/// `base`, or `base_`, `base__`, … if a state variable already has the name.
fn fresh(state: &[StateVar], base: &str) -> String {
    let mut name = base.to_string();
    while state.iter().any(|s| s.name == name) {
        name.push('_');
    }
    name
}

/// `exprs` with the state component `k` replaced by the number `v`.
fn substitute(g: &mut Graph, exprs: &[Id], k: usize, v: f64) -> Vec<Id> {
    let target = Input::State(k as u32);
    g.rebuild(exprs, |g, node| match node {
        Node::Input(i) if *i == target => Some(g.num(v)),
        _ => None,
    })
}

/// a · b.
fn dot(g: &mut Graph, a: &[Id], b: &[Id]) -> Id {
    let terms: Vec<Id> = a.iter().zip(b).map(|(&x, &y)| g.mul(&[x, y])).collect();
    g.add(&terms)
}
