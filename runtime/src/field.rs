//! The traits that generated models implement.
//!
//! A model is a vector field ẋ = X(x) on Rᴺ ([`Field`]), optionally with invariants
//! f = (f₀, f₁, …, f_ℓ): Rᴺ → Rᴹ stacked component by component ([`Invariants`]: constraints
//! f₀ and first integrals f₁…f_ℓ), and a Lyapunov function V built from them with G gains
//! ([`Lyapunov`]; by default V = Σ kᵢ/2 |fᵢ(x) − fᵢ(x₀)|², paper eq. (10)).
//!
//! Every method writes into a caller's fixed-size buffer and never allocates, so steppers can
//! call them in a hot loop. Everything is generic over the scalar `T: num_traits::Float`.

use num_traits::Float;

/// Converts an `f64` literal into any `Float` scalar (nalgebra's `convert` habit).
///
/// Generated code writes every numeric constant through this helper, so the same code runs
/// on `f32`, `f64` or a double-double type.
#[inline(always)]
pub fn lit<T: Float>(x: f64) -> T {
    // `NumCast` from f64 into a float type never fails; NaN falls back to NaN.
    T::from(x).unwrap_or_else(T::nan)
}

/// An autonomous vector field ẋ = X(x) on Rᴺ.
pub trait Field<T: Float, const N: usize> {
    /// Writes X(x) into `dx`.
    fn field(&self, x: &[T; N], dx: &mut [T; N]);
}

/// Is the invariant a manifold condition (f₀) or a first integral (fᵢ, ∇fᵢ · X = 0)?
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InvariantKind {
    /// A constraint f₀: the motion stays on {f₀(x) = f₀(x₀)}.
    Constraint,
    /// A first integral: ∇f · X = 0 everywhere.
    Integral,
}

/// The shape of a state variable, parameter or invariant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Shape {
    /// A scalar.
    Scalar,
    /// A column vector of this length.
    Vector(usize),
    /// A matrix (rows, columns), stored column-major like nalgebra.
    Matrix(usize, usize),
}

impl Shape {
    /// Number of scalar components.
    pub const fn len(self) -> usize {
        match self {
            Shape::Scalar => 1,
            Shape::Vector(n) => n,
            Shape::Matrix(r, c) => r * c,
        }
    }

    /// True for shapes without components (never produced by the generator).
    pub const fn is_empty(self) -> bool {
        self.len() == 0
    }
}

impl std::fmt::Display for Shape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Shape::Scalar => write!(f, "scalar"),
            Shape::Vector(n) => write!(f, "vec{n}"),
            Shape::Matrix(r, c) if r == c => write!(f, "mat{r}"),
            Shape::Matrix(r, c) => write!(f, "mat{r}x{c}"),
        }
    }
}

/// Where a named block (state variable, invariant) sits in a flat array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot {
    /// The name in the model file.
    pub name: &'static str,
    /// Its shape; matrices are stored column-major.
    pub shape: Shape,
    /// Index of its first component in the flat array.
    pub offset: usize,
}

impl Slot {
    /// The index range of this block in the flat array.
    pub const fn range(&self) -> std::ops::Range<usize> {
        self.offset..self.offset + self.shape.len()
    }
}

/// A declared invariant: its slot in the stacked f, its kind and its gain index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InvariantInfo {
    /// Name, shape and position in the stacked vector f ∈ Rᴹ.
    pub slot: Slot,
    /// Constraint or first integral.
    pub kind: InvariantKind,
    /// Index into the gains array of the gain that weighs it in V (default form).
    pub gain: usize,
}

/// Static description of a generated model: names and layout of its state, invariants and gains.
pub trait ModelInfo {
    /// The model's name as written after `model`.
    const NAME: &'static str;
    /// The state variables in order, with their offsets in the flat state.
    const STATE: &'static [Slot];
    /// The invariants in order, with their offsets in the stacked f.
    const INVARIANTS: &'static [InvariantInfo];
    /// Names of the gains, in the order of the gains array.
    const GAIN_NAMES: &'static [&'static str];
    /// Default gains as written in the model file.
    const DEFAULT_GAINS: &'static [f64];
    /// Parameter names with their shapes (matrices column-major), in declaration order.
    const PARAMS: &'static [Slot];
}

/// Constraints and first integrals, stacked into f(x) ∈ Rᴹ.
pub trait Invariants<T: Float, const N: usize, const M: usize>: Field<T, N> {
    /// Writes f(x).
    fn invariants(&self, x: &[T; N], f: &mut [T; M]);
    /// Writes the Jacobian Df(x), row i = ∇fᵢ(x).
    fn invariants_jacobian(&self, x: &[T; N], jac: &mut [[T; N]; M]);
}

/// A Lyapunov function V(x) ≥ 0 vanishing on {f(x) = f(x₀)} and the feedback field X − ∇V.
///
/// `target` is f(x₀) (the stacked invariants at the initial point) and `gains` the G gains.
pub trait Lyapunov<T: Float, const N: usize, const M: usize, const G: usize>:
    Invariants<T, N, M>
{
    /// V(x), e.g. ½ (f(x) − f(x₀))ᵀ K (f(x) − f(x₀)) (paper eq. (10)).
    fn lyapunov(&self, x: &[T; N], target: &[T; M], gains: &[T; G]) -> T;
    /// ∇V(x).
    fn lyapunov_gradient(&self, x: &[T; N], target: &[T; M], gains: &[T; G], grad: &mut [T; N]);
    /// The feedback field ẋ = X(x) − ∇V(x) (paper eqs. (3), (11)).
    fn feedback_field(&self, x: &[T; N], target: &[T; M], gains: &[T; G], dx: &mut [T; N]);
}

/// A partitioned field: the state splits into groups q and p with q̇ = a(p), ṗ = b(q)
/// (e.g. ẋ = v, v̇ = −μx/|x|³), which Störmer–Verlet integrates explicitly.
pub trait Partitioned<T: Float, const N: usize>: Field<T, N> {
    /// `true` at the components of q (the "drift" group), `false` at those of p.
    const IS_Q: [bool; N];
    /// Writes q̇ = a(p) into the q components of `dx`; leaves the p components alone.
    fn field_q(&self, x: &[T; N], dx: &mut [T; N]);
    /// Writes ṗ = b(q) into the p components of `dx`; leaves the q components alone.
    fn field_p(&self, x: &[T; N], dx: &mut [T; N]);
}
