//! Certified tube times: a lower bound on the time to leave a tube about an elliptic
//! equilibrium that is a theorem about the model (its Hamiltonian as evaluated exactly, with
//! the parameters' `f64` values), not about a truncated series.
//!
//! # What is proved, step by step
//!
//! Let `x*` be the true equilibrium (`∇H(x*) = 0`, enclosed in a box proved by the
//! Krawczyk operator in ball arithmetic, [`Ball`]; if that proof fails, the `f64`
//! equilibrium `x_e` takes its place and everything below holds with `x_e` for `x*` except
//! that the degree-1 coefficients are enclosed instead of zero) and `B` the matrix
//! [`NormalForm::linear_inverse`] + [`NormalForm::linear_inverse_lo`] (the normal form's A⁻¹
//! in its working precision, the two `f64` words taken as an exact double-double; the
//! `f64` matrix of an `f64` run), and let `y = B(x − x*)` (exact real arithmetic: this
//! *defines* the linear normal coordinates, and `|y|` is the `linear-normal` distance the
//! command prints). Let `T` be the polynomial map [`NormalForm::to_normal_map`] with its
//! coefficients `hi + lo` ([`NormalForm::to_normal_map_lo`]) taken as exact (in three or
//! more degrees of freedom cut at degree N,
//! [`CertifiedOptions::map_degree`]), and `W(x) = |T(y)|²`, `ρ = √W`. Nothing requires
//! `T` to be an exact conjugacy: `W` is just a function, and what follows bounds how fast
//! the true flow can change it.
//!
//! 1. **The field in y, enclosed.** `C ∋ B⁻¹` is an interval matrix (the approximate inverse
//!    `A`, refined in double-double, corrected by a Neumann-series bound on `I − BA`, in
//!    balls), `S ∋ B J Bᵀ` (in balls). With `H̃(y) = H(x* + B⁻¹y)`, `ẏ = S∇H̃(y)`. The
//!    Taylor polynomial of `H̃` at 0 to degree K + 1 is computed by evaluating the model's
//!    expression over interval jets ([`Jet`]`<`[`Iv`]`>`) at the box of `x*`: every
//!    coefficient is an interval containing the exact one; the degree-1 coefficients,
//!    `Cᵀ∇H(x*)`, are exactly 0 and set so. The
//!    rest of `∂_k H̃` beyond degree K is bounded by the Lagrange form: its coefficients at
//!    degree K + 1 are derivatives of order K + 2 at some point of the segment `[0, y]`,
//!    enclosed by the same jets evaluated at the interval box `[−R, R]ⁿ ⊃ {|y| ≤ R}`.
//! 2. **Taylor models.** Every function is a polynomial with interval coefficients of degree
//!    ≤ D plus a majorant `e(|y|) = Σ e_s |y|ˢ` of the difference, valid on `|y| ≤ R`
//!    ([`Majorant`]); products drop the degrees above D into the majorant. Each homogeneous
//!    part `P_s = Σ p_α y^α` is bounded on spheres by `|P_s(y)| ≤ b_s |y|ˢ` with
//!    `b_s = min(Σ|p_α|, (Σ|p_α|² α!/s!)^{1/2})`: the ℓ¹ sum (`|y^α| ≤ |y|^{|α|}`), or
//!    Cauchy–Schwarz against the multinomial identity `|y|^{2s} = Σ (s!/α!) y^{2α}`, which
//!    is never larger and is far smaller when many monomials share a degree.
//!    `Ẇ = 2 Σ_j v_j ẏ_j`, `v_j = Σ_i T_i ∂_j T_i = ½ ∂_j Σ_i T_i²`, is such a model (its
//!    degrees ≤ N, and N + 1 where the map is cut at N, intersected with their enclosure in
//!    balls from ball jets of H, the double-double T and B, [`Ball`]); its polynomial part keeps the
//!    cancellations of the normal form (the degrees below N + 1 are zero up to the
//!    coefficients' rounding, enclosed), so `|Ẇ(y)| ≤ G(|y|)` with a majorant G of degree
//!    N + 1 and above, up to rounding-size terms.
//! 3. **From |y| to ρ.** `T(y) = y + h(y)` with `|h(y)| ≤ τ(|y|)` (majorants of each
//!    component) and `|y·h(y)| ≤ κ(|y|)` (the majorant of the scalar polynomial y·h, which
//!    uses the direction of h), so on `|y| = r`:
//!    `max(r − τ(r), (r² − 2κ(r))^{1/2}) ≤ ρ ≤ min(r + τ(r), (r² + 2κ(r) + τ(r)²)^{1/2})`.
//!    The lower bound ψ(r) is increasing on `[0, R]` (each of its two parts is used only
//!    where its derivative is checked positive up to R; with neither, u = R below), so a
//!    point with `|y| ≤ R` and `ρ(y) = ρ` has `|y| ≤ u(ρ) = min(R, ψ⁻¹(ρ))`, and
//!    `dρ/dt = Ẇ/(2ρ) ≤ G(u(ρ))/(2ρ)`.
//! 4. **The tube.** ρ₀ bounds ρ on the inner ball `|y| ≤ d₀` from above (the smaller of
//!    the bounds of step 3 at d₀ and the interval branch and bound of `|T(y)|²` over the
//!    ball), ρ₁ bounds ρ from below on the outer sphere `|y| = d₁ = R`: the larger of
//!    `(d₁² − 2κ(d₁))^{1/2}` and `d₁ − max_{|y|≤d₁} |h(y)|`, the maximum bounded by branch
//!    and bound of `|h|²` (or by τ(d₁)). An orbit from the
//!    inner ball that reaches the outer sphere has ρ going from ≤ ρ₀ to ≥ ρ₁ while inside
//!    the ball, so by comparison it needs at least
//!    `∫_{ρ₀}^{ρ₁} 2ρ dρ / G(u(ρ)) ≥ Σ_k (ρ_{k+1} − ρ_k) 2ρ_k / G(u(ρ_{k+1}))`,
//!    each term rounded down ([`CertifiedTube::time`]).
//! 5. **Euclidean tubes** `|x − x*| ≤ d` are reduced to the above by
//!    `|y| ≤ ‖B‖_F |x − x*|` and `|x − x*| ≤ ‖C‖_F |y|`.
//!
//! Assumed, not proved: that the platform's `exp`, `ln`, `sin`, `cos`, `pow` are accurate
//! to [`LIBM_ULPS`](super::LIBM_ULPS) ulps (IEEE arithmetic and `√` are exact to the
//! rounding); the model's expression is what is evaluated, so the model file is the theorem's
//! hypothesis (the parameters as `f64`). What the bound loses against the true exit time:
//! G bounds |Ẇ| over whole spheres (every direction at once; at Earth–Moon L4 the largest
//! |Ẇ| sampled on the spheres is within a factor 3–7 of it), the Taylor models' degrees
//! above M, and u(ρ) ≥ |y|.

// index loops over coordinates read as the formulas they implement
#![allow(clippy::needless_range_loop)]

use super::ball::Ball;
use super::{add_up, mul_up, Iv};
use crate::bound::Metric;
use crate::error::NormalFormError;
use crate::hamiltonian::HamiltonianFn;
use crate::jet::Jet;
use crate::monomial::MonomialTable;
use crate::normal_form::NormalForm;
use crate::poly::Poly;
use serde::Serialize;
use std::sync::Arc;

/// A univariate majorant `m(r) = Σ_s c_s rˢ`, `c_s ≥ 0` upper bounds (rounded up), for
/// `r = |y| ≥ 0`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Majorant {
    /// `c_s` by degree s.
    pub c: Vec<f64>,
}

/// `xᵏ` rounded up (x ≥ 0).
fn pow_up(x: f64, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, _| mul_up(acc, x))
}

/// An upper bound on `α!/s!` (`s = |α|`), the reciprocal of the multinomial coefficient
/// `s!/α!`: computed exactly in integers, then rounded so that the bound is never below it
/// (1 when the integers overflow: `α!/s! ≤ 1` always).
fn inverse_multinomial_up(alpha: &[u8]) -> f64 {
    // s!/α! = Π_j C(a_1 + … + a_j, a_j), each binomial exact
    let mut m: u128 = 1;
    let mut total: u128 = 0;
    for &a in alpha {
        let a = a as u128;
        total += a;
        // C(total, a) = Π_{i=1..a} (total − a + i)/i, exact at every step
        let mut b: u128 = 1;
        for i in 1..=a {
            b = match b.checked_mul(total - a + i) {
                Some(x) => x / i,
                None => return 1.0,
            };
        }
        m = match m.checked_mul(b) {
            Some(x) => x,
            None => return 1.0,
        };
    }
    // m as f64 is within half an ulp of m; one ulp down is below m
    let mf = m as f64;
    let m_lo = if mf < 9.007_199_254_740_992e15 {
        mf
    } else {
        mf.next_down()
    };
    (Iv::point(1.0) / Iv::point(m_lo)).hi.min(1.0)
}

/// The bound of one homogeneous part on the unit sphere: `|P_s(y)| ≤ b_s |y|ˢ` with
/// `b_s = min(Σ|p_α|, (Σ |p_α|² α!/s!)^{1/2})`, rounded up. The first is the triangle
/// inequality with `|y^α| ≤ |y|^{|α|}`; the second is Cauchy–Schwarz against the multinomial
/// identity `|y|^{2s} = Σ_{|α|=s} (s!/α!) y^{2α}`:
/// `|Σ p_α y^α| = |Σ (p_α (α!/s!)^{1/2}) ((s!/α!)^{1/2} y^α)| ≤ (Σ p_α² α!/s!)^{1/2} |y|ˢ`.
/// The weighted ℓ² form is never larger and is much smaller when many monomials share
/// a degree (the ℓ¹ sum counts each at its worst direction, which no single y attains).
fn sphere_bound(p: &Poly<Iv>, k: usize) -> f64 {
    let Some(part) = p.part(k) else {
        return 0.0;
    };
    let (mut l1, mut l2) = (0.0, 0.0);
    for (i, c) in part.iter().enumerate() {
        let m = c.mag();
        if m == 0.0 {
            continue;
        }
        l1 = add_up(l1, m);
        let w = inverse_multinomial_up(p.exponents(k, i));
        l2 = add_up(l2, mul_up(mul_up(m, m), w));
    }
    l1.min(l2.sqrt().next_up())
}

impl Majorant {
    /// Σ_s b_s rˢ with `b_s` the bound of the homogeneous part of degree s on the unit
    /// sphere (the smaller of the ℓ¹ sum Σ|p_α| and the weighted ℓ² norm
    /// (Σ|p_α|² α!/s!)^{1/2}), so `|p(y)| ≤ m(|y|)`.
    pub fn of_poly(p: &Poly<Iv>) -> Majorant {
        let c = (0..=p.max_degree()).map(|k| sphere_bound(p, k)).collect();
        Majorant { c }
    }
    /// Σ_s (Σ_{|α|=s} |p_α|) rˢ: the ℓ¹ majorant alone (the bound before the weighted ℓ²
    /// form; kept to report how much that form gains).
    pub fn of_poly_l1(p: &Poly<Iv>) -> Majorant {
        let c = (0..=p.max_degree())
            .map(|k| {
                p.part(k)
                    .map_or(0.0, |part| part.iter().fold(0.0, |s, c| add_up(s, c.mag())))
            })
            .collect();
        Majorant { c }
    }
    /// The coefficients above degree d only.
    pub fn above(&self, d: usize) -> Majorant {
        Majorant {
            c: self
                .c
                .iter()
                .enumerate()
                .map(|(s, &c)| if s > d { c } else { 0.0 })
                .collect(),
        }
    }
    /// Sum (rounded up).
    pub fn add(&self, o: &Majorant) -> Majorant {
        let n = self.c.len().max(o.c.len());
        let g = |v: &Vec<f64>, i: usize| v.get(i).copied().unwrap_or(0.0);
        Majorant {
            c: (0..n).map(|i| add_up(g(&self.c, i), g(&o.c, i))).collect(),
        }
    }
    /// Product (rounded up).
    pub fn mul(&self, o: &Majorant) -> Majorant {
        if self.c.is_empty() || o.c.is_empty() {
            return Majorant::default();
        }
        let mut c = vec![0.0; self.c.len() + o.c.len() - 1];
        for (i, &a) in self.c.iter().enumerate() {
            if a == 0.0 {
                continue;
            }
            for (j, &b) in o.c.iter().enumerate() {
                c[i + j] = add_up(c[i + j], mul_up(a, b));
            }
        }
        Majorant { c }
    }
    /// `s · m` (rounded up), s ≥ 0.
    pub fn scaled(&self, s: f64) -> Majorant {
        Majorant {
            c: self.c.iter().map(|&c| mul_up(c, s)).collect(),
        }
    }
    /// m(r) rounded up, r ≥ 0.
    pub fn eval(&self, r: f64) -> f64 {
        self.c
            .iter()
            .rev()
            .fold(0.0, |acc, &c| add_up(mul_up(acc, r), c))
    }
    /// m′(r) rounded up.
    pub fn derivative_at(&self, r: f64) -> f64 {
        self.c
            .iter()
            .enumerate()
            .skip(1)
            .rev()
            .fold(0.0, |acc, (s, &c)| {
                add_up(mul_up(acc, r), mul_up(c, s as f64))
            })
    }
}

/// A Taylor model on the ball `|y| ≤ R`: `f(y) ∈ p(y) + [−e(|y|), e(|y|)]`.
#[derive(Clone, Debug)]
struct Tm {
    p: Poly<Iv>,
    e: Majorant,
}

impl Tm {
    fn exact(p: Poly<Iv>) -> Tm {
        Tm {
            p,
            e: Majorant::default(),
        }
    }
    fn add(&self, o: &Tm) -> Tm {
        Tm {
            p: self.p.add(&o.p),
            e: self.e.add(&o.e),
        }
    }
    fn mul(&self, o: &Tm) -> Tm {
        let d = self.p.max_degree();
        let (a, b) = (Majorant::of_poly(&self.p), Majorant::of_poly(&o.p));
        let high = a.mul(&b).above(d);
        let e = high
            .add(&a.mul(&o.e))
            .add(&self.e.mul(&b))
            .add(&self.e.mul(&o.e));
        Tm {
            p: self.p.mul(&o.p),
            e,
        }
    }
    fn scaled(&self, c: Iv) -> Tm {
        Tm {
            p: self.p.scaled(c),
            e: self.e.scaled(c.mag()),
        }
    }
    fn majorant(&self) -> Majorant {
        Majorant::of_poly(&self.p).add(&self.e)
    }
}

/// Options of the certified bound.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CertifiedOptions {
    /// Degree of the map T used in W = |T(y)|² (default: the whole map, degree M − 1, in
    /// two degrees of freedom; the normal form's order N from three on, where the Taylor
    /// models of degree M + 1 in six variables are too large).
    pub map_degree: Option<usize>,
    /// Degree K of the field's Taylor polynomial (default: the map's degree + 1 in two
    /// degrees of freedom, N + 1 from three on).
    pub field_degree: Option<usize>,
    /// Truncation degree D of the Taylor models (default: max(K, the map's degree) + 1).
    pub model_degree: Option<usize>,
    /// Intervals of the final quadrature.
    pub intervals: usize,
    /// Relative gap at which the branch and bound for ρ₀², ρ₁² stops.
    pub tolerance: f64,
    /// Box budget of each branch and bound (the bound is certified when it runs out, only
    /// less sharp).
    pub budget: usize,
}

impl Default for CertifiedOptions {
    fn default() -> Self {
        CertifiedOptions {
            map_degree: None,
            field_degree: None,
            model_degree: None,
            intervals: 2048,
            tolerance: 2e-2,
            budget: 4_000,
        }
    }
}

/// The certified bound of one tube.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CertifiedTube {
    /// The tube's radii in the given metric.
    pub d0: f64,
    /// Outer radius.
    pub d1: f64,
    /// Inner and outer radii in `|y|` (equal to d0, d1 in the linear-normal metric).
    pub y0: f64,
    /// Outer radius in `|y|`.
    pub y1: f64,
    /// Certified upper bound of ρ on the inner ball.
    pub rho0: f64,
    /// Certified lower bound of ρ on the outer sphere.
    pub rho1: f64,
    /// The certified time (a lower bound on the exit time); `None` when ρ₁ ≤ ρ₀.
    pub time: Option<f64>,
    /// The degree of the map T in W = |T(y)|².
    pub map_degree: usize,
    /// K, the field's Taylor degree.
    pub field_degree: usize,
    /// D, the Taylor models' degree.
    pub model_degree: usize,
    /// The majorant G of |Ẇ| (coefficients by degree of |y|).
    pub wdot: Majorant,
    /// τ(d₁): the bound on |T(y) − y| on the outer sphere.
    pub tau1: f64,
    /// Boxes of the branch and bound (both extrema).
    pub boxes: usize,
    /// The degrees L to which h = T − id enters the two branch and bounds (the rest is
    /// bounded by its sphere bounds: [`CertifiedSetup`]).
    pub extremum_degrees: (usize, usize),
    /// The half-width (in x, the largest coordinate's) of the box proved to contain the
    /// true equilibrium, the tube's centre; `None` when the proof failed and the centre is
    /// the `f64` equilibrium (then Ẇ keeps a degree-1 term of rounding size).
    pub centre_radius: Option<f64>,
    /// Seconds spent.
    pub seconds: f64,
}

/// Interval enclosure of `B⁻¹` from the approximate inverse `a`: with `E = I − B·a`,
/// `B⁻¹ = a(I − E)⁻¹ = a + aE(I − E)⁻¹`, so every entry of `B⁻¹ − a` is at most
/// `‖aE‖_∞ / (1 − ‖E‖_∞)` in absolute value.
fn inverse_enclosure(bi: &[Vec<Iv>], a: &[Vec<f64>]) -> Option<Vec<Vec<Iv>>> {
    let n = bi.len();
    let bi = bi.to_vec();
    let ai: Vec<Vec<Iv>> = a
        .iter()
        .map(|r| r.iter().map(|&x| Iv::point(x)).collect())
        .collect();
    let mm = |x: &Vec<Vec<Iv>>, y: &Vec<Vec<Iv>>| -> Vec<Vec<Iv>> {
        (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0..n).fold(Iv::point(0.0), |s, k| s + x[i][k] * y[k][j]))
                    .collect()
            })
            .collect()
    };
    let ba = mm(&bi, &ai);
    let e: Vec<Vec<Iv>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| Iv::point(if i == j { 1.0 } else { 0.0 }) - ba[i][j])
                .collect()
        })
        .collect();
    let norm_inf = |m: &Vec<Vec<Iv>>| {
        m.iter()
            .map(|r| r.iter().fold(0.0, |s, c| add_up(s, c.mag())))
            .fold(0.0, f64::max)
    };
    let eps = norm_inf(&e);
    if eps >= 0.5 {
        return None;
    }
    let ae = mm(&ai, &e);
    // ‖aE‖/(1 − ε), rounded up (1 − ε rounded down)
    let delta = (Iv::point(norm_inf(&ae)) / Iv::point((1.0 - eps).next_down())).hi;
    Some(
        ai.iter()
            .map(|r| r.iter().map(|&c| c + Iv::symmetric(delta)).collect())
            .collect(),
    )
}

/// Frobenius norm of an interval matrix, rounded up (≥ the spectral norm).
fn frobenius_up(m: &[Vec<Iv>]) -> f64 {
    let s = m
        .iter()
        .flatten()
        .fold(0.0, |s, c| add_up(s, mul_up(c.mag(), c.mag())));
    s.sqrt().next_up()
}

/// Taylor polynomial of H at `x + C(base + t)` in t to the table's degree, over interval
/// jets, for every x in the box `xe` (base = 0 for the expansion at the equilibrium, a box
/// for the Lagrange remainder).
fn jet_at<H: HamiltonianFn + ?Sized>(
    h: &H,
    xe: &[Iv],
    c: &[Vec<Iv>],
    base: &[Iv],
    table: &Arc<MonomialTable>,
) -> Poly<Iv> {
    let n = xe.len();
    let inputs: Vec<Jet<Iv>> = (0..n)
        .map(|i| {
            let c0 = (0..n).fold(xe[i], |s, j| s + c[i][j] * base[j]);
            let p = Poly::linear(table.clone(), &c[i]).add_constant(c0);
            Jet::Series(p)
        })
        .collect();
    h.eval(&inputs).into_poly(table)
}

/// Taylor polynomial of H at `x + Ct` (`x + t` without C) in t over ball jets (double-double
/// centres), for every x in the balls `x` and every matrix in the balls `C`.
fn ball_jet<H: HamiltonianFn + ?Sized>(
    h: &H,
    x: &[Ball],
    c: Option<&[Vec<Ball>]>,
    table: &Arc<MonomialTable>,
) -> Poly<Ball> {
    let n = x.len();
    let inputs: Vec<Jet<Ball>> = (0..n)
        .map(|i| {
            let p = match c {
                Some(c) => Poly::linear(table.clone(), &c[i]).add_constant(x[i]),
                None => Poly::variable(table.clone(), i, x[i]),
            };
            Jet::Series(p)
        })
        .collect();
    h.eval(&inputs).into_poly(table)
}

/// The gradient (degree-1 coefficients) and Hessian (from the degree-2 ones) of a Taylor
/// polynomial of degree ≥ 2.
fn grad_hess(p: &Poly<Ball>, n: usize) -> (Vec<Ball>, Vec<Vec<Ball>>) {
    let mut g = vec![Ball::point(0.0); n];
    let mut hs = vec![vec![Ball::point(0.0); n]; n];
    for i in 0..n {
        let mut e = vec![0u8; n];
        e[i] = 1;
        g[i] = p.coeff(&e);
        for j in i..n {
            let mut e = vec![0u8; n];
            e[i] += 1;
            e[j] += 1;
            let c = p.coeff(&e);
            if i == j {
                hs[i][i] = c * Ball::point(2.0);
            } else {
                hs[i][j] = c;
                hs[j][i] = c;
            }
        }
    }
    (g, hs)
}

/// A matrix of balls.
type BallMatrix = Vec<Vec<Ball>>;

fn ball_matmul(a: &[Vec<Ball>], b: &[Vec<Ball>]) -> Vec<Vec<Ball>> {
    let (n, m, l) = (a.len(), b.len(), b.first().map_or(0, |r| r.len()));
    (0..n)
        .map(|i| {
            (0..l)
                .map(|j| (0..m).fold(Ball::point(0.0), |s, k| s + a[i][k] * b[k][j]))
                .collect()
        })
        .collect()
}

fn ball_points(m: &[Vec<f64>]) -> Vec<Vec<Ball>> {
    m.iter()
        .map(|r| r.iter().map(|&x| Ball::point(x)).collect())
        .collect()
}

/// The true equilibrium x* (∇H(x*) = 0) enclosed in a box of double-double balls by the
/// Krawczyk operator: from x̃ (the normal form's double-double equilibrium, refined by two
/// Newton steps) and a box X = x̃ + [−w, w]ⁿ,
/// `K(X) = x̃ − Y∇H(x̃) + (I − Y∇²H(X))(X − x̃)` with Y ≈ ∇²H(x̃)⁻¹ (any real matrix) and
/// ∇²H(X) enclosing the Hessian over the whole box (ball jets at the box). If K(X) lies in
/// the interior of X, ∇H has exactly one zero in X and it lies in K(X) (Krawczyk 1969;
/// Moore, *Methods and applications of interval analysis*, 1979, §5.2). `None` when the
/// test fails for every w tried (e.g. a model whose functions the balls do not enclose).
fn prove_equilibrium<H: HamiltonianFn + ?Sized>(h: &H, nf: &NormalForm) -> Option<Vec<Ball>> {
    let n = 2 * nf.n_dof;
    let t1 = Arc::new(MonomialTable::new(n, 2));
    let mut x: Vec<Ball> = nf
        .equilibrium
        .iter()
        .map(|v| Ball::new(v.value, v.lo, 0.0))
        .collect();
    let hess_f64 = |x: &[Ball]| -> Option<(Vec<Ball>, Vec<Vec<f64>>)> {
        let (g, hs) = grad_hess(&ball_jet(h, x, None, &t1), n);
        let hm: Vec<Vec<f64>> = hs
            .iter()
            .map(|r| r.iter().map(|c| c.mid()).collect())
            .collect();
        let y = crate::linalg::inverse(&hm)?;
        y.iter().flatten().all(|v| v.is_finite()).then_some((g, y))
    };
    for _ in 0..2 {
        let (g, y) = hess_f64(&x)?;
        let yb = ball_points(&y);
        x = (0..n)
            .map(|i| {
                let step = (0..n).fold(Ball::point(0.0), |s, j| s + yb[i][j] * g[j]);
                (x[i] - step).centre()
            })
            .collect();
    }
    let (g, y) = hess_f64(&x)?;
    let yb = ball_points(&y);
    let yg: Vec<Ball> = (0..n)
        .map(|i| (0..n).fold(Ball::point(0.0), |s, j| s + yb[i][j] * g[j]))
        .collect();
    let scale = x.iter().map(|b| b.mid().abs()).fold(1.0, f64::max);
    let mut w = (1e-28 * scale).max(4.0 * yg.iter().map(|b| b.mag()).fold(0.0, f64::max));
    for _ in 0..6 {
        let xb: Vec<Ball> = x.iter().map(|b| b.with_radius(w)).collect();
        let (_, hs) = grad_hess(&ball_jet(h, &xb, None, &t1), n);
        let yh = ball_matmul(&yb, &hs);
        let dk: Vec<Ball> = (0..n)
            .map(|i| {
                (0..n).fold(-yg[i], |s, j| {
                    let id = if i == j { 1.0 } else { 0.0 };
                    s + (Ball::point(id) - yh[i][j]) * Ball::point(0.0).with_radius(w)
                })
            })
            .collect();
        if dk.iter().all(|d| crate::Coeff::is_finite(d) && d.mag() < w) {
            return Some(
                (0..n)
                    .map(|i| {
                        let c = x[i] + dk[i].centre();
                        c.with_radius(add_up(c.rad, dk[i].rad))
                    })
                    .collect(),
            );
        }
        w *= 1e3;
    }
    None
}

/// The linear normalisation in ball arithmetic (B and A exact double-doubles, the normal
/// form's in its working precision): `C ∋ B⁻¹` (the approximate inverse A
/// refined by one Newton step to A₂ = A + A(I − BA) in double-double, then the
/// Neumann-series bound of [`inverse_enclosure`] with E = I − BA₂ enclosed in balls) and
/// `S ∋ BJBᵀ`, both to about 10⁻³⁰ instead of the `f64` rounding.
fn linear_balls(bb: &[Vec<Ball>], ab: &[Vec<Ball>], nd: usize) -> Option<(BallMatrix, BallMatrix)> {
    let n = bb.len();
    let id = |i: usize, j: usize| Ball::point(if i == j { 1.0 } else { 0.0 });
    let ba = ball_matmul(bb, ab);
    let e0: Vec<Vec<Ball>> = (0..n)
        .map(|i| (0..n).map(|j| id(i, j) - ba[i][j]).collect())
        .collect();
    let corr = ball_matmul(ab, &e0);
    let a2: Vec<Vec<Ball>> = (0..n)
        .map(|i| (0..n).map(|j| (ab[i][j] + corr[i][j]).centre()).collect())
        .collect();
    let ba2 = ball_matmul(bb, &a2);
    let e: Vec<Vec<Ball>> = (0..n)
        .map(|i| (0..n).map(|j| id(i, j) - ba2[i][j]).collect())
        .collect();
    let norm_inf = |m: &Vec<Vec<Ball>>| {
        m.iter()
            .map(|r| r.iter().fold(0.0, |s, c| add_up(s, c.mag())))
            .fold(0.0, f64::max)
    };
    let eps = norm_inf(&e);
    if eps.is_nan() || eps >= 0.5 {
        return None;
    }
    let delta =
        (Iv::point(norm_inf(&ball_matmul(&a2, &e))) / Iv::point((1.0 - eps).next_down())).hi;
    if !delta.is_finite() {
        return None;
    }
    let c = a2
        .iter()
        .map(|r| {
            r.iter()
                .map(|x| x.with_radius(add_up(x.rad, delta)))
                .collect()
        })
        .collect();
    let s = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    (0..n).fold(Ball::point(0.0), |acc, k| {
                        let jb = if k < nd {
                            bb[j][k + nd]
                        } else {
                            -bb[j][k - nd]
                        };
                        acc + bb[i][k] * jb
                    })
                })
                .collect()
        })
        .collect();
    Some((c, s))
}

/// The degrees ≤ l of `Ẇ/2 = Σ_j v_j ẏ_j` (`v_j = Σ_i T_i ∂_j T_i`, `ẏ = S∇H̃`) in balls:
/// H̃'s Taylor polynomial to degree l + 1 from ball jets of H at the proved box of x\* with
/// C ∋ B⁻¹ (its degree-1 coefficients, C^T∇H(x\*), exactly 0), S ∋ BJBᵀ, and the map T
/// with its double-double coefficients (`t`, taken as exact). These are the degrees where
/// the normal form's cancellations leave only rounding: in balls they come out near 10⁻³⁰
/// of the coefficients that cancel, where the `f64` intervals leave 10⁻¹⁶.
fn wdot_low_balls<H: HamiltonianFn + ?Sized>(
    h: &H,
    centre: &[Ball],
    c: &[Vec<Ball>],
    s: &[Vec<Ball>],
    t: &[Poly<Ball>],
    l: usize,
) -> Poly<Ball> {
    let n = centre.len();
    let t_l1 = Arc::new(MonomialTable::new(n, l + 1));
    let t_l = Arc::new(MonomialTable::new(n, l));
    let mut hb = ball_jet(h, centre, Some(c), &t_l1);
    for i in 0..n {
        let mut e = vec![0u8; n];
        e[i] = 1;
        hb.set_coeff(&e, Ball::point(0.0));
    }
    let grad: Vec<Poly<Ball>> = (0..n)
        .map(|v| hb.derivative(v).retabled(t_l.clone()))
        .collect();
    // v_j = Σ_i T_i ∂_j T_i = ½ ∂_j Σ_i T_i², its degrees ≤ l from the squares cut at l + 1
    let sq = t
        .iter()
        .fold(Poly::zero(t_l1.clone()), |acc: Poly<Ball>, p| {
            let p = p.retabled(t_l1.clone());
            acc.add(&p.mul(&p))
        });
    let mut w = Poly::zero(t_l.clone());
    for j in 0..n {
        let ydot = (0..n).fold(Poly::zero(t_l.clone()), |acc: Poly<Ball>, i| {
            acc.add(&grad[i].scaled(s[j][i]))
        });
        let v = sq
            .derivative(j)
            .scaled(Ball::point(0.5))
            .retabled(t_l.clone());
        w = w.add(&v.mul(&ydot));
    }
    w
}

/// A polynomial whose coefficients are `hi + lo` (`lo` on the same table, or none), mapped
/// coefficient-wise by `f(hi, lo)`.
fn dd_poly<T: crate::Coeff>(
    hi: &Poly<f64>,
    lo: Option<&Poly<f64>>,
    f: impl Fn(f64, f64) -> T,
) -> Poly<T> {
    let mut p = Poly::zero(hi.table().clone());
    for k in 0..=hi.max_degree() {
        if let Some(ph) = hi.part(k) {
            let pl = lo.and_then(|l| l.part(k));
            let part = ph
                .iter()
                .enumerate()
                .map(|(i, &x)| f(x, pl.and_then(|pl| pl.get(i).copied()).unwrap_or(0.0)))
                .collect();
            p.set_part(k, part);
        }
    }
    p
}

/// The intersection of two enclosures of the same number (`None` if they are disjoint,
/// which would mean an enclosure is wrong).
fn intersect(a: Iv, b: Iv) -> Option<Iv> {
    let (lo, hi) = (a.lo.max(b.lo), a.hi.min(b.hi));
    (lo <= hi).then(|| Iv::new(lo, hi))
}

/// Certified extrema of `ρ² = |T(y)|² = |y|² + 2y·h(y) + |h(y)|²` (`h = T − id`) by interval
/// branch and bound on boxes of y: each box's enclosure uses the mean-value form
/// `h(Y) ⊂ h(c) + Dh(Y)(Y − c)` (the dominant |y|² part is exact on the sphere, and bounded
/// by the box on the ball).
///
/// Only the low degrees of h enter the boxes: `h = h_L + h_>L` with L the lowest degree at
/// which the sphere bounds of the higher parts give `|h_>L(y)| ≤ ε` on the ball `|y| ≤ d`
/// with ε below a small fraction of the requested gap (`ε ≤ 10⁻³·tol·d`); ε is then added to
/// every enclosure (`|T(y)| ∈ |y + h_L(y)| ± ε`, `|h(y)| ∈ |h_L(y)| ± ε`). The monomials of
/// `h_L` and of its derivatives are evaluated once per box and shared by all of them.
struct Extremum {
    n: usize,
    /// The monomials of h_L and Dh_L.
    monos: Monomials,
    /// h_L = T − id cut at degree L.
    hot: Vec<Sparse>,
    /// ∂h_L,i/∂y_j.
    dhot: Vec<Vec<Sparse>>,
    /// L (for the power tables).
    degree: usize,
    /// |h − h_L| ≤ ε on the ball (rounded up).
    eps: f64,
}

/// Monomials of n variables, each computed from its parent (the same exponents with the
/// last non-zero one cleared) times one power of one coordinate.
struct Monomials {
    n: usize,
    index: std::collections::HashMap<Vec<u8>, u32>,
    /// (parent, variable, exponent); entry 0 is the constant 1.
    recipe: Vec<(u32, u8, u8)>,
}

impl Monomials {
    fn new(n: usize) -> Monomials {
        let mut index = std::collections::HashMap::new();
        index.insert(vec![0u8; n], 0);
        Monomials {
            n,
            index,
            recipe: vec![(0, 0, 0)],
        }
    }
    fn insert(&mut self, e: &[u8]) -> u32 {
        if let Some(&i) = self.index.get(e) {
            return i;
        }
        let v = (0..self.n).rev().find(|&v| e[v] > 0).unwrap_or(0);
        let mut parent = e.to_vec();
        parent[v] = 0;
        let p = self.insert(&parent);
        let i = self.recipe.len() as u32;
        self.recipe.push((p, v as u8, e[v]));
        self.index.insert(e.to_vec(), i);
        i
    }
    /// The value of every monomial, with `pw[v][e]` = (coordinate v)ᵉ.
    fn values(&self, pw: &[Vec<Iv>]) -> Vec<Iv> {
        let mut vals = Vec::with_capacity(self.recipe.len());
        vals.push(Iv::point(1.0));
        for &(p, v, e) in &self.recipe[1..] {
            let x = pw[v as usize][e as usize];
            let m = if p == 0 { x } else { vals[p as usize] * x };
            vals.push(m);
        }
        vals
    }
}

/// A polynomial as (monomial, coefficient) pairs over a [`Monomials`] table.
struct Sparse {
    terms: Vec<(u32, Iv)>,
}

/// `c·x` enclosed, with a fast path for a point coefficient.
fn mul_coeff(c: Iv, x: Iv) -> Iv {
    if c.lo == c.hi {
        let a = c.lo;
        if a == 0.0 {
            return Iv::point(0.0);
        }
        let (p, q) = if a > 0.0 { (x.lo, x.hi) } else { (x.hi, x.lo) };
        let lo = super::mul_bounds(a, p).0;
        let hi = super::mul_bounds(a, q).1;
        if lo.is_nan() || hi.is_nan() {
            return Iv::point(f64::NAN);
        }
        return Iv { lo, hi };
    }
    c * x
}

impl Sparse {
    fn new(p: &Poly<Iv>, monos: &mut Monomials) -> Sparse {
        let mut terms = Vec::new();
        for (k, i, c) in p.terms() {
            if !(c.lo == 0.0 && c.hi == 0.0) {
                terms.push((monos.insert(p.exponents(k, i)), c));
            }
        }
        Sparse { terms }
    }
    fn eval(&self, vals: &[Iv]) -> Iv {
        let mut sum = Iv::point(0.0);
        for &(i, c) in &self.terms {
            sum += mul_coeff(c, vals[i as usize]);
        }
        sum
    }
}

/// Powers of each coordinate of a box up to `degree` (even powers as squares: tighter on
/// boxes containing 0).
fn powers(bx: &[Iv], degree: usize) -> Vec<Vec<Iv>> {
    bx.iter()
        .map(|&b| {
            let mut v = Vec::with_capacity(degree + 1);
            v.push(Iv::point(1.0));
            for e in 1..=degree {
                let next = if e % 2 == 0 {
                    v[e / 2].sqr()
                } else {
                    v[e - 1] * b
                };
                v.push(next);
            }
            v
        })
        .collect()
}

/// The result of a branch and bound: the certified bound, and the boxes used.
#[derive(Clone, Copy, Debug)]
struct Bnb {
    bound: f64,
    boxes: usize,
}

/// A box keyed by its bound, for the priority queue.
#[derive(PartialEq)]
struct Keyed(f64, Vec<Iv>);
impl Eq for Keyed {}
impl PartialOrd for Keyed {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Keyed {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// `(√a ± ε)²` for the enclosure `a` of a square: the square of a norm moved by at most ε.
fn widen_sq(a: Iv, eps: f64) -> Iv {
    if eps == 0.0 {
        return a;
    }
    let hi = {
        let r = add_up(a.hi.max(0.0).sqrt().next_up(), eps);
        mul_up(r, r)
    };
    let lo = {
        let r = (a.lo.max(0.0).sqrt().next_down() - eps).next_down();
        if r > 0.0 {
            (r * r).next_down()
        } else {
            0.0
        }
    };
    Iv::new(lo, hi)
}

impl Extremum {
    /// For the ball `|y| ≤ radius`, h_L cut where the rest is below `eps_target` there.
    fn new(hots: &[Poly<Iv>], radius: f64, eps_target: f64) -> Extremum {
        let n = hots.len();
        let full = hots.iter().map(|h| h.max_degree()).max().unwrap_or(1);
        // |h_i,s(y)| ≤ b_is |y|ˢ; the tail beyond L on the ball, as a Euclidean norm
        let parts: Vec<Vec<f64>> = hots
            .iter()
            .map(|h| {
                (0..=full)
                    .map(|s| mul_up(sphere_bound(h, s), pow_up(radius, s)))
                    .collect()
            })
            .collect();
        let tail = |l: usize| -> f64 {
            let s = parts.iter().fold(0.0, |acc, b| {
                let t = b.iter().skip(l + 1).fold(0.0, |a, &x| add_up(a, x));
                add_up(acc, mul_up(t, t))
            });
            if s == 0.0 {
                0.0
            } else {
                s.sqrt().next_up()
            }
        };
        let degree = (2..=full)
            .find(|&l| tail(l) <= eps_target)
            .unwrap_or(full)
            .max(2);
        let mut monos = Monomials::new(n);
        // point coefficients (two products per term, not four): h_L = m + (h_L − m), m the
        // coefficients' midpoints, |h_L,i(y) − m_i(y)| ≤ Σ_α rad_α |y|^|α| on the ball, and
        // the norm of those bounds is added to ε (T's double-double coefficients are
        // enclosed in intervals an ulp wide)
        let mut rad_sq = 0.0;
        let low: Vec<Poly<Iv>> = hots
            .iter()
            .map(|h| {
                let mut h = h.clone();
                h.truncate(degree);
                let mut r = 0.0;
                for (k, _, c) in h.terms() {
                    if crate::Coeff::is_finite(&c) {
                        let m = c.mid();
                        let rad = (Iv::point(c.hi) - Iv::point(m))
                            .hi
                            .max((Iv::point(m) - Iv::point(c.lo)).hi);
                        r = add_up(r, mul_up(rad, pow_up(radius, k)));
                    }
                }
                rad_sq = add_up(rad_sq, mul_up(r, r));
                h.map(|c| {
                    if crate::Coeff::is_finite(&c) {
                        Iv::point(c.mid())
                    } else {
                        c
                    }
                })
            })
            .collect();
        let eps = add_up(tail(degree), rad_sq.sqrt().next_up());
        let hot = low.iter().map(|h| Sparse::new(h, &mut monos)).collect();
        let dhot = low
            .iter()
            .map(|h| {
                (0..n)
                    .map(|j| Sparse::new(&h.derivative(j), &mut monos))
                    .collect()
            })
            .collect();
        Extremum {
            n,
            monos,
            hot,
            dhot,
            degree,
            eps,
        }
    }
    /// h_L and Dh_L enclosed over a box of y (mean-value form for h_L).
    fn h_dh(&self, yb: &[Iv]) -> (Vec<Iv>, Vec<Vec<Iv>>) {
        let c: Vec<Iv> = yb.iter().map(|b| Iv::point(b.mid())).collect();
        let vc = self.monos.values(&powers(&c, self.degree));
        let vb = self.monos.values(&powers(yb, self.degree));
        let dh: Vec<Vec<Iv>> = (0..self.n)
            .map(|i| (0..self.n).map(|j| self.dhot[i][j].eval(&vb)).collect())
            .collect();
        let h = (0..self.n)
            .map(|i| {
                (0..self.n).fold(self.hot[i].eval(&vc), |acc, j| {
                    acc + dh[i][j] * (yb[j] - c[j])
                })
            })
            .collect();
        (h, dh)
    }
    /// Enclosure of 2y·h_L(y) + |h_L(y)|² over the box, by the mean-value form.
    fn q(&self, bx: &[Iv]) -> Iv {
        let (h, _) = self.h_dh(bx);
        let mut acc = Iv::point(0.0);
        for i in 0..self.n {
            acc += Iv::point(2.0) * bx[i] * h[i] + h[i].sqr();
        }
        acc
    }
    /// |h_L|² at a point.
    fn h_at(&self, y: &[f64]) -> Iv {
        let c: Vec<Iv> = y.iter().map(|&v| Iv::point(v)).collect();
        let vals = self.monos.values(&powers(&c, self.degree));
        (0..self.n).fold(Iv::point(0.0), |acc, i| acc + self.hot[i].eval(&vals).sqr())
    }
    /// |y + h_L(y)|² at a point (an interval around the exact value).
    fn at(&self, y: &[f64]) -> Iv {
        let c: Vec<Iv> = y.iter().map(|&v| Iv::point(v)).collect();
        let vals = self.monos.values(&powers(&c, self.degree));
        let mut acc = Iv::point(0.0);
        for i in 0..self.n {
            let t = self.hot[i].eval(&vals) + c[i];
            acc += t.sqr();
        }
        acc
    }
    /// max ρ² over the ball |y| ≤ d (`maximum`) or min over the sphere |y| = d (of |h|²
    /// instead of ρ² with `of_h`), to a relative gap `tol` or `budget` boxes (the bound is
    /// certified either way). `d` must not exceed the radius the struct was built for.
    /// With `stop_at`, a maximum stops as soon as a point of the region is found where the
    /// value is at least that (the caller needs no sharper bound then; the bound returned is
    /// still certified).
    fn extremum(
        &self,
        d: f64,
        maximum: bool,
        of_h: bool,
        tol: f64,
        budget: usize,
        stop_at: Option<f64>,
    ) -> Bnb {
        use std::collections::BinaryHeap;
        let n = self.n;
        let d2 = Iv::point(d).sqr();
        let meets = |bx: &[Iv]| -> bool {
            let lo = bx
                .iter()
                .fold(Iv::point(0.0), |s, b| s + Iv::point(b.mig()).sqr());
            let hi = bx
                .iter()
                .fold(Iv::point(0.0), |s, b| s + Iv::point(b.mag()).sqr());
            lo.lo <= d2.hi && (maximum || hi.hi >= d2.lo)
        };
        let enclose = |bx: &[Iv]| -> Iv {
            if of_h {
                let (h, _) = self.h_dh(bx);
                let a = h.iter().fold(Iv::point(0.0), |s, x| s + x.sqr());
                return widen_sq(a, self.eps);
            }
            let r2 = if maximum {
                let s = bx.iter().fold(Iv::point(0.0), |s, b| s + b.sqr());
                Iv::new(0.0, s.hi.min(d2.hi))
            } else {
                d2
            };
            widen_sq(r2 + self.q(bx), self.eps)
        };
        // a point of the region near the box's centre, projected on the sphere (only the
        // stopping rule uses it: the bound returned is always a box's enclosure)
        let probe = |bx: &[Iv]| -> Option<Iv> {
            let c: Vec<f64> = bx.iter().map(|b| b.mid()).collect();
            let r = c.iter().map(|v| v * v).sum::<f64>().sqrt();
            if r == 0.0 {
                return None;
            }
            let y: Vec<f64> = c.iter().map(|v| v * d / r).collect();
            Some(widen_sq(
                if of_h { self.h_at(&y) } else { self.at(&y) },
                self.eps,
            ))
        };
        // best value at a point (with a relative 1e-12 allowance for the projection)
        let mut best = if maximum { 0.0 } else { f64::INFINITY };
        let mut heap = BinaryHeap::new();
        let root = vec![Iv::symmetric(d); n];
        let e = enclose(&root);
        heap.push(Keyed(if maximum { e.hi } else { -e.lo }, root));
        let mut boxes = 1;
        while let Some(Keyed(key, bx)) = heap.pop() {
            let bound = if maximum { key } else { -key };
            let gap = if maximum { bound - best } else { best - bound };
            let enough = maximum && stop_at.is_some_and(|s| best >= s);
            if gap <= tol * best.abs() || boxes >= budget || enough {
                return Bnb { bound, boxes };
            }
            // split the widest side
            let k = (0..n)
                .max_by(|&a, &b| bx[a].width().total_cmp(&bx[b].width()))
                .unwrap_or(0);
            let m = bx[k].mid();
            for half in [Iv::new(bx[k].lo, m), Iv::new(m, bx[k].hi)] {
                let mut child = bx.clone();
                child[k] = half;
                if !meets(&child) {
                    continue;
                }
                boxes += 1;
                if let Some(p) = probe(&child) {
                    best = if maximum {
                        best.max(p.lo * (1.0 - 1e-12))
                    } else {
                        best.min(p.hi * (1.0 + 1e-12))
                    };
                }
                let e = enclose(&child);
                heap.push(Keyed(if maximum { e.hi } else { -e.lo }, child));
            }
        }
        // every box discarded: the region is empty (cannot happen for d > 0)
        Bnb {
            bound: if maximum { 0.0 } else { f64::INFINITY },
            boxes,
        }
    }
}

/// What the certified bound of a tube needs that does not depend on its radii: the
/// enclosures of B⁻¹ and of the field's Taylor polynomial, the Taylor model of Ẇ without the
/// field's Lagrange remainder (which is the only part of G that depends on the outer
/// radius), the map T and the majorants τ and κ. Built once per normal form
/// ([`CertifiedSetup::new`]); [`CertifiedSetup::tube`] then costs the remainder's jet over the
/// outer box, the branch and bound of the two extrema and the quadrature.
pub struct CertifiedSetup<'a, H: HamiltonianFn + ?Sized> {
    h: &'a H,
    n: usize,
    /// The tube's centre: the box proved to contain the true equilibrium, or the `f64`
    /// equilibrium as a point.
    xe: Vec<Iv>,
    /// The half-width of the proved box around the true equilibrium (max over the
    /// coordinates, in x), or `None` when the centre is the `f64` equilibrium.
    pub centre_radius: Option<f64>,
    /// The box proved to contain the true equilibrium, in balls with double-double centres
    /// (`None` when the proof failed).
    pub centre: Option<Vec<Ball>>,
    c: Vec<Vec<Iv>>,
    bi: Vec<Vec<Iv>>,
    s: Vec<Vec<Iv>>,
    metric: Metric,
    options: CertifiedOptions,
    m_deg: usize,
    k: usize,
    d: usize,
    /// 2·(majorant of Ẇ's polynomial part and of its truncations), with no field remainder.
    g0: Majorant,
    /// Per j: maj(v_j) + e(v_j), v_j = Σ_i T_i ∂_j T_i; Ẇ's majorant gains
    /// 2·Σ_j (maj(v_j) + e(v_j))·e(ẏ_j) from the field's remainder e(ẏ_j).
    vmaj: Vec<Majorant>,
    /// h = T − id, per component.
    hots: Vec<Poly<Iv>>,
    taus: Vec<Majorant>,
    kappa: Majorant,
    /// The normal form's order N (the certified time falls roughly like d^{−(N−1)}).
    order: usize,
    /// Seconds spent building it.
    pub seconds: f64,
}

/// A certified radius for a time: the largest inner radius found whose tube of ratio k has
/// a certified time ≥ T ([`CertifiedSetup::radius_for_time`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CertifiedRadius {
    /// T.
    pub time: f64,
    /// k = d1/d0.
    pub outer_ratio: f64,
    /// The certified tube at the radius found (its time ≥ T), if any radius tried passed.
    pub tube: Option<CertifiedTube>,
    /// The smallest radius tried above it whose certified time is below T (or which has
    /// none), with that time: the bracket's upper end.
    pub failed: Option<(f64, Option<f64>)>,
    /// Every radius tried, in order, with its certified time.
    pub evaluations: Vec<(f64, Option<f64>)>,
    /// Seconds spent (the setup excluded).
    pub seconds: f64,
}

impl CertifiedRadius {
    /// The certified radius d0.
    pub fn d0(&self) -> Option<f64> {
        self.tube.as_ref().map(|t| t.d0)
    }
}

impl<'a, H: HamiltonianFn + ?Sized> CertifiedSetup<'a, H> {
    /// The radius-independent part of the bound for the normal form `nf` of `h` (computed
    /// with a remainder degree M and its `to_normal_map`), distances in `metric`.
    pub fn new(
        h: &'a H,
        nf: &NormalForm,
        metric: Metric,
        options: &CertifiedOptions,
    ) -> Result<Self, NormalFormError> {
        let t0 = std::time::Instant::now();
        let map = nf.to_normal_map.as_ref().ok_or_else(|| {
            NormalFormError::Invalid(
                "the certified bound needs the map to the normal coordinates".into(),
            )
        })?;
        let n = 2 * nf.n_dof;
        let nd = nf.n_dof;
        let b = &nf.linear_inverse;
        // the centre: the true equilibrium in a proved box, else the f64 equilibrium
        let proved = prove_equilibrium(h, nf);
        let xe: Vec<Iv> = match &proved {
            Some(x) => x.iter().map(|b| b.to_iv()).collect(),
            None => nf.equilibrium_f64().into_iter().map(Iv::point).collect(),
        };
        let centre_radius = proved
            .as_ref()
            .map(|x| x.iter().map(|b| b.rad).fold(0.0, f64::max));
        // B = A⁻¹ in the normal form's working precision, hi + lo taken as exact (the
        // double-double B keeps the linear normalisation symplectic to 10⁻³², which Ẇ's
        // degree 2 needs); A likewise (only an approximate inverse)
        let dd_mat = |hi: &[Vec<f64>], lo: &[Vec<f64>]| -> BallMatrix {
            hi.iter()
                .enumerate()
                .map(|(i, r)| {
                    r.iter()
                        .enumerate()
                        .map(|(j, &x)| {
                            let l = lo.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0);
                            Ball::new(x, l, 0.0)
                        })
                        .collect()
                })
                .collect()
        };
        let bb = dd_mat(b, &nf.linear_inverse_lo);
        let ab = dd_mat(&nf.linear_map, &nf.linear_map_lo);
        let bi: Vec<Vec<Iv>> = bb
            .iter()
            .map(|r| r.iter().map(|x| x.to_iv()).collect())
            .collect();
        // C ∋ B⁻¹ and S ∋ BJBᵀ in balls (rounded out to f64 intervals), else in intervals
        let balls = linear_balls(&bb, &ab, nd);
        let c = match &balls {
            Some((cb, _)) => cb
                .iter()
                .map(|r| r.iter().map(|x| x.to_iv()).collect())
                .collect(),
            None => inverse_enclosure(&bi, &nf.linear_map).ok_or_else(|| {
                NormalFormError::Invalid(
                    "the linear normalisation is too ill-conditioned to enclose its inverse".into(),
                )
            })?,
        };
        let full_degree = map
            .components
            .iter()
            .map(|p| p.max_degree())
            .max()
            .unwrap_or(1);
        // from three degrees of freedom on, the map is cut at the normalisation order (W is
        // any function: a shorter T keeps the cancellations of Ẇ through degree N + 1)
        let reduced = nf.n_dof > 2;
        let m_deg = options
            .map_degree
            .unwrap_or(if reduced {
                full_degree.min(nf.order)
            } else {
                full_degree
            })
            .clamp(1, full_degree);
        let k = options
            .field_degree
            .unwrap_or(if reduced { nf.order + 1 } else { m_deg + 1 })
            .max(2);
        let d = options.model_degree.unwrap_or(k.max(m_deg) + 1).max(k);
        let table = Arc::new(MonomialTable::new(n, d));

        // 1. the field ẏ = S ∇H̃, S = B J Bᵀ
        let s_iv: Vec<Vec<Iv>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| {
                        // (B J Bᵀ)_ij = Σ_k B_ik (J Bᵀ)_kj, (J Bᵀ)_kj = B_j,k+n (k < n/2), −B_j,k−n
                        (0..n).fold(Iv::point(0.0), |acc, kk| {
                            let jb = if kk < nd {
                                bi[j][kk + nd]
                            } else {
                                -bi[j][kk - nd]
                            };
                            acc + bi[i][kk] * jb
                        })
                    })
                    .collect()
            })
            .collect();
        let s: Vec<Vec<Iv>> = match &balls {
            Some((_, sb)) => (0..n)
                .map(|i| {
                    (0..n)
                        .map(|j| intersect(s_iv[i][j], sb[i][j].to_iv()).unwrap_or(s_iv[i][j]))
                        .collect()
                })
                .collect(),
            None => s_iv,
        };
        let t_k1 = Arc::new(MonomialTable::new(n, k + 1));
        let zero = vec![Iv::point(0.0); n];
        let mut hp = jet_at(h, &xe, &c, &zero, &t_k1);
        if proved.is_some() {
            // at the true equilibrium the degree-1 coefficients, C^T ∇H(x*), are exactly 0;
            // the others are enclosed over the box, which contains x*
            for i in 0..n {
                let mut e = vec![0u8; n];
                e[i] = 1;
                hp.set_coeff(&e, Iv::point(0.0));
            }
        }
        if !hp.is_finite() {
            return Err(NormalFormError::Invalid(
                "the Hamiltonian's interval Taylor expansion at the equilibrium is not finite"
                    .into(),
            ));
        }
        // the gradient of H̃ to degree K (its Lagrange remainder is added per radius)
        let grad: Vec<Poly<Iv>> = (0..n)
            .map(|v| {
                let mut p = hp.derivative(v).retabled(table.clone());
                p.truncate(k);
                p
            })
            .collect();
        let field: Vec<Tm> = (0..n)
            .map(|i| {
                (0..n).fold(Tm::exact(Poly::zero(table.clone())), |acc, j| {
                    acc.add(&Tm::exact(grad[j].clone()).scaled(s[i][j]))
                })
            })
            .collect();

        // 2. W = |T|², Ẇ = 2 Σ_j v_j ẏ_j, v_j = Σ_i T_i ∂_j T_i
        // T's coefficients are hi + lo (double-double in a double-double run), each enclosed
        let map_lo = nf.to_normal_map_lo.as_ref();
        let tball: Vec<Poly<Ball>> = map
            .components
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let lo = map_lo.and_then(|m| m.components.get(i));
                let mut t = dd_poly(p, lo, |hi, lo| Ball::new(hi, lo, 0.0));
                t.truncate(m_deg);
                t
            })
            .collect();
        let tmap: Vec<Poly<Iv>> = tball
            .iter()
            .map(|t| t.map(|b| b.to_iv()).retabled(table.clone()))
            .collect();
        // v_j = Σ_i T_i ∂_j T_i = ½ ∂_j W: its degrees ≤ D are those of ½ ∂_j (Σ_i T_i²) cut
        // at D + 1 (n products instead of n²), and the degrees above D, dropped, are bounded
        // as a product of Taylor models bounds them, by Σ_i (maj T_i · maj ∂_j T_i) above D
        let table1 = Arc::new(MonomialTable::new(n, d + 1));
        let w_poly = tmap.iter().fold(Poly::zero(table1.clone()), |acc, ti| {
            let t1 = ti.retabled(table1.clone());
            acc.add(&t1.mul(&t1))
        });
        let tmaj: Vec<Majorant> = tmap.iter().map(Majorant::of_poly).collect();
        let mut wdot = Tm::exact(Poly::zero(table.clone()));
        let mut vmaj = Vec::with_capacity(n);
        for j in 0..n {
            let e = tmap
                .iter()
                .zip(&tmaj)
                .fold(Majorant::default(), |acc, (ti, mi)| {
                    acc.add(&mi.mul(&Majorant::of_poly(&ti.derivative(j))).above(d))
                });
            let v = Tm {
                p: w_poly
                    .derivative(j)
                    .scaled(Iv::point(0.5))
                    .retabled(table.clone()),
                e,
            };
            vmaj.push(v.majorant());
            wdot = wdot.add(&v.mul(&field[j]));
        }
        // Ẇ's degrees ≤ N + 1 (those where the normal form's cancellations leave rounding,
        // and the first of the remainder): each coefficient the intersection with its
        // enclosure in balls (both contain it), 10⁻³⁰ wide where the f64 intervals are 10⁻¹⁶
        if let (Some(centre), Some((cb, sb))) = (&proved, &balls) {
            // the degrees that cancel: ≤ N, and N + 1 where the map is cut at N
            let low = if reduced { nf.order + 1 } else { nf.order }.min(d);
            let wb = wdot_low_balls(h, centre, cb, sb, &tball, low);
            let all = (0..=low).flat_map(|deg| (0..wb.table().count(deg)).map(move |i| (deg, i)));
            for (deg, i) in all {
                let cball = wb.part(deg).map_or(Ball::point(0.0), |p| p[i]);
                let e = wb.exponents(deg, i).to_vec();
                let old = wdot.p.coeff(&e);
                let tight = intersect(old, cball.to_iv()).ok_or_else(|| {
                    NormalFormError::Invalid(
                        "two enclosures of a coefficient of Ẇ are disjoint".into(),
                    )
                })?;
                wdot.p.set_coeff(&e, tight);
            }
        }
        let g0 = wdot.majorant().scaled(2.0);

        // 3. τ: |T(y) − y| ≤ τ(|y|), and κ: |y·h(y)| ≤ κ(|y|) (h = T − id)
        let hots: Vec<Poly<Iv>> = tmap
            .iter()
            .enumerate()
            .map(|(i, ti)| {
                let mut e = vec![0u8; n];
                e[i] = 1;
                let mut hot = ti.clone();
                let c1 = hot.coeff(&e);
                hot.set_coeff(&e, c1 - Iv::point(1.0));
                hot
            })
            .collect();
        let taus: Vec<Majorant> = hots.iter().map(Majorant::of_poly).collect();
        let kappa = Majorant::of_poly(
            &hots
                .iter()
                .enumerate()
                .fold(Poly::zero(table.clone()), |acc, (i, h)| {
                    acc.add(&Poly::variable(table.clone(), i, Iv::point(0.0)).mul(h))
                }),
        );
        Ok(CertifiedSetup {
            h,
            n,
            xe,
            centre_radius,
            centre: proved,
            c,
            bi,
            s,
            metric,
            options: *options,
            m_deg,
            k,
            d,
            g0,
            vmaj,
            hots,
            taus,
            kappa,
            order: nf.order,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// The largest inner radius d0 whose tube `d0 → k·d0` has a certified time ≥ `time`,
    /// searched from `start` (a tube already evaluated, usually at the estimate's radius):
    /// the certified time decreases with the radius (roughly like d^{−(N−1)}: the remainder
    /// starts at degree N + 1), so the search brackets the radius by steps predicted from
    /// that power law (its exponent re-fitted from the last two radii), then narrows the
    /// bracket [passes, fails] by the secant method in (log d, log T), safeguarded towards
    /// bisection, until the upper end is within `rel_tol` of the lower one or `max_evals`
    /// tubes have been evaluated. The radius reported is the largest one that passed, with
    /// its tube; the bracket's upper end is the smallest radius tried above it that failed.
    pub fn radius_for_time(
        &self,
        time: f64,
        k: f64,
        start: CertifiedTube,
        rel_tol: f64,
        max_evals: usize,
    ) -> Result<CertifiedRadius, NormalFormError> {
        let t0 = std::time::Instant::now();
        let p0 = (self.order.max(3) - 1) as f64;
        let mut evaluations = vec![(start.d0, start.time)];
        let mut lo: Option<CertifiedTube> = None;
        let mut hi: Option<(f64, Option<f64>)> = None;
        let mut last = start;
        let mut prev: Option<(f64, f64)> = None;
        let passes = |t: &CertifiedTube| t.time.is_some_and(|x| x >= time);
        loop {
            // the exponent of T ∝ d^{−p}: fitted from the last two radii with a time
            let p = match (prev, last.time) {
                (Some((d, t)), Some(tl)) if d != last.d0 && t > 0.0 && tl > 0.0 => {
                    let fit = -(tl / t).ln() / (last.d0 / d).ln();
                    if fit.is_finite() {
                        fit.clamp(0.5, 4.0 * p0)
                    } else {
                        p0
                    }
                }
                _ => p0,
            };
            if let Some(t) = last.time.filter(|&t| t > 0.0) {
                prev = Some((last.d0, t));
            }
            if passes(&last) {
                if lo.as_ref().is_none_or(|l| last.d0 > l.d0) {
                    lo = Some(last.clone());
                }
            } else if hi.is_none_or(|h| last.d0 < h.0) {
                hi = Some((last.d0, last.time));
            }
            if evaluations.len() >= max_evals {
                break;
            }
            let predicted = |d: f64, t: Option<f64>| -> Option<f64> {
                t.filter(|&t| t > 0.0).map(|t| d * (t / time).powf(1.0 / p))
            };
            let next = match (&lo, hi) {
                (Some(l), Some((h, th))) => {
                    if h / l.d0 <= 1.0 + rel_tol {
                        break;
                    }
                    // secant in (log d, log T) between the bracket's ends, kept inside
                    // its middle 80 % (in log d)
                    let (a, b) = (l.d0.ln(), h.ln());
                    let x = match (l.time, th) {
                        (Some(ta), Some(tb)) if ta > 0.0 && tb > 0.0 && ta != tb => {
                            let (fa, fb) = ((ta / time).ln(), (tb / time).ln());
                            a + (b - a) * fa / (fa - fb)
                        }
                        _ => 0.5 * (a + b),
                    };
                    let x = x.clamp(a + 0.1 * (b - a), a + 0.9 * (b - a));
                    x.exp()
                }
                (Some(l), None) => {
                    // passes: predicted radius, at least 2 % and at most ×4 further out
                    let d = predicted(l.d0, l.time).unwrap_or(4.0 * l.d0);
                    (d * 1.01).clamp(1.02 * l.d0, 4.0 * l.d0)
                }
                (None, Some((h, th))) => {
                    if h < 1e-9 {
                        break;
                    }
                    let d = predicted(h, th).unwrap_or(0.5 * h);
                    (d * 0.99).clamp(0.25 * h, h / 1.02)
                }
                (None, None) => break,
            };
            last = self.tube(next, k * next)?;
            evaluations.push((last.d0, last.time));
        }
        Ok(CertifiedRadius {
            time,
            outer_ratio: k,
            tube: lo,
            failed: hi,
            evaluations,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// The certified time of the tube `d0 → d1` (radii in the setup's metric).
    pub fn tube(&self, d0: f64, d1: f64) -> Result<CertifiedTube, NormalFormError> {
        let t0 = std::time::Instant::now();
        let (n, k) = (self.n, self.k);
        // radii in |y|
        let (y0, y1) = match self.metric {
            Metric::LinearNormal => (d0, d1),
            Metric::Euclidean => (
                mul_up(frobenius_up(&self.bi), d0),
                (Iv::point(d1) / Iv::point(frobenius_up(&self.c))).lo,
            ),
        };
        // the Lagrange remainder of ∇H̃ beyond degree K on the box [−y1, y1]ⁿ
        let t_k2 = Arc::new(MonomialTable::new(n, k + 2));
        let boxed = vec![Iv::symmetric(y1); n];
        let hb = jet_at(self.h, &self.xe, &self.c, &boxed, &t_k2);
        if !hb.is_finite() {
            return Err(NormalFormError::Invalid(format!(
                "the Hamiltonian's interval Taylor expansion is not finite on the ball |y| ≤ {y1:e} (a singularity within the tube?)"
            )));
        }
        let top = hb.part(k + 2).map(|p| p.to_vec()).unwrap_or_default();
        let grad_e: Vec<f64> = (0..n)
            .map(|v| {
                let mut e = 0.0;
                for (i, c) in top.iter().enumerate() {
                    let ex = t_k2.exponents(k + 2, i);
                    if ex[v] > 0 {
                        e = add_up(e, mul_up(ex[v] as f64, c.mag()));
                    }
                }
                e
            })
            .collect();
        // e(ẏ_j) = Σ_i |S_ji| e_i r^{K+1}; G = G₀ + 2 Σ_j (maj(v_j) + e(v_j))·e(ẏ_j)
        let mut g = self.g0.clone();
        for j in 0..n {
            let e = (0..n).fold(0.0, |acc, i| {
                add_up(acc, mul_up(self.s[j][i].mag(), grad_e[i]))
            });
            let mut ec = vec![0.0; k + 2];
            ec[k + 1] = e;
            g = g.add(&self.vmaj[j].mul(&Majorant { c: ec }).scaled(2.0));
        }

        // ρ² = r² + 2y·h + |h|² on |y| = r: r² − 2κ(r) ≤ ρ² ≤ r² + 2κ(r) + τ(r)²
        let kappa = &self.kappa;
        let taus = &self.taus;
        let kappa2 = |r: f64| mul_up(2.0, kappa.eval(r));
        let tau = |r: f64| -> f64 {
            let s = taus
                .iter()
                .fold(0.0, |s, m| add_up(s, mul_up(m.eval(r), m.eval(r))));
            s.sqrt().next_up()
        };
        let tau_slope = {
            let s = taus.iter().fold(0.0, |s, m| {
                let dm = m.derivative_at(y1);
                add_up(s, mul_up(dm, dm))
            });
            s.sqrt().next_up()
        };
        let tau1 = tau(y1);
        // ρ₀, ρ₁: the better of the majorant and the branch and bound
        let tol = self.options.tolerance;
        let budget = self.options.budget;
        let ext0 = Extremum::new(&self.hots, y0, 1e-3 * tol * y0);
        let max0 = ext0.extremum(y0, true, false, tol, budget, None);
        // the lower bound of ρ² on the sphere |y| = r from κ
        let phi_lo = |r: f64| (Iv::point(r).sqr() - Iv::point(kappa2(r))).lo;
        let rho0_kappa = {
            let t = tau(y0);
            let up = add_up(add_up(mul_up(y0, y0), kappa2(y0)), mul_up(t, t));
            up.sqrt().next_up()
        };
        let rho0 = add_up(y0, tau(y0))
            .min(rho0_kappa)
            .min(max0.bound.sqrt().next_up());
        let rho1_kappa = {
            let p = phi_lo(y1);
            if p > 0.0 {
                p.sqrt().next_down()
            } else {
                0.0
            }
        };
        // on the outer sphere ρ ≥ |y| − |h(y)| ≥ y1 − max_{|y| ≤ y1} |h|; where κ's bound
        // leaves ρ₁ ≤ ρ₀, the search stops once |h|² ≥ (y1 − ρ₀)² is seen somewhere
        // (then no bound from it can give ρ₁ > ρ₀: there is no certified time to sharpen)
        let ext1 = Extremum::new(&self.hots, y1, 1e-3 * tol * y1);
        let hopeless = (rho1_kappa <= rho0).then(|| {
            let gap = (y1 - rho0).max(0.0);
            gap * gap
        });
        let hmax1 = ext1.extremum(y1, true, true, tol, budget, hopeless);
        let tau1 = tau1.min(hmax1.bound.sqrt().next_up());
        let rho1 = (Iv::point(y1) - Iv::point(tau1)).lo.max(rho1_kappa);
        let boxes = max0.boxes + hmax1.boxes;
        let seconds = || t0.elapsed().as_secs_f64();
        let mut out = CertifiedTube {
            d0,
            d1,
            y0,
            y1,
            rho0,
            rho1,
            time: None,
            map_degree: self.m_deg,
            field_degree: k,
            model_degree: self.d,
            wdot: g.clone(),
            tau1,
            boxes,
            extremum_degrees: (ext0.degree, ext1.degree),
            centre_radius: self.centre_radius,
            seconds: 0.0,
        };
        // ψ(r) = r − τ(r) must increase on [0, y1]: τ′ ≤ |(τ_i′)| ≤ its value at y1
        // where the majorant τ does not keep ψ increasing, |y| ≤ y1 is all that is used
        let monotone = tau_slope < 1.0;
        // r² − 2κ(r) increases on [0, y1] when 2κ′(r) < 2r there: Σ s κ_s r^{s−2} < 1 at y1
        // (κ starts at degree 3: h does at degree 2)
        let kappa_monotone = kappa.c.iter().take(3).all(|&c| c == 0.0)
            && kappa
                .c
                .iter()
                .enumerate()
                .skip(3)
                .fold(0.0, |acc, (s, &c)| {
                    add_up(acc, mul_up(mul_up(c, s as f64), pow_up(y1, s - 2)))
                })
                < 1.0;
        if rho1 <= rho0 || rho1.is_nan() || rho0.is_nan() {
            out.seconds = seconds();
            return Ok(out);
        }
        // 4. u(ρ) = min(y1, ψ⁻¹(ρ)) rounded up: the smallest r found with ψ(r) ≥ ρ, where
        // ψ(r) ≤ ρ(y) on |y| = r is the larger of the increasing lower bounds r − τ(r) and
        // (r² − 2κ(r))^{1/2}
        let psi_lo = |r: f64| {
            let a = if monotone {
                (Iv::point(r) - Iv::point(tau(r))).lo
            } else {
                f64::NEG_INFINITY
            };
            let b = if kappa_monotone {
                let p = phi_lo(r);
                if p > 0.0 {
                    p.sqrt().next_down()
                } else {
                    0.0
                }
            } else {
                f64::NEG_INFINITY
            };
            a.max(b)
        };
        let u = |rho: f64| -> f64 {
            if !(monotone || kappa_monotone) || psi_lo(y1) < rho {
                return y1;
            }
            let (mut lo, mut hi) = (0.0, y1);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if psi_lo(mid) >= rho {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            hi
        };
        let m = self.options.intervals.max(1);
        let q = (rho1 / rho0).powf(1.0 / m as f64);
        let mut total = Iv::point(0.0);
        let mut a = rho0;
        for i in 1..=m {
            let bnd = if i == m { rho1 } else { (a * q).min(rho1) };
            let gmax = g.eval(u(bnd));
            let num = (Iv::point(bnd) - Iv::point(a)) * Iv::point(2.0 * a);
            let term = num / Iv::point(gmax);
            if gmax > 0.0 && term.lo.is_finite() {
                total += Iv::point(term.lo.max(0.0));
            } else if gmax == 0.0 {
                total = Iv::point(f64::INFINITY);
                break;
            }
            a = bnd;
        }
        out.time = Some(total.lo.max(0.0));
        out.seconds = seconds();
        Ok(out)
    }
}

/// The certified time of the tube `d0 → d1` in `metric` for the normal form `nf` of `h`
/// (computed with a remainder degree M and its `to_normal_map`): [`CertifiedSetup::new`]
/// then [`CertifiedSetup::tube`], the setup's seconds included.
pub fn certified_tube<H: HamiltonianFn + ?Sized>(
    h: &H,
    nf: &NormalForm,
    d0: f64,
    d1: f64,
    metric: Metric,
    options: &CertifiedOptions,
) -> Result<CertifiedTube, NormalFormError> {
    let setup = CertifiedSetup::new(h, nf, metric, options)?;
    let mut t = setup.tube(d0, d1)?;
    t.seconds += setup.seconds;
    Ok(t)
}
