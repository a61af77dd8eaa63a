//! The two built-in methods: `traced`, the ground truth (shadow rays through the BVH), and
//! `none`, the cost floor. Both are configured like every plugin ([`crate::interface::method`]).

use crate::geometry::light::RectLight;
use crate::geometry::light_sampling::HorizonPart;
use crate::geometry::ray_origin::offset_origin;
use crate::geometry::scene::Scene;
use crate::geometry::shaft;
use crate::interface::entry::{MethodEntry, SweepSetting, top_samples};
use crate::interface::method::{KeyError, MethodParams, NoKeys, ShadowMethod};
use crate::interface::shadowing::{LightShadowing, PrepareContext, ShadowError, ShadowQuery};
use crate::util::sampling::{Rng, strata};
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
    const ABOUT: &'static str = "No shadows (V = 1): the cost floor";
    const KEYS_DOC: &'static str = "No keys.\n";
    /// The colour the plots give a family they do not know (`none` is never plotted).
    const COLOUR: [u8; 3] = [148, 103, 189];
    /// None: the bench runs `none` on its own, as the cost floor of every setting.
    fn sweep(_quick: bool) -> Vec<SweepSetting> {
        Vec::new()
    }
}

impl LightShadowing for Unshadowed {
    fn name(&self) -> &'static str {
        Self::NAME
    }
    fn prepare(&mut self, _: &PrepareContext) -> Result<(), ShadowError> {
        Ok(())
    }
    fn visibility(&self, _: &Scene, _: &ShadowQuery) -> f32 {
        1.0
    }
}

/// Most light samples per shading point `traced` takes.
pub const MAX_TRACED_SAMPLES: u32 = 65536;

/// Parameters of the traced method. `[shadows.traced]` takes no keys ([`NoKeys`]): the sample
/// count is `[shadows].samples`, and shaft culling is a code-only switch (the same bits
/// either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TracedParams {
    /// Light samples per shading point: a stratified nx x ny grid (nx * ny = samples,
    /// see [`strata`]), jittered per point. 1024 matches the edge-table masks.
    pub samples: u32,
    /// Test each point's shaft to the light first ([`crate::geometry::shaft`]): where no triangle can
    /// meet it, the rays it covers are counted unblocked without being traced. The same bits
    /// either way; only the cost differs (the bench's `traced plain` turns it off).
    pub shaft_culling: bool,
}

impl TracedParams {
    pub const NAME: &'static str = "traced";

    /// Shafts culled: the method as it ships.
    pub const fn new(samples: u32) -> Self {
        Self { samples, shaft_culling: true }
    }

    /// Every ray traced: the plain reference.
    pub const fn plain(samples: u32) -> Self {
        Self { samples, shaft_culling: false }
    }
}

impl Default for TracedParams {
    fn default() -> Self {
        Self::new(256)
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
        Box::new(Traced::new(TracedParams { samples, ..*self }))
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

/// Label prefix of the bench's plain traced reference: reported, but not a reference of the
/// equal-error speedup (that compares with `traced` as it ships, shaft-culled).
pub const PLAIN_LABEL: &str = "traced plain";

impl MethodEntry for TracedParams {
    const ABOUT: &'static str =
        "Shadow rays through the BVH to `samples` stratified points on the light: the truth";
    const KEYS_DOC: &'static str = "No keys: the samples are `[shadows].samples`. Shaft culling (proving \
        bundles of rays\nunblocked with one BVH query) is always on; it changes no bit, only the cost.\n";
    const COLOUR: [u8; 3] = [90, 90, 90];
    /// One parameter (N): a curve.
    const PLOT_LINE: bool = true;
    const BENCH_RANK: u32 = 0;

    /// Shaft-culled over sample counts (the references of the equal-error speedup), then the
    /// plain reference at the top count: every ray traced, no shaft culling (the same bits as
    /// `traced N=1024`, so the cost of culling's absence is read off side by side).
    fn sweep(quick: bool) -> Vec<SweepSetting> {
        let counts: &[u32] = if quick { &[4, 16, 64] } else { &[4, 16, 64, 256, 1024] };
        let mut out: Vec<SweepSetting> = counts
            .iter()
            .map(|&n| SweepSetting {
                reference: true,
                ..SweepSetting::new(format!("traced N={n}"), TracedParams::new(n), n)
            })
            .collect();
        let n = top_samples(quick);
        out.push(SweepSetting::new(format!("{PLAIN_LABEL} N={n}"), TracedParams::plain(n), n));
        out
    }
}

/// The ground truth: `samples` stratified, jittered points on the part of the light above the
/// shading point's horizon (the part the irradiance counts: where the horizon cuts the light,
/// the strata are warped onto that part), one any-hit shadow ray through the BVH to each.
#[derive(Debug)]
pub struct Traced {
    params: TracedParams,
    light: Option<RectLight>,
    rays: AtomicU64,
    occluded: AtomicU64,
    /// Shafts tested, and those found clear.
    shafts: AtomicU64,
    shafts_clear: AtomicU64,
    /// [`LightShadowing::seed_salt`]: 0 but for [`Traced::with_seed_salt`].
    seed_salt: u64,
}

impl Traced {
    pub fn new(params: TracedParams) -> Self {
        Self {
            params,
            seed_salt: 0,
            light: None,
            rays: AtomicU64::new(0),
            occluded: AtomicU64::new(0),
            shafts: AtomicU64::new(0),
            shafts_clear: AtomicU64::new(0),
        }
    }
}

impl Traced {
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
        if self.params.samples == 0 {
            return Err(ShadowError { method: "traced", message: "samples must be >= 1".into() });
        }
        self.light = Some(*ctx.light);
        Ok(())
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let light = self.light.as_ref().expect("prepare() runs before visibility()");
        let (nx, ny) = strata(self.params.samples);
        // Where the horizon cuts the light, the strata are warped onto the part above it
        // ([`crate::geometry::light_sampling::HorizonWarp`]): every sample counts. The whole light
        // above, or too thin a part above, keeps the plain grid (and its fallback below).
        let point = &q.point;
        let warp = match HorizonPart::new(light, point) {
            HorizonPart::Clipped(w) => Some(w),
            HorizonPart::Whole | HorizonPart::Degenerate => None,
        };
        let clear = if self.params.shaft_culling {
            let (mask, tests) = match &warp {
                None => shaft::clear_leaves(scene, light, point, (nx, ny)),
                // A leaf's samples lie in the image of its strata block: prove the shaft to
                // that image's bounding rectangle.
                Some(w) => shaft::clear_leaves_mapped(scene, light, point, (nx, ny), |a, b| {
                    let (a, b) = w.bounds(a.map(f64::from), b.map(f64::from));
                    (a.map(|x| x as f32), b.map(|x| x as f32))
                }),
            };
            self.shafts.fetch_add(tests as u64, Ordering::Relaxed);
            self.shafts_clear.fetch_add(mask.count_ones() as u64, Ordering::Relaxed);
            mask
        } else {
            0
        };
        // The origin every ray above the tangent plane starts from (the shafts' apex).
        let origin = offset_origin(point, point.n_geom);
        // The whole light proven clear and wholly covered: every counted sample is unblocked,
        // so the answer is 1 without drawing them. Measured: drawing 1024 samples per such
        // point cost ~10 us, most of a clear point's time.
        if clear != 0 && clear == shaft::all_leaves((nx, ny)) && shaft::covers_light(point, origin, light) {
            return 1.0;
        }
        // Per point, not per sample: the covered test's terms with the light's largest point
        // error (every sample's own bound is at most that: a stricter test, so it still
        // accepts only rays the shaft holds), and the ray origin on the lit side (the one
        // `offset_origin` gives every target with n_geom . (target - p) >= 0).
        let cover = shaft::Cover::new(point, origin, light.max_point_error());
        let (lx, ly) = shaft::leaves_per_axis((nx, ny));
        let mut rng = Rng::new(q.seed);
        let (mut above, mut unblocked, mut traced) = (0u32, 0u32, 0u32);
        for j in 0..ny {
            // This row's clear leaves, as bits 0..lx; leaf column `x` holds samples
            // first(x) <= i < first(x + 1) ([`shaft::leaf_bit`], stepped instead of divided).
            let row_clear =
                (clear >> (shaft::LEAVES as u32 * (j * ly as u32 / ny))) & ((1 << shaft::LEAVES) - 1);
            let (mut col, mut next_col) = (0u32, shaft::first_stratum(1, nx, lx));
            for i in 0..nx {
                if i == next_col {
                    col += 1;
                    next_col = shaft::first_stratum(col + 1, nx, lx);
                }
                debug_assert_eq!(row_clear & (1 << col) != 0, clear & shaft::leaf_bit(i, j, (nx, ny)) != 0);
                let mut a = (i as f32 + rng.next_f32()) / nx as f32;
                let mut b = (j as f32 + rng.next_f32()) / ny as f32;
                if let Some(w) = &warp {
                    let (wa, wb) = w.map(a as f64, b as f64);
                    (a, b) = (wa as f32, wb as f32);
                }
                let target = light.point(a, b);
                let w = target - point.p;
                if point.n_shading.dot(w) <= 0.0 {
                    // Below the horizon: not part of the light this point sees. (A warped
                    // sample is above it in f64; f32 rounding may still drop one at the cut.)
                    continue;
                }
                above += 1;
                let height = point.n_geom.dot(w);
                // `max_point_error` bounds points with a, b in [0, 1] (a warped sample off the
                // unit square by a rounding is traced instead).
                if row_clear & (1 << col) != 0
                    && (warp.is_none() || ((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)))
                    && cover.covers(height, w)
                {
                    unblocked += 1; // inside a clear shaft: proven unblocked
                    continue;
                }
                traced += 1;
                // `offset_origin(point, target - p)`: the lit side's origin unless the target is
                // under the geometric tangent plane.
                let from = if height < 0.0 { offset_origin(point, w) } else { origin };
                if !scene.segment_occluded_from(from, target, light.point_error(a, b), light.normal) {
                    unblocked += 1;
                }
            }
        }
        // Relaxed counters: one add per query, not per ray (measured: no visible cost).
        self.rays.fetch_add(traced as u64, Ordering::Relaxed);
        self.occluded.fetch_add((above - unblocked) as u64, Ordering::Relaxed);
        if above == 0 {
            // The irradiance is non-zero but no sample landed above the horizon: a sliver of
            // less than MIN_CLIPPED_AREA of the light (not warped), or lost to f32 rounding.
            // Too small to resolve; count it unshadowed.
            return 1.0;
        }
        unblocked as f32 / above as f32
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let mut c = vec![
            ("shadow_rays", self.rays.load(Ordering::Relaxed)),
            ("shadow_rays_occluded", self.occluded.load(Ordering::Relaxed)),
        ];
        if self.params.shaft_culling {
            c.push(("shafts", self.shafts.load(Ordering::Relaxed)));
            c.push(("shafts_clear", self.shafts_clear.load(Ordering::Relaxed)));
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::Camera;
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
        let mut t = Traced::new(TracedParams::plain(samples));
        let ctx = PrepareContext {
            scene,
            light: &scene.lights[0],
            light_index: 0,
            visible: &[],
            seed: 0,
            memory_budget_bytes: u64::MAX,
        };
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
    fn half_plane_visibility_converges_to_the_analytic_fraction() {
        // Occluder: the half-plane x < 0 at y = 1. Light: 1 x 1 at y = 2, centred on x = 0.
        // From P = (x0, 0, 0) the edge projects onto the light at x = -x0, so the visible
        // fraction is clamp(0.5 + x0, 0, 1).
        let light = unit_light_at(2.0);
        let half_plane = ([-25.0, 1.0, 0.0], [50.0, 0.0, 0.0], [0.0, 0.0, 50.0]);
        let scene = quads_scene(&[FLOOR, half_plane], light);
        let seeds = 200u64;
        for x0 in [-0.31f32, 0.13, 0.37] {
            let exact = (0.5 + x0 as f64).clamp(0.0, 1.0);
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
        };
        assert_eq!(t.visibility(&scene, &q), 1.0);
    }
}
