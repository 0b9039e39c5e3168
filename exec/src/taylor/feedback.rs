//! The Taylor kernel of X − ∇V of a model loaded with its families kept as loops
//! ([`LoopFeedbackTaylor`]): the three stages of [`LoopFeedback`] propagated as Taylor series
//! ([`FeedbackTaylorProgram`]: the coefficients of S and of the carried values C from x's by
//! the pass's loop recurrences, w's from x's and S's by the weights' recurrences, then order
//! k + 1 of x from the last stage's recurrences on x, S, C and w), interpreted in the order the program's docs
//! (`lasalle_model::loops::feedback_taylor`) fix. The JIT's kernel
//! (`lasalle_exec::jit::taylor::JitLoopFeedbackTaylor`) runs the same operations in the same
//! order, so the two agree bitwise. Code independent of the number of tuples, storage linear
//! in it; nothing is built from the unrolled model. The chaos indicators' field of a loop-form
//! extension is staged the same way, and this kernel (or its JIT) is its Taylor kernel too.

use super::loops::{regions, Scatter};
use super::{coefficient, zeroth};
use lasalle_model::loops::{FeedbackTaylorProgram, LoopFeedback, LoopTape};
use lasalle_model::tape::taylor::TaylorProgram;
use lasalle_runtime::taylor::{TaylorError, TaylorKernel};
use lasalle_runtime::StepError;

use crate::LoadedModel;

/// The interpreted Taylor kernel of X − ∇V in loop form; see the [module docs](self).
#[derive(Clone, Debug)]
pub struct LoopFeedbackTaylor {
    pub(crate) tapes: LoopFeedback,
    pub(crate) program: FeedbackTaylorProgram,
    pub(crate) params: Vec<f64>,
    /// The targets f(x₀) and the gains.
    pub(crate) target: Vec<f64>,
    pub(crate) gains: Vec<f64>,
    pub(crate) hoisted: Hoisted,
    pub(crate) max_order: usize,
    pub(crate) stride: usize,
    /// The shared table: rows × (p + 1), row-major, x, S, C and w first.
    pub(crate) table: Vec<f64>,
    /// Per region of the pass, then per region of the last stage: tuples × its rows × (p + 1).
    pub(crate) sums_blocks: Vec<Vec<f64>>,
    pub(crate) feedback_blocks: Vec<Vec<f64>>,
    /// The order of the last compute.
    pub(crate) order: usize,
}

/// The hoisted values of the stages' tapes.
#[derive(Clone, Debug, Default)]
pub(crate) struct Hoisted {
    /// The pass's plain tape, then each of its regions'.
    pub(crate) sums: Vec<Vec<f64>>,
    pub(crate) weights: Vec<f64>,
    /// The last stage's plain tape, then each of its regions'.
    pub(crate) feedback: Vec<Vec<f64>>,
}

fn hoist_loop(tape: &LoopTape, params: &[f64]) -> Result<Vec<Vec<f64>>, TaylorError> {
    let mut h = vec![tape.base.hoist(params).map_err(TaylorError::kernels)?];
    for r in &tape.regions {
        h.push(r.tape.hoist(params).map_err(TaylorError::kernels)?);
    }
    Ok(h)
}

fn blocks(
    tape: &LoopTape,
    program: &lasalle_model::loops::LoopTaylorProgram,
    stride: usize,
) -> Vec<Vec<f64>> {
    tape.regions
        .iter()
        .zip(&program.regions)
        .map(|(r, p)| vec![0.0; r.count * p.rows * stride])
        .collect()
}

/// Order k of a stage's plain program on the shared table `t` (stride `s`): order 0 from
/// `[hoisted, target, gains]`, the higher orders of the non-constant rows by their recurrences.
/// Also run from the JIT's code for a program too large to compile
/// (`lasalle_exec::jit::taylor::JitLoopFeedbackTaylor`).
pub(crate) fn plain_order(
    t: &mut [f64],
    s: usize,
    prog: &TaylorProgram,
    [hoisted, target, gains]: [&[f64]; 3],
    k: usize,
) {
    for &(r, constant) in &prog.recs {
        if k == 0 {
            zeroth(t, s, r, hoisted, target, gains);
        } else if !constant {
            coefficient(t, s, r, k);
        }
    }
}

impl LoopFeedbackTaylor {
    /// The kernel of X − ∇V given by the stages `tapes`, with parameter values `params`, for
    /// orders up to `max_order`. Targets and gains start at 0; set them with
    /// [`TaylorKernel::set_inputs`].
    pub fn new(
        tapes: &LoopFeedback,
        params: &[f64],
        max_order: u32,
    ) -> Result<LoopFeedbackTaylor, TaylorError> {
        let program = tapes.taylor().map_err(TaylorError::kernels)?;
        if max_order == 0 {
            return Err(TaylorError::Option("the order must be at least 1".into()));
        }
        let stride = max_order as usize + 1;
        let w = tapes.weights.dims;
        let mut k = LoopFeedbackTaylor {
            table: vec![0.0; program.rows * stride],
            sums_blocks: blocks(&tapes.pass, &program.sums, stride),
            feedback_blocks: blocks(&tapes.feedback, &program.feedback, stride),
            tapes: tapes.clone(),
            program,
            params: Vec::new(),
            target: vec![0.0; w.targets],
            gains: vec![0.0; w.gains],
            hoisted: Hoisted::default(),
            max_order: max_order as usize,
            stride,
            order: 0,
        };
        k.set_params(params)?;
        Ok(k)
    }

    /// Recomputes the hoisted values for new parameter values.
    pub fn set_params(&mut self, params: &[f64]) -> Result<(), TaylorError> {
        self.hoisted = Hoisted {
            sums: hoist_loop(&self.tapes.pass, params)?,
            weights: self
                .tapes
                .weights
                .hoist(params)
                .map_err(TaylorError::kernels)?,
            feedback: hoist_loop(&self.tapes.feedback, params)?,
        };
        self.params.clear();
        self.params.extend_from_slice(params);
        Ok(())
    }

    /// The order of the last [`LoopFeedbackTaylor::compute`].
    pub fn order(&self) -> usize {
        self.order
    }

    /// Computes the normalised Taylor coefficients x^\[0..=order\] of the solution of
    /// ẋ = X(x) − ∇V(x) through `x` (`order ≤ max_order`; the excess is clamped). Allocates
    /// nothing.
    ///
    /// # Panics
    /// If `x.len()` is not the state dimension.
    pub fn compute(&mut self, x: &[f64], order: usize) {
        let p = &self.program;
        let (n, nk) = (p.dim, p.pass_outputs());
        assert_eq!(x.len(), n, "state dimension");
        let order = order.min(self.max_order);
        self.order = order;
        let s = self.stride;
        let t = &mut self.table[..];
        for (i, &xi) in x.iter().enumerate() {
            t[i * s] = xi;
        }
        let h = &self.hoisted;
        let (target, gains) = (&self.target[..], &self.gains[..]);
        let plain = |t: &mut [f64], prog: &TaylorProgram, hoisted: &[f64], k: usize| {
            plain_order(t, s, prog, [hoisted, target, gains], k)
        };
        let tapes = &self.tapes;
        for k in 0..order {
            // 1. S and the carried values
            plain(t, &p.sums.base, &h.sums[0], k);
            for i in 0..nk {
                t[p.sum_row(i) * s + k] = 0.0;
            }
            for (&o, &row) in tapes.pass.base_at.iter().zip(&p.sums.base.outputs) {
                t[p.sum_row(o as usize) * s + k] = t[row * s + k];
            }
            let to = Scatter { first: n, shift: 0 };
            let blocks = &mut self.sums_blocks;
            regions(
                t,
                s,
                k,
                to,
                &tapes.pass,
                &p.sums,
                blocks,
                &h.sums[1..],
                &self.params,
            );
            // 2. w
            plain(t, &p.weights, &h.weights, k);
            for (i, &row) in p.weights.outputs[1..].iter().enumerate() {
                t[p.weight_row(i) * s + k] = t[row * s + k];
            }
            // 3. X − ∇V
            plain(t, &p.feedback.base, &h.feedback[0], k);
            for i in 0..n {
                t[i * s + k + 1] = 0.0;
            }
            for (&o, &row) in tapes.feedback.base_at.iter().zip(&p.feedback.base.outputs) {
                t[o as usize * s + k + 1] = t[row * s + k];
            }
            let to = Scatter { first: 0, shift: 1 };
            let blocks = &mut self.feedback_blocks;
            let (fb, prog) = (&tapes.feedback, &p.feedback);
            regions(
                t,
                s,
                k,
                to,
                fb,
                prog,
                blocks,
                &h.feedback[1..],
                &self.params,
            );
            let inv = 1.0 / (k as f64 + 1.0);
            for i in 0..n {
                t[i * s + k + 1] *= inv;
            }
        }
    }

    /// The coefficients x_i^\[0..=order\] of state component `i` from the last
    /// [`LoopFeedbackTaylor::compute`].
    pub fn state_coefficients(&self, i: usize) -> &[f64] {
        &self.table[i * self.stride..i * self.stride + self.order + 1]
    }

    /// [`TaylorKernel::sync`]: recomputes the hoisted values if `params` changed.
    pub(crate) fn sync_params(&mut self, params: &[f64]) -> Result<(), StepError> {
        if params == self.params.as_slice() {
            return Ok(());
        }
        self.set_params(params)
            .map_err(|e| StepError::InvalidInput(e.to_string()))
    }

    /// [`TaylorKernel::set_inputs`].
    pub(crate) fn set_targets(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        super::copy_inputs((target, gains), (&mut self.target, &mut self.gains))
    }
}

impl TaylorKernel<LoadedModel> for LoopFeedbackTaylor {
    fn dim(&self) -> usize {
        self.program.dim
    }

    fn max_order(&self) -> usize {
        self.max_order
    }

    fn sync(&mut self, model: &LoadedModel) -> Result<(), StepError> {
        self.sync_params(model.params())
    }

    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        self.set_targets(target, gains)
    }

    fn compute(&mut self, x: &[f64], order: usize) {
        LoopFeedbackTaylor::compute(self, x, order);
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        self.state_coefficients(i)
    }
}
