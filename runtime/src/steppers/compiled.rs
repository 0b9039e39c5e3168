//! A fixed step compiled whole by a back end: the stages of an explicit Runge–Kutta method,
//! the field and the guards' margins of the new state in one function, which the stepper calls
//! once per step on the caller's state.
//!
//! A back end builds it ([`crate::Declared::compiled_step`]; the JIT of `lasalle-exec` from a
//! step tape, `lasalle_model::tape::step`) so that the step does the IEEE operations of
//! [`ExplicitRk`](super::ExplicitRk) in its order: a run with it is bitwise the run with the
//! generic stepper, with the guards checked on the same states, only without the per-stage
//! calls, the stage buffers and the separate guard call.

use std::any::Any;
use std::sync::Arc;

use super::{Batch, StepOutcome, Stepper};
use crate::declared::GuardFailure;
use crate::error::{all_finite, StepError};
use crate::field::Field;
use crate::state::State;

/// A fixed-step explicit Runge–Kutta method by its tableau, as [`crate::Declared::compiled_step`]
/// receives it: row i of `a` holds a_i0 … a_i(i−1) (longer rows are read that far).
#[derive(Clone, Copy, Debug)]
pub struct FixedMethod<'a> {
    /// The method's name, e.g. `"rk4"`.
    pub name: &'static str,
    /// Its order.
    pub order: u32,
    /// The coupling coefficients, row by row.
    pub a: &'a [&'a [f64]],
    /// The weights.
    pub b: &'a [f64],
}

/// The code of a compiled step: `(hoisted, state, targets, gains, out)`, with the gains the
/// field's, then the step size h, then the step size the guards read; `out` receives the new
/// state, then the guards' margins.
pub type RawStep = unsafe extern "C" fn(*const f64, *const f64, *const f64, *const f64, *mut f64);

/// The code of a batch of compiled steps: `(hoisted, a, targets, gains, b, k) -> taken`, the
/// arguments as [`RawStep`]'s with two state buffers `a` and `b` (each with room for the new
/// state and the margins): up to k steps from the state in `a`, each reading one buffer and
/// writing the other, stopping before the first step whose new state is not finite or whose
/// margins fail, as [`CompiledStep`]'s own loop does. The state after the `taken` steps is in
/// `a` if `taken` is even, in `b` if odd.
pub type RawBatch =
    unsafe extern "C" fn(*const f64, *mut f64, *const f64, *const f64, *mut f64, u64) -> u64;

/// A fixed step compiled whole by a back end: the stages of an explicit Runge–Kutta method,
/// the field and the guards' margins of the new state in one function, called once per step.
///
/// The step does the IEEE operations of [`ExplicitRk`](crate::ExplicitRk) in its order, so a
/// run with it is bitwise the run with the generic stepper, the guards checked on the same
/// states; [`crate::Declared::compiled_step`] hands it out where the back end compiles one.
pub struct CompiledStep {
    name: &'static str,
    order: u32,
    stages: u32,
    code: RawStep,
    /// The back end's loop of a batch of steps, if it compiles one.
    batch: Option<RawBatch>,
    /// What keeps `code` and `batch` alive.
    _owner: Arc<dyn Any + Send + Sync>,
    hoisted: Vec<f64>,
    targets: Vec<f64>,
    /// The field's gains, then h (set at every step), then the guards' step size.
    gains: Vec<f64>,
    /// The new state (`n` values), then the margins.
    out: Vec<f64>,
    /// The other half of a batch's double buffer, shaped as `out`.
    back: Vec<f64>,
    n: usize,
    /// Name, condition and strictness of each guard, in the order of the margins.
    guards: Vec<(&'static str, &'static str, bool)>,
}

impl std::fmt::Debug for CompiledStep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CompiledStep")
            .field("name", &self.name)
            .field("n", &self.n)
            .field("guards", &self.guards.len())
            .finish_non_exhaustive()
    }
}

impl CompiledStep {
    /// A stepper calling `code` for `method` on states of `n` components.
    ///
    /// # Safety
    ///
    /// `code` must read `hoisted.len()` hoisted values, `n` state components,
    /// `targets.len()` targets and `gains.len() + 2` gains, write `n + guards.len()` values,
    /// and stay valid as long as `owner` is alive.
    #[allow(clippy::too_many_arguments)]
    pub unsafe fn new(
        method: &FixedMethod<'_>,
        code: RawStep,
        owner: Arc<dyn Any + Send + Sync>,
        hoisted: Vec<f64>,
        n: usize,
        targets: Vec<f64>,
        gains: &[f64],
        guards: Vec<(&'static str, &'static str, bool)>,
        guard_step: f64,
    ) -> CompiledStep {
        let mut all_gains = gains.to_vec();
        all_gains.extend([0.0, guard_step]);
        CompiledStep {
            name: method.name,
            order: method.order,
            stages: method.b.len() as u32,
            code,
            batch: None,
            _owner: owner,
            hoisted,
            targets,
            gains: all_gains,
            out: vec![0.0; n + guards.len()],
            back: vec![0.0; n + guards.len()],
            n,
            guards,
        }
    }
}

impl CompiledStep {
    /// The same stepper, taking its batches of steps ([`Stepper::fixed_steps`]) with `batch`.
    ///
    /// # Safety
    ///
    /// `batch` must be the loop of [`RawBatch`] around this stepper's `code` (the same steps,
    /// bitwise), read and write what `code` does, and stay valid as long as the `owner` given
    /// to [`CompiledStep::new`] is alive.
    pub unsafe fn with_batch(mut self, batch: RawBatch) -> CompiledStep {
        self.batch = Some(batch);
        self
    }
}

impl<X: State<f64>, F: Field<f64, X> + ?Sized> Stepper<f64, X, F> for CompiledStep {
    fn step(
        &mut self,
        field: &F,
        t: f64,
        x: &mut X,
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        let n = self.n;
        if x.len() != n {
            return Err(StepError::InvalidInput(format!(
                "the compiled step takes states of {n} components, not {}",
                x.len()
            )));
        }
        let at_h = self.gains.len() - 2;
        self.gains[at_h] = h;
        // SAFETY: the lengths are those `new`'s contract names: `x` has n components (checked
        // above), the other buffers were sized in `new`.
        unsafe {
            (self.code)(
                self.hoisted.as_ptr(),
                x.as_ref().as_ptr(),
                self.targets.as_ptr(),
                self.gains.as_ptr(),
                self.out.as_mut_ptr(),
            )
        };
        let (next, margins) = self.out.split_at(n);
        if !all_finite(next) {
            // the generic stepper's report: a non-finite field at the step's start is its
            // error; otherwise the driver finds the non-finite state
            let mut k = x.clone();
            field.field(x, &mut k);
            if !all_finite(k.as_ref()) {
                return Err(StepError::non_finite("field", t, h, x.as_ref()));
            }
            x.as_mut().copy_from_slice(next);
            return Ok(StepOutcome::fixed(h, self.stages));
        }
        x.as_mut().copy_from_slice(next);
        for (&(name, condition, strict), &margin) in self.guards.iter().zip(margins) {
            if let Some(failure) = GuardFailure::check(name, condition, margin, strict) {
                return Err(StepError::Guard {
                    t: t + h,
                    step: 0,
                    h,
                    message: failure.to_string(),
                    state: x.as_ref().to_vec(),
                });
            }
        }
        Ok(StepOutcome::fixed(h, self.stages))
    }

    fn fixed_steps(&mut self, _field: &F, x: &mut X, h: f64, k: u64) -> Option<Batch> {
        let n = self.n;
        if x.len() != n {
            // `step` reports the mismatch
            return None;
        }
        let at_h = self.gains.len() - 2;
        self.gains[at_h] = h;
        if let Some(batch) = self.batch {
            let (a, b) = (&mut self.back, &mut self.out);
            a[..n].copy_from_slice(x.as_ref());
            // SAFETY: as in `step`, with both buffers sized for the new state and the margins
            // (`new`), which `with_batch`'s contract asks of the batch.
            let taken = unsafe {
                batch(
                    self.hoisted.as_ptr(),
                    a.as_mut_ptr(),
                    self.targets.as_ptr(),
                    self.gains.as_ptr(),
                    b.as_mut_ptr(),
                    k,
                )
            };
            let last = if taken % 2 == 0 { a } else { b };
            x.as_mut().copy_from_slice(&last[..n]);
            return Some(Batch {
                steps: taken,
                evaluations: taken * u64::from(self.stages),
            });
        }
        let (code, guards) = (self.code, &self.guards);
        let (hoisted, targets, gains) = (
            self.hoisted.as_ptr(),
            self.targets.as_ptr(),
            self.gains.as_ptr(),
        );
        // each step reads one buffer and writes the other: no copy between steps
        let (mut from, mut to) = (&mut self.back, &mut self.out);
        from[..n].copy_from_slice(x.as_ref());
        let mut taken = 0;
        while taken < k {
            // SAFETY: as in `step`: `from` holds the n state components, `to` has room for
            // the n new ones and the margins, the other buffers were sized in `new`.
            unsafe { code(hoisted, from.as_ptr(), targets, gains, to.as_mut_ptr()) };
            let (next, margins) = to.split_at(n);
            let good = all_finite(next)
                && guards
                    .iter()
                    .zip(margins)
                    .all(|(&(name, condition, strict), &m)| {
                        GuardFailure::check(name, condition, m, strict).is_none()
                    });
            if !good {
                // `step` takes this one again and reports it
                break;
            }
            std::mem::swap(&mut from, &mut to);
            taken += 1;
        }
        x.as_mut().copy_from_slice(&from[..n]);
        Some(Batch {
            steps: taken,
            evaluations: taken * u64::from(self.stages),
        })
    }

    fn order(&self) -> u32 {
        self.order
    }

    fn name(&self) -> String {
        self.name.to_string()
    }

    fn checks_guards(&self) -> bool {
        true
    }
}
