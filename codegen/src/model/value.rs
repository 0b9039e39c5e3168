//! Shaped values: scalars, vectors and matrices whose components are DAG nodes.

use crate::ir::Id;
use std::fmt;

/// The shape of a value. Matrices are stored column-major (as nalgebra does).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Shape {
    /// A scalar.
    Scalar,
    /// A column vector of length n.
    Vector(usize),
    /// A matrix (rows, columns).
    Matrix(usize, usize),
}

impl Shape {
    /// Number of scalar components.
    pub fn len(self) -> usize {
        match self {
            Shape::Scalar => 1,
            Shape::Vector(n) => n,
            Shape::Matrix(r, c) => r * c,
        }
    }

    /// Never true for shapes the parser accepts.
    pub fn is_empty(self) -> bool {
        self.len() == 0
    }

    /// Parses `scalar`, `vecN`, `matN`, `matRxC`.
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
    pub fn dims(self) -> (usize, usize) {
        match self {
            Shape::Scalar => (1, 1),
            Shape::Vector(n) => (n, 1),
            Shape::Matrix(r, c) => (r, c),
        }
    }

    /// The shape with these dims, using the simplest kind (1×1 → scalar, n×1 → vector).
    pub fn from_dims(r: usize, c: usize) -> Shape {
        match (r, c) {
            (1, 1) => Shape::Scalar,
            (n, 1) => Shape::Vector(n),
            _ => Shape::Matrix(r, c),
        }
    }

    /// The Rust type of a value of this shape over `T` (parameters, accessors).
    pub fn rust_type(self) -> String {
        match self {
            Shape::Scalar => "T".into(),
            Shape::Vector(n) => format!("[T; {n}]"),
            Shape::Matrix(r, c) => format!("[[T; {c}]; {r}]"),
        }
    }
}

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

/// A shaped value.
#[derive(Clone, Debug)]
pub struct Value {
    /// Its shape.
    pub shape: Shape,
    /// Its components, column-major for matrices.
    pub ids: Vec<Id>,
}

impl Value {
    /// A scalar.
    pub fn scalar(id: Id) -> Value {
        Value {
            shape: Shape::Scalar,
            ids: vec![id],
        }
    }

    /// Component (i, j) of a matrix (or (i, 0) of a vector).
    pub fn at(&self, i: usize, j: usize) -> Id {
        let (r, _) = self.shape.dims();
        self.ids[j * r + i]
    }
}
