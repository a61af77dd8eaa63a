//! `depth_march`: each shadow ray marched on its own through the depth map, pixel by pixel,
//! with the walls-and-floors test (Agrawala et al. 2000, one ray at a time). The baseline
//! that edge tables must beat, and their test oracle: it uses the same depth map, the same
//! crossing arithmetic and the same bias.
//!
//! Retired from the CLI's registry (docs/notes/2026-11-26-retired-depth-march.md: on no bench
//! scene's cost-error Pareto front): a scene file naming it is an error. The code stays as a
//! library, the oracle of `shadow_plugin/tests/differential.rs` and the baseline of
//! `benches/edge_table.rs`. Its table, were a registry to list it again ([`DepthMarchParams`]
//! still implements `MethodEntry`), holds the depth-map keys of `[shadows.edge_table]` and their
//! defaults: `depth_map` (256), `heightfield` (`plates`), `slope_bias` (1.0), `slab_thickness`
//! (2.0, `plates` only), `normal_offset` (0.5), `grazing_cos` (0.5).

mod entry;

use crate::depth_map::bits::{self, MAX_SAMPLES, MAX_WORDS};
use crate::depth_map::fallback::{Located, MapFallback, OnMap};
use crate::depth_map::heightfield::{Heightfield, inapplicable_to_reading};
use crate::depth_map::march::{ray_blocked, stop_height};
use crate::depth_map::mask_samples;
use crate::depth_map::{DepthMap, DepthMapParams, MapPoint};
use glam::Vec2;
use renderer::util::random::Rng;
use renderer::{
    KeyError, LightShadowing, MethodParams, PrepareContext, Scene, ShadowError, ShadowMethod, ShadowQuery,
};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};

/// Visible-sample bits of the rays from map point `mp` to `samples`: bit r is 1 iff ray r
/// is not blocked by the heightfield of `map` read as `heightfield`. `z_stop` is the depth
/// above which no ray can be blocked ([`DepthMap::stop_depth`]).
pub fn march_bits(
    map: &DepthMap,
    mp: &MapPoint,
    samples: &[Vec2],
    z_stop: f32,
    heightfield: Heightfield,
    out: &mut [u64],
) {
    bits::fill_first(out, samples.len());
    let [i0, j0] = mp.pixel;
    let h_stop = stop_height(z_stop, mp.z);
    let pz_pitch = mp.z * map.pitch;
    // `plates` reads the hidden layer too: blocked by a slab of either layer.
    let layers = if heightfield == Heightfield::Plates { map.layers() } else { 1 };
    for (r, s) in samples.iter().enumerate() {
        let blocked = (0..layers).any(|layer| {
            let floor = |c: [i32; 2]| map.layer_heights(layer, i0 + c[0], j0 + c[1], mp.z);
            ray_blocked(mp.offset, *s, pz_pitch, h_stop, heightfield, floor)
        });
        if blocked {
            out[r / 64] &= !(1u64 << (r % 64));
        }
    }
}

/// Parameters of `depth_march` (the scene file's `[shadows.depth_march]` is
/// [`DepthMarchTable`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthMarchParams {
    pub depth_map: DepthMapParams,
    /// How the depth map's heightfield is read.
    pub heightfield: Heightfield,
}

/// `[shadows.depth_march]`: the depth map's keys ([`DepthMapParams`]) and `heightfield`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DepthMarchTable {
    depth_map: u32,
    slope_bias: f32,
    slab_thickness: f32,
    normal_offset: f32,
    grazing_cos: f32,
    heightfield: Heightfield,
}

impl Default for DepthMarchParams {
    fn default() -> Self {
        // edge_table's defaults (its `balanced` preset).
        Self { depth_map: DepthMapParams::default(), heightfield: Heightfield::Plates }
    }
}

impl ShadowMethod for DepthMarchParams {
    fn name(&self) -> &'static str {
        DepthMarch::NAME
    }
    fn max_samples(&self) -> u32 {
        MAX_SAMPLES as u32
    }
    fn build(&self, samples: u32) -> Box<dyn LightShadowing> {
        Box::new(DepthMarch::new(self.depth_map, self.heightfield, samples))
    }
}

impl MethodParams for DepthMarchParams {
    const NAME: &'static str = DepthMarch::NAME;
    type Table = DepthMarchTable;
    fn table(&self) -> DepthMarchTable {
        let m = &self.depth_map;
        DepthMarchTable {
            depth_map: m.resolution,
            slope_bias: m.slope_bias,
            slab_thickness: m.slab_thickness,
            normal_offset: m.normal_offset,
            grazing_cos: m.grazing_cos,
            heightfield: self.heightfield,
        }
    }
    fn with_table(&self, t: DepthMarchTable) -> Self {
        let depth_map = DepthMapParams {
            resolution: t.depth_map,
            slope_bias: t.slope_bias,
            slab_thickness: t.slab_thickness,
            normal_offset: t.normal_offset,
            grazing_cos: t.grazing_cos,
            switches: self.depth_map.switches,
        };
        Self { depth_map, heightfield: t.heightfield }
    }
    fn inapplicable(&self, key: &str) -> Option<String> {
        inapplicable_to_reading(key, self.heightfield)
    }
    fn validate(&self) -> Result<(), KeyError> {
        self.depth_map.validate()
    }
}

/// The plugin.
pub struct DepthMarch {
    params: DepthMapParams,
    heightfield: Heightfield,
    samples: u32,
    map: Option<DepthMap>,
    fallback: MapFallback,
    early_outs: AtomicU64,
    clipped: AtomicU64,
}

impl DepthMarch {
    pub const NAME: &'static str = "depth_march";

    /// # Panics
    /// `samples` above [`MAX_SAMPLES`] (checked at the config boundary).
    pub fn new(params: DepthMapParams, heightfield: Heightfield, samples: u32) -> Self {
        assert!((1..=MAX_SAMPLES as u32).contains(&samples));
        Self {
            params,
            heightfield,
            samples,
            map: None,
            fallback: MapFallback::new(samples),
            early_outs: AtomicU64::new(0),
            clipped: AtomicU64::new(0),
        }
    }
}

impl LightShadowing for DepthMarch {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.map = Some(DepthMap::build(ctx.scene, ctx.light, ctx.visible, &self.params));
        self.fallback.prepare(ctx)
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let map = self.map.as_ref().expect("prepare() runs before visibility()");
        let frame = &map.frame;
        // Grazed points and points outside the map: traced rays answer (counted).
        let OnMap { mp, z_stop, clipped, .. } = match self.fallback.locate(map, scene, q) {
            Located::OnMap(on_map) => on_map,
            Located::Traced(v) => return v,
            Located::NearerThanMap => {
                self.early_outs.fetch_add(1, Ordering::Relaxed);
                return 1.0;
            }
        };
        if clipped {
            self.clipped.fetch_add(1, Ordering::Relaxed);
        }
        let n = self.samples as usize;
        let mut sample_buf = [Vec2::ZERO; MAX_SAMPLES];
        let samples = &mut sample_buf[..n];
        mask_samples::stratified(samples, frame.half_size, &mut Rng::new(q.seed));
        let w = bits::words(n);
        let mut visible = [0u64; MAX_WORDS];
        let mut above = [0u64; MAX_WORDS];
        march_bits(map, &mp, samples, z_stop, self.heightfield, &mut visible[..w]);
        mask_samples::above_horizon(frame, samples, Vec2::ONE, &q.point, &mut above[..w]);
        let n_above = bits::count(&above[..w]);
        if n_above == 0 {
            return 1.0;
        }
        bits::count_and(&visible[..w], &above[..w]) as f32 / n_above as f32
    }

    fn memory_bytes(&self) -> u64 {
        self.map.as_ref().map_or(0, DepthMap::bytes)
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let mut c = vec![
            ("early_outs", self.early_outs.load(Ordering::Relaxed)),
            ("regions_clipped", self.clipped.load(Ordering::Relaxed)),
            ("depth_map_bytes", self.map.as_ref().map_or(0, |m| m.bytes())),
        ];
        c.extend(self.fallback.counters());
        c
    }
}
