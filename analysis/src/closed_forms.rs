//! Closed-form solutions of the SO(3) optimal-control extremals (Rodgerson 2009, chs. 4–7):
//! the thesis' formulas **as corrected**, and the thesis' **printed** ones (Appendix B), so
//! that every discrepancy is measurable against integration (`tests/so3_closed_forms.rs`;
//! the derivations and the measured numbers are in `docs/so3.md`).
//!
//! All four types are Lie–Poisson on so(3)* ≅ ℝ³ with Ṗ = P × ∇H and the Casimir K = |P|²:
//!
//! | type | H | chapter |
//! |---|---|---|
//! | I | P₁²/(2c₁) + P₃ | 4, Theorems 4.3.1 (Jacobi) and 4.3.2 (Weierstrass ℘) |
//! | IIa | P₁²/(2c₁) + P₂²/(2c₂) | 5, Theorem 5.3.1 |
//! | IIb | P₁²/(2c₁) + P₂²/(2c₂) + P₃ | 6, Theorem 6.3.1 |
//! | III | P₁²/(2c₁) + P₂²/(2c₂) + P₃²/(2c₃) | 7, Theorem 7.3.1 |
//!
//! # Corrected closed forms ([`Extremal`])
//!
//! Every constant — modulus, amplitudes, time scale and phase — is computed from P(0), H and
//! K (never from the thesis' rounded numbers), and the Jacobi functions are called with the
//! *parameter* m = k² ([`lasalle_runtime::elliptic`]'s and MATLAB's convention).
//!
//! * **Types IIa and III** (no linear term: Euler's free rigid body with inverse moments
//!   Iᵢ = 1/cᵢ, I₃ = 0 for IIa). In axes (i, j, l) — a permutation π of (1, 2, 3) — the
//!   solution is
//!   (Pᵢ, Pⱼ, Pₗ) = (A₁ cn w, A₂ sn w, A₃ dn w), w = w₀ + ω·sgn(π)·t, with
//!   A₁² = (2H − IₗK)/(Iᵢ − Iₗ), A₂² = (2H − IₗK)/(Iⱼ − Iₗ), A₃² = (IᵢK − 2H)/(Iᵢ − Iₗ),
//!   ω = (Iᵢ − Iₗ)A₁A₃/A₂ and m = (Iᵢ − Iⱼ)(2H − IₗK)/((Iⱼ − Iₗ)(IᵢK − 2H)); the axes are
//!   the ones for which these are positive and m < 1 (the dn-axis is the one about which P
//!   circulates), and w₀ = F(atan2(Pⱼ(0)/A₂, Pᵢ(0)/A₁) | m). This is Theorems 5.3.1/7.3.1's
//!   "P₃ = … dn / cn / sn" with the phase w₀ the theorems lack, the sign-carrying cn, sn in
//!   place of their "P₁, P₂ = ±√…", and m = k².
//! * **Types I and IIb** (a linear term P₃). With x = P₃, P₁² = G₁(x), P₂² = G₂(x) for
//!   polynomials of degree ≤ 2 (from H and K) and P₁P₂ = κẋ (κ = −c₁ for I,
//!   c₁c₂/(c₁ − c₂) for IIb), so ẋ² = Q(x) = G₁G₂/κ² — the cubic (4.13) or the quartic of
//!   Theorem 6.3.1's proof. P₃ oscillates between adjacent roots r < r′ of Q. With
//!   b₁ = Q′(r), b₂ = Q″(r)/2, Weierstrass' substitution
//!   x = r + b₁ / (4(℘(t − τ) − b₂/12))
//!   turns ẋ² = Q into ℘′² = 4℘³ − g₂℘ − g₃ (τ: a time with P₃ = r); the roots of that cubic
//!   are eⱼ = b₂/12 + b₁/(4(rⱼ − r)) for the other roots rⱼ of Q (rⱼ = ∞ for the cubic of
//!   Type I). ℘ is evaluated through Jacobi functions (A&S 18.9.8 for three real eⱼ, 18.9.11
//!   for one), and P₁, P₂ through the sign-carrying square roots √(℘ − eⱼ) (cs, ds, ns, or
//!   cn/(sn dn)) instead of "±√G". For Type I this is Theorem 4.3.2 with the argument of ℘
//!   fixed (it must be t − τ on the pole branch in these variables; in the thesis' variables
//!   ℘ must be taken on the bounded branch, shifted by the imaginary half-period).
//!
//! # Printed closed forms ([`Printed`])
//!
//! SECTION 2 of each Appendix B case, transcribed: P₃ is a multiple of a Jacobi function or
//! the Möbius form (α − βa·f)/(1 − a·f) of Theorems 4.3.1/6.3.1, with the four-decimal
//! constants, the time scale and the *second argument of `ellipj`* as printed, and
//! P₁ = √(…), P₂ = √(…) polynomials in P₃ (a negative radicand gives 0: MATLAB plots the real
//! part of the imaginary root it warns about). [`Printed::eval`] takes the parameter m to use:
//! `printed.k` reproduces the thesis' MATLAB (which passes k where `ellipj` expects m),
//! `printed.k * printed.k` fixes only that.

use lasalle_runtime::elliptic::{ellipf, ellipj, ellipk, Jacobi};

/// The four types of chapters 4–7. The variants are the thesis' names (Roman numerals).
#[allow(clippy::upper_case_acronyms)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Type {
    /// Chapter 4: ġ = g(E₃ + uE₁).
    I,
    /// Chapter 5: ġ = g(u₁E₁ + u₂E₂).
    IIa,
    /// Chapter 6: ġ = g(E₃ + u₁E₁ + u₂E₂).
    IIb,
    /// Chapter 7: ġ = g(u₁E₁ + u₂E₂ + u₃E₃).
    III,
}

impl Type {
    /// The optimal Hamiltonian (4.4), (5.4), (6.4), (7.4).
    pub fn hamiltonian(self, c: [f64; 3], p: [f64; 3]) -> f64 {
        let [c1, c2, c3] = c;
        let [p1, p2, p3] = p;
        match self {
            Type::I => p1 * p1 / (2.0 * c1) + p3,
            Type::IIa => 0.5 * (p1 * p1 / c1 + p2 * p2 / c2),
            Type::IIb => 0.5 * (p1 * p1 / c1 + p2 * p2 / c2) + p3,
            Type::III => 0.5 * (p1 * p1 / c1 + p2 * p2 / c2 + p3 * p3 / c3),
        }
    }
}

/// The Casimir K = |P|² (Prop. 3.3.1).
pub fn casimir(p: [f64; 3]) -> f64 {
    p.iter().map(|v| v * v).sum()
}

/// A Jacobi function of the printed formulas, as numerator/denominator from (sn, cn, dn) so
/// that poles (ns at 0) stay finite inside the Möbius form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Jf {
    /// sn
    Sn,
    /// cn
    Cn,
    /// dn
    Dn,
    /// nd = 1/dn
    Nd,
    /// sd = sn/dn
    Sd,
    /// cd = cn/dn
    Cd,
    /// dc = dn/cn
    Dc,
    /// ns = 1/sn
    Ns,
    /// nc = 1/cn
    Nc,
    /// ds = dn/sn
    Ds,
}

impl Jf {
    fn frac(self, j: &Jacobi) -> (f64, f64) {
        match self {
            Jf::Sn => (j.sn, 1.0),
            Jf::Cn => (j.cn, 1.0),
            Jf::Dn => (j.dn, 1.0),
            Jf::Nd => (1.0, j.dn),
            Jf::Sd => (j.sn, j.dn),
            Jf::Cd => (j.cn, j.dn),
            Jf::Dc => (j.dn, j.cn),
            Jf::Ns => (1.0, j.sn),
            Jf::Nc => (1.0, j.cn),
            Jf::Ds => (j.dn, j.sn),
        }
    }

    /// The period of P₃ in the scaled argument, in units of K(m): 2K for dn, nd (even, of
    /// period 2K); 4K for every other function here (sn, cn, … change sign under w → w + 2K,
    /// and the Möbius forms are not even in f).
    pub fn period_in_k(self) -> f64 {
        match self {
            Jf::Dn | Jf::Nd => 2.0,
            _ => 4.0,
        }
    }
}

/// The printed P₃ of one elliptic function of an Appendix B case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum P3Form {
    /// P₃ = A·f(ωt).
    Scaled(f64, Jf),
    /// P₃ = (n₀ − n₁ f(ωt)) / (1 − d₁ f(ωt)) — Theorems 4.3.1/6.3.1 with n₀ = α,
    /// n₁ = βa (or β√(a² + b²)), d₁ = a (or √(a² + b²)).
    Mobius {
        /// α
        n0: f64,
        /// βa
        n1: f64,
        /// a
        d1: f64,
        /// the Jacobi function
        f: Jf,
    },
}

/// One printed closed form (SECTION 2 of an Appendix B case, one of its two functions):
/// `[s,c,d] = ellipj(omega*t, k); P3 = …; P2 = sqrt(p2[0] + p2[1] P3 + p2[2] P3²);
/// P1 = sqrt(p1[0] + …)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Printed {
    /// The name of the function in the thesis ("dc", "nd", …).
    pub name: &'static str,
    /// The time scale printed as the first argument of `ellipj`.
    pub omega: f64,
    /// The second argument of `ellipj` as printed: the modulus k of Theorems 4.3.1–7.3.1.
    pub k: f64,
    /// P₃.
    pub p3: P3Form,
    /// P₁² as a polynomial in P₃ (constant, linear, quadratic coefficients).
    pub p1: [f64; 3],
    /// P₂² as a polynomial in P₃.
    pub p2: [f64; 3],
}

impl Printed {
    /// The printed P(t) with `ellipj(omega t, m)`: m = `self.k` is the thesis' MATLAB,
    /// m = k² the convention fixed. P₁, P₂ ≥ 0 (the thesis' "±" left to the reader).
    pub fn eval(&self, t: f64, m: f64) -> [f64; 3] {
        let j = ellipj(self.omega * t, m);
        let p3 = match self.p3 {
            P3Form::Scaled(a, f) => {
                let (n, d) = f.frac(&j);
                a * n / d
            }
            P3Form::Mobius { n0, n1, d1, f } => {
                let (n, d) = f.frac(&j);
                (n0 * d - n1 * n) / (d - d1 * n)
            }
        };
        let root = |q: [f64; 3]| (q[0] + q[1] * p3 + q[2] * p3 * p3).max(0.0).sqrt();
        [root(self.p1), root(self.p2), p3]
    }

    /// The period of the printed P₃ with parameter m.
    pub fn period(&self, m: f64) -> f64 {
        let f = match self.p3 {
            P3Form::Scaled(_, f) | P3Form::Mobius { f, .. } => f,
        };
        f.period_in_k() * ellipk(m) / self.omega
    }
}

/// A worked case of Appendix B / Figure C.n.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Case {
    /// "C.1" … "C.19".
    pub figure: &'static str,
    /// The type (chapter).
    pub ty: Type,
    /// (c₁, c₂, c₃), unused ones 0.
    pub c: [f64; 3],
    /// P(0): the value of the thesis' ode45 call, exact where it is a rounded closed number
    /// (C.6–C.8, C.18; see the models' points).
    pub p0: [f64; 3],
    /// The end of the ode45 time span.
    pub t_end: f64,
    /// The two printed closed forms ("first" and "second elliptic function").
    pub printed: [Printed; 2],
}

const fn scaled(
    name: &'static str,
    omega: f64,
    k: f64,
    a: f64,
    f: Jf,
    p1: [f64; 3],
    p2: [f64; 3],
) -> Printed {
    Printed {
        name,
        omega,
        k,
        p3: P3Form::Scaled(a, f),
        p1,
        p2,
    }
}

#[allow(clippy::too_many_arguments)]
const fn mobius(
    name: &'static str,
    omega: f64,
    k: f64,
    n0: f64,
    n1: f64,
    d1: f64,
    f: Jf,
    p1: [f64; 3],
    p2: [f64; 3],
) -> Printed {
    Printed {
        name,
        omega,
        k,
        p3: P3Form::Mobius { n0, n1, d1, f },
        p1,
        p2,
    }
}

/// √2, √3, √6, √10, √34 for the exact P(0) of C.6–C.8 and C.18.
const SQRT_3: f64 = 1.732_050_807_568_877_2;
const SQRT_6: f64 = 2.449_489_742_783_178;
const SQRT_10: f64 = 3.162_277_660_168_379_5;
const SQRT_34: f64 = 5.830_951_894_845_301;

/// The 19 cases of Appendix B with their printed closed forms (transcribed from the OCR of
/// the MATLAB listings; four decimals as printed).
// The printed four-decimal numbers (0.7071, 1.4142) are the thesis', not approximations of ours.
#[allow(clippy::approx_constant)]
pub const CASES: [Case; 19] = {
    use Jf::*;
    use Type::*;
    const Z: f64 = 0.0;
    [
        Case {
            figure: "C.1",
            ty: I,
            c: [2.0, Z, Z],
            p0: [4.0, 0.0, 1.0],
            t_end: 10.0,
            printed: [
                mobius(
                    "dc",
                    1.7071,
                    0.1716,
                    7.8284,
                    12.6569,
                    5.8284,
                    Dc,
                    [20.0, -4.0, 0.0],
                    [-3.0, 4.0, -1.0],
                ),
                mobius(
                    "ns",
                    1.7071,
                    0.1716,
                    7.8284,
                    12.6569,
                    5.8284,
                    Ns,
                    [20.0, -4.0, 0.0],
                    [-3.0, 4.0, -1.0],
                ),
            ],
        },
        Case {
            figure: "C.2",
            ty: IIa,
            c: [4.0, 1.0, Z],
            p0: [2.0, 2.0, 4.0],
            t_end: 10.0,
            printed: [
                scaled(
                    "nd",
                    2.1794,
                    0.8885,
                    2.0,
                    Nd,
                    [25.3333, 0.0, -1.3333],
                    [-1.3333, 0.0, 0.3333],
                ),
                scaled(
                    "dn",
                    2.1794,
                    0.8885,
                    4.3589,
                    Dn,
                    [25.3333, 0.0, -1.3333],
                    [-1.3333, 0.0, 0.3333],
                ),
            ],
        },
        Case {
            figure: "C.3",
            ty: IIa,
            c: [4.0, 1.0, Z],
            p0: [4.0, 2.0, 2.0],
            t_end: 10.0,
            printed: [
                scaled(
                    "sd",
                    2.4495,
                    0.8165,
                    2.3094,
                    Sd,
                    [21.3333, 0.0, -1.3333],
                    [2.6667, 0.0, 0.3333],
                ),
                scaled(
                    "cn",
                    2.4495,
                    0.8165,
                    4.0,
                    Cn,
                    [21.3333, 0.0, -1.3333],
                    [2.6667, 0.0, 0.3333],
                ),
            ],
        },
        Case {
            figure: "C.4",
            ty: IIa,
            c: [1.0, 4.0, Z],
            p0: [1.0, 2.0, 3.0],
            t_end: 10.0,
            printed: [
                scaled(
                    "nd",
                    1.7321,
                    0.7071,
                    2.4495,
                    Nd,
                    [16.0, 0.0, -1.3333],
                    [-2.0, 0.0, 0.3333],
                ),
                // P1 and P2 exchanged relative to the nd listing, as printed
                scaled(
                    "dn",
                    1.7321,
                    0.7071,
                    3.4641,
                    Dn,
                    [-2.0, 0.0, 0.3333],
                    [16.0, 0.0, -1.3333],
                ),
            ],
        },
        Case {
            figure: "C.5",
            ty: IIa,
            c: [1.0, 4.0, Z],
            p0: [3.0, 2.0, 1.0],
            t_end: 10.0,
            printed: [
                scaled(
                    "sd",
                    2.7386,
                    0.3651,
                    1.8619,
                    Sd,
                    [8.6667, 0.0, 0.3333],
                    [5.3333, 0.0, -1.3333],
                ),
                scaled(
                    "cn",
                    2.7386,
                    0.3651,
                    2.0,
                    Cn,
                    [8.6667, 0.0, 0.3333],
                    [5.3333, 0.0, -1.3333],
                ),
            ],
        },
        Case {
            figure: "C.6",
            ty: IIb,
            c: [1.0, 0.5, Z],
            p0: [0.353_553_390_593_273_8, 11.0 * SQRT_6 / 32.0, 5.0 / 32.0],
            t_end: 30.0,
            printed: [
                mobius(
                    "dc",
                    0.3381,
                    0.0403,
                    0.9756,
                    0.9845,
                    1.1190,
                    Dc,
                    [-0.1386, 2.0, -2.0],
                    [0.9971, -2.0, 1.0],
                ),
                mobius(
                    "ns",
                    0.3381,
                    0.0403,
                    0.9756,
                    0.9845,
                    1.1190,
                    Ns,
                    [-0.1386, 2.0, -2.0],
                    [0.9971, -2.0, 1.0],
                ),
            ],
        },
        Case {
            figure: "C.7",
            ty: IIb,
            c: [1.0, 0.5, Z],
            p0: [1.224_744_871_391_589, 2.828_427_124_746_190_3, -1.0],
            t_end: 10.0,
            printed: [
                mobius(
                    "nc",
                    3.7523,
                    0.6413,
                    14.7901,
                    5.8572,
                    8.2504,
                    Nc,
                    [5.5, 2.0, -2.0],
                    [5.0, -2.0, 1.0],
                ),
                mobius(
                    "ds",
                    3.7523,
                    0.6413,
                    14.7901,
                    7.6332,
                    8.2504,
                    Ds,
                    [5.5, 2.0, -2.0],
                    [5.0, -2.0, 1.0],
                ),
            ],
        },
        Case {
            figure: "C.8",
            ty: IIb,
            c: [1.0, 2.0, Z],
            p0: [SQRT_34 / 4.0, SQRT_10 / 8.0, 0.5],
            t_end: 30.0,
            printed: [
                mobius(
                    "dc",
                    0.4781,
                    0.4407,
                    1.7853,
                    1.9437,
                    1.3709,
                    Dc,
                    [3.875, -4.0, 1.0],
                    [-1.3438, 4.0, -2.0],
                ),
                mobius(
                    "ns",
                    0.4781,
                    0.4407,
                    1.7853,
                    1.9437,
                    1.3709,
                    Ns,
                    [3.875, -4.0, 1.0],
                    [-1.3438, 4.0, -2.0],
                ),
            ],
        },
        Case {
            figure: "C.9",
            ty: IIb,
            c: [1.0, 2.0, Z],
            p0: [4.472_135_954_999_58, 1.0, -2.0],
            t_end: 10.0,
            printed: [
                mobius(
                    "nc",
                    2.5617,
                    0.8194,
                    14.8122,
                    7.5635,
                    4.4813,
                    Nc,
                    [8.0, -4.0, 1.0],
                    [17.0, 4.0, -2.0],
                ),
                mobius(
                    "ds",
                    2.5617,
                    0.8194,
                    14.8122,
                    13.1951,
                    7.8179,
                    Ds,
                    [8.0, -4.0, 1.0],
                    [17.0, 4.0, -2.0],
                ),
            ],
        },
        Case {
            figure: "C.10",
            ty: III,
            c: [3.0, 2.0, 4.0],
            p0: [0.0, 1.0, 2.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "nd",
                    0.2887,
                    0.7071,
                    1.4142,
                    Nd,
                    [6.0, 0.0, -1.5],
                    [-1.0, 0.0, 0.5],
                ),
                scaled(
                    "dn",
                    0.2887,
                    0.7071,
                    2.0,
                    Dn,
                    [6.0, 0.0, -1.5],
                    [-1.0, 0.0, 0.5],
                ),
            ],
        },
        Case {
            figure: "C.11",
            ty: III,
            c: [3.0, 2.0, 4.0],
            p0: [0.0, 2.0, 1.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "sd",
                    0.4082,
                    0.3536,
                    0.9354,
                    Sd,
                    [1.5, 0.0, -1.5],
                    [3.5, 0.0, 0.5],
                ),
                scaled(
                    "cn",
                    0.4082,
                    0.3536,
                    1.0,
                    Cn,
                    [1.5, 0.0, -1.5],
                    [3.5, 0.0, 0.5],
                ),
            ],
        },
        Case {
            figure: "C.12",
            ty: III,
            c: [1.0, 2.0, 3.0],
            p0: [1.0, 1.0, 2.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "nd",
                    0.7265,
                    0.8885,
                    1.0,
                    Nd,
                    [-0.3334, 0.0, 0.3333],
                    [6.3334, 0.0, -1.3333],
                ),
                scaled(
                    "dn",
                    0.7265,
                    0.8885,
                    2.1795,
                    Dn,
                    [-0.3334, 0.0, 0.3333],
                    [6.3334, 0.0, -1.3333],
                ),
            ],
        },
        Case {
            figure: "C.13",
            ty: III,
            c: [1.0, 2.0, 3.0],
            p0: [1.0, 1.0, 1.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "sd",
                    0.6455,
                    0.6832,
                    0.9660,
                    Sd,
                    [0.6666, 0.0, 0.3333],
                    [2.3334, 0.0, -1.3333],
                ),
                scaled(
                    "cn",
                    0.6455,
                    0.6832,
                    1.3229,
                    Cn,
                    [0.6666, 0.0, 0.3333],
                    [2.3334, 0.0, -1.3333],
                ),
            ],
        },
        Case {
            figure: "C.14",
            ty: III,
            c: [2.0, 3.0, 1.0],
            p0: [1.0, 1.0, 1.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "nd",
                    0.6455,
                    0.6832,
                    0.8165,
                    Nd,
                    [4.9998, 0.0, -4.0],
                    [-1.9998, 0.0, 3.0],
                ),
                scaled(
                    "dn",
                    0.6455,
                    0.6832,
                    1.1180,
                    Dn,
                    [4.9998, 0.0, -4.0],
                    [-1.9998, 0.0, 3.0],
                ),
            ],
        },
        Case {
            figure: "C.15",
            ty: III,
            c: [2.0, 3.0, 1.0],
            p0: [1.0, 2.0, 1.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "sd",
                    0.7265,
                    0.8885,
                    0.5130,
                    Sd,
                    [4.9998, 0.0, -4.0],
                    [1.0002, 0.0, 3.0],
                ),
                scaled(
                    "cn",
                    0.7265,
                    0.8885,
                    1.1180,
                    Cn,
                    [4.9998, 0.0, -4.0],
                    [1.0002, 0.0, 3.0],
                ),
            ],
        },
        Case {
            figure: "C.16",
            ty: III,
            c: [3.0, 2.0, 1.0],
            p0: [1.0, 1.0, 1.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "nd",
                    0.6455,
                    0.6832,
                    0.8165,
                    Nd,
                    [-1.9998, 0.0, 3.0],
                    [4.9998, 0.0, -4.0],
                ),
                scaled(
                    "dn",
                    0.6455,
                    0.6832,
                    1.1180,
                    Dn,
                    [-1.9998, 0.0, 3.0],
                    [4.9998, 0.0, -4.0],
                ),
            ],
        },
        Case {
            figure: "C.17",
            ty: III,
            c: [3.0, 2.0, 1.0],
            p0: [2.0, 1.0, 1.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "sd",
                    0.5278,
                    0.8885,
                    0.5130,
                    Sd,
                    [1.0002, 0.0, 3.0],
                    [4.9998, 0.0, -4.0],
                ),
                scaled(
                    "cn",
                    0.5278,
                    0.8885,
                    1.1180,
                    Cn,
                    [1.0002, 0.0, 3.0],
                    [4.9998, 0.0, -4.0],
                ),
            ],
        },
        Case {
            figure: "C.18",
            ty: III,
            c: [2.0, 0.5, 1.0],
            p0: [SQRT_3, 1.0, 1.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "sn",
                    1.6583,
                    0.8528,
                    2.0,
                    Sn,
                    [3.6667, 0.0, -0.6667],
                    [1.3333, 0.0, -0.3333],
                ),
                scaled(
                    "cd",
                    1.6583,
                    0.8528,
                    2.0,
                    Cd,
                    [3.6667, 0.0, -0.6667],
                    [1.3333, 0.0, -0.3333],
                ),
            ],
        },
        Case {
            figure: "C.19",
            ty: III,
            c: [1.0, 3.0, 2.0],
            p0: [2.0, 2.0, 2.0],
            t_end: 30.0,
            printed: [
                scaled(
                    "sn",
                    1.2910,
                    0.6831,
                    3.0551,
                    Sn,
                    [5.0, 0.0, -0.25],
                    [7.0001, 0.0, -0.75],
                ),
                scaled(
                    "cd",
                    1.2910,
                    0.6831,
                    3.0551,
                    Cd,
                    [5.0, 0.0, -0.25],
                    [7.0001, 0.0, -0.75],
                ),
            ],
        },
    ]
};

/// The corrected closed form of one extremal, P(t) for all real t.
#[derive(Clone, Debug)]
pub struct Extremal {
    kind: Kind,
}

#[derive(Clone, Debug)]
enum Kind {
    /// (P_π₀, P_π₁, P_π₂) = (a[0] cn w, a[1] sn w, a[2] dn w), w = w0 + omega·t.
    EulerTop {
        perm: [usize; 3],
        a: [f64; 3],
        m: f64,
        w0: f64,
        omega: f64,
    },
    /// P_axes[2] constant, (P_axes[0], P_axes[1]) = rho (cos, sin)(phi + rate·t).
    Rotation {
        axes: [usize; 3],
        rho: f64,
        phi: f64,
        rate: f64,
        p_axis: f64,
    },
    /// P₃ = r + y(w), w = w0 + lambda·t, Weierstrass' substitution through Jacobi functions.
    Weierstrass(Box<Weier>),
}

/// Which of 1, cn, dn a sign-carrying √(℘ − eⱼ)·sn/λ is (three real roots: √(℘ − e₃) = λ ns,
/// √(℘ − e₁) = λ cs, √(℘ − e₂) = λ ds).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Root {
    E1,
    E2,
    E3,
}

#[derive(Clone, Debug)]
struct Weier {
    /// the lower turning point of P₃
    r: f64,
    /// Q′(r)
    b1: f64,
    /// b₂/12 = Q″(r)/24
    e0: f64,
    /// index (0 for P₁, 1 for P₂) of the component that vanishes at P₃ = r
    a: usize,
    /// σ √(b₁ G_a′(r)/4): P_a = ca · √(℘ − e*)/(℘ − e₀)
    ca: f64,
    /// σ κ √(b₁/G_a′(r)): P_b = cb · Π_{j ≠ *} √(℘ − eⱼ)/(℘ − e₀)
    cb: f64,
    m: f64,
    w0: f64,
    /// dw/dt
    lambda: f64,
    roots: Roots,
}

#[derive(Clone, Debug)]
enum Roots {
    /// e₁ > e₂ > e₃ real (A&S 18.9.8): ℘(s) = e₃ + λ²/sn²(λs | m), λ² = e₁ − e₃,
    /// m = (e₂ − e₃)/(e₁ − e₃); `star` is the root paired with P_a.
    Three { e3: f64, star: Root },
    /// one real root e_r (paired with P_a) and ξ ± iη (A&S 18.9.11 with v = √H₂·s):
    /// ℘(s) = e_r + H₂ cn²/(sn² dn²)(v | m), H₂ = |e_r − (ξ + iη)|, m = ½ − 3e_r/(4H₂).
    One { er: f64, h2: f64, xi: f64, eta: f64 },
}

/// Polynomials as coefficient arrays, constant term first.
fn poly_mul(a: &[f64; 3], b: &[f64; 3]) -> [f64; 5] {
    let mut p = [0.0; 5];
    for i in 0..3 {
        for j in 0..3 {
            p[i + j] += a[i] * b[j];
        }
    }
    p
}

fn poly_eval(p: &[f64], x: f64) -> f64 {
    p.iter().rev().fold(0.0, |acc, c| acc * x + c)
}

fn poly_deriv(p: &[f64]) -> Vec<f64> {
    p.iter()
        .enumerate()
        .skip(1)
        .map(|(i, c)| i as f64 * c)
        .collect()
}

/// The roots of g₀ + g₁x + g₂x²: real ones, or one complex pair (re, im), or the single root
/// of a linear polynomial.
enum QuadRoots {
    Real(Vec<f64>),
    Complex(f64, f64),
}

fn quad_roots(g: &[f64; 3]) -> QuadRoots {
    let [c, b, a] = *g;
    if a == 0.0 {
        return QuadRoots::Real(vec![-c / b]);
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        QuadRoots::Complex(-b / (2.0 * a), (-disc).sqrt() / (2.0 * a).abs())
    } else {
        // stable form
        let q = -0.5 * (b + disc.sqrt().copysign(b));
        QuadRoots::Real(vec![q / a, c / q])
    }
}

impl Extremal {
    /// The corrected closed form for `ty` with parameters `c` from P(0) = `p0`; H and K are
    /// computed from them. Panics if the extremal is an equilibrium or a separatrix (m = 1),
    /// where the elliptic forms degenerate (none of the Appendix B cases is).
    pub fn new(ty: Type, c: [f64; 3], p0: [f64; 3]) -> Extremal {
        match ty {
            Type::IIa => Self::euler_top([1.0 / c[0], 1.0 / c[1], 0.0], p0),
            Type::III => Self::euler_top([1.0 / c[0], 1.0 / c[1], 1.0 / c[2]], p0),
            // c1 = c2 (Prop. 6.3.1): ∇H = (P1/c, P2/c, 1), (P1, P2) turns at P3/c − 1
            Type::IIb if c[0] == c[1] => Self::rotation([0, 1, 2], p0, p0[2] / c[0] - 1.0),
            Type::I | Type::IIb => Self::weierstrass(ty, c, p0),
        }
    }

    /// The corrected closed form of an Appendix B case.
    pub fn of_case(case: &Case) -> Extremal {
        Self::new(case.ty, case.c, case.p0)
    }

    /// Pₗ constant and (Pᵢ, Pⱼ) = ρ (cos(φ + Ωt), sin(φ + Ωt)) for the cyclic axes (i, j, l).
    fn rotation(axes: [usize; 3], p0: [f64; 3], rate: f64) -> Extremal {
        let [i, j, _] = axes;
        Extremal {
            kind: Kind::Rotation {
                axes,
                rho: p0[i].hypot(p0[j]),
                phi: p0[j].atan2(p0[i]),
                rate,
                p_axis: p0[axes[2]],
            },
        }
    }

    fn euler_top(inertia: [f64; 3], p0: [f64; 3]) -> Extremal {
        // a symmetric top (Props. 5.3.1, 7.3.1, 7.3.2 and the "similar results" after 7.3.2):
        // for the cyclic axes (i, j, l) with Iᵢ = Iⱼ = I, Ṗᵢ = −(I − Iₗ)Pₗ Pⱼ,
        // Ṗⱼ = (I − Iₗ)Pₗ Pᵢ: (Pᵢ, Pⱼ) turns at Ω = (I − Iₗ)Pₗ, Pₗ is constant.
        for axes in [[0, 1, 2], [1, 2, 0], [2, 0, 1]] {
            let [i, j, l] = axes;
            if inertia[i] == inertia[j] {
                return Self::rotation(axes, p0, (inertia[i] - inertia[l]) * p0[l]);
            }
        }
        let h2 = (0..3).map(|i| inertia[i] * p0[i] * p0[i]).sum::<f64>(); // 2H
        let k = casimir(p0);
        const PERMS: [([usize; 3], f64); 6] = [
            ([0, 1, 2], 1.0),
            ([1, 2, 0], 1.0),
            ([2, 0, 1], 1.0),
            ([0, 2, 1], -1.0),
            ([2, 1, 0], -1.0),
            ([1, 0, 2], -1.0),
        ];
        let mut best: Option<(f64, Extremal)> = None;
        for (perm, parity) in PERMS {
            let [ii, ij, il] = perm.map(|i| inertia[i]);
            if ii == il || ij == il || ii == ij {
                continue;
            }
            let a1s = (h2 - il * k) / (ii - il);
            let a2s = (h2 - il * k) / (ij - il);
            let a3s = (ii * k - h2) / (ii - il);
            let m = (ii - ij) * (h2 - il * k) / ((ij - il) * (ii * k - h2));
            if !(a1s > 0.0 && a2s > 0.0 && a3s > 0.0 && (0.0..1.0).contains(&m)) {
                continue;
            }
            let q = perm.map(|i| p0[i]);
            let a1 = a1s.sqrt();
            let a2 = a2s.sqrt();
            let a3 = a3s.sqrt().copysign(q[2]);
            let omega = (ii - il) * a1 * a3 / a2 * parity;
            let w0 = ellipf((q[1] / a2).atan2(q[0] / a1), m);
            let x = Extremal {
                kind: Kind::EulerTop {
                    perm,
                    a: [a1, a2, a3],
                    m,
                    w0,
                    omega,
                },
            };
            let at0 = x.p(0.0);
            let res = (0..3).fold(0.0f64, |r, i| r.max((at0[i] - p0[i]).abs()));
            if best.as_ref().is_none_or(|(r, _)| res < *r) {
                best = Some((res, x));
            }
        }
        best.expect("no elliptic regime: equilibrium or separatrix")
            .1
    }

    fn weierstrass(ty: Type, c: [f64; 3], p0: [f64; 3]) -> Extremal {
        let h = ty.hamiltonian(c, p0);
        let k = casimir(p0);
        let [c1, c2, _] = c;
        // P1² = G1(P3), P2² = G2(P3), P1 P2 = κ Ṗ3
        let (g1, g2, kappa) = match ty {
            Type::I => (
                [2.0 * c1 * h, -2.0 * c1, 0.0],
                [k - 2.0 * c1 * h, 2.0 * c1, -1.0],
                -c1,
            ),
            Type::IIb => {
                let s1 = c1 / (c2 - c1);
                let s2 = c2 / (c2 - c1);
                (
                    [s1 * (2.0 * c2 * h - k), -2.0 * s1 * c2, s1],
                    [s2 * (k - 2.0 * c1 * h), 2.0 * s2 * c1, -s2],
                    c1 * c2 / (c1 - c2),
                )
            }
            _ => unreachable!("Euler-top types are handled by euler_top"),
        };
        let q: Vec<f64> = poly_mul(&g1, &g2)
            .iter()
            .map(|v| v / (kappa * kappa))
            .collect();
        // real roots of Q, each tagged with the component that vanishes there
        let mut real: Vec<(f64, usize)> = Vec::new();
        let mut complex: Option<(f64, f64, usize)> = None;
        for (idx, g) in [g1, g2].iter().enumerate() {
            match quad_roots(g) {
                QuadRoots::Real(rs) => real.extend(rs.into_iter().map(|r| (r, idx))),
                QuadRoots::Complex(re, im) => complex = Some((re, im, idx)),
            }
        }
        real.sort_by(|a, b| a.0.total_cmp(&b.0));
        let x0 = p0[2];
        let dq = poly_deriv(&q);
        // the adjacent pair of real roots around x0 with Q > 0 between
        let scale = 1.0 + x0.abs();
        let (lo, _) = real
            .windows(2)
            .map(|w| (w[0], w[1]))
            .filter(|(l, u)| {
                l.0 <= x0 + 1e-12 * scale
                    && u.0 >= x0 - 1e-12 * scale
                    && poly_eval(&q, 0.5 * (l.0 + u.0)) > 0.0
            })
            .min_by(|x, y| (x.1 .0 - x.0 .0).total_cmp(&(y.1 .0 - y.0 .0)))
            .expect("P3(0) is not between two turning points");
        let r = lo.0;
        let a = lo.1;
        let ga = if a == 0 { g1 } else { g2 };
        let ga_prime = ga[1] + 2.0 * ga[2] * r;
        let b1 = poly_eval(&dq, r);
        let b2 = 0.5 * poly_eval(&poly_deriv(&dq), r);
        let e0 = b2 / 12.0;
        let e_of = |rj: f64| e0 + b1 / (4.0 * (rj - r));
        let y0 = (x0 - r).max(0.0);
        let ca = (b1 * ga_prime / 4.0).sqrt();
        let cb = kappa * (b1 / ga_prime).sqrt();
        let (roots, m, lambda, w0_abs) = match complex {
            None => {
                // the three other roots of Q (∞ for a cubic), paired with a component
                let mut es: Vec<(f64, bool)> = real
                    .iter()
                    .filter(|(rj, _)| *rj != r)
                    .map(|&(rj, idx)| (e_of(rj), idx == a))
                    .collect();
                if es.len() == 2 {
                    // cubic: the root at infinity belongs to the linear G
                    let linear_is_a = ga[2] == 0.0;
                    es.push((e0, linear_is_a));
                }
                es.sort_by(|x, y| y.0.total_cmp(&x.0));
                let [(e1, s1), (e2, s2), (e3, _)] = [es[0], es[1], es[2]];
                let star = if s1 {
                    Root::E1
                } else if s2 {
                    Root::E2
                } else {
                    Root::E3
                };
                let lambda = (e1 - e3).sqrt();
                let m = (e2 - e3) / (e1 - e3);
                // sn²(w0) from y0 = b1 sn²/(4(λ² + (e3 − e0) sn²))
                let sn2 =
                    (4.0 * y0 * lambda * lambda / (b1 + 4.0 * y0 * (e0 - e3))).clamp(0.0, 1.0);
                let w0 = ellipf(sn2.sqrt().asin(), m);
                (Roots::Three { e3, star }, m, lambda, w0)
            }
            Some((re, im, idx)) => {
                assert_ne!(
                    idx, a,
                    "the complex pair must belong to the other component"
                );
                let d = re - r;
                let den = 4.0 * (d * d + im * im);
                let xi = e0 + b1 * d / den;
                let eta = b1 * im / den;
                // the real e: from the other root of G_a, or ∞ (e0) if G_a is linear
                let er = real
                    .iter()
                    .find(|(rj, _)| *rj != r)
                    .map_or(e0, |&(rj, _)| e_of(rj));
                let h2 = ((er - xi).powi(2) + eta * eta).sqrt();
                let m = 0.5 - 3.0 * er / (4.0 * h2);
                // cn(2v0) = (R − 1)/(R + 1), R = (℘ − e_r)/H₂, ℘ = e0 + b1/(4 y0)
                let num = 4.0 * y0 * (e0 - er) + b1;
                let cn2 = ((num - 4.0 * y0 * h2) / (num + 4.0 * y0 * h2)).clamp(-1.0, 1.0);
                let v0 = 0.5 * ellipf(cn2.acos(), m);
                (Roots::One { er, h2, xi, eta }, m, h2.sqrt(), v0)
            }
        };
        let mut best: Option<(f64, Extremal)> = None;
        for sigma in [1.0, -1.0] {
            for dir in [1.0, -1.0] {
                let x = Extremal {
                    kind: Kind::Weierstrass(Box::new(Weier {
                        r,
                        b1,
                        e0,
                        a,
                        ca: sigma * ca,
                        cb: sigma * cb,
                        m,
                        w0: dir * w0_abs,
                        lambda,
                        roots: roots.clone(),
                    })),
                };
                let at0 = x.p(0.0);
                let res = (0..3).fold(0.0f64, |acc, i| acc.max((at0[i] - p0[i]).abs()));
                if best.as_ref().is_none_or(|(b, _)| res < *b) {
                    best = Some((res, x));
                }
            }
        }
        let (_, mut best) = best.expect("four candidates");
        // Near a turning point x(0) fixes w₀ only to √(rounding); the component that vanishes
        // there (P_a at r, ∝ sn; the cn-factor at r′) fixes it to full accuracy.
        if let Kind::Weierstrass(w) = &mut best.kind {
            w.refine_phase(p0[a], p0[1 - a]);
        }
        best
    }

    /// The parameter m = k² of the Jacobi functions (0 for a uniform rotation).
    pub fn parameter(&self) -> f64 {
        match &self.kind {
            Kind::EulerTop { m, .. } => *m,
            Kind::Rotation { .. } => 0.0,
            Kind::Weierstrass(w) => w.m,
        }
    }

    /// The time scale |dw/dt| of the Jacobi argument w (|Ω| for a rotation).
    pub fn time_scale(&self) -> f64 {
        match &self.kind {
            Kind::EulerTop { omega, .. } => omega.abs(),
            Kind::Rotation { rate, .. } => rate.abs(),
            Kind::Weierstrass(w) => w.lambda,
        }
    }

    /// P(t).
    pub fn p(&self, t: f64) -> [f64; 3] {
        match &self.kind {
            Kind::EulerTop {
                perm,
                a,
                m,
                w0,
                omega,
            } => {
                let j = ellipj(w0 + omega * t, *m);
                let mut p = [0.0; 3];
                p[perm[0]] = a[0] * j.cn;
                p[perm[1]] = a[1] * j.sn;
                p[perm[2]] = a[2] * j.dn;
                p
            }
            Kind::Rotation {
                axes,
                rho,
                phi,
                rate,
                p_axis,
            } => {
                let (s, c) = (phi + rate * t).sin_cos();
                let mut p = [0.0; 3];
                p[axes[0]] = rho * c;
                p[axes[1]] = rho * s;
                p[axes[2]] = *p_axis;
                p
            }
            Kind::Weierstrass(w) => w.p(t),
        }
    }

    /// The (least) period of P₃(t) (∞ where P₃ is constant).
    pub fn p3_period(&self) -> f64 {
        match &self.kind {
            Kind::EulerTop { perm, m, omega, .. } => {
                // P3 is a·dn (period 2K) if axis 3 is the dn-axis, else cn or sn (4K)
                let n = if perm[2] == 2 { 2.0 } else { 4.0 };
                n * ellipk(*m) / omega.abs()
            }
            Kind::Rotation { axes, rate, .. } => {
                if axes[2] == 2 {
                    f64::INFINITY
                } else {
                    2.0 * std::f64::consts::PI / rate.abs()
                }
            }
            Kind::Weierstrass(w) => {
                // ℘ has real period 2K/λ in both root configurations (in v = √H₂ s the
                // function cn²/(sn² dn²) has period 2K)
                2.0 * ellipk(w.m) / w.lambda
            }
        }
    }
}

impl Weier {
    /// Recomputes w₀ near the turning points, where x(0) determines it badly: near r
    /// (sn w₀ ≈ 0) from P_a(0) ∝ sn w₀, near r′ (cn w₀ ≈ 0) from the component ∝ cn w₀.
    fn refine_phase(&mut self, pa0: f64, pb0: f64) {
        let j = ellipj(self.w0, self.m);
        let (sn, cn, dn) = (j.sn, j.cn, j.dn);
        let s2 = sn * sn;
        let (sn_new, cn_new) = match self.roots {
            Roots::Three { e3, star } => {
                let d = self.lambda * self.lambda + (e3 - self.e0) * s2;
                let f = |root: Root| match root {
                    Root::E1 => cn,
                    Root::E2 => dn,
                    Root::E3 => 1.0,
                };
                if s2 < 0.5 {
                    // P_a = ca λ f* sn / D
                    let sn_new = pa0 * d / (self.ca * self.lambda * f(star));
                    (sn_new, (1.0 - sn_new * sn_new).max(0.0).sqrt().copysign(cn))
                } else {
                    // the cn-factor: in P_a (e* = e₁) or in P_b = cb λ² f_j f_l / D
                    let cn_new = if star == Root::E1 {
                        pa0 * d / (self.ca * self.lambda * sn)
                    } else {
                        let g = if star == Root::E2 { 1.0 } else { dn };
                        pb0 * d / (self.cb * self.lambda * self.lambda * g)
                    };
                    ((1.0 - cn_new * cn_new).max(0.0).sqrt().copysign(sn), cn_new)
                }
            }
            Roots::One { er, h2, .. } => {
                // P_a = ca √H₂ cn sn dn / D: near sn = 0 solve for sn, near cn = 0 for cn
                let d = h2 * cn * cn + (er - self.e0) * s2 * dn * dn;
                let scd = pa0 * d / (self.ca * h2.sqrt());
                if s2 < 0.5 {
                    let sn_new = scd / (cn * dn);
                    (sn_new, (1.0 - sn_new * sn_new).max(0.0).sqrt().copysign(cn))
                } else {
                    let cn_new = scd / (sn * dn);
                    ((1.0 - cn_new * cn_new).max(0.0).sqrt().copysign(sn), cn_new)
                }
            }
        };
        if sn_new.is_finite() && cn_new.is_finite() {
            self.w0 = ellipf(sn_new.atan2(cn_new), self.m);
        }
    }

    fn p(&self, t: f64) -> [f64; 3] {
        let j = ellipj(self.w0 + self.lambda * t, self.m);
        let (sn, cn, dn) = (j.sn, j.cn, j.dn);
        // y = P3 − r, P_a = ca·ra, P_b = cb·rb with ra = √(℘ − e*)/(℘ − e0),
        // rb = Π_{j ≠ *} √(℘ − eⱼ)/(℘ − e0), all multiplied through by sn² (or sn² dn²).
        let (y, ra, rb) = match self.roots {
            Roots::Three { e3, star } => {
                let l2 = self.lambda * self.lambda;
                let d = l2 + (e3 - self.e0) * sn * sn;
                let f = |root: Root| match root {
                    Root::E1 => cn,
                    Root::E2 => dn,
                    Root::E3 => 1.0,
                };
                let others: Vec<Root> = [Root::E1, Root::E2, Root::E3]
                    .into_iter()
                    .filter(|x| *x != star)
                    .collect();
                (
                    self.b1 * sn * sn / (4.0 * d),
                    self.lambda * f(star) * sn / d,
                    l2 * f(others[0]) * f(others[1]) / d,
                )
            }
            Roots::One { er, h2, xi, eta } => {
                let s2d2 = sn * sn * dn * dn;
                let d = h2 * cn * cn + (er - self.e0) * s2d2;
                let n = h2 * cn * cn + (er - xi) * s2d2;
                (
                    self.b1 * s2d2 / (4.0 * d),
                    h2.sqrt() * cn * sn * dn / d,
                    (n * n + eta * eta * s2d2 * s2d2).sqrt() / d,
                )
            }
        };
        let mut p = [0.0, 0.0, self.r + y];
        p[self.a] = self.ca * ra;
        p[1 - self.a] = self.cb * rb;
        p
    }
}

/// The invariants (g₂, g₁) of Theorem 4.3.2 as printed (its g₁ is the usual g₃), with
/// a = 2c₁, b = (H + 2c₁)/3: ℘′² = 4℘³ − g₂℘ − g₁ for ℘ = (P₃ − b)/a.
pub fn theorem_4_3_2_invariants(c1: f64, h: f64, k: f64) -> (f64, f64) {
    let a = 2.0 * c1;
    let b = (h + 2.0 * c1) / 3.0;
    let q = 2.0 + h / c1;
    let g1 = -2.0 / (a * a)
        * (b.powi(3) / c1 - q * b * b + (4.0 * h - k / c1) * b + h * (k / c1 - 2.0 * h));
    let g2 = -2.0 / a * (3.0 / c1 * b * b - 2.0 * q * b + 4.0 * h - k / c1);
    (g2, g1)
}

/// Theorem 4.3.2 corrected: P₃ = 2c₁ ℘(t − t₀ + ω₃) + (H + 2c₁)/3 with the printed invariants
/// and ℘ on its **bounded** real branch (shifted by the imaginary half-period ω₃),
/// ℘(z + ω₃) = e₃ + (e₂ − e₃) sn²(√(e₁ − e₃) z | m), m = (e₂ − e₃)/(e₁ − e₃), e₁ > e₂ > e₃
/// the roots of 4e³ − g₂e − g₁ (trigonometric solution), and t₀ from P₃(0) and the sign of
/// Ṗ₃(0) = −P₁(0)P₂(0)/c₁. As printed, "P₃ = 2c₁℘ + b" with ℘(t) on the real axis has a pole
/// at t = 0 and takes values ≥ e₁, i.e. P₃ ≥ H on the unbounded branch where P₁² < 0.
pub fn theorem_4_3_2_p3(c1: f64, p0: [f64; 3], t: f64) -> f64 {
    let h = Type::I.hamiltonian([c1, 0.0, 0.0], p0);
    let k = casimir(p0);
    let (g2, g3) = theorem_4_3_2_invariants(c1, h, k);
    let a = 2.0 * c1;
    let b = (h + 2.0 * c1) / 3.0;
    // 4e³ − g₂e − g₃ = 0: e = 2√(g₂/12) cos(θ/3 − 2πj/3), cos θ = g₃/(8 (g₂/12)^{3/2})
    let r = (g2 / 12.0).sqrt();
    let theta = (g3 / (8.0 * r * r * r)).clamp(-1.0, 1.0).acos();
    let e = |j: f64| 2.0 * r * (theta / 3.0 - 2.0 * std::f64::consts::PI * j / 3.0).cos();
    let (e1, e2, e3) = (e(0.0), e(1.0), e(2.0));
    let m = (e2 - e3) / (e1 - e3);
    let lambda = (e1 - e3).sqrt();
    // sn²(u₀) = (℘(0) − e₃)/(e₂ − e₃), u₀ = −λt₀,
    // and Ṗ₃(0) = 2a(e₂ − e₃)λ sn cn dn; near sn = 0 (cn = 0) the latter fixes sn (cn) to full
    // accuracy (√ of the former would lose half the digits at a turning point)
    let s2 = (((p0[2] - b) / a - e3) / (e2 - e3)).clamp(0.0, 1.0);
    let dp3 = -p0[0] * p0[1] / c1;
    let cn0 = (1.0 - s2).sqrt();
    let scd = dp3 / (2.0 * a * (e2 - e3) * lambda); // sn cn dn at u₀
    let dn0 = (1.0 - m * s2).sqrt();
    let (sn0, cn0) = if s2 < 0.5 {
        (scd / (cn0 * dn0), cn0)
    } else {
        // near the maximum (cn u₀ ≈ 0) take cn from Ṗ₃(0), with u₀ ∈ [0, 2K) (sn ≥ 0)
        let sn0 = s2.sqrt();
        (sn0, scd / (sn0 * dn0))
    };
    let u0 = ellipf(sn0.atan2(cn0), m);
    let sn = ellipj(u0 + lambda * t, m).sn;
    a * (e3 + (e2 - e3) * sn * sn) + b
}

/// Prop. 5.3.1 as printed (Type IIa, c₁ = c₂ = c): P₃ = P₃(0) and (P₁, P₂) turned by
/// P₃(0) t / c. Correct.
pub fn prop_5_3_1_printed(c: f64, p0: [f64; 3], t: f64) -> [f64; 3] {
    let (s, co) = (p0[2] * t / c).sin_cos();
    [p0[0] * co - p0[1] * s, p0[0] * s + p0[1] * co, p0[2]]
}

/// Prop. 6.3.1 as printed (Type IIb, c₁ = c₂ = c): P₁ = √k₁ cos((1 − k₂/c)t + k₃),
/// P₂ = √k₁ sin((1 − k₂/c)t + k₃), k₃ = −tan⁻¹(P₂(0)/P₁(0)). Wrong sign of P₂ (and tan⁻¹
/// loses the quadrant for P₁(0) < 0): the true motion is P₂ = −√k₁ sin(…).
pub fn prop_6_3_1_printed(c: f64, p0: [f64; 3], t: f64) -> [f64; 3] {
    let k1 = p0[0] * p0[0] + p0[1] * p0[1];
    let k3 = -(p0[1] / p0[0]).atan();
    let arg = (1.0 - p0[2] / c) * t + k3;
    [k1.sqrt() * arg.cos(), k1.sqrt() * arg.sin(), p0[2]]
}

/// Prop. 7.3.2 as printed (Type III, c₁ = c₂ ≠ c₃), real part: the diagonal entries are
/// cosh((c₁ − c₃)(c₃ − c₂)P₃(0)t/√(c₁c₂c₃)) with a real argument; the off-diagonal sinh has
/// √(c₁c₂(c₁ − c₃)(c₃ − c₂)) = √(−c²(c − c₃)²), imaginary, so sinh(iθ) = i sin θ contributes
/// no real part. Wrong: the true motion is a rotation (see [`Extremal`]).
pub fn prop_7_3_2_printed(c: [f64; 3], p0: [f64; 3], t: f64) -> [f64; 3] {
    let [c1, c2, c3] = c;
    let ch = ((c1 - c3) * (c3 - c2) * p0[2] / (c1 * c2 * c3).sqrt() * t).cosh();
    [p0[0] * ch, p0[1] * ch, p0[2]]
}

/// The corrected P(t) of Appendix B case `case` (an index into [`CASES`], 0 for C.1).
pub fn p_closed(case: usize, t: f64) -> [f64; 3] {
    Extremal::of_case(&CASES[case]).p(t)
}

/// The printed P(t) of case `case`, function `which` (0 = first, 1 = second elliptic
/// function), with the thesis' `ellipj(·, k)`.
pub fn p_printed(case: usize, which: usize, t: f64) -> [f64; 3] {
    let f = &CASES[case].printed[which];
    f.eval(t, f.k)
}

/// The listing `which` (0 = first, 1 = second elliptic function) of `case` with every
/// constant computed from c, P(0), H and K by the formulas of its theorem — Theorem 4.3.1
/// (Type I), 5.3.1 (IIa), 6.3.1 (IIb), 7.3.1 (III), in the sub-case the listing belongs to —
/// at full precision, where the listing prints four decimals. Two of the theorems' formulas
/// are replaced by the correct ones (`docs/so3.md`): the time scale of Theorem 7.3.1's
/// "sd and/or cn" sub-cases is √((c₃−c₂)(c₃−c₁)(a² + b²)/(c₁c₂c₃²)), not ·(a² + b²), and
/// the nc/ds forms of Theorem 6.3.1 keep √(a² + b²) in the denominator of ds (as printed in
/// the theorem; the C.7 listing prints a there). `k` is the theorem's modulus (so
/// `eval(t, k²)` is the form with MATLAB's convention fixed) and the form has no phase: like
/// the printed one, it is right only up to a time shift (`docs/so3.md`, #2).
pub fn exact_listing(case: &Case, which: usize) -> Printed {
    let printed = &case.printed[which];
    let f = match printed.p3 {
        P3Form::Scaled(_, f) | P3Form::Mobius { f, .. } => f,
    };
    let [c1, c2, c3] = case.c;
    let h = case.ty.hamiltonian(case.c, case.p0);
    let k = casimir(case.p0);
    let listing = |omega: f64, modulus: f64, p3: P3Form, p1: [f64; 3], p2: [f64; 3]| Printed {
        name: printed.name,
        omega,
        k: modulus,
        p3,
        p1,
        p2,
    };
    match case.ty {
        Type::I => {
            // Theorem 4.3.1
            let s = (h * h - k).sqrt();
            let (alpha, beta) = (h + s, h - s);
            let a = ((c1 - s - h) / (c1 + s - h)).sqrt();
            let a1a2 = -(c1 + s - h) / (4.0 * s * s);
            listing(
                (alpha - beta) * a1a2.sqrt() * a / c1.sqrt(),
                1.0 / a, // b = 1
                P3Form::Mobius {
                    n0: alpha,
                    n1: beta * a,
                    d1: a,
                    f,
                },
                [2.0 * c1 * h, -2.0 * c1, 0.0],
                [k - 2.0 * h * c1, 2.0 * c1, -1.0],
            )
        }
        Type::IIa => {
            // Theorem 5.3.1: CASE (I) c₁ > c₂, CASE (II) the same with c₁ ↔ c₂
            let (big, small) = if c1 > c2 { (c1, c2) } else { (c2, c1) };
            let (omega, modulus, amp) = match f {
                Jf::Nd | Jf::Dn => {
                    let amp = if f == Jf::Nd {
                        (k - 2.0 * h * big).sqrt()
                    } else {
                        (k - 2.0 * h * small).sqrt()
                    };
                    (
                        ((k - 2.0 * h * small) / (c1 * c2)).sqrt(),
                        (2.0 * h * (big - small) / (k - 2.0 * h * small)).sqrt(),
                        amp,
                    )
                }
                _ => {
                    let amp = if f == Jf::Sd {
                        ((2.0 * h * big - k) * (k - 2.0 * h * small) / (2.0 * h * (big - small)))
                            .sqrt()
                    } else {
                        (k - 2.0 * h * small).sqrt()
                    };
                    (
                        (2.0 * h * (big - small) / (c1 * c2)).sqrt(),
                        ((k - 2.0 * h * small) / (2.0 * h * (big - small))).sqrt(),
                        amp,
                    )
                }
            };
            listing(
                omega,
                modulus,
                P3Form::Scaled(amp, f),
                [c1 * (k - 2.0 * h * c2) / (c1 - c2), 0.0, -c1 / (c1 - c2)],
                [c2 * (k - 2.0 * h * c1) / (c2 - c1), 0.0, -c2 / (c2 - c1)],
            )
        }
        Type::IIb => {
            // Theorem 6.3.1: a² from the smaller cᵢ, b² from the larger (CASE (I) c₁ > c₂,
            // CASE (II) c₂ > c₁)
            let s = (h * h - k).sqrt();
            let (alpha, beta) = (h + s, h - s);
            let (big, small) = if c1 > c2 { (c1, c2) } else { (c2, c1) };
            let a2 = (h - small + s) / (h - small - s);
            let b2 = (h - big + s) / (h - big - s);
            let a = a2.sqrt();
            let a1a2 = -(h - c2 - s) * (h - c1 - s) / (4.0 * s * s);
            let scale = (alpha - beta) * a1a2.sqrt() / (c1 * c2).sqrt();
            let (omega, modulus, p3) = match f {
                Jf::Dc | Jf::Ns => (
                    scale * a,
                    b2.sqrt() / a,
                    P3Form::Mobius {
                        n0: alpha,
                        n1: beta * a,
                        d1: a,
                        f,
                    },
                ),
                _ => {
                    // "nc and/or ds": b² = −(H − c + √(H² − K))/(H − c − √(H² − K))
                    let r = (a2 - b2).sqrt();
                    let (n1, d1) = if f == Jf::Nc {
                        (beta * a, a)
                    } else {
                        (beta * r, r)
                    };
                    (
                        scale * r,
                        (-b2).sqrt() / r,
                        P3Form::Mobius {
                            n0: alpha,
                            n1,
                            d1,
                            f,
                        },
                    )
                }
            };
            let q1 = c1 / (c2 - c1);
            let q2 = c2 / (c1 - c2);
            listing(
                omega,
                modulus,
                p3,
                [q1 * (2.0 * h * c2 - k), -2.0 * c2 * q1, q1],
                [q2 * (2.0 * h * c1 - k), -2.0 * c1 * q2, q2],
            )
        }
        Type::III => {
            // Theorem 7.3.1
            let rate = ((c3 - c2) * (c3 - c1)).abs().sqrt() / (c1 * c2).sqrt() / c3;
            let x2 = c3 * (k - 2.0 * h * c2) / (c3 - c2);
            let x1 = c3 * (k - 2.0 * h * c1) / (c3 - c1);
            let y1 = c3 * (2.0 * h * c1 - k) / (c3 - c1);
            let y2 = c3 * (2.0 * h * c2 - k) / (c3 - c2);
            // CASE 1A(I) and 1B(I) share their a², b², as do 1A(II) and 1B(II)
            let first = (c3 - c1) * (c1 - c2) > 0.0;
            let case2 = (c3 - c1) * (c3 - c2) < 0.0;
            let (a2, b2) = match f {
                _ if case2 => {
                    if x1 < x2 {
                        (x2, x1)
                    } else {
                        (x1, x2)
                    }
                }
                Jf::Nd | Jf::Dn if first => (x2, x1),
                Jf::Nd | Jf::Dn => (x1, x2),
                _ if first => (y1, x2),
                _ => (y2, x1),
            };
            let (a, b) = (a2.sqrt(), b2.sqrt());
            let (omega, modulus, amp) = match f {
                Jf::Nd => (rate * a, (a2 - b2).sqrt() / a, b),
                Jf::Dn => (rate * a, (a2 - b2).sqrt() / a, a),
                Jf::Sd | Jf::Cn => {
                    let r = (a2 + b2).sqrt();
                    (rate * r, b / r, if f == Jf::Sd { a * b / r } else { b })
                }
                _ => (rate * a, b / a, b), // CASE 2: sn, cd
            };
            let q1 = c1 * (c3 - c2) / (c3 * (c1 - c2));
            let q2 = c2 * (c3 - c1) / (c3 * (c2 - c1));
            listing(
                omega,
                modulus,
                P3Form::Scaled(amp, f),
                [q1 * x2, 0.0, -q1],
                [q2 * x1, 0.0, -q2],
            )
        }
    }
}

/// One printed number of an Appendix B listing next to its exact value.
#[derive(Clone, Debug, PartialEq)]
pub struct Constant {
    /// "C.1" … "C.19".
    pub figure: &'static str,
    /// The listing(s) that print it: "dc", "dc, ns" (the same number in both), or "ode45"
    /// for the initial value of SECTION 1.
    pub listing: String,
    /// What it is: "ω", "k", "A" (the amplitude of P₃ = A·f), "α", "βa", "a" (the Möbius form
    /// (α − βa f)/(1 − a f); for ds "β√(a²+b²)" and "√(a²+b²)"), "P₁²: 1", "P₁²: P₃",
    /// "P₁²: P₃²" (the coefficients of P₁² as a polynomial in P₃), likewise P₂², or "Pᵢ(0)".
    pub name: &'static str,
    /// As printed (four decimals at most).
    pub printed: f64,
    /// From c, P(0), H and K ([`exact_listing`]; P(0) for the ode45 values).
    pub exact: f64,
}

impl Constant {
    /// Whether the printed number is the exact one rounded to four decimals (a tie such as
    /// −1.34375 may go either way).
    pub fn rounds(&self) -> bool {
        (self.printed - self.exact).abs() <= 0.5e-4 + 1e-12
    }
}

/// The initial values of the ode45 calls (SECTION 1) that are printed with four decimals;
/// the other cases print integers, which are P(0) exactly.
pub const ODE45_P0: [(&str, [f64; 3]); 5] = [
    ("C.6", [0.3536, 0.8420, 0.1563]),
    ("C.7", [1.2247, 2.8284, -1.0]),
    ("C.8", [1.4577, 0.3953, 0.5]),
    ("C.9", [4.4721, 1.0, -2.0]),
    ("C.18", [1.7321, 1.0, 1.0]),
];

/// Every printed constant of every Appendix B listing (and the four-decimal ode45 initial
/// values), with its exact value; a number that both listings of a case print alike (ω, k,
/// the P₁², P₂² coefficients) is one entry "dc, ns" when its exact values agree too.
pub fn printed_constants() -> Vec<Constant> {
    const P3_NAMES: [&str; 3] = ["α", "βa", "a"];
    const P3_NAMES_DS: [&str; 3] = ["α", "β√(a²+b²)", "√(a²+b²)"];
    const POLY: [[&str; 3]; 2] = [
        ["P₁²: 1", "P₁²: P₃", "P₁²: P₃²"],
        ["P₂²: 1", "P₂²: P₃", "P₂²: P₃²"],
    ];
    let mut out = Vec::new();
    for case in &CASES {
        if let Some((_, p)) = ODE45_P0.iter().find(|(f, _)| *f == case.figure) {
            for (i, name) in ["P₁(0)", "P₂(0)", "P₃(0)"].into_iter().enumerate() {
                out.push(Constant {
                    figure: case.figure,
                    listing: "ode45".to_string(),
                    name,
                    printed: p[i],
                    exact: case.p0[i],
                });
            }
        }
        // (name, printed, exact) of each listing, in a fixed order
        let rows: Vec<Vec<(&'static str, f64, f64)>> = (0..2)
            .map(|w| {
                let (pr, ex) = (&case.printed[w], exact_listing(case, w));
                let mut r = vec![("ω", pr.omega, ex.omega), ("k", pr.k, ex.k)];
                match (pr.p3, ex.p3) {
                    (P3Form::Scaled(a, _), P3Form::Scaled(b, _)) => r.push(("A", a, b)),
                    (
                        P3Form::Mobius { n0, n1, d1, f },
                        P3Form::Mobius {
                            n0: e0,
                            n1: e1,
                            d1: e2,
                            ..
                        },
                    ) => {
                        let names = if f == Jf::Ds { P3_NAMES_DS } else { P3_NAMES };
                        r.extend([(names[0], n0, e0), (names[1], n1, e1), (names[2], d1, e2)]);
                    }
                    _ => unreachable!("{}: printed and exact forms differ in kind", case.figure),
                }
                for (names, (pp, pe)) in POLY.iter().zip([(pr.p1, ex.p1), (pr.p2, ex.p2)]) {
                    for i in 0..3 {
                        // coefficients that are 0 in both are not printed
                        if pp[i] != 0.0 || pe[i] != 0.0 {
                            r.push((names[i], pp[i], pe[i]));
                        }
                    }
                }
                r
            })
            .collect();
        let names = [case.printed[0].name, case.printed[1].name];
        for &(name, printed, exact) in &rows[0] {
            let other = rows[1].iter().find(|r| r.0 == name);
            let same = |o: &(&str, f64, f64)| o.1 == printed && (o.2 - exact).abs() <= 1e-12;
            match other {
                Some(o) if same(o) => out.push(Constant {
                    figure: case.figure,
                    listing: format!("{}, {}", names[0], names[1]),
                    name,
                    printed,
                    exact,
                }),
                _ => out.push(Constant {
                    figure: case.figure,
                    listing: names[0].to_string(),
                    name,
                    printed,
                    exact,
                }),
            }
        }
        for &(name, printed, exact) in &rows[1] {
            let first = rows[0].iter().find(|r| r.0 == name);
            let shared = first.is_some_and(|o| o.1 == printed && (o.2 - exact).abs() <= 1e-12);
            if !shared {
                out.push(Constant {
                    figure: case.figure,
                    listing: names[1].to_string(),
                    name,
                    printed,
                    exact,
                });
            }
        }
    }
    out
}
