//! The integration driver: runs a [`Stepper`] from t₀ to t_end, observing, checking for
//! blow-up and running the caller's guard.
//!
//! The driver never stops silently: it either reaches the end time (or an observer's stop
//! request) and returns a [`Summary`], or returns a [`StepError`] carrying the time, the step
//! size and the state (non-finite state, guard failure, step budget, or the stepper's own
//! error).

use num_traits::Float;

use crate::error::{all_finite, state_to_vec, to_f64, StepError};
use crate::field::lit;
use crate::observe::{Control, Observer};
use crate::state::State;
use crate::steppers::{DenseOutput, Stepper};

/// A validity check run on the state after every k-th step: `None` if the state is fine,
/// `Some(message)` otherwise (e.g. `|x| < 1e-8` for Kepler: "collision").
pub type GuardFn<'g, X> = dyn Fn(&X) -> Option<String> + 'g;

/// How an integration ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary<T, X> {
    /// The final time (t_end unless an observer stopped the run).
    pub t: T,
    /// The final state.
    pub x: X,
    /// Accepted steps.
    pub steps: u64,
    /// Rejected trial steps (adaptive steppers).
    pub rejections: u64,
    /// Field evaluations reported by the stepper (excluding the 2 evaluations of an adaptive
    /// stepper's initial step selection).
    pub evaluations: u64,
    /// True if an observer returned [`Control::Stop`].
    pub stopped_by_observer: bool,
}

/// Settings of an integration run: time span, step size, step budget and guard.
///
/// ```
/// use lasalle_runtime::{Field, Driver, ExplicitRk, StepError};
/// struct Blow;
/// impl Field<f64, [f64; 1]> for Blow {
///     fn field(&self, x: &[f64; 1], dx: &mut [f64; 1]) { dx[0] = x[0] * x[0]; }
/// }
/// let err = Driver::new(0.0, 2.0, 0.01)
///     .guard(1, |x: &[f64; 1]| (x[0] > 1e6).then(|| format!("|x| = {} > 1e6", x[0])))
///     .run(&mut ExplicitRk::euler(), &Blow, &[1.0], &mut ())
///     .unwrap_err();
/// assert!(matches!(err, StepError::Guard { .. }));
/// assert!(err.time().unwrap() > 0.9);
/// ```
pub struct Driver<'g, T, X> {
    t0: T,
    t_end: T,
    h: T,
    max_steps: u64,
    guard: Option<(u64, Box<GuardFn<'g, X>>)>,
    divergence: Option<(u64, Box<GuardFn<'g, X>>)>,
    interrupt: Option<Box<dyn Fn() -> bool + 'g>>,
}

/// Every how many steps the driver asks whether to stop ([`Driver::interrupt`]).
pub const INTERRUPT_EVERY: u64 = 256;

impl<'g, T: Float, X: State<T>> Driver<'g, T, X> {
    /// Integrates from `t0` to `t_end ≥ t0` with step `h` (fixed-step methods; for adaptive
    /// ones `h` is the initial step, and `h = 0` asks the stepper to choose it).
    pub fn new(t0: T, t_end: T, h: T) -> Self {
        Driver {
            t0,
            t_end,
            h,
            max_steps: u64::MAX,
            guard: None,
            divergence: None,
            interrupt: None,
        }
    }

    /// Fails with [`StepError::MaxSteps`] once `n` steps, accepted and rejected together, are
    /// spent short of the end time (default: unlimited). The budget is checked before each
    /// step, so an adaptive step's own trials (at most its `max_rejections`, 50 for
    /// [`crate::DormandPrince`]) may pass it by that many.
    pub fn max_steps(mut self, n: u64) -> Self {
        self.max_steps = n;
        self
    }

    /// Runs `check` on the initial state and after every `every`-th step (0 is treated as 1);
    /// a `Some(message)` stops the run with [`StepError::Guard`].
    pub fn guard(mut self, every: u64, check: impl Fn(&X) -> Option<String> + 'g) -> Self {
        self.guard = Some((every.max(1), Box::new(check)));
        self
    }

    /// Runs `check` after every `every`-th step and on the final state (0 is treated as 1); a
    /// `Some(message)` stops the run with [`StepError::Diverged`]. Meant for checks that cost
    /// about a field evaluation, such as a [`crate::DriftBound`] on the invariants, run where
    /// the run records its samples.
    pub fn divergence(mut self, every: u64, check: impl Fn(&X) -> Option<String> + 'g) -> Self {
        self.divergence = Some((every.max(1), Box::new(check)));
        self
    }

    /// Calls `stop` at the start and every [`INTERRUPT_EVERY`] steps and ends the run with
    /// [`StepError::Interrupted`] once it returns true: a caller cancels a run this way (a
    /// Ctrl-C, a scheduler), e.g. with `stop` reading an `AtomicBool` another thread sets.
    pub fn interrupt(mut self, stop: impl Fn() -> bool + 'g) -> Self {
        self.interrupt = Some(Box::new(stop));
        self
    }

    /// The interrupt flag, and the guard and the divergence check on the state after step
    /// `step`, each if it is due ([`Period`]; the divergence check also at the end, `last`).
    #[allow(clippy::too_many_arguments)]
    fn run_checks(
        &self,
        guard_due: bool,
        divergence_due: bool,
        step: u64,
        last: bool,
        t: T,
        h: T,
        x: &X,
    ) -> Result<(), StepError> {
        if let Some(stop) = &self.interrupt {
            if step % INTERRUPT_EVERY == 0 && stop() {
                return Err(StepError::Interrupted {
                    t: to_f64(t),
                    step,
                    state: state_to_vec(x.as_ref()),
                });
            }
        }
        if let (true, Some((_, check))) = (guard_due, &self.guard) {
            if let Some(message) = check(x) {
                return Err(StepError::Guard {
                    t: to_f64(t),
                    step,
                    h: to_f64(h),
                    message,
                    state: state_to_vec(x.as_ref()),
                });
            }
        }
        if let (true, Some((_, check))) = (divergence_due || last, &self.divergence) {
            if step > 0 {
                if let Some(message) = check(x) {
                    return Err(StepError::Diverged {
                        t: to_f64(t),
                        step,
                        message,
                        state: state_to_vec(x.as_ref()),
                    });
                }
            }
        }
        Ok(())
    }

    /// The shared stepping loop; `on_step(stepper, steps, t, x)` is called at the start
    /// (steps = 0) and after every accepted step it asks for: it returns whether to go on
    /// and the next step it must see ([`Observer::next_wanted`]). Fixed steps that nothing
    /// watches (no observation, no check due, not the last) go to the stepper in batches
    /// ([`Stepper::fixed_steps`]) where it takes them.
    fn drive<F, S, C>(
        &self,
        stepper: &mut S,
        field: &F,
        x0: &X,
        t_end: T,
        mut on_step: C,
    ) -> Result<Summary<T, X>, StepError>
    where
        F: ?Sized,
        S: Stepper<T, X, F>,
        C: FnMut(&S, u64, T, &X) -> (Control, u64),
    {
        let t0 = self.t0;
        if !(t0.is_finite() && t_end.is_finite() && t_end >= t0) {
            return Err(StepError::InvalidInput(format!(
                "need finite t0 <= t_end, got t0 = {}, t_end = {}",
                to_f64(t0),
                to_f64(t_end)
            )));
        }
        let adaptive = stepper.is_adaptive();
        let mut h = self.h;
        if adaptive && !(h > T::zero()) {
            h = stepper.initial_step(field, t0, x0, t_end).ok_or_else(|| {
                StepError::InvalidInput(
                    "no starting step: the field at the initial state is not finite or too \
                     large for any step; give a first step h > 0 (--dt)"
                        .to_string(),
                )
            })?;
        }
        if !(h > T::zero() && h.is_finite()) {
            return Err(StepError::InvalidInput(format!(
                "step size must be positive and finite, got h = {}",
                to_f64(h)
            )));
        }
        let mut x = x0.clone();
        let mut summary = Summary {
            t: t0,
            x: x0.clone(),
            steps: 0,
            rejections: 0,
            evaluations: 0,
            stopped_by_observer: false,
        };
        if !all_finite(x.as_ref()) {
            return Err(StepError::non_finite("state", t0, h, x.as_ref()));
        }
        // the checks' periods, counted down (a division per step costs more than an Euler step)
        let mut guard = Period::new(self.guard.as_ref().map(|g| g.0));
        let mut divergence = Period::new(self.divergence.as_ref().map(|d| d.0));
        self.run_checks(true, false, 0, false, t0, h, &x)?;
        let (control, mut wanted) = on_step(stepper, 0, t0, &x);
        if control == Control::Stop {
            summary.stopped_by_observer = true;
            return Ok(summary);
        }
        // whether the stepper takes batches of fixed steps (asked at the first chance)
        let mut batches = !adaptive;
        // fixed steps: t_n = t0 + n h exactly, the last step shortened to hit t_end
        let (n_full, partial) = {
            let ratio = (t_end - t0) / h;
            let r = ratio.round();
            if (ratio - r).abs() <= lit::<T>(1e-9) * ratio.max(T::one()) {
                (r, false)
            } else {
                (ratio.floor(), true)
            }
        };
        let n_total = n_full + if partial { T::one() } else { T::zero() };
        let mut t = t0;
        // adaptive steps: t is the sum of the steps taken, kept as the unevaluated pair
        // t + t_lo (error-free transformations), so that rounding does not accumulate in the
        // time: t is the exact sum rounded, within half an ulp however many steps it holds
        let mut t_lo = T::zero();
        let mut n = T::zero();
        while t < t_end {
            // whether a batch took the watched step as its last
            let mut took_watched = false;
            if batches {
                // the next step anything watches: the observer's, a check's, the interrupt's
                let next_interrupt = match self.interrupt {
                    Some(_) => (summary.steps / INTERRUPT_EVERY + 1) * INTERRUPT_EVERY,
                    None => u64::MAX,
                };
                let watched = wanted
                    .min(summary.steps.saturating_add(guard.left))
                    .min(summary.steps.saturating_add(divergence.left))
                    .min(next_interrupt);
                let before_last = to_f64(n_total - n - T::one()).max(0.0) as u64;
                // the steps up to it, short of the budget's end and of the last, shortened
                // step (an observer that names a step already taken gets every step; one
                // that wants the very next may read the stepper's continuous extension of
                // it, which a batch does not leave, so k > 1)
                let k = watched
                    .saturating_sub(summary.steps)
                    .min(before_last)
                    .min(self.max_steps.saturating_sub(summary.steps));
                if k > 1 {
                    match stepper.fixed_steps(field, &mut x, h, k) {
                        Some(batch) => {
                            summary.steps += batch.steps;
                            summary.evaluations += batch.evaluations;
                            n = n + lit::<T>(batch.steps as f64);
                            t = t0 + n * h;
                            // the watched step, finite and within the guards, is left
                            // only its checks and its observer, as after a step
                            took_watched = batch.steps == k && summary.steps == watched;
                            let before = batch.steps - u64::from(took_watched);
                            guard.skip(before);
                            divergence.skip(before);
                        }
                        None => batches = false,
                    }
                }
            }
            let h_taken = if took_watched {
                h
            } else {
                let (h_step, last) = if adaptive {
                    let remaining = t_end - t;
                    if h * lit(1.01) >= remaining {
                        (remaining, true)
                    } else {
                        (h, false)
                    }
                } else if n + T::one() >= n_total {
                    (t_end - t, true)
                } else {
                    (h, false)
                };
                // rejected trial steps spend the budget as accepted ones do: a run whose
                // steps are all rejected ends too
                if summary.steps.saturating_add(summary.rejections) >= self.max_steps {
                    return Err(StepError::MaxSteps {
                        t: to_f64(t),
                        h: to_f64(h_step),
                        steps: self.max_steps,
                        rejected: summary.rejections,
                        state: state_to_vec(x.as_ref()),
                    });
                }
                let outcome = stepper.step(field, t, &mut x, h_step).map_err(|e| {
                    // a fixed step's new time, as computed below
                    let t_new = if last { t_end } else { t0 + (n + T::one()) * h };
                    e.at_step(summary.steps + 1)
                        .guard_at(summary.steps + 1, to_f64(t_new))
                })?;
                summary.steps += 1;
                summary.rejections += u64::from(outcome.rejections);
                summary.evaluations += u64::from(outcome.evaluations);
                n = n + T::one();
                t = if last && outcome.h_taken >= h_step {
                    t_end
                } else if adaptive {
                    let (hi, lo) = compensated_add(t, t_lo, outcome.h_taken);
                    t_lo = lo;
                    hi
                } else {
                    t0 + n * h
                };
                if !all_finite(x.as_ref()) {
                    return Err(
                        StepError::non_finite("state", t, outcome.h_taken, x.as_ref())
                            .at_step(summary.steps),
                    );
                }
                if adaptive {
                    h = outcome.h_next;
                }
                outcome.h_taken
            };
            let done = t >= t_end;
            let (guard_due, divergence_due) = (guard.tick(), divergence.tick());
            self.run_checks(
                guard_due,
                divergence_due,
                summary.steps,
                done,
                t,
                h_taken,
                &x,
            )?;
            let control;
            (control, wanted) = on_step(stepper, summary.steps, t, &x);
            if control == Control::Stop {
                summary.stopped_by_observer = true;
                break;
            }
        }
        summary.t = t;
        summary.x = x;
        Ok(summary)
    }

    /// Integrates `field` from `x0` with `stepper`, calling `observer` at the start, after
    /// every accepted step and (via [`Observer::finish`]) at the end.
    pub fn run<F, S, O>(
        &self,
        stepper: &mut S,
        field: &F,
        x0: &X,
        observer: &mut O,
    ) -> Result<Summary<T, X>, StepError>
    where
        F: ?Sized,
        S: Stepper<T, X, F>,
        O: Observer<T, X> + ?Sized,
    {
        let summary = self.drive(stepper, field, x0, self.t_end, |_, step, t, x| {
            (observer.observe(step, t, x), observer.next_wanted(step))
        })?;
        observer.finish(summary.steps, summary.t, &summary.x);
        Ok(summary)
    }

    /// Integrates `field` from `x0` with `stepper`, calling `on_step(stepper, step, t, x)` at
    /// the start (step 0) and after every accepted step, with the stepper, so that the caller
    /// can read its continuous extension ([`Stepper::dense_output`]) — what events and output
    /// times need ([`crate::events::Watch`]). Returning [`Control::Stop`] ends the run.
    pub fn run_stepwise<F, S, C>(
        &self,
        stepper: &mut S,
        field: &F,
        x0: &X,
        on_step: C,
    ) -> Result<Summary<T, X>, StepError>
    where
        F: ?Sized,
        S: Stepper<T, X, F>,
        C: FnMut(&S, u64, T, &X) -> Control,
    {
        let mut on_step = on_step;
        self.drive(stepper, field, x0, self.t_end, |s, step, t, x| {
            (on_step(s, step, t, x), step + 1)
        })
    }

    /// Integrates with a dense-output stepper up to the last of `times` (sorted, within
    /// [t₀, t_end]) and calls `observer(i, times[i], x(times[i]))` with the interpolated state
    /// at each output time, independent of the steps taken (HNW I §II.6).
    /// [`Observer::finish`] receives the number of outputs and the last one.
    pub fn run_dense<F, S, O>(
        &self,
        stepper: &mut S,
        field: &F,
        x0: &X,
        times: &[T],
        observer: &mut O,
    ) -> Result<Summary<T, X>, StepError>
    where
        F: ?Sized,
        S: Stepper<T, X, F> + DenseOutput<T, X>,
        O: Observer<T, X> + ?Sized,
    {
        let Some(&t_last) = times.last() else {
            return Err(StepError::InvalidInput("no output times".to_string()));
        };
        let sorted = times.windows(2).all(|w| w[0] <= w[1]);
        if !sorted || times[0] < self.t0 || t_last > self.t_end {
            return Err(StepError::InvalidInput(
                "output times must be sorted and within [t0, t_end]".to_string(),
            ));
        }
        let mut next = 0usize;
        let mut out = x0.clone();
        let mut last_out = x0.clone();
        let mut stopped = false;
        let mut summary = self.drive(stepper, field, x0, t_last, |s, step, t, x| {
            while next < times.len() && times[next] <= t {
                let ti = times[next];
                let exact = step == 0 || ti == t;
                if exact || !s.interpolate(ti, &mut out) {
                    out.clone_from(x);
                }
                last_out.clone_from(&out);
                let c = observer.observe(next as u64, ti, &out);
                next += 1;
                if c == Control::Stop {
                    stopped = true;
                    return (Control::Stop, step + 1);
                }
            }
            (Control::Continue, step + 1)
        })?;
        summary.stopped_by_observer = stopped;
        let t_done = if next > 0 { times[next - 1] } else { self.t0 };
        observer.finish(next as u64, t_done, &last_out);
        Ok(summary)
    }
}

/// A check's period in steps: [`Period::tick`] is true at every `every`-th step (steps are
/// counted from 1; never without a check).
struct Period {
    every: u64,
    left: u64,
}

impl Period {
    fn new(every: Option<u64>) -> Period {
        let every = every.unwrap_or(u64::MAX);
        Period { every, left: every }
    }

    /// Counts `k` steps before the one the check is due after (`k < left`).
    fn skip(&mut self, k: u64) {
        debug_assert!(k < self.left);
        self.left -= k;
    }

    /// Counts one step: is the check due after it?
    fn tick(&mut self) -> bool {
        self.left -= 1;
        if self.left == 0 {
            self.left = self.every;
            true
        } else {
            false
        }
    }
}

/// Integrates `field` from `(t0, x0)` to `t_end` with `stepper` and step `h` (the initial step
/// for adaptive steppers; `h = 0` chooses it automatically), calling `observer` after each
/// accepted step. Shortcut for `Driver::new(t0, t_end, h).run(stepper, field, x0, observer)`.
///
/// ```
/// use lasalle_runtime::{integrate, ExplicitRk, Field};
/// struct Osc;
/// impl Field<f64, [f64; 2]> for Osc {
///     fn field(&self, x: &[f64; 2], dx: &mut [f64; 2]) { dx[0] = x[1]; dx[1] = -x[0]; }
/// }
/// let end = integrate(&mut ExplicitRk::rk4(), &Osc, &[1.0, 0.0], 0.0, 1.0, 0.01, &mut ()).unwrap();
/// assert_eq!(end.steps, 100);
/// assert!((end.x[0] - 1f64.cos()).abs() < 1e-9);
/// ```
pub fn integrate<T, X, F, S, O>(
    stepper: &mut S,
    field: &F,
    x0: &X,
    t0: T,
    t_end: T,
    h: T,
    observer: &mut O,
) -> Result<Summary<T, X>, StepError>
where
    T: Float,
    X: State<T>,
    F: ?Sized,
    S: Stepper<T, X, F>,
    O: Observer<T, X> + ?Sized,
{
    Driver::new(t0, t_end, h).run(stepper, field, x0, observer)
}

/// (t + t_lo) + h as a normalised pair (hi, lo), hi = the sum rounded to nearest up to the
/// pair's own rounding (Knuth's two-sum, then Dekker's fast two-sum).
pub(crate) fn compensated_add<T: Float>(t: T, t_lo: T, h: T) -> (T, T) {
    let s = t + h;
    let b = s - t;
    let err = (t - (s - b)) + (h - b);
    let e = err + t_lo;
    let hi = s + e;
    (hi, e - (hi - s))
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use super::*;
    use crate::steppers::ExplicitRk;

    struct Rotation;
    impl crate::Field<f64, [f64; 2]> for Rotation {
        fn field(&self, x: &[f64; 2], dx: &mut [f64; 2]) {
            *dx = [-x[1], x[0]];
        }
    }

    #[test]
    fn an_interrupt_ends_the_run_at_its_next_check() {
        // asked at the start and every INTERRUPT_EVERY steps; says stop at its fourth call
        let calls = Cell::new(0u64);
        let err = Driver::new(0.0, 100.0, 1e-3)
            .interrupt(|| {
                calls.set(calls.get() + 1);
                calls.get() == 4
            })
            .run(&mut ExplicitRk::rk4(), &Rotation, &[1.0, 0.0], &mut ())
            .unwrap_err();
        let StepError::Interrupted { t, step, state } = &err else {
            panic!("{err}");
        };
        assert_eq!(*step, 3 * INTERRUPT_EVERY);
        assert!((t - 3.0 * INTERRUPT_EVERY as f64 * 1e-3).abs() < 1e-12);
        assert!((state[0] - t.cos()).abs() < 1e-9 && (state[1] - t.sin()).abs() < 1e-9);
        assert_eq!((err.step(), err.time()), (Some(768), Some(*t)));
        // never asked to stop: the run reaches its end
        let done = Driver::new(0.0, 1.0, 1e-3)
            .interrupt(|| false)
            .run(&mut ExplicitRk::rk4(), &Rotation, &[1.0, 0.0], &mut ())
            .unwrap();
        assert_eq!(done.steps, 1000);
    }

    /// Euler, taking batches by stepping in a loop, and counting the steps taken in batches.
    struct Batched {
        euler: ExplicitRk<f64, 1, [f64; 2]>,
        in_batches: u64,
    }

    impl Stepper<f64, [f64; 2], Rotation> for Batched {
        fn step(
            &mut self,
            field: &Rotation,
            t: f64,
            x: &mut [f64; 2],
            h: f64,
        ) -> Result<crate::StepOutcome<f64>, StepError> {
            self.euler.step(field, t, x, h)
        }
        fn order(&self) -> u32 {
            1
        }
        fn name(&self) -> String {
            "batched euler".to_string()
        }
        fn fixed_steps(
            &mut self,
            field: &Rotation,
            x: &mut [f64; 2],
            h: f64,
            k: u64,
        ) -> Option<crate::Batch> {
            for _ in 0..k {
                self.euler.step(field, 0.0, x, h).ok()?;
            }
            self.in_batches += k;
            Some(crate::Batch {
                steps: k,
                evaluations: k,
            })
        }
    }

    /// A run to t = 10.0005 in steps of 10⁻³ with a step budget and an interrupt flag that
    /// says stop at its `at`-th reading.
    fn driver(calls: &Cell<u64>, budget: u64, at: u64) -> Driver<'_, f64, [f64; 2]> {
        Driver::new(0.0, 10.000_5, 1e-3)
            .max_steps(budget)
            .interrupt(move || {
                calls.set(calls.get() + 1);
                calls.get() == at
            })
    }

    #[test]
    fn batches_leave_runs_as_they_were() {
        let run = |batched: bool, driver: Driver<'_, f64, [f64; 2]>, every: u64| {
            let mut seen = Vec::new();
            let mut stride = crate::Stride::new(
                |step: u64, t: f64, x: &[f64; 2]| {
                    seen.push((step, t.to_bits(), x[0].to_bits()));
                    Control::Continue
                },
                every,
            );
            let mut stepper = Batched {
                euler: ExplicitRk::euler(),
                in_batches: 0,
            };
            let out = if batched {
                driver.run(&mut stepper, &Rotation, &[1.0, 0.0], &mut stride)
            } else {
                driver.run(&mut &mut stepper.euler, &Rotation, &[1.0, 0.0], &mut stride)
            };
            let out = out.map_err(|e| e.to_string());
            (out, seen, stepper.in_batches)
        };
        // a sample every 100 steps, the last step shortened; a step budget; an interrupt at
        // the interrupt flag's third reading
        for (every, budget, interrupt_at) in
            [(100, u64::MAX, 0), (100, 950, 0), (1000, u64::MAX, 3)]
        {
            let (calls_plain, calls_batched) = (Cell::new(0), Cell::new(0));
            let (plain, plain_seen, _) =
                run(false, driver(&calls_plain, budget, interrupt_at), every);
            let (batched, batched_seen, in_batches) =
                run(true, driver(&calls_batched, budget, interrupt_at), every);
            assert_eq!(plain, batched, "every {every}, budget {budget}");
            assert_eq!(plain_seen, batched_seen);
            assert!(in_batches > 500, "{in_batches} steps in batches");
        }
    }
}
