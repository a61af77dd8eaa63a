//! The exact reading (`reading = "exact"`, the default): the masks classify each of a
//! point's rays clear, blocked or undecided against conservative depth bounds, and only the
//! undecided ones are traced through the BVH, with the renderer's one origin rule. The
//! visibility is then exactly that of tracing every ray of the mask's sample set.
//!
//! A ray from a point at depth `pz` to the light is split by depth into three parts, each
//! proven on its own:
//!
//! - **near field** (deeper than `z_cut`, the nearest bound of the 3 x 3 blocks around the
//!   point: the receiver's own surface lies there): a shaft from the point's ray origin to the
//!   light, cut under the tangent plane and clipped to that depth range, proven empty through
//!   the BVH (whole light, then quarters, then sixteenths);
//! - **mid field** (`z_stop` to `z_cut`): the mask's tables against the near bounds
//!   ([`Mask::classify`]); `z_stop` comes from shrinking the point's region on the near
//!   bounds' min pyramid;
//! - **far field** (nearer the light than `z_stop`, or than the mask marched for this point,
//!   and off the map): the same shaft clipped to that range.
//!
//! A ray is clear when all three parts are; blocked when the tables show it crossing an opaque
//! sheet (whatever its other parts do). Anything else is traced. A point whose whole-light
//! shaft is clear is answered 1 first, as `traced` does; a point off the map traces every ray.

use super::mask::{ExactQuery, Mask};
use crate::depth_map::bits::{self, MAX_WORDS};
use crate::depth_map::march::region_reach;
use crate::depth_map::{DepthBounds, DepthMap, MapPoint};
use glam::{Vec2, Vec3};
use renderer::geometry::ray_origin::{gamma, offset_origin, shadow_ray_from};
use renderer::geometry::shaft::{Cover, covers_light};
use renderer::methods::irradiance_share::IrradianceShare;
use renderer::{RectLight, Scene, ShadowQuery, Shaft};

/// Relative distance of the near field's cut above the nearest bound around the point.
pub const CUT_MARGIN: f32 = 1e-4;

/// Relative distance of the far field's clip above the nearest bound in the point's region.
pub const STOP_MARGIN: f32 = 1e-3;

/// Relative overlap in depth of a traced field's segment with the mid field the tables cover.
pub const SEGMENT_OVERLAP: f32 = 1e-3;

/// The share of a mask's samples that must lie above a point's horizon for the mask to answer
/// it. Measured (bench, N = 1024, every sample above the horizon counted): exact RMSE 0.026 /
/// 0.047 / 0.039 against traced's 0.0019 / 0.0021 / 0.0014 on glass-vase-flowers,
/// metal-rough-spheres and toy-car, whose curved or tilted receivers see a sliver of the
/// light: the few samples above it are noise (and none at all read 1). With 0.5, toy-car's RMSE
/// was still 1.25x traced's at 160x120 (0.0017 against 0.0014); with 0.9, 1.0x, at the same
/// cost (1.04 s against 1.04 s at N = 1024): points that lose more than a tenth of the light
/// to the horizon are few and cheap to trace.
pub const HORIZON_SHARE: f32 = 0.9;

/// Most visible points the masks' march height is estimated from.
pub const QUANTILE_POINTS: usize = 16384;

/// Most pixels a point's rays cross in the tables before the far field takes over.
pub const MAX_REACH: f32 = 12.0;

/// Light parts per axis of the finest shaft subdivision.
pub const PARTS: usize = 4;

/// A mask with what the exact reading needs beside its tables: each sample's light
/// coordinates and, per part of a `PARTS` x `PARTS` split of the light, the bits of its
/// samples.
pub struct ExactMask {
    pub mask: Mask,
    pub ab: Vec<[f32; 2]>,
    parts: Vec<[u64; MAX_WORDS]>,
}

impl ExactMask {
    pub fn new(mask: Mask, half_size: Vec2) -> Self {
        let ab: Vec<[f32; 2]> = mask
            .samples
            .iter()
            .map(|s| {
                [
                    (s.x / (2.0 * half_size.x) + 0.5).clamp(0.0, 1.0),
                    (s.y / (2.0 * half_size.y) + 0.5).clamp(0.0, 1.0),
                ]
            })
            .collect();
        let mut parts = vec![[0u64; MAX_WORDS]; PARTS * PARTS];
        for (r, [a, b]) in ab.iter().enumerate() {
            let (x, y) =
                (((a * PARTS as f32) as usize).min(PARTS - 1), ((b * PARTS as f32) as usize).min(PARTS - 1));
            parts[x + PARTS * y][r / 64] |= 1 << (r % 64);
        }
        ExactMask { mask, ab, parts }
    }

    /// The bits of the samples in parts [x0, x1) x [y0, y1) (of `PARTS` per axis), ORed
    /// into `out`.
    fn part_bits(&self, x: [usize; 2], y: [usize; 2], out: &mut [u64]) {
        for j in y[0]..y[1] {
            for i in x[0]..x[1] {
                for (o, p) in out.iter_mut().zip(&self.parts[i + PARTS * j]) {
                    *o |= *p;
                }
            }
        }
    }
}

/// The light's bounds and the light, as prepared.
pub struct ExactMap {
    pub bounds: DepthBounds,
    /// The near bounds as a depth map (locating points, the min pyramid).
    pub near: DepthMap,
    pub light: RectLight,
    pub scene_bound: f32,
}

/// Rays the tables proved clear in the mid field but one shaft could not clear its field:
/// per ray bits, and the depths bounding what is left to trace (a ray is left to trace
/// between its origin and `near_end`, or between `far_start` and the light).
#[derive(Clone, Copy)]
pub struct Split {
    pub near_pending: [u64; MAX_WORDS],
    pub far_pending: [u64; MAX_WORDS],
    pub near_end: f32,
    pub far_start: f32,
}

impl Default for Split {
    fn default() -> Self {
        Split { near_pending: [0; MAX_WORDS], far_pending: [0; MAX_WORDS], near_end: 0.0, far_start: 0.0 }
    }
}

/// One query read through one mask: what [`ExactMap::classify`] and
/// [`ExactMap::shaft_bits`] share. Built once per query, on the stack.
struct ExactRead<'a> {
    scene: &'a Scene,
    q: &'a ShadowQuery,
    m: &'a ExactMask,
    /// Where the point falls on the map (None off it, or behind the light's plane).
    mp: Option<MapPoint>,
    /// The point's ray origin above its tangent plane (`offset_origin` toward `n_geom`): the
    /// shafts' apex, and the start of every ray to a target above that plane.
    origin: Vec3,
}

/// How one exact query went, for the counters.
#[derive(Default, Clone, Copy)]
pub struct ExactStats {
    pub lookups: u64,
    pub rays_clear: u64,
    pub rays_blocked: u64,
    pub rays_traced: u64,
    pub shafts: u64,
    pub blocks_culled: u64,
    /// Of the traced rays, those traced only over the near or the far field.
    pub rays_near_traced: u64,
    pub rays_far_traced: u64,
}

impl ExactMap {
    /// The depth where a point's region stops (see the module doc): where its rays have
    /// moved `MAX_REACH` pixels, or, when nothing in that region is nearer the light, the
    /// nearest bound in it, shrunk as far as the pyramid allows (a few rounds). Beyond, the
    /// far-field shaft (one BVH query) is cheaper than the tables' region (measured: with no
    /// cap, sauerbraten-zdm2's queries spent 40% of their time reading cells).
    pub fn stop_depth(&self, pixel: [i32; 2], pz: f32) -> f32 {
        let near = &self.near;
        let region_min = |z: f32| {
            let r = region_reach(near.frame.half_size, near.pitch, z, pz);
            near.min_depth([pixel[0] - r[0], pixel[1] - r[1]], [pixel[0] + r[0], pixel[1] + r[1]])
        };
        let reach_depth = 1.0 / (MAX_REACH * near.pitch / near.frame.half_size.max_element() + 1.0 / pz);
        let start = reach_depth.max(self.bounds.z_clip);
        let mut z = region_min(start).max(start);
        for _ in 0..3 {
            let zr = region_min(z);
            if zr <= z || zr >= pz {
                break;
            }
            z = zr;
        }
        // Clearly above that nearest bound: the far-field shaft's depth clip (and its slack)
        // must not reach down to the geometry the tables already handle.
        (z * (1.0 - STOP_MARGIN)).max(self.bounds.z_clip)
    }

    /// Where a world point falls on the map (None off it, or behind the light's plane).
    #[inline]
    pub fn locate(&self, p: Vec3) -> Option<MapPoint> {
        let p = self.near.frame.light_from_world(p);
        self.near.locate(p).filter(|mp| self.near.contains(mp.pixel, mp.pixel))
    }

    /// The `quantile` of w = 1/z_stop - 1/pz over the receivers on the map: how far (in
    /// depth-independent units) the masks must march for that share of them.
    pub fn stop_reach_quantile(&self, visible: &[renderer::ShadingPoint], quantile: f64) -> f32 {
        use rayon::prelude::*;
        // `visible` is prepare's subsample (at most QUANTILE_POINTS): an estimate suffices.
        let mut needed: Vec<f32> = visible
            .par_iter()
            .filter_map(|v| {
                let mp = self.locate(v.p)?;
                let z_stop = self.stop_depth(mp.pixel, mp.z).min(self.cut_depth(mp.pixel, mp.z)).min(mp.z);
                let w = 1.0 / z_stop - 1.0 / mp.z;
                w.is_finite().then_some(w.max(0.0))
            })
            .collect();
        if needed.is_empty() {
            return 0.0;
        }
        let q = ((needed.len() - 1) as f64 * quantile) as usize;
        // No further than a ray crossing the whole map: beyond, it is off the map.
        let across = self.near.resolution as f32 * self.near.pitch / self.near.frame.half_size.max_element();
        needed.select_nth_unstable_by(q, f32::total_cmp).1.min(across)
    }

    /// The near field's depth: the nearest bound of the receiver's level in the 3 x 3 blocks
    /// around the pixel, less `CUT_MARGIN` of it, so that those blocks lie clearly below the
    /// cut (a floor facing the light has one depth: without the margin, rounding would put
    /// its own block above).
    pub fn cut_depth(&self, pixel: [i32; 2], pz: f32) -> f32 {
        let mut z = f32::INFINITY;
        for dj in -1..=0 {
            for di in -1..=0 {
                let (i, j) = (pixel[0] + di, pixel[1] + dj);
                // The receiver's level: its block's first run, or the next one where the
                // first ends clearly above the point (an occluder over it).
                let (end, next) = self.bounds.gap2_at(i, j);
                z = z.min(if end < pz * (1.0 - 1e-3) { next } else { self.bounds.near2_at(i, j) });
            }
        }
        z * (1.0 - CUT_MARGIN)
    }

    /// The depth at which a ray from depth `pz` reaches height `h` of a mask at depth `z0`.
    fn depth_at_height(h: f32, z0: f32, pz: f32) -> f32 {
        if h >= 1.0 {
            return 0.0;
        }
        let w = h / (z0 * (1.0 - h));
        1.0 / (w + 1.0 / pz)
    }

    /// Bits of the samples (of `read.m`) whose rays' part inside `[lo, hi]` (depths) lies in
    /// a shaft proven clear: the whole light, then quarters, then sixteenths of what is not.
    fn shaft_bits(&self, read: &ExactRead, lo: f32, hi: f32, out: &mut [u64], stats: &mut ExactStats) {
        let ExactRead { scene, q, m, .. } = *read;
        out.fill(0);
        let frame = &self.near.frame;
        let finite = |z: f32| if z.is_finite() { z.abs() } else { 0.0 };
        let slack = 1e-4 * finite(lo).max(finite(hi)) + gamma(64) * self.scene_bound;
        let (lo, hi) =
            (if lo.is_finite() { lo - slack } else { lo }, if hi.is_finite() { hi + slack } else { hi });
        let mut todo = [([0usize; 2], [0usize; 2]); 24];
        todo[0] = ([0, PARTS], [0, PARTS]);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (x, y) = todo[top];
            let step = 1.0 / PARTS as f32;
            let a = [x[0] as f32 * step, x[1] as f32 * step];
            let b = [y[0] as f32 * step, y[1] as f32 * step];
            let Some(shaft) = Shaft::to_part(&self.light, a, b, &q.point) else {
                continue;
            };
            stats.shafts += 1;
            if scene.shaft_clear(&shaft.clip_depth(frame.z, frame.origin, lo, hi, 0.0)) {
                m.part_bits(x, y, out);
                continue;
            }
            if x[1] - x[0] == 1 {
                continue;
            }
            let (xm, ym) = ((x[0] + x[1]) / 2, (y[0] + y[1]) / 2);
            for (xa, xb) in [(x[0], xm), (xm, x[1])] {
                for (ya, yb) in [(y[0], ym), (ym, y[1])] {
                    todo[top] = ([xa, xb], [ya, yb]);
                    top += 1;
                }
            }
        }
    }

    /// The visibility of `q` through mask `m` (bits over its samples): see the module doc.
    /// `traced_only` traces every counted ray (the reference the tests hold the
    /// classification to). None where the horizon leaves fewer than `HORIZON_SHARE` of the
    /// samples: `traced` answers those (its strata are warped onto the part above).
    pub fn visibility(
        &self,
        scene: &Scene,
        q: &ShadowQuery,
        m: &ExactMask,
        mp: Option<MapPoint>,
        traced_only: bool,
        stats: &mut ExactStats,
    ) -> Option<f32> {
        let light = &self.light;
        let frame = &self.near.frame;
        let n = m.mask.samples.len();
        let words = bits::words(n);
        let mut above = [0u64; MAX_WORDS];
        let above = &mut above[..words];
        crate::depth_map::mask_samples::above_horizon(frame, &m.mask.samples, Vec2::ONE, &q.point, above);
        let n_above = bits::count(above);
        if (n_above as f32) < HORIZON_SHARE * n as f32 {
            return None;
        }
        let origin = offset_origin(&q.point, q.point.n_geom);
        let read = ExactRead { scene, q, m, mp, origin };
        let mut decided = [0u64; MAX_WORDS];
        let decided = &mut decided[..words];
        let mut blocked = [0u64; MAX_WORDS];
        let blocked = &mut blocked[..words];
        let mut clear = [0u64; MAX_WORDS];
        let clear = &mut clear[..words];
        let mut split = Split::default();
        if !traced_only {
            split = self.classify(&read, clear, blocked, stats);
            for k in 0..words {
                decided[k] = (clear[k] | blocked[k]) & above[k];
            }
        }
        // The unblocked samples above the horizon: the clear ones, and those traced clear.
        let mut open = [0u64; MAX_WORDS];
        let open = &mut open[..words];
        for k in 0..words {
            open[k] = clear[k] & above[k];
        }
        let mut unblocked = bits::count(open);
        stats.rays_clear += unblocked as u64;
        stats.rays_blocked += bits::count_and(blocked, above) as u64;
        for k in 0..words {
            let mut todo = above[k] & !decided[k];
            while todo != 0 {
                let r = k * 64 + todo.trailing_zeros() as usize;
                todo &= todo - 1;
                let [a, b] = m.ab[r];
                let target = light.point(a, b);
                let w = target - q.point.p;
                let from = if q.point.n_geom.dot(w) < 0.0 { offset_origin(&q.point, w) } else { origin };
                let Some(mut ray) = shadow_ray_from(from, target, light.point_error(a, b), light.normal)
                else {
                    unblocked += 1; // nothing left of the segment: as traced, unblocked
                    open[k] |= 1 << (r % 64);
                    continue;
                };
                // The part the shafts could not prove: only that stretch of the very ray
                // traced would trace (a prefix or a suffix: the same origin and direction,
                // so the same hits), the rest being proven clear.
                let bit = 1u64 << (r % 64);
                let (near_left, far_left) =
                    (split.near_pending[k] & bit != 0, split.far_pending[k] & bit != 0);
                if near_left || far_left {
                    let rate = frame.z.dot(Vec3::from(ray.direction));
                    let d0 = frame.z.dot(from - frame.origin);
                    if rate < 0.0 {
                        if near_left {
                            ray.tmax = ray.tmax.min((d0 - split.near_end) / -rate);
                            stats.rays_near_traced += 1;
                        } else {
                            ray.tmin = ((d0 - split.far_start) / -rate).max(0.0);
                            stats.rays_far_traced += 1;
                        }
                    }
                }
                stats.rays_traced += 1;
                if !scene.occluded(ray) {
                    unblocked += 1;
                    open[k] |= bit;
                }
            }
        }
        Some(share_of_irradiance(light, q, m, above, open, unblocked))
    }

    /// Each sample's verdict before tracing (tests): Some(true) clear, Some(false) blocked,
    /// None undecided.
    pub fn verdicts(
        &self,
        scene: &Scene,
        q: &ShadowQuery,
        m: &ExactMask,
        mp: MapPoint,
    ) -> Vec<([f32; 2], Option<bool>)> {
        let words = bits::words(m.mask.samples.len());
        let (mut clear, mut blocked) = ([0u64; MAX_WORDS], [0u64; MAX_WORDS]);
        let origin = offset_origin(&q.point, q.point.n_geom);
        let read = ExactRead { scene, q, m, mp: Some(mp), origin };
        self.classify(&read, &mut clear[..words], &mut blocked[..words], &mut ExactStats::default());
        let bit = |b: &[u64], r: usize| b[r / 64] >> (r % 64) & 1 == 1;
        m.ab.iter()
            .enumerate()
            .map(|(r, ab)| {
                let v = match (bit(&clear, r), bit(&blocked, r)) {
                    (true, false) => Some(true),
                    (false, true) => Some(false),
                    (false, false) => None,
                    (true, true) => panic!("ray {r} classified both clear and blocked"),
                };
                (*ab, v)
            })
            .collect()
    }

    /// Sets `clear` and `blocked` for the query's rays through its mask (see the module doc).
    fn classify(
        &self,
        read: &ExactRead,
        clear: &mut [u64],
        blocked: &mut [u64],
        stats: &mut ExactStats,
    ) -> Split {
        let ExactRead { q, m, mp, origin, .. } = *read;
        let words = clear.len();
        let mut split = Split::default();
        // Off the map (or behind the light's plane): nothing is decided.
        let Some(mp) = mp else { return split };
        let p = mp;
        let z_cut = self.cut_depth(mp.pixel, p.z).min(p.z);
        let z_stop = self.stop_depth(mp.pixel, p.z).min(z_cut);
        let eq =
            ExactQuery { bounds: &self.bounds, near: &self.near, base: mp.pixel, pz: p.z, z_cut, z_stop };
        let st = m.mask.classify(&eq, clear, blocked);
        stats.lookups += st.lookups;
        stats.blocks_culled += st.blocks_culled;
        if clear.iter().all(|&w| w == 0) {
            return split;
        }
        // Rays the shafts hold: above the cut under the apex (every one, when the light's
        // corners are).
        if !covers_light(&q.point, origin, &self.light) {
            let cover = Cover::new(&q.point, origin, self.light.max_point_error());
            for (r, [a, b]) in m.ab.iter().enumerate() {
                let w = self.light.point(*a, *b) - q.point.p;
                if !cover.covers(q.point.n_geom.dot(w), w) {
                    clear[r / 64] &= !(1 << (r % 64));
                }
            }
        }
        // The far field: nearer than the stop, or than the mask's tables reach for this point.
        let z_far =
            z_stop.max(Self::depth_at_height(m.mask.h_max, m.mask.depth, p.z)).max(self.bounds.z_clip);
        let (mut far_ok, mut near_ok) = ([0u64; MAX_WORDS], [0u64; MAX_WORDS]);
        self.shaft_bits(read, f32::NEG_INFINITY, z_far, &mut far_ok[..words], stats);
        self.shaft_bits(read, z_cut, f32::INFINITY, &mut near_ok[..words], stats);
        for k in 0..words {
            let mid = clear[k];
            clear[k] = mid & far_ok[k] & near_ok[k];
            split.near_pending[k] = mid & far_ok[k] & !near_ok[k];
            split.far_pending[k] = mid & near_ok[k] & !far_ok[k];
        }
        // Overlapping the mid field's ends by SEGMENT_OVERLAP of their depths.
        split.near_end = z_cut * (1.0 - SEGMENT_OVERLAP);
        split.far_start = z_far * (1.0 + SEGMENT_OVERLAP);
        far_ok[..words].iter().zip(clear.iter()).map(|(f, _)| f.count_ones() as u64).sum::<u64>();
        split
    }
}

/// V as the share of irradiance ([`IrradianceShare`]) from the mask's samples above the
/// horizon and the unblocked ones among them: the smaller set weighed, in sample order (the
/// same bits whichever way each verdict was reached). The mask's samples are uniform over
/// the whole light.
fn share_of_irradiance(
    light: &RectLight,
    q: &ShadowQuery,
    m: &ExactMask,
    above: &[u64],
    open: &[u64],
    unblocked: u32,
) -> f32 {
    debug_assert_eq!(bits::count_and(above, open), unblocked);
    let share = IrradianceShare::new(light, q, 1.0, m.mask.samples.len() as u32);
    let words = above.iter().copied().zip(open.iter().copied());
    share.visibility_from_bits(words, |k| {
        let [a, b] = m.ab[k];
        share.weight(light.point(a, b))
    })
}
