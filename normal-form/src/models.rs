//! Hamiltonians written in Rust rather than in the model language, for independent checks
//! of the algebra (closed forms, hand-built test Hamiltonians). Real models are DSL files
//! (`models/*.lsl`) that go through [`normalize_model_file`](crate::normalize_model_file).

use crate::hamiltonian::HamiltonianFn;
use crate::monomial::MonomialTable;
use crate::poly::Poly;
use lasalle_model::ir::Scalar;
use std::sync::Arc;

/// A Hamiltonian given as a real polynomial in z = (q₁…q_n, p₁…p_n) (f64 coefficients).
///
/// ```
/// use lasalle_normal_form::models::PolynomialHamiltonian;
/// // H = ½(p² + q²) + q³/3: one degree of freedom, exponents of (q, p)
/// let h = PolynomialHamiltonian::from_terms(1, &[(0.5, &[2, 0]), (0.5, &[0, 2]), (1.0 / 3.0, &[3, 0])]);
/// assert_eq!(lasalle_normal_form::HamiltonianFn::eval(&h, &[1.0, 2.0]), 2.5 + 1.0 / 3.0);
/// ```
#[derive(Clone, Debug)]
pub struct PolynomialHamiltonian {
    /// The polynomial; its number of variables must be even.
    pub poly: Poly<f64>,
}

impl PolynomialHamiltonian {
    /// `Σ c·z^e` over `terms = [(c, e)]`, each `e` the 2n exponents of (q₁…q_n, p₁…p_n);
    /// repeated monomials add up.
    ///
    /// # Panics
    /// If an exponent vector does not have 2·`n_dof` entries.
    pub fn from_terms(n_dof: usize, terms: &[(f64, &[u8])]) -> Self {
        let degree = terms
            .iter()
            .map(|(_, e)| e.iter().map(|&x| x as usize).sum::<usize>())
            .max()
            .unwrap_or(0)
            .max(2);
        let table = Arc::new(MonomialTable::new(2 * n_dof, degree));
        let mut poly = Poly::zero(table);
        for &(c, e) in terms {
            assert_eq!(e.len(), 2 * n_dof, "exponents of (q, p)");
            let old = poly.coeff(e);
            poly.set_coeff(e, old + c);
        }
        PolynomialHamiltonian { poly }
    }
}

impl HamiltonianFn for PolynomialHamiltonian {
    fn n_dof(&self) -> usize {
        self.poly.nvars() / 2
    }
    fn eval<S: Scalar>(&self, z: &[S]) -> S {
        let mut sum = S::from_f64(0.0);
        for (k, i, c) in self.poly.terms() {
            let e = self.poly.exponents(k, i);
            let mut m = S::from_f64(c);
            for (v, &ev) in e.iter().enumerate() {
                if ev > 0 {
                    m = m.mul(&z[v].powi(ev as i32));
                }
            }
            sum = sum.add(&m);
        }
        sum
    }
    fn name(&self) -> String {
        "polynomial".into()
    }
}
