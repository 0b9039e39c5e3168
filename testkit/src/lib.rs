//! What the workspace's tests, fuzz example and benches share (a dev-dependency only).
//!
//! [`CountingAllocator`] counts the allocations of the current thread, for tests that assert a
//! hot loop allocates nothing (install it with `#[global_allocator]` in the test file).
//!
//! [`Rng`] is the one random generator of the tests: the library's seeded SplitMix64
//! ([`lasalle_model::Rng`], which the conservation checks and sampled bounds use) with the
//! helpers tests want, seeded explicitly, so every failure reproduces from the seed printed
//! with it.
//!
//! [`same`] and [`assert_same`] are what "bitwise" means in the tests: equal bits, so `0.0`
//! and `-0.0` differ, and NaN equals NaN (where `==` says the opposite of both).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

/// The system allocator, counting this thread's allocations and reallocations:
/// `#[global_allocator] static GLOBAL: CountingAllocator = CountingAllocator;`.
pub struct CountingAllocator;

// SAFETY: every call is forwarded to the system allocator unchanged.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// The allocations of this thread so far (with [`CountingAllocator`] installed).
pub fn allocations() -> u64 {
    ALLOCATIONS.with(|c| c.get())
}

/// The library's seeded generator ([`lasalle_model::Rng`], SplitMix64) with what tests want
/// of it besides: picks, signs, arrays, decades.
#[derive(Clone, Debug)]
pub struct Rng(lasalle_model::Rng);

impl Rng {
    /// A generator from a seed (any value, 0 included).
    pub fn new(seed: u64) -> Self {
        Rng(lasalle_model::Rng::new(seed))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in [0, 1), on the 2⁻⁵³ grid.
    pub fn unit(&mut self) -> f64 {
        self.0.unit()
    }

    /// Uniform in [a, b).
    pub fn uniform(&mut self, a: f64, b: f64) -> f64 {
        self.0.uniform(a, b)
    }

    /// 10ᵘ with u uniform in [lo, hi): log-uniform over the decades 10^lo to 10^hi.
    pub fn decade(&mut self, lo: f64, hi: f64) -> f64 {
        10f64.powf(self.uniform(lo, hi))
    }

    /// N values uniform in [a, b).
    pub fn array<const N: usize>(&mut self, a: f64, b: f64) -> [f64; N] {
        std::array::from_fn(|_| self.uniform(a, b))
    }

    /// Uniform in 0..n (n > 0; the modulo bias, below 2⁻⁵⁰ for the small n of tests, is
    /// irrelevant here).
    pub fn below(&mut self, n: usize) -> usize {
        assert!(n > 0, "Rng::below(0)");
        (self.next_u64() % n as u64) as usize
    }

    /// A uniformly chosen element of a non-empty slice.
    pub fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }

    /// True with probability p.
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    /// ±u with u uniform in [lo, hi) and either sign equally likely: values bounded away from
    /// zero (0 < lo) and of both signs.
    pub fn signed(&mut self, lo: f64, hi: f64) -> f64 {
        self.sign() * self.uniform(lo, hi)
    }

    /// ±1 with equal probability.
    pub fn sign(&mut self) -> f64 {
        if self.next_u64() & 1 == 0 {
            1.0
        } else {
            -1.0
        }
    }
}

/// The Pleiades (seven bodies in the plane) of the IVP test set at t = 3: x₁…x₇, y₁…y₇,
/// ẋ₁…ẋ₇, ẏ₁…ẏ₇, the 16 digits as published (Mazzia & Magherini, *Test Set for Initial Value
/// Problem Solvers*, the Pleiades problem, reference solution), for `tests/models/pleiades.lsl`
/// and `models/pleiades.lsl`.
#[allow(clippy::excessive_precision)]
pub const PLEIADES_AT_3: [f64; 28] = [
    0.3706139143970502,
    3.237284092057233,
    -3.222559032418324,
    0.6597091455775310,
    0.3425581707156584,
    1.562172101400631,
    -0.7003092922212495,
    -3.943437585517392,
    -3.271380973972550,
    5.225081843456543,
    -2.590612434977470,
    1.198213693392275,
    -0.2429682344935824,
    1.091449240428980,
    3.417003806314313,
    1.354584501625501,
    -2.590065597810775,
    2.025053734714242,
    -1.155815100160448,
    -0.8072988170223021,
    0.5952396354208710,
    -3.741244961234010,
    0.3773459685750630,
    0.9386858869551073,
    0.3667922227200571,
    -0.3474046353808490,
    2.344915448180937,
    -1.947020434263292,
];

/// The repository's model files (`models/*.lsl`), sorted: what the tests that run over every
/// model (back ends, tapes, lanes) iterate on.
pub fn model_files() -> Vec<std::path::PathBuf> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../models");
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .expect("the models/ folder")
        .map(|e| e.expect("an entry of models/").path())
        .filter(|p| p.extension().is_some_and(|e| e == "lsl"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 6, "models/ has {} models", paths.len());
    paths
}

/// The same f64, bit for bit: `0.0` and `-0.0` differ, and any NaN equals any NaN (the sign
/// and payload bits of a NaN may differ between back ends). What the tests mean by "bitwise".
pub fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Panics unless `a` and `b` have the same length and are [`same`] entry by entry, naming
/// `what` and the first entry that differs.
#[track_caller]
pub fn assert_same(a: &[f64], b: &[f64], what: impl std::fmt::Display) {
    assert_eq!(a.len(), b.len(), "{what}: lengths differ");
    if let Some(i) = (0..a.len()).find(|&i| !same(a[i], b[i])) {
        panic!(
            "{what}: entry {i} differs bitwise: {:e} ({:#018x}) vs {:e} ({:#018x})",
            a[i],
            a[i].to_bits(),
            b[i],
            b[i].to_bits()
        );
    }
}

/// Whether `a` and `b` are [`same`] or differ by at most `max` ulps of `scale` (the largest
/// magnitude of the vector they belong to: a sum that cancels keeps its absolute error).
pub fn within_ulps(a: f64, b: f64, max: u64, scale: f64) -> bool {
    same(a, b) || (a - b).abs() <= max as f64 * f64::EPSILON * scale
}

/// Panics unless `a` and `b` have the same length and each entry of `a` is [`within_ulps`] of
/// `b`'s, in ulps of `b`'s largest magnitude (`max` = 0: [`assert_same`]).
#[track_caller]
pub fn assert_within_ulps(a: &[f64], b: &[f64], max: u64, what: impl std::fmt::Display) {
    assert_eq!(a.len(), b.len(), "{what}: lengths differ");
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if let Some(i) = (0..a.len()).find(|&i| !within_ulps(a[i], b[i], max, scale)) {
        panic!(
            "{what}: entry {i} differs by more than {max} ulps of {scale:e}: {:e} vs {:e}",
            a[i], b[i]
        );
    }
}

/// Model files of `models/` whose emitted code is known to differ from the tape in the last
/// bits, with the largest difference in ulps the tests allow: the FPUT chain (its emitted
/// scalar field and its emitted lanes sum the springs' forces in different orders), in ulps of
/// the largest entry of each function's values. Every other model file agrees bitwise.
pub const KNOWN_ULPS: &[(&str, u64)] = &[("fput.lsl", 32)];

/// The ulps a model file's emitted code may differ by ([`KNOWN_ULPS`]; 0 for the others).
pub fn known_ulps(file: &str) -> u64 {
    KNOWN_ULPS
        .iter()
        .find(|(f, _)| *f == file)
        .map_or(0, |&(_, u)| u)
}

#[cfg(test)]
mod tests {
    use super::Rng;

    #[test]
    fn ranges_hold() {
        let mut r = Rng::new(0);
        for _ in 0..10_000 {
            let u = r.uniform(-2.0, 3.0);
            assert!((-2.0..3.0).contains(&u));
            assert!(r.below(7) < 7);
            let s = r.signed(0.5, 1.5);
            assert!((0.5..1.5).contains(&s.abs()), "{s}");
        }
        for _ in 0..1000 {
            let d = r.decade(-300.0, 300.0);
            assert!((1e-300..1e300).contains(&d), "{d}");
        }
        let mean = (0..100_000).map(|_| r.unit()).sum::<f64>() / 1e5;
        assert!((mean - 0.5).abs() < 0.005, "mean {mean}");
    }
}
