//! The seeded sampler of the library's numerical checks and samples: SplitMix64 (Steele, Lea
//! & Flood, *Fast splittable pseudorandom number generators*, OOPSLA 2014), so a check gives
//! the same verdict, and a sample the same points, on every run. The tests have their own
//! generator (`lasalle_testkit::Rng`), with the helpers tests want.

/// SplitMix64: a small, fast, seeded generator with full 64-bit output.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator with this seed (any value, 0 included).
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1), on the 2⁻⁵³ grid.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in (0, 1], on the 2⁻⁵³ grid: never 0, for a logarithm (Box–Muller).
    pub fn unit_positive(&mut self) -> f64 {
        1.0 - self.unit()
    }

    /// Uniform in [a, b).
    pub fn uniform(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unit()
    }
}

#[cfg(test)]
mod tests {
    use super::Rng;

    /// The reference implementation's first outputs from seed 1234567
    /// (<https://prng.di.unimi.it/splitmix64.c>).
    #[test]
    fn splitmix64_reference_values() {
        let mut rng = Rng::new(1234567);
        let want = [
            6457827717110365317u64,
            3203168211198807973,
            9817491932198370423,
            4593380528125082431,
            16408922859458223821,
        ];
        for w in want {
            assert_eq!(rng.next_u64(), w);
        }
    }

    #[test]
    fn units_stay_in_their_intervals() {
        let mut rng = Rng::new(0);
        for _ in 0..10_000 {
            let u = rng.unit();
            assert!((0.0..1.0).contains(&u), "{u}");
            let p = rng.unit_positive();
            assert!(p > 0.0 && p <= 1.0, "{p}");
            let v = rng.uniform(-2.0, 3.0);
            assert!((-2.0..3.0).contains(&v), "{v}");
        }
    }
}
