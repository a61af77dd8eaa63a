//! What the depth-map methods do where the map cannot answer: traced rays, counted; and the
//! opening of their `visibility` that decides it ([`MapFallback::locate`]). Shared by
//! `depth_march`, `edge_table` and `pcss`, so the policy and its counters are one.

use crate::depth_map::{DepthMap, MapPoint};
use glam::Vec3;
use renderer::{LightShadowing, PrepareContext, Scene, ShadowError, ShadowQuery, Traced, TracedParams};
use std::sync::atomic::{AtomicU64, Ordering};

/// How [`MapFallback::locate`] routes a query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Located {
    /// The light grazes the point or it falls outside the map: its traced visibility
    /// (counted as a fallback).
    Traced(f32),
    /// Nearer the light than any surface in the map: nothing can shadow it (visibility 1;
    /// the methods count it as an early out).
    NearerThanMap,
    /// The map answers.
    OnMap(OnMap),
}

/// A query point the map answers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OnMap {
    /// The light-space lookup point ([`DepthMap::lookup_point`]) and where it falls in the
    /// map.
    pub p: Vec3,
    pub mp: MapPoint,
    /// [`DepthMap::stop_depth`] at the point: the depth above which none of its rays can be
    /// blocked, and whether its filter region reaches outside the map.
    pub z_stop: f32,
    pub clipped: bool,
}

/// The traced fallback of a depth-map method and its counters.
pub struct MapFallback {
    traced: Traced,
    /// Points answered by traced rays, for any reason.
    fallbacks: AtomicU64,
    /// Of those, points the light grazes ([`crate::depth_map::DepthMapParams::grazing_cos`]).
    grazing: AtomicU64,
}

impl MapFallback {
    pub fn new(samples: u32) -> Self {
        Self {
            traced: Traced::new(TracedParams::CULLED, samples),
            fallbacks: AtomicU64::new(0),
            grazing: AtomicU64::new(0),
        }
    }

    pub fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.traced.prepare(ctx)
    }

    /// The opening every depth-map method's `visibility` shares: where the light grazes
    /// the point ([`DepthMap::grazing`]) or its lookup point falls outside the map
    /// ([`DepthMap::query_point`]), traced rays answer (counted here); a point nearer the
    /// light than any surface in the map is unshadowed; any other point is located in the
    /// map with its stop depth ([`DepthMap::stop_depth`]).
    #[inline]
    pub fn locate(&self, map: &DepthMap, scene: &Scene, q: &ShadowQuery) -> Located {
        if map.grazing(&q.point) {
            self.grazing.fetch_add(1, Ordering::Relaxed);
            return Located::Traced(self.trace(scene, q));
        }
        let Some((p, mp)) = map.query_point(&q.point) else {
            return Located::Traced(self.trace(scene, q));
        };
        if p.z <= map.z_min {
            return Located::NearerThanMap;
        }
        let (z_stop, clipped) = map.stop_depth(mp.pixel, p.z);
        Located::OnMap(OnMap { p, mp, z_stop, clipped })
    }

    /// Traced visibility of `q`, counted as a fallback.
    pub fn trace(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        self.fallbacks.fetch_add(1, Ordering::Relaxed);
        renderer::util::pixel_cost::count_fallback();
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
