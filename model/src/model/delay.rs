//! Delay equations: the delayed states of `delay(x, r)`.
//!
//! ẋ(t) = f(x(t), x(t − r₁), …, x(t − r_m)) with constant delays rⱼ > 0 (a retarded functional
//! differential equation ẋ = f(x_t) on C([−r, 0]); LaSalle, "An invariance principle in the
//! theory of stability", §3). Each distinct pair (state component, delay) becomes a *lag
//! slot*: a state component that the field reads where the model wrote `delay(x, r)`, and
//! that the run fills with x(t − r) from the solution's past before every evaluation (the
//! method of steps, `lasalle_run`'s delay run). A *clock* component τ with τ̇ = 1 before the
//! lag slots carries the time into the field, which is otherwise autonomous.
//!
//! The field of a lag slot is the delay r itself, an expression of the parameters: the run
//! reads it once at the start, checks it (positive, finite) and integrates the slot with
//! derivative 0. A model file never sees these components; its points start them at 0.

use super::lower::{Lowerer, L};
use super::{Event, Invariant, Point, StateVar, EVENT_TIME};
use crate::error::{Diagnostic, Span};
use crate::ir::{Id, Input, Node};
use crate::model::Shape;
use crate::parse::ast::Expr;

/// The most lag slots (distinct pairs of state component and delay) a model may have.
pub const MAX_DELAYS: usize = 16;

/// A delayed state as lowering meets it.
#[derive(Clone, Debug)]
pub(crate) struct Lag {
    /// The delayed state component.
    pub(crate) component: usize,
    /// The delay r (an expression of the parameters).
    pub(crate) lag: Id,
    /// The `delay(x, r)` call.
    pub(crate) span: Span,
}

/// A delayed state x(t − r) of a model: the component read, its lag slot, the delay.
#[derive(Clone, Debug)]
pub struct Delay {
    /// The state component x.
    pub component: usize,
    /// The state component the field reads x(t − r) from.
    pub slot: usize,
    /// The state component of the clock τ (τ̇ = 1), shared by all delays.
    pub clock: usize,
    /// The delay r, an expression of the parameters (also the field of `slot`).
    pub lag: Id,
    /// The call as written in the model file, e.g. `delay(x, r)`.
    pub text: String,
    /// Where the call is.
    pub span: Span,
}

impl Lowerer {
    /// `delay(x, r)`: the lag slot of the pair (x, r).
    pub(super) fn delay(&mut self, x: Id, r: Id, call: &Expr, args: &[Expr]) -> L<Id> {
        let n = self.declared_dim as u32;
        let component = match self.g.node(x) {
            Node::Input(Input::State(k)) if *k < n => *k as usize,
            _ => {
                return Err(Diagnostic::new(
                    &args[0].span,
                    "`delay` reads a state component at t − r, and this argument is not one",
                )
                .help("write `delay(x, r)` for a scalar state `x` or a component `x[i]`; a function of the past state is a function of delays, e.g. `sin(delay(x, r))`"));
            }
        };
        let not_constant = self.g.depends_on(r, |i| {
            matches!(i, Input::State(_) | Input::Target(_)) || i == EVENT_TIME
        });
        if not_constant {
            return Err(Diagnostic::new(
                &args[1].span,
                "the delay of `delay(x, r)` must be a positive constant, and this one depends on the state or the time",
            )
            .help("write a number or an expression of the parameters, e.g. `delay(x, r)` with `param r = 1;`"));
        }
        if let Some(v) = self.g.as_num(r) {
            if !(v > 0.0 && v.is_finite()) {
                return Err(Diagnostic::new(
                    &args[1].span,
                    format!("the delay of `delay(x, r)` must be a positive constant, and this one is {v}"),
                )
                .help("a delay of 0 is the present state: write `x` itself"));
            }
        }
        let j = match self
            .delays
            .iter()
            .position(|d| d.component == component && d.lag == r)
        {
            Some(j) => j,
            None => {
                if self.delays.len() == MAX_DELAYS {
                    return Err(Diagnostic::new(
                        &call.span,
                        format!("a model may read at most {MAX_DELAYS} delayed states"),
                    )
                    .help("each distinct pair of state component and delay is one"));
                }
                self.delays.push(Lag {
                    component,
                    lag: r,
                    span: call.span.clone(),
                });
                self.delays.len() - 1
            }
        };
        Ok(self.g.input(Input::State(n + 1 + j as u32)))
    }

    /// Appends the clock and the lag slots to the state and the field, and checks that only
    /// the field reads them (see the module docs).
    pub(super) fn delaying(
        &mut self,
        state: &mut Vec<StateVar>,
        field: &mut Vec<Id>,
        field_spans: &mut Vec<Span>,
        parts: Parts<'_>,
    ) -> L<Vec<Delay>> {
        let lags = std::mem::take(&mut self.delays);
        let Some(first) = lags.first() else {
            return Ok(Vec::new());
        };
        if parts.switched {
            return Err(Diagnostic::new(
                &first.span,
                "a model with `sign` may not also read delayed states",
            )
            .help("a delay run and a switching run are separate machinery: use one of them"));
        }
        let n = self.declared_dim;
        let lag_slot = |i: Input| matches!(i, Input::State(k) if k as usize >= n);
        for e in parts.events.iter() {
            if self.g.depends_on(e.value, lag_slot) {
                return Err(located_outside(&e.span, "an event"));
            }
        }
        for inv in parts.invariants.iter() {
            if inv
                .value
                .ids
                .iter()
                .any(|&v| self.g.depends_on(v, lag_slot))
            {
                return Err(located_outside(&inv.span, "an invariant"));
            }
        }
        let clock = n;
        let one = self.g.num(1.0);
        let zero = self.g.num(0.0);
        let name = fresh(state, "clock");
        state.push(StateVar {
            name,
            shape: Shape::Scalar,
            offset: clock,
            span: first.span.clone(),
        });
        field.push(one);
        field_spans.push(first.span.clone());
        let mut delays = Vec::new();
        for (j, lag) in lags.into_iter().enumerate() {
            let slot = n + 1 + j;
            let name = fresh(state, &format!("lag_{j}"));
            state.push(StateVar {
                name,
                shape: Shape::Scalar,
                offset: slot,
                span: lag.span.clone(),
            });
            field.push(lag.lag);
            field_spans.push(lag.span.clone());
            let text = lag.span.text().split_whitespace().collect::<Vec<_>>();
            delays.push(Delay {
                component: lag.component,
                slot,
                clock,
                lag: lag.lag,
                text: text.join(" "),
                span: lag.span,
            });
        }
        for p in parts.points.iter_mut() {
            p.values.extend(std::iter::repeat_n(zero, delays.len() + 1));
        }
        Ok(delays)
    }
}

/// What [`Lowerer::delaying`] checks and extends besides the state and the field.
pub(super) struct Parts<'a> {
    /// The model's events.
    pub(super) events: &'a [Event],
    /// Its invariants.
    pub(super) invariants: &'a [Invariant],
    /// Its points, which start the clock and the lag slots at 0.
    pub(super) points: &'a mut [Point],
    /// Whether it switches on a `sign(g)`.
    pub(super) switched: bool,
}

/// The error of a delayed state read outside the field.
fn located_outside(span: &Span, what: &str) -> Diagnostic {
    Diagnostic::new(
        span,
        format!("{what} may not read a delayed state: only the field reads `delay(x, r)`"),
    )
    .help("the run fills x(t − r) in for the field's evaluations alone")
}

/// `base`, or `base_`, `base__`, … if a state variable already has the name.
fn fresh(state: &[StateVar], base: &str) -> String {
    let mut name = base.to_string();
    while state.iter().any(|s| s.name == name) {
        name.push('_');
    }
    name
}
