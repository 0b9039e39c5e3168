//! Storage of states, invariant values and gains: fixed size (`[T; N]`) or sized at run time
//! (`Vec<T>`), behind one trait.
//!
//! # Why a storage trait
//!
//! A model compiled ahead of time knows its dimensions when it is compiled: its state is a
//! `[T; N]`, its stacked invariants a `[T; M]`, its gains a `[T; G]`, and every loop over them
//! has a constant trip count that the compiler unrolls and vectorises. A model loaded from a
//! file at run time (`lasalle run my_model.lsl`) learns N, M and G only when it is loaded, so
//! its vectors live on the heap. The runtime's algorithms (steppers, driver, feedback field,
//! gain selection, projection, recorder, outputs) are written once, generic over a storage
//! type `X: State<T>`, and are monomorphised for both:
//!
//! - `[T; N]` — [`State::LEN`] is `Some(N)`: compiled models lose nothing, the code is the
//!   code the const-generic runtime had (the traits were `Field<T, N>` before; they are
//!   `Field<T, [T; N]>` now);
//! - `Vec<T>` — the length is the vector's own; scratch storage is allocated once, when a
//!   stepper first sees a state, never per step.
//!
//! The alternatives were worse: a `dyn`-dimension runtime alone would cost compiled models
//! their unrolled loops; a second, heap-based copy of the runtime would double every
//! algorithm; nalgebra's `Dim` with storage projections (`<D as Dim>::Buf<T>`) defeats type
//! inference at every call (`integrate(…, &x0, …)` could not infer D from `[f64; 6]`), whereas
//! with the storage type itself as the parameter the state's type *is* the inferred type.
//!
//! Matrices with one row per invariant (the Jacobian Df ∈ R^{M×N}) are [`State::Rows`] of the
//! invariants' storage: `[[T; N]; M]` for compiled models, `Vec<Vec<T>>` for loaded ones.

use std::ops::{Index, IndexMut};

/// A flat vector of scalars of fixed (`[T; N]`) or run-time (`Vec<T>`) length: a state, the
/// stacked invariants f(x), the gains. See the [module docs](crate::state) for why.
pub trait State<T>:
    Clone + PartialEq + AsRef<[T]> + AsMut<[T]> + Index<usize, Output = T> + IndexMut<usize>
{
    /// The length fixed by the type (`Some(N)` for `[T; N]`), `None` if it is known only at
    /// run time.
    const LEN: Option<usize>;

    /// Storage with one element of type `R` per component of `Self`: `[R; N]` or `Vec<R>`.
    /// The Jacobian of the invariants is `F::Rows<X>` (one state-sized row per invariant).
    type Rows<R: Clone + PartialEq>: Clone
        + PartialEq
        + AsRef<[R]>
        + AsMut<[R]>
        + Index<usize, Output = R>
        + IndexMut<usize>;

    /// A vector of `len` components, all `value`. For `[T; N]`, `len` must be `N`.
    fn filled(len: usize, value: T) -> Self;

    /// `len` rows, each a clone of `row`. For `[T; N]`, `len` must be `N`.
    fn rows<R: Clone + PartialEq>(len: usize, row: R) -> Self::Rows<R>;

    /// The number of components.
    #[inline]
    fn len(&self) -> usize {
        self.as_ref().len()
    }

    /// True for an empty vector.
    #[inline]
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The length to use for a vector of this type that must hold `len` components: `len`
    /// itself for run-time storage, and for fixed storage its `N` (checked in debug builds).
    #[inline]
    fn len_for(len: usize) -> usize {
        match Self::LEN {
            Some(n) => {
                debug_assert_eq!(n, len, "fixed-size storage of length {n} used for {len}");
                n
            }
            None => len,
        }
    }
}

impl<T: Copy + PartialEq, const N: usize> State<T> for [T; N] {
    const LEN: Option<usize> = Some(N);
    type Rows<R: Clone + PartialEq> = [R; N];

    #[inline]
    fn filled(len: usize, value: T) -> Self {
        debug_assert_eq!(len, N, "[T; {N}] filled with length {len}");
        [value; N]
    }

    #[inline]
    fn rows<R: Clone + PartialEq>(len: usize, row: R) -> [R; N] {
        debug_assert_eq!(len, N, "[R; {N}] with {len} rows");
        std::array::from_fn(|_| row.clone())
    }
}

impl<T: Clone + PartialEq> State<T> for Vec<T> {
    const LEN: Option<usize> = None;
    type Rows<R: Clone + PartialEq> = Vec<R>;

    #[inline]
    fn filled(len: usize, value: T) -> Self {
        vec![value; len]
    }

    #[inline]
    fn rows<R: Clone + PartialEq>(len: usize, row: R) -> Vec<R> {
        vec![row; len]
    }
}

/// Makes `buf` a vector of `len` components (keeping its allocation when it already has that
/// length): the lazily sized scratch storage of steppers and observers.
#[inline]
pub(crate) fn ensure_len<T: Copy, X: State<T>>(buf: &mut Option<X>, len: usize, zero: T) -> &mut X {
    if buf.as_ref().is_some_and(|b| b.len() == len) {
        return buf.as_mut().expect("checked above");
    }
    buf.insert(X::filled(X::len_for(len), zero))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrays_and_vectors_agree() {
        let a = <[f64; 3]>::filled(3, 2.0);
        let v = <Vec<f64>>::filled(3, 2.0);
        assert_eq!(a.as_ref(), v.as_slice());
        assert_eq!(<[f64; 3]>::LEN, Some(3));
        assert_eq!(<Vec<f64>>::LEN, None);
        let rows = <[f64; 2]>::rows(2, a);
        assert_eq!(rows[1], [2.0; 3]);
        let rows = <Vec<f64>>::rows(2, v.clone());
        assert_eq!(rows[1], v);
        let mut scratch: Option<Vec<f64>> = None;
        assert_eq!(ensure_len(&mut scratch, 4, 0.0).len(), 4);
        assert_eq!(ensure_len(&mut scratch, 2, 0.0).len(), 2);
    }
}
