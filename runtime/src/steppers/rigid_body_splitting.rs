//! The free rigid body integrated by splitting into three rotations.
//!
//! GNI (Hairer–Lubich–Wanner, *Geometric Numerical Integration*, 2nd ed.), §VII.5,
//! pp. 284–285. With body angular momentum m = 𝕀Ω, 𝕀 = diag(I₁, I₂, I₃), the equations
//! Ṙ = RΩ̂, Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω) read ṁ = m × ∇H(m), Ṙ = R hat(∇H(m)) with
//! H = H₁ + H₂ + H₃, H_k = m_k²/(2I_k). The flow of H_k alone keeps m_k fixed, so ∇H_k =
//! (m_k/I_k) e_k is constant and the flow is an exact rotation by θ = τ m_k/I_k about e_k:
//!
//! ```text
//! ṁ = m × (θ/τ) e_k  ⇒  m(τ) = Q_kᵀ m,      Ṙ = R hat((θ/τ) e_k)  ⇒  R(τ) = R Q_k,
//! Q_k = exp(θ ê_k)  (rotation by θ about the k-th body axis).
//! ```
//!
//! Each sub-flow keeps the spatial angular momentum π = R m (R Q_k Q_kᵀ m = R m), |m|, H_k and
//! RᵀR exactly — but *not* the total energy H unless two moments of inertia are equal. The
//! step is the symmetric (Strang) composition
//! Φ_h = φ¹_{h/2} ∘ φ²_{h/2} ∘ φ³_h ∘ φ²_{h/2} ∘ φ¹_{h/2}, of order 2, symplectic (Poisson)
//! and time-reversible.

use num_traits::Float;

use super::{StepOutcome, Stepper};
use crate::error::{all_finite, StepError};
use crate::field::lit;
use crate::state::State;

/// The three-rotation splitting of the free rigid body (GNI §VII.5), for the 12-dimensional
/// state x = (R column-major in x[0..9], Ω in x[9..12]).
///
/// The field passed to [`Stepper::step`] is ignored: the method uses only the moments of
/// inertia given here, which must match the model's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidBodySplitting<T> {
    inertia: [T; 3],
    axes: [usize; 3],
}

impl<T: Float> RigidBodySplitting<T> {
    /// The splitting φ¹_{h/2} ∘ φ²_{h/2} ∘ φ³_h ∘ φ²_{h/2} ∘ φ¹_{h/2} for 𝕀 = diag(`inertia`).
    pub fn new(inertia: [T; 3]) -> Self {
        RigidBodySplitting {
            inertia,
            axes: [0, 1, 2],
        }
    }

    /// The same with another order of the axes: `axes = [a, b, c]` gives
    /// φᵃ_{h/2} ∘ φᵇ_{h/2} ∘ φᶜ_h ∘ φᵇ_{h/2} ∘ φᵃ_{h/2} (must be a permutation of 0, 1, 2).
    pub fn with_axes(inertia: [T; 3], axes: [usize; 3]) -> Self {
        let mut seen = [false; 3];
        for &a in &axes {
            assert!(a < 3 && !seen[a], "axes must be a permutation of 0, 1, 2");
            seen[a] = true;
        }
        RigidBodySplitting { inertia, axes }
    }

    /// The moments of inertia.
    pub fn inertia(&self) -> [T; 3] {
        self.inertia
    }

    /// The exact flow of H_k = m_k²/(2I_k) over time `tau` (axis `k` ∈ {0, 1, 2}), in place.
    pub fn sub_flow(&self, k: usize, tau: T, x: &mut [T]) {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        // θ = τ m_k / I_k = τ Ω_k
        let theta = tau * x[9 + k];
        let (s, c) = theta.sin_cos();
        // R ← R Q_k: columns i and j rotate, column k stays
        for a in 0..3 {
            let ri = x[a + 3 * i];
            let rj = x[a + 3 * j];
            x[a + 3 * i] = c * ri + s * rj;
            x[a + 3 * j] = -s * ri + c * rj;
        }
        // m ← Q_kᵀ m, then Ω = 𝕀⁻¹ m
        let mi = self.inertia[i] * x[9 + i];
        let mj = self.inertia[j] * x[9 + j];
        x[9 + i] = (c * mi + s * mj) / self.inertia[i];
        x[9 + j] = (-s * mi + c * mj) / self.inertia[j];
    }
}

impl<T: Float, X: State<T>, F: ?Sized> Stepper<T, X, F> for RigidBodySplitting<T> {
    fn step(&mut self, _field: &F, t: T, x: &mut X, h: T) -> Result<StepOutcome<T>, StepError> {
        let x = x.as_mut();
        if x.len() != 12 {
            return Err(StepError::InvalidInput(format!(
                "the rigid-body splitting needs the 12-dimensional state (R, Ω), got {}",
                x.len()
            )));
        }
        let half = h * lit(0.5);
        let [a, b, c] = self.axes;
        self.sub_flow(a, half, x);
        self.sub_flow(b, half, x);
        self.sub_flow(c, h, x);
        self.sub_flow(b, half, x);
        self.sub_flow(a, half, x);
        if !all_finite(x) {
            return Err(StepError::non_finite("state", t + h, h, x));
        }
        Ok(StepOutcome::fixed(h, 0))
    }

    fn order(&self) -> u32 {
        2
    }

    fn name(&self) -> String {
        "splitting".to_string()
    }
}
