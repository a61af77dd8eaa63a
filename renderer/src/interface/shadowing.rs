//! The `LightShadowing` plugin interface. The two built-in methods, `traced` (the ground
//! truth) and `none`, are in [`crate::methods::traced`]; how a method is configured is
//! [`crate::interface::method`].
//!
//! A method is built per light and frame: [`LightShadowing::prepare`] runs once, with the
//! scene and the camera's primary hits, before the pixel loop (its wall time is the run
//! report's `shadow_prepare`); then [`LightShadowing::visibility`] answers per shading point
//! through `&self`, without allocating, from any thread.

use crate::geometry::light::RectLight;
use crate::geometry::point::ShadingPoint;
use crate::geometry::scene::Scene;
use crate::interface::lobe::{GlossyLobe, LobeVisibility};

/// What a method may look at when it prepares for one light.
pub struct PrepareContext<'a> {
    pub scene: &'a Scene,
    pub light: &'a RectLight,
    pub light_index: usize,
    /// Every primary hit of the frame (what the camera sees), for methods that fit a depth
    /// map or other structure to it; empty when no method of the frame reads it
    /// ([`LightShadowing::reads_visible_points`]).
    pub visible: &'a [ShadingPoint],
    /// The frame's seed.
    pub seed: u64,
    /// Most bytes a method may hold for this light (`edge_table`'s masks), from
    /// [`crate::RenderSettings::memory_budget_bytes`]: given as data, so that methods never
    /// probe their environment.
    pub memory_budget_bytes: u64,
}

impl<'a> PrepareContext<'a> {
    /// Light `light_index` of `scene` alone: no visible points, seed 0, no memory budget.
    /// For methods that read none of them (`traced`, `silhouette`), studies and tests.
    pub fn for_light(scene: &'a Scene, light_index: usize) -> Self {
        let light = &scene.lights[light_index];
        Self { scene, light, light_index, visible: &[], seed: 0, memory_budget_bytes: u64::MAX }
    }

    /// An error for `method` if the scene keeps instances unflattened: a method that reads
    /// the triangle arrays (its own structures over them) would miss those instances.
    pub fn require_flattened(&self, method: &'static str) -> Result<(), ShadowError> {
        match self.scene.kept_instances() {
            0 => Ok(()),
            kept => Err(ShadowError {
                method,
                message: format!(
                    "the scene keeps {kept} instances unflattened (it does not fit in memory flattened); \
                     this method needs its triangles flattened: use `traced`"
                ),
            }),
        }
    }
}

/// One visibility question: the fraction of the light (its part above the tangent plane of
/// `point.n_shading`) that `point.p` sees unoccluded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowQuery {
    /// The shading point, on the surface (not offset), with its error bound and normals
    /// (on the side the camera ray came from).
    pub point: ShadingPoint,
    /// Pixel (x, y), for methods that key anything on it.
    pub pixel: [u32; 2],
    /// Seed of this point's random stream: a pure function of (frame seed, pixel, primary
    /// sample, light), never of the thread.
    pub seed: u64,
    /// The light's unshadowed irradiance at the point over its radiance
    /// ([`crate::RectLight::irradiance_factor`]), as the shading computed it, or 0 where the
    /// caller did not: the denominator of V's share of irradiance, which a method then
    /// computes itself ([`crate::methods::irradiance_share`]).
    pub irradiance: f32,
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

    /// Whether `prepare` reads [`PrepareContext::visible`] (to fit a depth map to what the
    /// camera sees). When no light's method does, the frame does not gather those points:
    /// `none` at 16384 x 4096 spent 5.8 s and gigabytes on a list nobody read. True unless a
    /// method says otherwise, so that a new method is never handed an empty list unasked.
    fn reads_visible_points(&self) -> bool {
        true
    }

    /// Visibility in [0, 1] of the prepared light from `q`. Called only where the light's
    /// unshadowed irradiance at `q` is non-zero. Must not allocate.
    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32;

    /// For a glossy surface: V and the share of `lobe`'s weighted light
    /// ([`crate::interface::lobe`]), from one set of verdicts. Called, like `visibility`,
    /// only where the light's unshadowed irradiance at `q` is non-zero; must not allocate.
    /// The default weighs no lobe: the glossy share is V (the depth-map methods, whose
    /// verdicts are not per light point; the contract says so).
    fn visibility_glossy(&self, scene: &Scene, q: &ShadowQuery, lobe: &GlossyLobe) -> LobeVisibility {
        let _ = lobe;
        LobeVisibility::both(self.visibility(scene, q))
    }

    /// XORed into the frame's seed where this method's query seeds are derived
    /// ([`ShadowQuery::seed`]; 0, the frame's own streams, unless a method asks for light
    /// samples independent of every other method's along the same paths).
    fn seed_salt(&self) -> u64 {
        0
    }

    /// Counters for the run report (name, value), summed over lights by the renderer.
    fn counters(&self) -> Vec<(&'static str, u64)> {
        Vec::new()
    }

    /// What the last `prepare` did that a user should hear of (such as the memory it took),
    /// one line each; the frame adds them to its warnings, naming the light.
    fn warnings(&self) -> Vec<String> {
        Vec::new()
    }

    /// Bytes the prepared structures hold (depth maps, masks): taken off the memory budget
    /// of the lights prepared after this one.
    fn memory_bytes(&self) -> u64 {
        0
    }
}
