//! `silhouette`: exact soft shadows from the occluders' silhouette edges (soft shadow
//! volumes for ray tracing, Laine et al. 2005), counted in `traced`'s own light samples.
//!
//! For a shading point (its ray origin `o`) and a light sample `s`, let D(s) be the number of
//! triangles the shadow ray o -> s crosses: `s` is visible iff D(s) = 0. D changes only
//! where `s` crosses the projection from `o` of an edge, by the edge's weight (the incident
//! faces' orientations as seen from `o`: 0 for an edge inside a smooth surface, +-2 for a
//! fold, +-1 for a boundary). So from a reference point `r` on the light, each sample's
//! count relative to r is a sum over the few edges whose projection separates r from it.
//! One any-hit ray to the sample with the lowest count then settles the constant: unblocked,
//! the visible samples are those with that count; blocked, the point is in umbra. Cost: per
//! silhouette edge, the rows of light samples its projection spans, plus one ray, whatever
//! N.
//!
//! Exact, or traced: a sample within rounding of a projected edge, outside the point's
//! shaft, or whose ray may meet a triangle left out of the counting (alpha-tested with
//! holes, near the light's plane, zero-area) is traced with `traced`'s own ray; a point with
//! no reference point clear of every edge's band is traced whole. Samples under the
//! geometric tangent plane (seen past a smoothed normal) start from the origin below the
//! surface: they are counted from there, with their own ray. The answer equals `traced`'s
//! with the same samples (tests/silhouette.rs counts disagreements over every settled
//! sample).
//!
//! Cost: per light, the potential silhouette edges in a BVH with normal cones
//! (`silhouette_edges/`, shared with other edge methods: `edge_tree.rs`), walked once per
//! block of neighbouring points (`blocks.rs`); per point, one shaft query, exact weights for
//! the edges over the light (`gather.rs`, `projection.rs`), the counting row by row of the
//! strata grid along a path from r through each row's own height (`counting.rs`: runs of
//! cells and whole rows move at once, samples are drawn only where a line passes), and one
//! ray per side.
//!
//! Scene file: `method = "silhouette"`; `[shadows.silhouette]` takes no keys (the sample
//! count is `[shadows].samples`, as for `traced`).

#[cfg(test)]
mod band_tests;
mod counting;
mod entry;
mod query;
mod scratch;

use crate::silhouette_edges::{GatherRefusal, OccluderEdges};
use renderer::interface::lobe::{GlossyLobe, LobeVisibility};
use renderer::interface::method::NoKeys;
use renderer::methods::sample_stream::{Culling, LightSample, SampleStream};
use renderer::{
    KeyError, LightShadowing, MethodParams, PrepareContext, RectLight, Scene, ShadowError, ShadowMethod,
    ShadowQuery,
};
use std::sync::atomic::{AtomicU64, Ordering};

/// Parameters of `silhouette`: `[shadows.silhouette]` (no keys). Its samples are
/// `[shadows].samples` (given to [`ShadowMethod::build`]): `traced`'s strata, jitter and
/// horizon warp.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SilhouetteParams {}

impl SilhouetteParams {
    pub const NAME: &'static str = "silhouette";
}

impl ShadowMethod for SilhouetteParams {
    fn name(&self) -> &'static str {
        Self::NAME
    }
    fn max_samples(&self) -> u32 {
        renderer::MAX_TRACED_SAMPLES
    }
    fn build(&self, samples: u32) -> Box<dyn LightShadowing> {
        Box::new(Silhouette::new(samples))
    }
}

impl MethodParams for SilhouetteParams {
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

/// Only the whole light's shaft is tested before counting: the counting answers a point
/// whose shaft is not clear with one ray, so proving parts of the light clear (up to 21
/// more shaft tests, `traced`'s culling) saves at most that ray.
const CULLING: Culling = Culling::WholeLight;

/// Why a whole point was traced.
#[derive(Debug, Clone, Copy)]
enum Fallback {
    /// No reference point clear of every active edge's band.
    NoReference,
    /// More active edges than the counting pays for against tracing.
    Costly,
    NoShaft,
    Inconsistent,
    /// The shaft meets a kept instance the counting does not answer for
    /// (`silhouette_edges/kept.rs`).
    KeptInstance,
}

impl From<GatherRefusal> for Fallback {
    fn from(why: GatherRefusal) -> Fallback {
        match why {
            GatherRefusal::TooManyCandidates => Fallback::Costly,
            GatherRefusal::NoShaft => Fallback::NoShaft,
            GatherRefusal::KeptInstance => Fallback::KeptInstance,
        }
    }
}

/// The plugin: the light's occluder edges (`OccluderEdges`) and `traced`'s samples (the renderer's [`SampleStream`],
/// which also traces what the counting leaves).
#[derive(Debug)]
pub struct Silhouette {
    stream: SampleStream,
    occluders: OccluderEdges,
    counters: Counters,
}

#[derive(Debug, Default)]
struct Counters {
    points: AtomicU64,
    rays: AtomicU64,
    samples_uncertain: AtomicU64,
    edges_tested: AtomicU64,
    edges_active: AtomicU64,
    points_umbra: AtomicU64,
    points_below: AtomicU64,
    /// Points counted cell by cell (plain strata grid, every sample above the horizon).
    points_by_cell: AtomicU64,
    /// Points counted sample by sample (the general path).
    points_by_sample: AtomicU64,
    fallback_no_reference: AtomicU64,
    fallback_costly: AtomicU64,
    fallback_no_shaft: AtomicU64,
    fallback_inconsistent: AtomicU64,
    fallback_kept_instance: AtomicU64,
    alpha_tests: AtomicU64,
}

impl Silhouette {
    /// The plugin for one light, with `samples` light samples per shading point.
    pub fn new(samples: u32) -> Self {
        Self {
            stream: SampleStream::new(samples),
            occluders: OccluderEdges::default(),
            counters: Counters::default(),
        }
    }

    /// The light's occluder edges, as the last `prepare` built them (read by `analytic`,
    /// which counts its inexact points with this plugin).
    pub(crate) fn occluders(&self) -> &OccluderEdges {
        &self.occluders
    }

    fn light(&self) -> &RectLight {
        self.stream.light().expect("prepare() runs before visibility()")
    }

    /// Every sample traced as `traced` traces it (the whole-point fallback), with its culling
    /// too: parts of the light proven clear by their own shafts are not traced (the whole
    /// light's shaft alone, which the counting needs, left flight-helmet under a softbox
    /// 1.2x slower than `traced` on the points it traces whole).
    fn trace_all(
        &self,
        scene: &Scene,
        (q, lobe): (&ShadowQuery, Option<&GlossyLobe>),
        why: Fallback,
    ) -> LobeVisibility {
        let c = &self.counters;
        match why {
            Fallback::NoReference => &c.fallback_no_reference,
            Fallback::Costly => &c.fallback_costly,
            Fallback::NoShaft => &c.fallback_no_shaft,
            Fallback::Inconsistent => &c.fallback_inconsistent,
            Fallback::KeptInstance => &c.fallback_kept_instance,
        }
        .fetch_add(1, Ordering::Relaxed);
        let culled = match self.stream.point(scene, q, Culling::Leaves) {
            Ok(culled) => culled,
            Err(visibility) => return LobeVisibility::both(visibility),
        };
        let Some(lobe) = lobe else {
            let (tally, rays) = culled.trace(scene);
            c.rays.fetch_add(rays as u64, Ordering::Relaxed);
            return LobeVisibility::both(tally.visibility(culled.share()));
        };
        let (tally, glossy, rays) = culled.trace_glossy(scene, lobe);
        c.rays.fetch_add(rays as u64, Ordering::Relaxed);
        let diffuse = tally.visibility(culled.share());
        LobeVisibility { diffuse, glossy: glossy.share(diffuse) }
    }

    /// V, and `lobe`'s share where there is one: counted, or traced whole.
    fn answer(&self, scene: &Scene, q: &ShadowQuery, lobe: Option<&GlossyLobe>) -> LobeVisibility {
        self.counters.points.fetch_add(1, Ordering::Relaxed);
        let samples = match self.stream.point(scene, q, CULLING) {
            Ok(samples) => samples,
            Err(visibility) => return LobeVisibility::both(visibility),
        };
        match query::count(self, scene, (q, lobe), &samples) {
            Ok(v) => v,
            Err(why) => self.trace_all(scene, (q, lobe), why),
        }
    }
}

impl Silhouette {
    /// Every sample of `q` above its horizon with the method's verdict: `Some(lit)` where
    /// the counting settles it, `None` where it is traced (the sample, or the whole point).
    /// For differential tests: allocates.
    pub fn verdicts(&self, scene: &Scene, q: &ShadowQuery) -> Vec<(LightSample, Option<bool>)> {
        let samples = match self.stream.point(scene, q, CULLING) {
            Ok(samples) => samples,
            Err(_) => return Vec::new(), // every sample proven lit by shafts, none counted
        };
        query::verdicts(self, scene, q, &samples).unwrap_or_else(|_| {
            let mut all = Vec::new();
            samples.for_each(|x| all.push((x, None)));
            all
        })
    }

    /// `traced`'s verdicts on `samples` of `q` (its own rays): whether each is lit.
    pub fn traced_lit(&self, scene: &Scene, q: &ShadowQuery, samples: &[LightSample]) -> Vec<bool> {
        match self.stream.point(scene, q, Culling::Leaves) {
            Ok(stream) => samples.iter().map(|s| s.proven || !stream.occluded(scene, s)).collect(),
            Err(_) => vec![true; samples.len()],
        }
    }
}

impl LightShadowing for Silhouette {
    fn name(&self) -> &'static str {
        SilhouetteParams::NAME
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.stream
            .prepare(*ctx.light)
            .map_err(|message| ShadowError { method: SilhouetteParams::NAME, message })?;
        self.occluders = OccluderEdges::build(ctx.scene, ctx.light);
        Ok(())
    }

    /// Its edges are found per light over the whole scene, not what the camera sees.
    fn reads_visible_points(&self) -> bool {
        false
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        self.answer(scene, q, None).diffuse
    }

    fn visibility_glossy(&self, scene: &Scene, q: &ShadowQuery, lobe: &GlossyLobe) -> LobeVisibility {
        self.answer(scene, q, Some(lobe))
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let c = &self.counters;
        let load = |a: &AtomicU64| a.load(Ordering::Relaxed);
        let s = &self.occluders.edges.stats;
        let mut out = vec![
            ("silhouette_points", load(&c.points)),
            ("shadow_rays", load(&c.rays)),
            ("samples_uncertain", load(&c.samples_uncertain)),
            ("edges_tested", load(&c.edges_tested)),
            ("edges_active", load(&c.edges_active)),
            ("points_umbra", load(&c.points_umbra)),
            ("points_counted_below", load(&c.points_below)),
            ("points_counted_by_cell", load(&c.points_by_cell)),
            ("points_counted_by_sample", load(&c.points_by_sample)),
            ("points_fallback_no_reference", load(&c.fallback_no_reference)),
            ("points_fallback_costly", load(&c.fallback_costly)),
            ("points_fallback_no_shaft", load(&c.fallback_no_shaft)),
            ("points_fallback_inconsistent", load(&c.fallback_inconsistent)),
            ("points_fallback_kept_instance", load(&c.fallback_kept_instance)),
            ("alpha_triangle_tests", load(&c.alpha_tests)),
            ("edges", s.edges),
            ("edges_potential", s.potential),
            ("edges_boundary", s.boundary),
            ("edges_non_manifold", s.non_manifold),
            ("triangles_alpha", s.alpha_triangles),
            ("triangles_alpha_opaque", s.alpha_opaque_triangles),
            ("triangles_alpha_clear", s.alpha_clear_triangles),
            ("triangles_near_light", s.near_light_triangles),
            ("triangles_zero_area", s.zero_area_triangles),
            ("instances_counted", self.occluders.kept.counted),
            ("instance_mesh_edges", self.occluders.kept.mesh_edges),
        ];
        // `traced`'s shaft counters (its rays are never traced through it).
        out.extend(self.stream.shaft_counters());
        out
    }

    fn memory_bytes(&self) -> u64 {
        self.occluders.bytes()
    }
}
