//! `edge_table`: soft shadows by ray tracing a depth map with precomputed edge tables
//! (Egan & Neulander, "Ray Tracing Depth Maps Using Precomputed Edge Tables", SIGGRAPH 2004
//! sketch), with trilinear blending across masks.
//!
//! Because the depth map's centre of projection lies on the (planar) light and its axis is
//! the light's normal, the normalised height at which a shadow ray crosses a pixel-frustum
//! side depends only on the side's position relative to P's pixel, P's offset inside its
//! pixel, P's depth and the light sample, not on P's absolute pixel (the shear invariance).
//! So a *mask* built for one (sub-pixel offset, depth, light-sample set) serves every pixel:
//! for each pixel of its filter region it stores the crossings of its N rays into that
//! pixel, sorted by height, with cumulative bitmasks (bit r cleared once ray r has entered
//! at or below that height). A query then costs one binary search and one N-bit AND per
//! pixel of the region instead of N separate marches.
//!
//! The per-pixel table is the union of the pixel's (one or two) in-edges: under the
//! solid-heightfield reading, "AND every wall and floor" reduces exactly to "AND over pixels
//! of Below(floor height)" (technical note, section 5.4), so one search per pixel suffices.
//!
//! | key (`[shadows.edge_table]`) | type | default | meaning |
//! |---|---|---|---|
//! | `depth_map` | int | 256 | depth-map pixels per side |
//! | `grid` | [int; 3] | [4, 4, 2] | masks over (sub-pixel x, sub-pixel y, depth) |
//! | `blend` | "trilinear" / "nearest" | "trilinear" | blend the 8 (4 with one depth) nearest masks' visibilities, or take the nearest |
//! | `slope_bias` | float | 1.0 | slope-scaled depth bias, in pixels |
//!
//! `samples` (`[shadows]`) is the number of rays per mask (at most 4096).
//!
//! ```toml
//! [shadows]
//! method = "edge_table"
//! samples = 1024
//! [shadows.edge_table]
//! depth_map = 256
//! grid = [4, 4, 2]
//! blend = "trilinear"
//! ```

use crate::bits::{self, MAX_SAMPLES, MAX_WORDS};
use crate::depth_map::{DepthMap, DepthMapParams};
use crate::depth_march::fallback_name;
use crate::march::{floor_height, for_each_crossing, region_reach, stop_height};
use crate::samples;
use glam::Vec2;
use rayon::prelude::*;
use renderer::sampling::{Rng, stream_seed};
use renderer::{LightShadowing, PrepareContext, Scene, ShadowError, ShadowQuery, Traced, TracedParams};
use std::sync::atomic::{AtomicU64, Ordering};

/// How visibilities of neighbouring masks combine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Blend {
    /// The mask nearest in sub-pixel offset and (log) depth.
    Nearest,
    /// Trilinear weights over the 8 surrounding masks (4 with a single depth level); the
    /// visibility fractions are blended, never the bits (each mask has its own samples).
    Trilinear,
}

/// Parameters of the edge-table method. See the module doc for the scene-file keys.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeTableParams {
    pub depth_map: DepthMapParams,
    /// Masks over (sub-pixel x, sub-pixel y, depth). Sub-pixel samples are cell-centred,
    /// (a + 1/2) / n; depth levels are spaced uniformly in log depth over the receivers'
    /// range.
    pub grid: [u32; 3],
    pub blend: Blend,
}

impl EdgeTableParams {
    /// The paper's configuration: 256^2 map, 4 x 4 x 1 masks, nearest mask.
    pub const fn paper() -> Self {
        Self {
            depth_map: DepthMapParams { resolution: 256, slope_bias: 1.0 },
            grid: [4, 4, 1],
            blend: Blend::Nearest,
        }
    }
    /// The default: 256^2 map, 4 x 4 x 2 masks, trilinear.
    pub const fn balanced() -> Self {
        Self {
            depth_map: DepthMapParams { resolution: 256, slope_bias: 1.0 },
            grid: [4, 4, 2],
            blend: Blend::Trilinear,
        }
    }
    /// Finer: 512^2 map, 8 x 8 x 4 masks, trilinear.
    pub const fn fine() -> Self {
        Self {
            depth_map: DepthMapParams { resolution: 512, slope_bias: 1.0 },
            grid: [8, 8, 4],
            blend: Blend::Trilinear,
        }
    }
}

impl Default for EdgeTableParams {
    fn default() -> Self {
        Self::balanced()
    }
}

/// The tables of one pixel of a mask's region: crossings `start..start + len` of the mask's
/// `heights` / `masks` arrays.
#[derive(Debug, Clone, Copy)]
struct CellTable {
    dx: i32,
    dy: i32,
    start: u32,
    len: u32,
    /// The lowest crossing height: a floor below it blocks nothing here.
    first: f32,
}

/// One edge-table mask.
#[derive(Debug, Clone)]
pub struct Mask {
    /// The model point's offset inside its pixel and its depth.
    pub offset: Vec2,
    pub depth: f32,
    /// Light samples (light frame, z = 0).
    pub samples: Vec<Vec2>,
    words: usize,
    cells: Vec<CellTable>,
    /// Crossing heights, grouped by cell, ascending within a cell.
    heights: Vec<f32>,
    /// Cumulative bitmasks, `words` per crossing: ray bits still set = not yet entered at or
    /// below that height.
    masks: Vec<u64>,
    /// Pixel extent of the region relative to the model point's pixel: [min x, min y, max
    /// x, max y].
    pub extent: [i32; 4],
}

impl Mask {
    /// Builds a mask for a model point at `offset` inside its pixel and at depth `depth`,
    /// marching every ray up to the normalised height `h_stop`.
    pub fn build(offset: Vec2, depth: f32, samples: Vec<Vec2>, pitch: f32, h_stop: f32) -> Self {
        let n = samples.len();
        let words = bits::words(n);
        let mut crossings: Vec<([i32; 2], f32, u32)> = Vec::new();
        for (r, s) in samples.iter().enumerate() {
            for_each_crossing(offset, *s, depth * pitch, h_stop, |c, h| {
                crossings.push((c, h, r as u32));
                true
            });
        }
        // Row-major cell order (so a query reads the depth map row by row), then height.
        crossings.sort_unstable_by(|a, b| {
            (a.0[1], a.0[0]).cmp(&(b.0[1], b.0[0])).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2))
        });
        let mut full = vec![0u64; words];
        bits::fill_first(&mut full, n);
        let mut cells = Vec::new();
        let mut heights = Vec::with_capacity(crossings.len());
        let mut masks = Vec::with_capacity(crossings.len() * words);
        let mut extent = [0i32; 4];
        let mut i = 0;
        while i < crossings.len() {
            let cell = crossings[i].0;
            let start = heights.len() as u32;
            let mut current = full.clone();
            while i < crossings.len() && crossings[i].0 == cell {
                let (_, h, r) = crossings[i];
                current[r as usize / 64] &= !(1u64 << (r % 64));
                heights.push(h);
                masks.extend_from_slice(&current);
                i += 1;
            }
            let len = heights.len() as u32 - start;
            cells.push(CellTable { dx: cell[0], dy: cell[1], start, len, first: heights[start as usize] });
            extent = [
                extent[0].min(cell[0]),
                extent[1].min(cell[1]),
                extent[2].max(cell[0]),
                extent[3].max(cell[1]),
            ];
        }
        Mask { offset, depth, samples, words, cells, heights, masks, extent }
    }

    pub fn bytes(&self) -> u64 {
        (self.cells.len() * std::mem::size_of::<CellTable>()
            + self.heights.len() * 4
            + self.masks.len() * 8
            + self.samples.len() * 8) as u64
    }

    pub fn crossings(&self) -> usize {
        self.heights.len()
    }

    /// Unblocked-ray bits for a point at depth `pz` whose mask-relative pixel is `base`:
    /// bit r is 1 iff ray r enters no pixel of the region at or below its floor (and the
    /// point is in front of its own floor). Returns the number of table searches.
    pub fn query(&self, map: &DepthMap, base: [i32; 2], pz: f32, out: &mut [u64]) -> QueryStats {
        let mut stats = QueryStats::default();
        let out = &mut out[..self.words];
        if floor_height(map.at(base[0], base[1]), pz) >= 0.0 {
            out.iter_mut().for_each(|w| *w = 0);
            stats.early_out = true;
            return stats;
        }
        bits::fill_first(out, self.samples.len());
        // Only floors that can reach above a ray matter: H(c) >= first crossing height.
        for c in &self.cells {
            let h_floor = floor_height(map.at(base[0] + c.dx, base[1] + c.dy), pz);
            if h_floor < c.first {
                continue;
            }
            let range = c.start as usize..(c.start + c.len) as usize;
            // The last crossing at or below the floor (ties block).
            let k = self.heights[range.clone()].partition_point(|&h| h <= h_floor) - 1;
            let m = &self.masks[(c.start as usize + k) * self.words..][..self.words];
            let mut any = 0u64;
            for (o, w) in out.iter_mut().zip(m) {
                *o &= *w;
                any |= *o;
            }
            stats.lookups += 1;
            if any == 0 {
                stats.early_out = true;
                break;
            }
        }
        stats
    }
}

#[derive(Debug, Default, Clone, Copy)]
pub struct QueryStats {
    pub lookups: u64,
    pub early_out: bool,
}

/// The plugin: one depth map and a grid of masks per light and frame.
pub struct EdgeTable {
    params: EdgeTableParams,
    samples: u32,
    state: Option<Prepared>,
    fallback: Traced,
    queries: AtomicU64,
    lookups: AtomicU64,
    early_outs: AtomicU64,
    fallbacks: AtomicU64,
}

struct Prepared {
    map: DepthMap,
    /// Indexed [depth level][sub-pixel y][sub-pixel x].
    masks: Vec<Mask>,
    /// Depth of each level (ascending).
    levels: Vec<f32>,
    /// The union of every mask's region extent.
    extent: [i32; 4],
}

impl EdgeTable {
    /// # Panics
    /// `samples` outside 1..=4096 or a zero grid dimension (checked at the config boundary).
    pub fn new(params: EdgeTableParams, samples: u32) -> Self {
        assert!((1..=MAX_SAMPLES as u32).contains(&samples));
        assert!(params.grid.iter().all(|&g| g >= 1));
        Self {
            params,
            samples,
            state: None,
            fallback: Traced::new(TracedParams { samples }),
            queries: AtomicU64::new(0),
            lookups: AtomicU64::new(0),
            early_outs: AtomicU64::new(0),
            fallbacks: AtomicU64::new(0),
        }
    }

    pub fn depth_map(&self) -> Option<&DepthMap> {
        self.state.as_ref().map(|s| &s.map)
    }

    pub fn masks(&self) -> &[Mask] {
        self.state.as_ref().map_or(&[], |s| &s.masks)
    }

    /// Weighted masks for a point: up to 8 (mask index, pixel shift, weight).
    fn select(&self, st: &Prepared, offset: Vec2, pz: f32, out: &mut [(usize, [i32; 2], f32); 8]) -> usize {
        let [gx, gy, gz] = self.params.grid;
        let level_pos = if st.levels.len() > 1 {
            let (lo, hi) = (st.levels[0].ln(), st.levels[st.levels.len() - 1].ln());
            ((pz.ln() - lo) / (hi - lo) * (gz - 1) as f32).clamp(0.0, (gz - 1) as f32)
        } else {
            0.0
        };
        let index = |a: i32, b: i32, k: u32| -> (usize, [i32; 2]) {
            let (sx, ax) = (a.div_euclid(gx as i32), a.rem_euclid(gx as i32));
            let (sy, ay) = (b.div_euclid(gy as i32), b.rem_euclid(gy as i32));
            (((k * gy + ay as u32) * gx + ax as u32) as usize, [sx, sy])
        };
        match self.params.blend {
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

impl LightShadowing for EdgeTable {
    fn name(&self) -> &'static str {
        "edge_table"
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.fallback.prepare(ctx)?;
        let map = DepthMap::build(ctx.scene, ctx.light, ctx.visible, &self.params.depth_map);
        // Depth levels over the receivers the light reaches: uniform in log depth.
        let (mut z_lo, mut z_hi) = (f32::INFINITY, 0.0f32);
        for v in ctx.visible {
            let z = map.frame.light_from_world(v.p).z;
            if z > map.z_min {
                z_lo = z_lo.min(z);
                z_hi = z_hi.max(z);
            }
        }
        if z_lo > z_hi {
            (z_lo, z_hi) = (map.z_min.max(1e-6) * 2.0, map.z_min.max(1e-6) * 2.0);
        }
        let [gx, gy, gz] = self.params.grid;
        let levels: Vec<f32> = if gz == 1 {
            vec![(z_lo * z_hi).sqrt()]
        } else {
            (0..gz).map(|k| (z_lo.ln() + (z_hi / z_lo).ln() * k as f32 / (gz - 1) as f32).exp()).collect()
        };
        // Each mask marches far enough for the deepest point it serves.
        let serve_hi: Vec<f32> = (0..gz as usize)
            .map(|k| match self.params.blend {
                Blend::Trilinear if k + 1 < levels.len() => levels[k + 1],
                Blend::Nearest if k + 1 < levels.len() => (levels[k] * levels[k + 1]).sqrt(),
                _ => z_hi.max(levels[k]),
            })
            .collect();
        let n = self.samples as usize;
        let half = map.frame.half_size;
        let pitch = map.pitch;
        let z_min = map.z_min;
        let seed = ctx.seed;
        let light_index = ctx.light_index as u64;
        let masks: Vec<Mask> = (0..(gx * gy * gz) as usize)
            .into_par_iter()
            .map(|m| {
                let (ax, ay, k) = (m as u32 % gx, (m as u32 / gx) % gy, m as u32 / (gx * gy));
                let offset = Vec2::new((ax as f32 + 0.5) / gx as f32, (ay as f32 + 0.5) / gy as f32);
                let mut s = vec![Vec2::ZERO; n];
                samples::stratified(
                    &mut s,
                    half,
                    &mut Rng::new(stream_seed(&[seed, light_index, m as u64, 3])),
                );
                let depth = levels[k as usize];
                Mask::build(offset, depth, s, pitch, stop_height(z_min, serve_hi[k as usize]))
            })
            .collect();
        let mut extent = [0i32; 4];
        for m in &masks {
            extent = [
                extent[0].min(m.extent[0]),
                extent[1].min(m.extent[1]),
                extent[2].max(m.extent[2]),
                extent[3].max(m.extent[3]),
            ];
        }
        self.state = Some(Prepared { map, masks, levels, extent });
        Ok(())
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let st = self.state.as_ref().expect("prepare() runs before visibility()");
        self.queries.fetch_add(1, Ordering::Relaxed);
        let map = &st.map;
        let frame = &map.frame;
        let p = frame.light_from_world(q.p);
        if p.z <= map.z_min {
            self.early_outs.fetch_add(1, Ordering::Relaxed);
            return 1.0;
        }
        let fallback = || {
            self.fallbacks.fetch_add(1, Ordering::Relaxed);
            self.fallback.visibility(scene, q)
        };
        let Some(mp) = map.locate(p) else { return fallback() };
        // The region must lie in the map: the masks' own extents (one pixel of shift for
        // the wrapped neighbours) and the reach of rays up to the nearest caster.
        let reach = region_reach(frame.half_size, map.pitch, map.z_min.min(map.caster_z_near), p.z);
        let [i, j] = mp.pixel;
        let lo = [i - 1 + st.extent[0].min(-reach[0]), j - 1 + st.extent[1].min(-reach[1])];
        let hi = [i + 1 + st.extent[2].max(reach[0]), j + 1 + st.extent[3].max(reach[1])];
        if !map.contains(lo, hi) {
            return fallback();
        }
        let mut chosen = [(0usize, [0i32; 2], 0.0f32); 8];
        let count = self.select(st, mp.offset, p.z, &mut chosen);
        let mut visible = [0u64; MAX_WORDS];
        let mut above = [0u64; MAX_WORDS];
        let (mut v, mut lookups, mut early_outs) = (0.0f32, 0u64, 0u64);
        for &(m, shift, w) in &chosen[..count] {
            let mask = &st.masks[m];
            let words = bits::words(mask.samples.len());
            let stats = mask.query(map, [i + shift[0], j + shift[1]], p.z, &mut visible);
            lookups += stats.lookups;
            early_outs += stats.early_out as u64;
            let all_above =
                samples::above_horizon(frame, &mask.samples, q.p, q.n_shading, &mut above[..words]);
            let (n_visible, n_above) = if all_above {
                (bits::count(&visible[..words]), mask.samples.len() as u32)
            } else {
                (bits::count_and(&visible[..words], &above[..words]), bits::count(&above[..words]))
            };
            v += w * if n_above == 0 { 1.0 } else { n_visible as f32 / n_above as f32 };
        }
        self.lookups.fetch_add(lookups, Ordering::Relaxed);
        self.early_outs.fetch_add(early_outs, Ordering::Relaxed);
        v.clamp(0.0, 1.0)
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let (masks, bytes, crossings, map_bytes) = match &self.state {
            Some(st) => (
                st.masks.len() as u64,
                st.masks.iter().map(Mask::bytes).sum::<u64>(),
                st.masks.iter().map(|m| m.crossings() as u64).sum::<u64>(),
                st.map.bytes(),
            ),
            None => (0, 0, 0, 0),
        };
        let mut c = vec![
            ("masks_built", masks),
            ("mask_bytes", bytes),
            ("mask_crossings", crossings),
            ("depth_map_bytes", map_bytes),
            ("edge_lookups", self.lookups.load(Ordering::Relaxed)),
            ("early_outs", self.early_outs.load(Ordering::Relaxed)),
            ("fallbacks", self.fallbacks.load(Ordering::Relaxed)),
        ];
        c.extend(self.fallback.counters().into_iter().map(|(k, v)| (fallback_name(k), v)));
        c
    }
}
