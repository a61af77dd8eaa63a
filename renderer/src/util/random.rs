//! Deterministic random numbers keyed by (seed, pixel, sample, light), never by thread or
//! execution order, so that images are the same bytes with any thread count.
//!
//! A hand-written SplitMix64 rather than `rand`: the stream must stay fixed across crate
//! versions (cached ground truths and regression images depend on it), and `rand`'s small
//! generators are documented as not portable between versions.

/// The SplitMix64 finaliser: a bijective 64-bit mix with good avalanche.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A seed for one stream, from any number of keys.
#[inline]
pub fn stream_seed(keys: &[u64]) -> u64 {
    keys.iter().fold(0x9e37_79b9_7f4a_7c15, |h, &k| mix64(h ^ mix64(k.wrapping_add(0x632b_e59b_d9b4_e019))))
}

/// SplitMix64 generator.
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        mix64(self.state)
    }

    /// The generator `n` draws further on (SplitMix64's state moves by a constant per draw).
    #[inline]
    pub fn skip(&mut self, n: u64) {
        self.state = self.state.wrapping_add(n.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    }

    /// Uniform in [0, 1), 24 bits.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

/// The stratification grid for `n` samples: `(nx, ny)` with `nx * ny == n` and `nx` the
/// largest divisor of `n` not above sqrt(n) (32 x 32 for 1024; 1 x n for a prime n).
pub fn strata(n: u32) -> (u32, u32) {
    let mut nx = (n as f64).sqrt() as u32;
    while nx > 1 && !n.is_multiple_of(nx) {
        nx -= 1;
    }
    let nx = nx.max(1);
    (nx, n / nx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strata_cover_n_exactly() {
        assert_eq!(strata(1024), (32, 32));
        assert_eq!(strata(256), (16, 16));
        assert_eq!(strata(7), (1, 7));
        assert_eq!(strata(1), (1, 1));
        assert_eq!(strata(96), (8, 12));
    }

    #[test]
    fn uniform_mean_and_range() {
        let mut r = Rng::new(stream_seed(&[1, 2, 3]));
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        let mean = sum / n as f64;
        // Standard error of the mean is 1/sqrt(12 n) = 0.0009; allow 5 sigma.
        assert!((mean - 0.5).abs() < 0.0046, "{mean}");
    }
}
