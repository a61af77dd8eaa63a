//! Fixed-capacity bit sets over light samples, on the stack: queries must not allocate.

/// Most light samples a depth-map method takes (64 words of 64 bits).
pub const MAX_SAMPLES: usize = 4096;
pub const MAX_WORDS: usize = MAX_SAMPLES / 64;

/// Words needed for `n` samples.
#[inline]
pub fn words(n: usize) -> usize {
    n.div_ceil(64)
}

/// Sets the first `n` bits of `out` (and clears the rest of its `words(n)` words).
#[inline]
pub fn fill_first(out: &mut [u64], n: usize) {
    for (w, word) in out.iter_mut().enumerate() {
        let lo = w * 64;
        *word = if n >= lo + 64 {
            u64::MAX
        } else if n > lo {
            (1u64 << (n - lo)) - 1
        } else {
            0
        };
    }
}

#[inline]
pub fn count(bits: &[u64]) -> u32 {
    bits.iter().map(|w| w.count_ones()).sum()
}

#[inline]
pub fn count_and(a: &[u64], b: &[u64]) -> u32 {
    a.iter().zip(b).map(|(x, y)| (x & y).count_ones()).sum()
}
