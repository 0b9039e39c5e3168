//! [`Reusing`]: a loaded model whose Taylor kernels outlive a run.
//!
//! Building a loaded model's Taylor kernels (lowering its tapes again and compiling the
//! recurrences of X and of X − ∇V for the order of the tolerance) costs milliseconds, while a
//! Taylor run of a few hundred steps costs a fraction of one. [`simulate`](crate::simulate) of
//! a [`Reusing`] model takes the kernels from its [`KernelPool`] when the pool has some for
//! the order, and puts them back when the run ends, so the runs of an ensemble on one thread
//! build them once. A kernel's results do not depend on the runs it served before (it reads
//! the model's parameters before every step and is given the targets and gains of every
//! feedback step), so each run's recording is bitwise the one with new kernels.

use std::sync::{Arc, Mutex};

use lasalle_exec::LoadedModel;
use lasalle_runtime::{
    CompiledStep, Declared, EventSpec, Field, FixedMethod, GuardFailure, InvariantInfo, Invariants,
    Lyapunov, ModelInfo, Partitioned, Preset, Slot, Splitting, StepError, TaylorBatch, TaylorError,
    TaylorKernel, TaylorKernels,
};

/// A Taylor kernel of a loaded model.
type Kernel = Box<dyn TaylorKernel<LoadedModel>>;

/// A batch kernel of a loaded model's field ([`TaylorLanes`](lasalle_runtime::TaylorLanes)).
pub(crate) type BatchKernel = Box<dyn TaylorBatch<LoadedModel>>;

/// A pool's batch kernel of one order.
enum Batch {
    /// The model has none (lanes do not apply to it).
    Refused,
    /// Built and waiting.
    Free(BatchKernel),
}

/// Taylor kernels of one loaded model (or of copies of it) kept between runs, by order.
#[derive(Default)]
pub struct KernelPool {
    /// (order, kernel of X, kernel of X − ∇V).
    free: Mutex<Vec<(u32, Kernel, Kernel)>>,
    /// The batch kernels of X, by order.
    batches: Mutex<Vec<(u32, Batch)>>,
}

impl std::fmt::Debug for KernelPool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let orders: Vec<u32> = self.lock().iter().map(|(p, _, _)| *p).collect();
        f.debug_struct("KernelPool")
            .field("orders", &orders)
            .finish()
    }
}

impl KernelPool {
    /// An empty pool.
    pub fn new() -> Arc<KernelPool> {
        Arc::new(KernelPool::default())
    }

    /// The number of kernel pairs waiting in the pool.
    pub fn len(&self) -> usize {
        self.lock().len()
    }

    /// No kernels in the pool.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The batch kernel of the order `order`: a waiting one, else `build`'s (`None`, and never
    /// built again for this order, if the model has none).
    pub(crate) fn take_batch(
        &self,
        order: u32,
        build: impl FnOnce() -> Option<BatchKernel>,
    ) -> Option<BatchKernel> {
        let lock = || self.batches.lock().unwrap_or_else(|p| p.into_inner());
        let mut batches = lock();
        if let Some(at) = batches.iter().position(|(o, _)| *o == order) {
            return match batches.swap_remove(at).1 {
                Batch::Refused => {
                    batches.push((order, Batch::Refused));
                    None
                }
                Batch::Free(kernel) => Some(kernel),
            };
        }
        drop(batches);
        let kernel = build();
        if kernel.is_none() {
            lock().push((order, Batch::Refused));
        }
        kernel
    }

    /// Puts back a batch kernel of the order `order`.
    pub(crate) fn put_batch(&self, order: u32, kernel: BatchKernel) {
        let mut batches = self.batches.lock().unwrap_or_else(|p| p.into_inner());
        batches.push((order, Batch::Free(kernel)));
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<(u32, Kernel, Kernel)>> {
        self.free
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

/// A kernel lent by a [`KernelPool`] to one run; back to the pool when the run drops it.
struct Lent {
    order: u32,
    field: bool,
    kernel: Option<Kernel>,
    /// The other kernel of the pair, once it has been returned first.
    pair: Arc<Mutex<Option<Kernel>>>,
    pool: Arc<KernelPool>,
}

impl Lent {
    fn kernel(&self) -> &Kernel {
        self.kernel.as_ref().expect("present until dropped")
    }

    fn kernel_mut(&mut self) -> &mut Kernel {
        self.kernel.as_mut().expect("present until dropped")
    }
}

impl Drop for Lent {
    fn drop(&mut self) {
        let Some(kernel) = self.kernel.take() else {
            return;
        };
        let mut pair = self.pair.lock().unwrap_or_else(|p| p.into_inner());
        match pair.take() {
            // the second of the pair: both go back
            Some(other) => {
                let (field, feedback) = if self.field {
                    (kernel, other)
                } else {
                    (other, kernel)
                };
                self.pool.lock().push((self.order, field, feedback));
            }
            None => *pair = Some(kernel),
        }
    }
}

impl<'a> TaylorKernel<Reusing<'a>> for Lent {
    fn dim(&self) -> usize {
        self.kernel().dim()
    }

    fn max_order(&self) -> usize {
        self.kernel().max_order()
    }

    fn sync(&mut self, model: &Reusing<'a>) -> Result<(), StepError> {
        self.kernel_mut().sync(model.model)
    }

    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        self.kernel_mut().set_inputs(target, gains)
    }

    fn compute(&mut self, x: &[f64], order: usize) {
        self.kernel_mut().compute(x, order)
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        self.kernel().coefficients(i)
    }
}

/// A loaded model that takes its Taylor kernels from a [`KernelPool`]; everything else is the
/// model's own.
///
/// Building a loaded model's Taylor kernels (lowering its tapes again and compiling the
/// recurrences of X and of X − ∇V for the order of the tolerance) costs milliseconds, while a
/// Taylor run of a few hundred steps costs a fraction of one. [`simulate`](crate::simulate) of
/// a `Reusing` model takes the kernels from the pool when it has some for the order, and puts
/// them back when the run ends. A kernel's results do not depend on the runs it served before
/// (it reads the model's parameters before every step and is given the targets and gains of
/// every feedback step), so each recording is bitwise the one with new kernels.
#[derive(Clone, Copy, Debug)]
pub struct Reusing<'a> {
    model: &'a LoadedModel,
    pool: &'a Arc<KernelPool>,
}

impl<'a> Reusing<'a> {
    /// `model` with the kernels of `pool`, which must hold kernels of this model only (or of
    /// models loaded from the same text: the kernels read the parameters of the model they
    /// run).
    pub fn new(model: &'a LoadedModel, pool: &'a Arc<KernelPool>) -> Self {
        Reusing { model, pool }
    }

    /// The model.
    pub fn model(&self) -> &'a LoadedModel {
        self.model
    }
}

impl Field<f64, Vec<f64>> for Reusing<'_> {
    #[inline]
    fn field(&self, x: &Vec<f64>, dx: &mut Vec<f64>) {
        self.model.field(x, dx)
    }
}

impl Invariants<f64, Vec<f64>, Vec<f64>> for Reusing<'_> {
    #[inline]
    fn invariant_dim(&self) -> usize {
        self.model.invariant_dim()
    }
    #[inline]
    fn invariants(&self, x: &Vec<f64>, f: &mut Vec<f64>) {
        self.model.invariants(x, f)
    }
    #[inline]
    fn invariants_jacobian(&self, x: &Vec<f64>, jac: &mut Vec<Vec<f64>>) {
        self.model.invariants_jacobian(x, jac)
    }
}

impl Lyapunov<f64, Vec<f64>, Vec<f64>, Vec<f64>> for Reusing<'_> {
    #[inline]
    fn lyapunov(&self, x: &Vec<f64>, target: &Vec<f64>, gains: &Vec<f64>) -> f64 {
        self.model.lyapunov(x, target, gains)
    }
    #[inline]
    fn lyapunov_gradient(
        &self,
        x: &Vec<f64>,
        target: &Vec<f64>,
        gains: &Vec<f64>,
        grad: &mut Vec<f64>,
    ) {
        self.model.lyapunov_gradient(x, target, gains, grad)
    }
    #[inline]
    fn feedback_field(&self, x: &Vec<f64>, target: &Vec<f64>, gains: &Vec<f64>, dx: &mut Vec<f64>) {
        self.model.feedback_field(x, target, gains, dx)
    }
}

impl ModelInfo for Reusing<'_> {
    fn model_name(&self) -> &'static str {
        self.model.model_name()
    }
    fn state_slots(&self) -> &'static [Slot] {
        self.model.state_slots()
    }
    fn invariant_infos(&self) -> &'static [InvariantInfo] {
        self.model.invariant_infos()
    }
    fn gain_names(&self) -> &'static [&'static str] {
        self.model.gain_names()
    }
    fn default_gain_values(&self) -> &'static [f64] {
        self.model.default_gain_values()
    }
    fn param_slots(&self) -> &'static [Slot] {
        self.model.param_slots()
    }
    fn state_dim(&self) -> usize {
        self.model.state_dim()
    }
}

impl<'a> Declared<f64, Vec<f64>> for Reusing<'a> {
    fn presets(&self) -> &'static [Preset] {
        self.model.presets()
    }

    #[inline]
    fn check_guards(&self, x: &Vec<f64>, dt: f64) -> Option<GuardFailure> {
        self.model.check_guards(x, dt)
    }

    fn partitioned(&self) -> Option<&dyn Partitioned<f64, Vec<f64>>> {
        self.model.partitioned()
    }

    fn splitting(&self) -> Option<Splitting<f64>> {
        self.model.splitting()
    }

    fn compiled_step(
        &self,
        method: &FixedMethod<'_>,
        feedback: Option<(&[f64], &[f64])>,
        guard_step: f64,
    ) -> Option<CompiledStep> {
        self.model.compiled_step(method, feedback, guard_step)
    }

    fn events(&self) -> &'static [EventSpec] {
        self.model.events()
    }

    #[inline]
    fn event_values(&self, x: &Vec<f64>, t: f64, g: &mut [f64]) {
        self.model.event_values(x, t, g)
    }

    /// The pool's kernels for `max_order`, else new ones; back to the pool after the run.
    fn taylor_kernels(&self, max_order: u32) -> Result<TaylorKernels<Self>, TaylorError> {
        let pooled = {
            let mut free = self.pool.lock();
            free.iter()
                .position(|(p, _, _)| *p == max_order)
                .map(|i| free.swap_remove(i))
        };
        let (field, feedback) = match pooled {
            Some((_, field, feedback)) => (field, feedback),
            None => {
                let k = self.model.taylor_kernels(max_order)?;
                (k.field, k.feedback)
            }
        };
        let pair = Arc::new(Mutex::new(None));
        let lend = |kernel, field| -> Box<dyn TaylorKernel<Self>> {
            Box::new(Lent {
                order: max_order,
                field,
                kernel: Some(kernel),
                pair: pair.clone(),
                pool: self.pool.clone(),
            })
        };
        Ok(TaylorKernels {
            field: lend(field, true),
            feedback: lend(feedback, false),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{simulate, RunSpec};
    use lasalle_exec::Backend;
    use lasalle_runtime::Parameters;

    #[test]
    fn reused_kernels_give_the_bits_of_new_ones() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/kepler.lsl");
        let mut model = LoadedModel::load(path, Backend::Jit).unwrap();
        let pool = KernelPool::new();
        for method in ["taylor", "feedback-taylor", "split-taylor"] {
            let spec = RunSpec::builder()
                .method(method.parse().unwrap())
                .t_end(30.0)
                .rtol(1e-14)
                .build()
                .unwrap();
            for (mu, speed) in [(1.0, 1.2), (0.9, 1.1), (1.0, 1.3)] {
                model.set_param("mu", &[mu]).unwrap();
                let x0 = vec![1.0, 0.0, 0.0, 0.0, speed, 0.0];
                let new = simulate(&model, &x0, &spec).unwrap();
                let reused = simulate(&Reusing::new(&model, &pool), &x0, &spec).unwrap();
                assert_eq!(pool.len(), 1, "the pair went back to the pool");
                assert!(new.failure.is_none() && new.steps > 20);
                assert_eq!(new.x, reused.x, "{method}, mu = {mu}");
                assert_eq!(new.errors, reused.errors);
                assert_eq!(new.steps, reused.steps);
            }
        }
    }
}
