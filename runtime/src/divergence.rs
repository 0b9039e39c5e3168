//! When a run has diverged: a bound on the drift of the declared invariants.
//!
//! The driver already stops at a non-finite state. A state can stay finite and still be
//! garbage (1e142 after a feedback gain too stiff for the step): [`DriftBound`] catches that
//! through the invariants, which every model of lasalle declares. Block i has diverged when
//! ‖fᵢ(x) − fᵢ(x₀)‖ is not finite or exceeds `max_drift · max(‖fᵢ(x₀)‖, 1)`: the drift
//! measured against the invariant's own size, or in absolute terms for invariants near zero
//! (a constraint RᵀR − I, a momentum that starts at zero). [`crate::Driver::divergence`] runs
//! the check where a run records its samples.

use std::cell::RefCell;
use std::ops::Range;

use num_traits::Float;

use crate::error::to_f64;
use crate::field::{Invariants, ModelInfo};
use crate::state::State;

/// The default `max_drift`: an invariant's error a thousand times its scale is no longer an
/// integration error but a run that left the problem.
pub const DEFAULT_MAX_DRIFT: f64 = 1e3;

/// The divergence check of a model's invariants relative to f(x₀) (see the module docs).
#[derive(Clone, Debug)]
pub struct DriftBound<'m, Mdl: ?Sized, T, F> {
    model: &'m Mdl,
    target: F,
    /// Scratch for f(x), so that a check allocates nothing.
    f: RefCell<F>,
    /// (name, range in f, bound on the block's error).
    blocks: Vec<(&'static str, Range<usize>, T)>,
    max_drift: T,
}

impl<'m, Mdl, T, F> DriftBound<'m, Mdl, T, F>
where
    Mdl: ModelInfo + ?Sized,
    T: Float,
    F: State<T>,
{
    /// The bound `max_drift · max(‖fᵢ(x₀)‖, 1)` on each declared invariant block of `model`.
    pub fn new<X>(model: &'m Mdl, x0: &X, max_drift: T) -> Self
    where
        Mdl: Invariants<T, X, F>,
        X: State<T>,
    {
        let mut target = F::filled(F::len_for(model.invariant_dim()), T::zero());
        model.invariants(x0, &mut target);
        let blocks = model
            .invariant_infos()
            .iter()
            .map(|i| {
                let range = i.slot.range();
                let scale = norm(target.as_ref()[range.clone()].iter().copied());
                (i.slot.name, range, max_drift * scale.max(T::one()))
            })
            .collect();
        DriftBound {
            model,
            f: RefCell::new(target.clone()),
            target,
            blocks,
            max_drift,
        }
    }

    /// `None` while every block's drift at `x` is within its bound, else what diverged.
    pub fn check<X>(&self, x: &X) -> Option<String>
    where
        Mdl: Invariants<T, X, F>,
        X: State<T>,
    {
        let mut f = self.f.borrow_mut();
        self.model.invariants(x, &mut f);
        self.first_past(self.blocks.iter().map(|(_, range, _)| {
            norm(
                range
                    .clone()
                    .map(|i| f.as_ref()[i] - self.target.as_ref()[i]),
            )
        }))
    }

    /// [`check`](Self::check) on the blocks' drifts |fᵢ(x) − fᵢ(x₀)| already computed, one
    /// per declared invariant block in the model's order, as a
    /// [`Recorder`](crate::Recorder) of the same model records them
    /// ([`Recorder::errors_at`](crate::Recorder::errors_at)): a run that records what it checks
    /// evaluates the invariants once.
    pub fn check_errors(&self, errors: &[T]) -> Option<String> {
        debug_assert_eq!(errors.len(), self.blocks.len());
        self.first_past(errors.iter().copied())
    }

    /// The message of the first block whose drift is past its bound (or not a number).
    fn first_past(&self, drifts: impl Iterator<Item = T>) -> Option<String> {
        self.blocks
            .iter()
            .zip(drifts)
            .find_map(|((name, _, bound), drift)| {
                (!(drift <= *bound)).then(|| {
                    format!(
                        "invariant {name} drifted by |Δ{name}| = {:e}, past {:e} × max(|{name}(x₀)|, 1) = {:e}",
                        to_f64(drift),
                        to_f64(self.max_drift),
                        to_f64(*bound)
                    )
                })
            })
    }
}

fn norm<T: Float>(v: impl Iterator<Item = T>) -> T {
    v.fold(T::zero(), |s, x| s + x * x).sqrt()
}
