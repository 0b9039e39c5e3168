//! Runs of discontinuous fields (`sign(g)` in a model file): the switching loop.
//!
//! The model holds each switching surface's mode s = sign(g) and slide flag σ in its state,
//! so within one mode the field is smooth ([`SwitchSpec`]). A switched run is a sequence of
//! ordinary runs ([`simulate`](crate::simulate)'s machinery, any method), each from the state
//! where the previous one stopped at one of the surfaces' `stop` events (located on the
//! method's continuous extension, so a switching time is exact to the method's accuracy),
//! with the modes decided anew there, in one of two senses ([`Switching`]):
//!
//! - **classical**: on reaching g = 0 the solution follows the case the field gives on the
//!   surface itself (s = 0) while that case is tangent to it, and otherwise goes to the side
//!   it points to;
//! - **Filippov**: where the fields of both sides point into the surface (a⁺ ≤ 0 ≤ a⁻ for the
//!   normal velocities a± = ∇g · X±) the solution slides on it with the convex combination of
//!   X⁺ and X⁻ tangent to it (σ = 1), until a± leaves that range; elsewhere it goes to the side
//!   both fields point to. The case on the surface itself, a set of measure zero, never counts.

use lasalle_runtime::{State, SwitchSpec};

use crate::{EventHit, Recording, RunError, RunModel, RunSpec};

/// Which solutions of a discontinuous field a run computes (`--filippov`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Switching {
    /// Classical solutions: on a surface, the field's own case there.
    #[default]
    Classical,
    /// Solutions in the sense of Filippov: sliding with the convex combination K\[X\] tangent to
    /// a surface that both sides' fields point into.
    Filippov,
}

impl Switching {
    /// The name used in summaries: `classical` or `filippov`.
    pub fn name(self) -> &'static str {
        match self {
            Switching::Classical => "classical",
            Switching::Filippov => "filippov",
        }
    }
}

/// The most switches one run may make: more means the solution chatters (a classical solution
/// that does not exist past that time, or a Zeno sequence of switches).
pub const MAX_SWITCHES_PER_RUN: usize = 10_000;

/// Normal velocities within this fraction of the largest of them count as tangent.
const TANGENT: f64 = 1e-9;

/// Which of a surface's four events stopped a segment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stop {
    Crossing,
    SlideEndsPlus,
    SlideEndsMinus,
    SurfaceEnds,
}

/// An ordinary run from a state, with a spec and a progress callback.
type PlainRun<'a, X> = dyn Fn(&X, &RunSpec, &dyn Fn(f64)) -> Result<Recording, RunError> + 'a;

/// A switched run of `model` from `x0` (its modes are set from x0 first).
pub(crate) fn switched_run<Mdl, X, FV, K>(
    model: &Mdl,
    x0: &X,
    spec: &RunSpec,
    progress: &dyn Fn(f64),
    plain: &PlainRun<'_, X>,
) -> Result<Recording, RunError>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let switches = model.switches();
    let mut x = x0.clone();
    for sw in switches {
        // the crossing event is g s²: with s = 1 it reads g
        x.as_mut()[sw.slide] = 0.0;
        x.as_mut()[sw.mode] = 1.0;
        let g = event_values(model, &x)[sw.event];
        if g == 0.0 {
            if decide(model, &mut x, sw, Stop::Crossing, true, spec.switching).is_err() {
                return Err(chatter(spec, 0.0, sw.surface));
            }
        } else {
            x.as_mut()[sw.mode] = g.signum();
        }
    }
    let mut t0 = 0.0;
    let mut total: Option<Recording> = None;
    for _ in 0..=MAX_SWITCHES_PER_RUN {
        let mut seg = spec.clone();
        seg.t_end = spec.t_end - t0;
        if !spec.t_eval.is_empty() {
            seg.t_eval = spec
                .t_eval
                .iter()
                .filter(|&&t| if total.is_none() { t >= t0 } else { t > t0 })
                .map(|&t| (t - t0).clamp(0.0, seg.t_end))
                .collect();
        }
        let shifted = |t: f64| progress(t0 + t);
        let mut rec = plain(&x, &seg, &shifted)?;
        shift(&mut rec, t0);
        let stop = rec.stopped_by.as_ref().and_then(|hit| {
            let i = model.events().iter().position(|e| e.name == hit.name)?;
            switches.iter().find_map(|sw| {
                let kind = match i.checked_sub(sw.event)? {
                    0 => Stop::Crossing,
                    1 => Stop::SlideEndsPlus,
                    2 => Stop::SlideEndsMinus,
                    3 => Stop::SurfaceEnds,
                    _ => return None,
                };
                Some((sw, kind))
            })
        });
        let Some((sw, kind)) = stop.filter(|_| rec.failure.is_none()) else {
            return Ok(merge(total, rec));
        };
        let hit = rec.stopped_by.take().expect("a switch stopped the segment");
        if !spec.t_eval.is_empty() {
            // the crossing was recorded as the segment's last sample: not a grid time
            rec.t.pop();
            let n = rec.state_names.len();
            rec.x.truncate(rec.x.len() - n);
            rec.errors.truncate(rec.t.len() * rec.blocks.len());
        }
        x.as_mut().copy_from_slice(&hit.x);
        t0 = hit.t;
        if decide(model, &mut x, sw, kind, hit.rising, spec.switching).is_err() {
            return Err(chatter(spec, t0, sw.surface));
        }
        rec.events.push(hit);
        total = Some(merge(total, rec));
        if t0 >= spec.t_end {
            return Ok(total.expect("just set"));
        }
    }
    let surface = switches.first().map_or("", |s| s.surface);
    Err(chatter(spec, t0, surface))
}

/// The error of a solution that chatters at time `t` on the surface `surface` = 0.
fn chatter(spec: &RunSpec, t: f64, surface: &str) -> RunError {
    RunError::Model(format!(
        "the solution chatters on the surface `{surface}` = 0 at t = {t} (the field there points back to it, or it switched more than {MAX_SWITCHES_PER_RUN} times): a {} solution does not continue{}",
        spec.switching.name(),
        match spec.switching {
            Switching::Classical => "; a Filippov solution may (`--filippov`)",
            Switching::Filippov => "",
        }
    ))
}

/// The model's event functions at `x`.
fn event_values<Mdl, X, FV, K>(model: &Mdl, x: &X) -> Vec<f64>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let mut g = vec![0.0; model.events().len()];
    model.event_values(x, 0.0, &mut g);
    g
}

/// The normal velocities at `x`: a⁺ and a⁻ of the two sides' fields, c of the surface's own.
fn normal_velocities<Mdl, X, FV, K>(model: &Mdl, x: &X, sw: &SwitchSpec) -> (f64, f64, f64)
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let mut y = x.clone();
    y.as_mut()[sw.slide] = 1.0;
    let g = event_values(model, &y);
    let (ap, am) = (g[sw.event + 1], g[sw.event + 2]);
    y.as_mut()[sw.slide] = 0.0;
    y.as_mut()[sw.mode] = 0.0;
    let c = event_values(model, &y)[sw.event + 3];
    (ap, am, c)
}

/// Sets the mode and slide flag of `sw` in `x` after `stop` (`rising`: the event function
/// crossed upwards).
fn decide<Mdl, X, FV, K>(
    model: &Mdl,
    x: &mut X,
    sw: &SwitchSpec,
    stop: Stop,
    rising: bool,
    sense: Switching,
) -> Result<(), ()>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let previous = x.as_ref()[sw.mode];
    let (mode, slide) = match stop {
        // the slide ends where its weight leaves [0, 1]: into the side that now points away
        Stop::SlideEndsPlus => (1.0, 0.0),
        Stop::SlideEndsMinus => (-1.0, 0.0),
        Stop::SurfaceEnds => {
            // c crossing zero within rounding of a case tangent to the surface is no end
            let (ap, am, c) = normal_velocities(model, x, sw);
            if c.abs() <= TANGENT * ap.abs().max(am.abs()) {
                (0.0, 0.0)
            } else {
                (if rising { 1.0 } else { -1.0 }, 0.0)
            }
        }
        Stop::Crossing => {
            let (ap, am, c) = normal_velocities(model, x, sw);
            let tiny = TANGENT * ap.abs().max(am.abs()).max(c.abs());
            match sense {
                Switching::Classical if c.abs() <= tiny => (0.0, 0.0),
                Switching::Classical => {
                    // the side the surface's case points to must not point back
                    let side = if c > 0.0 { ap } else { am };
                    if side * c < -tiny * tiny.max(1.0) {
                        return Err(());
                    }
                    (c.signum(), 0.0)
                }
                Switching::Filippov => {
                    let (pos, neg) = (|a: f64| a > tiny, |a: f64| a < -tiny);
                    if !pos(ap) && !neg(am) && (neg(ap) || pos(am)) {
                        (0.0, 1.0) // both sides point into the surface: slide
                    } else if pos(ap) && !neg(am) {
                        (1.0, 0.0)
                    } else if neg(am) && !pos(ap) {
                        (-1.0, 0.0)
                    } else if pos(ap) {
                        // both point away: stay on the side the solution came from
                        (if previous < 0.0 { -1.0 } else { 1.0 }, 0.0)
                    } else {
                        // both tangent: keep the side
                        (if previous == 0.0 { 1.0 } else { previous }, 0.0)
                    }
                }
            }
        }
    };
    x.as_mut()[sw.mode] = mode;
    x.as_mut()[sw.slide] = slide;
    Ok(())
}

/// Shifts a segment's times by its start `t0`.
fn shift(rec: &mut Recording, t0: f64) {
    if t0 == 0.0 {
        return;
    }
    rec.t.iter_mut().for_each(|t| *t += t0);
    let hits = rec.events.iter_mut().chain(rec.stopped_by.as_mut());
    hits.for_each(|h: &mut EventHit| h.t += t0);
}

/// `next` appended to the recording so far.
pub(crate) fn merge(total: Option<Recording>, next: Recording) -> Recording {
    let Some(mut total) = total else {
        return next;
    };
    total.t.extend(next.t);
    total.x.extend(next.x);
    total.errors.extend(next.errors);
    total.wall_seconds += next.wall_seconds;
    total.cpu_seconds = total.cpu_seconds.zip(next.cpu_seconds).map(|(a, b)| a + b);
    total.steps += next.steps;
    total.evaluations += next.evaluations;
    total.rejections += next.rejections;
    for (name, v) in next.counters {
        match total.counters.iter_mut().find(|(n, _)| *n == name) {
            Some((_, w)) => *w += v,
            None => total.counters.push((name, v)),
        }
    }
    total.gains_final = next.gains_final;
    total.failure = next.failure;
    total.events.extend(next.events);
    total.stopped_by = next.stopped_by;
    total
}
