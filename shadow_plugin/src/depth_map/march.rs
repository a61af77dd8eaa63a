//! Walking one shadow ray through the depth map's pixel frusta, and the walls-and-floors
//! reading of the map (Agrawala et al. 2000) that decides whether it is blocked.
//!
//! In light space a shadow ray from P (depth `Pz`, image point g_P in pixel units) to the
//! light sample L = (Lx, Ly, 0) is, with s = t / (1 - t) in [0, inf):
//! image(s) = g_P + s (Lx, Ly) / (Pz * pitch), and its normalised height above P is
//! h = zeta / Pz = s / (1 + s) (technical note, section 2.2). Both `edge_table` (at build
//! time) and `depth_march` (per ray) use [`for_each_crossing`], so they see the same
//! crossings with the same floating-point values: the differential test relies on it.
//!
//! Each pixel is a floor at normalised height H(c) = 1 - D(c) / Pz (D: the biased depth);
//! "at or below the floor" (h <= H, ties block) is inside the solid the map implies. See
//! [`Heightfield`] for the readings and [`ray_blocked`] for the per-ray rule.

use crate::depth_map::heightfield::Heightfield;
use glam::Vec2;

/// Calls `visit(cell, axis, h)` for each pixel the ray enters (axis 0: through a vertical
/// side, 1: a horizontal one), in order, with the cell relative to
/// P's pixel and the normalised height at which it enters; stops at `h_stop` or when
/// `visit` returns false. `offset` is P's position inside its pixel, in [0, 1)^2;
/// `pz_pitch` is P's depth times the map's pixel pitch.
///
/// Conventions: a ray through a pixel corner (equal crossing parameters) steps in x first;
/// a sample with Lx = 0 never crosses a vertical side (likewise y).
#[inline]
pub fn for_each_crossing(
    offset: Vec2,
    sample: Vec2,
    pz_pitch: f32,
    h_stop: f32,
    mut visit: impl FnMut([i32; 2], u8, f32) -> bool,
) {
    // s at the k-th vertical side: (k - offset.x) * pz_pitch / Lx, computed directly for
    // every side (not accumulated) so every caller gets bit-identical values.
    let (step_x, mut kx, scale_x) = axis(sample.x, pz_pitch);
    let (step_y, mut ky, scale_y) = axis(sample.y, pz_pitch);
    let mut sx = if step_x == 0 { f32::INFINITY } else { (kx as f32 - offset.x) * scale_x };
    let mut sy = if step_y == 0 { f32::INFINITY } else { (ky as f32 - offset.y) * scale_y };
    let mut cell = [0i32, 0i32];
    loop {
        let (s, axis);
        if sx <= sy {
            if sx == f32::INFINITY {
                return;
            }
            (s, axis) = (sx, 0);
            cell[0] += step_x;
            kx += step_x;
            sx = (kx as f32 - offset.x) * scale_x;
        } else {
            (s, axis) = (sy, 1);
            cell[1] += step_y;
            ky += step_y;
            sy = (ky as f32 - offset.y) * scale_y;
        }
        let h = s / (1.0 + s);
        if h >= h_stop || !visit(cell, axis, h) {
            return;
        }
    }
}

/// (step, first side index, s per pixel) along one axis.
#[inline]
fn axis(l: f32, pz_pitch: f32) -> (i32, i32, f32) {
    if l > 0.0 {
        (1, 1, pz_pitch / l)
    } else if l < 0.0 {
        (-1, 0, pz_pitch / l)
    } else {
        (0, 0, f32::INFINITY)
    }
}

/// The normalised floor height of a pixel with biased depth `depth`, seen from depth `pz`.
#[inline]
pub fn floor_height(depth: f32, pz: f32) -> f32 {
    1.0 - depth / pz
}

/// The height above which a ray from depth `pz` is above every floor of a map whose nearest
/// (biased) depth is `z_min`.
#[inline]
pub fn stop_height(z_min: f32, pz: f32) -> f32 {
    1.0 - z_min / pz
}

/// The pixel reach of a filter region, per axis: a ray from depth `pz` toward a light of
/// half size `half_size` moves at most this many pixels before it is above depth `z_stop`.
#[inline]
pub fn region_reach(half_size: Vec2, pitch: f32, z_stop: f32, pz: f32) -> [i32; 2] {
    // Capped so that pixel arithmetic on it cannot overflow (a depth of 0 reaches forever;
    // no map is a million pixels wide).
    let r = (half_size * ((1.0 / z_stop - 1.0 / pz).max(0.0) / pitch)).min(Vec2::splat(1e6));
    [r.x.ceil() as i32 + 1, r.y.ceil() as i32 + 1]
}

/// Whether one ray is blocked, marched pixel by pixel: the oracle for the edge tables.
/// `floor(cell)` is the normalised (floor, slab bottom) heights of a pixel relative to P's;
/// only `Plates` reads the slab bottom (it equals the floor for infinitely thin plates).
///
/// Solid (variant A): blocked iff P starts at or below its own floor or the ray ever enters
/// a pixel at or below its floor. Shells (variant B): blocked iff the ray rises through a
/// floor it entered under (INTERSECTFLOOR), or crosses from above one floor to under a
/// higher one (a front-facing wall, INTERSECTWALL). Plates: floors only. The march ends
/// above every floor, so a ray still under its last pixel's floor then rises through it.
#[inline]
pub fn ray_blocked(
    offset: Vec2,
    sample: Vec2,
    pz_pitch: f32,
    h_stop: f32,
    heightfield: Heightfield,
    floor: impl Fn([i32; 2]) -> (f32, f32),
) -> bool {
    let (h_own, bottom_own) = floor([0, 0]);
    let mut under = h_own >= 0.0; // P itself is at height 0
    if under && heightfield == Heightfield::Solid {
        return true;
    }
    let mut h_prev_floor = h_own;
    let mut h_prev_bottom = bottom_own;
    let mut blocked = false;
    for_each_crossing(offset, sample, pz_pitch, h_stop, |c, _, h| {
        let (h_floor, h_bottom) = floor(c);
        let through_floor = under && h > h_prev_floor;
        blocked = match heightfield {
            Heightfield::Solid => h <= h_floor,
            Heightfield::Shells => through_floor || (h_prev_floor < h && h <= h_floor),
            // Through the slab: entered at or below its top, left above its bottom.
            Heightfield::Plates => under && h > h_prev_bottom,
        };
        under = h <= h_floor;
        h_prev_floor = h_floor;
        h_prev_bottom = h_bottom;
        !blocked
    });
    blocked || (heightfield != Heightfield::Solid && under)
}
