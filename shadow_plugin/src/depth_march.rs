//! `depth_march`: each shadow ray marched on its own through the depth map, pixel by pixel,
//! with the walls-and-floors test (Agrawala et al. 2000, one ray at a time). The baseline
//! that edge tables must beat, and their test oracle: it uses the same depth map, the same
//! crossing arithmetic and the same bias.
//!
//! Scene file: `method = "depth_march"`, with `[shadows.depth_march]` `depth_map` (pixels per
//! side, default 256) and `slope_bias` (pixels, default 1.0).

use crate::bits::{self, MAX_SAMPLES, MAX_WORDS};
use crate::depth_map::{DepthMap, DepthMapParams, MapPoint};
use crate::march::{floor_height, for_each_crossing, region_reach, stop_height};
use crate::samples;
use glam::Vec2;
use renderer::sampling::Rng;
use renderer::{LightShadowing, PrepareContext, Scene, ShadowError, ShadowQuery, Traced, TracedParams};
use std::sync::atomic::{AtomicU64, Ordering};

/// Visible-sample bits of the rays from map point `mp` to `samples`: bit r is 1 iff ray r
/// is not blocked by the solid heightfield of `map`.
pub fn march_bits(map: &DepthMap, mp: &MapPoint, samples: &[Vec2], out: &mut [u64]) -> MarchStats {
    let mut stats = MarchStats::default();
    let n = samples.len();
    bits::fill_first(out, n);
    let [i0, j0] = mp.pixel;
    if floor_height(map.at(i0, j0), mp.z) >= 0.0 {
        out.iter_mut().for_each(|w| *w = 0); // at or behind its own floor
        return stats;
    }
    let h_stop = stop_height(map.z_min, mp.z);
    let pz_pitch = mp.z * map.pitch;
    for (r, s) in samples.iter().enumerate() {
        let mut blocked = false;
        for_each_crossing(mp.offset, *s, pz_pitch, h_stop, |c, h| {
            stats.steps += 1;
            blocked = h <= floor_height(map.at(i0 + c[0], j0 + c[1]), mp.z);
            !blocked
        });
        if blocked {
            out[r / 64] &= !(1u64 << (r % 64));
        }
    }
    stats
}

#[derive(Debug, Default, Clone, Copy)]
pub struct MarchStats {
    pub steps: u64,
}

/// The plugin.
pub struct DepthMarch {
    params: DepthMapParams,
    samples: u32,
    map: Option<DepthMap>,
    fallback: Traced,
    steps: AtomicU64,
    fallbacks: AtomicU64,
    early_outs: AtomicU64,
}

impl DepthMarch {
    /// # Panics
    /// `samples` above [`MAX_SAMPLES`] (checked at the config boundary).
    pub fn new(params: DepthMapParams, samples: u32) -> Self {
        assert!((1..=MAX_SAMPLES as u32).contains(&samples));
        Self {
            params,
            samples,
            map: None,
            fallback: Traced::new(TracedParams { samples }),
            steps: AtomicU64::new(0),
            fallbacks: AtomicU64::new(0),
            early_outs: AtomicU64::new(0),
        }
    }

    pub fn depth_map(&self) -> Option<&DepthMap> {
        self.map.as_ref()
    }
}

impl LightShadowing for DepthMarch {
    fn name(&self) -> &'static str {
        "depth_march"
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.map = Some(DepthMap::build(ctx.scene, ctx.light, ctx.visible, &self.params));
        self.fallback.prepare(ctx)
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let map = self.map.as_ref().expect("prepare() runs before visibility()");
        let frame = &map.frame;
        let p = frame.light_from_world(q.p);
        if p.z <= map.z_min {
            self.early_outs.fetch_add(1, Ordering::Relaxed);
            return 1.0; // nearer the light than any surface in the map
        }
        let Some(mp) = map.locate(p) else {
            self.fallbacks.fetch_add(1, Ordering::Relaxed);
            return self.fallback.visibility(scene, q);
        };
        let reach = region_reach(frame.half_size, map.pitch, map.z_min.min(map.caster_z_near), p.z);
        let [i, j] = mp.pixel;
        if !map.contains([i - reach[0], j - reach[1]], [i + reach[0], j + reach[1]]) {
            self.fallbacks.fetch_add(1, Ordering::Relaxed);
            return self.fallback.visibility(scene, q);
        }
        let n = self.samples as usize;
        let mut sample_buf = [Vec2::ZERO; MAX_SAMPLES];
        let samples = &mut sample_buf[..n];
        samples::stratified(samples, frame.half_size, &mut Rng::new(q.seed));
        let w = bits::words(n);
        let mut visible = [0u64; MAX_WORDS];
        let mut above = [0u64; MAX_WORDS];
        let stats = march_bits(map, &mp, samples, &mut visible[..w]);
        self.steps.fetch_add(stats.steps, Ordering::Relaxed);
        samples::above_horizon(frame, samples, q.p, q.n_shading, &mut above[..w]);
        let n_above = bits::count(&above[..w]);
        if n_above == 0 {
            return 1.0;
        }
        bits::count_and(&visible[..w], &above[..w]) as f32 / n_above as f32
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let mut c = vec![
            ("march_steps", self.steps.load(Ordering::Relaxed)),
            ("fallbacks", self.fallbacks.load(Ordering::Relaxed)),
            ("early_outs", self.early_outs.load(Ordering::Relaxed)),
            ("depth_map_bytes", self.map.as_ref().map_or(0, |m| m.bytes())),
        ];
        c.extend(self.fallback.counters().into_iter().map(|(k, v)| (fallback_name(k), v)));
        c
    }
}

/// Counter names of the traced fallback, prefixed so they do not mix with a traced run's.
pub fn fallback_name(k: &'static str) -> &'static str {
    match k {
        "shadow_rays" => "fallback_shadow_rays",
        "shadow_rays_occluded" => "fallback_shadow_rays_occluded",
        other => other,
    }
}
