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

pub use crate::state::State;

/// Converts an `f64` literal into any `Float` scalar (nalgebra's `convert` habit).
///
/// Generated code writes every numeric constant through this helper, so the same code runs
/// on `f32`, `f64` or a double-double type.
#[inline(always)]
pub fn lit<T: Float>(x: f64) -> T {
    // `NumCast` from f64 into a float type never fails; NaN falls back to NaN.
    T::from(x).unwrap_or_else(T::nan)
}

/// An autonomous vector field ẋ = X(x) on Rᴺ, for states stored as `X` (`[T; N]` for compiled
/// models, `Vec<T>` for models loaded at run time; see [`State`]).
pub trait Field<T, X: State<T>> {
    /// Writes X(x) into `dx`.
    fn field(&self, x: &X, dx: &mut X);
}

pub use lasalle_layout::{InvariantKind, Shape};

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

/// Description of a model: names and layout of its state, invariants, gains and parameters.
///
/// Compiled models return constants; a model loaded at run time returns its own tables (whose
/// names it keeps for the life of the process).
pub trait ModelInfo {
    /// The model's name as written after `model`.
    fn model_name(&self) -> &'static str;
    /// The state variables in order, with their offsets in the flat state.
    fn state_slots(&self) -> &'static [Slot];
    /// The invariants in order, with their offsets in the stacked f.
    fn invariant_infos(&self) -> &'static [InvariantInfo];
    /// Names of the gains, in the order of the gains array.
    fn gain_names(&self) -> &'static [&'static str];
    /// Default gains as written in the model file.
    fn default_gain_values(&self) -> &'static [f64];
    /// Parameter names with their shapes (matrices column-major), in declaration order.
    fn param_slots(&self) -> &'static [Slot];
    /// The dimension N of the flat state.
    fn state_dim(&self) -> usize {
        self.state_slots().iter().map(|s| s.shape.len()).sum()
    }
}

/// Constraints and first integrals, stacked into f(x) ∈ Rᴹ (storage `F`).
pub trait Invariants<T, X: State<T>, F: State<T>>: Field<T, X> {
    /// The number M of stacked components. The default is the length of fixed-size storage;
    /// a model with run-time-sized storage (`Vec<T>`) must implement it.
    fn invariant_dim(&self) -> usize {
        F::LEN.expect("Invariants::invariant_dim must be implemented for run-time-sized storage")
    }
    /// Writes f(x).
    fn invariants(&self, x: &X, f: &mut F);
    /// Writes the Jacobian Df(x), row i = ∇fᵢ(x).
    fn invariants_jacobian(&self, x: &X, jac: &mut F::Rows<X>);
}

/// A Lyapunov function V(x) ≥ 0 vanishing on {f(x) = f(x₀)} and the feedback field X − ∇V.
///
/// `target` is f(x₀) (the stacked invariants at the initial point) and `gains` the G gains
/// (storage `K`).
pub trait Lyapunov<T, X: State<T>, F: State<T>, K: State<T>>: Invariants<T, X, F> {
    /// V(x), e.g. ½ (f(x) − f(x₀))ᵀ K (f(x) − f(x₀)) (paper eq. (10)).
    fn lyapunov(&self, x: &X, target: &F, gains: &K) -> T;
    /// ∇V(x).
    fn lyapunov_gradient(&self, x: &X, target: &F, gains: &K, grad: &mut X);
    /// The feedback field ẋ = X(x) − ∇V(x) (paper eqs. (3), (11)).
    fn feedback_field(&self, x: &X, target: &F, gains: &K, dx: &mut X);
}

/// A partitioned field: the state splits into groups q and p with q̇ = a(p), ṗ = b(q)
/// (e.g. ẋ = v, v̇ = −μx/|x|³), which Störmer–Verlet integrates explicitly.
pub trait Partitioned<T, X: State<T>>: Field<T, X> {
    /// `true` at the components of q (the "drift" group), `false` at those of p; one entry
    /// per state component.
    fn is_q(&self) -> &[bool];
    /// Writes q̇ = a(p) into the q components of `dx`; leaves the p components alone.
    fn field_q(&self, x: &X, dx: &mut X);
    /// Writes ṗ = b(q) into the p components of `dx`; leaves the q components alone.
    fn field_p(&self, x: &X, dx: &mut X);
}
