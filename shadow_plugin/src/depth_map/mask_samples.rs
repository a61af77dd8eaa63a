//! Light samples in the light's frame (z = 0) and the horizon test against them.

use crate::depth_map::LightFrame;
use crate::depth_map::bits;
use glam::Vec2;
use renderer::ShadingPoint;
use renderer::util::random::{Rng, strata};

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

/// Bits of the samples above `point`'s horizon (the tangent plane of its shading normal):
/// the part of the light that the irradiance counts and visibility is a fraction of. Returns whether every sample is above
/// (the common case, answered from the light's corners without touching the samples).
/// `mirror` (each component 1 or -1) reflects the samples across the light's axes first
/// (a mirrored edge-table mask's samples); the light's corners are symmetric.
#[inline]
pub fn above_horizon(
    frame: &LightFrame,
    samples: &[Vec2],
    mirror: Vec2,
    point: &ShadingPoint,
    out: &mut [u64],
) -> bool {
    let (p, n) = (point.p, point.n_shading);
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
    let (a, b, c) = (n.dot(frame.x) * mirror.x, n.dot(frame.y) * mirror.y, n.dot(frame.origin - p));
    for (r, s) in samples.iter().enumerate() {
        if a * s.x + b * s.y + c <= 0.0 {
            out[r / 64] &= !(1u64 << (r % 64));
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// `mirror` must read as the reflected samples themselves, bit for bit, for receivers
    /// that see part of the light (the tangent plane through the light) and all of it.
    #[test]
    fn mirrored_horizon_bits_are_the_reflected_samples_bits() {
        let frame = LightFrame {
            origin: Vec3::new(0.3, 2.0, -0.1),
            x: Vec3::X,
            y: Vec3::new(0.0, 0.6, 0.8),
            z: Vec3::new(0.0, -0.8, 0.6),
            half_size: Vec2::new(0.7, 0.4),
        };
        let mut rng = Rng::new(7);
        let mut samples = vec![Vec2::ZERO; 256];
        stratified(&mut samples, frame.half_size, &mut rng);
        let (mut partial, mut all) = (0, 0);
        for k in 0..200 {
            let p = Vec3::new(rng.next_f32() - 0.5, 2.0 + rng.next_f32() - 0.5, rng.next_f32() - 0.5);
            let a = k as f32 * 0.7;
            // Every other receiver faces the light's centre (wholly above, mostly).
            let n = if k % 2 == 0 {
                (frame.origin - p).normalize()
            } else {
                Vec3::new(a.cos() * 0.9, a.sin() * 0.9, 0.44 * (k % 3) as f32 - 0.44).normalize()
            };
            for mirror in [Vec2::new(-1.0, 1.0), Vec2::new(1.0, -1.0), Vec2::new(-1.0, -1.0)] {
                let reflected: Vec<Vec2> = samples.iter().map(|s| *s * mirror).collect();
                let (mut got, mut want) = ([0u64; 4], [0u64; 4]);
                let point = ShadingPoint { p, p_error: Vec3::ZERO, n_geom: n, n_shading: n };
                let g = above_horizon(&frame, &samples, mirror, &point, &mut got);
                let w = above_horizon(&frame, &reflected, Vec2::ONE, &point, &mut want);
                assert_eq!((g, got), (w, want), "point {p}, normal {n}, mirror {mirror}");
                let c = bits::count(&want);
                partial += (c > 0 && c < 256) as u32;
                all += g as u32;
            }
        }
        assert!(partial > 60 && all > 60, "{partial} partly and {all} wholly above");
    }
}
