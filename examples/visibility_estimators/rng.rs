//! Random numbers: the renderer's SplitMix64 stream and strata, with f64 draws on top.

pub use renderer::util::random::{mix64, strata};

/// The renderer's stream, its seed mixed first (seeds here are small consecutive integers).
pub struct Rng(renderer::util::random::Rng);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(renderer::util::random::Rng::new(mix64(seed)))
    }

    /// Uniform in [0, 1), 53 bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [0, 1), 24 bits (the renderer's jitter).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        self.0.next_f32()
    }
}
