//! The `LightShadowing` plugin interface and the two built-in methods: `traced` (the ground
//! truth) and `none`.
//!
//! A method is built per light and frame: [`LightShadowing::prepare`] runs once, with the
//! scene and the camera's primary hits, before the pixel loop (its wall time is the run
//! report's `shadow_prepare`); then [`LightShadowing::visibility`] answers per shading point
//! through `&self`, without allocating, from any thread.

use crate::light::RectLight;
use crate::sampling::{Rng, strata};
use crate::scene::Scene;
use glam::Vec3;
use std::sync::atomic::{AtomicU64, Ordering};

/// What a method may look at when it prepares for one light.
pub struct PrepareContext<'a> {
    pub scene: &'a Scene,
    pub light: &'a RectLight,
    pub light_index: usize,
    /// Every primary hit of the frame (what the camera sees), for methods that fit a depth
    /// map or other structure to it.
    pub visible: &'a [VisiblePoint],
    /// The frame's seed.
    pub seed: u64,
}

/// A primary hit, as handed to `prepare`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisiblePoint {
    pub p: Vec3,
    pub n_geom: Vec3,
    pub n_shading: Vec3,
}

/// One visibility question: the fraction of the light (its part above the tangent plane of
/// `n_shading`) that `p` sees unoccluded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowQuery {
    /// The shading point (render space), on the surface: not offset.
    pub p: Vec3,
    /// Unit geometric normal, on the side the camera ray came from. Ray origins are offset
    /// along it (`Scene::epsilon`).
    pub n_geom: Vec3,
    /// Unit shading normal (same side): defines the horizon.
    pub n_shading: Vec3,
    /// Pixel (x, y), for methods that key anything on it.
    pub pixel: [u32; 2],
    /// Seed of this point's random stream: a pure function of (frame seed, pixel, primary
    /// sample, light), never of the thread.
    pub seed: u64,
}

/// Why `prepare` could not build a method's structures.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{method}: {message}")]
pub struct ShadowError {
    pub method: &'static str,
    pub message: String,
}

/// The shadow-method plugin interface. See the module doc.
pub trait LightShadowing: Send + Sync {
    /// The method's name as the scene file spells it (`traced`, `none`, ...).
    fn name(&self) -> &'static str;

    /// Builds whatever the method needs for `ctx.light` in this frame.
    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError>;

    /// Visibility in [0, 1] of the prepared light from `q`. Called only where the light's
    /// unshadowed irradiance at `q` is non-zero. Must not allocate.
    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32;

    /// Counters for the run report (name, value), summed over lights by the renderer.
    fn counters(&self) -> Vec<(&'static str, u64)> {
        Vec::new()
    }
}

/// No shadows: V = 1 everywhere. The cost floor every method's shadow cost is measured
/// against.
#[derive(Debug, Default)]
pub struct Unshadowed;

impl LightShadowing for Unshadowed {
    fn name(&self) -> &'static str {
        "none"
    }
    fn prepare(&mut self, _: &PrepareContext) -> Result<(), ShadowError> {
        Ok(())
    }
    fn visibility(&self, _: &Scene, _: &ShadowQuery) -> f32 {
        1.0
    }
}

/// Parameters of the traced method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TracedParams {
    /// Light samples per shading point: a stratified nx x ny grid (nx * ny = samples,
    /// see [`strata`]), jittered per point. 1024 matches the edge-table masks.
    pub samples: u32,
}

/// The ground truth: `samples` stratified, jittered points on the light, one any-hit shadow
/// ray through the BVH to each. Samples below the shading point's horizon are not counted
/// (they are already excluded from the irradiance).
#[derive(Debug)]
pub struct Traced {
    params: TracedParams,
    light: Option<RectLight>,
    rays: AtomicU64,
    occluded: AtomicU64,
}

impl Traced {
    pub fn new(params: TracedParams) -> Self {
        Self { params, light: None, rays: AtomicU64::new(0), occluded: AtomicU64::new(0) }
    }
}

impl LightShadowing for Traced {
    fn name(&self) -> &'static str {
        "traced"
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        if self.params.samples == 0 {
            return Err(ShadowError { method: "traced", message: "samples must be >= 1".into() });
        }
        self.light = Some(*ctx.light);
        Ok(())
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let light = self.light.as_ref().expect("prepare() runs before visibility()");
        let (nx, ny) = strata(self.params.samples);
        let mut rng = Rng::new(q.seed);
        let (mut above, mut unblocked) = (0u32, 0u32);
        for j in 0..ny {
            for i in 0..nx {
                let a = (i as f32 + rng.next_f32()) / nx as f32;
                let b = (j as f32 + rng.next_f32()) / ny as f32;
                let target = light.point(a, b);
                if q.n_shading.dot(target - q.p) <= 0.0 {
                    continue; // below the horizon: not part of the light this point sees
                }
                above += 1;
                if !scene.segment_occluded(q.p, q.n_geom, target) {
                    unblocked += 1;
                }
            }
        }
        // Relaxed counters: one add per query, not per ray (measured: no visible cost).
        self.rays.fetch_add(above as u64, Ordering::Relaxed);
        self.occluded.fetch_add((above - unblocked) as u64, Ordering::Relaxed);
        if above == 0 {
            // The irradiance is non-zero but no sample landed above the horizon: a sliver
            // thinner than one stratum. Too small to resolve; count it unshadowed.
            return 1.0;
        }
        unblocked as f32 / above as f32
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        vec![
            ("shadow_rays", self.rays.load(Ordering::Relaxed)),
            ("shadow_rays_occluded", self.occluded.load(Ordering::Relaxed)),
        ]
    }
}
