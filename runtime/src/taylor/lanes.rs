//! Taylor in lanes: several orbits of one model (same parameters, different initial states)
//! integrated together, as heyoka's batch mode does, each bitwise the run
//! [`Taylor`](super::Taylor) gives it alone under the [`Driver`](crate::Driver).
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

use super::{min_step, JorbaZou, TaylorError, TaylorOptions};
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

/// Whether a state passes a model's guards.
pub type Guards<'a> = dyn Fn(&[f64]) -> bool + 'a;

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
    pub guards: Option<&'a Guards<'a>>,
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
        let (n, b) = (self.kernel.dim(), self.kernel.lanes());
        if self.kernel.sync(model).is_err() || x0s.iter().any(|x| x.len() != n) {
            return ends;
        }
        let mut waiting = 0..x0s.len();
        let mut slots: Vec<Option<Lane>> = (0..b).map(|_| None).collect();
        // the orbits' states and carried rounding errors, interleaved as the kernel reads them
        let mut batch = Batch {
            b,
            x: vec![0.0; n * b],
            low: vec![0.0; n * b],
        };
        // this sweep's step of each lane (taken where `stepping`)
        let (mut h, mut stepping) = (vec![0.0; b], vec![false; b]);
        let mut column = vec![0.0; n];
        let mut sweeps = 0u64;
        loop {
            for (l, slot) in slots.iter_mut().enumerate() {
                if slot.is_none() {
                    *slot = waiting.by_ref().find_map(|run| start(run, &x0s[run], runs));
                    if let Some(lane) = slot {
                        batch.set(l, &x0s[lane.run]);
                    }
                }
            }
            let Some(first) = slots.iter().position(Option::is_some) else {
                break;
            };
            if sweeps % INTERRUPT_EVERY == 0 && runs.stop.is_some_and(|stop| stop()) {
                break;
            }
            sweeps += 1;
            // an empty lane computes a copy of a running orbit, whose values are finite
            for l in (0..b).filter(|&l| slots[l].is_none()) {
                batch.copy(first, l);
            }
            self.kernel.compute(&batch.x);
            let table = self.kernel.table();
            for (l, slot) in slots.iter_mut().enumerate() {
                stepping[l] = false;
                let Some(lane) = slot else { continue };
                match self.plan(lane, table, l, b, runs) {
                    Plan::Step(taken) => (h[l], stepping[l]) = (taken, true),
                    Plan::Done => {
                        batch.get(l, &mut column);
                        ends[lane.run] = Some(lane.end(&column, self.order));
                        *slot = None;
                    }
                    Plan::Failed => *slot = None,
                }
            }
            horner_lanes(table, self.order as usize + 1, &h, &stepping, &mut batch);
            for (l, slot) in slots.iter_mut().enumerate() {
                let Some(lane) = slot.as_mut().filter(|_| stepping[l]) else {
                    continue;
                };
                batch.get(l, &mut column);
                let guarded = runs.guards.is_some_and(|ok| !ok(&column));
                if !all_finite(&column) || guarded {
                    *slot = None;
                } else if lane.t >= runs.t_end {
                    ends[lane.run] = Some(lane.end(&column, self.order));
                    *slot = None;
                }
            }
        }
        ends
    }

    /// The step of `lane` from the expansion at its state (lane l of the batch table):
    /// [`Taylor`](super::Taylor)'s step under the driver's rules, in their order; the lane's
    /// time, step size and count advanced as if it were taken.
    fn plan(&self, lane: &mut Lane, table: &[f64], l: usize, b: usize, runs: &LaneRuns) -> Plan {
        let p = self.order as usize;
        let at = |i: usize, k: usize| table[(i * (p + 1) + k) * b + l];
        // Jorba & Zou's norms, as `super::norms` takes them
        let (mut n0, mut n1, mut n2) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..self.kernel.dim() {
            n0 = n0.max(at(i, 0).abs());
            n1 = n1.max(at(i, p - 1).abs());
            n2 = n2.max(at(i, p).abs());
        }
        let h_jz = self.control.step(n0, n1, n2);
        let t_end = runs.t_end;
        if !(lane.h > 0.0) {
            // the driver's initial step, from the same expansion as the first step's
            let h = h_jz.min(self.opts.h_max);
            let h = if t_end > 0.0 { h.min(t_end) } else { h };
            if !(h > 0.0 && h.is_finite()) {
                return Plan::Failed;
            }
            lane.h = h;
        }
        if lane.t >= t_end {
            return Plan::Done;
        }
        let remaining = t_end - lane.t;
        let (h_step, last) = if lane.h * 1.01 >= remaining {
            (remaining, true)
        } else {
            (lane.h, false)
        };
        if lane.steps >= runs.max_steps || h_step.is_nan() || h_step <= 0.0 || h_jz.is_nan() {
            return Plan::Failed;
        }
        let h_own = h_jz.min(self.opts.h_max);
        if h_own < min_step(lane.t) && h_step > h_own {
            return Plan::Failed;
        }
        let h_taken = h_step.min(h_own);
        lane.steps += 1;
        lane.t = if last && h_taken >= h_step {
            t_end
        } else {
            let (hi, lo) = compensated_add(lane.t, lane.t_lo, h_taken);
            lane.t_lo = lo;
            hi
        };
        lane.h = if h_own.is_finite() { h_own } else { h_step };
        Plan::Step(h_taken)
    }
}

/// What the expansion at an orbit's state decides.
enum Plan {
    /// Take a step of this size.
    Step(f64),
    /// The end time is reached.
    Done,
    /// The run fails here.
    Failed,
}

impl Lane {
    fn end(&self, x: &[f64], order: u32) -> LaneEnd {
        LaneEnd {
            t: self.t,
            x: x.to_vec(),
            steps: self.steps,
            evaluations: self.steps * u64::from(order),
        }
    }
}

/// The states and carried rounding errors of the orbits in the lanes, interleaved: component
/// i of lane l at `i·b + l`.
struct Batch {
    b: usize,
    x: Vec<f64>,
    low: Vec<f64>,
}

impl Batch {
    /// A new orbit from `x0` in lane `l`.
    fn set(&mut self, l: usize, x0: &[f64]) {
        for (i, &v) in x0.iter().enumerate() {
            self.x[i * self.b + l] = v;
            self.low[i * self.b + l] = 0.0;
        }
    }

    /// The state of lane `from` into lane `to` (an empty lane's values).
    fn copy(&mut self, from: usize, to: usize) {
        for i in 0..self.x.len() / self.b {
            self.x[i * self.b + to] = self.x[i * self.b + from];
        }
    }

    /// The state of lane `l`.
    fn get(&self, l: usize, out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.x[i * self.b + l];
        }
    }
}

/// `super::horner_update` of every lane with `stepping[l]` by its step `h[l]`, the lanes side by
/// side (the same operations in the same order in each lane, so each is bitwise the lone
/// update); the other lanes are left as they are.
fn horner_lanes(table: &[f64], s: usize, h: &[f64], stepping: &[bool], batch: &mut Batch) {
    #[inline(always)]
    fn update<const B: usize>(
        table: &[f64],
        s: usize,
        h: &[f64],
        stepping: &[bool],
        batch: &mut Batch,
    ) {
        let h: [f64; B] = std::array::from_fn(|l| h[l]);
        for (i, (x, low)) in batch
            .x
            .chunks_exact_mut(B)
            .zip(batch.low.chunks_exact_mut(B))
            .enumerate()
        {
            let row = &table[i * s * B..(i + 1) * s * B];
            let mut acc = [0.0; B];
            for k in (1..s).rev() {
                for l in 0..B {
                    acc[l] = acc[l] * h[l] + row[k * B + l];
                }
            }
            for l in 0..B {
                // two-sum of x and (increment + carried error)
                let y = acc[l] * h[l] + low[l];
                let sum = x[l] + y;
                let b = sum - x[l];
                if stepping[l] {
                    low[l] = (x[l] - (sum - b)) + (y - b);
                    x[l] = sum;
                }
            }
        }
    }
    match batch.b {
        1 => update::<1>(table, s, h, stepping, batch),
        2 => update::<2>(table, s, h, stepping, batch),
        4 => update::<4>(table, s, h, stepping, batch),
        8 => update::<8>(table, s, h, stepping, batch),
        b => unreachable!("{b} lanes: batch kernels have 1, 2, 4 or 8"),
    }
}

/// Run `run` from `x0` in a lane, or `None` if it fails at once (a non-finite initial state,
/// one outside the guards, a negative end time or first step).
fn start(run: usize, x0: &[f64], runs: &LaneRuns) -> Option<Lane> {
    let fine = all_finite(x0)
        && runs.t_end >= 0.0
        && runs.h0 >= 0.0
        && runs.h0.is_finite()
        && !runs.guards.is_some_and(|ok| !ok(x0));
    fine.then_some(Lane {
        run,
        t: 0.0,
        t_lo: 0.0,
        h: runs.h0,
        steps: 0,
    })
}
