//! Renders a scene through the CLI's render path with a wrapping method that checks each
//! query (the differential tests of the exact methods), and reads its counters.

#![allow(dead_code)] // each test binary uses a different subset

use penumbra::{RenderArgs, run_render};
use renderer::ShadowMethod;
use std::path::Path;
use std::sync::Arc;

/// The run report's counters `keys` after rendering `scene` at `width` x `height` with
/// `samples` through `method`; the image files are removed (`tag` names their folder).
pub fn counters<const K: usize>(
    scene: &Path,
    dims: (u32, u32, u32),
    method: Arc<dyn ShadowMethod>,
    tag: &str,
    keys: [&str; K],
) -> [u64; K] {
    counters_kept(scene, dims, method, tag, keys, None)
}

/// [`counters`] with instances kept unflattened or not as `keep` says (`None`: the method's
/// rule).
pub fn counters_kept<const K: usize>(
    scene: &Path,
    (width, height, samples): (u32, u32, u32),
    method: Arc<dyn ShadowMethod>,
    tag: &str,
    keys: [&str; K],
    keep: Option<renderer::KeepInstances>,
) -> [u64; K] {
    let dir = std::env::temp_dir().join(format!("penumbra-{tag}-{}", std::process::id()));
    let stem = scene.file_stem().unwrap().to_string_lossy().to_string();
    let out = dir.join(format!("{stem}.png"));
    let args = RenderArgs {
        scene: Some(scene.to_path_buf()),
        samples: Some(samples),
        width: Some(width),
        height: Some(height),
        out: Some(out.clone()),
        quiet: true,
        method: Some(method),
        max_depth: paths_depth(scene),
        keep_instances: keep,
        ..Default::default()
    };
    let outcome = run_render(&args).unwrap_or_else(|e| panic!("{}: {e}", scene.display()));
    for suffix in ["png", "exr", "json"] {
        let _ = std::fs::remove_file(out.with_extension(suffix));
    }
    let c = &outcome.report.counters;
    keys.map(|k| *c.get(k).unwrap_or_else(|| panic!("{k} missing from {c:?}")))
}

/// The scene files of `scenes/gltf` and `scenes/bench` render direct light only
/// (`max_depth = 2`, for a clean picture at 1 spp); the checks follow their paths as they
/// did before (`--max-depth 5`: three bounces), so they still meet the secondary vertices.
/// Other scenes keep their own setting.
fn paths_depth(scene: &Path) -> Option<u32> {
    let dir = scene.parent().and_then(|d| d.file_name()).and_then(|d| d.to_str());
    let in_scenes = scene.parent().and_then(|d| d.parent()).is_some_and(|d| d.ends_with("scenes"));
    (in_scenes && matches!(dir, Some("gltf" | "bench"))).then_some(5)
}

/// `check`'s counters summed over `scenes`.
pub fn summed<const K: usize>(scenes: &[std::path::PathBuf], check: impl Fn(&Path) -> [u64; K]) -> [u64; K] {
    scenes.iter().map(|s| check(s)).fold([0; K], |mut total, got| {
        for (t, g) in total.iter_mut().zip(got) {
            *t += g;
        }
        total
    })
}
