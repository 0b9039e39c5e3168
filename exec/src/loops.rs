//! Loop tapes ([`lasalle_model::loops`]) as kernels: the plain tape compiled by the chosen back
//! end, then every region run as a loop over its tuples, by the interpreter below or by the
//! JIT (one Cranelift function with a loop block per region, `jit::region`). The code is
//! independent of the number of tuples.
//!
//! Both back ends gather, compute and scatter in the same order with the same IEEE operations,
//! so their outputs agree bit for bit (and with [`LoopTape::eval`]).

use crate::{Backend, Dims, ExecError, Kernel, Op};
use lasalle_model::ir::Func;
use lasalle_model::loops::{LoopFeedback, LoopTape, Region, Source};
use lasalle_model::tape::powi;

/// A loop tape compiled by one back end; a [`Kernel`] like any tape's.
pub struct LoopKernel {
    base: Box<dyn Kernel>,
    regions: Vec<RegionKernel>,
    backend: Backend,
    /// Values [`Kernel::hoist`] of the plain kernel returns.
    base_hoisted: usize,
    /// Where each region's hoisted values start in this kernel's hoisted values; the
    /// parameters (which slots may gather) follow the last region's.
    offsets: Vec<usize>,
    params_at: usize,
    dims: Dims,
    n_outputs: usize,
    /// The output of each plain output, if not all outputs are plain ones in order.
    base_at: Option<Vec<u32>>,
}

thread_local! {
    /// The plain kernel's outputs, before they are placed.
    static PLAIN: std::cell::Cell<Vec<f64>> = const { std::cell::Cell::new(Vec::new()) };
}

impl std::fmt::Debug for LoopKernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoopKernel")
            .field("backend", &self.backend)
            .field("regions", &self.regions.len())
            .finish_non_exhaustive()
    }
}

struct RegionKernel {
    region: Region,
    #[cfg(feature = "jit")]
    jit: Option<(crate::jit::Code, crate::jit::region::RegionFn)>,
}

// SAFETY: the JIT's module is only touched again on drop; the compiled functions are pure
// (they read their arguments and add to `out`), so sharing them between threads is sound.
unsafe impl Send for RegionKernel {}
// SAFETY: as above.
unsafe impl Sync for RegionKernel {}

impl LoopKernel {
    /// Compiles a loop tape (checked with [`LoopTape::validate`]).
    pub fn new(tape: &LoopTape, backend: Backend) -> Result<LoopKernel, ExecError> {
        tape.validate()?;
        let base = backend.compile(&tape.base)?;
        let dims = tape.dims();
        let base_hoisted = base.hoist(&vec![0.0; dims.params])?.len();
        let mut offsets = Vec::with_capacity(tape.regions.len());
        let mut at = base_hoisted;
        let mut regions = Vec::with_capacity(tape.regions.len());
        for r in &tape.regions {
            offsets.push(at);
            at += r.tape.hoisted.len();
            regions.push(RegionKernel {
                #[cfg(feature = "jit")]
                jit: match backend {
                    Backend::Jit => Some(crate::jit::region::compile(r)?),
                    Backend::Interpreter => None,
                },
                region: r.clone(),
            });
        }
        Ok(LoopKernel {
            base,
            regions,
            backend,
            base_hoisted,
            offsets,
            params_at: at,
            dims,
            n_outputs: tape.n_outputs(),
            base_at: (tape.base_at.len() != tape.n_outputs()).then(|| tape.base_at.clone()),
        })
    }

    /// The back end.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    fn hoisted_len(&self) -> usize {
        self.params_at + self.dims.params
    }

    /// Writes the plain outputs into `out` (the others 0).
    fn plain(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        let Some(at) = &self.base_at else {
            return self.base.eval(hoisted, state, target, gains, out);
        };
        out.iter_mut().for_each(|v| *v = 0.0);
        PLAIN.with(|cell| {
            let mut v = cell.take();
            v.resize(at.len(), 0.0);
            let r = self.base.eval(hoisted, state, target, gains, &mut v);
            for (&o, x) in at.iter().zip(&v) {
                out[o as usize] = *x;
            }
            cell.set(v);
            r
        })
    }

    /// Runs the regions after the plain kernel wrote `out`.
    ///
    /// # Safety
    /// The lengths are those [`Kernel::eval`] checks.
    unsafe fn regions(&self, hoisted: &[f64], state: &[f64], out: &mut [f64]) {
        let params = &hoisted[self.params_at..];
        for (r, &at) in self.regions.iter().zip(&self.offsets) {
            let h = &hoisted[at..];
            #[cfg(feature = "jit")]
            if let Some((_, f)) = &r.jit {
                // SAFETY: the tables were validated against these lengths.
                unsafe {
                    f(
                        h.as_ptr(),
                        state.as_ptr(),
                        params.as_ptr(),
                        r.region.gather.as_ptr(),
                        r.region.scatter.as_ptr(),
                        out.as_mut_ptr(),
                    )
                };
                continue;
            }
            interpret(&r.region, h, state, params, out);
        }
    }
}

/// A region by the interpreter: the operations of `jit::region` in the same order.
fn interpret(r: &Region, hoisted: &[f64], state: &[f64], params: &[f64], out: &mut [f64]) {
    let ops = &r.tape.body;
    let (k, o) = (r.sources.len(), r.tape.outputs.len());
    crate::interp::with_scratch(ops.len(), |regs| {
        for t in 0..r.count {
            let g = &r.gather[t * k..(t + 1) * k];
            for (i, op) in ops.iter().enumerate() {
                let v = |r: crate::Reg| regs[r.index()];
                regs[i] = match *op {
                    Op::State(s) => {
                        let at = g[s as usize] as usize;
                        match r.sources[s as usize] {
                            Source::State => state[at],
                            Source::Param => params[at],
                        }
                    }
                    Op::Hoisted(h) => hoisted[h as usize],
                    Op::Const(c) => c,
                    Op::Add(a, b) => v(a) + v(b),
                    Op::Sub(a, b) => v(a) - v(b),
                    Op::Mul(a, b) => v(a) * v(b),
                    Op::Div(a, b) => v(a) / v(b),
                    Op::Neg(a) => -v(a),
                    Op::Powi(a, n) => powi(v(a), n),
                    Op::Sqrt(a) => v(a).sqrt(),
                    Op::Cbrt(a) => v(a).cbrt(),
                    Op::Powf(a, p) => crate::interp::powf(v(a), p),
                    Op::Exp(a) => v(a).exp(),
                    Op::Ln(a) => v(a).ln(),
                    Op::Sin(a) => v(a).sin(),
                    Op::Cos(a) => v(a).cos(),
                    Op::EllipK(a) => Func::EllipK.apply(v(a)),
                    Op::Func2(f, a, b) => f.apply(v(a), v(b)),
                    // validated: a region's body reads no parameter, target or gain
                    Op::Param(_) | Op::Target(_) | Op::Gain(_) => f64::NAN,
                };
            }
            let s = &r.scatter[t * o..(t + 1) * o];
            for (reg, &at) in r.tape.outputs.iter().zip(s) {
                out[at as usize] += regs[reg.index()];
            }
        }
    });
}

impl Kernel for LoopKernel {
    fn dims(&self) -> Dims {
        self.dims
    }

    fn n_outputs(&self) -> usize {
        self.n_outputs
    }

    fn hoist(&self, params: &[f64]) -> Result<Vec<f64>, ExecError> {
        let mut h = self.base.hoist(params)?;
        debug_assert_eq!(h.len(), self.base_hoisted);
        for r in &self.regions {
            h.extend(r.region.tape.hoist(params)?);
        }
        h.extend_from_slice(params);
        Ok(h)
    }

    fn eval(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        use lasalle_model::tape::expect_len;
        expect_len("hoisted", self.hoisted_len(), hoisted.len())?;
        expect_len("state", self.dims.state, state.len())?;
        expect_len("out", self.n_outputs, out.len())?;
        self.plain(&hoisted[..self.base_hoisted], state, target, gains, out)?;
        // SAFETY: lengths checked above.
        unsafe { self.regions(hoisted, state, out) };
        Ok(())
    }

    unsafe fn eval_unchecked(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) {
        if self
            .plain(&hoisted[..self.base_hoisted], state, target, gains, out)
            .is_err()
        {
            out.iter_mut().for_each(|v| *v = f64::NAN);
            return;
        }
        // SAFETY: the caller's guarantee, passed on.
        unsafe { self.regions(hoisted, state, out) };
    }

    /// Lane by lane: each lane is [`Kernel::eval`] of its state, so bitwise equal to it.
    fn eval_lanes(
        &self,
        k: usize,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        lane_by_lane(self, k, hoisted, state, target, gains, out)
    }
}

/// Which function of a [`LoopFeedback`] a [`StagedKernel`] computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// V: one output.
    Lyapunov,
    /// ∇V: N outputs.
    Gradient,
    /// X − ∇V: N outputs.
    Feedback,
}

/// V, ∇V or X − ∇V of a model with families kept as loops ([`LoopFeedback`]): the sums S (for
/// V) or the pass, which gives S and the carried values C in one loop over each family's
/// tuples (for ∇V and X − ∇V), as a loop kernel; V and w = ∂V/∂S as a plain kernel of
/// `[x, S]`; then (for ∇V and X − ∇V) the last stage, a kernel of `[x, S, C, w]`; each
/// compiled by the chosen back end and run in this order, so the back ends agree bit for bit
/// (and with [`LoopFeedback::eval_gradient`] and its kin).
pub struct StagedKernel {
    sums: LoopKernel,
    weights: Box<dyn Kernel>,
    last: Option<LoopKernel>,
    /// Lengths of the hoisted values of `sums`, `weights` (then `last`'s follow).
    hoisted: [usize; 2],
    /// Hoisted values in all.
    hoisted_len: usize,
    /// The sums K.
    k: usize,
    /// The carried values D (0 for V).
    carried: usize,
    dims: Dims,
    n_outputs: usize,
}

impl std::fmt::Debug for StagedKernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StagedKernel")
            .field("sums", &self.k)
            .field("outputs", &self.n_outputs)
            .finish_non_exhaustive()
    }
}

thread_local! {
    /// `[x, S, C, w]` and `[V, w]` of a staged evaluation.
    static STAGES: std::cell::Cell<(Vec<f64>, Vec<f64>)> =
        const { std::cell::Cell::new((Vec::new(), Vec::new())) };
}

impl StagedKernel {
    /// Compiles the stages of `tapes` that `stage` needs.
    pub fn new(tapes: &LoopFeedback, stage: Stage, backend: Backend) -> Result<Self, ExecError> {
        let first = match stage {
            Stage::Lyapunov => &tapes.sums,
            Stage::Gradient | Stage::Feedback => &tapes.pass,
        };
        let sums = LoopKernel::new(first, backend)?;
        let weights = backend.compile(&tapes.weights)?;
        let last = match stage {
            Stage::Lyapunov => None,
            Stage::Gradient => Some(LoopKernel::new(&tapes.gradient, backend)?),
            Stage::Feedback => Some(LoopKernel::new(&tapes.feedback, backend)?),
        };
        let (n, k) = (tapes.sums.dims().state, tapes.sums.n_outputs());
        let carried = first.n_outputs().saturating_sub(k);
        let w = tapes.weights.dims;
        if w.state != n + k
            || tapes.weights.outputs.len() != 1 + k
            || first.dims() != tapes.sums.dims()
            || first.n_outputs() < k
        {
            return Err(ExecError::Jit(
                "V's stages: the weights' sizes do not match the sums'".into(),
            ));
        }
        if let Some(l) = &last {
            let d = l.dims();
            if d.state != n + 2 * k + carried || d.targets != w.targets || d.gains != w.gains {
                return Err(ExecError::Jit(
                    "V's stages: the last stage's sizes do not match the weights'".into(),
                ));
            }
        }
        let zeros = vec![0.0; w.params];
        let hoisted = [sums.hoist(&zeros)?.len(), weights.hoist(&zeros)?.len()];
        let hoisted_len = hoisted[0]
            + hoisted[1]
            + last
                .as_ref()
                .map_or(Ok(0), |l| l.hoist(&zeros).map(|h| h.len()))?;
        Ok(StagedKernel {
            n_outputs: last.as_ref().map_or(1, |l| l.n_outputs()),
            sums,
            weights,
            last,
            hoisted,
            hoisted_len,
            k,
            carried,
            dims: Dims { state: n, ..w },
        })
    }
}

impl StagedKernel {
    /// The stages in order, `xsw` and `vw` the scratch for `[x, S, C, w]` and `[V, w]`.
    #[allow(clippy::too_many_arguments)]
    fn stages(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        xsw: &mut Vec<f64>,
        vw: &mut Vec<f64>,
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        let (n, k, c) = (self.dims.state, self.k, self.carried);
        let [a, b] = self.hoisted;
        xsw.clear();
        xsw.extend_from_slice(state);
        xsw.resize(n + 2 * k + c, 0.0);
        vw.resize(1 + k, 0.0);
        let (x, rest) = xsw.split_at_mut(n);
        self.sums
            .eval(&hoisted[..a], x, &[], &[], &mut rest[..k + c])?;
        self.weights
            .eval(&hoisted[a..a + b], &xsw[..n + k], target, gains, vw)?;
        match &self.last {
            None => out[0] = vw[0],
            Some(l) => {
                xsw[n + k + c..].copy_from_slice(&vw[1..]);
                l.eval(&hoisted[a + b..], xsw, target, gains, out)?;
            }
        }
        Ok(())
    }
}

impl Kernel for StagedKernel {
    fn dims(&self) -> Dims {
        self.dims
    }

    fn n_outputs(&self) -> usize {
        self.n_outputs
    }

    fn hoist(&self, params: &[f64]) -> Result<Vec<f64>, ExecError> {
        let mut h = self.sums.hoist(params)?;
        h.extend(self.weights.hoist(params)?);
        if let Some(l) = &self.last {
            h.extend(l.hoist(params)?);
        }
        Ok(h)
    }

    fn eval(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        use lasalle_model::tape::expect_len;
        expect_len("hoisted", self.hoisted_len, hoisted.len())?;
        expect_len("state", self.dims.state, state.len())?;
        expect_len("out", self.n_outputs, out.len())?;
        STAGES.with(|cell| {
            let (mut xsw, mut vw) = cell.take();
            let r = self.stages(hoisted, state, target, gains, &mut xsw, &mut vw, out);
            cell.set((xsw, vw));
            r
        })
    }

    /// Lane by lane: each lane is [`Kernel::eval`] of its state, so bitwise equal to it.
    fn eval_lanes(
        &self,
        k: usize,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        lane_by_lane(self, k, hoisted, state, target, gains, out)
    }
}

/// [`Kernel::eval_lanes`] as one [`Kernel::eval`] per lane, so each lane is bitwise that call.
fn lane_by_lane(
    kernel: &dyn Kernel,
    k: usize,
    hoisted: &[f64],
    state: &[f64],
    target: &[f64],
    gains: &[f64],
    out: &mut [f64],
) -> Result<(), ExecError> {
    use lasalle_model::tape::expect_len;
    let (n, m) = (kernel.dims().state, kernel.n_outputs());
    expect_len("state", n * k, state.len())?;
    expect_len("out", m * k, out.len())?;
    let mut x = vec![0.0; n];
    let mut y = vec![0.0; m];
    for lane in 0..k {
        for (i, v) in x.iter_mut().enumerate() {
            *v = state[i * k + lane];
        }
        kernel.eval(hoisted, &x, target, gains, &mut y)?;
        for (j, v) in y.iter().enumerate() {
            out[j * k + lane] = *v;
        }
    }
    Ok(())
}
