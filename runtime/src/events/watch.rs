//! [`Watch`]: after every step, the crossings of the model's events on the step's continuous
//! extension, and the states at the output times that fall in it.

use super::extension::{Extension, Hermite};
use super::root::{brent, golden_min};
use super::{Crossing, EventDirection, EventSpec};
use crate::state::State;
use crate::steppers::DenseOutput;

/// Subintervals a step is cut into to look for sign changes and extrema of each event
/// function: two crossings of one event closer than a quarter step are seen as an extremum
/// (and then both found) only where the sampled values show one.
pub const SUBINTERVALS: usize = 4;

/// A minimum of |g| along a step within this fraction of g's range over the step is a touch:
/// found once, as one crossing, even where the interpolant dips through zero and back.
pub const TOUCH: f64 = 1e-8;

/// The event function g(x, t) of every event at once, into the slice.
pub type EventFn<'m, X> = dyn Fn(&X, f64, &mut [f64]) + 'm;
/// The model's field, for the Hermite interpolant.
pub type FieldFn<'m, X> = dyn Fn(&X, &mut X) + 'm;

/// Locates events and samples output times step by step; see the [module docs](super).
pub struct Watch<'m, X> {
    events: Vec<EventSpec>,
    g: Box<EventFn<'m, X>>,
    field: Box<FieldFn<'m, X>>,
    t_eval: Vec<f64>,
    next_eval: usize,
    t0: f64,
    x0: X,
    f0: X,
    f0_valid: bool,
    f1: X,
    /// g at t₀, per event.
    g0: Vec<f64>,
    /// The sign of the last nonzero value of each event function (0 before any).
    sign: Vec<f64>,
    /// Did the last step end with the event function coming nearer zero (and no touch)?
    approach: Vec<bool>,
    /// Where each event function last became exactly 0, while it stays 0.
    zero_at: Vec<Option<f64>>,
    /// A crossing near which g stayed within a touch of zero to the step's end, per event.
    pending: Vec<Option<Crossing<X>>>,
    tmp: X,
    gtmp: Vec<f64>,
    /// Node values, `(SUBINTERVALS + 1) × events`.
    nodes: Vec<f64>,
    /// The states at the interior nodes and just before the step's end.
    states: Vec<X>,
    found: Vec<Crossing<X>>,
    step_found: Vec<Crossing<X>>,
    /// Interpolations and event-function evaluations so far.
    pub evaluations: u64,
    /// Extra field evaluations for Hermite interpolants.
    pub field_evaluations: u64,
}

impl<'m, X: State<f64>> Watch<'m, X> {
    /// A watch of `events` (evaluated by `g`), sampling the sorted output times `t_eval`,
    /// starting at (t₀, x₀); `field` is the model's field for the Hermite interpolant of
    /// steppers without dense output. Returns the outputs at t₀ through `on_grid`.
    pub fn new(
        events: Vec<EventSpec>,
        g: Box<EventFn<'m, X>>,
        field: Box<FieldFn<'m, X>>,
        t_eval: Vec<f64>,
        t0: f64,
        x0: &X,
    ) -> Self {
        let m = events.len();
        let mut w = Watch {
            events,
            g,
            field,
            t_eval,
            next_eval: 0,
            t0,
            x0: x0.clone(),
            f0: x0.clone(),
            f0_valid: false,
            f1: x0.clone(),
            g0: vec![0.0; m],
            sign: vec![0.0; m],
            approach: vec![false; m],
            zero_at: vec![None; m],
            pending: vec![None; m],
            tmp: x0.clone(),
            gtmp: vec![0.0; m],
            nodes: vec![0.0; (SUBINTERVALS + 1) * m],
            states: vec![x0.clone(); SUBINTERVALS],
            found: Vec::new(),
            step_found: Vec::new(),
            evaluations: 0,
            field_evaluations: 0,
        };
        if m > 0 {
            (w.g)(x0, t0, &mut w.g0);
            for (s, &v) in w.sign.iter_mut().zip(&w.g0) {
                *s = sgn(v);
            }
        }
        w
    }

    /// The events watched.
    pub fn events(&self) -> &[EventSpec] {
        &self.events
    }

    /// Calls `on_grid(t, x)` for the output times at the start (t = t₀).
    pub fn start(&mut self, on_grid: &mut dyn FnMut(f64, &X)) {
        while self.next_eval < self.t_eval.len() && self.t_eval[self.next_eval] <= self.t0 {
            on_grid(self.t_eval[self.next_eval], &self.x0);
            self.next_eval += 1;
        }
    }

    /// The non-terminal crossings found so far, in time order; they are handed out once.
    pub fn take_crossings(&mut self) -> Vec<Crossing<X>> {
        std::mem::take(&mut self.found)
    }

    /// At the end of the run: the crossings that were waiting to see whether a touch follows
    /// (g still within a touch of zero at the last step's end), up to `t_end`, in time order.
    pub fn finish(&mut self, t_end: f64) -> Vec<Crossing<X>> {
        let mut rest: Vec<Crossing<X>> = self.pending.iter_mut().filter_map(Option::take).collect();
        rest.retain(|c| c.t <= t_end);
        rest.retain(|c| {
            c.touch
                || match self.events[c.event].direction {
                    EventDirection::Both => true,
                    EventDirection::Rising => c.rising,
                    EventDirection::Falling => !c.rising,
                }
        });
        rest.sort_by(|a, b| a.t.total_cmp(&b.t));
        let mut found = self.take_crossings();
        found.append(&mut rest);
        found
    }

    /// Are there output times left?
    pub fn grid_done(&self) -> bool {
        self.next_eval >= self.t_eval.len()
    }

    /// After a step to (t₁, x₁) whose stepper has the continuous extension `dense` (or none:
    /// the Hermite cubic): records the crossings in the step, calls `on_grid` for the output
    /// times in (t₀, t₁] (up to a terminal crossing), and returns the first terminal
    /// crossing, if any, which ends the run.
    pub fn after_step(
        &mut self,
        dense: Option<&dyn DenseOutput<f64, X>>,
        t1: f64,
        x1: &X,
        on_grid: &mut dyn FnMut(f64, &X),
    ) -> Option<Crossing<X>> {
        let t0 = self.t0;
        let h = t1 - t0;
        let slack = 1e-9 * h.abs().max(f64::MIN_POSITIVE);
        let dense = dense.and_then(|d| {
            let (a, b) = d.dense_interval()?;
            ((a - t0).abs() <= slack && (b - t1).abs() <= slack).then_some((d, a, b))
        });
        let needs_work = !self.events.is_empty() || self.next_eval < self.t_eval.len();
        if needs_work && dense.is_none() {
            if !self.f0_valid {
                (self.field)(&self.x0, &mut self.f0);
                self.field_evaluations += 1;
            }
            (self.field)(x1, &mut self.f1);
            self.field_evaluations += 1;
        }
        let mut terminal = None;
        if needs_work {
            let ext = match dense {
                Some((d, a, b)) => Extension::Dense(d, a, b),
                None => Extension::Hermite(Hermite {
                    t0,
                    t1,
                    x0: &self.x0,
                    x1,
                    f0: &self.f0,
                    f1: &self.f1,
                }),
            };
            if !self.events.is_empty() && h > 0.0 {
                terminal = locate(
                    &ext,
                    t0,
                    t1,
                    x1,
                    Locate {
                        events: &self.events,
                        g: &*self.g,
                        g0: &mut self.g0,
                        sign: &mut self.sign,
                        approach: &mut self.approach,
                        zero_at: &mut self.zero_at,
                        pending: &mut self.pending,
                        nodes: &mut self.nodes,
                        states: &mut self.states,
                        tmp: &mut self.tmp,
                        gtmp: &mut self.gtmp,
                        found: &mut self.step_found,
                        evaluations: &mut self.evaluations,
                    },
                );
                self.found.append(&mut self.step_found);
            }
            let t_cut = terminal.as_ref().map_or(t1, |c: &Crossing<X>| c.t);
            while self.next_eval < self.t_eval.len() && self.t_eval[self.next_eval] <= t_cut {
                let t = self.t_eval[self.next_eval];
                if t == t1 {
                    on_grid(t, x1);
                } else {
                    ext.eval(t, &mut self.tmp);
                    on_grid(t, &self.tmp);
                }
                self.next_eval += 1;
            }
        }
        self.t0 = t1;
        self.x0.clone_from(x1);
        if dense.is_none() && needs_work {
            std::mem::swap(&mut self.f0, &mut self.f1);
            self.f0_valid = true;
        } else {
            self.f0_valid = false;
        }
        terminal
    }
}

/// The sign of v: ±1, or 0 for 0 and NaN.
fn sgn(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// The watch's event state, borrowed for one step.
struct Locate<'a, 'm, X> {
    events: &'a [EventSpec],
    g: &'a EventFn<'m, X>,
    g0: &'a mut Vec<f64>,
    sign: &'a mut Vec<f64>,
    approach: &'a mut Vec<bool>,
    zero_at: &'a mut Vec<Option<f64>>,
    pending: &'a mut Vec<Option<Crossing<X>>>,
    nodes: &'a mut Vec<f64>,
    states: &'a mut [X],
    tmp: &'a mut X,
    gtmp: &'a mut Vec<f64>,
    found: &'a mut Vec<Crossing<X>>,
    evaluations: &'a mut u64,
}

/// The crossings of every event on [t₀, t₁] of the extension `ext` into `l.found` (time
/// order, cut after the first terminal one, which is returned instead).
fn locate<X: State<f64>>(
    ext: &Extension<'_, X>,
    t0: f64,
    t1: f64,
    x1: &X,
    l: Locate<'_, '_, X>,
) -> Option<Crossing<X>> {
    let m = l.events.len();
    let node_t = |j: usize| {
        if j == SUBINTERVALS {
            t1
        } else {
            t0 + (t1 - t0) * j as f64 / SUBINTERVALS as f64
        }
    };
    // The states at the interior nodes and just before the step's end (where g is looked at
    // only if it comes nearer zero at the end), interpolated together; then the event
    // functions at the nodes: t₀ from the last step, t₁ at the stepper's state.
    let mut times = [0.0; SUBINTERVALS];
    for (j, t) in times.iter_mut().enumerate().take(SUBINTERVALS - 1) {
        *t = node_t(j + 1);
    }
    let t_near = t1 - 1e-6 * (t1 - node_t(SUBINTERVALS - 1));
    times[SUBINTERVALS - 1] = t_near;
    ext.eval_many(&times, l.states);
    l.nodes[..m].copy_from_slice(l.g0);
    for j in 1..=SUBINTERVALS {
        let t = node_t(j);
        let row = &mut l.nodes[j * m..(j + 1) * m];
        if j == SUBINTERVALS {
            (l.g)(x1, t, row);
        } else {
            (l.g)(&l.states[j - 1], t, row);
        }
        *l.evaluations += 1;
    }
    let (g, tmp, gtmp, evaluations) = (l.g, &mut *l.tmp, &mut *l.gtmp, &mut *l.evaluations);
    let near_state = &l.states[SUBINTERVALS - 1];
    // g_i along the extension; at t_near from the state interpolated above
    let mut gi = |i: usize, t: f64| -> f64 {
        if t == t_near {
            g(near_state, t, gtmp);
        } else {
            ext.eval(t, tmp);
            g(tmp, t, gtmp);
        }
        *evaluations += 1;
        gtmp[i]
    };
    l.found.clear();
    for (i, spec) in l.events.iter().enumerate() {
        let v = |j: usize| l.nodes[j * m + i];
        let scale = (0..=SUBINTERVALS).fold(0.0f64, |s, j| s.max(v(j).abs()));
        let tiny = 1e-7 * (t1 - t0);
        let mut roots: Vec<Root> = Vec::new();
        let mut s = l.sign[i];
        // the first subinterval, where the last step ended coming nearer zero without a touch
        // at its end
        let same = |s: f64, a: f64, b: f64| s != 0.0 && sgn(a) == s && sgn(b) == s;
        let mut xm = Extremum {
            gi: &mut gi,
            i,
            touch: TOUCH * scale,
            tiny,
        };
        if l.approach[i] && same(s, v(0), v(1)) && v(0).abs() < v(1).abs() {
            xm.search(&mut roots, s, (t0, v(0)), (node_t(1), v(1)), (true, false));
        }
        let (mut edge_touch, mut approaching) = (false, false);
        for j in 1..=SUBINTERVALS {
            let (a, b) = (node_t(j - 1), node_t(j));
            let (va, vb) = (v(j - 1), v(j));
            if vb == 0.0 {
                // an exact zero: a crossing if the sign changes after it, else a touch
                if s != 0.0 && l.zero_at[i].is_none() {
                    l.zero_at[i] = Some(b);
                }
            } else if s != 0.0 && sgn(vb) != s {
                // a sign change on [a, b] (va may be 0: the zero is then at a)
                let t = match l.zero_at[i].take() {
                    Some(tz) => tz,
                    None => brent(|t| (xm.gi)(i, t), a, b, va, vb, 0.0),
                };
                roots.push(Root::new(t, s < 0.0, false, false));
            } else if let Some(tz) = l.zero_at[i].take() {
                roots.push(Root::new(tz, s < 0.0, true, true));
            } else if j < SUBINTERVALS && same(s, va, vb) && sgn(v(j + 1)) == s {
                let vc = v(j + 1);
                if vb.abs() < va.abs() && vb.abs() <= vc.abs() {
                    xm.search(&mut roots, s, (a, va), (node_t(j + 1), vc), (false, false));
                }
            } else if j == SUBINTERVALS && same(s, va, vb) && vb.abs() < va.abs() {
                // nearer zero at the step's end than a sample before: if g already turned
                // back (a value just before the end is nearer still), its extremum lies in
                // the last subinterval; if it is still coming nearer, in the next step
                let near = (xm.gi)(i, t_near);
                if sgn(near) == s && near.abs() < vb.abs() {
                    let touch = xm.search(&mut roots, s, (a, va), (b, vb), (false, false));
                    edge_touch = touch.is_some_and(|tm| tm >= b - tiny);
                } else {
                    approaching = true;
                }
            }
            if vb != 0.0 {
                s = sgn(vb);
            }
        }
        l.approach[i] = approaching && !edge_touch;
        l.sign[i] = s;
        // Two opposite crossings with g no farther from zero than a touch between them (at
        // the samples) are one touch, also across steps: a crossing with g still that near
        // zero at the step's end waits for the next step.
        let big_between = |a: f64, b: f64| {
            (0..=SUBINTERVALS).any(|j| {
                let t = node_t(j);
                t > a && t < b && v(j).abs() > TOUCH * scale
            })
        };
        let emit = |c: Crossing<X>, found: &mut Vec<Crossing<X>>| {
            let wanted = c.touch
                || match spec.direction {
                    EventDirection::Both => true,
                    EventDirection::Rising => c.rising,
                    EventDirection::Falling => !c.rising,
                };
            if wanted {
                found.push(c);
            }
        };
        let at = |t: f64| {
            let mut x = x1.clone();
            ext.eval(t.max(t0), &mut x);
            x
        };
        let mut open = l.pending[i].take();
        for r in roots {
            if let Some(p) = open.take() {
                if !r.touch && r.rising != p.rising && !big_between(p.t, r.t) {
                    let t = 0.5 * (p.t + r.t);
                    emit(
                        Crossing {
                            event: i,
                            t,
                            x: at(t),
                            rising: p.rising,
                            touch: true,
                        },
                        l.found,
                    );
                    continue;
                }
                emit(p, l.found);
            }
            let c = Crossing {
                event: i,
                t: r.t,
                x: at(r.t),
                rising: r.rising,
                touch: r.touch,
            };
            if r.touch || r.confirmed || spec.terminal {
                emit(c, l.found);
            } else {
                open = Some(c);
            }
        }
        if let Some(p) = open {
            if big_between(p.t, f64::INFINITY) {
                emit(p, l.found);
            } else {
                l.pending[i] = Some(p);
            }
        }
    }
    l.g0.copy_from_slice(&l.nodes[SUBINTERVALS * m..]);
    l.found.sort_by(|a, b| a.t.total_cmp(&b.t));
    let first_stop = l.found.iter().position(|c| l.events[c.event].terminal)?;
    let stop = l.found.remove(first_stop);
    l.found.truncate(first_stop);
    Some(stop)
}

/// A zero of one event function in a step.
struct Root {
    t: f64,
    rising: bool,
    touch: bool,
    /// Known to be a crossing of its own (not half of a touch).
    confirmed: bool,
}

impl Root {
    fn new(t: f64, rising: bool, touch: bool, confirmed: bool) -> Root {
        Root {
            t,
            rising,
            touch,
            confirmed,
        }
    }
}

/// The search of an extremum of one event function between samples.
struct Extremum<'e> {
    gi: &'e mut dyn FnMut(usize, f64) -> f64,
    i: usize,
    /// |g| at most this is a touch.
    touch: f64,
    /// Nearer than this to an open end of the interval is outside it.
    tiny: f64,
}

impl Extremum<'_> {
    /// Where g of sign `s` at both ends of [a, c] comes nearer zero between them, its extremum:
    /// two crossings into `roots` if it passes zero, one touch if it (about) reaches it,
    /// returning the touch's time; `open` excludes touches at the interval's ends.
    fn search(
        &mut self,
        roots: &mut Vec<Root>,
        s: f64,
        (a, va): (f64, f64),
        (c, vc): (f64, f64),
        open: (bool, bool),
    ) -> Option<f64> {
        let i = self.i;
        let gi = &mut *self.gi;
        let (tm, gm) = golden_min(|t| s * gi(i, t), a, c);
        if gm < -self.touch {
            let t = brent(|t| gi(i, t), a, tm, va, s * gm, 0.0);
            roots.push(Root::new(t, s < 0.0, false, true));
            let t = brent(|t| gi(i, t), tm, c, s * gm, vc, 0.0);
            roots.push(Root::new(t, s > 0.0, false, false));
            None
        } else if gm <= self.touch
            && !(open.0 && tm <= a + self.tiny)
            && !(open.1 && tm >= c - self.tiny)
        {
            roots.push(Root::new(tm, s < 0.0, true, true));
            Some(tm)
        } else {
            None
        }
    }
}
