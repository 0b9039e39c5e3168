//! Stage 3: derivatives. The model's Jacobian Df, the Lie derivatives ∇f·X, ∇V (reverse mode)
//! and the feedback field X − ∇V, by the graph operations [`ir::diff`](crate::ir::diff) and
//! [`ir::gradient`](crate::ir::gradient).

use crate::ir::{diff, gradient, jacobian, Id, Input, LARGE_GRAPH};
use std::collections::HashMap;

/// Everything the emitter needs beyond the model itself.
#[derive(Clone, Debug)]
pub struct Derivatives {
    /// Df: `jacobian[c][i] = ∂f_c/∂x_i`, M rows of N.
    pub jacobian: Vec<Vec<Id>>,
    /// ∇V, by reverse mode.
    pub lyapunov_gradient: Vec<Id>,
    /// X − ∇V.
    pub feedback: Vec<Id>,
    /// The Lie derivatives ∇f_c · X, which must vanish for integrals.
    pub lie_derivatives: Vec<Id>,
    /// For a partitioned field (q̇ = a(p), ṗ = b(q)): `true` at the q components.
    pub partition: Option<Vec<bool>>,
}

/// The output of stage 3: a lowered model with its derivatives (their nodes added to its
/// graph). The input of [`check`](crate::check()) and of the tapes.
#[derive(Clone)]
pub struct Derived {
    /// The model; its graph holds the derivatives' nodes too.
    pub model: crate::Model,
    /// Df, ∇V, X − ∇V, the Lie derivatives and the partition.
    pub derivatives: Derivatives,
}

/// Differentiates a lowered model: Df, ∇V, X − ∇V, the Lie derivatives and the partition.
pub fn derive(mut model: crate::Model) -> Derived {
    let derivatives = derivatives(&mut model);
    Derived { model, derivatives }
}

fn derivatives(model: &mut crate::Model) -> Derivatives {
    let n = model.dim();
    let vars: Vec<Input> = (0..n as u32).map(Input::State).collect();
    let f = model.invariant_ids();
    let g = &mut model.graph;
    // A large graph's Jacobian by the sparse forward mode (each column through the nodes that
    // depend on its variable); a small one's, every model of `models/`, entry by entry as
    // always (the same expressions, in the order the emitted code has always had).
    let jacobian: Vec<Vec<Id>> = if g.reachable(&f).len() >= LARGE_GRAPH {
        jacobian(g, &f, &vars)
    } else {
        let mut memos: Vec<HashMap<Id, Id>> = vec![HashMap::new(); n];
        f.iter()
            .map(|&fc| {
                (0..n)
                    .map(|i| diff(g, fc, vars[i], &mut memos[i]))
                    .collect()
            })
            .collect()
    };
    let lie_derivatives = jacobian
        .iter()
        .map(|row| {
            let terms: Vec<Id> = row
                .iter()
                .zip(&model.field)
                .map(|(&d, &x)| g.mul(&[d, x]))
                .collect();
            g.add(&terms)
        })
        .collect();
    let lyapunov_gradient = gradient(g, model.lyapunov, &vars);
    let feedback = model
        .field
        .iter()
        .zip(&lyapunov_gradient)
        .map(|(&x, &d)| g.sub(x, d))
        .collect();
    let partition = model.partition();
    Derivatives {
        jacobian,
        lyapunov_gradient,
        feedback,
        lie_derivatives,
        partition,
    }
}
