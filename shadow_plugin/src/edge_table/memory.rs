//! What a light's depth map and masks will take, found before they are built, so that a
//! configuration the memory budget cannot hold is refused in milliseconds rather than after
//! the allocations (a 64 x 64 x 1 grid at 4096 samples used to refuse after 39 s and 11.9 GB;
//! `depth_map = 8192` built its 5.1 GB unannounced).

use super::params::{EdgeTableParams, Reading};
use super::{EdgeTable, Mask, grid};
use crate::depth_map::heightfield::Heightfield;
use crate::depth_map::mask_samples;
use glam::Vec2;
use renderer::util::random::{Rng, stream_seed};
use renderer::{PrepareContext, ShadowError};

/// Peak bytes per depth-map pixel while the exact reading's map is built: the conservative
/// bounds (16 bytes held), the near map and its pyramid (about 13), and the rasterization's
/// per-pixel accumulators and triangle ranges (freed after the build). Measured as the slope
/// of peak RSS between `depth_map = 2048` and `4096` on the default scene: 78.8 bytes.
pub const MAP_PEAK_BYTES_PER_PIXEL_EXACT: u64 = 80;
/// The same for the published reading's map (floor, slab bottom, hidden layer, 16 bytes
/// held, and the min-depth pyramid): measured 22.3 bytes.
pub const MAP_PEAK_BYTES_PER_PIXEL_PUBLISHED: u64 = 24;

/// From this many bytes of map and masks, a prepared light says what it took (a warning):
/// more than most renders expect a shadow method to use.
pub const WARN_BYTES: u64 = 1 << 30;

/// Bytes as a person reads them: "5.0 GiB", "22.1 MiB".
pub fn human(bytes: u64) -> String {
    let mib = bytes as f64 / (1u64 << 20) as f64;
    if mib >= 1024.0 { format!("{:.1} GiB", mib / 1024.0) } else { format!("{mib:.1} MiB") }
}

/// The peak bytes of building `params`' depth map: its pixels times what each takes at the
/// peak ([`MAP_PEAK_BYTES_PER_PIXEL_EXACT`], [`MAP_PEAK_BYTES_PER_PIXEL_PUBLISHED`]).
pub fn map_peak_bytes(params: &EdgeTableParams) -> u64 {
    let per_pixel = match params.reading {
        Reading::Exact => MAP_PEAK_BYTES_PER_PIXEL_EXACT,
        Reading::Published(_) => MAP_PEAK_BYTES_PER_PIXEL_PUBLISHED,
    };
    (params.resolution as u64).pow(2) * per_pixel
}

/// Refuses a depth map whose build would pass `budget`, naming `depth_map` and the bytes.
pub fn check_map(params: &EdgeTableParams, budget: u64) -> Result<(), ShadowError> {
    let need = map_peak_bytes(params);
    if need <= budget {
        return Ok(());
    }
    let res = params.resolution;
    Err(ShadowError {
        method: EdgeTable::NAME,
        message: format!(
            "depth_map = {res} needs about {} to build ({res} x {res} pixels, {} bytes each), more than \
             the {} left of the memory budget; use a smaller depth_map (each halving needs a quarter)",
            human(need),
            need / (res as u64).pow(2),
            human(budget)
        ),
    })
}

/// Grid cell `m`'s mask's inputs as [`EdgeTable::build_masks`] builds it: its sub-pixel
/// offset and its light samples (seeded by frame, light and cell).
pub fn mask_inputs(
    ctx: &PrepareContext,
    params: &EdgeTableParams,
    samples: u32,
    half: Vec2,
    m: u32,
) -> (Vec2, Vec<Vec2>) {
    let [gx, gy, _] = params.grid;
    let [ax, ay, _] = grid::coordinates(m, params.grid);
    // The exact reading's masks sit at their cell's lower corner (a point's ray is the mask's
    // shifted by less than one cell along +x and +y); the published reading's at the cell's
    // centre.
    let centre = if params.reading == Reading::Exact { 0.0 } else { 0.5 };
    let offset = Vec2::new((ax as f32 + centre) / gx as f32, (ay as f32 + centre) / gy as f32);
    let mut s = vec![Vec2::ZERO; samples as usize];
    let light = ctx.light_index as u64;
    mask_samples::stratified(&mut s, half, &mut Rng::new(stream_seed(&[ctx.seed, light, m as u64, 3])));
    (offset, s)
}

/// The masks of grid cells `built` at depth levels `levels` (depth, march height), as
/// [`EdgeTable::build_masks`] would build them: per depth level, one mask's exact bytes
/// ([`Mask::estimate_bytes`], the built cell nearest the grid's centre) times the masks built
/// at that level. Masks of one level differ only in sub-pixel offset and samples, which
/// moves each ray's crossings by at most one per axis.
pub struct MaskEstimate {
    pub bytes: u64,
    pub masks: usize,
    /// Whether every depth level was estimated (`false`: `bytes` is the levels' so far, which
    /// already passed the caller's bound: a lower bound).
    pub complete: bool,
}

/// See [`MaskEstimate`].
pub fn estimate_masks(
    ctx: &PrepareContext,
    params: &EdgeTableParams,
    samples: u32,
    (half, pitch): (Vec2, f32),
    built: &[u32],
    (heightfield, levels): (Heightfield, &[(f32, f32)]),
    stop_above: u64,
) -> MaskEstimate {
    let [gx, gy, _] = params.grid;
    let mut bytes = 0u64;
    for (k, &(depth, h_stop)) in levels.iter().enumerate() {
        // Each level's estimate builds one mask's crossings: seconds for masks of tens of
        // MiB. Past `stop_above` the answer is known.
        if bytes > stop_above {
            return MaskEstimate { bytes, masks: built.len(), complete: false };
        }
        let at_level: Vec<u32> =
            built.iter().copied().filter(|&m| grid::coordinates(m, params.grid)[2] == k as u32).collect();
        let centre = |&&m: &&u32| {
            let [ax, ay, _] = grid::coordinates(m, params.grid);
            (2 * ax).abs_diff(gx) + (2 * ay).abs_diff(gy)
        };
        let Some(&m) = at_level.iter().min_by_key(centre) else { continue };
        let (offset, s) = mask_inputs(ctx, params, samples, half, m);
        bytes += Mask::estimate_bytes(heightfield, offset, depth, s, pitch, h_stop) * at_level.len() as u64;
    }
    MaskEstimate { bytes, masks: built.len(), complete: true }
}

/// Refuses masks whose estimate passes `budget`, naming the grid, the samples and the bytes.
pub fn check_masks(
    params: &EdgeTableParams,
    samples: u32,
    estimate: &MaskEstimate,
    budget: u64,
) -> Result<(), ShadowError> {
    if estimate.bytes <= budget {
        return Ok(());
    }
    let need = if estimate.complete {
        format!(
            "about {} ({} masks of about {}",
            human(estimate.bytes),
            estimate.masks,
            human(estimate.bytes / estimate.masks.max(1) as u64)
        )
    } else {
        // Some depth levels were not estimated: no per-mask size to give.
        format!("at least {} ({} masks", human(estimate.bytes), estimate.masks)
    };
    Err(ShadowError {
        method: EdgeTable::NAME,
        message: format!(
            "the masks need {need}: grid {:?} x {samples} samples), more than the {} left of the memory \
             budget; use a smaller grid, fewer samples or a smaller depth map",
            params.grid,
            human(budget)
        ),
    })
}

/// The warning of a light whose map and masks took more than [`WARN_BYTES`], or `None`.
pub fn warning(params: &EdgeTableParams, map_peak: u64, held: u64, mask_bytes: u64) -> Option<String> {
    (map_peak.max(held) >= WARN_BYTES).then(|| {
        format!(
            "edge_table took about {} while its depth_map = {} was built and holds {} while rendering \
             ({} of it masks); each halving of depth_map takes a quarter of the map's share",
            human(map_peak.max(held)),
            params.resolution,
            human(held),
            human(mask_bytes)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The estimate is the built mask's bytes exactly, for both kinds of table layout
    /// (walls or not), small and large sample counts, shallow and deep marches.
    #[test]
    fn the_mask_estimate_is_the_built_masks_bytes() {
        let mut rng = Rng::new(7);
        for (n, depth, h_stop) in [(64, 1.0, 0.3), (1024, 2.0, 0.6), (4096, 2.0, 0.5), (256, 3.0, 0.05)] {
            let mut s = vec![Vec2::ZERO; n];
            mask_samples::stratified(&mut s, Vec2::new(0.45, 0.3), &mut rng);
            for heightfield in [Heightfield::Plates, Heightfield::Shells] {
                for offset in [Vec2::ZERO, Vec2::new(0.5, 0.25), Vec2::new(0.99, 0.01)] {
                    let pitch = 0.01;
                    let built = Mask::build_for(heightfield, offset, depth, s.clone(), pitch, h_stop).bytes();
                    let estimate = Mask::estimate_bytes(heightfield, offset, depth, s.clone(), pitch, h_stop);
                    assert_eq!(estimate, built, "{n} samples, {heightfield:?}, offset {offset}");
                }
            }
        }
    }

    /// A light that took a GiB or more says so; one that took less says nothing.
    #[test]
    fn a_light_that_takes_a_gib_says_what_it_took() {
        let params = EdgeTableParams { resolution: 8192, ..EdgeTableParams::default() };
        let peak = map_peak_bytes(&params);
        assert_eq!(peak, 8192 * 8192 * 80);
        assert_eq!(
            warning(&params, peak, 1700 << 20, 148 << 20).as_deref(),
            Some(
                "edge_table took about 5.0 GiB while its depth_map = 8192 was built and holds 1.7 GiB while \
                 rendering (148.0 MiB of it masks); each halving of depth_map takes a quarter of the map's share"
            )
        );
        let small = EdgeTableParams::default();
        assert_eq!(warning(&small, map_peak_bytes(&small), 30 << 20, 20 << 20), None);
    }

    #[test]
    fn bytes_read_as_people_read_them() {
        assert_eq!(human(5 << 30), "5.0 GiB");
        assert_eq!(human(22 << 20), "22.0 MiB");
        assert_eq!(human(0), "0.0 MiB");
    }
}
