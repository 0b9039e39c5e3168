//! `splitting rigid_body(R, Omega, I);`: the free rigid body Ṙ = RΩ̂, Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω) with
//! 𝕀 = diag(I₁, I₂, I₃), split into three exact rotations (Hairer, Lubich & Wanner, *Geometric
//! Numerical Integration*, §VII.5). The runtime's stepper is `RigidBodySplitting`.

use super::Declaration;
use crate::error::Diagnostic;
use crate::ir::Input;
use crate::model::Shape;

/// The layout the stepper needs (R a mat3 at x[0..9], Ω a vec3 at x[9..12], nothing else),
/// the principal moments as a parameter, and the field compared with the free rigid body's at
/// random states. Returns the parameter slots of I₁, I₂, I₃.
pub(super) fn check(d: &Declaration) -> Result<Vec<u32>, Diagnostic> {
    let [r, omega, inertia] = d.args else {
        unreachable!("the table's arity is checked before")
    };
    let var = |a: &crate::parse::ast::Ident,
               shape: Shape,
               offset: usize|
     -> Result<(), Diagnostic> {
        match d.state.iter().find(|s| s.name == a.name) {
            Some(s) if s.shape == shape && s.offset == offset => Ok(()),
            Some(s) => Err(Diagnostic::new(
                &a.span,
                format!(
                    "the rigid-body splitting needs `{}` as a {shape} at x[{offset}..{}], it is a {} at x[{}..{}]",
                    a.name,
                    offset + shape.len(),
                    s.shape,
                    s.offset,
                    s.offset + s.shape.len()
                ),
            )
            .help("declare `state R: mat3, Omega: vec3;` in this order")),
            None => Err(Diagnostic::new(
                &a.span,
                format!("`{}` is not a state variable", a.name),
            )),
        }
    };
    var(r, Shape::Matrix(3, 3), 0)?;
    var(omega, Shape::Vector(3), 9)?;
    if d.state.iter().map(|s| s.shape.len()).sum::<usize>() != 12 {
        return Err(Diagnostic::new(
            d.span,
            "the rigid-body splitting needs the state (R, Omega) and nothing else",
        ));
    }
    let p = d
        .params
        .iter()
        .find(|p| p.name == inertia.name)
        .ok_or_else(|| {
            Diagnostic::new(
                &inertia.span,
                format!("`{}` is not a parameter", inertia.name),
            )
            .help("declare the inertia tensor as `param I = diag(3, 2, 1);`")
        })?;
    if !(p.slots() == 3 && (p.diagonal || p.shape == Shape::Vector(3))) {
        return Err(Diagnostic::new(
            &inertia.span,
            format!(
                "the rigid-body splitting needs the principal moments of inertia: `{}` must be `diag(I1, I2, I3)` or a vec3",
                inertia.name
            ),
        ));
    }
    let slots = [p.offset as u32, p.offset as u32 + 1, p.offset as u32 + 2];
    // The field must be Ṙ = RΩ̂, Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω): compare at random states.
    let defaults: Vec<f64> = d.params.iter().flat_map(|q| q.defaults.clone()).collect();
    let mut rng = crate::Rng::new(0x9e37_79b9_7f4a_7c15);
    for _ in 0..16 {
        let x: Vec<f64> = (0..12).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let got = d.graph.eval_f64(d.field, &mut |i| match i {
            Input::State(k) => x[k as usize],
            Input::Param(k) => defaults[k as usize],
            _ => f64::NAN,
        });
        let i: Vec<f64> = slots.iter().map(|&k| defaults[k as usize]).collect();
        let w = &x[9..12];
        let rr = |a: usize, b: usize| x[a + 3 * b];
        let mut want = [0.0; 12];
        // (R Ω̂)_{ab} = Σ_c R_{ac} Ω̂_{cb}, Ω̂ = [[0, −w3, w2], [w3, 0, −w1], [−w2, w1, 0]]
        let hat = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
        for a in 0..3 {
            for b in 0..3 {
                want[a + 3 * b] = (0..3).map(|c| rr(a, c) * hat[c][b]).sum();
            }
        }
        let m = [i[0] * w[0], i[1] * w[1], i[2] * w[2]];
        let cross = [
            m[1] * w[2] - m[2] * w[1],
            m[2] * w[0] - m[0] * w[2],
            m[0] * w[1] - m[1] * w[0],
        ];
        for k in 0..3 {
            want[9 + k] = cross[k] / i[k];
        }
        let bad = (0..12).find(|&k| (got[k] - want[k]).abs() > 1e-12 * (1.0 + want[k].abs()));
        if let Some(k) = bad {
            return Err(Diagnostic::new(
                d.span,
                format!(
                    "the field is not the free rigid body's, so the rigid-body splitting does not apply: component {k} is {} where Ṙ = RΩ̂, Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω) gives {}",
                    got[k], want[k]
                ),
            )
            .help("write `d/dt R = R * hat(Omega); d/dt Omega = inv(I) * cross(I * Omega, Omega);`"));
        }
    }
    Ok(slots.to_vec())
}
