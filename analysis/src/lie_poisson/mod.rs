//! Equilibria and their stability for Lie–Poisson models on so(3)* (Ṗ = P × ∇H, Casimir
//! C = ½|P|²): the energy–Casimir method, automated.
//!
//! On a Casimir level |P| = ρ (a symplectic leaf, the sphere of radius ρ) the equilibria are
//! the critical points of H restricted to the sphere: ∇H(P) + λP = 0 for a multiplier λ, which
//! is also the multiplier making H + λC critical (STEP 2 of the method, thesis §1.7, with the
//! Casimir K = λC). For each equilibrium:
//!
//! 1. the second variation δ²(H + λC) restricted to the tangent space of the sphere (2×2,
//!    from the symbolic Hessian of H) definite → **nonlinearly stable** (energy–Casimir; STEP 3;
//!    on a 2-dimensional leaf this is the Lagrange–Dirichlet theorem for H on the leaf);
//! 2. indefinite → the linearisation of the model's field (the symbolic Jacobian of its Ṗ) on
//!    the tangent plane has a real pair ±μ, μ = ρ √(−det δ²): **linearly unstable**;
//! 3. singular → **undecided** by second-order tests; a probe then says more: whether the
//!    equilibrium lies on a curve of equilibria (a *family*: the circle it traces, found by
//!    continuation) or, for an isolated one, whether H restricted to the sphere has a strict
//!    local extremum there (sampled on small geodesic circles: a numerical higher-order test).
//!
//! Equilibria on a level are found by Newton's method on (P, λ) from many starts on the sphere
//! (a Fibonacci lattice), deduplicated; nothing assumes H quadratic, so Hamiltonians with linear
//! terms (Types I, IIb) and any other Lie–Poisson so(3)* model work. [`sweep`] follows the
//! equilibria over a range of Casimir levels and reports, per branch, the ranges of ρ where each
//! verdict holds, with the boundaries located by bisection.

mod system;

pub use system::{LiePoissonSystem, Local};

use std::fmt;

use lasalle_exec::LoadedModel;
use lasalle_runtime::{Control, DormandPrince, DormandPrinceOptions, Driver, ModelInfo};
use nalgebra::{DMatrix, DVector, Vector3};

/// Why an analysis cannot run.
#[derive(Clone, Debug, PartialEq)]
pub enum StabilityError {
    /// The model declares no `hamiltonian … structure …`.
    NoStructure {
        /// Model name.
        model: String,
    },
    /// A canonical Hamiltonian model given to the Lie–Poisson analysis (its analysis is
    /// [`canonical::analyse`](crate::canonical::analyse)).
    Canonical {
        /// Model name.
        model: String,
    },
    /// Lie–Poisson, but not in a form this analysis handles.
    Unsupported {
        /// Model name.
        model: String,
        /// Why.
        why: String,
    },
    /// A Casimir level that is not a positive finite radius.
    BadLevel(f64),
    /// `--at` a point that is not an equilibrium.
    NotEquilibrium {
        /// The point.
        p: [f64; 3],
        /// |P × ∇H| there.
        residual: f64,
        /// The nearest equilibrium on the same Casimir level, if Newton found one.
        nearest: Option<[f64; 3]>,
    },
}

const SUPPORTED: &str = "`stability` analyses Lie–Poisson models (structure lie_poisson_so3)";

impl fmt::Display for StabilityError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StabilityError::NoStructure { model } => write!(
                f,
                "{SUPPORTED}; `{model}` has none (it declares no `hamiltonian H = …; structure …;`)"
            ),
            StabilityError::Canonical { model } => write!(
                f,
                "{SUPPORTED}; `{model}` is canonical (structure canonical(q, p)): its \
                 equilibria are analysed by `stability::canonical::analyse` (the normal-form \
                 verdicts and time bounds of `lasalle stability`)"
            ),
            StabilityError::Unsupported { model, why } => {
                write!(f, "{SUPPORTED}; `{model}` cannot be analysed: {why}")
            }
            StabilityError::BadLevel(r) => {
                write!(
                    f,
                    "the Casimir level |P| = {r} is not a positive finite number"
                )
            }
            StabilityError::NotEquilibrium {
                p,
                residual,
                nearest,
            } => {
                write!(
                    f,
                    "P = ({}, {}, {}) is not an equilibrium: |P × ∇H| = {residual:.3e}",
                    p[0], p[1], p[2]
                )?;
                if let Some(q) = nearest {
                    write!(
                        f,
                        "; the nearest equilibrium on the same Casimir level is ({:.10}, {:.10}, {:.10})",
                        q[0], q[1], q[2]
                    )?;
                }
                Ok(())
            }
        }
    }
}

impl std::error::Error for StabilityError {}

/// Which extremum of H on the leaf an energy–Casimir stable equilibrium is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Extremum {
    /// δ²(H + λC) positive definite on the tangent space.
    Min,
    /// δ²(H + λC) negative definite on the tangent space.
    Max,
}

/// What the probe of a degenerate equilibrium found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Probe {
    /// Isolated, and H on the sphere is strictly below H(Pₑ) on every sampled small circle: a
    /// strict local maximum, hence stable (Lagrange–Dirichlet on the leaf) — numerically.
    StrictMax,
    /// As `StrictMax`, a strict local minimum.
    StrictMin,
    /// Isolated, and H − H(Pₑ) takes both signs on every sampled small circle: not an extremum.
    /// On a 2-dimensional leaf an isolated equilibrium of an analytic Hamiltonian that is not
    /// an extremum is unstable.
    NotExtremum,
    /// On a curve of equilibria whose transverse second variation is definite: the curve is
    /// stable as a set (H is extremal across it), but nearby points drift along it, so single
    /// points are not Lyapunov stable unless the field vanishes nearby.
    FamilyStableAsSet,
    /// No conclusion.
    Inconclusive,
}

/// The verdict for one equilibrium.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "verdict")]
pub enum Verdict {
    /// Nonlinearly stable by the energy–Casimir method.
    Stable {
        /// H + λC has this kind of strict extremum on the leaf.
        extremum: Extremum,
    },
    /// The linearisation on the leaf has the eigenvalue `rate` > 0 (and −rate).
    LinearlyUnstable {
        /// The positive real eigenvalue.
        rate: f64,
    },
    /// The second variation is singular; the probe's finding.
    Undecided {
        /// What the higher-order probe says.
        probe: Probe,
    },
}

impl Verdict {
    /// Coarse class, for ranges in a sweep.
    pub fn class(&self) -> VerdictClass {
        match self {
            Verdict::Stable { .. } => VerdictClass::Stable,
            Verdict::LinearlyUnstable { .. } => VerdictClass::LinearlyUnstable,
            Verdict::Undecided { .. } => VerdictClass::Undecided,
        }
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Verdict::Stable { extremum } => write!(
                f,
                "nonlinearly stable (energy–Casimir, {} of H + λC)",
                match extremum {
                    Extremum::Min => "min",
                    Extremum::Max => "max",
                }
            ),
            Verdict::LinearlyUnstable { rate } => {
                write!(f, "linearly unstable (eigenvalue +{rate:.6})")
            }
            Verdict::Undecided { probe } => write!(
                f,
                "undecided (degenerate); {}",
                match probe {
                    Probe::StrictMax => "probe: strict max of H on the leaf → stable (numerical)",
                    Probe::StrictMin => "probe: strict min of H on the leaf → stable (numerical)",
                    Probe::NotExtremum =>
                        "probe: not an extremum of H on the leaf → unstable (numerical)",
                    Probe::FamilyStableAsSet =>
                        "on a family of equilibria: stable as a set, points drift along it",
                    Probe::Inconclusive => "probe inconclusive",
                }
            ),
        }
    }
}

/// Coarse verdict classes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum VerdictClass {
    /// Energy–Casimir stable.
    Stable,
    /// Linearly unstable.
    LinearlyUnstable,
    /// Degenerate second variation.
    Undecided,
}

impl fmt::Display for VerdictClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            VerdictClass::Stable => "nonlinearly stable",
            VerdictClass::LinearlyUnstable => "linearly unstable",
            VerdictClass::Undecided => "undecided",
        })
    }
}

/// A curve of equilibria on one Casimir level: the circle {n·P = d, |P| = ρ}.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Family {
    /// Unit normal n of the plane of the circle.
    pub normal: [f64; 3],
    /// Offset d of the plane.
    pub offset: f64,
    /// Points traced by continuation.
    pub members: usize,
    /// Whether the continuation came back to its start (a closed curve).
    pub closed: bool,
    /// Largest distance of a traced point from the fitted plane.
    pub fit_residual: f64,
}

/// The eigenvalues ±μ of the linearisation on the leaf: μ² = −ρ² det δ².
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "value")]
pub enum Spectrum {
    /// ±μ real (μ > 0).
    Real(f64),
    /// ±iω.
    Imaginary(f64),
    /// 0, 0 (to the tolerance).
    Zero,
}

impl fmt::Display for Spectrum {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Spectrum::Real(m) => write!(f, "±{m:.6}"),
            Spectrum::Imaginary(w) => write!(f, "±{w:.6}i"),
            Spectrum::Zero => write!(f, "0, 0"),
        }
    }
}

/// One equilibrium and its analysis.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Equilibrium {
    /// P.
    pub p: [f64; 3],
    /// The Casimir level ρ = |P|.
    pub rho: f64,
    /// The multiplier: ∇H + λ∇C = 0 with C = ½|P|² (for C = |P|² it is λ/2).
    pub lambda: f64,
    /// H(P).
    pub energy: f64,
    /// |P × ∇H| as the model's field computes it.
    pub residual: f64,
    /// Eigenvalues of δ²(H + λC) on the tangent space of the sphere, ascending.
    pub second_variation: [f64; 2],
    /// Eigenvalues of the model's linearised field on the tangent plane (from its Jacobian).
    pub spectrum: Spectrum,
    /// The verdict.
    pub verdict: Verdict,
    /// The family of equilibria through P, if it lies on one.
    pub family: Option<Family>,
}

/// The equilibria on one Casimir level.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Level {
    /// ρ.
    pub rho: f64,
    /// The field vanishes on the whole level (every point is an equilibrium, trivially
    /// stable); `equilibria` is then empty.
    pub all_equilibria: bool,
    /// Isolated equilibria, and one representative per family.
    pub equilibria: Vec<Equilibrium>,
}

/// Tuning of the search; the defaults are what the command uses.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Newton starts on the sphere.
    pub starts: usize,
    /// Relative tolerance under which an eigenvalue of δ² counts as zero (relative to the
    /// size of ∇²H and λ).
    pub degenerate: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            starts: 96,
            degenerate: 1e-7,
        }
    }
}

type V3 = Vector3<f64>;

/// An orthonormal basis (e₁, e₂) of the tangent plane P^⊥, with e₁ × e₂ = P/|P|.
fn tangent_basis(p: V3) -> (V3, V3) {
    let u = p * (1.0 / p.norm());
    let k = (0..3)
        .min_by(|&a, &b| u[a].abs().total_cmp(&u[b].abs()))
        .unwrap_or(0);
    let mut axis = V3::zeros();
    axis[k] = 1.0;
    let e1 = axis - u * axis.dot(&u);
    let e1 = e1 * (1.0 / e1.norm());
    (e1, u.cross(&e1))
}

/// n points spread evenly over the sphere of radius ρ (a Fibonacci lattice, slightly rotated
/// so no point sits on a coordinate axis or plane).
fn fibonacci(n: usize, rho: f64) -> Vec<V3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let t = golden * i as f64 + 0.1234;
            let q = [r * t.cos(), r * t.sin(), z];
            // a fixed generic rotation
            let (s, c) = 0.3779f64.sin_cos();
            let q = [q[0], c * q[1] - s * q[2], s * q[1] + c * q[2]];
            let (s, c) = 0.5171f64.sin_cos();
            let q = [c * q[0] + s * q[2], q[1], -s * q[0] + c * q[2]];
            V3::new(q[0], q[1], q[2]) * rho
        })
        .collect()
}

/// Eigenvalues of a symmetric 2×2 matrix, ascending.
fn sym2_eigen(a: f64, b: f64, c: f64) -> [f64; 2] {
    let m = 0.5 * (a + c);
    let r = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    [m - r, m + r]
}

// ---- Newton on (P, λ) ---------------------------------------------------------------------

/// Newton (Gauss–Newton with an SVD pseudo-inverse and backtracking) on
/// ∇H(P) + λP = 0, (|P|² − ρ²)/(2ρ) = 0 and, with `pin = Some((v, q))`, v·(P − q) = 0.
/// Returns P and λ when the residual falls below the tolerance.
fn newton(sys: &LiePoissonSystem, p0: V3, rho: f64, pin: Option<(V3, V3)>) -> Option<(V3, f64)> {
    let rows = if pin.is_some() { 5 } else { 4 };
    let residual = |p: V3, lambda: f64| -> (DVector<f64>, Local, f64) {
        let loc = sys.local(p);
        let mut r = DVector::zeros(rows);
        for i in 0..3 {
            r[i] = loc.grad[i] + lambda * p[i];
        }
        r[3] = (p.dot(&p) - rho * rho) / (2.0 * rho);
        if let Some((v, q)) = pin {
            r[4] = v.dot(&(p - q));
        }
        let size = loc.grad.norm().max(lambda.abs() * rho).max(1e-300);
        (r, loc, size)
    };
    let mut p = p0;
    let loc0 = sys.local(p);
    let mut lambda = -loc0.grad.dot(&p) / p.dot(&p);
    let (mut r, mut loc, mut size) = residual(p, lambda);
    let converged = |r: &DVector<f64>, size: f64| {
        r.iter().take(3).all(|x| x.abs() <= 1e-12 * size)
            && r.iter().skip(3).all(|x| x.abs() <= 1e-12 * rho)
    };
    // after convergence, keep iterating while the residual still falls (up to 80 more
    // steps): at a degenerate (multiple) root Newton converges only linearly, and the point is
    // determined to about the cube root of the rounding level there
    let mut extra = None;
    for _ in 0..300 {
        if !r.iter().all(|x| x.is_finite()) {
            return None;
        }
        if extra.is_none() && converged(&r, size) {
            extra = Some(0);
        }
        if let Some(k) = extra.as_mut() {
            *k += 1;
            if *k > 80 {
                return Some((p, lambda));
            }
        }
        let mut jm = DMatrix::zeros(rows, 4);
        for i in 0..3 {
            for j in 0..3 {
                jm[(i, j)] = loc.hess[(i, j)] + if i == j { lambda } else { 0.0 };
            }
            jm[(i, 3)] = p[i];
            jm[(3, i)] = p[i] / rho;
            if let Some((v, _)) = pin {
                jm[(4, i)] = v[i];
            }
        }
        let svd = jm.svd(true, true);
        let smax = svd.singular_values.max();
        let step = svd.solve(&r, 1e-13 * smax).ok()?;
        let n0 = r.norm();
        let mut t = 1.0;
        let mut accepted = false;
        for _ in 0..30 {
            let pn = p - V3::new(step[0], step[1], step[2]) * t;
            let ln = lambda - t * step[3];
            let (rn, locn, sizen) = residual(pn, ln);
            if rn.norm() < n0 || rn.norm() == 0.0 {
                p = pn;
                lambda = ln;
                r = rn;
                loc = locn;
                size = sizen;
                accepted = true;
                break;
            }
            t *= 0.5;
        }
        if !accepted {
            break;
        }
    }
    if extra.is_some() {
        return Some((p, lambda));
    }
    // stagnated: accept only a small residual (degenerate roots converge slowly)
    let ok = r.iter().take(3).all(|x| x.abs() <= 1e-9 * size)
        && r.iter().skip(3).all(|x| x.abs() <= 1e-9 * rho);
    ok.then_some((p, lambda))
}

// ---- classification -------------------------------------------------------------------------

/// The second-order data at an equilibrium: δ² on the tangent plane (a, b, c), its
/// eigenvalues, the spectrum of the model's linearised field and the degeneracy scale.
struct SecondOrder {
    basis: (V3, V3),
    eig: [f64; 2],
    tol: f64,
    spectrum: Spectrum,
    rate: f64,
    lambda: f64,
    local: Local,
}

fn second_order(sys: &LiePoissonSystem, p: V3, opts: &Options) -> SecondOrder {
    let local = sys.local(p);
    let lambda = -local.grad.dot(&p) / p.dot(&p);
    let (e1, e2) = tangent_basis(p);
    let m = |u: V3, v: V3| u.dot(&(local.hess * v)) + lambda * u.dot(&v);
    let (a, b, c) = (m(e1, e1), m(e1, e2), m(e2, e2));
    let eig = sym2_eigen(a, b, c);
    let tol = opts.degenerate * local.hess.amax().max(lambda.abs()).max(1e-300);
    // the model's own linearisation, restricted to the tangent plane
    let j = |u: V3, v: V3| u.dot(&(local.jac * v));
    let (j11, j12, j21, j22) = (j(e1, e1), j(e1, e2), j(e2, e1), j(e2, e2));
    let half_tr = 0.5 * (j11 + j22);
    let disc = half_tr * half_tr - (j11 * j22 - j12 * j21);
    let jscale = local.jac.amax().max(1e-300);
    let spectrum = if disc.abs() <= (opts.degenerate * jscale).powi(2) {
        Spectrum::Zero
    } else if disc > 0.0 {
        Spectrum::Real(disc.sqrt())
    } else {
        Spectrum::Imaginary((-disc).sqrt())
    };
    SecondOrder {
        basis: (e1, e2),
        eig,
        tol,
        spectrum,
        rate: disc.max(0.0).sqrt(),
        lambda,
        local,
    }
}

/// The point at geodesic distance r from P on its sphere, in the tangent direction
/// cos θ e₁ + sin θ e₂.
fn geodesic(p: V3, basis: (V3, V3), r: f64, theta: f64) -> V3 {
    let rho = p.norm();
    let dir = basis.0 * theta.cos() + basis.1 * theta.sin();
    let a = r / rho;
    p * a.cos() + dir * (rho * a.sin())
}

/// The higher-order probe of an isolated degenerate equilibrium: the sign of H − H(Pₑ) on
/// geodesic circles of radii ρ·{10⁻¹, 3·10⁻², 10⁻², 3·10⁻³}, 720 directions each.
fn leaf_probe(sys: &LiePoissonSystem, p: V3, basis: (V3, V3)) -> Probe {
    let rho = p.norm();
    let h0 = sys.energy(p);
    let (mut all_below, mut all_above, mut mixed_everywhere) = (true, true, true);
    for r in [1e-1, 3e-2, 1e-2, 3e-3] {
        let (mut below, mut above) = (false, false);
        for k in 0..720 {
            let theta = 2.0 * std::f64::consts::PI * k as f64 / 720.0;
            let d = sys.energy(geodesic(p, basis, r * rho, theta)) - h0;
            let noise = 1e-14 * h0.abs().max(1e-300) + 1e-300;
            if d < -noise {
                below = true;
            } else if d > noise {
                above = true;
            } else {
                // flat to rounding in some direction: neither strictly below nor above
                below = true;
                above = true;
            }
        }
        all_below &= below && !above;
        all_above &= above && !below;
        mixed_everywhere &= below && above;
    }
    if all_below {
        Probe::StrictMax
    } else if all_above {
        Probe::StrictMin
    } else if mixed_everywhere {
        Probe::NotExtremum
    } else {
        Probe::Inconclusive
    }
}

/// Follows a curve of equilibria from P along the kernel of δ²: steps of length `step` with a
/// predictor along the kernel and a corrector (Newton on the level, pinned to the plane through
/// the predicted point normal to the kernel). `None` when the first step finds no equilibrium
/// (P is isolated).
fn trace_family(sys: &LiePoissonSystem, p: V3, opts: &Options) -> Option<(Family, Vec<V3>)> {
    let rho = p.norm();
    let step = 0.05 * rho;
    let kernel = |q: V3, prev: Option<V3>| -> V3 {
        let so = second_order(sys, q, opts);
        let (e1, e2) = so.basis;
        let lm = so.local;
        let m = |u: V3, v: V3| u.dot(&(lm.hess * v)) + so.lambda * u.dot(&v);
        let (a, b) = (m(e1, e1), m(e1, e2));
        // the eigenvector of the eigenvalue closest to zero
        let ev = so.eig[if so.eig[0].abs() <= so.eig[1].abs() {
            0
        } else {
            1
        }];
        let (x, y) = if b.abs() > 1e-300 || (a - ev).abs() > 1e-300 {
            (b, ev - a)
        } else {
            (1.0, 0.0)
        };
        let (x, y) = if x.abs() + y.abs() == 0.0 {
            (1.0, 0.0)
        } else {
            (x, y)
        };
        let v = e1 * x + e2 * y;
        let v = v * (1.0 / v.norm());
        match prev {
            Some(w) if v.dot(&w) < 0.0 => -v,
            _ => v,
        }
    };
    let mut members = vec![p];
    let mut v = kernel(p, None);
    let mut q = p;
    let mut closed = false;
    for k in 0..2000 {
        let pred = q + v * step;
        let pred = pred * (rho / pred.norm());
        let (next, _) = newton(sys, pred, rho, Some((v, pred)))?;
        if (next - pred).norm() > 0.5 * step {
            return if k == 0 {
                None
            } else {
                break_family(members, closed, rho)
            };
        }
        let so = second_order(sys, next, opts);
        if so.eig[0].abs().min(so.eig[1].abs()) > 10.0 * so.tol {
            // left the family (its end, or an isolated neighbour)
            return if k == 0 {
                None
            } else {
                break_family(members, closed, rho)
            };
        }
        if k >= 3 && (next - p).norm() < 0.75 * step {
            closed = true;
            break;
        }
        v = kernel(next, Some(v));
        q = next;
        members.push(next);
    }
    break_family(members, closed, rho)
}

fn break_family(members: Vec<V3>, closed: bool, rho: f64) -> Option<(Family, Vec<V3>)> {
    if members.len() < 3 {
        return None;
    }
    let n = members.len() as f64;
    let mean = members.iter().fold(V3::zeros(), |a, &m| a + m * (1.0 / n));
    let mut mat = DMatrix::zeros(members.len(), 3);
    for (i, m) in members.iter().enumerate() {
        for j in 0..3 {
            mat[(i, j)] = m[j] - mean[j];
        }
    }
    let svd = mat.svd(false, true);
    let vt = svd.v_t?;
    let k = (0..3)
        .min_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]))
        .unwrap_or(2);
    let mut normal = V3::new(vt[(k, 0)], vt[(k, 1)], vt[(k, 2)]);
    // a canonical orientation: the largest component positive
    let big = (0..3)
        .max_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs()))
        .unwrap_or(0);
    if normal[big] < 0.0 {
        normal = -normal;
    }
    let mut offset = normal.dot(&mean);
    if offset.abs() < 1e-12 * rho {
        offset = 0.0;
    }
    let fit_residual = members
        .iter()
        .fold(0.0f64, |a, &m| a.max((normal.dot(&m) - offset).abs()));
    Some((
        Family {
            normal: normal.into(),
            offset,
            members: members.len(),
            closed,
            fit_residual,
        },
        members,
    ))
}

/// Classifies an equilibrium P (assumed one: `residual` is reported, not checked).
pub fn classify(sys: &LiePoissonSystem, p: [f64; 3], opts: &Options) -> Equilibrium {
    classify_inner(sys, V3::from(p), opts, true).0
}

fn classify_inner(
    sys: &LiePoissonSystem,
    p: V3,
    opts: &Options,
    families: bool,
) -> (Equilibrium, Vec<V3>) {
    let so = second_order(sys, p, opts);
    let [a1, a2] = so.eig;
    let mut family = None;
    let mut members = Vec::new();
    let verdict = if a1 > so.tol {
        Verdict::Stable {
            extremum: Extremum::Min,
        }
    } else if a2 < -so.tol {
        Verdict::Stable {
            extremum: Extremum::Max,
        }
    } else if a1 < -so.tol && a2 > so.tol {
        if matches!(so.spectrum, Spectrum::Real(_)) {
            Verdict::LinearlyUnstable { rate: so.rate }
        } else {
            // cannot happen for a field P × ∇H (μ² = −ρ² det δ²); reported, not hidden
            Verdict::Undecided {
                probe: Probe::Inconclusive,
            }
        }
    } else {
        let traced = if families {
            trace_family(sys, p, opts)
        } else {
            None
        };
        let probe = match traced {
            Some((f, m)) => {
                family = Some(f);
                members = m;
                if a1.abs().max(a2.abs()) > so.tol {
                    Probe::FamilyStableAsSet
                } else {
                    Probe::Inconclusive
                }
            }
            None => leaf_probe(sys, p, so.basis),
        };
        Verdict::Undecided { probe }
    };
    let eq = Equilibrium {
        p: p.into(),
        rho: p.norm(),
        lambda: so.lambda,
        energy: so.local.h,
        residual: so.local.field.norm(),
        second_variation: so.eig,
        spectrum: so.spectrum,
        verdict,
        family,
    };
    (eq, members)
}

fn field_scale(sys: &LiePoissonSystem, p: V3) -> f64 {
    let l = sys.local(p);
    p.norm() * l.grad.norm()
}

/// All equilibria on the Casimir level |P| = ρ.
pub fn analyse_level(
    sys: &LiePoissonSystem,
    rho: f64,
    opts: &Options,
) -> Result<Level, StabilityError> {
    if !(rho.is_finite() && rho > 0.0) {
        return Err(StabilityError::BadLevel(rho));
    }
    // a level on which the field vanishes identically (e.g. c₁ = c₂ = c₃ for Type III)
    let probes = fibonacci(40, rho);
    let vanishes = probes.iter().all(|&q| {
        let l = sys.local(q);
        l.field.norm() <= 1e-12 * (q.norm() * l.grad.norm() + l.hess.amax() * rho * rho) + 1e-300
    });
    if vanishes {
        return Ok(Level {
            rho,
            all_equilibria: true,
            equilibria: Vec::new(),
        });
    }
    // clusters of converged points: within 10⁻⁴ ρ, or within 10⁻³ ρ when both are nearly
    // degenerate (a multiple root is only determined to ~ε^⅓); a cluster is represented by its
    // mean, put back on the sphere
    let mut clusters: Vec<(Vec<V3>, bool)> = Vec::new();
    for start in fibonacci(opts.starts, rho) {
        let Some((p, _)) = newton(sys, start, rho, None) else {
            continue;
        };
        let p = p * (rho / p.norm());
        if sys.local(p).field.norm() > 1e-8 * field_scale(sys, p).max(1e-300) {
            continue;
        }
        let so = second_order(sys, p, opts);
        let near_degenerate =
            so.eig[0].abs().min(so.eig[1].abs()) <= 1e-3 * so.tol / opts.degenerate;
        let home = clusters.iter_mut().find(|(members, degenerate)| {
            let d = (p - members[0]).norm();
            d <= 1e-4 * rho || (near_degenerate && *degenerate && d <= 1e-3 * rho)
        });
        match home {
            Some((members, _)) => members.push(p),
            None => clusters.push((vec![p], near_degenerate)),
        }
    }
    let found: Vec<V3> = clusters
        .iter()
        .map(|(members, _)| {
            let n = members.len() as f64;
            let mean = members.iter().fold(V3::zeros(), |a, &m| a + m * (1.0 / n));
            if mean.norm() > 0.5 * rho {
                mean * (rho / mean.norm())
            } else {
                members[0]
            }
        })
        .collect();
    let mut equilibria: Vec<Equilibrium> = Vec::new();
    let mut covered: Vec<(Family, Vec<V3>)> = Vec::new();
    for p in found {
        let on_known_family = covered.iter().any(|(f, m)| {
            (V3::from(f.normal).dot(&p) - f.offset).abs() <= 1e-6 * rho
                && m.iter().any(|&q| (p - q).norm() <= 0.2 * rho)
        });
        if on_known_family {
            continue;
        }
        let (mut eq, members) = classify_inner(sys, p, opts, true);
        if let Some(f) = &eq.family {
            // the member closest to a fixed generic direction represents the family, so a
            // sweep over levels sees a continuous representative
            let reference = V3::new(0.9, 0.3, 0.1);
            let rep = members
                .iter()
                .copied()
                .max_by(|&a, &b| a.dot(&reference).total_cmp(&b.dot(&reference)))
                .unwrap_or(p);
            let f = f.clone();
            let (mut eq2, _) = classify_inner(sys, rep, opts, false);
            eq2.family = Some(f.clone());
            if let Verdict::Undecided { .. } = eq2.verdict {
                eq2.verdict = eq.verdict;
            }
            eq = eq2;
            covered.push((f, members));
        }
        equilibria.push(eq);
    }
    equilibria.sort_by(|a, b| {
        let key = |e: &Equilibrium| e.p.map(|x| (x / rho * 1e6).round() as i64);
        key(b).cmp(&key(a))
    });
    Ok(Level {
        rho,
        all_equilibria: false,
        equilibria,
    })
}

/// Analyses a given point: it must be an equilibrium (|P × ∇H| ≤ 10⁻⁸ |P| |∇H|); otherwise the
/// error names the nearest equilibrium on its level.
pub fn analyse_point(
    sys: &LiePoissonSystem,
    p: [f64; 3],
    opts: &Options,
) -> Result<Equilibrium, StabilityError> {
    let p = V3::from(p);
    let rho = p.norm();
    if !(rho.is_finite() && rho > 0.0) {
        return Err(StabilityError::BadLevel(rho));
    }
    let residual = sys.local(p).field.norm();
    if residual > 1e-8 * field_scale(sys, p).max(1e-300) {
        // Newton from P, else (P may be a singular start) from points 1–10 % of ρ away
        let basis = tangent_basis(p);
        let nearest = newton(sys, p, rho, None)
            .or_else(|| {
                [1e-2, 3e-2, 1e-1]
                    .iter()
                    .find_map(|&r| newton(sys, geodesic(p, basis, r * rho, 0.7), rho, None))
            })
            .map(|(q, _)| q * (rho / q.norm()));
        return Err(StabilityError::NotEquilibrium {
            p: p.into(),
            residual,
            nearest: nearest.map(Into::into),
        });
    }
    Ok(classify_inner(sys, p, opts, true).0)
}

// ---- sweeps over Casimir levels ---------------------------------------------------------------

/// A range of Casimir levels over which one branch keeps one verdict class.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Segment {
    /// The verdict class.
    pub class: VerdictClass,
    /// The full verdict at the first level of the range (its probe, extremum).
    pub verdict: Verdict,
    /// Lower end of ρ.
    pub rho_from: f64,
    /// Upper end of ρ.
    pub rho_to: f64,
    /// Whether each end is a verdict change located by bisection (else the sweep's bound or
    /// where the branch appears or disappears, to the grid spacing).
    pub refined: [bool; 2],
    /// The equilibrium at each end.
    pub p_from: [f64; 3],
    /// The equilibrium at the upper end.
    pub p_to: [f64; 3],
    /// Whether the branch is a family (a circle of equilibria on each level).
    pub family: bool,
}

/// One branch of equilibria over Casimir levels, with its verdict ranges.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Branch {
    /// Ranges of ρ, ascending.
    pub segments: Vec<Segment>,
}

/// What a sweep found.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Sweep {
    /// The levels analysed.
    pub rho: Vec<f64>,
    /// Branches, in the order they appear.
    pub branches: Vec<Branch>,
    /// Levels on which every point is an equilibrium.
    pub all_equilibria: Vec<f64>,
}

/// Follows the equilibria over `levels` Casimir levels evenly spaced in [ρ_min, ρ_max]: on
/// each level all equilibria are found ([`analyse_level`]); a branch is continued to the next
/// level by Newton from its last point (scaled to the new level) and matched to the equilibrium
/// found there (else, nearest first, to the closest direction P/|P| within 0.35), and where a branch's verdict class changes
/// the level is located by bisection (50 halvings, the branch followed by Newton).
pub fn sweep(
    sys: &LiePoissonSystem,
    rho_min: f64,
    rho_max: f64,
    levels: usize,
    opts: &Options,
) -> Result<Sweep, StabilityError> {
    for r in [rho_min, rho_max] {
        if !(r.is_finite() && r > 0.0) {
            return Err(StabilityError::BadLevel(r));
        }
    }
    let levels = levels.max(2);
    let rhos: Vec<f64> = (0..levels)
        .map(|k| rho_min + (rho_max - rho_min) * k as f64 / (levels - 1) as f64)
        .collect();
    // each branch: its list of (level index, equilibrium)
    let mut branches: Vec<Vec<(usize, Equilibrium)>> = Vec::new();
    let mut all = Vec::new();
    let mut open: Vec<usize> = Vec::new();
    for (k, &rho) in rhos.iter().enumerate() {
        let level = analyse_level(sys, rho, opts)?;
        if level.all_equilibria {
            all.push(rho);
        }
        let unit = |e: &Equilibrium| V3::from(e.p) * (1.0 / e.rho);
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for &b in &open {
            let last = &branches[b].last().expect("open branches are non-empty").1;
            // the branch continued to this level by Newton from its last point, scaled
            let tracked = if last.family.is_none() {
                newton(sys, V3::from(last.p) * (rho / last.rho), rho, None)
                    .map(|(p, _)| p * (rho / p.norm()))
            } else {
                None
            };
            for (i, e) in level.equilibria.iter().enumerate() {
                if e.family.is_some() != last.family.is_some() {
                    continue;
                }
                let d = (unit(e) - unit(last)).norm();
                match tracked {
                    // the continuation lands on it: matched before any closeness guess
                    Some(t) if (t - V3::from(e.p)).norm() <= 1e-3 * rho => {
                        pairs.push((1e-3 * (t - V3::from(e.p)).norm() / rho, b, i))
                    }
                    _ if d < 0.35 => pairs.push((d, b, i)),
                    _ => {}
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut used_b = Vec::new();
        let mut used_i = vec![false; level.equilibria.len()];
        let mut next_open = Vec::new();
        for (_, b, i) in pairs {
            if used_b.contains(&b) || used_i[i] {
                continue;
            }
            used_b.push(b);
            used_i[i] = true;
            branches[b].push((k, level.equilibria[i].clone()));
            next_open.push(b);
        }
        for (i, e) in level.equilibria.into_iter().enumerate() {
            if !used_i[i] {
                branches.push(vec![(k, e)]);
                next_open.push(branches.len() - 1);
            }
        }
        open = next_open;
    }
    let out = branches
        .into_iter()
        .map(|points| segments(sys, &rhos, &points, opts))
        .collect();
    Ok(Sweep {
        rho: rhos,
        branches: out,
        all_equilibria: all,
    })
}

/// Splits a branch into ranges of one verdict class, locating the changes by bisection.
fn segments(
    sys: &LiePoissonSystem,
    rhos: &[f64],
    points: &[(usize, Equilibrium)],
    opts: &Options,
) -> Branch {
    let mut out: Vec<Segment> = Vec::new();
    let family = points[0].1.family.is_some();
    let mut start = 0;
    for i in 1..=points.len() {
        let end_here =
            i == points.len() || points[i].1.verdict.class() != points[start].1.verdict.class();
        if !end_here {
            continue;
        }
        let (k0, e0) = &points[start];
        let (k1, e1) = &points[i - 1];
        let mut seg = Segment {
            class: e0.verdict.class(),
            verdict: e0.verdict,
            rho_from: rhos[*k0],
            rho_to: rhos[*k1],
            refined: [false, false],
            p_from: e0.p,
            p_to: e1.p,
            family,
        };
        if i < points.len() && points[i].0 == k1 + 1 && !family {
            // a verdict change between two consecutive levels: bisect
            if let Some((rho, p)) = bisect(sys, e1, &points[i].1, opts) {
                seg.rho_to = rho;
                seg.p_to = p.into();
                seg.refined[1] = true;
            }
        }
        if let Some(prev) = out.last() {
            if prev.refined[1] && points[start].0 > 0 && prev.rho_to <= seg.rho_from {
                seg.rho_from = prev.rho_to;
                seg.p_from = prev.p_to;
                seg.refined[0] = true;
            }
        }
        out.push(seg);
        start = i;
    }
    Branch { segments: out }
}

/// The level between `a` and `b` (adjacent levels of one branch with different verdict
/// classes) where the class changes, and the equilibrium there (on `a`'s side).
fn bisect(
    sys: &LiePoissonSystem,
    a: &Equilibrium,
    b: &Equilibrium,
    opts: &Options,
) -> Option<(f64, V3)> {
    let class_a = a.verdict.class();
    let (mut lo, mut hi) = (a.rho, b.rho);
    let mut p_lo = V3::from(a.p);
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        let guess = p_lo * (mid / p_lo.norm());
        let (p, _) = newton(sys, guess, mid, None)?;
        let p = p * (mid / p.norm());
        let (e, _) = classify_inner(sys, p, opts, false);
        if e.verdict.class() == class_a {
            lo = mid;
            p_lo = p;
        } else {
            hi = mid;
        }
    }
    let mid = 0.5 * (lo + hi);
    Some((mid, p_lo * (mid / p_lo.norm())))
}

// ---- dynamics -----------------------------------------------------------------------------------

/// Integrates `model` with DOPRI5 (rtol 10⁻¹⁰, atol 10⁻¹², steps at most 0.05) from
/// P = Pₑ + δP (the rest of the state zero: the P-subsystem is closed) on [0, t_end] and returns
/// the largest distance |P(t) − Pₑ| seen at the steps.
pub fn max_excursion(
    model: &LoadedModel,
    p_index: [usize; 3],
    pe: [f64; 3],
    dp: [f64; 3],
    t_end: f64,
) -> Result<f64, String> {
    let mut x0 = vec![0.0; model.dim()];
    for (k, &i) in p_index.iter().enumerate() {
        x0[i] = pe[k] + dp[k];
    }
    let opts = DormandPrinceOptions {
        rtol: 1e-10,
        atol: 1e-12,
        h_max: 0.05,
        ..Default::default()
    };
    let mut worst = 0.0f64;
    let mut observer = |_: u64, _: f64, x: &Vec<f64>| {
        let p = V3::new(x[p_index[0]], x[p_index[1]], x[p_index[2]]);
        worst = worst.max((p - V3::from(pe)).norm());
        Control::Continue
    };
    let mut dp5 = DormandPrince::<f64, Vec<f64>>::new(opts);
    Driver::new(0.0, t_end, 0.0)
        .run(&mut dp5, model, &x0, &mut observer)
        .map_err(|e| e.to_string())?;
    Ok(worst)
}

/// The P-subsystem of a loaded model with its current parameters.
pub fn system(model: &LoadedModel) -> Result<LiePoissonSystem, StabilityError> {
    let lowered = model.model().map_err(|e| StabilityError::Unsupported {
        model: model.model_name().to_string(),
        why: e.to_string(),
    })?;
    LiePoissonSystem::new(lowered, model.params())
}
