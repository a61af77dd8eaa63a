//! The exact reading of a mask: each ray clear, blocked or undecided against conservative
//! depth bounds ([`DepthBounds`]), for every point of the mask's sub-pixel cell.
//!
//! - **Clear** within the depth range `[z_stop, z_cut]`: a ray that enters no pixel at or
//!   below that pixel's near bound (the `solid` reading's test, over the near bounds of 2 x 2
//!   blocks) meets nothing there. Pixels whose near bound is at or below `z_cut` are skipped:
//!   the part of every ray deeper than `z_cut` is the near-field shaft's to prove, the part
//!   nearer than `z_stop` the far-field shaft's (`edge_table/exact.rs`).
//! - **Blocked**: a ray that enters a covered block below its far bound and leaves it above its
//!   near bound crosses an opaque sheet there (the seed's INTERSECTFLOOR with the slab
//!   between the two bounds).
//!
//! The tables hold heights in the mask's own units (normalised at its depth `z0`); a depth
//! `D` is reached by a ray from depth `pz` at w = 1/D - 1/pz whatever the depth, which is
//! z0 w / (1 + z0 w) in the mask's units: the comparison is exact for any `pz`, not only the
//! mask's. Thresholds move by `H_MARGIN` towards "undecided".

use super::{Cell, Mask, NONE, QueryStats};
use crate::depth_map::DepthBounds;
use crate::depth_map::DepthMap;

/// Relative and absolute slack on every height compared (a few f32 roundings of the
/// conversion and of the tables' own heights).
const H_REL: f32 = 1e-5;
const H_ABS: f32 = 1e-6;

/// `h` raised by the slack (`H_REL` of it, plus `H_ABS`): each threshold is moved by it
/// whichever way makes a claim harder.
#[inline]
fn up(h: f32) -> f32 {
    h + h.abs() * H_REL + H_ABS
}

/// `h` lowered by the slack ([`up`]'s mirror).
#[inline]
fn down(h: f32) -> f32 {
    h - h.abs() * H_REL - H_ABS
}

/// Heights at or above this are too near the light for a blocked claim: traced rays stop
/// `SHADOW_EPSILON` (1e-4) of their length short of it.
const H_LIGHT: f32 = 1.0 - 1e-3;

/// Where one exact query looks: the point's pixel and depth, and its depth range.
pub struct ExactQuery<'a> {
    pub bounds: &'a DepthBounds,
    /// The near bounds as a depth map (its pyramid culls blocks of the mask's region).
    pub near: &'a DepthMap,
    pub base: [i32; 2],
    pub pz: f32,
    /// Pixels with near bounds at or below this depth are the near-field shaft's.
    pub z_cut: f32,
    /// Crossings at or above this depth's height are the far-field shaft's.
    pub z_stop: f32,
}

impl Mask {
    /// A depth's height in this mask's units for a point at depth `pz`: -inf at or below the
    /// point, 1 at the light.
    #[inline]
    fn height_of(&self, depth: f32, pz: f32) -> f32 {
        if depth <= 0.0 {
            return 1.0;
        }
        let w = 1.0 / depth - 1.0 / pz;
        if w.is_nan() || w <= 0.0 {
            return f32::NEG_INFINITY;
        }
        let s = self.depth * w;
        if s.is_infinite() { 1.0 } else { s / (1.0 + s) }
    }

    /// Sets `clear` to the rays proven clear between `z_stop` and `z_cut`, and ORs into
    /// `blocked` the rays proven blocked. Both are over this mask's samples, `words` long.
    pub fn classify(&self, q: &ExactQuery, clear: &mut [u64], blocked: &mut [u64]) -> QueryStats {
        let clear = &mut clear[..self.words];
        let blocked = &mut blocked[..self.words];
        clear.copy_from_slice(&self.full);
        let mut stats = QueryStats::default();
        let h_cut = down(self.height_of(q.z_cut, q.pz));
        // Crossings at or above the stop are not looked at; the tables end at `h_max`.
        let h_lim = up(self.height_of(q.z_stop, q.pz)).min(self.h_max).next_down();
        let [bi, bj] = q.base;
        self.own_pixel(q, h_cut, clear);
        for b in &self.blocks {
            if b.first > h_lim {
                break;
            }
            let (lo, hi) = ([bi + b.lo[0], bj + b.lo[1]], [bi + b.hi[0], bj + b.hi[1]]);
            // Off the map anything may be there: never culled.
            if q.near.contains(lo, hi) && up(self.height_of(q.near.min_depth(lo, hi), q.pz)) < b.first {
                stats.blocks_culled += 1;
                continue;
            }
            for c in &self.cells[b.start as usize..b.end as usize] {
                if c.in_first > h_lim {
                    break;
                }
                let (i, j) = (bi + c.dx, bj + c.dy);
                let h_near = up(self.height_of(q.bounds.near2_at(i, j), q.pz));
                if h_near < c.in_first {
                    continue; // every ray enters above everything here
                }
                if h_near > h_cut {
                    stats.lookups += 1;
                    self.clear_in_cell(q, c, [i, j], h_near.min(h_lim), h_cut, clear);
                }
                let far = q.bounds.far2_at(i, j);
                if far.is_nan() {
                    continue;
                }
                // Blocked: entered under the far bound, left over the near bound, both away
                // from the point and from the light, and within the marched heights.
                let h_far = down(self.height_of(far, q.pz));
                if h_far <= H_ABS || h_far < c.in_first || h_near >= H_LIGHT || h_near >= self.h_max {
                    continue;
                }
                stats.lookups += 2;
                let Some((w0, entered)) = self.below_table(c.in_table, h_far) else { continue };
                let left = self.below_table(c.out_table, h_near);
                for (k, (o, e)) in blocked[w0..].iter_mut().zip(entered).enumerate() {
                    let not_left = match left {
                        Some((x0, x)) if w0 + k >= x0 && w0 + k - x0 < x.len() => x[w0 + k - x0],
                        _ => u64::MAX,
                    };
                    *o |= !*e & not_left;
                }
            }
        }
        stats
    }
}

/// One table's Below(q) word `w` (1 outside its span).
#[inline]
fn word(below: Option<(usize, &[u64])>, w: usize) -> u64 {
    match below {
        Some((w0, m)) if w >= w0 && w - w0 < m.len() => m[w - w0],
        _ => u64::MAX,
    }
}

impl Mask {
    /// The own pixel (no in-table: every ray starts in it, at height 0, at or under the
    /// cut). Where its block's first run lies above the cut, a ray is clear there only if it
    /// leaves the pixel under that run's far end, with the next run at or under the cut.
    fn own_pixel(&self, q: &ExactQuery, h_cut: f32, clear: &mut [u64]) {
        let [bi, bj] = q.base;
        if up(self.height_of(q.bounds.near2_at(bi, bj), q.pz)) <= h_cut {
            return;
        }
        let (end, next) = q.bounds.gap2_at(bi, bj);
        if up(self.height_of(next, q.pz)) > h_cut {
            clear.fill(0);
            return;
        }
        let h_end = down(self.height_of(end, q.pz));
        for (w, c) in clear.iter_mut().enumerate() {
            let mut left = 0u64;
            for t in self.own_out.iter().flatten() {
                left |= !word(self.below(t, h_end), w);
            }
            *c &= left;
        }
    }

    /// ANDs into `clear` the rays clear in cell `c` (map block `at`) above the cut: entered
    /// over the block's first run (near bound `h_near`, capped at the stop), or passed
    /// through the gap under it (left under the run's far end, entered over the next run or
    /// that run at or under the cut).
    #[inline]
    fn clear_in_cell(
        &self,
        q: &ExactQuery,
        c: &Cell,
        at: [i32; 2],
        h_near: f32,
        h_cut: f32,
        clear: &mut [u64],
    ) {
        let Some((w0, above)) = self.below_table(c.in_table, h_near) else { return };
        let (end, next) = q.bounds.gap2_at(at[0], at[1]);
        let h_end = down(self.height_of(end, q.pz));
        let h_next = up(self.height_of(next, q.pz));
        let through_gap = c.out_table != NONE && h_end > c.in_first;
        let left = if through_gap { self.below_table(c.out_table, h_end) } else { None };
        let entered_next =
            if through_gap && h_next > h_cut { self.below_table(c.in_table, h_next) } else { None };
        for (k, (o, a)) in clear[w0..].iter_mut().zip(above).enumerate() {
            let w = w0 + k;
            let gap = if through_gap { !word(left, w) & word(entered_next, w) } else { 0 };
            *o &= *a | gap;
        }
    }
}
