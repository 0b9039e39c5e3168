//! Events and output on a time grid, from each step's continuous extension.
//!
//! A model declares events as scalar functions g(x, t) whose zeros matter
//! (`event pericentre: dot(x, v) = 0 rising;`). After every accepted step the [`Watch`]
//! evaluates them along the step's continuous extension — the stepper's own dense output
//! where it has one ([`Stepper::dense_output`](crate::Stepper::dense_output): DOPRI5's
//! interpolant, the Taylor polynomial), otherwise the cubic Hermite interpolant of the end
//! states and fields ([`Hermite`], one extra field evaluation per step) — at the step's ends
//! and [`SUBINTERVALS`]` − 1` interior points, and locates each sign change with Brent's method
//! ([`brent`]) to a few ulps of t. So a crossing is located as accurately as the method
//! computes the solution, and never better: to the interpolant's error inside the step.
//!
//! - Signs are followed across steps from one continuous function, so a zero at a step's end
//!   is found once, not again at the next step's start; a zero at the initial time is no
//!   crossing.
//! - Where an interior sample is nearer zero than its neighbours, the extremum of g between
//!   them is searched (golden section, [`golden_min`]): if g passes through zero and back
//!   there, both crossings are found; if it only reaches zero to within [`TOUCH`] of g's range
//!   over the step — a graze, or a pair of crossings closer than the method can tell apart —
//!   it is one crossing, flagged [`Crossing::touch`], whatever the event's direction.
//! - `rising` events count crossings from g < 0 to g > 0, `falling` the others, and a
//!   terminal (`stop`) event ends the run at its first crossing: the crossings of the step
//!   after it are dropped.
//!
//! The same extension gives the states at requested output times ([`Watch::new`]'s `t_eval`),
//! so adaptive methods keep their own steps.

mod extension;
mod root;
mod watch;

pub use extension::{Extension, Hermite};
pub use root::{brent, golden_min};
pub use watch::{EventFn, FieldFn, Watch, SUBINTERVALS, TOUCH};

/// Which crossings of zero an event counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventDirection {
    /// Both (the default).
    Both,
    /// `rising`: from g < 0 to g > 0.
    Rising,
    /// `falling`: from g > 0 to g < 0.
    Falling,
}

/// An event as a model file declares it (`event escape: norm(x) - 10 = 0 rising stop;`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EventSpec {
    /// Its name.
    pub name: &'static str,
    /// Which crossings count.
    pub direction: EventDirection,
    /// Does its first crossing end the run?
    pub terminal: bool,
}

/// One located crossing.
#[derive(Clone, Debug, PartialEq)]
pub struct Crossing<X> {
    /// The event's index in the model's list.
    pub event: usize,
    /// Its time.
    pub t: f64,
    /// The state there (on the step's continuous extension).
    pub x: X,
    /// From g < 0 to g > 0 (for a touch: from below).
    pub rising: bool,
    /// A graze: g reached zero without (resolvably) crossing it.
    pub touch: bool,
}
