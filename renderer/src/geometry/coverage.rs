//! glTF's `alphaMode = BLEND` read as coverage, as path tracers read it: a surface of alpha
//! a stops a share a of what crosses it, for camera rays, bounces and shadow rays alike.
//!
//! Each point of a BLEND surface is opaque or a hole by a threshold of its own, a keyed hash
//! of where it lies: its triangle (instance and index in its mesh, [`TriangleOrigin`]: the
//! same for a flattened copy and a kept one, whatever the BVH order) and the exact bits of
//! its barycentric weights there. The point is a hole where its alpha is below the threshold.
//! So the surface is an alpha mask whose pattern is white noise of density a: a pure
//! function of the point, the same for every ray and every method that tests that point
//! (`traced`'s shadow rays, the camera's, the bounces', the edge methods' samples of their
//! alpha-tested leaves, the depth map's rays), whatever the thread count. A ray meets a new
//! point of the pattern each time (the bits of its barycentrics differ), so an estimate over
//! many rays converges to the share a. Rejected: a per-ray random stream (the edge methods
//! test points on a leaf without a ray and could not reproduce it).
//!
//! The thresholds are `(k + 1/2) / 2^16`, k the hash's top 16 bits: none is 0 or 1, so
//! alpha 0 is a hole everywhere and alpha 1 opaque everywhere, even read just under 1 by a
//! bilinear filter's rounding (a 24-bit threshold could fall above it); the share a is met
//! to 2^-17.

use crate::geometry::instances::TriangleOrigin;
use crate::util::random::mix64;

/// The lowest threshold: an alpha under it is a hole at every point.
pub const COVERAGE_MIN: f32 = 0.5 / 65536.0;
/// The highest threshold: an alpha at or over it is opaque at every point.
pub const COVERAGE_MAX: f32 = 1.0 - 0.5 / 65536.0;

/// Keys the hash, so that the pattern is not that of some other use of [`mix64`].
const COVERAGE_KEY: u64 = 0x626c_656e_645f_6376;

/// Where a hit of a BLEND surface lies, as its coverage reads it, and COLOR_0's alpha there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoveragePoint {
    /// Its triangle's instance and index in its mesh; for a triangle of no mesh
    /// ([`TriangleOrigin::LOOSE`]), instance `u32::MAX` and its slot as `local`.
    pub triangle: TriangleOrigin,
    /// The barycentric weights of the triangle's second and third corners (the
    /// intersector's own for a ray's hit).
    pub b1: f32,
    pub b2: f32,
    /// COLOR_0's alpha interpolated there; 1 where the triangle has none.
    pub color_alpha: f32,
}

impl CoveragePoint {
    /// The point's threshold, in [[`COVERAGE_MIN`], [`COVERAGE_MAX`]]: a hole where the
    /// alpha is below it. Two rounds of SplitMix64's finalizer: one over the triangle, one
    /// over the position on it (-0.0 read as 0.0: one point).
    #[inline]
    pub fn threshold(&self) -> f32 {
        let t = self.triangle;
        let triangle = (t.instance as u64) << 32 | t.local as u64;
        let at = ((self.b1 + 0.0).to_bits() as u64) << 32 | (self.b2 + 0.0).to_bits() as u64;
        let h = mix64(mix64(triangle ^ COVERAGE_KEY) ^ at);
        // Exact in f32: k + 1/2 needs 17 bits, and the scale is a power of two.
        ((h >> 48) as f32 + 0.5) * (1.0 / 65536.0)
    }

    /// Whether the point is a hole for a surface alpha `alpha` (factor x texture) there.
    #[inline]
    pub fn is_hole(&self, alpha: f32) -> bool {
        alpha * self.color_alpha < self.threshold()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::random::Rng;

    fn point(instance: u32, local: u32, b1: f32, b2: f32) -> CoveragePoint {
        CoveragePoint { triangle: TriangleOrigin { instance, local }, b1, b2, color_alpha: 1.0 }
    }

    /// Points drawn uniformly over triangles: the share opaque is alpha within 4.5 standard
    /// deviations of a binomial share (sqrt(a (1 - a) / n)) plus the thresholds' 2^-17.
    #[test]
    fn the_share_opaque_is_the_alpha() {
        let mut rng = Rng::new(7);
        let n = 200_000;
        for alpha in [0.01f32, 0.1, 0.3, 0.5, 0.7, 0.99] {
            let opaque = (0..n)
                .filter(|&i| {
                    let (u, v) = (rng.next_f32(), rng.next_f32());
                    let (b1, b2) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
                    !point(i % 7, i % 1000, b1, b2).is_hole(alpha)
                })
                .count();
            let share = opaque as f64 / n as f64;
            let a = alpha as f64;
            let tol = 4.5 * (a * (1.0 - a) / n as f64).sqrt() + 1.0 / 131072.0;
            assert!((share - a).abs() < tol, "alpha {alpha}: share opaque {share}, tolerance {tol}");
        }
    }

    /// Alpha 0 is a hole everywhere and alpha 1 opaque everywhere, and so is an alpha a
    /// bilinear filter's rounding reads just under 1 (1 - 2^-24): the thresholds are the
    /// 2^16 values (k + 1/2) / 2^16 exactly.
    #[test]
    fn alpha_zero_and_one_are_exact() {
        let mut rng = Rng::new(3);
        let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
        for i in 0..100_000u32 {
            let p = point(i % 3, i, rng.next_f32(), rng.next_f32());
            let t = p.threshold();
            assert_eq!(((t * 65536.0 - 0.5).fract(), t * 65536.0 < 65536.0), (0.0, true), "{t}");
            (lo, hi) = (lo.min(t), hi.max(t));
            assert!(p.is_hole(0.0) && !p.is_hole(1.0) && !p.is_hole(1.0 - f32::EPSILON / 2.0));
        }
        assert!(lo >= COVERAGE_MIN && hi <= COVERAGE_MAX, "{lo} {hi}");
    }

    /// The threshold is a function of the point alone, and other triangles (or positions
    /// one ulp away) draw other values: -0.0 and 0.0 are one point.
    #[test]
    fn the_pattern_is_keyed_by_the_point() {
        let p = point(2, 5, 0.25, 0.5);
        assert_eq!(p.threshold(), point(2, 5, 0.25, 0.5).threshold());
        assert_eq!(point(2, 5, 0.0, 0.5).threshold(), point(2, 5, -0.0, 0.5).threshold());
        let others = [
            point(3, 5, 0.25, 0.5),
            point(2, 6, 0.25, 0.5),
            point(2, 5, 0.25f32.next_up(), 0.5),
            point(2, 5, 0.25, 0.5f32.next_down()),
        ];
        for q in others {
            assert_ne!(p.threshold(), q.threshold(), "{q:?}");
        }
    }
}
