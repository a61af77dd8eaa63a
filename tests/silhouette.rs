//! `silhouette` against the BVH: every sample its counting settles is traced with `traced`'s
//! own ray and must agree (0 disagreements; samples the method traces itself are not
//! disagreements, and are counted), and its visibility must equal `traced`'s with the same
//! samples. Run through the ordinary render path (a wrapping method checks each query).

mod common;

use common::checked;
use common::gltf_writer::TempDir;
use common::soups;
use renderer::{
    LightShadowing, PrepareContext, Scene, ShadowError, ShadowMethod, ShadowQuery, Traced, TracedParams,
};
use shadow_plugin::Silhouette;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// `silhouette` wrapped: each query's settled samples checked against traced rays, and its
/// answer against `traced`'s own (the same samples, weighed: the share of irradiance).
struct Checked {
    inner: Silhouette,
    truth: Traced,
    settled: AtomicU64,
    traced: AtomicU64,
    wrong: AtomicU64,
    answers_differ: AtomicU64,
}

impl LightShadowing for Checked {
    fn name(&self) -> &'static str {
        "silhouette"
    }
    fn prepare(&mut self, ctx: &PrepareContext) -> Result<(), ShadowError> {
        self.truth.prepare(ctx)?;
        self.inner.prepare(ctx)
    }
    fn visibility(&self, scene: &Scene, q: &ShadowQuery) -> f32 {
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
        self.settled.fetch_add(settled, Ordering::Relaxed);
        self.traced.fetch_add(traced, Ordering::Relaxed);
        self.wrong.fetch_add(wrong, Ordering::Relaxed);
        let v = self.inner.visibility(scene, q);
        if v.to_bits() != self.truth.visibility(scene, q).to_bits() {
            self.answers_differ.fetch_add(1, Ordering::Relaxed);
        }
        v
    }
    fn counters(&self) -> Vec<(&'static str, u64)> {
        let mut c = self.inner.counters();
        c.push(("checked_settled", self.settled.load(Ordering::Relaxed)));
        c.push(("checked_traced", self.traced.load(Ordering::Relaxed)));
        c.push(("checked_wrong", self.wrong.load(Ordering::Relaxed)));
        c.push(("answers_differ", self.answers_differ.load(Ordering::Relaxed)));
        c
    }
}

#[derive(Debug)]
struct CheckedMethod;

impl ShadowMethod for CheckedMethod {
    fn name(&self) -> &'static str {
        "silhouette"
    }
    fn max_samples(&self) -> u32 {
        4096
    }
    fn build(&self, samples: u32) -> Box<dyn LightShadowing> {
        Box::new(Checked {
            inner: Silhouette::new(samples),
            truth: Traced::new(TracedParams::CULLED, samples),
            settled: AtomicU64::new(0),
            traced: AtomicU64::new(0),
            wrong: AtomicU64::new(0),
            answers_differ: AtomicU64::new(0),
        })
    }
}

/// (settled samples checked, samples traced by the method, disagreements, answers differing
/// from tracing every sample, points whose samples under the geometric tangent plane were
/// counted, alpha-tested triangles counted as opaque, dropped as clear, and left out as
/// mixed).
fn check(scene: &Path, width: u32, height: u32, samples: u32) -> [u64; 8] {
    let got = checked::counters(
        scene,
        (width, height, samples),
        Arc::new(CheckedMethod),
        "silhouette",
        [
            "checked_settled",
            "checked_traced",
            "checked_wrong",
            "answers_differ",
            "points_counted_below",
            "triangles_alpha_opaque",
            "triangles_alpha_clear",
            "triangles_alpha",
        ],
    );
    eprintln!(
        "{}: {} settled, {} traced by the method; {} wrong; {} answers differ; {} points counted below; alpha-tested triangles: {} opaque, {} clear, {} mixed",
        scene.display(),
        got[0],
        got[1],
        got[2],
        got[3],
        got[4],
        got[5],
        got[6],
        got[7]
    );
    got
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Sums the checks over scenes and asserts none disagrees; returns the sums (see [`check`]).
fn check_all(scenes: &[PathBuf], width: u32, height: u32, samples: u32) -> [u64; 8] {
    let total = checked::summed(scenes, |s| check(s, width, height, samples));
    eprintln!("total: {} settled, {} traced by the method; {} wrong", total[0], total[1], total[2]);
    assert_eq!(total[2], 0, "samples the counting settled that the BVH disagrees with");
    assert_eq!(total[3], 0, "answers differing from tracing the same samples");
    total
}

/// The default scene: the visibility equals `traced`'s with the same samples, bit for bit, at
/// every pixel.
#[test]
fn default_scene_equals_tracing_the_same_samples() {
    let settled = check_all(&[root().join("scenes/default.toml")], 160, 120, 256)[0];
    assert!(settled > 200_000, "only {settled} settled samples checked");
}

/// Every shared scene (alpha-masked foliage, zero-area triangles, non-manifold meshes
/// included): at least 10^6 settled samples, none wrong.
#[test]
fn shared_scenes_agree_with_the_bvh() {
    if !common::shared::scenes_present("silhouette::shared_scenes_agree_with_the_bvh") {
        return;
    }
    let scenes = common::shared::gltf_scene_files();
    let settled = check_all(&scenes, 64, 48, 256)[0];
    assert!(settled > 1_000_000, "only {settled} settled samples checked");
}

/// The safety net: at N = 4 a point of metal-rough-spheres' spheres has more active edges
/// than 3 per sample, and is traced whole; the answers still equal tracing every sample.
#[test]
fn points_with_more_edges_than_the_counting_pays_for_are_traced_whole() {
    if !common::shared::scenes_present("silhouette::points_with_more_edges_than_the_counting_pays_for") {
        return;
    }
    let scene = root().join("scenes/gltf/metal-rough-spheres.toml");
    let keys = ["answers_differ", "points_fallback_costly", "silhouette_points"];
    let [differ, costly, points] =
        checked::counters(&scene, (48, 36, 4), Arc::new(CheckedMethod), "costly", keys);
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
    let [settled, _, _, _, below, ..] = check_all(&scenes, 64, 48, 512);
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
    let [settled, ..] = check_all(&scenes, 64, 48, 512);
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
    scenes.push(root().join("scenes/stress/boulder-field-400.toml"));
    let keys = [
        "checked_settled",
        "checked_wrong",
        "answers_differ",
        "instances_counted",
        "points_fallback_kept_instance",
        "silhouette_points",
    ];
    let keep = Some(renderer::KeepInstances::Always);
    let [settled, wrong, differ, counted, uncounted, points] = checked::summed(&scenes, |s| {
        checked::counters_kept(s, (64, 48, 512), Arc::new(CheckedMethod), "kept", keys, keep)
    });
    eprintln!(
        "kept: {settled} settled, {wrong} wrong, {differ} differ; {counted} instances counted; {uncounted} of {points} points traced whole for an uncounted instance"
    );
    assert_eq!((wrong, differ), (0, 0), "disagreements with the BVH, answers differing from tracing");
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
    let scenes = common::shared::gltf_scene_files();
    let keys = ["checked_settled", "checked_wrong", "answers_differ"];
    let keep = Some(renderer::KeepInstances::Always);
    let [settled, wrong, differ] = checked::summed(&scenes, |s| {
        checked::counters_kept(s, (64, 48, 256), Arc::new(CheckedMethod), "kept-shared", keys, keep)
    });
    assert_eq!((wrong, differ), (0, 0), "disagreements with the BVH, answers differing from tracing");
    assert!(settled > 500_000, "only {settled} settled samples checked");
}

/// Random soups of alpha-masked triangles (a banded texture: clear, noise, opaque; wrapped
/// and transformed; constant alphas) among opaque ones: every class is met, and every
/// settled sample agrees with the BVH (opaque ones counted, clear ones dropped, mixed ones
/// traced).
#[test]
fn alpha_masked_soups_agree_with_the_bvh() {
    let dir = TempDir::new("silhouette-alpha-soups");
    let scenes = soups::alpha_soups(&dir, 41);
    let [settled, _, _, _, _, opaque, clear, mixed] = check_all(&scenes, 64, 48, 512);
    assert!(settled > 2_000_000, "only {settled} settled samples checked");
    assert!(
        opaque > 100 && clear > 100 && mixed > 100,
        "classes met: {opaque} opaque, {clear} clear, {mixed} mixed"
    );
}

/// The bench's glass-vase-flowers at its own size (23 M settled samples, ~15 s in release; run
/// by hand: `cargo test --release --test silhouette -- --ignored --nocapture`). It found the one
/// sample in 23 M where Möller-Trumbore let a ray through a seam (the test is now watertight).
#[test]
#[ignore]
fn glass_vase_flowers_at_bench_size_agrees_with_the_bvh() {
    check_all(&[root().join("scenes/bench/glass-vase-flowers.toml")], 320, 240, 1024);
}

/// sauerbraten-zdm2 through the path tracer's vertices (160x120, N = 1024: 49 M settled
/// samples, ~17 s in release; run by hand with the test above). It found the f32 watertight
/// test's rays meeting the wall they leave (27 samples; the test's frame is now f64).
#[test]
#[ignore]
fn sauerbraten_zdm2_paths_agree_with_the_bvh() {
    check_all(&[root().join("scenes/bench/sauerbraten-zdm2.toml")], 160, 120, 1024);
}
