//! The Taylor integrator of a model loaded at run time: [`TaylorTape`], the coefficient
//! kernel that interprets a field tape's Taylor recurrences, under the shared driver
//! [`lasalle_runtime::taylor::Taylor`] (order and step of Jorba & Zou, Horner update, dense
//! output, feedback mode; the recurrences and the step control are documented there).
//!
//! The tape is lowered to recurrences by [`TaylorProgram`]. With the JIT back end
//! ([`LoadedModel::taylor_tapes`]) the program is compiled for the order p instead
//! (`crate::jit::taylor::JitTaylor`, 1.2–2.9× faster per step, `cargo bench -p lasalle-exec
//! --bench taylor`), or, when its code would be too large to compile at once, after a run's
//! first 10 000 interpreted computes (`DeferredJit`); compiled models run the same
//! program as emitted Rust. All agree bitwise (`tests/tape_kernels.rs` in the root crate,
//! `exec/tests/taylor.rs`). The driver, its options and the error ([`Taylor`],
//! [`TaylorOptions`], [`TaylorError`]) are the runtime's, re-exported here.
//!
//! # Use
//!
//! ```
//! use lasalle_exec::{Backend, LoadedModel, TaylorOptions};
//! use lasalle_runtime::{integrate, Parameters};
//!
//! let text = "model Osc { state q: scalar, p: scalar; param w = 2;
//!             d/dt q = p; d/dt p = -w^2 * q; integral E = p^2/2 + w^2 * q^2/2;
//!             point start { q = 1; p = 0; } }";
//! let m = LoadedModel::from_source("osc.lsl", text, Backend::Interpreter).unwrap();
//! let mut taylor = m.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
//! let x0 = m.point("start").unwrap();
//! // h = 0: the stepper chooses the first step; then every step is Jorba–Zou's
//! let end = integrate(&mut taylor, &m, &x0, 0.0, 10.0, 0.0, &mut ()).unwrap();
//! assert!((end.x[0] - 20f64.cos()).abs() < 1e-13);
//! ```
//!
//! The feedback field X − ∇V runs through [`Taylor`] as a
//! `Stepper<f64, Vec<f64>, FeedbackField<LoadedModel, Vec<f64>, Vec<f64>>>`, or with the target
//! and gains held by the stepper ([`TaylorField::Feedback`]).

use lasalle_model::loops::ExtendedField;
use lasalle_model::tape::taylor::{Leaf, PowZero, Rec, TaylorProgram};
use lasalle_model::tape::{expect_len, ModelTapes, Tape};
use lasalle_runtime::taylor::rec;
pub use lasalle_runtime::taylor::{
    jorba_zou_step, order_for_tolerance, Taylor, TaylorError, TaylorField, TaylorKernel,
    TaylorKernels, TaylorOptions,
};
use lasalle_runtime::StepError;

use crate::LoadedModel;

pub mod feedback;
pub mod loops;
pub use feedback::LoopFeedbackTaylor;
pub use loops::LoopTaylorTape;

/// The Taylor-coefficient recurrences of one field tape ([`TaylorProgram`]) interpreted over
/// their coefficient table: a [`TaylorKernel`] of [`LoadedModel`].
///
/// Built once per tape ([`TaylorTape::new`]); [`TaylorTape::compute`] fills the coefficients
/// x^\[0..=p\] of the solution of ẋ = tape(x) through a state, without allocating.
#[derive(Clone, Debug)]
pub struct TaylorTape {
    inputs: Inputs,
    program: TaylorProgram,
    max_order: usize,
    stride: usize,
    /// rows × (max_order + 1), row-major.
    table: Vec<f64>,
    /// The order of the last [`TaylorTape::compute`] (0 before any).
    order: usize,
}

/// The inputs of a Taylor kernel other than the state: the hoisted values of the tape's
/// prelude (for the parameters they were computed for), the targets and the gains.
#[derive(Clone, Debug)]
pub(crate) struct Inputs {
    tape: Tape,
    pub(crate) params: Vec<f64>,
    pub(crate) hoisted: Vec<f64>,
    pub(crate) target: Vec<f64>,
    pub(crate) gains: Vec<f64>,
}

/// [`TaylorKernel::set_inputs`] of a kernel whose targets and gains are `into`: copies a
/// run's, checking their lengths.
pub(crate) fn copy_inputs(
    (target, gains): (&[f64], &[f64]),
    into: (&mut [f64], &mut [f64]),
) -> Result<(), StepError> {
    let check = |kind, expected, given| {
        expect_len(kind, expected, given).map_err(|e| StepError::InvalidInput(e.to_string()))
    };
    check("target", into.0.len(), target.len())?;
    check("gains", into.1.len(), gains.len())?;
    into.0.copy_from_slice(target);
    into.1.copy_from_slice(gains);
    Ok(())
}

impl Inputs {
    /// The hoisted values of `tape` for `params`; targets and gains 0.
    pub(crate) fn new(tape: &Tape, params: &[f64]) -> Result<Inputs, TaylorError> {
        Ok(Inputs {
            hoisted: tape.hoist(params).map_err(TaylorError::kernels)?,
            tape: tape.clone(),
            params: params.to_vec(),
            target: vec![0.0; tape.dims.targets],
            gains: vec![0.0; tape.dims.gains],
        })
    }

    fn set_params(&mut self, params: &[f64]) -> Result<(), TaylorError> {
        self.hoisted = self.tape.hoist(params).map_err(TaylorError::kernels)?;
        self.params.clear();
        self.params.extend_from_slice(params);
        Ok(())
    }

    /// [`TaylorKernel::sync`]: reruns the prelude if the model's parameters changed.
    pub(crate) fn sync(&mut self, model: &LoadedModel) -> Result<(), StepError> {
        if model.params() == self.params.as_slice() {
            return Ok(());
        }
        self.set_params(model.params())
            .map_err(|e| StepError::InvalidInput(e.to_string()))
    }

    /// [`TaylorKernel::set_inputs`].
    pub(crate) fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        copy_inputs((target, gains), (&mut self.target, &mut self.gains))
    }
}

impl TaylorTape {
    /// The recurrences of `tape` (state → ẋ, as many outputs as state components) with
    /// parameter values `params`, for orders up to `max_order`. Targets and gains (for
    /// X − ∇V) start at 0; set them with [`TaylorKernel::set_inputs`].
    pub fn new(tape: &Tape, params: &[f64], max_order: u32) -> Result<TaylorTape, TaylorError> {
        let program = TaylorProgram::new(tape).map_err(TaylorError::kernels)?;
        Self::with_program(program, tape, params, max_order)
    }

    /// [`TaylorTape::new`] with the recurrences `program` of `tape` (e.g.
    /// [`TaylorProgram::unfused`], to compare with).
    pub fn with_program(
        program: TaylorProgram,
        tape: &Tape,
        params: &[f64],
        max_order: u32,
    ) -> Result<TaylorTape, TaylorError> {
        let inputs = Inputs::new(tape, params)?;
        if max_order == 0 {
            return Err(TaylorError::Option("the order must be at least 1".into()));
        }
        let stride = max_order as usize + 1;
        Ok(TaylorTape {
            table: vec![0.0; program.rows * stride],
            inputs,
            program,
            max_order: max_order as usize,
            stride,
            order: 0,
        })
    }

    /// Recomputes the hoisted values for new parameter values.
    pub fn set_params(&mut self, params: &[f64]) -> Result<(), TaylorError> {
        self.inputs.set_params(params)
    }

    /// Rows of the coefficient table (state components, registers and internal rows).
    pub fn rows(&self) -> usize {
        self.program.rows
    }

    /// The order of the last [`TaylorTape::compute`].
    pub fn order(&self) -> usize {
        self.order
    }

    /// Computes the normalised Taylor coefficients x^\[0..=order\] of the solution through `x`
    /// (`order ≤ max_order`; the excess is clamped). Allocates nothing.
    ///
    /// # Panics
    /// If `x.len()` is not the state dimension.
    pub fn compute(&mut self, x: &[f64], order: usize) {
        let n = self.program.dim;
        assert_eq!(x.len(), n, "state dimension");
        let order = order.min(self.max_order);
        let stride = self.stride;
        self.order = order;
        let t = &mut self.table[..];
        for (i, &xi) in x.iter().enumerate() {
            t[i * stride] = xi;
        }
        for k in 0..order {
            for &(r, constant) in &self.program.recs {
                if k == 0 {
                    let i = &self.inputs;
                    zeroth(t, stride, r, &i.hoisted, &i.target, &i.gains);
                } else if !constant {
                    coefficient(t, stride, r, k);
                }
            }
            let inv = 1.0 / (k as f64 + 1.0);
            for (i, &o) in self.program.outputs.iter().enumerate() {
                t[i * stride + k + 1] = t[o * stride + k] * inv;
            }
        }
    }

    /// The parameter values, hoisted values, targets and gains the kernel computes with.
    #[cfg(feature = "jit")]
    pub(crate) fn inputs(&self) -> &Inputs {
        &self.inputs
    }

    /// The coefficients x_i^\[0..=order\] of state component `i` from the last
    /// [`TaylorTape::compute`].
    pub fn state_coefficients(&self, i: usize) -> &[f64] {
        &self.table[i * self.stride..i * self.stride + self.order + 1]
    }
}

impl TaylorKernel<LoadedModel> for TaylorTape {
    fn dim(&self) -> usize {
        self.program.dim
    }

    fn max_order(&self) -> usize {
        self.max_order
    }

    /// Reruns the prelude if the model's parameters changed since the last call.
    fn sync(&mut self, model: &LoadedModel) -> Result<(), StepError> {
        self.inputs.sync(model)
    }

    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        self.inputs.set_inputs(target, gains)
    }

    fn compute(&mut self, x: &[f64], order: usize) {
        TaylorTape::compute(self, x, order);
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        self.state_coefficients(i)
    }
}

impl LoadedModel {
    /// The Taylor kernels of the model's field and of X − ∇V, with its current parameters,
    /// for orders up to `max_order`, from the model's tapes (lowered again).
    /// With the JIT back end (the default with the `jit` feature) the recurrences are compiled
    /// for the order `max_order` (`lasalle_exec::jit::taylor::JitTaylor`), or, above its size
    /// budget, interpreted first and compiled after `DEFER_COMPUTES` computes
    /// (`lasalle_exec::jit::taylor::DeferredJit`); with the interpreter back end they are
    /// interpreted ([`TaylorTape`]). All compute the same coefficients, bitwise.
    ///
    /// A model loaded with its families kept as loops has the loop form of the field's
    /// program ([`LoopTaylorTape`], or its JIT, `lasalle_exec::jit::taylor::JitLoopTaylor`)
    /// and of the program of X − ∇V, its three stages propagated as Taylor series
    /// ([`LoopFeedbackTaylor`], or its JIT, `lasalle_exec::jit::taylor::JitLoopFeedbackTaylor`).
    /// The chaos indicators' field of a loop-form extension ([`LoadedModel::extended`]) is
    /// staged as X − ∇V is, and its program is the same staged kernel on its stages.
    /// Where the loop form refuses X − ∇V (V reading a family through a guard), its program
    /// is built from the unrolled model when a feedback run first sets its inputs
    /// ([`TaylorKernel::set_inputs`]).
    pub fn taylor_tapes(&self, max_order: u32) -> Result<TaylorKernels<LoadedModel>, TaylorError> {
        if let Some((field, staged, lazy)) = self.loop_taylor() {
            let feedback: Box<dyn TaylorKernel<LoadedModel>> = match staged {
                Some(fb) => self.loop_feedback_kernel(fb, max_order)?,
                None => Box::new(loops::DeferredFeedback::new(
                    lazy,
                    self.backend(),
                    self.params(),
                    self.dim(),
                    max_order,
                )?),
            };
            let field = match field {
                ExtendedField::Loop(tape) => self.loop_taylor_kernel(tape, max_order)?,
                // the chaos indicators' field: stages as those of X − ∇V
                ExtendedField::Staged(stages) => self.loop_feedback_kernel(stages, max_order)?,
            };
            return Ok(TaylorKernels { field, feedback });
        }
        let derived = self.derived().map_err(TaylorError::kernels)?;
        let tapes = ModelTapes::new(derived).map_err(TaylorError::kernels)?;
        Ok(TaylorKernels {
            field: self.taylor_kernel(&tapes.field, max_order)?,
            feedback: self.taylor_kernel(&tapes.feedback, max_order)?,
        })
    }

    /// The kernel of the field X at the order `order` on several orbits at once
    /// ([`TaylorLanes`](lasalle_runtime::TaylorLanes)), where lanes pay: the JIT back end, the
    /// unrolled form, a program small enough to compile at once
    /// (`lasalle_exec::jit::taylor::JitTaylorBatch`); `Ok(None)` otherwise, and the orbits run
    /// one by one.
    pub fn taylor_batch(
        &self,
        order: u32,
    ) -> Result<Option<Box<dyn lasalle_runtime::TaylorBatch<LoadedModel>>>, TaylorError> {
        #[cfg(feature = "jit")]
        if self.backend() == crate::Backend::Jit && self.loop_taylor().is_none() {
            let derived = self.derived().map_err(TaylorError::kernels)?;
            let tapes = ModelTapes::new(derived).map_err(TaylorError::kernels)?;
            let batch =
                crate::jit::taylor::JitTaylorBatch::new(&tapes.field, self.params(), order)?;
            return Ok(batch.map(|b| Box::new(b) as _));
        }
        let _ = order;
        Ok(None)
    }

    /// The kernel of a loop field for this model's back end.
    fn loop_taylor_kernel(
        &self,
        tape: &lasalle_model::loops::LoopTape,
        max_order: u32,
    ) -> Result<Box<dyn TaylorKernel<LoadedModel>>, TaylorError> {
        #[cfg(feature = "jit")]
        if self.backend() == crate::Backend::Jit {
            return Ok(Box::new(crate::jit::taylor::JitLoopTaylor::new(
                tape,
                self.params(),
                max_order,
            )?));
        }
        Ok(Box::new(LoopTaylorTape::new(
            tape,
            self.params(),
            max_order,
        )?))
    }

    /// The kernel of X − ∇V in loop form for this model's back end.
    fn loop_feedback_kernel(
        &self,
        tapes: &lasalle_model::loops::LoopFeedback,
        max_order: u32,
    ) -> Result<Box<dyn TaylorKernel<LoadedModel>>, TaylorError> {
        #[cfg(feature = "jit")]
        if self.backend() == crate::Backend::Jit {
            return Ok(Box::new(crate::jit::taylor::JitLoopFeedbackTaylor::new(
                tapes,
                self.params(),
                max_order,
            )?));
        }
        Ok(Box::new(LoopFeedbackTaylor::new(
            tapes,
            self.params(),
            max_order,
        )?))
    }

    /// The kernel of one field tape for this model's back end (see
    /// [`LoadedModel::taylor_tapes`]).
    fn taylor_kernel(
        &self,
        tape: &Tape,
        max_order: u32,
    ) -> Result<Box<dyn TaylorKernel<LoadedModel>>, TaylorError> {
        kernel_of(tape, self.backend(), self.params(), max_order)
    }

    /// The adaptive Taylor integrator of the model (mode [`TaylorField::Plain`]), its kernels
    /// sized for the order of `opts`.
    pub fn taylor(&self, opts: TaylorOptions) -> Result<Taylor<LoadedModel>, TaylorError> {
        let order = opts.checked_order()?;
        Taylor::new(self.taylor_tapes(order)?, opts)
    }
}

/// The kernel of one field tape for `backend` (see [`LoadedModel::taylor_tapes`]).
pub(crate) fn kernel_of(
    tape: &Tape,
    backend: crate::Backend,
    params: &[f64],
    max_order: u32,
) -> Result<Box<dyn TaylorKernel<LoadedModel>>, TaylorError> {
    #[cfg(feature = "jit")]
    if backend == crate::Backend::Jit {
        use crate::jit::taylor::{DeferredJit, JitTaylor};
        return Ok(match JitTaylor::new(tape, params, max_order)? {
            Some(k) => Box::new(k),
            None => Box::new(DeferredJit::new(tape, params, max_order)?),
        });
    }
    let _ = backend;
    Ok(Box::new(TaylorTape::new(tape, params, max_order)?))
}

/// A row of the table.
#[inline(always)]
fn row(t: &[f64], stride: usize, r: usize) -> &[f64] {
    &t[r * stride..(r + 1) * stride]
}

/// Order 0: the instruction's own f64 operation (the tape's value).
#[inline]
pub(crate) fn zeroth(
    t: &mut [f64],
    s: usize,
    r: Rec,
    hoisted: &[f64],
    target: &[f64],
    gains: &[f64],
) {
    match r {
        Rec::Leaf { d, leaf } => {
            t[d * s] = match leaf {
                Leaf::Const(c) => c,
                Leaf::Hoisted(k) => hoisted[k],
                Leaf::Target(k) => target[k],
                Leaf::Gain(k) => gains[k],
            }
        }
        Rec::Add { d, a, b } => t[d * s] = t[a * s] + t[b * s],
        Rec::Sub { d, a, b } => t[d * s] = t[a * s] - t[b * s],
        Rec::Neg { d, a } => t[d * s] = -t[a * s],
        Rec::Mul { d, a, b } => t[d * s] = t[a * s] * t[b * s],
        Rec::Scale { d, a, c } => t[d * s] = t[a * s] * t[c * s],
        Rec::Square { d, a } => t[d * s] = t[a * s] * t[a * s],
        Rec::Div { d, a, b } => t[d * s] = t[a * s] / t[b * s],
        Rec::DivConst { d, a, c } => t[d * s] = t[a * s] / t[c * s],
        Rec::Pow { d, a, zero, .. } => {
            t[d * s] = match zero {
                PowZero::Cbrt => t[a * s].cbrt(),
                PowZero::Powf(p) => t[a * s].powf(p),
                // order 0 is the fused chain's
                PowZero::Fused => return,
            }
        }
        Rec::Sqrt { d, a } => t[d * s] = t[a * s].sqrt(),
        Rec::Exp { d, a } => t[d * s] = t[a * s].exp(),
        Rec::Ln { d, a } => t[d * s] = t[a * s].ln(),
        Rec::SinCos { s: rs, c, a } => {
            let (sa, ca) = t[a * s].sin_cos();
            t[rs * s] = sa;
            t[c * s] = ca;
        }
        Rec::Jacobi { rows, a, m } => {
            let j = lasalle_runtime::elliptic::ellipj(t[a * s], t[m * s]);
            for (r, v) in
                rows.into_iter()
                    .zip([j.sn, j.cn, j.dn, j.cn * j.dn, j.sn * j.dn, j.sn * j.cn])
            {
                t[r * s] = v;
            }
        }
        Rec::EllipK { d, a } => t[d * s] = lasalle_runtime::elliptic::ellipk(t[a * s]),
        Rec::EllipF { d, a, m, .. } => {
            t[d * s] = lasalle_runtime::elliptic::ellipf(t[a * s], t[m * s])
        }
    }
}

/// Order k ≥ 1 of a non-constant instruction ([`rec`]).
#[inline]
pub(crate) fn coefficient(t: &mut [f64], s: usize, r: Rec, k: usize) {
    let (d, v) = match r {
        Rec::Leaf { .. } => return,
        Rec::Add { d, a, b } => (d, t[a * s + k] + t[b * s + k]),
        Rec::Sub { d, a, b } => (d, t[a * s + k] - t[b * s + k]),
        Rec::Neg { d, a } => (d, -t[a * s + k]),
        Rec::Mul { d, a, b } => (d, rec::mul(row(t, s, a), row(t, s, b), k)),
        Rec::Scale { d, a, c } => (d, t[a * s + k] * t[c * s]),
        Rec::Square { d, a } => (d, rec::square(row(t, s, a), k)),
        Rec::Div { d, a, b } => (d, rec::div(row(t, s, a), row(t, s, b), row(t, s, d), k)),
        Rec::DivConst { d, a, c } => (d, t[a * s + k] / t[c * s]),
        Rec::Pow { d, a, alpha, .. } => (d, rec::pow(row(t, s, a), row(t, s, d), alpha, k)),
        Rec::Sqrt { d, a } => (d, rec::sqrt(row(t, s, a), row(t, s, d), k)),
        Rec::Exp { d, a } => (d, rec::exp(row(t, s, a), row(t, s, d), k)),
        Rec::Ln { d, a } => (d, rec::ln(row(t, s, a), row(t, s, d), k)),
        Rec::SinCos { s: rs, c, a } => {
            let (sk, ck) = rec::sin_cos(row(t, s, a), row(t, s, rs), row(t, s, c), k);
            t[rs * s + k] = sk;
            t[c * s + k] = ck;
            return;
        }
        Rec::Jacobi { rows, a, m } => {
            let [sn, cn, dn, cd, sd, sc] = rows;
            let (r, m) = (|i| row(t, s, i), t[m * s]);
            let (sk, ck, dk) = rec::jacobi(r(a), r(cd), r(sd), r(sc), m, k);
            t[sn * s + k] = sk;
            t[cn * s + k] = ck;
            t[dn * s + k] = dk;
            t[cd * s + k] = rec::mul(row(t, s, cn), row(t, s, dn), k);
            t[sd * s + k] = rec::mul(row(t, s, sn), row(t, s, dn), k);
            t[sc * s + k] = rec::mul(row(t, s, sn), row(t, s, cn), k);
            return;
        }
        Rec::EllipK { .. } => return, // constant along the solution
        Rec::EllipF { d, a, w, .. } => (d, rec::chain(row(t, s, a), row(t, s, w), k)),
    };
    t[d * s + k] = v;
}
