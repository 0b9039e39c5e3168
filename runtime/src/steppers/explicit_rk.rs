//! A fixed-step explicit Runge–Kutta stepper generic over its [`Tableau`].
//!
//! One algorithm for every tableau (diffsol's `ExplicitRk` habit): the stages live in a stack
//! array `[[T; N]; S]`, so a step allocates nothing.

use num_traits::Float;

use super::{StepOutcome, Stepper, Tableau};
use crate::error::{all_finite, StepError};
use crate::field::{lit, Field};

/// A fixed-step explicit Runge–Kutta method with `S` stages (HNW I, §II.1, eq. (1.8)):
/// `k_i = X(x_n + h Σ_{j<i} a_ij k_j)`, `x_{n+1} = x_n + h Σ b_i k_i`.
///
/// Build it from a tableau: `ExplicitRk::new(Tableau::rk4())`, or with the shortcuts
/// [`ExplicitRk::euler`], [`ExplicitRk::heun`], [`ExplicitRk::rk4`],
/// [`ExplicitRk::dormand_prince54`]. The embedded weights of the tableau, if any, are ignored.
#[derive(Clone, Debug)]
pub struct ExplicitRk<T, const S: usize> {
    name: &'static str,
    a: [[T; S]; S],
    b: [T; S],
    order: u32,
}

/// The explicit Euler method.
pub type Euler<T> = ExplicitRk<T, 1>;
/// Heun's second-order method.
pub type Heun<T> = ExplicitRk<T, 2>;
/// The classical fourth-order Runge–Kutta method.
pub type Rk4<T> = ExplicitRk<T, 4>;

impl<T: Float, const S: usize> ExplicitRk<T, S> {
    /// A stepper for the given tableau (coefficients converted to `T` once).
    pub fn new(tableau: Tableau<S>) -> Self {
        ExplicitRk {
            name: tableau.name,
            a: tableau.a.map(|row| row.map(lit)),
            b: tableau.b.map(lit),
            order: tableau.order,
        }
    }
}

impl<T: Float> ExplicitRk<T, 1> {
    /// The explicit Euler method (order 1).
    pub fn euler() -> Self {
        Self::new(Tableau::euler())
    }
}

impl<T: Float> ExplicitRk<T, 2> {
    /// Heun's method (order 2).
    pub fn heun() -> Self {
        Self::new(Tableau::heun())
    }
}

impl<T: Float> ExplicitRk<T, 4> {
    /// The classical Runge–Kutta method (order 4).
    pub fn rk4() -> Self {
        Self::new(Tableau::rk4())
    }
}

impl<T: Float> ExplicitRk<T, 7> {
    /// Dormand–Prince 5(4) used as a fixed-step 5th-order method.
    pub fn dormand_prince54() -> Self {
        Self::new(Tableau::dormand_prince54())
    }
}

impl<T: Float, const N: usize, const S: usize, F: Field<T, N> + ?Sized> Stepper<T, N, F>
    for ExplicitRk<T, S>
{
    fn step(&mut self, field: &F, t: T, x: &mut [T; N], h: T) -> Result<StepOutcome<T>, StepError> {
        let mut k = [[T::zero(); N]; S];
        let mut y = [T::zero(); N];
        field.field(x, &mut k[0]);
        if !all_finite(&k[0]) {
            return Err(StepError::non_finite("field", t, h, x));
        }
        for i in 1..S {
            y.copy_from_slice(x);
            for j in 0..i {
                let c = self.a[i][j];
                if c != T::zero() {
                    let hc = h * c;
                    for (yn, kn) in y.iter_mut().zip(k[j].iter()) {
                        *yn = *yn + hc * *kn;
                    }
                }
            }
            field.field(&y, &mut k[i]);
        }
        for i in 0..S {
            let c = self.b[i];
            if c != T::zero() {
                let hc = h * c;
                for (xn, kn) in x.iter_mut().zip(k[i].iter()) {
                    *xn = *xn + hc * *kn;
                }
            }
        }
        Ok(StepOutcome::fixed(h, S as u32))
    }

    fn order(&self) -> u32 {
        self.order
    }

    fn name(&self) -> String {
        self.name.to_string()
    }
}
