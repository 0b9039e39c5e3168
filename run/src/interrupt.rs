//! [`Interrupt`]: a way to stop runs and ensembles from outside — a Ctrl-C handler, a
//! scheduler, a front end's watcher thread.

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Stops the runs that carry it ([`RunSpec::interrupt`](crate::RunSpec::interrupt)): each
/// run's driver asks it every [`INTERRUPT_EVERY`](lasalle_runtime::INTERRUPT_EVERY) steps and
/// ends with [`StepError::Interrupted`](lasalle_runtime::StepError::Interrupted) once it is
/// stopped; an ensemble ([`simulate_many`](crate::simulate_many)) starts no run after that and
/// reports [`RunError::Interrupted`](crate::RunError::Interrupted) for the members it did not
/// start (the runs it stopped have that failure in their recordings).
///
/// Clones share the state: stop one (from any thread) and every run carrying a clone stops.
/// An optional poll, [`Interrupt::with_poll`], is asked too (from the running threads), for a
/// caller that learns about a stop request only by asking (a Python interpreter's pending
/// signals).
#[derive(Clone, Default)]
pub struct Interrupt {
    flag: Arc<AtomicBool>,
    poll: Option<Arc<dyn Fn() -> bool + Send + Sync>>,
}

impl Interrupt {
    /// A fresh interrupt, not stopped.
    pub fn new() -> Self {
        Interrupt::default()
    }

    /// A fresh interrupt that also stops when `poll` returns true (asked where the flag is
    /// read, so it should be cheap or rate-limit itself).
    pub fn with_poll(poll: impl Fn() -> bool + Send + Sync + 'static) -> Self {
        Interrupt {
            flag: Arc::default(),
            poll: Some(Arc::new(poll)),
        }
    }

    /// Stops every run carrying this interrupt (or a clone).
    pub fn stop(&self) {
        self.flag.store(true, Ordering::Relaxed);
    }

    /// Has it been stopped (asking the poll, if any)?
    pub fn is_stopped(&self) -> bool {
        if self.flag.load(Ordering::Relaxed) {
            return true;
        }
        match &self.poll {
            Some(poll) if poll() => {
                self.stop();
                true
            }
            _ => false,
        }
    }
}

impl PartialEq for Interrupt {
    /// The same interrupt (clones of one another).
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.flag, &other.flag)
    }
}

impl fmt::Debug for Interrupt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Interrupt")
            .field("stopped", &self.flag.load(Ordering::Relaxed))
            .field("poll", &self.poll.is_some())
            .finish()
    }
}
