//! The elliptic functions over any [`Float`], as generated code calls them
//! (`lasalle_runtime::elliptic::generic::sn(u, m)`): computed in `f64` by the kernels of
//! this crate, so for `T = f64` they are exactly [`ellipj`]'s, [`ellipk`]'s and [`ellipf`]'s
//! values. Parameter m = k², 0 ≤ m ≤ 1; NaN outside (see the [crate docs](crate)).

use crate::{ellipf as ellipf64, ellipj, ellipk as ellipk64};
use num_traits::Float;

fn f64_of<T: Float>(x: T) -> f64 {
    x.to_f64().unwrap_or(f64::NAN)
}

fn of_f64<T: Float>(x: f64) -> T {
    T::from(x).unwrap_or_else(T::nan)
}

/// sn(u | m).
#[inline]
pub fn sn<T: Float>(u: T, m: T) -> T {
    of_f64(ellipj(f64_of(u), f64_of(m)).sn)
}

/// cn(u | m).
#[inline]
pub fn cn<T: Float>(u: T, m: T) -> T {
    of_f64(ellipj(f64_of(u), f64_of(m)).cn)
}

/// dn(u | m).
#[inline]
pub fn dn<T: Float>(u: T, m: T) -> T {
    of_f64(ellipj(f64_of(u), f64_of(m)).dn)
}

/// K(m).
#[inline]
pub fn ellipk<T: Float>(m: T) -> T {
    of_f64(ellipk64(f64_of(m)))
}

/// F(φ | m).
#[inline]
pub fn ellipf<T: Float>(phi: T, m: T) -> T {
    of_f64(ellipf64(f64_of(phi), f64_of(m)))
}
