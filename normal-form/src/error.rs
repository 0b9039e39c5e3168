//! The crate's error type.

use std::fmt;
use thiserror::Error;

/// A complex number for error reports, `re ± i·im`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Eigenvalue {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl fmt::Display for Eigenvalue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:.12} {} {:.12}i",
            self.re,
            if self.im < 0.0 { '-' } else { '+' },
            self.im.abs()
        )
    }
}

fn list(eigs: &[Eigenvalue]) -> String {
    eigs.iter()
        .map(|e| e.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

fn ivec(m: &[i32]) -> String {
    format!(
        "({})",
        m.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// Why a normal form could not be computed.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum NormalFormError {
    /// The linearisation has eigenvalues off the imaginary axis.
    #[error("equilibrium is not elliptic: eigenvalues {} (a Birkhoff normal form needs them all on the imaginary axis)", list(.eigenvalues))]
    NotElliptic {
        /// All eigenvalues of the linearised field J·S.
        eigenvalues: Vec<Eigenvalue>,
    },
    /// A repeated frequency whose eigenspace is too small: the linearisation is not
    /// diagonalisable (no linear normal form `Σ σ_k ω_k I_k` exists).
    #[error("the frequency ω = {omega:.12} is repeated {multiplicity} times (ω = {}) but the linearisation has only {eigenvectors} eigenvector(s) for it: it is not diagonalisable (a nilpotent part, as at L4 for Routh's mass ratio), so no Birkhoff normal form exists here; change the parameters to separate the frequencies", list_f(.frequencies))]
    Defective {
        /// The repeated frequency.
        omega: f64,
        /// Its multiplicity.
        multiplicity: usize,
        /// Independent eigenvectors of iω found.
        eigenvectors: usize,
        /// All frequencies.
        frequencies: Vec<f64>,
    },
    /// Assumption 1′ fails: |m·ω| below the resonance tolerance for some 0 < |m| ≤ N.
    #[error("resonance m = {} at order {order}: m·ω = {m_dot_omega:.3e} (ω = {}){}; the Birkhoff normal form exists only to degree {}: use `--resonant` to keep the resonant terms (a resonant normal form), or `--order {}`", ivec(.m), list_f(.omega), repeated_hint(.m, .omega, *.m_dot_omega), .order - 1, .order - 1)]
    Resonance {
        /// Integer vector m (relative to the positive frequencies ω).
        m: Vec<i32>,
        /// m·ω
        m_dot_omega: f64,
        /// |m|₁, the lowest degree at which the small divisor appears.
        order: usize,
        /// The frequencies ω.
        omega: Vec<f64>,
    },
    /// Newton's method for ∇H = 0 did not converge.
    #[error("newton iteration for the equilibrium failed after {iterations} iterations (|∇H| = {residual:.3e}){}", if *.singular_hessian { ": the Hessian of H is singular there, so Newton's step is undefined; start closer to an equilibrium" } else { "" })]
    NewtonFailed {
        /// Iterations done.
        iterations: usize,
        /// Final gradient norm.
        residual: f64,
        /// Whether it stopped at a singular Hessian.
        singular_hessian: bool,
    },
    /// The equilibrium is degenerate: the Hessian of H is singular there, so H₂ vanishes in
    /// some directions (zero frequencies) and no Birkhoff normal form exists.
    #[error("degenerate equilibrium at z = ({}): H₂ vanishes in {}; a Birkhoff normal form needs a nondegenerate quadratic part{}", list_e(.point), null_list(.directions, .coordinates), symmetry_hint(.directions, .coordinates))]
    Degenerate {
        /// The equilibrium.
        point: Vec<f64>,
        /// The directions in which H₂ vanishes.
        directions: Vec<crate::NullDirection>,
        /// The names of the flat coordinates, for the message.
        coordinates: Vec<String>,
    },
    /// The given point is not an equilibrium.
    #[error("the point is not an equilibrium: |∇H| = {gradient_norm:.3e}")]
    NotAnEquilibrium {
        /// |∇H| at the point.
        gradient_norm: f64,
    },
    /// The working precision is not enough: a coefficient's estimated relative error is above
    /// `Options::max_relative_error`.
    #[error("{precision} is not enough for this normal form from degree {degree} on: a coefficient of that degree has an estimated relative error of {relative_error:.1e} (limit {limit:.0e}), so the numbers would be meaningless; {advice}")]
    PrecisionLost {
        /// The precision (`f64` or `dd`).
        precision: String,
        /// The first degree of H̄ over the limit.
        degree: usize,
        /// Its worst estimated relative error (see `DegreeError::max_relative_error`).
        relative_error: f64,
        /// The limit.
        limit: f64,
        /// What to do.
        advice: String,
    },
    /// A size or option is out of range.
    #[error("invalid input: {0}")]
    Invalid(String),
    /// The series produced NaN or ∞ (e.g. a singular Hamiltonian at the point).
    #[error("non-finite coefficients in {0}")]
    NonFinite(&'static str),
    /// The model file does not load: the generator's located diagnostics, kept typed (their
    /// [`DiagnosticKind`](lasalle_model::DiagnosticKind)s, spans and help).
    #[error(transparent)]
    Load(LoadError),
    /// The model is not a canonical Hamiltonian system the normal form can expand, or an
    /// argument does not fit it.
    #[error("model: {0}")]
    Model(String),
    /// A centre-manifold reduction was asked at an equilibrium that is not of type
    /// saddle × centre × … (exactly one real pair ±λ, the others on the imaginary axis).
    #[error("equilibrium is not of type saddle × centre: eigenvalues {} (the centre-manifold reduction needs exactly one real pair ±λ and the others purely imaginary and distinct)", list(.eigenvalues))]
    NotSaddleCentre {
        /// All eigenvalues of the linearised field J·S.
        eigenvalues: Vec<Eigenvalue>,
    },
}

/// `0.577 q1 + 0.577 q2` from a unit vector (components below 1e-9 left out).
fn combination(v: &[f64], names: &[String]) -> String {
    let terms: Vec<String> = v
        .iter()
        .zip(names)
        .filter(|(c, _)| c.abs() > 1e-9)
        .map(|(c, n)| format!("{c:.3} {n}"))
        .collect();
    terms.join(" + ").replace("+ -", "- ")
}

fn null_list(directions: &[crate::NullDirection], names: &[String]) -> String {
    let each: Vec<String> = directions
        .iter()
        .map(|d| {
            format!(
                "({}) (Hessian eigenvalue {:.1e})",
                combination(&d.direction, names),
                d.eigenvalue
            )
        })
        .collect();
    let zero_frequencies = if directions.iter().all(|d| d.symmetry) {
        ""
    } else {
        ": zero frequencies, where the lowest terms of H are of degree 3 or more"
    };
    format!(
        "the direction{} {}{zero_frequencies}",
        if each.len() > 1 { "s" } else { "" },
        each.join(", ")
    )
}

/// The conserved momenta of translation symmetries among `directions`.
fn symmetry_hint(directions: &[crate::NullDirection], names: &[String]) -> String {
    let n = names.len() / 2;
    let momenta: Vec<String> = directions
        .iter()
        .filter(|d| d.symmetry && d.direction[n..].iter().all(|c| c.abs() <= 1e-9))
        .map(|d| {
            // the translation q → q + t·v is generated by the momentum v·p
            let mut moved = vec![0.0; 2 * n];
            moved[n..].copy_from_slice(&d.direction[..n]);
            combination(&moved, names)
        })
        .collect();
    if momenta.is_empty() {
        return String::new();
    }
    format!(
        ". H does not change under the translation{s} along {these}: a symmetry, whose conserved momentum{s} {m} make{verb} the equilibria a continuum; reduce by {it} (fix the momentum, use relative coordinates) to get an isolated equilibrium",
        s = if momenta.len() > 1 { "s" } else { "" },
        these = if momenta.len() > 1 { "these directions" } else { "this direction" },
        m = momenta.iter().map(|m| format!("({m})")).collect::<Vec<_>>().join(", "),
        verb = if momenta.len() > 1 { "" } else { "s" },
        it = if momenta.len() > 1 { "them" } else { "it" },
    )
}

impl NormalFormError {
    /// A model file that did not load.
    pub fn load(e: lasalle_model::Error) -> Self {
        NormalFormError::Load(LoadError(std::sync::Arc::new(e)))
    }
}

/// The generator's error for a model file that does not load, shared (`Arc`) so that
/// [`NormalFormError`] stays `Clone`; equal when the messages are.
#[derive(Clone, Debug)]
pub struct LoadError(pub std::sync::Arc<lasalle_model::Error>);

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for LoadError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

impl PartialEq for LoadError {
    fn eq(&self, other: &Self) -> bool {
        self.0.to_string() == other.0.to_string()
    }
}

fn list_e(w: &[f64]) -> String {
    w.iter()
        .map(|x| format!("{x:.6e}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn list_f(w: &[f64]) -> String {
    w.iter()
        .map(|x| format!("{x:.12}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// ", ω1 = ω2 is repeated (1:1 resonance)" when m = e_j − e_k and m·ω vanishes.
fn repeated_hint(m: &[i32], omega: &[f64], m_dot_omega: f64) -> String {
    let nz: Vec<usize> = (0..m.len()).filter(|&k| m[k] != 0).collect();
    let scale = omega.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    if nz.len() == 2
        && m[nz[0]].abs() == 1
        && m[nz[1]].abs() == 1
        && m_dot_omega.abs() <= 1e-9 * scale
    {
        format!(
            "; ω{} = ω{} is a repeated frequency, a 1:1 resonance",
            nz[0] + 1,
            nz[1] + 1
        )
    } else {
        String::new()
    }
}
