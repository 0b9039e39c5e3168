//! The Taylor kernel of a field kept as loops ([`LoopTaylorTape`]): the recurrences of a
//! [`LoopTaylorProgram`] interpreted, the plain program over one table and each region's body
//! once per tuple over that tuple's own table, in the order the program's docs
//! (`lasalle_model::loops::taylor`) fix; the JIT's kernel
//! (`lasalle_exec::jit::taylor::JitLoopTaylor`) runs the same operations in the same order.

use super::{coefficient, zeroth};
use lasalle_model::loops::{LoopTape, LoopTaylorProgram, Source};
use lasalle_runtime::taylor::{TaylorError, TaylorKernel};
use lasalle_runtime::StepError;

use crate::LoadedModel;

/// The interpreted Taylor kernel of a field given as a [`LoopTape`]: code independent of the
/// number of tuples, coefficient storage linear in it (each region's rows × (p + 1) per tuple).
#[derive(Clone, Debug)]
pub struct LoopTaylorTape {
    pub(crate) tape: LoopTape,
    pub(crate) program: LoopTaylorProgram,
    pub(crate) params: Vec<f64>,
    /// The plain tape's hoisted values, then each region's.
    pub(crate) hoisted: Vec<Vec<f64>>,
    pub(crate) max_order: usize,
    pub(crate) stride: usize,
    /// The plain program's rows × (p + 1), row-major, the state rows first.
    pub(crate) table: Vec<f64>,
    /// Per region: tuples × its rows × (p + 1), tuple after tuple, each row-major.
    pub(crate) blocks: Vec<Vec<f64>>,
    /// The order of the last compute.
    pub(crate) order: usize,
}

impl LoopTaylorTape {
    /// The kernel of `tape` (a field: as many outputs as state components) with parameter
    /// values `params`, for orders up to `max_order`.
    pub fn new(
        tape: &LoopTape,
        params: &[f64],
        max_order: u32,
    ) -> Result<LoopTaylorTape, TaylorError> {
        let program = tape.taylor().map_err(TaylorError::kernels)?;
        if max_order == 0 {
            return Err(TaylorError::Option("the order must be at least 1".into()));
        }
        let stride = max_order as usize + 1;
        let blocks = tape
            .regions
            .iter()
            .zip(&program.regions)
            .map(|(r, p)| vec![0.0; r.count * p.rows * stride])
            .collect();
        let mut k = LoopTaylorTape {
            table: vec![0.0; program.base.rows * stride],
            blocks,
            tape: tape.clone(),
            program,
            params: Vec::new(),
            hoisted: Vec::new(),
            max_order: max_order as usize,
            stride,
            order: 0,
        };
        k.set_params(params)?;
        Ok(k)
    }

    /// Recomputes the hoisted values for new parameter values.
    pub fn set_params(&mut self, params: &[f64]) -> Result<(), TaylorError> {
        let mut hoisted = vec![self.tape.base.hoist(params).map_err(TaylorError::kernels)?];
        for r in &self.tape.regions {
            hoisted.push(r.tape.hoist(params).map_err(TaylorError::kernels)?);
        }
        self.hoisted = hoisted;
        self.params.clear();
        self.params.extend_from_slice(params);
        Ok(())
    }

    /// The order of the last [`LoopTaylorTape::compute`].
    pub fn order(&self) -> usize {
        self.order
    }

    /// Computes the normalised Taylor coefficients x^\[0..=order\] of the solution through `x`
    /// (`order ≤ max_order`; the excess is clamped). Allocates nothing.
    ///
    /// # Panics
    /// If `x.len()` is not the state dimension.
    pub fn compute(&mut self, x: &[f64], order: usize) {
        let n = self.program.base.dim;
        assert_eq!(x.len(), n, "state dimension");
        let order = order.min(self.max_order);
        self.order = order;
        let s = self.stride;
        let t = &mut self.table[..];
        for (i, &xi) in x.iter().enumerate() {
            t[i * s] = xi;
        }
        let base = &self.program.base;
        for k in 0..order {
            for &(r, constant) in &base.recs {
                if k == 0 {
                    zeroth(t, s, r, &self.hoisted[0], &[], &[]);
                } else if !constant {
                    coefficient(t, s, r, k);
                }
            }
            for i in 0..n {
                t[i * s + k + 1] = 0.0;
            }
            for (&o, &row) in self.tape.base_at.iter().zip(&base.outputs) {
                t[o as usize * s + k + 1] = t[row * s + k];
            }
            let to = Scatter { first: 0, shift: 1 };
            let (tape, program) = (&self.tape, &self.program);
            regions(
                t,
                s,
                k,
                to,
                tape,
                program,
                &mut self.blocks,
                &self.hoisted[1..],
                &self.params,
            );
            let inv = 1.0 / (k as f64 + 1.0);
            for i in 0..n {
                t[i * s + k + 1] *= inv;
            }
        }
    }

    /// The coefficients x_i^\[0..=order\] of state component `i` from the last
    /// [`LoopTaylorTape::compute`].
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
}

/// Where the regions of a loop tape add their outputs' order k in the table: to order
/// k + `shift` of row `first` + the output.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Scatter {
    pub(crate) first: usize,
    pub(crate) shift: usize,
}

/// Order k of every region of `tape` (programs `program`, per-tuple tables `blocks`, hoisted
/// values `hoisted` per region): per region, per tuple, the slots' order k gathered from the
/// rows of `t` (order 0 also from `params`), the body's recurrences at order k, and each
/// output's order k added to the row of `t` that `to` and its scatter column name.
#[allow(clippy::too_many_arguments)]
pub(crate) fn regions(
    t: &mut [f64],
    s: usize,
    k: usize,
    to: Scatter,
    tape: &LoopTape,
    program: &LoopTaylorProgram,
    blocks: &mut [Vec<f64>],
    hoisted: &[Vec<f64>],
    params: &[f64],
) {
    for (ri, (region, prog)) in tape.regions.iter().zip(&program.regions).enumerate() {
        let hoisted = &hoisted[ri];
        let block = prog.rows * s;
        let slots = region.sources.len();
        let outs = prog.outputs.len();
        for (u, b) in blocks[ri].chunks_exact_mut(block).enumerate() {
            let gather = &region.gather[u * slots..(u + 1) * slots];
            for (j, (src, &at)) in region.sources.iter().zip(gather).enumerate() {
                let at = at as usize;
                match src {
                    Source::State => b[j * s + k] = t[at * s + k],
                    Source::Param if k == 0 => b[j * s] = params[at],
                    Source::Param => {}
                }
            }
            for &(r, constant) in &prog.recs {
                if k == 0 {
                    zeroth(b, s, r, hoisted, &[], &[]);
                } else if !constant {
                    coefficient(b, s, r, k);
                }
            }
            let scatter = &region.scatter[u * outs..(u + 1) * outs];
            for (&o, &row) in scatter.iter().zip(&prog.outputs) {
                t[(to.first + o as usize) * s + k + to.shift] += b[row * s + k];
            }
        }
    }
}

impl TaylorKernel<LoadedModel> for LoopTaylorTape {
    fn dim(&self) -> usize {
        self.program.base.dim
    }

    fn max_order(&self) -> usize {
        self.max_order
    }

    fn sync(&mut self, model: &LoadedModel) -> Result<(), StepError> {
        self.sync_params(model.params())
    }

    /// A field reads no targets and no gains: only empty slices are accepted.
    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        let check = |kind, given| {
            lasalle_model::tape::expect_len(kind, 0, given)
                .map_err(|e| StepError::InvalidInput(e.to_string()))
        };
        check("target", target.len())?;
        check("gains", gains.len())
    }

    fn compute(&mut self, x: &[f64], order: usize) {
        LoopTaylorTape::compute(self, x, order);
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        self.state_coefficients(i)
    }
}

/// The Taylor kernel of X − ∇V of a model loaded with its families kept as loops where the loop
/// form refuses X − ∇V (V reading a family through a guard; otherwise the kernel is
/// [`super::LoopFeedbackTaylor`]): its program is built from the unrolled model's tape (by
/// [`super::kernel_of`], as for any model) when a run first sets its targets and gains, which
/// every feedback run does before its first compute; a run of the plain field never builds it.
pub(crate) struct DeferredFeedback {
    lazy: std::sync::Arc<crate::deferred::LazyTapes>,
    backend: crate::Backend,
    params: Vec<f64>,
    dim: usize,
    max_order: u32,
    kernel: Option<Box<dyn TaylorKernel<LoadedModel>>>,
    /// The coefficients handed out before the kernel exists (NaN: never a silent value).
    unset: Vec<f64>,
}

impl DeferredFeedback {
    pub(crate) fn new(
        lazy: std::sync::Arc<crate::deferred::LazyTapes>,
        backend: crate::Backend,
        params: &[f64],
        dim: usize,
        max_order: u32,
    ) -> Result<DeferredFeedback, TaylorError> {
        if max_order == 0 {
            return Err(TaylorError::Option("the order must be at least 1".into()));
        }
        Ok(DeferredFeedback {
            lazy,
            backend,
            params: params.to_vec(),
            dim,
            max_order,
            kernel: None,
            unset: vec![f64::NAN; max_order as usize + 1],
        })
    }

    fn kernel(&mut self) -> Result<&mut Box<dyn TaylorKernel<LoadedModel>>, StepError> {
        if self.kernel.is_none() {
            let fail =
                |e: String| StepError::InvalidInput(format!("the Taylor kernel of X − ∇V: {e}"));
            let tapes = self.lazy.get().map_err(|e| fail(e.to_string()))?;
            let k = super::kernel_of(&tapes.feedback, self.backend, &self.params, self.max_order)
                .map_err(|e| fail(e.to_string()))?;
            self.kernel = Some(k);
        }
        Ok(self.kernel.as_mut().expect("built above"))
    }
}

impl TaylorKernel<LoadedModel> for DeferredFeedback {
    fn dim(&self) -> usize {
        self.dim
    }

    fn max_order(&self) -> usize {
        self.max_order as usize
    }

    fn sync(&mut self, model: &LoadedModel) -> Result<(), StepError> {
        match &mut self.kernel {
            Some(k) => k.sync(model),
            None => {
                self.params.clear();
                self.params.extend_from_slice(model.params());
                Ok(())
            }
        }
    }

    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        self.kernel()?.set_inputs(target, gains)
    }

    /// Before any [`TaylorKernel::set_inputs`] (which no feedback run skips) the coefficients
    /// are NaN.
    fn compute(&mut self, x: &[f64], order: usize) {
        if let Some(k) = &mut self.kernel {
            k.compute(x, order);
        }
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        match &self.kernel {
            Some(k) => k.coefficients(i),
            None => &self.unset,
        }
    }
}
