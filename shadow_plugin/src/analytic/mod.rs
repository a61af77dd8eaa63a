//! `analytic`: noise-free soft shadows. V is integrated over the part of the light a point
//! sees, in closed form, from the occluders' silhouette edges (the machinery `silhouette`
//! counts with, [`crate::silhouette_edges`]); design: `../shared/design/analytic-visibility.md`.
//!
//! Per point: the active edges projected from the ray origin onto the light's plane (their
//! jumps of depth complexity D, exact weights), the triangles near the light's plane as
//! their clipped outlines; their arrangement over the light's part above the shading horizon
//! ([`arrangement`]: D on every piece, exact predicates); one any-hit ray into a face of the
//! lowest D settles the constant (blocked: umbra); then the sum of Lambert's edge terms
//! ([`lambert`]) round the region of lowest D over the same sum round the whole part: V, the
//! share of irradiance, to rounding. No samples, no noise.
//!
//! The part of the light under the geometric tangent plane (seen past a smoothed normal) is
//! integrated on its own, from the origin under the surface, as `traced` aims those samples.
//! Alpha-tested triangles with holes (leaves) follow no closed form: what they take from the
//! exactly integrated visible region is estimated by 8x `[shadows].samples` strata over their
//! projections alone ([`alpha`]). Where a point has thousands of active edges (a dense mesh
//! under a near softbox) the arrangement gives way to rows ([`rows`]): 256 line samples, each
//! exact along its length, so only the rows' places are sampled (noise about that of
//! `traced` at N = 65,536); so do the points whose arrangement fails (near-coincident
//! crossings, a lone end). Points neither answers (a row that does not close, a ray that
//! contradicts the depths, a certificate failed, no shaft) are answered by `silhouette`'s
//! counting at `[shadows].samples`, and counted in the run report by reason. `points_exact`
//! counts the points integrated without rows.
//!
//! Scene file: `method = "analytic"`; `[shadows.analytic]` takes no keys.

mod alpha;
pub mod arrangement;
mod contacts;
mod entry;
pub mod lambert;
mod lit_region;
mod lobe;
mod query;
mod rows;
pub mod segment;

use crate::silhouette::Silhouette;
use renderer::interface::lobe::{GlossyLobe, LobeVisibility};
use renderer::interface::method::NoKeys;
use renderer::{
    KeyError, LightShadowing, MethodParams, PrepareContext, RectLight, Scene, ShadowError, ShadowMethod,
    ShadowQuery,
};
use std::sync::atomic::{AtomicU64, Ordering};

/// Parameters of `analytic`: `[shadows.analytic]` (no keys). `[shadows].samples` is the
/// sample count of the points it answers by counting (see the module doc).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct AnalyticParams {}

impl AnalyticParams {
    pub const NAME: &'static str = "analytic";
}

impl ShadowMethod for AnalyticParams {
    fn name(&self) -> &'static str {
        Self::NAME
    }
    fn max_samples(&self) -> u32 {
        renderer::MAX_TRACED_SAMPLES
    }
    fn build(&self, samples: u32) -> Box<dyn LightShadowing> {
        Box::new(Analytic::new(samples))
    }
}

impl MethodParams for AnalyticParams {
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

/// Why a point was answered by counting rather than integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fallback {
    /// Alpha-tested leaves too many over the light to estimate their share cheaply.
    Alpha,
    /// The shaft's candidates could not be gathered (too deep a tree), or no frame.
    NoShaft,
    /// Collinear overlapping projections, a T-junction, a lone end.
    Degenerate,
    /// A loop of jumps did not close, or a depth was reached two ways differently.
    Inconsistent,
    /// V outside [0, 1] beyond rounding.
    Certificate,
}

/// The plugin: `silhouette` prepared for the light, whose occluder edges it reads and which
/// counts the points it does not integrate (one edge set per light for both).
#[derive(Debug)]
pub struct Analytic {
    light: Option<RectLight>,
    /// `[shadows].samples`: the strata over alpha-tested leaves, and the counted points'.
    samples: u32,
    counting: Silhouette,
    counters: Counters,
}

#[derive(Debug, Default)]
struct Counters {
    points: AtomicU64,
    exact: AtomicU64,
    umbra: AtomicU64,
    rays: AtomicU64,
    edges_active: AtomicU64,
    outlines: AtomicU64,
    crossings: AtomicU64,
    pieces: AtomicU64,
    merged: AtomicU64,
    fallback: [AtomicU64; 5],
    alpha_points: AtomicU64,
    alpha_tests: AtomicU64,
    rows_points: AtomicU64,
    row_crossings: AtomicU64,
    arrangement_failed: AtomicU64,
}

impl Analytic {
    pub fn new(samples: u32) -> Self {
        Self { light: None, samples, counting: Silhouette::new(samples), counters: Counters::default() }
    }

    fn light(&self) -> &RectLight {
        self.light.as_ref().expect("prepare() runs before visibility()")
    }

    /// `q` answered by counting (`why`), with `lobe`'s share where it has one.
    fn count(
        &self,
        scene: &Scene,
        q: &ShadowQuery,
        lobe: Option<&GlossyLobe>,
        why: Fallback,
    ) -> LobeVisibility {
        self.counters.fallback[why as usize].fetch_add(1, Ordering::Relaxed);
        match lobe {
            Some(lobe) => self.counting.visibility_glossy(scene, q, lobe),
            None => LobeVisibility::both(self.counting.visibility(scene, q)),
        }
    }
}

impl LightShadowing for Analytic {
    fn name(&self) -> &'static str {
        AnalyticParams::NAME
    }

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.counting
            .prepare(ctx)
            .map_err(|e| ShadowError { method: AnalyticParams::NAME, message: e.message })?;
        self.light = Some(*ctx.light);
        Ok(())
    }

    fn reads_visible_points(&self) -> bool {
        false
    }

    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        self.counters.points.fetch_add(1, Ordering::Relaxed);
        match query::visibility(self, scene, q, None) {
            Ok(v) => v.diffuse,
            Err(why) => self.count(scene, q, None, why).diffuse,
        }
    }

    fn visibility_glossy(&self, scene: &Scene, q: &ShadowQuery, lobe: &GlossyLobe) -> LobeVisibility {
        self.counters.points.fetch_add(1, Ordering::Relaxed);
        match query::visibility(self, scene, q, Some(lobe)) {
            Ok(v) => v,
            Err(why) => self.count(scene, q, Some(lobe), why),
        }
    }

    fn counters(&self) -> Vec<(&'static str, u64)> {
        let c = &self.counters;
        let load = |a: &AtomicU64| a.load(Ordering::Relaxed);
        let f = |w: Fallback| load(&c.fallback[w as usize]);
        let mut out = vec![
            ("analytic_points", load(&c.points)),
            ("points_exact", load(&c.exact)),
            ("points_umbra", load(&c.umbra)),
            ("shadow_rays", load(&c.rays)),
            ("edges_active", load(&c.edges_active)),
            ("near_light_outlines", load(&c.outlines)),
            ("crossings", load(&c.crossings)),
            ("pieces", load(&c.pieces)),
            ("segments_merged", load(&c.merged)),
            ("point_sides_alpha_sampled", load(&c.alpha_points)),
            ("alpha_leaf_tests", load(&c.alpha_tests)),
            ("point_sides_by_rows", load(&c.rows_points)),
            ("row_crossings", load(&c.row_crossings)),
            ("point_sides_arrangement_failed", load(&c.arrangement_failed)),
            ("points_counted_no_shaft", f(Fallback::NoShaft)),
            ("points_counted_alpha", f(Fallback::Alpha)),
            ("points_counted_degenerate", f(Fallback::Degenerate)),
            ("points_counted_inconsistent", f(Fallback::Inconsistent)),
            ("points_counted_certificate", f(Fallback::Certificate)),
        ];
        // The shared edge set's statistics, and the counted points' own work under names of
        // their own (the counting's finer counters stay with `silhouette`).
        out.extend(
            self.counting.counters().into_iter().filter_map(|(name, v)| Some((counted_name(name)?, v))),
        );
        out
    }

    fn memory_bytes(&self) -> u64 {
        self.counting.memory_bytes()
    }
}

/// The counting method's counters `analytic` reports, and under which names: the edge set's
/// and the shafts' as they are, the counted points' work prefixed.
fn counted_name(name: &'static str) -> Option<&'static str> {
    Some(match name {
        "silhouette_points" => "counted_points",
        "shadow_rays" => "counted_shadow_rays",
        "samples_uncertain" => "counted_samples_uncertain",
        "edges"
        | "edges_potential"
        | "edges_boundary"
        | "edges_non_manifold"
        | "triangles_alpha"
        | "triangles_alpha_opaque"
        | "triangles_alpha_clear"
        | "triangles_near_light"
        | "triangles_zero_area"
        | "instances_counted"
        | "instance_mesh_edges"
        | "shafts"
        | "shafts_clear" => name,
        _ => return None,
    })
}
