//! A fast, deterministic hasher for the generator's own tables (node → Id, Id → Id): the
//! multiply–rotate hash of the Rust compiler's `FxHasher`. The keys are the generator's
//! own small integers and nodes, never input an adversary chooses, so the standard library's
//! SipHash (built to resist collision attacks, and several times slower on such keys) buys
//! nothing here; the hash-consing table is the generator's hottest map.

use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

/// `FxHasher`: one rotate, xor and multiply per word.
#[derive(Clone, Copy, Default)]
pub struct FxHasher {
    hash: u64,
}

const SEED: u64 = 0x51_7c_c1_b7_27_22_0a_95;

impl FxHasher {
    #[inline]
    fn add(&mut self, word: u64) {
        self.hash = (self.hash.rotate_left(5) ^ word).wrapping_mul(SEED);
    }
}

impl Hasher for FxHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            self.add(u64::from_le_bytes(c.try_into().expect("8 bytes")));
        }
        let rest = chunks.remainder();
        if !rest.is_empty() {
            let mut word = [0u8; 8];
            word[..rest.len()].copy_from_slice(rest);
            self.add(u64::from_le_bytes(word));
        }
    }
    #[inline]
    fn write_u8(&mut self, i: u8) {
        self.add(i.into());
    }
    #[inline]
    fn write_u16(&mut self, i: u16) {
        self.add(i.into());
    }
    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.add(i.into());
    }
    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.add(i);
    }
    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.add(i as u64);
    }
    #[inline]
    fn write_i32(&mut self, i: i32) {
        self.add(i as u32 as u64);
    }
    #[inline]
    fn write_isize(&mut self, i: isize) {
        self.add(i as u64);
    }
    #[inline]
    fn finish(&self) -> u64 {
        // The multiplication leaves the entropy in the high bits; the table indexes by the
        // low ones (`rustc-hash` 2 rotates the same way).
        self.hash.rotate_left(26)
    }
}

/// A hash map with [`FxHasher`].
pub type FxHashMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;
/// A hash set with [`FxHasher`].
pub type FxHashSet<K> = HashSet<K, BuildHasherDefault<FxHasher>>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distinct_keys_stay_distinct_and_equal_keys_meet() {
        let mut m: FxHashMap<(u32, u32), usize> = FxHashMap::default();
        for i in 0..300u32 {
            for j in 0..300u32 {
                m.insert((i, j), (i * 300 + j) as usize);
            }
        }
        assert_eq!(m.len(), 90_000);
        assert_eq!(m[&(17, 251)], 17 * 300 + 251);
        let mut h1 = FxHasher::default();
        let mut h2 = FxHasher::default();
        h1.write(b"twelve bytes");
        h2.write(b"twelve bytes");
        assert_eq!(h1.finish(), h2.finish());
    }
}
