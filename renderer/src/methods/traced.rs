//! The two built-in methods: `traced`, the ground truth (shadow rays through the BVH), and
//! `none`, the cost floor. Both are configured like every plugin ([`crate::interface::method`]).

use crate::geometry::scene::Scene;
use crate::interface::entry::MethodEntry;
use crate::interface::lobe::{GlossyLobe, LobeVisibility};
use crate::interface::method::{KeyError, MethodParams, NoKeys, ShadowMethod};
use crate::interface::shadowing::{LightShadowing, PrepareContext, ShadowError, ShadowQuery};
use crate::methods::sample_stream::{Culling, SampleStream};
use std::sync::atomic::{AtomicU64, Ordering};

/// No shadows: V = 1 everywhere. The cost floor every method's shadow cost is measured
/// against. `[shadows.none]` takes no keys.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Unshadowed {}

impl Unshadowed {
    pub const NAME: &'static str = "none";
}

impl ShadowMethod for Unshadowed {
    fn name(&self) -> &'static str {
        Self::NAME
    }
    fn max_samples(&self) -> u32 {
        MAX_TRACED_SAMPLES
    }
    fn build(&self, _samples: u32) -> Box<dyn LightShadowing> {
        Box::new(*self)
    }
}

impl MethodParams for Unshadowed {
    const NAME: &'static str = Self::NAME;
    type Table = NoKeys;
    fn table(&self) -> NoKeys {
        NoKeys {}
    }
    fn with_table(&self, _: NoKeys) -> Self {
        *self
    }
    fn validate(&self) -> Result<(), KeyError> {
        Ok(())
    }
}

impl MethodEntry for Unshadowed {
    const TRACES_KEPT_INSTANCES: bool = true;
    const ABOUT: &'static str = "No shadows (V = 1): the cost floor";
    const KEYS_DOC: &'static str = "No keys.\n";
}

impl LightShadowing for Unshadowed {
    fn name(&self) -> &'static str {
        Self::NAME
    }
    fn prepare(&mut self, _: &PrepareContext) -> Result<(), ShadowError> {
        Ok(())
    }
    fn reads_visible_points(&self) -> bool {
        false
    }
    fn visibility(&self, _: &Scene, _: &ShadowQuery) -> f32 {
        1.0
    }
}

/// Most light samples per shading point `traced` takes (defined with the sample rows it
/// bounds, so that the two files do not import each other).
pub use crate::methods::sample_stream::MAX_TRACED_SAMPLES;

/// Parameters of the traced method. `[shadows.traced]` takes no keys ([`NoKeys`]): the sample
/// count is `[shadows].samples` (given to [`ShadowMethod::build`]), and shaft culling is a
/// code-only switch (the same bits either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TracedParams {
    /// Test each point's shaft to the light first ([`crate::geometry::shaft`]): where no triangle can
    /// meet it, the rays it covers are counted unblocked without being traced. The same bits
    /// either way; only the cost differs (the bench's `traced plain` turns it off).
    pub shaft_culling: bool,
}

impl TracedParams {
    pub const NAME: &'static str = "traced";

    /// Shafts culled: the method as it ships.
    pub const CULLED: Self = Self { shaft_culling: true };

    /// Every ray traced: the plain reference.
    pub const PLAIN: Self = Self { shaft_culling: false };
}

impl Default for TracedParams {
    fn default() -> Self {
        Self::CULLED
    }
}

impl ShadowMethod for TracedParams {
    fn name(&self) -> &'static str {
        Self::NAME
    }
    fn max_samples(&self) -> u32 {
        MAX_TRACED_SAMPLES
    }
    fn build(&self, samples: u32) -> Box<dyn LightShadowing> {
        Box::new(Traced::new(*self, samples))
    }
}

impl MethodParams for TracedParams {
    const NAME: &'static str = Self::NAME;
    type Table = NoKeys;
    fn table(&self) -> NoKeys {
        NoKeys {}
    }
    fn with_table(&self, _: NoKeys) -> Self {
        *self
    }
    fn validate(&self) -> Result<(), KeyError> {
        Ok(())
    }
}

impl MethodEntry for TracedParams {
    const TRACES_KEPT_INSTANCES: bool = true;
    const ABOUT: &'static str =
        "Shadow rays through the BVH to `samples` stratified points on the light: the truth";
    const KEYS_DOC: &'static str = "No keys: the samples are `[shadows].samples`. Shaft culling (proving \
        bundles of rays\nunblocked with one BVH query) is always on; it changes no bit, only the cost.\n";
}

/// The ground truth: `samples` stratified, jittered points on the part of the light above the
/// shading point's horizon (the part the irradiance counts: where the horizon cuts the light,
/// the strata are warped onto that part), one any-hit shadow ray through the BVH to each.
#[derive(Debug)]
pub struct Traced {
    params: TracedParams,
    /// The light samples (a stratified nx x ny grid per point, nx * ny = samples, see
    /// [`crate::geometry::irradiance_strata`]), jittered per point.
    stream: SampleStream,
    rays: AtomicU64,
    occluded: AtomicU64,
    /// [`LightShadowing::seed_salt`]: 0 but for [`Traced::with_seed_salt`].
    seed_salt: u64,
}

impl Traced {
    pub fn new(params: TracedParams, samples: u32) -> Self {
        Self {
            params,
            stream: SampleStream::new(samples),
            seed_salt: 0,
            rays: AtomicU64::new(0),
            occluded: AtomicU64::new(0),
        }
    }

    /// The same method drawing light samples of its own: `salt` is mixed into its queries'
    /// seeds ([`LightShadowing::seed_salt`]). The bench's truth along the runs' paths is such
    /// a `Traced`, so that its error is not read against the runs' own samples.
    pub fn with_seed_salt(self, salt: u64) -> Self {
        Self { seed_salt: salt, ..self }
    }
}

impl LightShadowing for Traced {
    fn name(&self) -> &'static str {
        "traced"
    }

    fn seed_salt(&self) -> u64 {
        self.seed_salt
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.stream.prepare(*ctx.light).map_err(|message| ShadowError { method: "traced", message })
    }

    /// Traced rays need only the light.
    fn reads_visible_points(&self) -> bool {
        false
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let culling = if self.params.shaft_culling { Culling::Leaves } else { Culling::Off };
        let samples = match self.stream.point(scene, q, culling) {
            Ok(samples) => samples,
            Err(visibility) => return visibility,
        };
        let (tally, traced) = samples.trace(scene);
        // Relaxed counters: one add per query, not per ray (measured: no visible cost).
        self.rays.fetch_add(traced as u64, Ordering::Relaxed);
        self.occluded.fetch_add(tally.blocked as u64, Ordering::Relaxed);
        // No sample above the horizon (a sliver of less than MIN_CLIPPED_AREA of the light,
        // not warped, or lost to f32 rounding) reads 1: too small to resolve, unshadowed.
        tally.visibility(samples.share())
    }

    fn visibility_glossy(&self, scene: &Scene, q: &ShadowQuery, lobe: &GlossyLobe) -> LobeVisibility {
        let culling = if self.params.shaft_culling { Culling::Leaves } else { Culling::Off };
        let samples = match self.stream.point(scene, q, culling) {
            Ok(samples) => samples,
            Err(visibility) => return LobeVisibility::both(visibility),
        };
        let (tally, glossy, traced) = samples.trace_glossy(scene, lobe);
        self.rays.fetch_add(traced as u64, Ordering::Relaxed);
        self.occluded.fetch_add(tally.blocked as u64, Ordering::Relaxed);
        let diffuse = tally.visibility(samples.share());
        LobeVisibility { diffuse, glossy: glossy.share(diffuse) }
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let mut c = vec![
            ("shadow_rays", self.rays.load(Ordering::Relaxed)),
            ("shadow_rays_occluded", self.occluded.load(Ordering::Relaxed)),
        ];
        if self.params.shaft_culling {
            c.extend(self.stream.shaft_counters());
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::Camera;
    use crate::geometry::light::RectLight;
    use crate::geometry::point::ShadingPoint;
    use crate::load::gltf_load::Geometry;
    use glam::DVec3;
    use glam::Vec3;
    use std::time::Duration;

    /// A scene of quads (center, u, v) in world = render space, with one light.
    fn quads_scene(quads: &[([f64; 3], [f64; 3], [f64; 3])], light: RectLight) -> Scene {
        let mut g = Geometry::default();
        for (c, u, v) in quads {
            g.add_quad(DVec3::from(*c), DVec3::from(*u), DVec3::from(*v), [0.5; 3]);
        }
        let camera = Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        Scene::build(g, vec![light], camera, DVec3::ZERO, Duration::ZERO)
    }

    fn unit_light_at(height: f32) -> RectLight {
        // 1 x 1, centred above the origin, facing down (X x Z = -Y).
        RectLight::new(Vec3::new(0.0, height, 0.0), Vec3::X, Vec3::Z, Vec3::ONE)
    }

    fn traced(scene: &Scene, samples: u32) -> Traced {
        let mut t = Traced::new(TracedParams::PLAIN, samples);
        let ctx = PrepareContext::for_light(scene, 0);
        t.prepare(&ctx).unwrap();
        t
    }

    fn query(p: Vec3, seed: u64) -> ShadowQuery {
        ShadowQuery {
            point: ShadingPoint {
                p,
                p_error: crate::geometry::ray_origin::point_error(p),
                n_geom: Vec3::Y,
                n_shading: Vec3::Y,
            },
            pixel: [0, 0],
            seed,
            irradiance: 0.0,
        }
    }

    const FLOOR: ([f64; 3], [f64; 3], [f64; 3]) = ([0.0, 0.0, 0.0], [20.0, 0.0, 0.0], [0.0, 0.0, -20.0]);

    #[test]
    fn large_occluder_gives_zero_and_open_sky_gives_one() {
        let light = unit_light_at(2.0);
        let roof = ([0.0, 1.0, 0.0], [100.0, 0.0, 0.0], [0.0, 0.0, 100.0]);
        let covered = quads_scene(&[FLOOR, roof], light);
        let open = quads_scene(&[FLOOR], light);
        let (tc, to) = (traced(&covered, 256), traced(&open, 256));
        for (i, p) in
            [Vec3::ZERO, Vec3::new(0.7, 0.0, -0.3), Vec3::new(-2.0, 0.0, 1.5)].into_iter().enumerate()
        {
            assert_eq!(tc.visibility(&covered, &query(p, i as u64)), 0.0, "covered {p}");
            assert_eq!(to.visibility(&open, &query(p, i as u64)), 1.0, "open {p}");
        }
        // The counters saw every ray above the horizon: 3 points x 256 samples each.
        let counters: std::collections::HashMap<_, _> = tc.counters().into_iter().collect();
        assert_eq!(counters["shadow_rays"], 3 * 256);
        assert_eq!(counters["shadow_rays_occluded"], 3 * 256);
    }

    #[test]
    fn half_plane_visibility_converges_to_the_share_of_irradiance() {
        // Occluder: the half-plane x < 0 at y = 1. Light: 1 x 1 at y = 2, centred on x = 0.
        // From P = (x0, 0, 0) the edge projects onto the light at x = -x0: the part x > -x0
        // is visible, and V is its irradiance over the whole light's (Lambert's formula on
        // each rectangle). The area fraction, 0.5 + x0, is off by 0.02-0.04 here.
        let light = unit_light_at(2.0);
        let half_plane = ([-25.0, 1.0, 0.0], [50.0, 0.0, 0.0], [0.0, 0.0, 50.0]);
        let scene = quads_scene(&[FLOOR, half_plane], light);
        let seeds = 200u64;
        for x0 in [-0.31f32, 0.13, 0.37] {
            let width = 0.5 + x0;
            let visible =
                RectLight::new(Vec3::new(0.5 - width / 2.0, 2.0, 0.0), width * Vec3::X, Vec3::Z, Vec3::ONE);
            let p = Vec3::new(x0, 0.0, 0.0);
            let exact = visible.irradiance_factor_f64(p, Vec3::Y) / light.irradiance_factor_f64(p, Vec3::Y);
            assert!((exact - width as f64).abs() > 0.015, "x0 {x0}: the test must tell the two apart");
            let mut rmse_by_n = Vec::new();
            for n in [4u32, 16, 64, 256, 1024] {
                let t = traced(&scene, n);
                let estimates: Vec<f64> = (0..seeds)
                    .map(|s| t.visibility(&scene, &query(Vec3::new(x0, 0.0, 0.0), s)) as f64)
                    .collect();
                let mean = estimates.iter().sum::<f64>() / seeds as f64;
                let var = estimates.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (seeds - 1) as f64;
                let standard_error = (var / seeds as f64).sqrt();
                // Unbiased: the mean of 200 estimates is within 3 standard errors (plus
                // f32 rounding) of the exact fraction.
                assert!(
                    (mean - exact).abs() <= 3.0 * standard_error + 1e-6,
                    "x0 {x0} N {n}: mean {mean} exact {exact} se {standard_error}"
                );
                let rmse = (estimates.iter().map(|e| (e - exact).powi(2)).sum::<f64>() / seeds as f64).sqrt();
                rmse_by_n.push(rmse);
            }
            // And each estimate converges: stratified sampling of a straight edge has error
            // ~ N^-3/4, so from N = 16 to 1024 the RMS error falls by ~22x; require 4x.
            assert!(rmse_by_n[4] * 4.0 < rmse_by_n[1], "x0 {x0}: rmse {rmse_by_n:?}");
        }
    }

    #[test]
    fn sample_counts_past_the_limit_are_refused_at_prepare() {
        let scene = quads_scene(&[FLOOR], unit_light_at(2.0));
        let ctx = PrepareContext::for_light(&scene, 0);
        let mut over = Traced::new(TracedParams::CULLED, MAX_TRACED_SAMPLES + 1);
        let err = over.prepare(&ctx).unwrap_err();
        assert!(err.message.contains("65536"), "{err}");
        assert!(Traced::new(TracedParams::CULLED, MAX_TRACED_SAMPLES).prepare(&ctx).is_ok());
    }

    #[test]
    fn samples_below_the_horizon_are_not_counted() {
        // A wall point whose normal is +X sees only the half of the light with x > 0; with
        // nothing in the way that half is fully visible: V = 1 exactly.
        let light = unit_light_at(2.0);
        let scene = quads_scene(&[FLOOR], light);
        let t = traced(&scene, 64);
        let q = ShadowQuery {
            point: ShadingPoint {
                p: Vec3::new(0.0, 1.0, 0.0),
                p_error: crate::geometry::ray_origin::point_error(Vec3::new(0.0, 1.0, 0.0)),
                n_geom: Vec3::X,
                n_shading: Vec3::X,
            },
            pixel: [0, 0],
            seed: 3,
            irradiance: 0.0,
        };
        assert_eq!(t.visibility(&scene, &q), 1.0);
    }
}
