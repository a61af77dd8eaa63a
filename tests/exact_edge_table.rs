//! The exact edge-table reading against the BVH: every ray its masks call clear or blocked is
//! traced and must agree (0 disagreements), and its visibility must equal tracing every ray
//! of the same sample set, bit for bit. Run through the ordinary render path (a wrapping
//! method checks each query), on the default scene, the bench scenes, every shared scene,
//! random triangle soups and terraced heightfields.

mod common;

use common::checked;
use common::gltf_writer::TempDir;
use common::soups;
use renderer::geometry::ray_origin::offset_origin;
use renderer::{LightShadowing, PrepareContext, RectLight, Scene, ShadowError, ShadowMethod, ShadowQuery};
use shadow_plugin::{EdgeTable, EdgeTableParams};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// `edge_table` (exact reading) wrapped: each query's verdicts are checked against traced
/// rays, and its answer against the all-traced answer on the same samples.
struct Checked {
    inner: EdgeTable,
    light: Option<RectLight>,
    clear: AtomicU64,
    blocked: AtomicU64,
    wrong: AtomicU64,
    answers_differ: AtomicU64,
}

impl LightShadowing for Checked {
    fn name(&self) -> &'static str {
        "edge_table"
    }
    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.light = Some(*ctx.light);
        self.inner.prepare(ctx)
    }
    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
        let light = self.light.as_ref().unwrap();
        if let Some(verdicts) = self.inner.classify_rays(scene, q) {
            for ([a, b], verdict) in verdicts {
                let Some(clear) = verdict else { continue };
                let target = light.point(a, b);
                let w = target - q.point.p;
                if q.point.n_shading.dot(w) <= 0.0 {
                    continue; // below the horizon: not counted
                }
                let from = offset_origin(&q.point, w);
                let occluded =
                    scene.segment_occluded_from(from, target, light.point_error(a, b), light.normal);
                let counter = if clear { &self.clear } else { &self.blocked };
                counter.fetch_add(1, Ordering::Relaxed);
                if occluded == clear {
                    self.wrong.fetch_add(1, Ordering::Relaxed);
                }
            }
        }
        let v = self.inner.visibility(scene, q);
        if v.to_bits() != self.inner.visibility_all_traced(scene, q).to_bits() {
            self.answers_differ.fetch_add(1, Ordering::Relaxed);
        }
        v
    }
    fn counters(&self) -> Vec<(&'static str, u64)> {
        vec![
            ("checked_clear", self.clear.load(Ordering::Relaxed)),
            ("checked_blocked", self.blocked.load(Ordering::Relaxed)),
            ("checked_wrong", self.wrong.load(Ordering::Relaxed)),
            ("answers_differ", self.answers_differ.load(Ordering::Relaxed)),
        ]
    }
    fn memory_bytes(&self) -> u64 {
        self.inner.memory_bytes()
    }
}

#[derive(Debug)]
struct CheckedMethod(EdgeTableParams);

impl ShadowMethod for CheckedMethod {
    fn name(&self) -> &'static str {
        "edge_table"
    }
    fn max_samples(&self) -> u32 {
        4096
    }
    fn build(&self, samples: u32) -> Box<dyn LightShadowing> {
        Box::new(Checked {
            inner: EdgeTable::new(self.0, samples),
            light: None,
            clear: AtomicU64::new(0),
            blocked: AtomicU64::new(0),
            wrong: AtomicU64::new(0),
            answers_differ: AtomicU64::new(0),
        })
    }
}

/// (clear rays checked, blocked rays checked, disagreements, answers differing).
fn check(scene: &Path, width: u32, height: u32, samples: u32) -> [u64; 4] {
    let got = checked::counters(
        scene,
        (width, height, samples),
        Arc::new(CheckedMethod(EdgeTableParams::default())),
        "exact",
        ["checked_clear", "checked_blocked", "checked_wrong", "answers_differ"],
    );
    eprintln!(
        "{}: {} clear, {} blocked checked; {} wrong; {} answers differ",
        scene.display(),
        got[0],
        got[1],
        got[2],
        got[3]
    );
    got
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Sums the checks over scenes and asserts none disagrees; returns the rays checked.
fn check_all(scenes: &[PathBuf], width: u32, height: u32, samples: u32) -> u64 {
    let total = checked::summed(scenes, |s| check(s, width, height, samples));
    assert_eq!(total[2], 0, "rays the masks decided that the BVH disagrees with");
    assert_eq!(total[3], 0, "answers differing from tracing the same samples");
    total[0] + total[1]
}

/// The default scene: visibility equal to tracing the same samples, bit for bit, at every
/// pixel, and every decided ray agreeing with the BVH.
#[test]
fn default_scene_equals_tracing_the_same_samples() {
    let rays = check_all(&[root().join("scenes/default.toml")], 160, 120, 256);
    assert!(rays > 1_000_000, "only {rays} decided rays checked");
}

/// The bench scenes and every shared scene: at least 10^6 decided rays, none wrong.
#[test]
fn shared_and_bench_scenes_agree_with_the_bvh() {
    if !common::shared::scenes_present("exact_edge_table::shared_and_bench_scenes_agree_with_the_bvh") {
        return;
    }
    let scenes = common::shared::gltf_scene_files();
    let rays = check_all(&scenes, 64, 48, 256);
    assert!(rays > 1_000_000, "only {rays} decided rays checked");
}

/// Random triangle soups (sizes from a millimetre to a metre, any orientation, some sharing
/// edges) and terraced heightfields (closed steps: shared edges, covers, walls), each under a
/// light of its own size: every decided ray agrees with the BVH.
#[test]
fn random_soups_and_heightfields_agree_with_the_bvh() {
    let dir = TempDir::new("exact-soups");
    let scenes = soups::soups_and_terraces(&dir, 17);
    let rays = check_all(&scenes, 64, 48, 256);
    assert!(rays > 300_000, "only {rays} decided rays checked");
}
