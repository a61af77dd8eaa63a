//! What the depth-map methods do where the map cannot answer: traced rays, counted. Shared
//! by `depth_march`, `edge_table` and `pcss`, so the policy and its counters are one.

use crate::depth_map::{DepthMap, MapPoint};
use glam::Vec3;
use renderer::{LightShadowing, PrepareContext, Scene, ShadowError, ShadowQuery, Traced, TracedParams};
use std::sync::atomic::{AtomicU64, Ordering};

/// The traced fallback of a depth-map method and its counters.
pub struct MapFallback {
    traced: Traced,
    /// Points answered by traced rays, for any reason.
    fallbacks: AtomicU64,
    /// Of those, points the light grazes ([`crate::DepthMapParams::grazing_cos`]).
    grazing: AtomicU64,
}

impl MapFallback {
    pub fn new(samples: u32) -> Self {
        Self {
            traced: Traced::new(TracedParams { samples, shaft_culling: true }),
            fallbacks: AtomicU64::new(0),
            grazing: AtomicU64::new(0),
        }
    }

    pub fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.traced.prepare(ctx)
    }

    /// Where query `q` reads `map` (its light-space lookup point and map point), or, where
    /// the light grazes the point or it falls outside the map, its traced visibility.
    #[inline]
    pub fn lookup(&self, map: &DepthMap, scene: &Scene, q: &ShadowQuery) -> Result<(Vec3, MapPoint), f32> {
        if map.grazing(q.p, q.n_geom) {
            self.grazing.fetch_add(1, Ordering::Relaxed);
            return Err(self.trace(scene, q));
        }
        map.query_point(q.p, q.n_geom).ok_or_else(|| self.trace(scene, q))
    }

    /// Traced visibility of `q`, counted as a fallback.
    pub fn trace(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        self.fallbacks.fetch_add(1, Ordering::Relaxed);
        self.traced.visibility(scene, q)
    }

    /// `fallbacks`, `fallbacks_grazing`, and the traced rays' counters, prefixed so they do
    /// not mix with a traced run's.
    pub fn counters(&self) -> Vec<(&'static str, u64)> {
        let mut c = vec![
            ("fallbacks", self.fallbacks.load(Ordering::Relaxed)),
            ("fallbacks_grazing", self.grazing.load(Ordering::Relaxed)),
        ];
        c.extend(self.traced.counters().into_iter().map(|(k, v)| {
            let k = match k {
                "shadow_rays" => "fallback_shadow_rays",
                "shadow_rays_occluded" => "fallback_shadow_rays_occluded",
                other => other,
            };
            (k, v)
        }));
        c
    }
}
