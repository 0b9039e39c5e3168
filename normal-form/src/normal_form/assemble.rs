//! The internal result of a run ([`Raw`], in the working precision) and its conversion
//! to a [`NormalForm`].

use super::options::Options;
use super::result::{
    ActionTerm, ArnoldMoser, DegreeError, Diagnostics, NormalForm, PolyMap, Remainder,
    ResonantTerm, SmallDivisor, Term, Timings, Value,
};
use crate::hamiltonian::HamiltonianFn;
use crate::linalg::Mat;
use crate::poly::Poly;
use crate::scalar::Real;

/// Internal result in the working precision.
pub(super) struct Raw<R> {
    pub(super) eq: crate::hamiltonian::Equilibrium<R>,
    pub(super) energy: R,
    pub(super) omega: Vec<R>,
    pub(super) sigma: Vec<i8>,
    pub(super) a: Mat<R>,
    pub(super) ainv: Mat<R>,
    pub(super) symplectic_residual: f64,
    pub(super) diagonal_residual: f64,
    pub(super) quadratic_residual: f64,
    /// dense over action exponents with 1 ≤ |a| ≤ N/2 (in table order of degree 2|a| with a=b)
    pub(super) hbar: Vec<(Vec<u32>, R)>,
    pub(super) hbar_imag: f64,
    pub(super) degrees: Vec<DegreeError>,
    pub(super) resonant_terms: Vec<ResonantTerm>,
    /// dense over all monomials of degrees 3…N
    pub(super) generating: Vec<(Vec<u32>, usize, R)>,
    pub(super) generating_imag: f64,
    pub(super) divisors: Vec<SmallDivisor>,
    pub(super) d4: Option<[R; 4]>,
    pub(super) remainder: Option<Remainder>,
    pub(super) to_normal: Option<Vec<Poly<R>>>,
    pub(super) from_normal: Option<Vec<Poly<R>>>,
    pub(super) transform_imag: f64,
    pub(super) timings: Timings,
    pub(super) table_bytes: usize,
}

fn to_f64_mat<R: Real>(m: &Mat<R>) -> Vec<Vec<f64>> {
    m.iter()
        .map(|r| r.iter().map(|x| x.to_f64()).collect())
        .collect()
}

/// `x − x.to_f64()` to the next double: the value is `to_f64() + lo_part` to about 10⁻³²
/// relative (0 in `f64`).
fn lo_part<R: Real>(x: R) -> f64 {
    let (h, l) = x.hi_lo();
    (h - x.to_f64()) + l
}

fn lo_mat<R: Real>(m: &Mat<R>) -> Vec<Vec<f64>> {
    m.iter()
        .map(|r| r.iter().map(|&x| lo_part(x)).collect())
        .collect()
}

pub(super) fn assemble<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    raw: Raw<R>,
    o: &Options,
) -> NormalForm {
    let map = |ps: Option<Vec<Poly<R>>>| {
        ps.map(|v| PolyMap {
            components: v.iter().map(|p| p.map(|c| c.to_f64())).collect(),
        })
    };
    let map_lo = |ps: &Option<Vec<Poly<R>>>| {
        ps.as_ref().map(|v| PolyMap {
            components: v.iter().map(|p| p.map(lo_part)).collect(),
        })
    };
    let to_normal_map_lo = map_lo(&raw.to_normal);
    let d4 = raw.d4.map(|[a, b, c, d]| ArnoldMoser {
        a: Value::of(a),
        b: Value::of(b),
        c: Value::of(c),
        d4: Value::of(d),
    });
    let generating = raw
        .generating
        .iter()
        .map(|(e, r, v)| Term {
            exponents: e.clone(),
            degree: *r,
            coeff: Value::of(*v),
        })
        .collect();
    NormalForm {
        model: h.name(),
        n_dof: h.n_dof(),
        order: o.order,
        precision: o.precision,
        resonant: o.resonant,
        coordinates: h.coordinate_names(),
        equilibrium: raw.eq.z.iter().map(|&x| Value::of(x)).collect(),
        energy: Value::of(raw.energy),
        omega: raw.omega.iter().map(|&x| Value::of(x)).collect(),
        signs: raw.sigma.clone(),
        linear_map: to_f64_mat(&raw.a),
        hamiltonian: raw
            .hbar
            .iter()
            .map(|(e, v)| ActionTerm {
                exponents: e.clone(),
                degree: 2 * e.iter().sum::<u32>() as usize,
                coeff: Value::of(*v),
            })
            .collect(),
        resonant_terms: raw.resonant_terms,
        generating_function: generating,
        small_divisors: raw.divisors,
        d4,
        diagnostics: Diagnostics {
            newton_iterations: raw.eq.iterations,
            gradient_norm: raw.eq.gradient,
            symplectic_residual: raw.symplectic_residual,
            diagonal_residual: raw.diagonal_residual,
            quadratic_residual: raw.quadratic_residual,
            hbar_imag_residual: raw.hbar_imag,
            hbar_degrees: raw.degrees,
            generating_imag_residual: raw.generating_imag,
            transform_imag_residual: raw.transform_imag,
            error_method: None,
            precision_note: None,
            amplification: None,
            timings: raw.timings,
            table_bytes: raw.table_bytes,
        },
        remainder: raw.remainder,
        to_normal_map: map(raw.to_normal),
        from_normal_map: map(raw.from_normal),
        linear_inverse: to_f64_mat(&raw.ainv),
        linear_inverse_lo: lo_mat(&raw.ainv),
        linear_map_lo: lo_mat(&raw.a),
        to_normal_map_lo,
    }
}
