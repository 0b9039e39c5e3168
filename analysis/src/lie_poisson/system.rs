//! The P-subsystem of a Lie–Poisson so(3)* model with its symbolic derivatives: ∇H and the
//! Hessian of H (second derivatives of the model's Hamiltonian node), the field Ṗ = P × ∇H and
//! its Jacobian (derivatives of the model's own field nodes), all evaluated on the lowered DAG.

use std::collections::HashMap;

use lasalle_model::ir::diff;
use lasalle_model::ir::{Graph, Id, Input};
use lasalle_model::Model;
use lasalle_model::Structure;
use nalgebra::{Matrix3, Vector3};

use super::StabilityError;

/// H, ∇H, ∇²H, X = P × ∇H and DX at one P.
#[derive(Clone, Copy, Debug)]
pub struct Local {
    /// H(P).
    pub h: f64,
    /// ∇H(P).
    pub grad: Vector3<f64>,
    /// ∇²H(P).
    pub hess: Matrix3<f64>,
    /// The field Ṗ = P × ∇H(P) as the model computes it.
    pub field: Vector3<f64>,
    /// Its Jacobian ∂Ṗᵢ/∂Pⱼ.
    pub jac: Matrix3<f64>,
}

/// A Lie–Poisson so(3)* Hamiltonian subsystem prepared for equilibrium and stability analysis.
#[derive(Clone)]
pub struct LiePoissonSystem {
    name: String,
    graph: Graph,
    /// Flat state indices of P₁, P₂, P₃.
    p: [u32; 3],
    /// h, ∇H (3), ∇²H (9, row-major), X (3), DX (9, row-major).
    outputs: Vec<Id>,
    h: Id,
    params: Vec<f64>,
}

impl std::fmt::Debug for LiePoissonSystem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiePoissonSystem")
            .field("name", &self.name)
            .field("p", &self.p)
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

impl LiePoissonSystem {
    /// Prepares the P-subsystem of `model` with parameter slots `params`.
    ///
    /// Errors when the model has no Hamiltonian, when its structure is not `lie_poisson_so3`
    /// (the canonical branch is where a normal-form based analysis will go), or when H or Ṗ
    /// depend on state outside P (then the P-subsystem is not closed).
    pub fn new(model: &Model, params: &[f64]) -> Result<LiePoissonSystem, StabilityError> {
        let Some(ham) = &model.hamiltonian else {
            return Err(StabilityError::NoStructure {
                model: model.name.clone(),
            });
        };
        let p: [u32; 3] = match &ham.structure {
            Structure::LiePoissonSo3 { p } if p.len() == 3 => {
                [p[0] as u32, p[1] as u32, p[2] as u32]
            }
            Structure::LiePoissonSo3 { p } => {
                return Err(StabilityError::Unsupported {
                    model: model.name.clone(),
                    why: format!(
                        "its lie_poisson_so3 momentum has {} components, not 3",
                        p.len()
                    ),
                })
            }
            Structure::Canonical { .. } => {
                return Err(StabilityError::Canonical {
                    model: model.name.clone(),
                })
            }
        };
        if params.len() != model.param_slots() {
            return Err(StabilityError::Unsupported {
                model: model.name.clone(),
                why: format!(
                    "{} parameter values given for {} slots",
                    params.len(),
                    model.param_slots()
                ),
            });
        }
        let mut graph = model.graph.clone();
        let outside = |i: Input| matches!(i, Input::State(k) if !p.contains(&k));
        let field: Vec<Id> = p.iter().map(|&k| model.field[k as usize]).collect();
        for (what, root) in std::iter::once(("H", ham.h)).chain(field.iter().map(|&f| ("Ṗ", f))) {
            if graph.depends_on(root, outside) {
                return Err(StabilityError::Unsupported {
                    model: model.name.clone(),
                    why: format!(
                        "{what} depends on state outside P: the P-subsystem is not closed"
                    ),
                });
            }
        }
        let vars: Vec<Input> = p.iter().map(|&k| Input::State(k)).collect();
        let mut memos: Vec<HashMap<Id, Id>> = vec![HashMap::new(); 3];
        let grad: Vec<Id> = (0..3)
            .map(|j| diff(&mut graph, ham.h, vars[j], &mut memos[j]))
            .collect();
        let mut outputs = vec![ham.h];
        outputs.extend(&grad);
        for &g in &grad {
            for j in 0..3 {
                let d = diff(&mut graph, g, vars[j], &mut memos[j]);
                outputs.push(d);
            }
        }
        outputs.extend(&field);
        for &f in &field {
            for j in 0..3 {
                let d = diff(&mut graph, f, vars[j], &mut memos[j]);
                outputs.push(d);
            }
        }
        let sys = LiePoissonSystem {
            name: model.name.clone(),
            graph,
            p,
            outputs,
            h: ham.h,
            params: params.to_vec(),
        };
        // H, ∇H, the field and their derivatives must be finite: a parameter that divides
        // (c₁ = 0 in H = P₁²/(2c₁)) makes them NaN everywhere, which no test for equilibria
        // may read as "the field vanishes"
        let probe = Vector3::new(0.6, -0.48, 0.64);
        let l = sys.local(probe);
        let finite = std::iter::once(l.h)
            .chain(l.grad.iter().copied())
            .chain(l.field.iter().copied())
            .chain(l.hess.iter().copied())
            .all(f64::is_finite);
        if !finite {
            let suspects: Vec<String> = model
                .params
                .iter()
                .filter(|p| {
                    params[p.offset..p.offset + p.slots()]
                        .iter()
                        .any(|&v| v == 0.0 || !v.is_finite())
                })
                .map(|p| {
                    let v = &params[p.offset..p.offset + p.slots()];
                    format!(
                        "{} = {}",
                        p.name,
                        v.iter().map(f64::to_string).collect::<Vec<_>>().join(",")
                    )
                })
                .collect();
            return Err(StabilityError::Unsupported {
                model: model.name.clone(),
                why: format!(
                    "H or its field is not finite at P = ({}, {}, {}){}",
                    probe[0],
                    probe[1],
                    probe[2],
                    if suspects.is_empty() {
                        String::new()
                    } else {
                        format!(
                            " with {} (a parameter the model divides by?): change it with --param",
                            suspects.join(", ")
                        )
                    }
                ),
            });
        }
        Ok(sys)
    }

    /// The model's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Flat state indices of P.
    pub fn p_indices(&self) -> [usize; 3] {
        self.p.map(|k| k as usize)
    }

    /// The parameter slots in use.
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    fn input(&self, x: Vector3<f64>) -> impl FnMut(Input) -> f64 + '_ {
        move |i| match i {
            Input::State(k) => self.p.iter().position(|&q| q == k).map_or(0.0, |j| x[j]),
            Input::Param(k) => self.params.get(k as usize).copied().unwrap_or(f64::NAN),
            _ => f64::NAN,
        }
    }

    /// H(P).
    pub fn energy(&self, x: Vector3<f64>) -> f64 {
        self.graph.eval_f64(&[self.h], &mut self.input(x))[0]
    }

    /// H, ∇H, ∇²H, X and DX at P.
    pub fn local(&self, x: Vector3<f64>) -> Local {
        let v = self.graph.eval_f64(&self.outputs, &mut self.input(x));
        let m = |o: usize| Matrix3::from_fn(|i, j| v[o + 3 * i + j]);
        Local {
            h: v[0],
            grad: Vector3::new(v[1], v[2], v[3]),
            hess: m(4),
            field: Vector3::new(v[13], v[14], v[15]),
            jac: m(16),
        }
    }
}
