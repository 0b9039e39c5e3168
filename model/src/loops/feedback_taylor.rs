//! The Taylor program of X − ∇V in loop form: the three stages of [`LoopFeedback`] propagated
//! as Taylor series.
//!
//! The same program serves every field staged as a [`LoopFeedback`]: the chaos indicators'
//! field of an extension ([`crate::loops::variational`]: S = (A·u, 0, 0, 0, 0) and no carried
//! values, w the rates of (u, ℓ, τ, a, b) after λ, stage 3 X followed by `w` read back) runs
//! these steps as they are, with no targets and no gains.
//!
//! X − ∇V is computed in three stages (see [`LoopFeedback`]): the pass, which gives the family
//! sums S and the carried values C (the family parts of ∇S and of the field) from the state x
//! in one loop over each family's tuples, then V and the weights w = ∂V/∂S from `[x, S]`, then
//! X − ∇V from `[x, S, C, w]`. Along a solution, S, C, w and X − ∇V are functions of x(t), so
//! their Taylor coefficients follow from x's stage by stage: order k of S and C reads orders
//! 0..=k of x (the recurrences of the pass's loop tape), order k of w reads orders 0..=k of x
//! and S (the plain tape's recurrences), and order k of X − ∇V reads orders 0..=k of x, S, C
//! and w (the last loop tape's recurrences: the products w·C are Cauchy products), which gives
//! order k + 1 of x. So a back end runs, at each order k = 0..p − 1, on one shared table:
//! 1. **S, C**: the pass's plain program at order k, then order k of the S and C rows set to
//!    its outputs' order k (0 where it has none), then its regions as in
//!    [`crate::loops::taylor`] — per region, per tuple: the slots' order k gathered, the
//!    body's recurrences, each output's order k added to order k of the row its scatter column
//!    names;
//! 2. **w**: the weights' program at order k, then order k of the w rows set to its outputs
//!    1..=K (output 0, V, is not read);
//! 3. **X − ∇V**: the last stage's plain program at order k, order k + 1 of the x rows set to
//!    its outputs' order k (0 where none), its regions adding to them as in step 1, then order
//!    k + 1 of x multiplied by the rounded 1/(k + 1).
//!
//! The shared table's rows are x (N rows), S (K), C (D), w (K), then the other rows of the
//! pass's plain program, of the weights' and of the last stage's plain program, in this order:
//! each stage's inputs are a prefix of the table (`[x]`, `[x, S]`, `[x, S, C, w]`), so its plain
//! program reads them where they are, and its regions gather from the table's rows by the
//! indices of their gather tables. The regions' coefficients are stored per tuple, as the
//! field's. Every back end (`lasalle_exec`'s interpreter and JIT) runs exactly these
//! operations in this order, so they agree bit for bit; the unrolled program computes the
//! same coefficients by another route (the sums never formed) and agrees to rounding.

use super::{LoopFeedback, LoopTaylorProgram};
use crate::tape::taylor::TaylorProgram;
use crate::tape::TapeError;

/// The Taylor recurrences of X − ∇V in three stages on one table; see the
/// [module docs](self).
#[derive(Clone, Debug, PartialEq)]
pub struct FeedbackTaylorProgram {
    /// Stage 1, S and C: the plain program (its rows placed in the shared table, its outputs
    /// the plain outputs of [`LoopFeedback::pass`]) and the regions' programs (rows 0..slots
    /// the slots, on the tuples' tables).
    pub sums: LoopTaylorProgram,
    /// Stage 2, V and w (its rows placed in the shared table): outputs 1..=K are w.
    pub weights: TaylorProgram,
    /// Stage 3, X − ∇V, as `sums`.
    pub feedback: LoopTaylorProgram,
    /// The state dimension N.
    pub dim: usize,
    /// The number K of sums (and of weights).
    pub sums_count: usize,
    /// The number D of carried values ([`LoopFeedback::carried`]), whose rows follow the sums'.
    pub carried: usize,
    /// Rows of the shared table.
    pub rows: usize,
}

impl FeedbackTaylorProgram {
    /// The table row of output `i` of the pass (sum `i` for `i` < K, then the carried values).
    pub fn sum_row(&self, i: usize) -> usize {
        self.dim + i
    }

    /// The number K + D of the pass's outputs.
    pub fn pass_outputs(&self) -> usize {
        self.sums_count + self.carried
    }

    /// The table row of weight `i`.
    pub fn weight_row(&self, i: usize) -> usize {
        self.dim + self.sums_count + self.carried + i
    }
}

impl LoopFeedback {
    /// The Taylor program of X − ∇V (or of any field staged as these three stages, as the chaos
    /// indicators' field is) in loop form; see the [module docs](crate::loops::feedback_taylor).
    pub fn taylor(&self) -> Result<FeedbackTaylorProgram, TapeError> {
        let n = self.sums.dims().state;
        let k = self.sums.n_outputs();
        let c = self.carried();
        let bad = |what: &str| {
            Err(TapeError::Malformed(format!(
                "the stages of X − ∇V: {what}"
            )))
        };
        if self.weights.dims.state != n + k || self.weights.outputs.len() != 1 + k {
            return bad("the weights' sizes do not match the sums'");
        }
        if self.pass.dims() != self.sums.dims() || self.pass.n_outputs() < k {
            return bad("the pass's sizes do not match the sums'");
        }
        let fd = self.feedback.dims();
        if fd.state != n + 2 * k + c || self.feedback.n_outputs() != n {
            return bad("the last stage's sizes do not match the weights'");
        }
        let mut sums = self.pass.taylor_function()?;
        let weights = TaylorProgram::function(&self.weights, &[])?;
        let mut feedback = self.feedback.taylor_function()?;
        let mut rows = n + 2 * k + c;
        let mut place = |p: &TaylorProgram| {
            let (dim, at) = (p.dim, rows);
            let f = |r: usize| if r < dim { r } else { r - dim + at };
            rows += p.rows - dim;
            TaylorProgram {
                recs: p.recs.iter().map(|&(r, c)| (r.map_rows(f), c)).collect(),
                outputs: p.outputs.iter().map(|&r| f(r)).collect(),
                rows: 0,
                dim,
            }
        };
        sums.base = place(&sums.base);
        let mut weights = place(&weights);
        feedback.base = place(&feedback.base);
        for p in [&mut sums.base, &mut weights, &mut feedback.base] {
            p.rows = rows;
        }
        Ok(FeedbackTaylorProgram {
            sums,
            weights,
            feedback,
            dim: n,
            sums_count: k,
            carried: c,
            rows,
        })
    }
}
