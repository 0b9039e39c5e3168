//! # lasalle-exec
//!
//! Execution back ends for the register tapes of `lasalle_model::tape`: an interpreter
//! ([`interp`]) and, with the `jit` feature (default), a Cranelift JIT (`jit`). Both compute
//! what the tape computes in f64, bitwise: every tape instruction is one IEEE operation or a
//! call of the `std` function the emitted Rust calls.
//!
//! A tape is compiled once into a [`Kernel`]. Its prelude (the parameter-only instructions)
//! runs once per parameter set ([`Kernel::hoist`]); the body runs per state ([`Kernel::eval`])
//! or for k states at once ([`Kernel::eval_lanes`]).
//!
//! ```
//! use lasalle_model::{derive, tape::ModelTapes};
//! use lasalle_exec::Backend;
//!
//! let text = "model Osc { state q: scalar, p: scalar; param w = 2;
//!             d/dt q = p; d/dt p = -w^2 * q; integral E = p^2/2 + w^2 * q^2/2; }";
//! let derived = derive(lasalle_model::lower_source("osc.lsl", text).unwrap());
//! let tapes = ModelTapes::new(&derived).unwrap();
//! let field = Backend::default().compile(&tapes.field).unwrap();
//! let hoisted = field.hoist(&derived.model.default_params()).unwrap();
//! let mut dx = [0.0; 2];
//! field.eval(&hoisted, &[1.0, 0.5], &[], &[], &mut dx).unwrap();
//! assert_eq!(dx, [0.5, -4.0]);
//! ```
#![warn(missing_docs)]

mod deferred;
pub mod ensemble;
mod intern;
pub mod interp;
#[cfg(feature = "jit")]
pub mod jit;
pub mod loops;
pub mod model;
pub mod taylor;

pub use ensemble::{FeedbackLanes, LaneField, Lanes, PackError};
pub use intern::{interned, Interned};
pub use lasalle_model::loops::{Families, LoopModel};
pub use loops::{LoopKernel, Stage, StagedKernel};
pub use model::{LoadError, LoadedModel};
pub use taylor::{
    LoopFeedbackTaylor, LoopTaylorTape, Taylor, TaylorError, TaylorField, TaylorOptions, TaylorTape,
};

pub use lasalle_model::tape::{Dims, Op, Reg, Tape, TapeError};

/// What can go wrong compiling or running a tape.
#[derive(Debug, thiserror::Error)]
pub enum ExecError {
    /// The tape is malformed, or an argument has the wrong length.
    #[error(transparent)]
    Tape(#[from] TapeError),
    /// The JIT was asked for but this build has no `jit` feature.
    #[error("the JIT back end is not compiled in: enable the `jit` feature of lasalle-exec")]
    JitUnavailable,
    /// Cranelift could not compile the tape (or does not support this machine).
    #[error("JIT compilation failed: {0}")]
    Jit(String),
}

/// A compiled tape.
///
/// All methods take `&self` and are thread-safe; none allocates except [`Kernel::hoist`] (the
/// interpreter evaluates on the stack, or for large tapes into a thread-local scratch buffer
/// that grows once per thread).
pub trait Kernel: Send + Sync {
    /// Input sizes of the tape.
    fn dims(&self) -> Dims;

    /// Number of outputs.
    fn n_outputs(&self) -> usize;

    /// Runs the prelude: the hoisted values for a parameter set (`params.len() ==
    /// dims().params`), to pass to this kernel's [`Kernel::eval`] and [`Kernel::eval_lanes`].
    /// A back end may append values of its own after the tape's hoisted values (the JIT's
    /// vector slots), so the result is for this kernel only.
    fn hoist(&self, params: &[f64]) -> Result<Vec<f64>, ExecError>;

    /// `out = f(state; target, gains, hoisted)` for one state.
    fn eval(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError>;

    /// [`Kernel::eval`] without the argument checks, for callers that fix the lengths once
    /// (as [`LoadedModel`] does) and call many times. The default runs [`Kernel::eval`] (and
    /// writes NaN on an error); the back ends skip the checks.
    ///
    /// # Safety
    ///
    /// `hoisted` must have the length of what [`Kernel::hoist`] returns, `state` `dims().state`,
    /// `target` `dims().targets`, `gains` `dims().gains` and `out` [`Kernel::n_outputs`]: the
    /// back ends read and write those ranges without bounds checks.
    unsafe fn eval_unchecked(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) {
        if self.eval(hoisted, state, target, gains, out).is_err() {
            out.iter_mut().for_each(|v| *v = f64::NAN);
        }
    }

    /// The compiled code of [`Kernel::eval`] as a plain function, if the back end has one (the
    /// JIT): a caller that checks the lengths once can then call it directly, without the
    /// virtual call and the checks. The pointer is valid while `self` is alive; calling it has
    /// the safety requirements of [`Kernel::eval_unchecked`], with the slices passed as their
    /// start pointers.
    fn raw_eval(&self) -> Option<RawEval> {
        None
    }

    /// For a step tape compiled with [`Backend::compile_step`], its batch of steps as a plain
    /// function, if the back end compiles one (the JIT; see
    /// [`lasalle_runtime::RawBatch`]). Valid while `self` is alive.
    fn raw_batch(&self) -> Option<lasalle_runtime::RawBatch> {
        None
    }

    /// k states at once, structure of arrays: component i of state `lane` at
    /// `state[i*k + lane]`, output j at `out[j*k + lane]`; targets, gains and hoisted values
    /// are shared. Each lane's outputs equal [`Kernel::eval`]'s bitwise.
    fn eval_lanes(
        &self,
        k: usize,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError>;
}

/// The code of [`Kernel::eval`] as a function of the start pointers of `hoisted`, `state`,
/// `target`, `gains` and `out` (see [`Kernel::raw_eval`]).
pub type RawEval = unsafe extern "C" fn(*const f64, *const f64, *const f64, *const f64, *mut f64);

/// Which back end compiles a tape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Backend {
    /// Native code through Cranelift (feature `jit`).
    Jit,
    /// A loop over the instructions.
    Interpreter,
}

impl Default for Backend {
    /// The JIT when the `jit` feature is on, else the interpreter.
    fn default() -> Self {
        if cfg!(feature = "jit") {
            Backend::Jit
        } else {
            Backend::Interpreter
        }
    }
}

impl Backend {
    /// The back ends compiled into this build.
    pub fn available() -> &'static [Backend] {
        if cfg!(feature = "jit") {
            &[Backend::Jit, Backend::Interpreter]
        } else {
            &[Backend::Interpreter]
        }
    }

    /// Compiles a tape (after checking that it is well formed).
    pub fn compile(self, tape: &Tape) -> Result<Box<dyn Kernel>, ExecError> {
        tape.validate()?;
        match self {
            Backend::Interpreter => Ok(Box::new(interp::Interpreter::new(tape)?)),
            #[cfg(feature = "jit")]
            Backend::Jit => Ok(Box::new(jit::JitKernel::new(tape)?)),
            #[cfg(not(feature = "jit"))]
            Backend::Jit => Err(ExecError::JitUnavailable),
        }
    }
}

impl Backend {
    /// Compiles a step tape (`lasalle_model::tape::step`) whose first `n` outputs are the new
    /// state and the others the guards' margins (`strict` per margin): as
    /// [`Backend::compile`], and the JIT also compiles the loop of a batch of steps
    /// ([`Kernel::raw_batch`]).
    pub fn compile_step(
        self,
        tape: &Tape,
        n: usize,
        strict: &[bool],
    ) -> Result<Box<dyn Kernel>, ExecError> {
        match self {
            #[cfg(feature = "jit")]
            Backend::Jit => {
                tape.validate()?;
                Ok(Box::new(jit::JitKernel::with_batch(tape, n, strict)?))
            }
            _ => self.compile(tape),
        }
    }
}

/// What every kernel keeps besides its code: sizes and the prelude, with argument checks.
#[derive(Clone, Debug)]
pub(crate) struct Common {
    dims: Dims,
    n_hoisted: usize,
    n_outputs: usize,
    /// The tape without its body: the prelude and the hoisted registers.
    prelude: Tape,
}

impl Common {
    pub(crate) fn new(tape: &Tape) -> Common {
        Common {
            dims: tape.dims,
            n_hoisted: tape.hoisted.len(),
            n_outputs: tape.outputs.len(),
            prelude: Tape {
                prelude: tape.prelude.clone(),
                hoisted: tape.hoisted.clone(),
                body: Vec::new(),
                outputs: Vec::new(),
                dims: tape.dims,
            },
        }
    }

    /// The same, for a kernel whose [`Kernel::hoist`] appends `n` values to the tape's.
    #[cfg(feature = "jit")]
    pub(crate) fn with_extra_hoisted(mut self, n: usize) -> Common {
        self.n_hoisted += n;
        self
    }

    pub(crate) fn dims(&self) -> Dims {
        self.dims
    }

    pub(crate) fn n_outputs(&self) -> usize {
        self.n_outputs
    }

    pub(crate) fn hoist(&self, params: &[f64]) -> Result<Vec<f64>, ExecError> {
        Ok(self.prelude.hoist(params)?)
    }

    /// Checks the lengths of the arguments of `eval_lanes` (k = 1 for `eval`).
    pub(crate) fn check(
        &self,
        k: usize,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &[f64],
    ) -> Result<(), ExecError> {
        use lasalle_model::tape::expect_len;
        let d = self.dims;
        // Byte offsets of lanes (8k) must fit in a usize.
        k.checked_mul(8).ok_or(TapeError::TooLarge)?;
        let times = |n: usize| n.checked_mul(k).ok_or(TapeError::TooLarge);
        expect_len("hoisted", self.n_hoisted, hoisted.len())?;
        expect_len("state", times(d.state)?, state.len())?;
        expect_len("target", d.targets, target.len())?;
        expect_len("gains", d.gains, gains.len())?;
        expect_len("out", times(self.n_outputs)?, out.len())?;
        Ok(())
    }
}
