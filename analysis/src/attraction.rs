//! Domains of attraction of an asymptotically stable equilibrium of a planar vector field,
//! estimated by sublevel sets of Lyapunov functions (the domain-of-attraction survey of NASA TM
//! X-53478, *Progress Report No. 8*, Marshall Space Flight Center, 1966: "optimal" quadratic
//! forms, and LaSalle's theorem on the extent of asymptotic stability).
//!
//! For V positive definite about the equilibrium xₑ, every bounded component Ω_ℓ of {V < ℓ}
//! around xₑ on which V̇ = ∇V·f ≤ 0 is positively invariant, and if the largest invariant set in
//! {V̇ = 0} ∩ Ω_ℓ is {xₑ}, every solution starting in Ω_ℓ tends to xₑ (LaSalle). The paper takes
//! V = yᵀPy (y = x − xₑ), so Ω_ℓ is an ellipse of area πℓ/√det P, and
//!
//! * ℓ*(P) = inf { V(x) : V̇(x) > 0 }, the largest level whose ellipse has V̇ ≤ 0 — the paper's
//!   (14) min { V : V̇ = 0, x ≠ 0 } when V̇ is negative definite near xₑ, and still meaningful
//!   at its optimum, where V̇ is only semidefinite;
//! * P is chosen to maximise the area. As in the paper, P solves AᵀP + PA = −Q for the
//!   linearisation A and a Q ⪰ 0, normalised by trace Q = 1: Q ranges over a disc (its boundary
//!   is the semidefinite Q), and every P with V̇ ≤ 0 near xₑ arises so.
//!
//! V̇ is formed symbolically on the model's lowered DAG: V̇ = 2yᵀP f(x) with the entries of P
//! as symbols, so V̇ is linear in them and its three coefficients ∂V̇/∂Pₖ are symbolic
//! derivatives too (the optimiser combines them without re-evaluating the DAG). Any other
//! scalar function of the state (the model's `let energy = …`) can be analysed the same way.
//!
//! ℓ* is found along 360 rays from xₑ: the first radius where V̇ exceeds rounding (sampled on
//! 300 radii, then bisected on the exact V̇), V there, minimised over the rays and refined by a
//! golden-section search in the angle. For a non-quadratic V each ray also stops where V stops
//! increasing, so the estimate is the star-shaped component of {V < ℓ} around xₑ. **What is
//! rigorous and what is not:** the construction is the paper's theorem; the numbers are
//! sampled — a region of V̇ > 0 thinner than the sampling (0.5° in angle, 1/300 of the search
//! radius) could be missed, and "V̇ ≤ 0" means "not above 64 ulps of the size of V̇'s terms".
//! [`Estimate::check`] re-samples the estimate densely and verifies LaSalle's condition on the
//! sampled zeros of V̇: the flow leaves {V̇ = 0} (some of V̈, V⃛ is non-zero there).

use std::collections::HashMap;
use std::f64::consts::PI;
use std::fmt;

use lasalle_exec::LoadedModel;
use lasalle_model::ir::diff;
use lasalle_model::ir::{Graph, Id, Input, Rational, Scalar};
use lasalle_model::Model;
use lasalle_runtime::{Control, DormandPrince, DormandPrinceOptions, Driver, Field};
use nalgebra::{Matrix3, Vector3};

/// A 2×2 matrix, row-major.
pub type Mat2 = [[f64; 2]; 2];

/// The entries P₁₁, P₁₂, P₂₂ of V = yᵀPy are these symbols in the DAG.
const P_SYMBOLS: [Input; 3] = [Input::Symbol(0), Input::Symbol(1), Input::Symbol(2)];

/// A sample counts as V̇ > 0 when V̇ exceeds this many ulps of the size of its terms.
const ROUNDING_ULPS: f64 = 64.0;

/// Why the analysis cannot run.
#[derive(Clone, Debug, PartialEq)]
pub enum AttractionError {
    /// The state is not two-dimensional.
    NotPlanar {
        /// Model name.
        model: String,
        /// Its state dimension.
        dim: usize,
    },
    /// The given point is not an equilibrium.
    NotEquilibrium {
        /// The point.
        x: Vec<f64>,
        /// |f(x)|.
        residual: f64,
    },
    /// The linearisation is not Hurwitz: no quadratic V has V̇ ≤ 0 near the point.
    NotAttracting {
        /// The point.
        x: [f64; 2],
        /// Eigenvalues of the Jacobian, (re, im).
        eigenvalues: [(f64, f64); 2],
    },
    /// No `let` of this name, or not a scalar.
    NoFunction {
        /// The name asked for.
        name: String,
        /// The model's scalar `let`s.
        known: Vec<String>,
    },
    /// V̇ ≤ 0 everywhere within the largest search radius tried.
    Unbounded {
        /// The radius.
        radius: f64,
    },
    /// An invalid option.
    BadOption(String),
}

impl fmt::Display for AttractionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AttractionError::NotPlanar { model, dim } => write!(
                f,
                "`stability` analyses Lie–Poisson models (structure lie_poisson_so3) and the domain of \
                 attraction of planar fields without Hamiltonian structure; `{model}` has {dim} state components"
            ),
            AttractionError::NotEquilibrium { x, residual } => {
                write!(f, "{x:?} is not an equilibrium: |f(x)| = {residual:.3e}")
            }
            AttractionError::NotAttracting { x, eigenvalues } => {
                let e: Vec<String> = eigenvalues
                    .iter()
                    .map(|(re, im)| format!("{re:.6}{im:+.6}i"))
                    .collect();
                write!(
                    f,
                    "the equilibrium ({}, {}) is not asymptotically stable by linearisation (eigenvalues {}): \
                     no quadratic Lyapunov function decreases near it",
                    x[0],
                    x[1],
                    e.join(", ")
                )
            }
            AttractionError::NoFunction { name, known } => write!(
                f,
                "the model has no scalar `let {name}` to use as a Lyapunov function (scalar lets: {})",
                if known.is_empty() {
                    "none".to_string()
                } else {
                    known.join(", ")
                }
            ),
            AttractionError::Unbounded { radius } => write!(
                f,
                "V̇ ≤ 0 everywhere within radius {radius:e} of the equilibrium: no bound found \
                 (the equilibrium may attract everything)"
            ),
            AttractionError::BadOption(why) => write!(f, "{why}"),
        }
    }
}

impl std::error::Error for AttractionError {}

/// Sampling of the analysis.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Rays from the equilibrium. Default: 360.
    pub rays: usize,
    /// Samples along each ray, up to the search radius. Default: 300.
    pub radii: usize,
    /// The search radius; `None` chooses it (see [`PlanarSystem::analyse`]).
    pub radius: Option<f64>,
    /// Nelder–Mead iterations of the optimiser. Default: 400.
    pub iterations: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            rays: 360,
            radii: 300,
            radius: None,
            iterations: 400,
        }
    }
}

/// A search radius must be a positive number.
fn check_radius(r: f64) -> Result<(), AttractionError> {
    if r.is_finite() && r > 0.0 {
        Ok(())
    } else {
        Err(AttractionError::BadOption(format!(
            "the search radius must be a positive number, got {r}"
        )))
    }
}

impl Options {
    fn validate(&self) -> Result<(), AttractionError> {
        if self.rays < 8 || self.radii < 8 {
            return Err(AttractionError::BadOption(format!(
                "need at least 8 rays and 8 radii, got {} and {}",
                self.rays, self.radii
            )));
        }
        self.radius.map_or(Ok(()), check_radius)
    }
}

/// A value with the size of the terms whose cancellation produced it (as
/// [`Graph::eval_with_scale`], for several outputs at once).
#[derive(Clone, Copy, Debug)]
struct Scaled {
    v: f64,
    m: f64,
}

impl Scalar for Scaled {
    fn from_f64(c: f64) -> Self {
        Scaled { v: c, m: c.abs() }
    }
    fn add(&self, o: &Self) -> Self {
        Scaled {
            v: self.v + o.v,
            m: self.m + o.m,
        }
    }
    fn mul(&self, o: &Self) -> Self {
        Scaled {
            v: self.v * o.v,
            m: self.m * o.m,
        }
    }
    fn recip(&self) -> Self {
        self.powi(-1)
    }
    fn powi(&self, n: i32) -> Self {
        let v = self.v.powi(n);
        Scaled {
            v,
            m: v.abs() * (f64::from(n).abs() * self.m / self.v.abs()).max(1.0),
        }
    }
    fn powf(&self, p: Rational) -> Self {
        let v = self.v.powf(p.to_f64());
        Scaled {
            v,
            m: v.abs() * (p.to_f64().abs() * self.m / self.v.abs()).max(1.0),
        }
    }
    fn exp(&self) -> Self {
        let v = self.v.exp();
        Scaled {
            v,
            m: v * self.m.max(1.0),
        }
    }
    fn ln(&self) -> Self {
        let v = self.v.ln();
        Scaled {
            v,
            m: v.abs().max(self.m / self.v.abs()),
        }
    }
    fn sin(&self) -> Self {
        let v = self.v.sin();
        Scaled {
            v,
            m: v.abs().max(self.m),
        }
    }
    fn cos(&self) -> Self {
        let v = self.v.cos();
        Scaled {
            v,
            m: v.abs().max(self.m),
        }
    }
}

impl Scaled {
    /// Above rounding: clearly positive.
    fn positive(self) -> bool {
        self.v > ROUNDING_ULPS * f64::EPSILON * self.m
    }
    /// Zero up to a relative `rel` of its terms.
    fn negligible(self, rel: f64) -> bool {
        self.v.abs() <= rel * self.m
    }
}

/// A Lyapunov function candidate on the DAG: V, V̇ = ∇V·f, V̈ and V⃛ (Lie derivatives along f).
#[derive(Clone, Copy, Debug)]
struct Candidate {
    v: Id,
    vdot: Id,
    lie: [Id; 2],
}

/// Which condition ends the estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Limit {
    /// V̇ becomes positive at the contact point.
    VdotPositive,
    /// V stops increasing along a ray (a non-quadratic V: the sublevel set would not be
    /// bounded beyond this level, e.g. the energy at a saddle).
    NotIncreasing,
    /// Neither within the search radius: the estimate is cut at it (still valid, conservative).
    SearchRadius,
}

/// The dense re-check of an estimate.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Check {
    /// Points sampled inside the estimate.
    pub samples: usize,
    /// Of these, points where V̇ > 0 beyond rounding (must be 0).
    pub positive: usize,
    /// Points where V̇ = 0 (to 10⁻⁹ of its terms): where LaSalle's principle is needed.
    pub zeros: usize,
    /// Zeros where neither V̈ nor V⃛ is non-zero: the flow might stay in {V̇ = 0} (must be 0).
    pub stuck: usize,
    /// max V̇ / (size of its terms) over the samples (≤ 0 up to rounding).
    pub max_relative_vdot: f64,
    /// min |V̇| / (size of its terms) on the boundary {V = ℓ*}: ≈ 0 where it touches V̇ = 0.
    pub boundary_min_relative_vdot: f64,
}

impl Check {
    /// The estimate is certified on the samples: V̇ ≤ 0 everywhere sampled, and the flow leaves
    /// every sampled zero of V̇.
    pub fn holds(&self) -> bool {
        self.positive == 0 && self.stuck == 0
    }
    /// Which theorem the samples support.
    pub fn theorem(&self) -> &'static str {
        match (self.holds(), self.zeros) {
            (false, _) => "not certified",
            (true, 0) => "V̇ < 0 on the estimate (Lyapunov)",
            (true, _) => "V̇ ≤ 0, the flow leaves {V̇ = 0} (LaSalle's invariance principle)",
        }
    }
}

/// An estimate {V < ℓ*} of the domain of attraction.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Estimate {
    /// ℓ*.
    pub level: f64,
    /// Its area (πℓ*/√det P for a quadratic V; by polar quadrature otherwise).
    pub area: f64,
    /// What bounds it.
    pub limit: Limit,
    /// Where it touches the limiting set (the first point of V̇ > 0 on the best ray, or V's
    /// maximum along it).
    pub contact: [f64; 2],
    /// The dense re-check.
    pub check: Check,
}

/// A quadratic estimate: V = yᵀPy with AᵀP + PA = −Q.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct QuadraticEstimate {
    /// P (trace Q = 1).
    pub p: Mat2,
    /// Q = −(AᵀP + PA).
    pub q: Mat2,
    /// The estimate {yᵀPy < ℓ*}.
    pub estimate: Estimate,
}

/// A saddle and the two branches of its stable manifold (integrated backwards).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Saddle {
    /// The saddle.
    pub x: [f64; 2],
    /// Its stable and unstable eigenvalues.
    pub eigenvalues: [f64; 2],
    /// The two branches, from the saddle outwards, as polylines in the search disc.
    pub stable_manifold: [Vec<[f64; 2]>; 2],
}

/// The whole analysis.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Analysis {
    /// The equilibrium.
    pub equilibrium: [f64; 2],
    /// The Jacobian A of the field there.
    pub jacobian: Mat2,
    /// Its eigenvalues (re, im).
    pub eigenvalues: [(f64, f64); 2],
    /// The search radius used.
    pub radius: f64,
    /// The area-optimal quadratic estimate.
    pub optimal: QuadraticEstimate,
    /// The quadratic estimate with Q = I (the textbook choice).
    pub lyapunov_equation: QuadraticEstimate,
    /// Objective evaluations of the optimiser.
    pub evaluations: usize,
}

/// A planar model's field at an equilibrium, with the symbolic V̇ of V = yᵀPy.
#[derive(Clone)]
pub struct PlanarSystem {
    name: String,
    graph: Graph,
    params: Vec<f64>,
    xe: [f64; 2],
    field: [Id; 2],
    jac: [[Id; 2]; 2],
    quadratic: Candidate,
    /// ∂V̇/∂(P₁₁, P₁₂, P₂₂) for the quadratic V.
    coefficients: [Id; 3],
    /// The model's scalar `let`s, by name.
    lets: Vec<(String, Id)>,
}

impl fmt::Debug for PlanarSystem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PlanarSystem")
            .field("name", &self.name)
            .field("xe", &self.xe)
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

/// Σᵢ ∂root/∂xᵢ · fᵢ.
fn lie(graph: &mut Graph, root: Id, field: [Id; 2]) -> Id {
    let terms: Vec<Id> = (0..2)
        .map(|i| {
            let d = diff(graph, root, Input::State(i as u32), &mut HashMap::new());
            graph.mul(&[d, field[i]])
        })
        .collect();
    graph.add(&terms)
}

fn candidate(graph: &mut Graph, v: Id, field: [Id; 2]) -> Candidate {
    let vdot = lie(graph, v, field);
    let l1 = lie(graph, vdot, field);
    let l2 = lie(graph, l1, field);
    Candidate {
        v,
        vdot,
        lie: [l1, l2],
    }
}

/// The symmetric P with AᵀP + PA = −Q (A Hurwitz).
pub fn lyapunov_equation(a: Mat2, q: Mat2) -> Mat2 {
    let m = Matrix3::new(
        2.0 * a[0][0],
        2.0 * a[1][0],
        0.0,
        a[0][1],
        a[0][0] + a[1][1],
        a[1][0],
        0.0,
        2.0 * a[0][1],
        2.0 * a[1][1],
    );
    let rhs = Vector3::new(-q[0][0], -q[0][1], -q[1][1]);
    let p = m
        .lu()
        .solve(&rhs)
        .unwrap_or_else(|| Vector3::repeat(f64::NAN));
    [[p[0], p[1]], [p[1], p[2]]]
}

/// Eigenvalues (re, im) of a 2×2 matrix.
pub fn eigenvalues(a: Mat2) -> [(f64, f64); 2] {
    let (tr, det) = (a[0][0] + a[1][1], a[0][0] * a[1][1] - a[0][1] * a[1][0]);
    let disc = tr * tr / 4.0 - det;
    if disc >= 0.0 {
        let s = disc.sqrt();
        [(tr / 2.0 - s, 0.0), (tr / 2.0 + s, 0.0)]
    } else {
        let s = (-disc).sqrt();
        [(tr / 2.0, -s), (tr / 2.0, s)]
    }
}

fn det(p: Mat2) -> f64 {
    p[0][0] * p[1][1] - p[0][1] * p[1][0]
}

fn quad(p: Mat2, y: [f64; 2]) -> f64 {
    p[0][0] * y[0] * y[0] + 2.0 * p[0][1] * y[0] * y[1] + p[1][1] * y[1] * y[1]
}

/// Q = [[(1 + a)/2, b/2], [b/2, (1 − a)/2]] for (a, b) in the unit disc (projected onto it
/// from outside): every Q ⪰ 0 of trace 1.
fn q_of(ab: [f64; 2]) -> Mat2 {
    let r = ab[0].hypot(ab[1]);
    let (a, b) = if r > 1.0 {
        (ab[0] / r, ab[1] / r)
    } else {
        (ab[0], ab[1])
    };
    [[(1.0 + a) / 2.0, b / 2.0], [b / 2.0, (1.0 - a) / 2.0]]
}

/// A Lyapunov function to analyse.
#[derive(Clone, Copy, Debug)]
pub enum LyapunovFunction<'a> {
    /// V = yᵀPy, y = x − xₑ.
    Quadratic(Mat2),
    /// The model's scalar `let` of this name (e.g. `energy`): its star-shaped sublevel
    /// component around the equilibrium (V must vanish there and increase along rays near it).
    Let(&'a str),
}

/// The samples of V̇'s coefficients along the rays, for the optimiser.
struct RayTable {
    dirs: Vec<[f64; 2]>,
    radii: Vec<f64>,
    /// Per ray and radius: ∂V̇/∂Pₖ and the sizes of their terms.
    coef: Vec<[Scaled; 3]>,
}

impl RayTable {
    /// The coarse ℓ*(P) (V̇ interpolated linearly between samples) and its area.
    fn area(&self, p: Mat2) -> f64 {
        let d = det(p);
        if !(d > 0.0 && p[0][0] > 0.0) {
            return 0.0;
        }
        let pk = [p[0][0], p[0][1], p[1][1]];
        let nr = self.radii.len();
        let mut level = f64::INFINITY;
        for (j, &u) in self.dirs.iter().enumerate() {
            let vu = quad(p, u);
            let mut prev = (0.0, 0.0);
            let mut hit = self.radii[nr - 1];
            for (i, &r) in self.radii.iter().enumerate() {
                let c = &self.coef[j * nr + i];
                let vd: f64 = (0..3).map(|k| pk[k] * c[k].v).sum();
                let size: f64 = (0..3).map(|k| pk[k].abs() * c[k].m).sum();
                if vd > ROUNDING_ULPS * f64::EPSILON * size {
                    let (r0, v0) = prev;
                    hit = if v0 < 0.0 {
                        r0 + (r - r0) * (-v0) / (vd - v0)
                    } else {
                        r0
                    };
                    break;
                }
                prev = (r, vd);
            }
            level = level.min(hit * hit * vu);
        }
        PI * level / d.sqrt()
    }
}

/// Nelder–Mead maximisation of `f` over R², from `x0` with initial steps `step`.
fn nelder_mead(
    f: &mut impl FnMut([f64; 2]) -> f64,
    x0: [f64; 2],
    step: f64,
    iterations: usize,
) -> ([f64; 2], f64) {
    let mut s: Vec<([f64; 2], f64)> = [x0, [x0[0] + step, x0[1]], [x0[0], x0[1] + step]]
        .into_iter()
        .map(|x| (x, -f(x)))
        .collect();
    let lerp =
        |a: [f64; 2], b: [f64; 2], t: f64| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
    for _ in 0..iterations {
        s.sort_by(|a, b| a.1.total_cmp(&b.1));
        let size = (1..3)
            .map(|k| (s[k].0[0] - s[0].0[0]).hypot(s[k].0[1] - s[0].0[1]))
            .fold(0.0, f64::max);
        if size < 1e-10 {
            break;
        }
        let centroid = lerp(s[0].0, s[1].0, 0.5);
        let worst = s[2];
        let xr = lerp(centroid, worst.0, -1.0);
        let fr = -f(xr);
        if fr < s[0].1 {
            let xe = lerp(centroid, worst.0, -2.0);
            let fe = -f(xe);
            s[2] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < s[1].1 {
            s[2] = (xr, fr);
        } else {
            let xc = lerp(centroid, worst.0, 0.5);
            let fc = -f(xc);
            if fc < worst.1 {
                s[2] = (xc, fc);
            } else {
                let best = s[0].0;
                for vertex in s.iter_mut().skip(1) {
                    let x = lerp(best, vertex.0, 0.5);
                    *vertex = (x, -f(x));
                }
            }
        }
    }
    s.sort_by(|a, b| a.1.total_cmp(&b.1));
    (s[0].0, -s[0].1)
}

/// Golden-section minimisation of `f` on [a, b].
fn golden(mut f: impl FnMut(f64) -> f64, mut a: f64, mut b: f64, iterations: usize) -> (f64, f64) {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..iterations {
        if fc < fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    if fc < fd {
        (c, fc)
    } else {
        (d, fd)
    }
}

/// One ray's result: the level, where it is reached, and why.
#[derive(Clone, Copy, Debug)]
struct RayLevel {
    level: f64,
    at: [f64; 2],
    limit: Limit,
}

impl PlanarSystem {
    /// Prepares `model` (parameter slots `params`) at the equilibrium `xe`.
    pub fn new(model: &Model, params: &[f64], xe: &[f64]) -> Result<PlanarSystem, AttractionError> {
        if model.dim() != 2 || xe.len() != 2 {
            return Err(AttractionError::NotPlanar {
                model: model.name.clone(),
                dim: model.dim(),
            });
        }
        let mut graph = model.graph.clone();
        let field = [model.field[0], model.field[1]];
        let mut jac = [[field[0]; 2]; 2];
        for (i, row) in jac.iter_mut().enumerate() {
            for (j, entry) in row.iter_mut().enumerate() {
                *entry = diff(
                    &mut graph,
                    field[i],
                    Input::State(j as u32),
                    &mut HashMap::new(),
                );
            }
        }
        // V = yᵀPy, V̇ = 2yᵀP f(x), y = x − xₑ, with P as symbols
        let y: Vec<Id> = (0..2)
            .map(|i| {
                let (x, c) = (graph.input(Input::State(i as u32)), graph.num(-xe[i]));
                graph.add(&[x, c])
            })
            .collect();
        let [p11, p12, p22] = P_SYMBOLS.map(|s| graph.input(s));
        let two = graph.num(2.0);
        let v_terms = [
            graph.mul(&[p11, y[0], y[0]]),
            graph.mul(&[two, p12, y[0], y[1]]),
            graph.mul(&[p22, y[1], y[1]]),
        ];
        let v = graph.add(&v_terms);
        let quadratic = candidate(&mut graph, v, field);
        let coefficients =
            P_SYMBOLS.map(|s| diff(&mut graph, quadratic.vdot, s, &mut HashMap::new()));
        let lets = model
            .lets
            .iter()
            .filter(|b| b.value.ids.len() == 1)
            .map(|b| (b.name.clone(), b.value.ids[0]))
            .collect();
        let sys = PlanarSystem {
            name: model.name.clone(),
            graph,
            params: params.to_vec(),
            xe: [xe[0], xe[1]],
            field,
            jac,
            quadratic,
            coefficients,
            lets,
        };
        let f = sys.field(sys.xe);
        let residual = f[0].hypot(f[1]);
        let size = sys.xe[0].hypot(sys.xe[1]).max(1.0);
        if residual.is_nan() || residual > 1e-10 * size {
            return Err(AttractionError::NotEquilibrium {
                x: xe.to_vec(),
                residual,
            });
        }
        Ok(sys)
    }

    /// The model's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The equilibrium.
    pub fn equilibrium(&self) -> [f64; 2] {
        self.xe
    }

    /// The names of the model's scalar `let`s (candidates for [`LyapunovFunction::Let`]).
    pub fn scalar_lets(&self) -> Vec<String> {
        self.lets.iter().map(|(n, _)| n.clone()).collect()
    }

    fn eval<S: Scalar>(&self, roots: &[Id], x: [f64; 2], p: Mat2, lift: fn(f64) -> S) -> Vec<S> {
        let pk = [p[0][0], p[0][1], p[1][1]];
        self.graph.eval(roots, &mut |i| {
            lift(match i {
                Input::State(k) if k < 2 => x[k as usize],
                Input::Param(k) => self.params.get(k as usize).copied().unwrap_or(f64::NAN),
                Input::Symbol(k) if k < 3 => pk[k as usize],
                _ => f64::NAN,
            })
        })
    }

    /// f(x).
    pub fn field(&self, x: [f64; 2]) -> [f64; 2] {
        let v = self.eval(&self.field, x, [[0.0; 2]; 2], |c| c);
        [v[0], v[1]]
    }

    /// The Jacobian of f at x (symbolic derivatives of the model's field).
    pub fn jacobian(&self, x: [f64; 2]) -> Mat2 {
        let ids = [
            self.jac[0][0],
            self.jac[0][1],
            self.jac[1][0],
            self.jac[1][1],
        ];
        let v = self.eval(&ids, x, [[0.0; 2]; 2], |c| c);
        [[v[0], v[1]], [v[2], v[3]]]
    }

    /// V̇(x) for V = yᵀPy, from the symbolic V̇.
    pub fn vdot(&self, p: Mat2, x: [f64; 2]) -> f64 {
        self.eval(&[self.quadratic.vdot], x, p, |c| c)[0]
    }

    fn point(&self, u: [f64; 2], r: f64) -> [f64; 2] {
        [self.xe[0] + r * u[0], self.xe[1] + r * u[1]]
    }

    /// Along the ray xₑ + r·u, r ∈ (0, radius]: where V̇ first exceeds rounding (bisected), or
    /// where V first stops increasing (its maximum, by golden section).
    fn ray_level(&self, c: &Candidate, p: Mat2, u: [f64; 2], radius: f64, n: usize) -> RayLevel {
        let at = |r: f64| self.eval(&[c.v, c.vdot], self.point(u, r), p, Scaled::from_f64);
        let positive = |r: f64| at(r)[1].positive();
        let v_at = |r: f64| at(r)[0].v;
        let mut prev = (0.0, f64::NEG_INFINITY);
        let mut before = 0.0;
        for i in 1..=n {
            let r = radius * i as f64 / n as f64;
            let s = at(r);
            if s[1].positive() {
                let (mut lo, mut hi) = (prev.0, r);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if positive(mid) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return RayLevel {
                    level: v_at(hi),
                    at: self.point(u, hi),
                    limit: Limit::VdotPositive,
                };
            }
            if s[0].v <= prev.1 {
                let (rm, neg) = golden(|r| -v_at(r), before, r, 80);
                return RayLevel {
                    level: -neg,
                    at: self.point(u, rm),
                    limit: Limit::NotIncreasing,
                };
            }
            before = prev.0;
            prev = (r, s[0].v);
        }
        RayLevel {
            level: prev.1,
            at: self.point(u, radius),
            limit: Limit::SearchRadius,
        }
    }

    fn dirs(n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|j| {
                let t = 2.0 * PI * j as f64 / n as f64;
                [t.cos(), t.sin()]
            })
            .collect()
    }

    /// ℓ* of a candidate: the minimum over the rays, refined in the angle.
    fn level(&self, c: &Candidate, p: Mat2, radius: f64, opts: &Options) -> RayLevel {
        let n = opts.rays;
        let per_ray: Vec<RayLevel> = Self::dirs(n)
            .into_iter()
            .map(|u| self.ray_level(c, p, u, radius, opts.radii))
            .collect();
        let (j, best) = per_ray
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.level.total_cmp(&b.1.level))
            .map(|(j, r)| (j, *r))
            .expect("at least 8 rays");
        let step = 2.0 * PI / n as f64;
        let t0 = step * j as f64;
        let mut refined = best;
        golden(
            |t| {
                let r = self.ray_level(c, p, [t.cos(), t.sin()], radius, opts.radii);
                if r.level < refined.level {
                    refined = r;
                }
                r.level
            },
            t0 - step,
            t0 + step,
            40,
        );
        refined
    }

    /// The boundary radius of the star-shaped component of {V < ℓ} along u: where V first
    /// reaches ℓ, or where it first stops increasing at a maximum that touches ℓ (to 10⁻⁹
    /// relative). The second case is the level set through a saddle, where ℓ is V's maximum
    /// along the ray: sampling alone never sees V ≥ ℓ there and would run to the search radius.
    fn boundary_radius(&self, c: &Candidate, p: Mat2, u: [f64; 2], level: f64, radius: f64) -> f64 {
        let v = |r: f64| self.eval(&[c.v], self.point(u, r), p, |x| x)[0];
        let crossing = |mut lo: f64, mut hi: f64| {
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if v(mid) >= level {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let touches = level - 1e-9 * level.abs();
        let n = 400;
        let (mut before, mut lo, mut v_lo) = (0.0, 0.0, f64::NEG_INFINITY);
        for i in 1..=n {
            let r = radius * i as f64 / n as f64;
            let v_r = v(r);
            if v_r >= level {
                return crossing(lo, r);
            }
            if v_r <= v_lo {
                // V had a maximum in (before, r)
                let (r_max, neg) = golden(|r| -v(r), before, r, 80);
                if -neg >= level {
                    return crossing(before, r_max);
                }
                if -neg >= touches {
                    return r_max;
                }
            }
            (before, lo, v_lo) = (lo, r, v_r);
        }
        radius
    }

    /// Re-samples {V < ℓ}: 2·rays directions × 80 radii inside, and the boundary.
    fn check(
        &self,
        c: &Candidate,
        p: Mat2,
        level: f64,
        radius: f64,
        opts: &Options,
    ) -> (Check, f64) {
        let dirs = Self::dirs(2 * opts.rays);
        let mut check = Check {
            samples: 0,
            positive: 0,
            zeros: 0,
            stuck: 0,
            max_relative_vdot: f64::NEG_INFINITY,
            boundary_min_relative_vdot: f64::INFINITY,
        };
        let mut area = 0.0;
        for &u in &dirs {
            let rho = self.boundary_radius(c, p, u, level, radius);
            area += 0.5 * rho * rho * 2.0 * PI / dirs.len() as f64;
            let samples = 80;
            for k in 1..=samples {
                let r = rho * k as f64 / samples as f64;
                let x = self.point(u, r);
                let s = self.eval(&[c.vdot, c.lie[0], c.lie[1]], x, p, Scaled::from_f64);
                let rel = s[0].v / s[0].m.max(f64::MIN_POSITIVE);
                if k == samples {
                    check.boundary_min_relative_vdot =
                        check.boundary_min_relative_vdot.min(rel.abs());
                    continue;
                }
                check.samples += 1;
                check.max_relative_vdot = check.max_relative_vdot.max(rel);
                if s[0].positive() {
                    check.positive += 1;
                } else if s[0].negligible(1e-9) {
                    check.zeros += 1;
                    if s[1].negligible(1e-9) && s[2].negligible(1e-9) {
                        check.stuck += 1;
                    }
                }
            }
        }
        (check, area)
    }

    /// The candidate's nodes (in an extended copy of the system for a `let`) and P.
    fn prepare(
        &self,
        function: LyapunovFunction,
    ) -> Result<(Option<PlanarSystem>, Candidate, Mat2), AttractionError> {
        Ok(match function {
            LyapunovFunction::Quadratic(p) => (None, self.quadratic, p),
            LyapunovFunction::Let(name) => {
                let v = self
                    .lets
                    .iter()
                    .find(|(n, _)| n == name)
                    .map(|&(_, id)| id)
                    .ok_or_else(|| AttractionError::NoFunction {
                        name: name.to_string(),
                        known: self.scalar_lets(),
                    })?;
                let mut ext = self.clone();
                let c = candidate(&mut ext.graph, v, self.field);
                (Some(ext), c, [[0.0; 2]; 2])
            }
        })
    }

    /// The estimate {V < ℓ*} (its star-shaped component around xₑ), searched within `radius`.
    pub fn estimate(
        &self,
        function: LyapunovFunction,
        radius: f64,
        opts: &Options,
    ) -> Result<Estimate, AttractionError> {
        opts.validate()?;
        check_radius(radius)?;
        let (sys, c, p) = self.prepare(function)?;
        let s = sys.as_ref().unwrap_or(self);
        let best = s.level(&c, p, radius, opts);
        let (check, polar_area) = s.check(&c, p, best.level, radius, opts);
        let area = match function {
            LyapunovFunction::Quadratic(pm) => PI * best.level / det(pm).sqrt(),
            LyapunovFunction::Let(_) => polar_area,
        };
        Ok(Estimate {
            level: best.level,
            area,
            limit: best.limit,
            contact: best.at,
            check,
        })
    }

    /// `n` points of the boundary of the component of {V < level} around xₑ (within `radius`).
    pub fn boundary(
        &self,
        function: LyapunovFunction,
        level: f64,
        radius: f64,
        n: usize,
    ) -> Result<Vec<[f64; 2]>, AttractionError> {
        check_radius(radius)?;
        let (sys, c, p) = self.prepare(function)?;
        let s = sys.as_ref().unwrap_or(self);
        Ok(Self::dirs(n)
            .into_iter()
            .map(|u| s.point(u, s.boundary_radius(&c, p, u, level, radius)))
            .collect())
    }

    fn ray_table(&self, radius: f64, opts: &Options) -> RayTable {
        let dirs = Self::dirs(opts.rays);
        let radii: Vec<f64> = (1..=opts.radii)
            .map(|i| radius * i as f64 / opts.radii as f64)
            .collect();
        let mut coef = Vec::with_capacity(dirs.len() * radii.len());
        for &u in &dirs {
            for &r in &radii {
                let s = self.eval(
                    &self.coefficients,
                    self.point(u, r),
                    [[0.0; 2]; 2],
                    Scaled::from_f64,
                );
                coef.push([s[0], s[1], s[2]]);
            }
        }
        RayTable { dirs, radii, coef }
    }

    /// The search radius: given, or doubled from 1 (times the size of xₑ) until the Q = I
    /// estimate is bounded by V̇ > 0 inside the disc, then 4× that estimate's largest extent.
    fn search_radius(&self, a: Mat2, opts: &Options) -> Result<f64, AttractionError> {
        if let Some(r) = opts.radius {
            return Ok(r);
        }
        let p = lyapunov_equation(a, [[1.0, 0.0], [0.0, 1.0]]);
        let coarse = Options {
            rays: 72,
            radii: 100,
            ..*opts
        };
        let mut r = self.xe[0].hypot(self.xe[1]).max(1.0);
        for _ in 0..40 {
            let table = self.ray_table(r, &coarse);
            let level = table.area(p) * det(p).sqrt() / PI;
            let lambda_min = {
                let (tr, d) = (p[0][0] + p[1][1], det(p));
                tr / 2.0 - (tr * tr / 4.0 - d).max(0.0).sqrt()
            };
            let extent = (level / lambda_min).sqrt();
            if extent < 0.9 * r {
                return Ok(4.0 * extent);
            }
            r *= 2.0;
        }
        Err(AttractionError::Unbounded { radius: r })
    }

    /// The linearisation, checked Hurwitz.
    pub fn linearisation(&self) -> Result<(Mat2, [(f64, f64); 2]), AttractionError> {
        let a = self.jacobian(self.xe);
        let eig = eigenvalues(a);
        if !(eig[0].0 < 0.0 && eig[1].0 < 0.0) {
            return Err(AttractionError::NotAttracting {
                x: self.xe,
                eigenvalues: eig,
            });
        }
        Ok((a, eig))
    }

    /// The analysis: the linearisation A (Hurwitz, else an error), the search radius, the
    /// area-optimal P (Q over the disc of trace-1 Q ⪰ 0: a 12 × 24 polar scan, then
    /// Nelder–Mead on the coarse area), and the Q = I estimate for comparison.
    pub fn analyse(&self, opts: &Options) -> Result<Analysis, AttractionError> {
        opts.validate()?;
        let (a, eig) = self.linearisation()?;
        let radius = self.search_radius(a, opts)?;
        let table = self.ray_table(radius, opts);
        let mut evaluations = 0;
        let mut area = |ab: [f64; 2]| {
            evaluations += 1;
            table.area(lyapunov_equation(a, q_of(ab)))
        };
        let mut start = ([0.0, 0.0], area([0.0, 0.0]));
        for i in 1..=12 {
            let rho = 1.0 - (1.0 - i as f64 / 12.0).powi(2);
            for k in 0..24 {
                let phi = 2.0 * PI * k as f64 / 24.0;
                let ab = [rho * phi.cos(), rho * phi.sin()];
                let v = area(ab);
                if v > start.1 {
                    start = (ab, v);
                }
            }
        }
        let (ab, _) = nelder_mead(&mut area, start.0, 0.05, opts.iterations);
        let quadratic = |q: Mat2| -> Result<QuadraticEstimate, AttractionError> {
            let p = lyapunov_equation(a, q);
            Ok(QuadraticEstimate {
                p,
                q,
                estimate: self.estimate(LyapunovFunction::Quadratic(p), radius, opts)?,
            })
        };
        Ok(Analysis {
            equilibrium: self.xe,
            jacobian: a,
            eigenvalues: eig,
            radius,
            optimal: quadratic(q_of(ab))?,
            lyapunov_equation: quadratic([[0.5, 0.0], [0.0, 0.5]])?,
            evaluations,
        })
    }

    /// The equilibria within `radius` of xₑ (Newton from a 21 × 21 grid, symbolic Jacobian),
    /// with Jacobians of negative determinant: the saddles, with their stable and unstable
    /// eigenvalues and the stable eigenvector.
    pub fn saddles(&self, radius: f64) -> Vec<([f64; 2], [f64; 2], [f64; 2])> {
        let mut found: Vec<[f64; 2]> = Vec::new();
        for i in 0..21 {
            for k in 0..21 {
                let mut x = [
                    self.xe[0] + radius * (i as f64 / 10.0 - 1.0),
                    self.xe[1] + radius * (k as f64 / 10.0 - 1.0),
                ];
                for _ in 0..60 {
                    let (f, j) = (self.field(x), self.jacobian(x));
                    let d = det(j);
                    if d == 0.0 || !d.is_finite() {
                        break;
                    }
                    let dx = [
                        (j[1][1] * f[0] - j[0][1] * f[1]) / d,
                        (-j[1][0] * f[0] + j[0][0] * f[1]) / d,
                    ];
                    x = [x[0] - dx[0], x[1] - dx[1]];
                    if dx[0].hypot(dx[1]) < 1e-14 * (1.0 + x[0].hypot(x[1])) {
                        break;
                    }
                }
                let f = self.field(x);
                let inside = (x[0] - self.xe[0]).hypot(x[1] - self.xe[1]) <= radius;
                if inside
                    && f[0].hypot(f[1]) < 1e-10 * (1.0 + x[0].hypot(x[1]))
                    && !found
                        .iter()
                        .any(|y| (y[0] - x[0]).hypot(y[1] - x[1]) < 1e-6 * radius)
                {
                    found.push(x);
                }
            }
        }
        found
            .into_iter()
            .filter_map(|x| {
                let j = self.jacobian(x);
                if det(j) >= 0.0 {
                    return None;
                }
                let eig = eigenvalues(j);
                let (ls, lu) = (eig[0].0, eig[1].0);
                let v1 = [j[0][1], ls - j[0][0]];
                let v2 = [ls - j[1][1], j[1][0]];
                let v = if v1[0].hypot(v1[1]) >= v2[0].hypot(v2[1]) {
                    v1
                } else {
                    v2
                };
                let n = v[0].hypot(v[1]);
                Some((x, [ls, lu], [v[0] / n, v[1] / n]))
            })
            .collect()
    }
}

/// The field of a loaded model reversed in time.
struct Reversed<'a>(&'a LoadedModel);

impl Field<f64, Vec<f64>> for Reversed<'_> {
    fn field(&self, x: &Vec<f64>, dx: &mut Vec<f64>) {
        self.0.field(x, dx);
        for d in dx.iter_mut() {
            *d = -*d;
        }
    }
}

/// A trajectory of `model` from `x0` (DOPRI5, rtol 10⁻¹⁰, atol 10⁻¹², steps ≤ 0.05), forwards
/// or backwards in time, up to `t_end` or until it leaves the disc of radius `radius` about
/// `centre`; the states at the accepted steps.
pub fn trajectory(
    model: &LoadedModel,
    x0: [f64; 2],
    t_end: f64,
    backwards: bool,
    centre: [f64; 2],
    radius: f64,
) -> Result<Vec<[f64; 2]>, String> {
    let opts = DormandPrinceOptions {
        rtol: 1e-10,
        atol: 1e-12,
        h_max: 0.05,
        ..Default::default()
    };
    let mut path = Vec::new();
    let mut observer = |_: u64, _: f64, x: &Vec<f64>| {
        path.push([x[0], x[1]]);
        if (x[0] - centre[0]).hypot(x[1] - centre[1]) > radius {
            Control::Stop
        } else {
            Control::Continue
        }
    };
    let mut dp5 = DormandPrince::<f64, Vec<f64>>::new(opts);
    let driver = Driver::new(0.0, t_end, 0.0).max_steps(2_000_000);
    let x0 = x0.to_vec();
    let result = if backwards {
        driver.run(&mut dp5, &Reversed(model), &x0, &mut observer)
    } else {
        driver.run(&mut dp5, model, &x0, &mut observer)
    };
    result.map_err(|e| e.to_string())?;
    Ok(path)
}

/// The saddles within `radius` of the equilibrium with both branches of their stable
/// manifolds: from the saddle ± 10⁻⁶·radius along the stable eigenvector, integrated backwards
/// until they leave the disc (or t = 200).
pub fn saddles_with_manifolds(
    sys: &PlanarSystem,
    model: &LoadedModel,
    radius: f64,
) -> Result<Vec<Saddle>, String> {
    sys.saddles(radius)
        .into_iter()
        .map(|(x, eig, v)| {
            let branch = |s: f64| {
                let x0 = [
                    x[0] + s * 1e-6 * radius * v[0],
                    x[1] + s * 1e-6 * radius * v[1],
                ];
                let mut path = vec![x];
                path.extend(trajectory(model, x0, 200.0, true, sys.xe, radius)?);
                Ok::<_, String>(path)
            };
            Ok(Saddle {
                x,
                eigenvalues: eig,
                stable_manifold: [branch(1.0)?, branch(-1.0)?],
            })
        })
        .collect()
}

/// The distance from `centre` along the unit vector `u` to the nearest crossing of a branch
/// of the saddles' stable manifolds: where the true domain's boundary lies in that direction
/// (when the stable manifolds bound it, as for the Duffing equation).
pub fn manifold_distance(saddles: &[Saddle], centre: [f64; 2], u: [f64; 2]) -> Option<f64> {
    let cross = |a: [f64; 2], b: [f64; 2]| a[0] * b[1] - a[1] * b[0];
    let mut best: Option<f64> = None;
    for branch in saddles.iter().flat_map(|s| s.stable_manifold.iter()) {
        for w in branch.windows(2) {
            let (a, d) = (w[0], [w[1][0] - w[0][0], w[1][1] - w[0][1]]);
            let denom = cross(u, d);
            if denom == 0.0 {
                continue;
            }
            let ac = [a[0] - centre[0], a[1] - centre[1]];
            let (t, s) = (cross(ac, d) / denom, cross(ac, u) / denom);
            if t > 0.0 && (0.0..=1.0).contains(&s) && best.is_none_or(|b| t < b) {
                best = Some(t);
            }
        }
    }
    best
}
