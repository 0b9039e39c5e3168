//! The tapes of every function of a model, built in the emitter's order.

use super::{Dims, Tape, TapeBuilder, TapeError, TapeTimes};
use crate::derive::{Derivatives, Derived};
use crate::ir::Id;
use crate::model::Model;
use std::time::Duration;

/// Störmer–Verlet's half-fields of a partitioned model (q̇ = a(p), ṗ = b(q)).
#[derive(Clone, Debug)]
pub struct Partition {
    /// `true` at the q components of the state.
    pub is_q: Vec<bool>,
    /// The field components where `is_q`, in order.
    pub field_q: Tape,
    /// The field components where `!is_q`, in order.
    pub field_p: Tape,
}

/// The tapes of a model's functions. Their [`Dims`] are the model's N state components and
/// parameter slots; V, ∇V and X − ∇V also take the M targets and the gains, the other tapes
/// none (targets and gains may appear only in V).
#[derive(Clone, Debug)]
pub struct ModelTapes {
    /// X(x): N outputs.
    pub field: Tape,
    /// f(x), the stacked invariants: M outputs.
    pub invariants: Tape,
    /// Df(x), row-major: M × N outputs, `∂f_c/∂x_i` at `c·N + i`.
    pub jacobian: Tape,
    /// V(x; target, gains): one output.
    pub lyapunov: Tape,
    /// ∇V: N outputs.
    pub lyapunov_gradient: Tape,
    /// X − ∇V: N outputs.
    pub feedback: Tape,
    /// H(x), if the model has a Hamiltonian: one output.
    pub hamiltonian: Option<Tape>,
    /// The half-fields, if the field is partitioned.
    pub partition: Option<Partition>,
}

impl ModelTapes {
    /// The tapes of a derived model (checked or not: checking adds nothing to the graph).
    ///
    /// The tapes are lowered from a copy of its graph in the emitter's order (field,
    /// invariants, Jacobian, V, ∇V, X − ∇V, half-fields; H last, as the emitter has no function
    /// for it), so their results are bitwise the emitted Rust's.
    pub fn new(derived: &Derived) -> Result<ModelTapes, TapeError> {
        Ok(ModelTapes::timed(derived, Duration::default)?.0)
    }

    /// [`ModelTapes::new`], with the time spent in the rewrites for emission
    /// ([`Graph::optimize_for_emission`](crate::ir::Graph::optimize_for_emission): factoring,
    /// shared roots and products, sub-sums) and in lowering the rewritten graphs to tapes, as
    /// measured by `clock` (a monotonic clock of the caller's choice, e.g. the thread's CPU
    /// time; differences of its readings are summed).
    pub fn timed(
        derived: &Derived,
        clock: impl Fn() -> Duration,
    ) -> Result<(ModelTapes, TapeTimes), TapeError> {
        let (model, d) = (&derived.model, &derived.derivatives);
        let dims = Dims {
            state: model.dim(),
            params: model.param_slots(),
            targets: model.invariant_dim(),
            gains: model.gains.len(),
        };
        let lets: Vec<Id> = model
            .lets
            .iter()
            .flat_map(|b| b.value.ids.iter().copied())
            .filter(|&id| !model.graph.children(id).is_empty())
            .collect();
        let plain = Dims {
            targets: 0,
            gains: 0,
            ..dims
        };
        let mut b = TapeBuilder::new(model.graph.clone(), plain).with_lets(lets);
        b.clock = Some(&clock);
        let field = b.build(&model.field)?;
        let invariants = b.build(&model.invariant_ids())?;
        let jacobian = jacobian(&mut b, model, d)?;
        b.set_dims(dims);
        let lyapunov = b.build(&[model.lyapunov])?;
        let lyapunov_gradient = b.build(&d.lyapunov_gradient)?;
        let feedback = b.build(&d.feedback)?;
        b.set_dims(plain);
        let partition = match &d.partition {
            Some(is_q) => {
                let part = |q: bool| -> Vec<Id> {
                    (model.field.iter().zip(is_q))
                        .filter(|(_, &x)| x == q)
                        .map(|(&id, _)| id)
                        .collect()
                };
                Some(Partition {
                    is_q: is_q.clone(),
                    field_q: b.build(&part(true))?,
                    field_p: b.build(&part(false))?,
                })
            }
            None => None,
        };
        let hamiltonian = match &model.hamiltonian {
            Some(h) => Some(b.build(&[h.h])?),
            None => None,
        };
        let times = b.times;
        let tapes = ModelTapes {
            field,
            invariants,
            jacobian,
            lyapunov,
            lyapunov_gradient,
            feedback,
            hamiltonian,
            partition,
        };
        Ok((tapes, times))
    }

    /// Every tape with its name: `field`, `invariants`, `jacobian`, `lyapunov`,
    /// `lyapunov_gradient`, `feedback`, then `hamiltonian`, `field_q`, `field_p` if present.
    pub fn all(&self) -> Vec<(&'static str, &Tape)> {
        let mut out = vec![
            ("field", &self.field),
            ("invariants", &self.invariants),
            ("jacobian", &self.jacobian),
            ("lyapunov", &self.lyapunov),
            ("lyapunov_gradient", &self.lyapunov_gradient),
            ("feedback", &self.feedback),
        ];
        if let Some(h) = &self.hamiltonian {
            out.push(("hamiltonian", h));
        }
        if let Some(p) = &self.partition {
            out.push(("field_q", &p.field_q));
            out.push(("field_p", &p.field_p));
        }
        out
    }
}

/// The Jacobian tape: like the emitter, only the nonzero entries are rewritten and lowered
/// together; the zero entries are constant outputs.
fn jacobian(b: &mut TapeBuilder<'_>, model: &Model, d: &Derivatives) -> Result<Tape, TapeError> {
    let entries: Vec<Id> = d.jacobian.iter().flatten().copied().collect();
    let nonzero: Vec<Id> = entries
        .iter()
        .copied()
        .filter(|&id| model.graph.as_num(id) != Some(0.0))
        .collect();
    let mut tape = b.build(&nonzero)?;
    let mut rows = tape.outputs.clone().into_iter();
    let mut zero = None;
    let mut outputs = Vec::with_capacity(entries.len());
    for &id in &entries {
        if model.graph.as_num(id) == Some(0.0) {
            let z = match zero {
                Some(z) => z,
                None => {
                    let z = match tape
                        .body
                        .iter()
                        .position(|op| matches!(op, super::Op::Const(c) if c.to_bits() == 0))
                    {
                        Some(k) => k,
                        None => {
                            tape.body.push(super::Op::Const(0.0));
                            tape.body.len() - 1
                        }
                    };
                    let z = super::Reg(u32::try_from(z).map_err(|_| TapeError::TooLarge)?);
                    zero = Some(z);
                    z
                }
            };
            outputs.push(z);
        } else {
            outputs.push(rows.next().expect("one output per nonzero entry"));
        }
    }
    tape.outputs = outputs;
    Ok(tape)
}
