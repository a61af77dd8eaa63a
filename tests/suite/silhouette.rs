//! `silhouette` against the BVH: every sample its counting settles is traced with `traced`'s
//! own ray and must agree (0 disagreements; samples the method traces itself are not
//! disagreements, and are counted), and its visibility must equal `traced`'s with the same
//! samples. Run through the ordinary render path (a wrapping method checks each query).

use crate::common;

use common::checked::{self, CheckedMethod, Verdicts};
use common::gltf_writer::TempDir;
use common::soups;
use renderer::{
    KeepInstances, LightShadowing, PrepareContext, Scene, ShadowError, ShadowMethod, ShadowQuery, Traced,
    TracedParams,
};
use shadow_plugin::Silhouette;
use std::path::PathBuf;
use std::sync::Arc;

/// `silhouette` checked: each query's settled samples against traced rays, and its answer
/// against `traced`'s own (the same samples, weighed: the share of irradiance).
struct Settled {
    inner: Silhouette,
    truth: Traced,
}

impl Verdicts for Settled {
    const NAME: &'static str = "silhouette";
    const KINDS: [&'static str; 2] = ["checked_settled", "checked_traced"];

    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.truth.prepare(ctx)?;
        self.inner.prepare(ctx)
    }
    fn check(&self, scene: &Scene, q: &ShadowQuery) -> [u64; 3] {
        let (mut settled, mut traced, mut wrong) = (0, 0, 0);
        let verdicts = self.inner.verdicts(scene, q);
        let samples: Vec<_> = verdicts.iter().map(|(s, _)| *s).collect();
        let truths = self.inner.traced_lit(scene, q, &samples);
        for ((_, verdict), &truth) in verdicts.iter().zip(&truths) {
            match verdict {
                None => traced += 1,
                Some(lit) => {
                    settled += 1;
                    wrong += (*lit != truth) as u64;
                }
            }
        }
        [settled, traced, wrong]
    }
    fn answers(&self, scene: &Scene, q: &ShadowQuery) -> (f32, f32) {
        (self.inner.visibility(scene, q), self.truth.visibility(scene, q))
    }
    fn counters(&self) -> Vec<(&'static str, u64)> {
        self.inner.counters()
    }
}

/// `silhouette`, checked.
fn checked_silhouette() -> Arc<dyn ShadowMethod> {
    CheckedMethod::shared(|samples| Settled {
        inner: Silhouette::new(samples),
        truth: Traced::new(TracedParams::CULLED, samples),
    })
}

/// Over `scenes` at `dims` (width, height, samples): settled samples checked, samples traced
/// by the method, disagreements, answers differing from tracing every sample, points whose
/// samples under the geometric tangent plane were counted, alpha-tested triangles counted as
/// opaque, dropped as clear, and left out as mixed. Asserts that the BVH agrees with every
/// settled sample and that every answer equals tracing the same samples.
fn counts(scenes: &[PathBuf], dims: (u32, u32, u32)) -> [u64; 8] {
    let keys = [
        "checked_settled",
        "checked_traced",
        "checked_wrong",
        "answers_differ",
        "points_counted_below",
        "triangles_alpha_opaque",
        "triangles_alpha_clear",
        "triangles_alpha",
    ];
    checked::check_all(scenes, dims, &checked_silhouette(), "silhouette", keys, None)
}

/// The default scene: the visibility equals `traced`'s with the same samples, bit for bit, at
/// every pixel.
#[test]
fn default_scene_equals_tracing_the_same_samples() {
    let settled = counts(&[checked::scene("scenes/default.toml")], (160, 120, 256))[0];
    assert!(settled > 200_000, "only {settled} settled samples checked");
}

/// Every shared scene (alpha-masked foliage, zero-area triangles, non-manifold meshes
/// included): at least 10^6 settled samples, none wrong.
#[test]
fn shared_scenes_agree_with_the_bvh() {
    if !common::shared::scenes_present("silhouette::shared_scenes_agree_with_the_bvh") {
        return;
    }
    let scenes = common::sweep(common::shared::gltf_scene_files(), 1);
    let settled = counts(&scenes, (64, 48, 256))[0];
    assert!(settled > common::sweep_floor(1_000_000), "only {settled} settled samples checked");
}

/// The safety net: at N = 4 a point of metal-rough-spheres' spheres has more active edges
/// than 3 per sample, and is traced whole; the answers still equal tracing every sample.
#[test]
fn points_with_more_edges_than_the_counting_pays_for_are_traced_whole() {
    if !common::shared::scenes_present("silhouette::points_with_more_edges_than_the_counting_pays_for") {
        return;
    }
    let scene = checked::scene("scenes/gltf/metal-rough-spheres.toml");
    let keys = ["answers_differ", "points_fallback_costly", "silhouette_points"];
    let [differ, costly, points] =
        checked::counters(&scene, (48, 36, 4), checked_silhouette(), "costly", keys);
    assert_eq!(differ, 0, "answers differing from tracing the same samples");
    assert!(costly > 20 && costly < points, "{costly} of {points} points traced whole");
}

/// Random soups with shared edges, terraced heightfields (closed boxes), duplicated and
/// reversed triangles, non-manifold fans, T-junctions, crossing closed boxes and meshes with
/// smoothed normals (samples under the geometric tangent plane, counted from the origin
/// below it), each under a light of its own size: every settled sample agrees with the BVH.
#[test]
fn soups_heightfields_and_stress_meshes_agree_with_the_bvh() {
    let dir = TempDir::new("silhouette-soups");
    let mut scenes = soups::soups_and_terraces(&dir, 17);
    scenes.extend(soups::stress_soups(&dir, 29));
    scenes.extend(soups::smooth_soups(&dir, 31));
    let [settled, _, _, _, below, ..] = counts(&scenes, (64, 48, 512));
    assert!(settled > 6_000_000, "only {settled} settled samples checked");
    assert!(below > 200, "only {below} points counted from below the tangent plane");
}

/// Meshes placed by several nodes (mirrored, unevenly scaled, nested; two instances closing
/// into one sphere at a seam; one mesh's two primitives sharing a row), each mesh's edges
/// found once and offset per instance: every settled sample agrees with the BVH.
#[test]
fn instanced_meshes_agree_with_the_bvh() {
    let dir = TempDir::new("silhouette-instances");
    let scenes = soups::instanced_soups(&dir, 43);
    let [settled, ..] = counts(&scenes, (64, 48, 512));
    assert!(settled > 1_000_000, "only {settled} settled samples checked");
}

/// The same instanced meshes kept unflattened (each mesh's edges found once in its own
/// space, placed per instance as the walk meets them), and a field of 400 boulders: every
/// settled sample agrees with the BVH, the answers equal tracing the same samples, and the
/// instances are counted, not traced whole (under 5% of the points meet one the counting
/// leaves out).
#[test]
fn kept_instances_agree_with_the_bvh() {
    let dir = TempDir::new("silhouette-kept-instances");
    let mut scenes = soups::instanced_soups(&dir, 43);
    // 400 smooth 5k-triangle boulders, the bench's instanced scene (kept by default).
    scenes.push(checked::scene("scenes/stress/boulder-field-400.toml"));
    let keys = [
        "checked_settled",
        "checked_wrong",
        "answers_differ",
        "instances_counted",
        "points_fallback_kept_instance",
        "silhouette_points",
    ];
    let keep = Some(KeepInstances::Always);
    let [settled, _, _, counted, uncounted, points] =
        checked::check_all(&scenes, (64, 48, 512), &checked_silhouette(), "kept", keys, keep);
    assert!(settled > 1_000_000, "only {settled} settled samples checked");
    assert!(counted >= 10, "only {counted} instances counted");
    assert!(uncounted * 20 < points, "{uncounted} of {points} points traced whole");
}

/// Every shared scene with its instances kept (metal-rough-spheres: 98 of one sphere):
/// every settled sample agrees with the BVH and every answer equals tracing the same
/// samples. (Instances with alpha-tested materials or triangles near the light are not
/// counted: their points are traced whole.)
#[test]
fn shared_scenes_with_kept_instances_agree_with_the_bvh() {
    if !common::shared::scenes_present("silhouette::shared_scenes_with_kept_instances_agree_with_the_bvh") {
        return;
    }
    let scenes = common::sweep(common::shared::gltf_scene_files(), 0);
    let keys = ["checked_settled", "checked_wrong", "answers_differ"];
    let keep = Some(KeepInstances::Always);
    let [settled, ..] =
        checked::check_all(&scenes, (64, 48, 256), &checked_silhouette(), "kept-shared", keys, keep);
    assert!(settled > common::sweep_floor(500_000), "only {settled} settled samples checked");
}

/// Random soups of alpha-masked triangles (a banded texture: clear, noise, opaque; wrapped
/// and transformed; constant alphas) among opaque ones: every class is met, and every
/// settled sample agrees with the BVH (opaque ones counted, clear ones dropped, mixed ones
/// traced).
#[test]
fn alpha_masked_soups_agree_with_the_bvh() {
    let dir = TempDir::new("silhouette-alpha-soups");
    let scenes = soups::alpha_soups(&dir, 41);
    let [settled, _, _, _, _, opaque, clear, mixed] = counts(&scenes, (64, 48, 512));
    assert!(settled > 2_000_000, "only {settled} settled samples checked");
    assert!(
        opaque > 100 && clear > 100 && mixed > 100,
        "classes met: {opaque} opaque, {clear} clear, {mixed} mixed"
    );
}

/// The bench's glass-vase-flowers at its own size (23 M settled samples, ~15 s in release; run
/// by hand: `cargo test --release --test suite silhouette:: -- --ignored --nocapture`). It found the one
/// sample in 23 M where Möller-Trumbore let a ray through a seam (the test is now watertight).
#[test]
#[ignore]
fn glass_vase_flowers_at_bench_size_agrees_with_the_bvh() {
    counts(&[checked::scene("scenes/bench/glass-vase-flowers.toml")], (320, 240, 1024));
}

/// sauerbraten-zdm2 through the path tracer's vertices (160x120, N = 1024: 49 M settled
/// samples, ~17 s in release; run by hand with the test above). It found the f32 watertight
/// test's rays meeting the wall they leave (27 samples; the test's frame is now f64).
#[test]
#[ignore]
fn sauerbraten_zdm2_paths_agree_with_the_bvh() {
    counts(&[checked::scene("scenes/bench/sauerbraten-zdm2.toml")], (160, 120, 1024));
}
