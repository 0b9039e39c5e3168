//! A fixed-step explicit Runge–Kutta stepper generic over its [`Tableau`].
//!
//! One algorithm for every tableau (diffsol's `ExplicitRk` habit): the S stages live in the
//! stepper (`[X; S]`, sized at the first step), so a step allocates nothing.

use num_traits::Float;

use super::{StepOutcome, Stepper, Tableau};
use crate::error::{all_finite, StepError};
use crate::field::{lit, Field};
use crate::state::State;

/// A fixed-step explicit Runge–Kutta method with `S` stages (HNW I, §II.1, eq. (1.8)):
/// `k_i = X(x_n + h Σ_{j<i} a_ij k_j)`, `x_{n+1} = x_n + h Σ b_i k_i`.
///
/// Build it from a tableau: `ExplicitRk::new(Tableau::rk4())`, or with the shortcuts
/// [`ExplicitRk::euler`], [`ExplicitRk::heun`], [`ExplicitRk::rk4`],
/// [`ExplicitRk::dormand_prince54`]. The embedded weights of the tableau, if any, are ignored.
#[derive(Clone, Debug)]
pub struct ExplicitRk<T, const S: usize, X> {
    name: &'static str,
    a: [[T; S]; S],
    b: [T; S],
    order: u32,
    /// The stages k₁…k_S and the stage argument y, sized at the first step.
    work: Option<([X; S], X)>,
}

/// The explicit Euler method.
pub type Euler<T, X> = ExplicitRk<T, 1, X>;
/// Heun's second-order method.
pub type Heun<T, X> = ExplicitRk<T, 2, X>;
/// The classical fourth-order Runge–Kutta method.
pub type Rk4<T, X> = ExplicitRk<T, 4, X>;

impl<T: Float, const S: usize, X> ExplicitRk<T, S, X> {
    /// A stepper for the given tableau (coefficients converted to `T` once).
    pub fn new(tableau: Tableau<S>) -> Self {
        ExplicitRk {
            name: tableau.name,
            a: tableau.a.map(|row| row.map(lit)),
            b: tableau.b.map(lit),
            order: tableau.order,
            work: None,
        }
    }
}

impl<T: Float, X> ExplicitRk<T, 1, X> {
    /// The explicit Euler method (order 1).
    pub fn euler() -> Self {
        Self::new(Tableau::euler())
    }
}

impl<T: Float, X> ExplicitRk<T, 2, X> {
    /// Heun's method (order 2).
    pub fn heun() -> Self {
        Self::new(Tableau::heun())
    }
}

impl<T: Float, X> ExplicitRk<T, 4, X> {
    /// The classical Runge–Kutta method (order 4).
    pub fn rk4() -> Self {
        Self::new(Tableau::rk4())
    }
}

impl<T: Float, X> ExplicitRk<T, 7, X> {
    /// Dormand–Prince 5(4) used as a fixed-step 5th-order method.
    pub fn dormand_prince54() -> Self {
        Self::new(Tableau::dormand_prince54())
    }
}

impl<T: Float, const S: usize, X: State<T>, F: Field<T, X> + ?Sized> Stepper<T, X, F>
    for ExplicitRk<T, S, X>
{
    fn step(&mut self, field: &F, t: T, x: &mut X, h: T) -> Result<StepOutcome<T>, StepError> {
        let n = x.len();
        if !matches!(&self.work, Some((_, y)) if y.len() == n) {
            let zero = X::filled(X::len_for(n), T::zero());
            self.work = Some((std::array::from_fn(|_| zero.clone()), zero));
        }
        let (k, y) = self.work.as_mut().expect("sized above");
        field.field(x, &mut k[0]);
        if !all_finite(k[0].as_ref()) {
            return Err(StepError::non_finite("field", t, h, x.as_ref()));
        }
        for i in 1..S {
            y.clone_from(x);
            for j in 0..i {
                let c = self.a[i][j];
                if c != T::zero() {
                    let hc = h * c;
                    for (yn, kn) in y.as_mut().iter_mut().zip(k[j].as_ref()) {
                        *yn = *yn + hc * *kn;
                    }
                }
            }
            field.field(y, &mut k[i]);
        }
        for i in 0..S {
            let c = self.b[i];
            if c != T::zero() {
                let hc = h * c;
                for (xn, kn) in x.as_mut().iter_mut().zip(k[i].as_ref()) {
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
