//! Light samples in the light's frame (z = 0) and the horizon test against them.

use crate::bits;
use crate::depth_map::LightFrame;
use glam::{Vec2, Vec3};
use renderer::sampling::{Rng, strata};

/// Writes `out.len()` stratified, jittered samples over the light (an nx x ny grid, see
/// [`strata`]), in the light's frame.
#[inline]
pub fn stratified(out: &mut [Vec2], half_size: Vec2, rng: &mut Rng) {
    let (nx, ny) = strata(out.len() as u32);
    for (i, s) in out.iter_mut().enumerate() {
        let (cx, cy) = (i as u32 % nx, i as u32 / nx);
        let a = (cx as f32 + rng.next_f32()) / nx as f32;
        let b = (cy as f32 + rng.next_f32()) / ny as f32;
        *s = Vec2::new((2.0 * a - 1.0) * half_size.x, (2.0 * b - 1.0) * half_size.y);
    }
}

/// Bits of the samples above the tangent plane of (p, n): the part of the light that the
/// irradiance counts and visibility is a fraction of. Returns whether every sample is above
/// (the common case, answered from the light's corners without touching the samples).
#[inline]
pub fn above_horizon(frame: &LightFrame, samples: &[Vec2], p: Vec3, n: Vec3, out: &mut [u64]) -> bool {
    let n_samples = samples.len();
    let corners = [Vec2::new(-1.0, -1.0), Vec2::new(1.0, -1.0), Vec2::new(1.0, 1.0), Vec2::new(-1.0, 1.0)];
    let all_above = corners.iter().all(|c| {
        let w = frame.world_from_light((*c * frame.half_size).extend(0.0));
        n.dot(w - p) > 0.0
    });
    bits::fill_first(out, n_samples);
    if all_above {
        return true;
    }
    // n . (C + Lx x + Ly y - p) > 0, with the sample-independent parts taken out: two
    // multiply-adds per sample instead of a frame transform.
    let (a, b, c) = (n.dot(frame.x), n.dot(frame.y), n.dot(frame.origin - p));
    for (r, s) in samples.iter().enumerate() {
        if a * s.x + b * s.y + c <= 0.0 {
            out[r / 64] &= !(1u64 << (r % 64));
        }
    }
    false
}
