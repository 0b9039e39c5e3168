//! Taylor in lanes: several orbits of one model (same parameters, different initial states)
//! integrated together, as heyoka's batch mode does, each bitwise the run [`Taylor`] gives it
//! alone under the [`Driver`](crate::Driver).
//!
//! A [`TaylorBatch`] kernel computes the coefficients of B states in one call: its values are
//! vectors of B f64, one per orbit, so the recurrences' arithmetic runs once for all of them
//! (the JIT's kernel: two orbits per SSE2 `F64X2` instruction). Each orbit keeps its own time,
//! step size, step count and compensated state: [`TaylorLanes::run`] computes the batch's
//! coefficients, then takes each orbit's step by the lone driver's rules (Jorba & Zou's step,
//! the last step shortened to the end time, the compensated time and state) with the same
//! functions. An orbit that ends leaves its lane to the next initial state waiting, so the
//! lanes stay full however different the orbits' step counts are. IEEE arithmetic is the same
//! in each lane of a vector as in a scalar register, and the orbit's steps are computed by the
//! same code as alone: each orbit's end is bitwise its lone run's.
//!
//! An orbit that fails (a step below the smallest, a non-finite state, the step budget, a
//! guard, an interrupt) leaves its lane with no result: the caller runs it alone, which
//! reports the failure where and as the lone run does.

use super::{horner_update, min_step, norms, JorbaZou, TaylorError, TaylorOptions};
use crate::driver::{compensated_add, INTERRUPT_EVERY};
use crate::error::{all_finite, StepError};

/// The Taylor coefficients of B states at once (see the [module docs](self)).
pub trait TaylorBatch<M: ?Sized>: Send {
    /// The state dimension N.
    fn dim(&self) -> usize;

    /// The orbits per call, B.
    fn lanes(&self) -> usize;

    /// The order p computed.
    fn order(&self) -> usize;

    /// Takes the model's current parameters.
    fn sync(&mut self, model: &M) -> Result<(), StepError>;

    /// The coefficients of orders 0..=p of the B states `x` (N·B values, interleaved:
    /// component i of orbit l at `x[i·B + l]`).
    ///
    /// # Panics
    /// If `x.len()` is not N·B.
    fn compute(&mut self, x: &[f64]);

    /// The last computed coefficients: order k of component i of orbit l at
    /// `table()[(i(p + 1) + k)·B + l]`.
    fn table(&self) -> &[f64];
}

/// The runs of [`TaylorLanes::run`]: each from t = 0, as the lone driver's.
pub struct LaneRuns<'a> {
    /// The end time (≥ 0).
    pub t_end: f64,
    /// The first step asked for; 0 for Jorba & Zou's at the initial state (the driver's
    /// initial step).
    pub h0: f64,
    /// The step budget of each run.
    pub max_steps: u64,
    /// Whether a state passes the model's guards (checked at the start and after every step).
    pub guards: Option<&'a (dyn Fn(&[f64]) -> bool + 'a)>,
    /// Whether to stop (asked every [`INTERRUPT_EVERY`] sweeps of the batch).
    pub stop: Option<&'a (dyn Fn() -> bool + 'a)>,
}

/// The end of a run that reached its end time.
#[derive(Clone, Debug, PartialEq)]
pub struct LaneEnd {
    /// The time reached (the end time).
    pub t: f64,
    /// The final state.
    pub x: Vec<f64>,
    /// Accepted steps.
    pub steps: u64,
    /// Sweeps of the recurrences (p per step, as [`Taylor`](super::Taylor) counts them).
    pub evaluations: u64,
}

/// The adaptive Taylor integrator of a batch kernel: many orbits, B at a time.
pub struct TaylorLanes<M: ?Sized> {
    kernel: Box<dyn TaylorBatch<M>>,
    opts: TaylorOptions,
    order: u32,
    control: JorbaZou,
}

impl<M: ?Sized> std::fmt::Debug for TaylorLanes<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TaylorLanes")
            .field("opts", &self.opts)
            .field("lanes", &self.kernel.lanes())
            .finish_non_exhaustive()
    }
}

/// One orbit in a lane.
struct Lane {
    /// Its index in the initial states.
    run: usize,
    t: f64,
    /// The rounding error of `t` (the driver's compensated time).
    t_lo: f64,
    /// The next step asked for; 0 until the first expansion gives the initial step.
    h: f64,
    steps: u64,
    x: Vec<f64>,
    /// The compensated update's carried rounding error.
    low: Vec<f64>,
}

/// What a step left an orbit.
enum Flow {
    Going,
    Done,
    Failed,
}

impl<M: ?Sized> TaylorLanes<M> {
    /// The integrator over `kernel`, which must compute the order of `opts`.
    pub fn new(kernel: Box<dyn TaylorBatch<M>>, opts: TaylorOptions) -> Result<Self, TaylorError> {
        let order = opts.checked_order()?;
        if kernel.order() != order as usize {
            return Err(TaylorError::Option(format!(
                "the batch kernel computes order {}, the tolerance asks for {order}",
                kernel.order()
            )));
        }
        Ok(TaylorLanes {
            kernel,
            opts,
            order,
            control: JorbaZou::new(order),
        })
    }

    /// The orbits per kernel call.
    pub fn lanes(&self) -> usize {
        self.kernel.lanes()
    }

    /// The order p.
    pub fn order(&self) -> u32 {
        self.order
    }

    /// The kernel, to hand back to a pool.
    pub fn into_kernel(self) -> Box<dyn TaylorBatch<M>> {
        self.kernel
    }

    /// Integrates each of `x0s` as `runs` says, B at a time; the end of each run that reached
    /// the end time, `None` for one that failed (see the [module docs](self)).
    pub fn run(&mut self, model: &M, x0s: &[Vec<f64>], runs: &LaneRuns) -> Vec<Option<LaneEnd>> {
        let mut ends: Vec<Option<LaneEnd>> = vec![None; x0s.len()];
        let (n, b, s) = (
            self.kernel.dim(),
            self.kernel.lanes(),
            self.order as usize + 1,
        );
        if self.kernel.sync(model).is_err() || x0s.iter().any(|x| x.len() != n) {
            return ends;
        }
        let mut waiting = 0..x0s.len();
        let mut slots: Vec<Option<Lane>> = (0..b).map(|_| None).collect();
        let (mut packed, mut coefficients) = (vec![0.0; n * b], vec![0.0; n * s]);
        let mut sweeps = 0u64;
        loop {
            for slot in slots.iter_mut().filter(|s| s.is_none()) {
                *slot = waiting.by_ref().find_map(|run| start(run, &x0s[run], runs));
            }
            let Some(first) = slots.iter().flatten().next() else {
                break;
            };
            if sweeps % INTERRUPT_EVERY == 0 && runs.stop.is_some_and(|stop| stop()) {
                break;
            }
            sweeps += 1;
            // an empty lane computes a copy of a running orbit, whose values are finite
            for (l, slot) in slots.iter().enumerate() {
                let x = &slot.as_ref().unwrap_or(first).x;
                for (i, &xi) in x.iter().enumerate() {
                    packed[i * b + l] = xi;
                }
            }
            self.kernel.compute(&packed);
            for (l, slot) in slots.iter_mut().enumerate() {
                let Some(lane) = slot else { continue };
                let table = self.kernel.table();
                for (j, c) in coefficients.iter_mut().enumerate() {
                    *c = table[j * b + l];
                }
                match self.step(lane, &coefficients, runs) {
                    Flow::Going => continue,
                    Flow::Done => {
                        ends[lane.run] = Some(LaneEnd {
                            t: lane.t,
                            x: std::mem::take(&mut lane.x),
                            steps: lane.steps,
                            evaluations: lane.steps * u64::from(self.order),
                        })
                    }
                    Flow::Failed => {}
                }
                *slot = None;
            }
        }
        ends
    }

    /// One step of `lane` from the expansion `coefficients` (N × (p + 1), row-major) at its
    /// state: [`Taylor`](super::Taylor)'s step under the driver's rules, in their order.
    fn step(&self, lane: &mut Lane, coefficients: &[f64], runs: &LaneRuns) -> Flow {
        let (n, p) = (lane.x.len(), self.order as usize);
        let c = |i: usize| &coefficients[i * (p + 1)..(i + 1) * (p + 1)];
        let (n0, n1, n2) = norms(n, p, c);
        let h_jz = self.control.step(n0, n1, n2);
        let t_end = runs.t_end;
        if !(lane.h > 0.0) {
            // the driver's initial step, from the same expansion as the first step's
            let h = h_jz.min(self.opts.h_max);
            let h = if t_end > 0.0 { h.min(t_end) } else { h };
            if !(h > 0.0 && h.is_finite()) {
                return Flow::Failed;
            }
            lane.h = h;
        }
        if lane.t >= t_end {
            return Flow::Done;
        }
        let remaining = t_end - lane.t;
        let (h_step, last) = if lane.h * 1.01 >= remaining {
            (remaining, true)
        } else {
            (lane.h, false)
        };
        if lane.steps >= runs.max_steps || h_step.is_nan() || h_step <= 0.0 || h_jz.is_nan() {
            return Flow::Failed;
        }
        let h_own = h_jz.min(self.opts.h_max);
        if h_own < min_step(lane.t) && h_step > h_own {
            return Flow::Failed;
        }
        let h_taken = h_step.min(h_own);
        horner_update(c, h_taken, &mut lane.x, &mut lane.low);
        lane.steps += 1;
        lane.t = if last && h_taken >= h_step {
            t_end
        } else {
            let (hi, lo) = compensated_add(lane.t, lane.t_lo, h_taken);
            lane.t_lo = lo;
            hi
        };
        lane.h = if h_own.is_finite() { h_own } else { h_step };
        if !all_finite(&lane.x) || runs.guards.is_some_and(|ok| !ok(&lane.x)) {
            return Flow::Failed;
        }
        if lane.t >= t_end {
            Flow::Done
        } else {
            Flow::Going
        }
    }
}

/// Run `run` from `x0` in a lane, or `None` if it fails at once (a non-finite initial state,
/// one outside the guards, a negative end time or first step).
fn start(run: usize, x0: &[f64], runs: &LaneRuns) -> Option<Lane> {
    let fine = all_finite(x0)
        && runs.t_end >= 0.0
        && runs.h0 >= 0.0
        && runs.h0.is_finite()
        && runs.guards.is_none_or(|ok| ok(x0));
    fine.then(|| Lane {
        run,
        t: 0.0,
        t_lo: 0.0,
        h: runs.h0,
        steps: 0,
        x: x0.to_vec(),
        low: vec![0.0; x0.len()],
    })
}
