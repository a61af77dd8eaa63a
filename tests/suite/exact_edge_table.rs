//! The exact edge-table reading against the BVH: every ray its masks call clear or blocked is
//! traced and must agree (0 disagreements), and its visibility must equal tracing every ray
//! of the same sample set, bit for bit. Run through the ordinary render path (a wrapping
//! method checks each query), on the default scene, the bench scenes, every shared scene,
//! random triangle soups and terraced heightfields.

use crate::common;

use common::checked::{self, CheckedMethod, Verdicts};
use common::gltf_writer::TempDir;
use common::soups;
use renderer::geometry::ray_origin::offset_origin;
use renderer::{LightShadowing, PrepareContext, RectLight, Scene, ShadowError, ShadowQuery};
use shadow_plugin::{EdgeTable, EdgeTableParams};
use std::path::PathBuf;

/// `edge_table` (exact reading) checked: each ray its masks decide against a traced ray, and
/// its answer against the all-traced answer on the same samples.
struct Exact {
    inner: EdgeTable,
    light: Option<RectLight>,
}

impl Verdicts for Exact {
    const NAME: &'static str = "edge_table";
    const KINDS: [&'static str; 2] = ["checked_clear", "checked_blocked"];

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.light = Some(*ctx.light);
        self.inner.prepare(ctx)
    }
    fn check(&self, scene: &Scene, q: &ShadowQuery) -> [u64; 3] {
        let light = self.light.as_ref().unwrap();
        let [mut clear, mut blocked, mut wrong] = [0; 3];
        for ([a, b], verdict) in self.inner.classify_rays(scene, q).unwrap_or_default() {
            let Some(lit) = verdict else { continue };
            let target = light.point(a, b);
            let w = target - q.point.p;
            if q.point.n_shading.dot(w) <= 0.0 {
                continue; // below the horizon: not counted
            }
            let from = offset_origin(&q.point, w);
            let occluded = scene.segment_occluded_from(from, target, light.point_error(a, b), light.normal);
            if lit {
                clear += 1;
            } else {
                blocked += 1;
            }
            wrong += (occluded == lit) as u64;
        }
        [clear, blocked, wrong]
    }
    fn answers(&self, scene: &Scene, q: &ShadowQuery) -> (f32, f32) {
        (self.inner.visibility(scene, q), self.inner.visibility_all_traced(scene, q))
    }
    fn memory_bytes(&self) -> u64 {
        self.inner.memory_bytes()
    }
}

/// Renders `scenes` at `dims` (width, height, samples) with the checked exact reading:
/// asserts that the BVH agrees with every decided ray, that every answer equals tracing the
/// same samples, and that more than `more_than` decided rays (clear and blocked) were checked.
fn agree_with_the_bvh(scenes: &[PathBuf], dims: (u32, u32, u32), more_than: u64) {
    let method = CheckedMethod::shared(|samples| Exact {
        inner: EdgeTable::new(EdgeTableParams::default(), samples),
        light: None,
    });
    let keys = ["checked_clear", "checked_blocked", "checked_wrong", "answers_differ"];
    let [clear, blocked, ..] = checked::check_all(scenes, dims, &method, "exact", keys, None);
    let rays = clear + blocked;
    assert!(rays > more_than, "only {rays} decided rays checked");
}

/// The default scene: visibility equal to tracing the same samples, bit for bit, at every
/// pixel, and every decided ray agreeing with the BVH.
#[test]
fn default_scene_equals_tracing_the_same_samples() {
    agree_with_the_bvh(&[checked::scene("scenes/default.toml")], (160, 120, 256), 1_000_000);
}

/// The bench scenes and every shared scene: at least 10^6 decided rays, none wrong.
#[test]
fn shared_and_bench_scenes_agree_with_the_bvh() {
    if !common::shared::scenes_present("exact_edge_table::shared_and_bench_scenes_agree_with_the_bvh") {
        return;
    }
    let scenes = common::sweep(common::shared::gltf_scene_files(), 0);
    agree_with_the_bvh(&scenes, (64, 48, 256), common::sweep_floor(1_000_000));
}

/// Random triangle soups (sizes from a millimetre to a metre, any orientation, some sharing
/// edges) and terraced heightfields (closed steps: shared edges, covers, walls), each under a
/// light of its own size: every decided ray agrees with the BVH.
#[test]
fn random_soups_and_heightfields_agree_with_the_bvh() {
    let dir = TempDir::new("exact-soups");
    agree_with_the_bvh(&soups::soups_and_terraces(&dir, 17), (64, 48, 256), 300_000);
}
