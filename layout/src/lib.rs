//! The layout vocabulary shared by the generator (`lasalle-model`, whose front end decides
//! it) and the runtime (`lasalle-runtime`, whose emitted and loaded models describe themselves
//! with it): the [`Shape`] of a state variable, parameter or invariant, and the
//! [`InvariantKind`] of an invariant. Defined once here, with no dependencies, so that the
//! generator — a build dependency — does not pull the runtime's numerics into build scripts.

use std::fmt;

/// The shape of a state variable, parameter or invariant. Matrices are stored column-major
/// (as nalgebra does).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Shape {
    /// A scalar.
    Scalar,
    /// A column vector of this length.
    Vector(usize),
    /// A matrix (rows, columns).
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

    /// Parses the model language's names: `scalar`, `vecN`, `matN`, `matRxC` (1 ≤ N ≤ 64).
    pub fn from_name(name: &str) -> Option<Shape> {
        let dim = |s: &str| s.parse::<usize>().ok().filter(|&n| (1..=64).contains(&n));
        if name == "scalar" {
            Some(Shape::Scalar)
        } else if let Some(n) = name.strip_prefix("vec") {
            dim(n).map(Shape::Vector)
        } else if let Some(rest) = name.strip_prefix("mat") {
            match rest.split_once('x') {
                Some((r, c)) => Some(Shape::Matrix(dim(r)?, dim(c)?)),
                None => dim(rest).map(|n| Shape::Matrix(n, n)),
            }
        } else {
            None
        }
    }

    /// (rows, columns), a vector being a column.
    pub const fn dims(self) -> (usize, usize) {
        match self {
            Shape::Scalar => (1, 1),
            Shape::Vector(n) => (n, 1),
            Shape::Matrix(r, c) => (r, c),
        }
    }

    /// The shape with these dims, using the simplest kind (1×1 → scalar, n×1 → vector).
    pub const fn from_dims(r: usize, c: usize) -> Shape {
        match (r, c) {
            (1, 1) => Shape::Scalar,
            (n, 1) => Shape::Vector(n),
            _ => Shape::Matrix(r, c),
        }
    }
}

/// The model language's name of the shape (`scalar`, `vec3`, `mat3`, `mat2x3`).
impl fmt::Display for Shape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Shape::Scalar => write!(f, "scalar"),
            Shape::Vector(n) => write!(f, "vec{n}"),
            Shape::Matrix(r, c) if r == c => write!(f, "mat{r}"),
            Shape::Matrix(r, c) => write!(f, "mat{r}x{c}"),
        }
    }
}

/// Is the invariant a manifold condition (a constraint f₀) or a first integral (fᵢ)?
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InvariantKind {
    /// A constraint f₀: the motion stays on {f₀(x) = f₀(x₀)}.
    Constraint,
    /// A first integral: ∇f · X = 0 everywhere (or on the constraints' manifold).
    Integral,
}

#[cfg(test)]
mod tests {
    use super::Shape;

    #[test]
    fn names_round_trip() {
        for s in [
            Shape::Scalar,
            Shape::Vector(3),
            Shape::Matrix(3, 3),
            Shape::Matrix(2, 5),
        ] {
            assert_eq!(Shape::from_name(&s.to_string()), Some(s));
            let (r, c) = s.dims();
            assert_eq!(Shape::from_dims(r, c), s);
            assert_eq!(s.len(), r * c);
        }
        assert_eq!(Shape::from_name("vec0"), None);
        assert_eq!(Shape::from_name("mat65"), None);
        assert_eq!(Shape::from_name("tensor3"), None);
    }
}
