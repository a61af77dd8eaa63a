//! What `prepare` decides before it builds anything large: whether the scene's one rounding
//! margin defeats a depth map ([`Margins`]), whether the masks can fit at all
//! ([`refuse_impossible_masks`], from a coarse map), and each reading's depth levels with how
//! high their masks march.

use super::exact::{self, ExactMap};
use super::grid::{self, Layout};
use super::{Blend, EdgeTableParams, Heightfield, MASK_HEIGHT_QUANTILE, Reading, memory};
use crate::depth_map::march::stop_height;
use crate::depth_map::{DepthBounds, DepthMap};
use rayon::prelude::*;
use renderer::{PrepareContext, ShadingPoint, ShadowError};

/// The height masks march to: what the receivers need after region shrinking, up to its
/// [`MASK_HEIGHT_QUANTILE`]; the few receivers that need more fall back to traced.
pub(super) fn mask_height_cap(map: &DepthMap, visible: &[ShadingPoint]) -> f32 {
    let mut needed: Vec<f32> = visible
        .par_iter()
        .filter(|v| !map.grazing(v))
        .filter_map(|v| {
            // Points off the map are traced and need no height (with `fit_shadowed` they
            // are most of a wide floor).
            map.query_point(v)?;
            let p = map.frame.light_from_world(v.p);
            let mp = map.locate(p)?;
            Some(stop_height(map.stop_depth(mp.pixel, p.z).0, p.z))
        })
        .collect();
    if needed.is_empty() {
        0.0
    } else {
        let q = ((needed.len() - 1) as f64 * MASK_HEIGHT_QUANTILE) as usize;
        *needed.select_nth_unstable_by(q, f32::total_cmp).1
    }
}

/// The exact reading's conservative depth bounds for `params`' map, and the receivers they
/// were fitted to. The fit, the depth levels and the march height are estimates from the
/// receivers (exactness does not rest on them): every k-th of at most `QUANTILE_POINTS`
/// suffices, where all of them cost a shaft query each in the fit.
pub(super) fn exact_map(ctx: &PrepareContext, params: &EdgeTableParams) -> (ExactMap, Vec<ShadingPoint>) {
    let stride = ctx.visible.len().div_ceil(exact::QUANTILE_POINTS).max(1);
    let visible: Vec<ShadingPoint> = ctx.visible.iter().step_by(stride).copied().collect();
    let (bounds, near) = DepthBounds::build_for_light(ctx.scene, ctx.light, &visible, &params.depth_map());
    let map = ExactMap { bounds, near, light: *ctx.light, scene_bound: ctx.scene.coordinate_bound() };
    (map, visible)
}

/// The published reading's depth levels, and per level its depth and how high its masks
/// march: far enough for the deepest point it serves, and no further than the receivers need.
pub(super) fn published_levels(
    map: &DepthMap,
    visible: &[ShadingPoint],
    gz: u32,
    blend: Blend,
) -> (Vec<f32>, Vec<(f32, f32)>) {
    let _span = tracing::info_span!("depth_levels").entered();
    let (levels, z_hi) = grid::depth_levels(map, visible, gz);
    let serve_hi = grid::serve_depths(&levels, z_hi, blend);
    let h_cap = mask_height_cap(map, visible);
    let per_level =
        levels.iter().zip(&serve_hi).map(|(&z, &hi)| (z, stop_height(map.z_min, hi).min(h_cap))).collect();
    (levels, per_level)
}

/// The exact reading's depth levels, and per level its depth and march height (what the
/// receivers' regions need, up to [`MASK_HEIGHT_QUANTILE`]).
pub(super) fn exact_levels(map: &ExactMap, visible: &[ShadingPoint], gz: u32) -> (Vec<f32>, Vec<(f32, f32)>) {
    let _span = tracing::info_span!("depth_levels").entered();
    let (levels, _) = grid::depth_levels(&map.near, visible, gz);
    let w_cap = map.stop_reach_quantile(visible, MASK_HEIGHT_QUANTILE);
    let per_level = levels
        .iter()
        .map(|&z| {
            let s = z * w_cap;
            (z, if s.is_finite() { s / (1.0 + s) } else { 1.0 })
        })
        .collect();
    (levels, per_level)
}

/// Depth maps up to this size are built before their masks are estimated (a few ms); a
/// larger one's masks are first estimated on a map of this size.
const COARSE_RESOLUTION: u32 = 256;

/// How far over the budget the coarse estimate must be to refuse before the map is built.
const EARLY_REFUSAL: u64 = 4;

/// Refuses masks the memory budget cannot hold before the depth map is built: their bytes
/// estimated from a [`COARSE_RESOLUTION`] map of the same reading (its fit and depth
/// levels; the real map's pixel pitch), against the budget less the real map's peak. A
/// request the masks' own check (after the map) would refuse is refused here, in
/// milliseconds, where the real map took 63 s and 5 GB (depth_map = 8192, grid [16, 16,
/// 16], 4096 samples: 172 GiB of masks); an estimate that falls short leaves that check.
pub(super) fn refuse_impossible_masks(
    params: &EdgeTableParams,
    samples: u32,
    ctx: &PrepareContext,
) -> Result<(), ShadowError> {
    let res = params.resolution;
    if res <= COARSE_RESOLUTION {
        return Ok(());
    }
    let coarse = EdgeTableParams { resolution: COARSE_RESOLUTION, ..*params };
    let gz = params.grid[2];
    let (map, per_level, heightfield, layout) = match &params.reading {
        Reading::Exact => {
            let (map, visible) = exact_map(ctx, &coarse);
            let (_, per_level) = exact_levels(&map, &visible, gz);
            (map.near, per_level, Heightfield::Plates, Layout::new(params.grid, false))
        }
        Reading::Published(p) => {
            let map = DepthMap::build(ctx.scene, ctx.light, ctx.visible, &coarse.depth_map());
            let (_, per_level) = published_levels(&map, ctx.visible, gz, p.blend);
            (map, per_level, p.heightfield, Layout::new(params.grid, params.switches.mirrored))
        }
    };
    let pitch = map.pitch * COARSE_RESOLUTION as f32 / res as f32;
    let half = map.frame.half_size;
    let budget = ctx.memory_budget_bytes.saturating_sub(memory::map_peak_bytes(params));
    // Refused here only past EARLY_REFUSAL times the budget: the coarse map's levels
    // put the estimate within ~2x of the real map's (measured: 301 GiB against 172 GiB
    // for the request above), and a request near the budget is left to the exact check.
    let bound = budget.saturating_mul(EARLY_REFUSAL);
    let estimate = memory::estimate_masks(
        ctx,
        params,
        samples,
        (half, pitch),
        &layout.built,
        (heightfield, &per_level),
        bound,
    );
    if estimate.bytes <= bound {
        return Ok(());
    }
    memory::check_masks(params, samples, &estimate, budget).map_err(|mut e| {
        e.message.push_str(&format!(
            " (estimated on a {COARSE_RESOLUTION}^2 map, before the {res}^2 one was built)"
        ));
        e
    })
}

/// The depth map's rounding margins are `gamma(64)` of the scene's largest coordinate (one
/// margin for every triangle, so that their depth ranges in a pixel compare: see
/// `depth_map::bounds`), unlike `traced`'s and `silhouette`'s, which follow each triangle.
/// Far geometry widens them (a 1 m quad 10^5 m away: 0.4 m, 1.25x the rays; at 10^6 m, 4 m:
/// the map is not built, [`Margins::defeat_the_map`]).
pub(super) struct Margins {
    /// The scene's largest coordinate, the margin it gives, and the light's distance to the
    /// farthest point it lights (of up to 1024 visible points).
    bound: f32,
    margin: f32,
    reach: f32,
}

impl Margins {
    pub(super) fn of(ctx: &PrepareContext) -> Margins {
        let bound = ctx.scene.coordinate_bound();
        let margin = renderer::geometry::ray_origin::gamma(64) * bound;
        let step = ctx.visible.len().div_ceil(1024).max(1);
        let reach =
            ctx.visible.iter().step_by(step).map(|q| (q.p - ctx.light.center).length()).fold(0.0, f32::max);
        Margins { bound, margin, reach }
    }

    /// Whether the margin passes 1/8 of the light's reach: the masks then march ever further
    /// to tell occluders from receivers, and cost more than tracing. Measured on the default
    /// scene with its floor enlarged (640x480, render seconds; margin / reach): 10^5 m 0.71 s
    /// (0.044), 2x10^5 0.86 (0.088), 3x10^5 0.91 (0.13), 5x10^5 1.5 (0.22), 7x10^5 4.6 (0.30),
    /// 10^6 12.9 (0.44: 164 MB of masks, 1.05 G edge lookups); every ray traced, 0.6 s. Past
    /// it no map is built and every ray is traced.
    pub(super) fn defeat_the_map(&self) -> bool {
        self.reach > 0.0 && self.margin > 0.125 * self.reach
    }

    /// A warning where the margin exceeds 1/100 of the light's reach.
    pub(super) fn warning(&self) -> Option<String> {
        let Margins { bound, margin, reach } = *self;
        let cost = if self.defeat_the_map() {
            "every ray is traced, at traced's cost (no depth map is built)"
        } else {
            "more rays are traced"
        };
        (reach > 0.0 && margin > 1e-2 * reach).then(|| {
            format!(
                "edge_table: geometry {bound:.1e} m from the camera widens the depth map's rounding \
                 margins to {margin:.1e} m, against {reach:.1e} m from the light to what it lights: {cost}; \
                 traced and silhouette do not depend on it"
            )
        })
    }
}
