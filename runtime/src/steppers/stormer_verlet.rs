//! Störmer–Verlet for partitioned fields q̇ = a(p), ṗ = b(q).
//!
//! Hairer–Lubich–Wanner, *Geometric Numerical Integration*, 2nd ed. (GNI), §VI.3, eqs. (3.4)
//! and (3.5), pp. 189–190 (Theorem 3.4: symplectic, order 2). For a separable Hamiltonian
//! H = T(p) + U(q) the implicit stages of (3.4)/(3.5) become explicit:
//!
//! ```text
//! (3.4), "A", kick–drift–kick:   p_{n+½} = p_n + h/2 b(q_n)
//!                                q_{n+1} = q_n + h a(p_{n+½})
//!                                p_{n+1} = p_{n+½} + h/2 b(q_{n+1})
//! (3.5), "B", drift–kick–drift:  q_{n+½} = q_n + h/2 a(p_n)
//!                                p_{n+1} = p_n + h b(q_{n+½})
//!                                q_{n+1} = q_{n+½} + h/2 a(p_{n+1})
//! ```
//!
//! The names A and B follow Chang, Jiménez & Perlmutter (2016), §4.2 ("Störmer–Verlet-A" =
//! GNI (3.4), "Störmer–Verlet-B" = GNI (3.5)). With b = −∇U and a = ∇T, (3.4) is GNI's
//! p_{n+½} = p_n − h/2 ∇U(q_n), q_{n+1} = q_n + h p_{n+½}, p_{n+1} = p_{n+½} − h/2 ∇U(q_{n+1}).

use num_traits::Float;

use super::{StepOutcome, Stepper};
use crate::error::{all_finite, StepError};
use crate::field::{lit, Partitioned};
use crate::state::{ensure_len, State};

/// Which Störmer–Verlet scheme to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VerletVariant {
    /// GNI (3.4): kick–drift–kick (half kick in p, full drift in q, half kick in p).
    A,
    /// GNI (3.5): drift–kick–drift (half drift in q, full kick in p, half drift in q).
    B,
}

/// The Störmer–Verlet method for a [`Partitioned`] field (order 2, symplectic for
/// Hamiltonian a = ∇T, b = −∇U; GNI §VI.3 Theorem 3.4).
///
/// Costs two evaluations of the expensive half per step (the FSAL reuse of b(q_{n+1}) is not
/// attempted, so the stepper is stateless).
#[derive(Clone, Debug, PartialEq)]
pub struct StormerVerlet<X> {
    /// The scheme.
    pub variant: VerletVariant,
    /// Scratch for the partial fields, sized at the first step.
    dx: Option<X>,
}

impl<X> StormerVerlet<X> {
    /// Störmer–Verlet-A, GNI (3.4): kick–drift–kick.
    pub fn a() -> Self {
        StormerVerlet {
            variant: VerletVariant::A,
            dx: None,
        }
    }

    /// Störmer–Verlet-B, GNI (3.5): drift–kick–drift.
    pub fn b() -> Self {
        StormerVerlet {
            variant: VerletVariant::B,
            dx: None,
        }
    }
}

/// x_p += τ·b(q) on the p components.
#[inline]
fn kick<T: Float, X: State<T>, F: Partitioned<T, X> + ?Sized>(
    field: &F,
    x: &mut X,
    tau: T,
    dx: &mut X,
) {
    field.field_p(x, dx);
    for (n, &q) in field.is_q().iter().enumerate() {
        if !q {
            x[n] = x[n] + tau * dx[n];
        }
    }
}

#[inline]
fn drift<T: Float, X: State<T>, F: Partitioned<T, X> + ?Sized>(
    field: &F,
    x: &mut X,
    tau: T,
    dx: &mut X,
) {
    field.field_q(x, dx);
    for (n, &q) in field.is_q().iter().enumerate() {
        if q {
            x[n] = x[n] + tau * dx[n];
        }
    }
}

impl<T: Float, X: State<T>, F: Partitioned<T, X> + ?Sized> Stepper<T, X, F> for StormerVerlet<X> {
    fn step(&mut self, field: &F, t: T, x: &mut X, h: T) -> Result<StepOutcome<T>, StepError> {
        let half = h * lit(0.5);
        let dx = ensure_len(&mut self.dx, x.len(), T::zero());
        match self.variant {
            VerletVariant::A => {
                kick(field, x, half, dx);
                drift(field, x, h, dx);
                kick(field, x, half, dx);
            }
            VerletVariant::B => {
                drift(field, x, half, dx);
                kick(field, x, h, dx);
                drift(field, x, half, dx);
            }
        }
        if !all_finite(dx.as_ref()) {
            return Err(StepError::non_finite("field", t, h, x.as_ref()));
        }
        // three partial evaluations ≈ 1.5 full ones; report the two expensive ones
        Ok(StepOutcome::fixed(h, 2))
    }

    fn order(&self) -> u32 {
        2
    }

    fn name(&self) -> String {
        match self.variant {
            VerletVariant::A => "stormer-verlet-a".to_string(),
            VerletVariant::B => "stormer-verlet-b".to_string(),
        }
    }
}
