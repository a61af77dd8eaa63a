//! The grid of masks over (sub-pixel x, sub-pixel y, depth level): where its depth levels
//! lie, which of its masks are built (with `mirrored`, the others are read as their mirror
//! images), and which masks a point reads.

use super::params::Blend;
use crate::depth_map::DepthMap;
use glam::Vec2;
use rayon::prelude::*;
use renderer::ShadingPoint;

/// Depth levels at quantiles of the receivers' log depths: level k at the (k + 1/2) / `gz`
/// quantile of the points the light reaches; and the deepest such point's depth. With no
/// such point, every level (and the depth) is twice the map's nearest depth (1 when nothing
/// is in front of the light).
pub(super) fn depth_levels(map: &DepthMap, visible: &[ShadingPoint], gz: u32) -> (Vec<f32>, f32) {
    // Receivers cluster (a floor facing the light has one depth), and a mask serves a point
    // exactly only at its own depth: the ray footprints of a point at depth z read through a
    // mask built at z0 are off by z0 / z. Measured against levels at the centres of equal
    // log-depth bins and at the range's ends: see docs/notes/2026-11-21-depth-level-placement.md.
    // Grazed receivers and those outside the map are traced and take no part.
    let mut log_depths: Vec<f32> = visible
        .par_iter()
        .filter(|v| !map.grazing(v) && map.query_point(v).is_some())
        .map(|v| map.frame.light_from_world(v.p).z)
        .filter(|&z| z > map.z_min && z.is_finite())
        .map(f32::ln)
        .collect();
    // Finite even where nothing at all is in front of the light (a light facing away from
    // the scene: the exact map's nearest depth is then infinite, and masks built at an
    // infinite depth marched without end, 24 GB at 40x32 pixels before this).
    let fallback_z = if map.z_min.is_finite() { map.z_min.max(1e-6) * 2.0 } else { 1.0 };
    let z_hi = log_depths.iter().copied().reduce(f32::max).map_or(fallback_z, f32::exp);
    // Quantiles by selection, not a sort (a few ms at 300k points; the value at a rank is
    // the same whichever way it is found).
    let levels: Vec<f32> = (0..gz)
        .map(|k| {
            if log_depths.is_empty() {
                return fallback_z;
            }
            let q = ((k as f32 + 0.5) / gz as f32 * log_depths.len() as f32) as usize;
            let q = q.min(log_depths.len() - 1);
            log_depths.select_nth_unstable_by(q, f32::total_cmp).1.exp()
        })
        .collect();
    (levels, z_hi)
}

/// Per level, the deepest point its masks serve (so how far they march), given the deepest
/// receiver `z_hi`.
pub(super) fn serve_depths(levels: &[f32], z_hi: f32, blend: Blend) -> Vec<f32> {
    (0..levels.len())
        .map(|k| match blend {
            Blend::Trilinear if k + 1 < levels.len() => levels[k + 1],
            Blend::Nearest if k + 1 < levels.len() => (levels[k] * levels[k + 1]).sqrt(),
            _ => z_hi.max(levels[k]),
        })
        .collect()
}

/// Grid cell `m`'s (sub-pixel column, sub-pixel row, depth level) on a `dims` grid.
#[inline]
pub(super) fn coordinates(m: u32, dims: [u32; 3]) -> [u32; 3] {
    let [gx, gy, _] = dims;
    [m % gx, (m / gx) % gy, m / (gx * gy)]
}

/// Which grid cells get a mask of their own, and which mask every cell reads.
pub(super) struct Layout {
    /// The grid cells whose masks are built, ascending.
    pub built: Vec<u32>,
    /// Per grid cell, indexed [depth level][sub-pixel y][sub-pixel x]: the mask built for it
    /// (an index into `built`) and whether it is read mirrored in x and y.
    pub cells: Vec<(u32, [bool; 2])>,
}

impl Layout {
    pub fn new(dims: [u32; 3], mirrored: bool) -> Self {
        let [gx, gy, gz] = dims;
        // With `mirrored`, a sub-pixel column a > (gx - 1) / 2 is read as column gx - 1 - a
        // mirrored (likewise rows); only the others are built.
        let fold = |a: u32, g: u32| if mirrored && a > (g - 1) / 2 { (g - 1 - a, true) } else { (a, false) };
        let mut built_index = vec![u32::MAX; (gx * gy * gz) as usize];
        let mut built = Vec::new();
        for m in 0..gx * gy * gz {
            let (ax, ay) = (m % gx, (m / gx) % gy);
            if !fold(ax, gx).1 && !fold(ay, gy).1 {
                built_index[m as usize] = built.len() as u32;
                built.push(m);
            }
        }
        let cells: Vec<(u32, [bool; 2])> = (0..gx * gy * gz)
            .map(|m| {
                let ((ax, mx), (ay, my), k) = (fold(m % gx, gx), fold((m / gx) % gy, gy), m / (gx * gy));
                (built_index[((k * gy + ay) * gx + ax) as usize], [mx, my])
            })
            .collect();
        Self { built, cells }
    }
}

/// The grid as prepared for one light: how a point picks its masks.
pub(super) struct MaskGrid {
    pub dims: [u32; 3],
    pub blend: Blend,
    /// Depth of each level (ascending).
    pub levels: Vec<f32>,
    /// See [`Layout::cells`].
    pub cells: Vec<(u32, [bool; 2])>,
}

impl MaskGrid {
    /// The mask grid cell `g` reads and whether it reads it mirrored in x and y.
    #[inline]
    pub fn mask(&self, g: usize) -> (u32, [bool; 2]) {
        self.cells[g]
    }

    /// Weighted masks for a point at sub-pixel `offset` and depth `pz`: up to 8 (grid cell,
    /// pixel shift, weight).
    pub fn select(&self, offset: Vec2, pz: f32, out: &mut [(usize, [i32; 2], f32); 8]) -> usize {
        let [gx, gy, gz] = self.dims;
        let level_pos = level_position(&self.levels, pz);
        let index = |a: i32, b: i32, k: u32| -> (usize, [i32; 2]) {
            let (sx, ax) = (a.div_euclid(gx as i32), a.rem_euclid(gx as i32));
            let (sy, ay) = (b.div_euclid(gy as i32), b.rem_euclid(gy as i32));
            (((k * gy + ay as u32) * gx + ax as u32) as usize, [sx, sy])
        };
        match self.blend {
            Blend::Nearest => {
                let a = ((offset.x * gx as f32) as i32).min(gx as i32 - 1);
                let b = ((offset.y * gy as f32) as i32).min(gy as i32 - 1);
                let (m, shift) = index(a, b, level_pos.round() as u32);
                out[0] = (m, shift, 1.0);
                1
            }
            Blend::Trilinear => {
                let tx = offset.x * gx as f32 - 0.5;
                let ty = offset.y * gy as f32 - 0.5;
                let (ax, ay) = (tx.floor(), ty.floor());
                let (wx, wy) = (tx - ax, ty - ay);
                let k0 = (level_pos.floor() as u32).min(gz - 1);
                let wz = level_pos - k0 as f32;
                let mut count = 0;
                for (dk, wk) in [(0u32, 1.0 - wz), (1, wz)] {
                    if wk <= 0.0 || k0 + dk >= gz {
                        continue;
                    }
                    for (db, wb) in [(0, 1.0 - wy), (1, wy)] {
                        for (da, wa) in [(0, 1.0 - wx), (1, wx)] {
                            let w = wk * wb * wa;
                            if w > 0.0 {
                                let (m, shift) = index(ax as i32 + da, ay as i32 + db, k0 + dk);
                                out[count] = (m, shift, w);
                                count += 1;
                            }
                        }
                    }
                }
                count
            }
        }
    }
}

/// Where depth `pz` falls among the (ascending) depth levels: k + f between levels k and
/// k + 1, linear in log depth, clamped to the first and last level.
fn level_position(levels: &[f32], pz: f32) -> f32 {
    let k = levels.partition_point(|&l| l <= pz);
    if k == 0 {
        return 0.0;
    }
    if k == levels.len() {
        return (levels.len() - 1) as f32;
    }
    let (lo, hi) = (levels[k - 1], levels[k]);
    let f = (pz / lo).ln() / (hi / lo).ln();
    // Equal levels (many receivers at one depth) give 0/0: use the lower one.
    (k - 1) as f32 + if f.is_finite() { f.clamp(0.0, 1.0) } else { 0.0 }
}
