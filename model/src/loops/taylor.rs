//! The Taylor program of a loop tape: the plain tape's recurrences and, per region, the
//! recurrences of its body, run once per tuple on coefficients gathered from the state's.
//!
//! For ẋ = X(x) with X a [`LoopTape`], order k of X is order k of the plain tape's outputs
//! plus, per region and tuple, order k of the body's outputs at the tuple's gathered slots.
//! The body's coefficients at order k read only the slots' coefficients 0..=k, which are the
//! state's (slots reading the state) or the order-0 value alone (slots reading a parameter:
//! constant along the solution, so the instructions on them are constants and scalings, as
//! the unrolled program's are). So a back end runs, at each order k:
//! 1. the plain program ([`LoopTaylorProgram::base`], rows 0..N the state) at order k;
//! 2. order k + 1 of the state set to the plain outputs' order k (0 where the plain tape has
//!    no output), in [`LoopTape::base_at`] order;
//! 3. per region, in order, per tuple, in order: the slots' order-k coefficients copied from
//!    the state rows (order 0 also from the parameters), the body's recurrences at order k
//!    ([`LoopTaylorProgram::regions`], rows 0..K the slots), and each output's order k added
//!    to order k + 1 of the state component its scatter column names, output after output;
//! 4. order k + 1 of the state multiplied by the rounded 1/(k + 1).
//!
//! Every back end (`lasalle_exec`'s interpreter and JIT) does exactly this, so they agree bit
//! for bit; the unrolled program sums the family's terms in another order and agrees to
//! rounding. The coefficients of a region are stored per tuple (its rows × (p + 1) for each
//! tuple): memory linear in the tuples, code independent of them.

use super::{LoopTape, Source};
use crate::tape::taylor::TaylorProgram;
use crate::tape::TapeError;

/// The Taylor recurrences of a field given as a [`LoopTape`]; see the [module docs](self).
#[derive(Clone, Debug, PartialEq)]
pub struct LoopTaylorProgram {
    /// The plain tape's recurrences: rows 0..N the state; its outputs are the plain outputs,
    /// placed at [`LoopTape::base_at`].
    pub base: TaylorProgram,
    /// Per region of the tape, its body's recurrences: rows 0..K the slots (those reading a
    /// parameter constant along the solution); its outputs scatter as the region's.
    pub regions: Vec<TaylorProgram>,
}

impl LoopTape {
    /// The Taylor program of this loop tape, a field (as many outputs as state components);
    /// see the [module docs](crate::loops::taylor).
    pub fn taylor(&self) -> Result<LoopTaylorProgram, TapeError> {
        let n = self.base.dims.state;
        if self.outputs != n {
            return Err(TapeError::Malformed(format!(
                "a Taylor integrator needs a field: the loop tape has {} outputs for a state of dimension {n}",
                self.outputs
            )));
        }
        self.taylor_function()
    }

    /// The recurrences of this loop tape as a function of the state (any number of outputs),
    /// for a caller that places the outputs' coefficients itself: the stages of X − ∇V
    /// ([`crate::loops::FeedbackTaylorProgram`]).
    pub fn taylor_function(&self) -> Result<LoopTaylorProgram, TapeError> {
        self.validate()?;
        let base = TaylorProgram::function(&self.base, &[])?;
        let regions = self
            .regions
            .iter()
            .map(|r| {
                let constant: Vec<bool> = r.sources.iter().map(|s| *s == Source::Param).collect();
                TaylorProgram::function(&r.tape, &constant)
            })
            .collect::<Result<_, _>>()?;
        Ok(LoopTaylorProgram { base, regions })
    }
}
