//! Functions of a model loaded with its families kept as loops that have no loop form (those
//! the loop form refuses, the compiled steps and lanes on X − ∇V, the analyses that read the
//! model's expressions): built from the unrolled model when one of them is first evaluated,
//! not when the model is loaded. The Taylor programs of the field (also the chaos indicators'
//! staged field of an extension) and of X − ∇V have loop forms
//! ([`crate::taylor::LoopTaylorTape`], [`crate::taylor::LoopFeedbackTaylor`] and their JITs);
//! only where the loop form refuses X − ∇V is its Taylor program built from here.
//!
//! The unrolled model is lowered and derived once ([`Unrolled`]) and its tapes are built once,
//! for all of them ([`LazyTapes`]); each function
//! is a [`Deferred`] kernel that compiles its tape at its first evaluation. Its "hoisted
//! values" are the parameters themselves (nothing is known about the tape before it is
//! built); it hoists the compiled kernel's own values when the parameters change.

use std::sync::{Arc, Mutex, OnceLock};

use lasalle_model::loops::LoopModel;
use lasalle_model::tape::{Dims, ModelTapes, Tape};
use lasalle_model::variational::Extension;
use lasalle_model::{derive, Derived};

use crate::{Backend, ExecError, Kernel};

/// The unrolled model of a [`LoopModel`] (extended by the front end if it is the
/// declarations of an extension), lowered and derived at the first request.
pub(crate) struct Unrolled {
    lm: Arc<LoopModel>,
    extension: Option<Extension>,
    derived: OnceLock<Result<Derived, String>>,
}

impl Unrolled {
    pub(crate) fn new(lm: Arc<LoopModel>) -> Unrolled {
        Unrolled {
            lm,
            extension: None,
            derived: OnceLock::new(),
        }
    }

    /// The unrolled model of an extension whose declarations are `lm`'s
    /// ([`lasalle_model::loops::LoopExtension::loops`]): `extension` applied to `lm`'s
    /// unrolled model.
    pub(crate) fn extended(lm: Arc<LoopModel>, extension: Extension) -> Unrolled {
        Unrolled {
            lm,
            extension: Some(extension),
            derived: OnceLock::new(),
        }
    }

    /// The loop model.
    pub(crate) fn loops(&self) -> &LoopModel {
        &self.lm
    }

    /// The unrolled model with its derivatives (lowered and derived now if not yet).
    pub(crate) fn get(&self) -> Result<&Derived, ExecError> {
        self.derived
            .get_or_init(|| {
                let model = self.lm.unrolled();
                let model = match self.extension {
                    Some(ext) => model.and_then(|m| ext.apply(&m)),
                    None => model,
                };
                model.map(derive).map_err(|e| e.to_string())
            })
            .as_ref()
            .map_err(|e| ExecError::Jit(format!("the unrolled model: {e}")))
    }
}

/// The unrolled model's tapes, built at the first request.
pub(crate) struct LazyTapes {
    unrolled: Unrolled,
    tapes: OnceLock<Result<ModelTapes, String>>,
}

impl LazyTapes {
    pub(crate) fn new(unrolled: Unrolled) -> LazyTapes {
        LazyTapes {
            unrolled,
            tapes: OnceLock::new(),
        }
    }

    /// The unrolled model.
    pub(crate) fn unrolled(&self) -> &Unrolled {
        &self.unrolled
    }

    /// The tapes (built now if not yet).
    pub(crate) fn get(&self) -> Result<&ModelTapes, ExecError> {
        self.tapes
            .get_or_init(|| {
                let derived = self.unrolled.get().map_err(|e| e.to_string())?;
                ModelTapes::new(derived).map_err(|e| e.to_string())
            })
            .as_ref()
            .map_err(|e| ExecError::Jit(format!("the unrolled model's tapes: {e}")))
    }
}

/// Which tape of [`ModelTapes`] a deferred kernel computes.
pub(crate) type Pick = fn(&ModelTapes) -> Option<&Tape>;

/// A kernel compiled from an unrolled tape at its first evaluation.
pub(crate) struct Deferred {
    lazy: Arc<LazyTapes>,
    pick: Pick,
    backend: Backend,
    dims: Dims,
    n_outputs: usize,
    kernel: OnceLock<Result<Box<dyn Kernel>, String>>,
    /// The parameters last seen and the compiled kernel's hoisted values for them.
    hoisted: Mutex<Option<(Vec<f64>, Vec<f64>)>>,
}

impl Deferred {
    /// The function `pick` of `lazy`'s tapes, whose dims and number of outputs are those given
    /// (they must be the tape's: evaluating checks them).
    pub(crate) fn new(
        lazy: Arc<LazyTapes>,
        pick: Pick,
        backend: Backend,
        dims: Dims,
        n_outputs: usize,
    ) -> Deferred {
        Deferred {
            lazy,
            pick,
            backend,
            dims,
            n_outputs,
            kernel: OnceLock::new(),
            hoisted: Mutex::new(None),
        }
    }

    fn kernel(&self) -> Result<&dyn Kernel, ExecError> {
        let k = self.kernel.get_or_init(|| {
            let tapes = self.lazy.get().map_err(|e| e.to_string())?;
            let tape = (self.pick)(tapes).ok_or("the unrolled model has no such function")?;
            if tape.dims != self.dims || tape.outputs.len() != self.n_outputs {
                return Err("the unrolled function's sizes differ from the loaded model's".into());
            }
            self.backend.compile(tape).map_err(|e| e.to_string())
        });
        match k {
            Ok(k) => Ok(k.as_ref()),
            Err(e) => Err(ExecError::Jit(e.clone())),
        }
    }

    /// Runs `f` with the kernel and its hoisted values for `params`.
    fn with<R>(
        &self,
        params: &[f64],
        f: impl FnOnce(&dyn Kernel, &[f64]) -> Result<R, ExecError>,
    ) -> Result<R, ExecError> {
        let k = self.kernel()?;
        let mut cache = self.hoisted.lock().unwrap_or_else(|e| e.into_inner());
        let same = |p: &[f64]| {
            p.len() == params.len()
                && p.iter()
                    .zip(params)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
        };
        match &*cache {
            Some((p, h)) if same(p) => f(k, h),
            _ => {
                let h = k.hoist(params)?;
                let r = f(k, &h);
                *cache = Some((params.to_vec(), h));
                r
            }
        }
    }
}

impl Kernel for Deferred {
    fn dims(&self) -> Dims {
        self.dims
    }

    fn n_outputs(&self) -> usize {
        self.n_outputs
    }

    /// The parameters: the kernel is not compiled yet.
    fn hoist(&self, params: &[f64]) -> Result<Vec<f64>, ExecError> {
        lasalle_model::tape::expect_len("params", self.dims.params, params.len())?;
        Ok(params.to_vec())
    }

    fn eval(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        self.with(hoisted, |k, h| k.eval(h, state, target, gains, out))
    }

    fn eval_lanes(
        &self,
        k: usize,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        self.with(hoisted, |kernel, h| {
            kernel.eval_lanes(k, h, state, target, gains, out)
        })
    }
}
