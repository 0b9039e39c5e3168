//! Symmetric compositions of Störmer–Verlet: symplectic methods of orders 4, 6 and 8 for
//! partitioned fields q̇ = a(p), ṗ = b(q).
//!
//! A step of size h is Störmer–Verlet A (kick–drift–kick) with the steps w₁h, …, w_sh, whose
//! weights are symmetric (w_k = w_{s+1−k}) and sum to 1 (GNI §II.4 and §V.3, "composition
//! methods"). Two kicks meet between consecutive substeps at the same q, so they are one
//! evaluation of b: a composition of s substeps costs s + 1 evaluations of b and s of a.
//!
//! | method | substeps | weights |
//! | --- | --- | --- |
//! | `symplectic4` | 3 | the triple jump w₁ = w₃ = 1/(2 − 2^⅓), w₂ = 1 − 2w₁ (Yoshida 1990, Suzuki 1990) |
//! | `symplectic6` | 7 | Yoshida (1990), solution A |
//! | `symplectic8` | 15 | Yoshida (1990), solution D |
//!
//! The order is checked by measurement (`runtime/tests/composition.rs`: the error falls as hᵖ),
//! and the energy error of a symplectic method stays bounded over 10⁶ steps.

use num_traits::Float;

use super::{StepOutcome, Stepper};
use crate::error::{all_finite, StepError};
use crate::field::{lit, Partitioned};
use crate::state::{ensure_len, State};

/// Yoshida's sixth-order solution A: w₁, w₂, w₃ of the outer substeps (w₀ = 1 − 2Σ in the
/// middle), to the digits of its high-precision solution.
const YOSHIDA6: [f64; 3] = [
    -1.177_679_984_178_871,
    0.235_573_213_359_358_13,
    0.784_513_610_477_557_3,
];

/// Yoshida's eighth-order solution D: w₁ … w₇.
const YOSHIDA8: [f64; 7] = [
    0.102_799_849_391_985,
    -1.960_610_232_975_49,
    1.938_139_137_622_76,
    -0.158_240_635_368_243,
    -1.444_852_236_860_48,
    0.253_693_336_566_229,
    0.914_844_246_229_74,
];

/// A symmetric composition of Störmer–Verlet A (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Composition<X> {
    /// The substeps' weights, summing to 1.
    weights: Vec<f64>,
    order: u32,
    /// Scratch for the partial fields, sized at the first step.
    dx: Option<X>,
}

impl<X> Composition<X> {
    /// Order 4: the triple jump (3 substeps).
    pub fn order4() -> Self {
        let w1 = 1.0 / (2.0 - 2f64.cbrt());
        Self::symmetric(4, &[w1])
    }

    /// Order 6: Yoshida's solution A (7 substeps).
    pub fn order6() -> Self {
        Self::symmetric(6, &YOSHIDA6)
    }

    /// Order 8: Yoshida's solution D (15 substeps).
    pub fn order8() -> Self {
        Self::symmetric(8, &YOSHIDA8)
    }

    /// The weights w_m … w₁, w₀, w₁ … w_m with w₀ = 1 − 2Σw_k, from w₁ … w_m.
    fn symmetric(order: u32, outer: &[f64]) -> Self {
        let w0 = 1.0 - 2.0 * outer.iter().sum::<f64>();
        let weights = outer
            .iter()
            .rev()
            .chain(std::iter::once(&w0))
            .chain(outer)
            .copied()
            .collect();
        Composition {
            weights,
            order,
            dx: None,
        }
    }

    /// The substeps' weights (they sum to 1).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }
}

/// x_p += τ·b(q) on the p components (the ṗ half), or x_q += τ·a(p) (the q̇ half).
#[inline]
fn advance<T: Float, X: State<T>, F: Partitioned<T, X> + ?Sized>(
    field: &F,
    x: &mut X,
    tau: T,
    dx: &mut X,
    q_half: bool,
) {
    if q_half {
        field.field_q(x, dx);
    } else {
        field.field_p(x, dx);
    }
    for (n, &q) in field.is_q().iter().enumerate() {
        if q == q_half {
            x[n] = x[n] + tau * dx[n];
        }
    }
}

impl<T: Float, X: State<T>, F: Partitioned<T, X> + ?Sized> Stepper<T, X, F> for Composition<X> {
    fn step(&mut self, field: &F, t: T, x: &mut X, h: T) -> Result<StepOutcome<T>, StepError> {
        let dx = ensure_len(&mut self.dx, x.len(), T::zero());
        let half = lit::<T>(0.5);
        let w = &self.weights;
        advance(field, x, half * lit(w[0]) * h, dx, false);
        for (k, &wk) in w.iter().enumerate() {
            advance(field, x, lit::<T>(wk) * h, dx, true);
            let next = w.get(k + 1).copied().unwrap_or(0.0);
            advance(field, x, half * lit(wk + next) * h, dx, false);
        }
        if !all_finite(x.as_ref()) {
            return Err(StepError::non_finite("state", t + h, h, x.as_ref()));
        }
        Ok(StepOutcome::fixed(h, w.len() as u32 + 1))
    }

    fn order(&self) -> u32 {
        self.order
    }

    fn name(&self) -> String {
        format!("symplectic{}", self.order)
    }
}
