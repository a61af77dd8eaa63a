//! Random numbers: SplitMix64, as the renderer's `Rng`; and the renderer's strata.

pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(mix64(seed))
    }

    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        (mix64(self.0) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [0, 1), 24 bits (the renderer's jitter).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        (mix64(self.0) >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// `strata` of the renderer: nx the largest divisor of n not above sqrt(n).
pub fn strata(n: u32) -> (u32, u32) {
    let mut nx = (n as f64).sqrt() as u32;
    while nx > 1 && !n.is_multiple_of(nx) {
        nx -= 1;
    }
    let nx = nx.max(1);
    (nx, n / nx)
}
