//! Butcher tableaux of explicit Runge–Kutta methods, stored as data.
//!
//! An s-stage explicit Runge–Kutta method (HNW I, §II.1, Def. 1.1) is
//!
//! ```text
//! k_i = X(x_n + h Σ_{j<i} a_ij k_j),  i = 1..s,      x_{n+1} = x_n + h Σ_i b_i k_i
//! ```
//!
//! (`c_i = Σ_j a_ij` only matters for non-autonomous fields). An embedded method `b̂` gives the
//! error estimate `h Σ (b_i − b̂_i) k_i` of adaptive steppers (HNW I, §II.4).

/// The coefficients `a`, `b`, `c` (and optionally an embedded `b̂`) of an explicit
/// Runge–Kutta method with `S` stages, in `f64` (converted once when a stepper is built).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tableau<const S: usize> {
    /// Short name, e.g. `"rk4"`.
    pub name: &'static str,
    /// Strictly lower-triangular coupling coefficients `a_ij` (row i, column j < i).
    pub a: [[f64; S]; S],
    /// Weights `b_i` of the propagated solution.
    pub b: [f64; S],
    /// Nodes `c_i = Σ_j a_ij`.
    pub c: [f64; S],
    /// Weights `b̂_i` of the embedded method used for error estimation, if any.
    pub b_hat: Option<[f64; S]>,
    /// Order of the method given by `b`.
    pub order: u32,
    /// Order of the embedded method `b̂`, if any.
    pub embedded_order: Option<u32>,
}

impl Tableau<1> {
    /// The explicit Euler method `x_{n+1} = x_n + h X(x_n)` (order 1; HNW I, §I.7 / §II.1).
    pub fn euler() -> Self {
        Tableau {
            name: "euler",
            a: [[0.0]],
            b: [1.0],
            c: [0.0],
            b_hat: None,
            order: 1,
            embedded_order: None,
        }
    }
}

impl Tableau<2> {
    /// Heun's method (explicit trapezoidal rule; order 2; HNW I, §II.1, Table 1.1 left,
    /// Heun 1900): `c = (0, 1)`, `a₂₁ = 1`, `b = (½, ½)`.
    pub fn heun() -> Self {
        Tableau {
            name: "heun",
            a: [[0.0, 0.0], [1.0, 0.0]],
            b: [0.5, 0.5],
            c: [0.0, 1.0],
            b_hat: None,
            order: 2,
            embedded_order: None,
        }
    }
}

impl Tableau<4> {
    /// The classical Runge–Kutta method (Kutta 1901; order 4; HNW I, §II.1, Table 1.2 left):
    /// `c = (0, ½, ½, 1)`, `b = (⅙, ⅓, ⅓, ⅙)`.
    pub fn rk4() -> Self {
        Tableau {
            name: "rk4",
            a: [
                [0.0, 0.0, 0.0, 0.0],
                [0.5, 0.0, 0.0, 0.0],
                [0.0, 0.5, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
            b: [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0],
            c: [0.0, 0.5, 0.5, 1.0],
            b_hat: None,
            order: 4,
            embedded_order: None,
        }
    }
}

impl Tableau<7> {
    /// Dormand–Prince 5(4), "DOPRI5" (J. R. Dormand & P. J. Prince, *A family of embedded
    /// Runge–Kutta formulae*, J. Comput. Appl. Math. 6 (1980) 19–26; HNW I, §II.5, Table 5.2).
    ///
    /// Seven stages, the last one first-same-as-last (FSAL: `a₇ⱼ = bⱼ`, so `k₇ = X(x_{n+1})`);
    /// `b` is the 5th-order solution that is propagated (local extrapolation), `b̂` the 4th-order
    /// embedded one. MATLAB's `ode45` uses the same pair.
    pub fn dormand_prince54() -> Self {
        const B: [f64; 7] = [
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
            0.0,
        ];
        Tableau {
            name: "dopri5",
            a: [
                [0.0; 7],
                [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0, 0.0],
                [
                    19372.0 / 6561.0,
                    -25360.0 / 2187.0,
                    64448.0 / 6561.0,
                    -212.0 / 729.0,
                    0.0,
                    0.0,
                    0.0,
                ],
                [
                    9017.0 / 3168.0,
                    -355.0 / 33.0,
                    46732.0 / 5247.0,
                    49.0 / 176.0,
                    -5103.0 / 18656.0,
                    0.0,
                    0.0,
                ],
                B,
            ],
            b: B,
            c: [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0],
            b_hat: Some([
                5179.0 / 57600.0,
                0.0,
                7571.0 / 16695.0,
                393.0 / 640.0,
                -92097.0 / 339200.0,
                187.0 / 2100.0,
                1.0 / 40.0,
            ]),
            order: 5,
            embedded_order: Some(4),
        }
    }
}

impl<const S: usize> Tableau<S> {
    /// Checks that the tableau is explicit (`a_ij = 0` for j ≥ i), that `c_i = Σ_j a_ij` and
    /// that the weights sum to one (consistency, order ≥ 1), to within `1e-14`.
    pub fn is_consistent(&self) -> bool {
        let tol = 1e-14;
        for i in 0..S {
            let mut row = 0.0;
            for j in 0..S {
                if j >= i && self.a[i][j] != 0.0 {
                    return false;
                }
                row += self.a[i][j];
            }
            if (row - self.c[i]).abs() > tol {
                return false;
            }
        }
        let sum_ok = |w: &[f64; S]| (w.iter().sum::<f64>() - 1.0).abs() <= tol;
        sum_ok(&self.b) && self.b_hat.as_ref().map_or(true, sum_ok)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tableaux_are_consistent() {
        assert!(Tableau::euler().is_consistent());
        assert!(Tableau::heun().is_consistent());
        assert!(Tableau::rk4().is_consistent());
        assert!(Tableau::dormand_prince54().is_consistent());
    }

    /// The order conditions up to order 5 for the propagated DOPRI5 weights (HNW I, Table 2.2
    /// lists them); checking a few catches a mistyped coefficient.
    #[test]
    fn dopri5_order_conditions() {
        let t = Tableau::dormand_prince54();
        let (b, c, a) = (t.b, t.c, t.a);
        let sum = |f: &dyn Fn(usize) -> f64| (0..7).map(f).sum::<f64>();
        assert!((sum(&|i| b[i] * c[i]) - 0.5).abs() < 1e-14);
        assert!((sum(&|i| b[i] * c[i] * c[i]) - 1.0 / 3.0).abs() < 1e-14);
        assert!((sum(&|i| b[i] * c[i].powi(3)) - 0.25).abs() < 1e-14);
        assert!((sum(&|i| b[i] * c[i].powi(4)) - 0.2).abs() < 1e-14);
        let ac = |i: usize| (0..7).map(|j| a[i][j] * c[j]).sum::<f64>();
        assert!((sum(&|i| b[i] * ac(i)) - 1.0 / 6.0).abs() < 1e-14);
        assert!((sum(&|i| b[i] * c[i] * ac(i)) - 1.0 / 8.0).abs() < 1e-14);
        // the embedded method satisfies the 8 conditions of order 4 (HNW I, Table 2.1) but
        // not all of order 5
        let bh = t.b_hat.unwrap();
        let ac2 = |i: usize| (0..7).map(|j| a[i][j] * c[j] * c[j]).sum::<f64>();
        let aac = |i: usize| (0..7).map(|j| a[i][j] * ac(j)).sum::<f64>();
        for w in [b, bh] {
            let s = |f: &dyn Fn(usize) -> f64| (0..7).map(|i| w[i] * f(i)).sum::<f64>();
            assert!((s(&|_| 1.0) - 1.0).abs() < 1e-14);
            assert!((s(&|i| c[i]) - 0.5).abs() < 1e-14);
            assert!((s(&|i| c[i] * c[i]) - 1.0 / 3.0).abs() < 1e-14);
            assert!((s(&ac) - 1.0 / 6.0).abs() < 1e-14);
            assert!((s(&|i| c[i].powi(3)) - 0.25).abs() < 1e-14);
            assert!((s(&|i| c[i] * ac(i)) - 1.0 / 8.0).abs() < 1e-14);
            assert!((s(&ac2) - 1.0 / 12.0).abs() < 1e-14);
            assert!((s(&aac) - 1.0 / 24.0).abs() < 1e-14);
        }
        assert!((sum(&|i| bh[i] * c[i].powi(4)) - 0.2).abs() > 1e-6);
    }
}
