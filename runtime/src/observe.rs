//! Observers: what happens to the state after each accepted step.
//!
//! The driver ([`crate::Driver`]) calls [`Observer::observe`] at the initial point (step 0) and
//! after every accepted step, and [`Observer::finish`] once at the end. An observer may stop
//! the integration by returning [`Control::Stop`]. Adapters thin out the samples ([`Stride`])
//! or add a stop condition ([`StopWhen`]); [`Recorder`] stores states and invariant errors in
//! preallocated vectors.

use std::marker::PhantomData;
use std::ops::Range;

use num_traits::Float;

use crate::field::{Invariants, ModelInfo};
use crate::state::State;

/// Whether the integration should go on after an observation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Control {
    /// Keep integrating.
    Continue,
    /// Stop now; the driver returns successfully with `stopped_by_observer = true`.
    Stop,
}

/// Called with `(step, t, x)` at the initial point (step 0) and after each accepted step
/// (`step` = number of accepted steps so far). With dense output
/// ([`crate::Driver::run_dense`]) `step` is the index of the output time instead.
pub trait Observer<T, X: ?Sized> {
    /// Observes the state `x` at time `t`; return [`Control::Stop`] to end the integration.
    fn observe(&mut self, step: u64, t: T, x: &X) -> Control;

    /// Called once when the integration ends without error (end time reached or stopped by an
    /// observer), with the final step count, time and state. The default does nothing.
    fn finish(&mut self, _step: u64, _t: T, _x: &X) {}

    /// The first step after `step` that this observer must see: the driver may take the steps
    /// in between without calling [`observe`](Self::observe) (a
    /// [`CompiledStep`](crate::CompiledStep) takes them in one call). The default, `step + 1`,
    /// sees every step; a sampling observer ([`Stride`], [`Recorder`]) names its next sample.
    fn next_wanted(&self, step: u64) -> u64 {
        step + 1
    }
}

/// The observer that observes nothing.
impl<T, X: ?Sized> Observer<T, X> for () {
    fn observe(&mut self, _step: u64, _t: T, _x: &X) -> Control {
        Control::Continue
    }

    fn next_wanted(&self, _step: u64) -> u64 {
        u64::MAX
    }
}

/// Any closure `FnMut(step, t, &x) -> Control` is an observer.
impl<T, X: ?Sized, C: FnMut(u64, T, &X) -> Control> Observer<T, X> for C {
    fn observe(&mut self, step: u64, t: T, x: &X) -> Control {
        self(step, t, x)
    }
}

/// Both observers see every observation; the integration stops if either asks to.
impl<T: Copy, X: ?Sized, A: Observer<T, X>, B: Observer<T, X>> Observer<T, X> for (A, B) {
    fn observe(&mut self, step: u64, t: T, x: &X) -> Control {
        let a = self.0.observe(step, t, x);
        let b = self.1.observe(step, t, x);
        if a == Control::Stop || b == Control::Stop {
            Control::Stop
        } else {
            Control::Continue
        }
    }

    fn finish(&mut self, step: u64, t: T, x: &X) {
        self.0.finish(step, t, x);
        self.1.finish(step, t, x);
    }

    fn next_wanted(&self, step: u64) -> u64 {
        self.0.next_wanted(step).min(self.1.next_wanted(step))
    }
}

/// The sampling rule every sampling observer shares: steps 0, n, 2n, … (with n = 1, every
/// observation, whatever its number) and, at the end, the final step if it was not sampled
/// already. It keeps the next sampled step instead of
/// dividing, so the hot loop of a run has no integer division, and names it to the driver
/// ([`Observer::next_wanted`]), which need not show it the steps in between.
///
/// A widening rule ([`Stride::widening`]) doubles n after every `widen_after` samples, so
/// that a run of unknown length keeps about `widen_after`·log₂(steps/`widen_after`) of them.
#[derive(Clone, Copy, Debug)]
struct Every {
    n: u64,
    next: u64,
    last: Option<u64>,
    /// Samples at the current n before it doubles (0: never).
    widen_after: u64,
    /// Samples taken at the current n.
    taken: u64,
}

impl Every {
    /// Every `n`-th step (0 is treated as 1).
    fn new(n: u64) -> Self {
        Every {
            n: n.max(1),
            next: 0,
            last: None,
            widen_after: 0,
            taken: 0,
        }
    }

    /// Is this step sampled? (Call once per observation.)
    #[inline]
    fn due(&mut self, step: u64) -> bool {
        if self.n > 1 && step < self.next {
            return false;
        }
        if self.widen_after > 0 {
            self.taken += 1;
            if self.taken == self.widen_after {
                self.taken = 0;
                self.n = self.n.saturating_mul(2);
            }
        }
        self.next = step.saturating_add(self.n);
        self.last = Some(step);
        true
    }

    /// The next sampled step after `step`.
    fn next(&self, step: u64) -> u64 {
        self.next.max(step + 1)
    }

    /// Is the final step still to be sampled? (Call once, from `finish`.)
    fn final_due(&mut self, step: u64) -> bool {
        let due = self.last != Some(step);
        self.last = Some(step);
        due
    }
}

/// Forwards every `every`-th observation (steps 0, n, 2n, … of a run) and, at the end, the final state
/// if it was not forwarded already.
#[derive(Clone, Debug)]
pub struct Stride<O> {
    /// The wrapped observer.
    pub inner: O,
    every: Every,
}

impl<O> Stride<O> {
    /// Forwards steps 0, `every`, 2·`every`, … to `inner` (`every` = 0 is treated as 1).
    pub fn new(inner: O, every: u64) -> Self {
        Stride {
            inner,
            every: Every::new(every),
        }
    }

    /// Forwards every `every`-th step for `samples` observations, then every 2·`every`-th
    /// for as many, every 4·`every`-th, …: a run of unknown length (an adaptive one) is
    /// sampled densely at its start and keeps about `samples`·log₂(steps/`samples`)
    /// observations however long it runs (`samples` = 0: never widens, as
    /// [`Stride::new`]).
    pub fn widening(inner: O, every: u64, samples: u64) -> Self {
        let mut every = Every::new(every);
        every.widen_after = samples;
        Stride { inner, every }
    }
}

impl<T: Copy, X: ?Sized, O: Observer<T, X>> Observer<T, X> for Stride<O> {
    fn observe(&mut self, step: u64, t: T, x: &X) -> Control {
        if self.every.due(step) {
            self.inner.observe(step, t, x)
        } else {
            Control::Continue
        }
    }

    fn finish(&mut self, step: u64, t: T, x: &X) {
        if self.every.final_due(step) {
            // the integration is over: a stop request is moot
            let _ = self.inner.observe(step, t, x);
        }
        self.inner.finish(step, t, x);
    }

    fn next_wanted(&self, step: u64) -> u64 {
        self.every.next(step)
    }
}

/// Stops the integration when `stop(t, x)` becomes true (after passing that observation on).
#[derive(Clone, Debug)]
pub struct StopWhen<O, P> {
    /// The wrapped observer.
    pub inner: O,
    stop: P,
}

impl<O, P> StopWhen<O, P> {
    /// Wraps `inner`, stopping when `stop(t, x)` returns true.
    pub fn new(inner: O, stop: P) -> Self {
        StopWhen { inner, stop }
    }
}

impl<T: Copy, X: ?Sized, O: Observer<T, X>, P: FnMut(T, &X) -> bool> Observer<T, X>
    for StopWhen<O, P>
{
    fn observe(&mut self, step: u64, t: T, x: &X) -> Control {
        let c = self.inner.observe(step, t, x);
        if c == Control::Stop || (self.stop)(t, x) {
            Control::Stop
        } else {
            Control::Continue
        }
    }

    fn finish(&mut self, step: u64, t: T, x: &X) {
        self.inner.finish(step, t, x);
    }
}

/// Records `(t, x)` every `every` steps (and the final state) into preallocated vectors.
#[derive(Clone, Debug)]
pub struct StateRecorder<T, X> {
    /// Sample times.
    pub t: Vec<T>,
    /// Sampled states.
    pub x: Vec<X>,
    every: Every,
}

impl<T: Copy, X: Clone> StateRecorder<T, X> {
    /// Records every `every`-th step (0 is treated as 1), with room for `capacity` samples.
    pub fn new(every: u64, capacity: usize) -> Self {
        StateRecorder {
            t: Vec::with_capacity(capacity),
            x: Vec::with_capacity(capacity),
            every: Every::new(every),
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True if nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    fn push(&mut self, t: T, x: &X) {
        self.t.push(t);
        self.x.push(x.clone());
    }
}

impl<T: Copy, X: Clone> Observer<T, X> for StateRecorder<T, X> {
    fn observe(&mut self, step: u64, t: T, x: &X) -> Control {
        if self.every.due(step) {
            self.push(t, x);
        }
        Control::Continue
    }

    fn finish(&mut self, step: u64, t: T, x: &X) {
        if self.every.final_due(step) {
            self.push(t, x);
        }
    }

    fn next_wanted(&self, step: u64) -> u64 {
        self.every.next(step)
    }
}

/// Number of samples a run of `steps` steps recorded every `every` steps produces (including
/// the initial and the final sample) — the capacity to reserve.
pub fn sample_capacity(steps: u64, every: u64) -> usize {
    (steps / every.max(1) + 2) as usize
}

/// Records `t`, the state and each declared invariant's error ‖fᵢ(x) − fᵢ(x₀)‖ (Euclidean
/// norm of the block; Frobenius for matrices) every `every` steps and at the end.
///
/// Storage is reserved up front; during the run a sample costs one evaluation of f and a push
/// into vectors with enough capacity (no reallocation if the capacity was right).
#[derive(Clone, Debug)]
pub struct Recorder<'m, Mdl: ?Sized, T, X, F> {
    model: &'m Mdl,
    target: F,
    /// Scratch for f(x) at a sample.
    f: F,
    blocks: Vec<(&'static str, Range<usize>)>,
    every: Every,
    /// Components per state.
    dim: usize,
    /// Sample times.
    pub t: Vec<T>,
    /// Sampled states, [`Recorder::dim`] components per sample, sample-major (one buffer, so
    /// that a sample costs no allocation; [`Recorder::state`] is sample i).
    pub x: Vec<T>,
    /// Invariant errors, `blocks().len()` per sample, sample-major.
    pub errors: Vec<T>,
    state: PhantomData<fn(&X)>,
}

impl<'m, Mdl, T, X, F> Recorder<'m, Mdl, T, X, F>
where
    Mdl: Invariants<T, X, F> + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
{
    /// A recorder of the invariants declared by the model ([`ModelInfo::invariant_infos`])
    /// relative to f(x₀), sampling every `every` steps, with room for `capacity` samples (see
    /// [`sample_capacity`]).
    pub fn new(model: &'m Mdl, x0: &X, every: u64, capacity: usize) -> Self
    where
        Mdl: ModelInfo,
    {
        let blocks = model
            .invariant_infos()
            .iter()
            .map(|i| (i.slot.name, i.slot.range()))
            .collect();
        Self::with_blocks(model, x0, blocks, every, capacity)
    }

    /// A recorder with explicitly given blocks `(name, index range in f)`.
    pub fn with_blocks(
        model: &'m Mdl,
        x0: &X,
        blocks: Vec<(&'static str, Range<usize>)>,
        every: u64,
        capacity: usize,
    ) -> Self {
        let mut target = F::filled(F::len_for(model.invariant_dim()), T::zero());
        model.invariants(x0, &mut target);
        let (nb, dim) = (blocks.len(), x0.as_ref().len());
        Recorder {
            model,
            f: target.clone(),
            target,
            blocks,
            every: Every::new(every),
            dim,
            t: Vec::with_capacity(capacity),
            x: Vec::with_capacity(capacity * dim),
            errors: Vec::with_capacity(capacity * nb),
            state: PhantomData,
        }
    }

    /// The recorded blocks (name, range in the stacked f).
    pub fn blocks(&self) -> &[(&'static str, Range<usize>)] {
        &self.blocks
    }

    /// The target f(x₀).
    pub fn target(&self) -> &F {
        &self.target
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True if nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Components per recorded state.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The state of sample `i`.
    pub fn state(&self, i: usize) -> &[T] {
        &self.x[i * self.dim..(i + 1) * self.dim]
    }

    /// The invariant errors of sample `i`, one per block.
    pub fn errors_at(&self, i: usize) -> &[T] {
        let nb = self.blocks.len();
        &self.errors[i * nb..(i + 1) * nb]
    }

    /// The error series of block `b` over all samples.
    pub fn error_series(&self, b: usize) -> impl Iterator<Item = T> + '_ {
        let nb = self.blocks.len();
        self.errors.iter().skip(b).step_by(nb.max(1)).copied()
    }

    /// The largest recorded error of block `b` (NaN-propagating).
    pub fn max_error(&self, b: usize) -> T {
        self.error_series(b).fold(T::zero(), |m, e| {
            if e.is_nan() || m.is_nan() {
                T::nan()
            } else {
                m.max(e)
            }
        })
    }

    /// The index of the block called `name`.
    pub fn block_index(&self, name: &str) -> Option<usize> {
        self.blocks.iter().position(|(n, _)| *n == name)
    }

    /// Forgets the last sample (a run that stops at a state it does not report).
    pub fn pop(&mut self) {
        if self.t.pop().is_some() {
            self.x.truncate(self.t.len() * self.dim);
            self.errors.truncate(self.t.len() * self.blocks.len());
        }
    }

    fn push(&mut self, t: T, x: &X) {
        self.model.invariants(x, &mut self.f);
        self.t.push(t);
        self.x.extend_from_slice(x.as_ref());
        for (_, range) in &self.blocks {
            let mut s = T::zero();
            for i in range.clone() {
                let d = self.f[i] - self.target[i];
                s = s + d * d;
            }
            self.errors.push(s.sqrt());
        }
    }
}

impl<Mdl, T, X, F> Observer<T, X> for Recorder<'_, Mdl, T, X, F>
where
    Mdl: Invariants<T, X, F> + ?Sized,
    T: Float,
    X: State<T>,
    F: State<T>,
{
    fn observe(&mut self, step: u64, t: T, x: &X) -> Control {
        if self.every.due(step) {
            self.push(t, x);
        }
        Control::Continue
    }

    fn finish(&mut self, step: u64, t: T, x: &X) {
        if self.every.final_due(step) {
            self.push(t, x);
        }
    }

    fn next_wanted(&self, step: u64) -> u64 {
        self.every.next(step)
    }
}
