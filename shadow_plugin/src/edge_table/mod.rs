//! `edge_table`: soft shadows by ray tracing a depth map with precomputed edge tables
//! (Egan & Neulander, "Ray Tracing Depth Maps Using Precomputed Edge Tables", SIGGRAPH 2004
//! sketch), read exactly (the default) or as published.
//!
//! Because the depth map's centre of projection lies on the (planar) light and its axis is
//! the light's normal, the normalised height at which a shadow ray crosses a pixel-frustum
//! side depends only on the side's position relative to P's pixel, P's offset inside its
//! pixel, P's depth and the light sample, not on P's absolute pixel (the shear invariance).
//! So a *mask* built for one (sub-pixel offset, depth, light-sample set) serves every pixel:
//! for each pixel of its filter region it stores the crossings of its N rays into and out of
//! that pixel, sorted by height, with cumulative bitmasks (bit r cleared once ray r has
//! crossed at or below that height). A query then costs one binary search and one N-bit AND
//! per pixel of the region instead of N separate marches.
//!
//! Two readings ([`Reading`]):
//!
//! - **exact** (`exact.rs`, `mask/classify.rs`): the tables are read against conservative
//!   depth bounds of every triangle (`depth_map/bounds/`), which classify each ray clear,
//!   blocked or undecided for every point the mask stands for; shafts through the BVH prove
//!   the parts of the rays next to the point and next to the light; the undecided rays (or
//!   the part of them a shaft could not prove) are traced through the BVH with the
//!   renderer's one origin rule. The answer is exactly that of tracing every ray of the
//!   mask's sample set: no bias, and the error is sampling noise, as for `traced`.
//! - **published** (`mask/query.rs`): the sketch's reading of a centre-ray depth map as a
//!   heightfield (`heightfield`), with bias, slabs, a grazing policy and optional trilinear
//!   blending: approximate, kept to compare with the published method.
//!
//! | key (`[shadows.edge_table]`) | type | default | meaning |
//! |---|---|---|---|
//! | `preset` | "paper" / "balanced" / "fine" | "balanced" | the starting point the other keys override ([`Preset`]) |
//! | `reading` | "exact" / "published" | "exact" | see above |
//! | `depth_map` | int | 256 | depth-map pixels per side |
//! | `grid` | [int; 3] | [2, 2, 8] | masks over (sub-pixel x, sub-pixel y, depth) |
//! | `blend` | "nearest" / "trilinear" | "nearest" | published: take the nearest mask, or blend the 8 (4 with one depth level) nearest masks' visibilities |
//! | `heightfield` | "plates" / "shells" / "solid" | "plates" | published: how the depth map is read ([`Heightfield`]) |
//! | `slab_thickness` | float | 2.0 | published, `plates` only: each floor is a slab this many pixel footprints thick |
//! | `slope_bias` | float | 1.0 | published: slope-scaled depth bias, in pixels |
//! | `normal_offset` | float | 0.5 | published: lookups move along the normal by this many pixel footprints times (1 - cos) of the light's axis |
//! | `grazing_cos` | float | 0.5 | published: receivers whose geometric normal's cosine to the direction of the light's centre is below this are answered by traced rays (counted as `fallbacks_grazing`); 0 turns it off |
//!
//! The same list, held to [`EdgeTableTable`] by a test: `keys.md` (its section of
//! `docs/scene-keys.md`). Code-only
//! ([`EdgeTableSwitches`]; the bench and the accuracy example switch them, presets set them):
//! `mirrored` (build only the masks at sub-pixel offsets up to 1/2 and read the others as
//! mirror images; off in `paper`; the exact reading never mirrors), and the depth map's
//! `closed_volumes`, `hidden_layer` and `fit_shadowed` ([`MapSwitches`](crate::MapSwitches)).
//!
//! `samples` (`[shadows]`) is the number of rays per mask (at most 4096).
//!
//! ```toml
//! [shadows]
//! method = "edge_table"
//! samples = 256
//! [shadows.edge_table]
//! depth_map = 256
//! grid = [2, 2, 8]
//! ```
//!
//! The rooms: this file is the plugin ([`EdgeTable`]: preparing a light's map and masks,
//! answering queries, the counters); `params.rs` holds [`EdgeTableParams`] and its presets,
//! `grid.rs` the grid of masks (depth levels, mirrored masks, which masks a point reads),
//! `exact.rs` the exact reading's per-point logic (fields, shafts, traced segments),
//! `mask/` one mask ([`Mask`]: `build.rs` builds it, `classify.rs` reads it exactly,
//! `query.rs` as published, one function per [`Heightfield`] reading).

mod entry;
mod exact;
mod grid;
mod mask;
pub mod memory;
mod params;
mod plan;

pub use crate::depth_map::heightfield::Heightfield;
pub use exact::{ExactMap, ExactMask, ExactStats};
pub use mask::{Mask, MaskQuery, QueryStats};
pub use params::{
    Blend, EdgeTableParams, EdgeTableSwitches, EdgeTableTable, GRID_RANGE, MAX_MASKS, Preset,
    PublishedParams, Reading,
};

use crate::depth_map::DepthMap;
use crate::depth_map::bits::{self, MAX_SAMPLES, MAX_WORDS};
use crate::depth_map::fallback::{Located, MapFallback, OnMap};
use crate::depth_map::march::stop_height;
use crate::depth_map::mask_samples;
use glam::Vec2;
use grid::{Layout, MaskGrid};
use rayon::prelude::*;
use renderer::{LightShadowing, PrepareContext, Scene, ShadowError, ShadowQuery};
use std::sync::atomic::{AtomicU64, Ordering};

/// The plugin: one depth map and a grid of masks per light and frame.
pub struct EdgeTable {
    params: EdgeTableParams,
    samples: u32,
    state: Option<Prepared>,
    fallback: MapFallback,
    lookups: AtomicU64,
    early_outs: AtomicU64,
    blocks_culled: AtomicU64,
    clipped: AtomicU64,
    exact_counters: ExactCounters,
    /// What the last `prepare` took, when it was more than most renders expect.
    warning: Option<String>,
    /// Why the last `prepare`'s depth-map margins are wide, when they are ([`margin_warning`]).
    margin_warning: Option<String>,
    /// The masks' bytes as estimated before they were built (a counter beside `mask_bytes`).
    mask_bytes_estimated: AtomicU64,
}

/// The exact reading's counters (relaxed, one add per query).
#[derive(Default)]
struct ExactCounters {
    rays_clear: AtomicU64,
    rays_blocked: AtomicU64,
    rays_traced: AtomicU64,
    shafts: AtomicU64,
    points_shaft_clear: AtomicU64,
    points_off_map: AtomicU64,
    points_horizon_traced: AtomicU64,
    rays_near_traced: AtomicU64,
    rays_far_traced: AtomicU64,
}

enum Prepared {
    Published {
        map: Box<DepthMap>,
        /// The masks built (all of the grid, or its mirror-image classes' representatives).
        masks: Vec<Mask>,
        grid: MaskGrid,
        /// How the masks read the map.
        heightfield: Heightfield,
    },
    Exact {
        map: Box<ExactMap>,
        masks: Vec<ExactMask>,
        grid: MaskGrid,
    },
    /// No map: its rounding margins would exceed the light's distance to what it lights
    /// ([`Margins::defeat_the_map`]), so every ray is traced.
    Traced,
}

/// Share of receivers whose stop height the masks cover (the rest fall back to traced).
pub const MASK_HEIGHT_QUANTILE: f64 = 0.995;

impl EdgeTable {
    pub const NAME: &'static str = "edge_table";

    /// # Panics
    /// `samples` outside 1..=4096 or a zero grid dimension (checked at the config boundary).
    pub fn new(params: EdgeTableParams, samples: u32) -> Self {
        assert!((1..=MAX_SAMPLES as u32).contains(&samples));
        assert!(params.grid.iter().all(|&g| g >= 1));
        Self {
            params,
            samples,
            state: None,
            fallback: MapFallback::new(samples),
            lookups: AtomicU64::new(0),
            early_outs: AtomicU64::new(0),
            blocks_culled: AtomicU64::new(0),
            clipped: AtomicU64::new(0),
            exact_counters: ExactCounters::default(),
            warning: None,
            margin_warning: None,
            mask_bytes_estimated: AtomicU64::new(0),
        }
    }

    /// Builds the masks of grid cells `built` for reading the map as `heightfield`, level
    /// k's at depth `levels[k].0` marching up to height `levels[k].1`, in parallel, until
    /// their bytes pass `budget`.
    ///
    /// # Errors
    /// The masks need more than `budget` bytes (an error naming the parameters).
    fn build_masks(
        &self,
        ctx: &PrepareContext,
        map: &DepthMap,
        built: &[u32],
        heightfield: Heightfield,
        levels: &[(f32, f32)],
        budget: u64,
    ) -> Result<Vec<Mask>, ShadowError> {
        let _span = tracing::info_span!("masks", count = built.len(), samples = self.samples).entered();
        let (half, pitch) = (map.frame.half_size, map.pitch);
        // Mask memory grows with grid x samples x filter-region size; a grid the machine
        // cannot hold is refused (an error naming the parameters) rather than swapped or
        // killed. Estimated before any mask is built (`memory.rs`); checked again as masks are
        // built, should the estimate fall short: once the total passes the budget the rest
        // are skipped, so the overshoot is at most one mask per thread.
        let estimate = memory::estimate_masks(
            ctx,
            &self.params,
            self.samples,
            (half, pitch),
            built,
            (heightfield, levels),
            u64::MAX,
        );
        self.mask_bytes_estimated.store(estimate.bytes, Ordering::Relaxed);
        memory::check_masks(&self.params, self.samples, &estimate, budget)?;
        let bytes = AtomicU64::new(0);
        let masks: Vec<Option<Mask>> = built
            .par_iter()
            .map(|&m| {
                if bytes.load(Ordering::Relaxed) > budget {
                    return None;
                }
                let k = grid::coordinates(m, self.params.grid)[2];
                let (offset, s) = memory::mask_inputs(ctx, &self.params, self.samples, half, m);
                let (depth, h_stop) = levels[k as usize];
                let mask = Mask::build_for(heightfield, offset, depth, s, pitch, h_stop);
                bytes.fetch_add(mask.bytes(), Ordering::Relaxed);
                Some(mask)
            })
            .collect();
        let total = bytes.load(Ordering::Relaxed);
        masks.into_iter().collect::<Option<Vec<Mask>>>().filter(|_| total <= budget).ok_or_else(|| {
            ShadowError {
                method: Self::NAME,
                message: format!(
                    "the masks need more than the {:.1} MiB left of the memory budget (grid {:?} x {} \
                     samples); use a smaller grid, fewer samples or a smaller depth map",
                    budget as f64 / (1u64 << 20) as f64,
                    self.params.grid,
                    self.samples
                ),
            }
        })
    }
}

impl EdgeTable {
    /// The published reading's prepare: the depth map, the depth levels, how high the masks
    /// march, the masks within the memory budget (less the map's bytes).
    fn prepare_published(&self, ctx: &PrepareContext, p: &PublishedParams) -> Result<Prepared, ShadowError> {
        let map = DepthMap::build(ctx.scene, ctx.light, ctx.visible, &self.params.depth_map());
        let budget = ctx.memory_budget_bytes.saturating_sub(map.bytes());
        let (levels, per_level) = plan::published_levels(&map, ctx.visible, self.params.grid[2], p.blend);
        let layout = Layout::new(self.params.grid, self.params.switches.mirrored);
        let masks = self.build_masks(ctx, &map, &layout.built, p.heightfield, &per_level, budget)?;
        let grid = MaskGrid { dims: self.params.grid, blend: p.blend, levels, cells: layout.cells };
        Ok(Prepared::Published { map: Box::new(map), masks, grid, heightfield: p.heightfield })
    }

    /// The exact reading's prepare: the conservative bounds, the depth levels, how high the
    /// masks march (what the receivers' regions need, up to its [`MASK_HEIGHT_QUANTILE`]), the
    /// masks at their cells' lower corners, every one built (no mirroring).
    fn prepare_exact(&self, ctx: &PrepareContext) -> Result<Prepared, ShadowError> {
        let (map, visible) = plan::exact_map(ctx, &self.params);
        let map = Box::new(map);
        let (levels, per_level) = plan::exact_levels(&map, &visible, self.params.grid[2]);
        let layout = Layout::new(self.params.grid, false);
        // Classification reads no walls: the masks are built without the `shells` reading's
        // per-side tables.
        let map_bytes = map.bounds.bytes() + map.near.bytes();
        let (built, budget) = (&layout.built, ctx.memory_budget_bytes.saturating_sub(map_bytes));
        let masks = self.build_masks(ctx, &map.near, built, Heightfield::Plates, &per_level, budget)?;
        let half = map.near.frame.half_size;
        let masks = masks.into_iter().map(|m| ExactMask::new(m, half)).collect();
        let grid = MaskGrid { dims: self.params.grid, blend: Blend::Nearest, levels, cells: layout.cells };
        Ok(Prepared::Exact { map, masks, grid })
    }

    /// The published reading's answer: the masks read against the centre-ray depth map as
    /// `heightfield`.
    fn visibility_published(
        &self,
        scene: &Scene,
        q: &ShadowQuery,
        map: &DepthMap,
        masks: &[Mask],
        grid: &MaskGrid,
        heightfield: Heightfield,
    ) -> f32 {
        let frame = &map.frame;
        // Grazed points and points outside the map: traced rays answer (counted).
        let OnMap { p, mp, z_stop, clipped } = match self.fallback.locate(map, scene, q) {
            Located::OnMap(on_map) => on_map,
            Located::Traced(v) => return v,
            Located::NearerThanMap => {
                self.early_outs.fetch_add(1, Ordering::Relaxed);
                return 1.0;
            }
        };
        // The masks must reach the region's stop height. A region reaching outside the map
        // sees no occluder there (counted).
        if clipped {
            self.clipped.fetch_add(1, Ordering::Relaxed);
        }
        let h_stop = stop_height(z_stop, p.z);
        let [i, j] = mp.pixel;
        let mut chosen = [(0usize, [0i32; 2], 0.0f32); 8];
        let count = grid.select(mp.offset, p.z, &mut chosen);
        let mut visible = [0u64; MAX_WORDS];
        let mut above = [0u64; MAX_WORDS];
        let (mut v, mut lookups, mut early_outs, mut culled) = (0.0f32, 0u64, 0u64, 0u64);
        for &(g, shift, w) in &chosen[..count] {
            let (m, mirror) = grid.mask(g);
            let mask = &masks[m as usize];
            if h_stop > mask.h_max {
                return self.fallback.trace(scene, q);
            }
            let words = bits::words(mask.samples.len());
            let at = MaskQuery { map, base: [i + shift[0], j + shift[1]], mirror, pz: p.z, h_stop };
            let stats = mask.query_mirrored(&at, heightfield, &mut visible);
            lookups += stats.lookups;
            early_outs += stats.early_out as u64;
            culled += stats.blocks_culled;
            let all_above = mask_samples::above_horizon(
                frame,
                &mask.samples,
                mirror.map(|m| if m { -1.0 } else { 1.0 }).into(),
                &q.point,
                &mut above[..words],
            );
            let (n_visible, n_above) = if all_above {
                (bits::count(&visible[..words]), mask.samples.len() as u32)
            } else {
                (bits::count_and(&visible[..words], &above[..words]), bits::count(&above[..words]))
            };
            v += w * if n_above == 0 { 1.0 } else { n_visible as f32 / n_above as f32 };
        }
        self.lookups.fetch_add(lookups, Ordering::Relaxed);
        renderer::util::pixel_cost::count_lookups(lookups);
        self.early_outs.fetch_add(early_outs, Ordering::Relaxed);
        if culled > 0 {
            self.blocks_culled.fetch_add(culled, Ordering::Relaxed);
        }
        v.clamp(0.0, 1.0)
    }

    /// The exact reading's answer: see `exact.rs`. With `traced_only`, every counted ray of
    /// the same sample set is traced (the reference the classification must equal).
    fn visibility_exact(&self, scene: &Scene, q: &ShadowQuery, traced_only: bool) -> f32 {
        let Some(Prepared::Exact { map, masks, grid }) = &self.state else {
            panic!("prepare() with the exact reading runs before visibility()");
        };
        let c = &self.exact_counters;
        if !traced_only && let Some(shaft) = renderer::Shaft::new(&map.light, &q.point) {
            c.shafts.fetch_add(1, Ordering::Relaxed);
            let origin = renderer::geometry::ray_origin::offset_origin(&q.point, q.point.n_geom);
            if scene.shaft_clear(&shaft)
                && renderer::geometry::shaft::covers_light(&q.point, origin, &map.light)
            {
                c.points_shaft_clear.fetch_add(1, Ordering::Relaxed);
                return 1.0;
            }
        }
        let located = map.locate(q.point.p);
        let (offset, z) = match located {
            Some(mp) => (mp.offset, mp.z),
            None => {
                c.points_off_map.fetch_add(1, Ordering::Relaxed);
                (Vec2::ZERO, map.near.frame.light_from_world(q.point.p).z.max(0.0))
            }
        };
        let mut chosen = [(0usize, [0i32; 2], 0.0f32); 8];
        grid.select(offset, z, &mut chosen);
        let (m, _) = grid.mask(chosen[0].0);
        let mut stats = ExactStats::default();
        // Where the horizon leaves the mask too few samples, traced's own (warped onto the part
        // above the horizon, all N counting) answers: the same traced rays either way.
        let Some(v) = map.visibility(scene, q, &masks[m as usize], located, traced_only, &mut stats) else {
            c.points_horizon_traced.fetch_add(1, Ordering::Relaxed);
            return self.fallback.trace(scene, q);
        };
        if located.is_none() {
            // Off the map: every ray traced (once per query: the horizon's fallback above
            // counts its own).
            renderer::util::pixel_cost::count_fallback();
        }
        if !traced_only {
            c.rays_clear.fetch_add(stats.rays_clear, Ordering::Relaxed);
            c.rays_blocked.fetch_add(stats.rays_blocked, Ordering::Relaxed);
            c.rays_traced.fetch_add(stats.rays_traced, Ordering::Relaxed);
            c.shafts.fetch_add(stats.shafts, Ordering::Relaxed);
            c.rays_near_traced.fetch_add(stats.rays_near_traced, Ordering::Relaxed);
            c.rays_far_traced.fetch_add(stats.rays_far_traced, Ordering::Relaxed);
            self.lookups.fetch_add(stats.lookups, Ordering::Relaxed);
            renderer::util::pixel_cost::count_lookups(stats.lookups);
            if stats.blocks_culled > 0 {
                self.blocks_culled.fetch_add(stats.blocks_culled, Ordering::Relaxed);
            }
        }
        v
    }

    /// Every counted ray of the exact reading's sample set for `q` traced through the BVH,
    /// none classified: what [`LightShadowing::visibility`] must equal bit for bit (tests).
    #[doc(hidden)]
    pub fn visibility_all_traced(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        self.visibility_exact(scene, q, true)
    }

    /// The exact reading's classification of `q`'s rays, for the differential tests: the
    /// mask's samples (light coordinates) with each one's verdict (Some(true) clear,
    /// Some(false) blocked, None undecided), before any ray is traced. None for the
    /// published reading, off the map, or a point whose whole-light shaft is clear.
    #[doc(hidden)]
    pub fn classify_rays(&self, scene: &Scene, q: &ShadowQuery) -> Option<Vec<([f32; 2], Option<bool>)>> {
        let Some(Prepared::Exact { map, masks, grid }) = &self.state else { return None };
        let mp = map.locate(q.point.p)?;
        let mut chosen = [(0usize, [0i32; 2], 0.0f32); 8];
        grid.select(mp.offset, mp.z, &mut chosen);
        let m = &masks[grid.mask(chosen[0].0).0 as usize];
        Some(map.verdicts(scene, q, m, mp))
    }
}

impl LightShadowing for EdgeTable {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        ctx.require_flattened(self.name())?;
        self.state = None;
        self.warning = None;
        // The map's peak is known from its size alone, the masks' from a coarse map: both
        // refused before anything large is built.
        let margins = plan::Margins::of(ctx);
        self.margin_warning = margins.warning();
        if margins.defeat_the_map() {
            self.fallback.prepare(ctx)?;
            self.state = Some(Prepared::Traced);
            return Ok(());
        }
        memory::check_map(&self.params, ctx.memory_budget_bytes)?;
        plan::refuse_impossible_masks(&self.params, self.samples, ctx)?;
        self.state = Some(match &self.params.reading {
            Reading::Exact => {
                self.fallback.prepare(ctx)?;
                self.prepare_exact(ctx)?
            }
            Reading::Published(p) => {
                self.fallback.prepare(ctx)?;
                self.prepare_published(ctx, p)?
            }
        });
        let mask_bytes = self.counters().iter().find(|c| c.0 == "mask_bytes").map_or(0, |c| c.1);
        let peak = memory::map_peak_bytes(&self.params);
        self.warning = memory::warning(&self.params, peak, self.memory_bytes(), mask_bytes);
        Ok(())
    }

    fn warnings(&self) -> Vec<String> {
        self.warning.iter().chain(&self.margin_warning).cloned().collect()
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        match self.state.as_ref().expect("prepare() runs before visibility()") {
            Prepared::Exact { .. } => self.visibility_exact(scene, q, false),
            Prepared::Published { map, masks, grid, heightfield } => {
                self.visibility_published(scene, q, map, masks, grid, *heightfield)
            }
            Prepared::Traced => self.fallback.trace(scene, q),
        }
    }

    fn memory_bytes(&self) -> u64 {
        match &self.state {
            None | Some(Prepared::Traced) => 0,
            Some(Prepared::Published { map, masks, .. }) => {
                masks.iter().map(Mask::bytes).sum::<u64>() + map.bytes()
            }
            Some(Prepared::Exact { map, masks, .. }) => {
                masks.iter().map(|m| m.mask.bytes()).sum::<u64>() + map.bounds.bytes() + map.near.bytes()
            }
        }
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let masks: Vec<&Mask> = match &self.state {
            Some(Prepared::Published { masks, .. }) => masks.iter().collect(),
            Some(Prepared::Exact { masks, .. }) => masks.iter().map(|m| &m.mask).collect(),
            None | Some(Prepared::Traced) => Vec::new(),
        };
        let map_bytes = match &self.state {
            Some(Prepared::Published { map, .. }) => map.bytes(),
            Some(Prepared::Exact { map, .. }) => map.bounds.bytes() + map.near.bytes(),
            None | Some(Prepared::Traced) => 0,
        };
        let mut c = vec![
            ("masks_built", masks.len() as u64),
            ("mask_bytes", masks.iter().map(|m| m.bytes()).sum::<u64>()),
            ("mask_bytes_estimated", self.mask_bytes_estimated.load(Ordering::Relaxed)),
            ("mask_crossings", masks.iter().map(|m| m.crossings() as u64).sum::<u64>()),
            ("depth_map_bytes", map_bytes),
            ("edge_lookups", self.lookups.load(Ordering::Relaxed)),
            ("blocks_culled", self.blocks_culled.load(Ordering::Relaxed)),
        ];
        if let Some(Prepared::Exact { map, .. }) = &self.state {
            let e = &self.exact_counters;
            c.extend([
                ("rays_clear", e.rays_clear.load(Ordering::Relaxed)),
                ("rays_blocked", e.rays_blocked.load(Ordering::Relaxed)),
                ("shadow_rays", e.rays_traced.load(Ordering::Relaxed)),
                ("shafts_tested", e.shafts.load(Ordering::Relaxed)),
                ("shadow_rays_near_field", e.rays_near_traced.load(Ordering::Relaxed)),
                ("shadow_rays_far_field", e.rays_far_traced.load(Ordering::Relaxed)),
                ("points_shaft_clear", e.points_shaft_clear.load(Ordering::Relaxed)),
                ("points_off_map", e.points_off_map.load(Ordering::Relaxed)),
                ("points_horizon_traced", e.points_horizon_traced.load(Ordering::Relaxed)),
                ("open_edges", map.bounds.open_edges),
            ]);
            c.extend(self.fallback.counters().into_iter().filter(|(k, _)| k.starts_with("fallback_")));
        } else {
            c.extend([
                ("early_outs", self.early_outs.load(Ordering::Relaxed)),
                ("regions_clipped", self.clipped.load(Ordering::Relaxed)),
            ]);
            c.extend(self.fallback.counters());
        }
        c
    }
}
