//! Shaped values: scalars, vectors and matrices whose components are DAG nodes.

use crate::ir::Id;

pub use lasalle_layout::Shape;

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
