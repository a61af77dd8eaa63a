//! The ground truth per scene: `traced` at a high sample count, cached on disk under a key of
//! the scene and the settings, and recomputed when either changes.
//!
//! The key hashes [`TRUTH_VERSION`], the scene file's bytes, each model's files (the glTF
//! and the buffers and images it names), the image size, spp, seed and sample count.
//! An entry is three kinds of file in the cache folder, named `<scene-stem>-<key>`: the
//! radiance (`.exr`), each light's visibility (`.visibility.<k>.exr`) and a `.json` holding
//! the key's inputs and the time the truth took. Entries of the same scene under another
//! key are removed when a new one is written.
//!
//! Code is not in the key: a change to `traced`, the loader or the frame's conventions must
//! bump [`TRUTH_VERSION`] (or the cache folder be removed).

use crate::cli_error::{CliError, OutputError};
use crate::output::StagedFiles;
use glam::Vec3;
use renderer::{Frame, RenderSettings, Scene, SceneError, SceneFile, Traced, TracedParams, render};
use serde::{Deserialize, Serialize};
use std::hash::{DefaultHasher, Hasher};
use std::path::{Path, PathBuf};

/// Bump when the traced method or the frame's conventions change: old entries then no
/// longer match.
/// v2: the one rule for ray origins (each hit's own error bound) replaced the scene-scaled
/// epsilon, and `traced` samples only the part of the light above the horizon.
/// v3: V is the share of irradiance (samples weighed by g), with strata in proportion to g
/// under near lights.
/// v4: glTF normal textures bend the shading normal (`[materials] shading = "gltf"`, the
/// default): toy-car's and glass-vase-flowers' truths change.
/// v5: alphaMode BLEND is coverage, no longer MASK 0.5 (`renderer::geometry::coverage`):
/// glass-vase-flowers' glass (alpha 0.3) and flight-helmet's lenses stop the share of light their
/// alpha says.
/// v6: the direct-light truth (`max_depth` 2) follows the runs' bounce rays too, as the path
/// truth does: under glTF shading each vertex still sends one BRDF ray toward the lights a
/// sharp lobe reflects and the emitters that are not lights, which a seed of its own drew
/// elsewhere (every method's image error then read that ray's noise: 6.5x the image's mean
/// on cornell-box, 19x on toy-car at 160x120).
pub const TRUTH_VERSION: &str = "traced-v6";

/// Mixed into the truth's shadow queries' seeds, so that its light samples are independent
/// of the swept `traced` runs' (which use the bench seed itself).
pub const TRUTH_SEED_SALT: u64 = 0x7275_7468_5eed;

/// The truth of one scene.
#[derive(Debug, Clone)]
pub struct Truth {
    pub radiance: Vec<Vec3>,
    pub visibility: Vec<Vec<f32>>,
    /// Whether it came from the cache.
    pub cached: bool,
    /// Wall time of the traced render that made it (then or now).
    pub seconds: f64,
    pub key: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
struct Entry {
    key: String,
    version: String,
    scene: String,
    width: u32,
    height: u32,
    spp: u32,
    seed: u64,
    samples: u32,
    /// Path depth (entries written before paths have none: 2).
    #[serde(default = "direct_only")]
    max_depth: u32,
    lights: usize,
    seconds: f64,
}

fn direct_only() -> u32 {
    2
}

/// The cache key of a scene (file `scene_path`, parsed as `file`) under these settings.
pub fn cache_key(
    scene_path: &Path,
    file: &SceneFile,
    settings: &RenderSettings,
    samples: u32,
) -> Result<String, CliError> {
    let mut h = DefaultHasher::new();
    h.write(TRUTH_VERSION.as_bytes());
    let read =
        |p: &Path| std::fs::read(p).map_err(|e| SceneError::new(p, "bench", format!("cannot read: {e}")));
    h.write(&read(scene_path)?);
    for model in &file.model {
        for f in crate::scene_files::model_files(&SceneFile::resolve(scene_path, &model.path)) {
            // Length-prefixed, so that no two file lists hash the same bytes.
            let bytes = read(&f)?;
            h.write_usize(bytes.len());
            h.write(&bytes);
        }
    }
    for v in
        [settings.width as u64, settings.height as u64, settings.spp as u64, settings.seed, samples as u64]
    {
        h.write_u64(v);
    }
    // Hashed only above 2, so that direct-light entries keep their keys.
    if settings.max_depth > 2 {
        // "salted": the path truth's light samples are its own (an earlier path truth shared
        // the runs').
        h.write(b"paths, salted");
        h.write_u64(settings.max_depth as u64);
    }
    Ok(format!("{:016x}", h.finish()))
}

fn entry_paths(cache: &Path, stem: &str, key: &str, lights: usize) -> (PathBuf, PathBuf, Vec<PathBuf>) {
    // Built as strings: `with_extension` would cut a stem with a dot in it.
    let base = format!("{stem}-{key}");
    let exr = cache.join(format!("{base}.exr"));
    let json = cache.join(format!("{base}.json"));
    let vis = (0..lights).map(|k| cache.join(format!("{base}.visibility.{k}.exr"))).collect();
    (exr, json, vis)
}

fn read_exr(path: &Path, settings: &RenderSettings) -> Option<Vec<Vec3>> {
    let img = image::open(path).ok()?.into_rgb32f();
    if img.dimensions() != (settings.width, settings.height) {
        return None;
    }
    Some(img.pixels().map(|p| Vec3::from_array(p.0)).collect())
}

/// The truth for `scene`: read from `cache` when an entry with this key is there and
/// whole, else rendered with `traced` at `samples` and written there.
pub fn truth(
    cache: &Path,
    stem: &str,
    scene_path: &Path,
    file: &SceneFile,
    scene: &Scene,
    settings: &RenderSettings,
    samples: u32,
) -> Result<Truth, CliError> {
    let key = cache_key(scene_path, file, settings, samples)?;
    let lights = scene.lights.len();
    let (exr, json, vis) = entry_paths(cache, stem, &key, lights);
    let expected = Entry {
        key: key.clone(),
        version: TRUTH_VERSION.to_string(),
        scene: scene_path.display().to_string(),
        width: settings.width,
        height: settings.height,
        spp: settings.spp,
        seed: settings.seed,
        samples,
        max_depth: settings.max_depth,
        lights,
        seconds: 0.0,
    };
    let cached = || -> Option<Truth> {
        let entry: Entry = serde_json::from_slice(&std::fs::read(&json).ok()?).ok()?;
        if (Entry { seconds: 0.0, scene: expected.scene.clone(), ..entry.clone() }) != expected {
            return None;
        }
        let radiance = read_exr(&exr, settings)?;
        let visibility = vis
            .iter()
            .map(|p| read_exr(p, settings).map(|v| v.iter().map(|c| c.x).collect()))
            .collect::<Option<Vec<Vec<f32>>>>()?;
        Some(Truth { radiance, visibility, cached: true, seconds: entry.seconds, key: key.clone() })
    };
    if let Some(t) = cached() {
        return Ok(t);
    }

    // Light samples of its own, never the runs' (their error would read too low): a salt of
    // its own in its shadow queries' seeds. Paths, and at depth 2 the one BRDF ray a vertex
    // sends toward sharp reflections and emitters: the runs' seed, so that the truth follows
    // the very same rays (they do not depend on the shadow method).
    let mut methods: Vec<Box<dyn renderer::LightShadowing>> = (0..lights)
        .map(|_| Box::new(Traced::new(TracedParams::PLAIN, samples).with_seed_salt(TRUTH_SEED_SALT)) as _)
        .collect();
    let frame: Frame = render(scene, &mut methods, settings, &|_| {})
        .map_err(|e| SceneError::new(scene_path, "bench", e.to_string()))?;
    let seconds = (frame.shadow_prepare + frame.render).as_secs_f64();

    std::fs::create_dir_all(cache)
        .map_err(|e| OutputError::new(cache, "--cache", format!("cannot create the folder: {e}")))?;
    let io = |e: String| OutputError::new(cache, "--cache", e);
    let mut staged = StagedFiles::default();
    staged.exr(&exr, settings.width, settings.height, &frame.radiance).map_err(io)?;
    for (path, v) in vis.iter().zip(&frame.visibility) {
        let rgb: Vec<Vec3> = v.iter().map(|&x| Vec3::splat(x)).collect();
        staged.exr(path, settings.width, settings.height, &rgb).map_err(io)?;
    }
    let entry = Entry { seconds, ..expected };
    staged.bytes(&json, &serde_json::to_vec_pretty(&entry).expect("serialises")).map_err(io)?;
    staged.commit().map_err(io)?;
    remove_stale(cache, stem, &key);
    Ok(Truth { radiance: frame.radiance, visibility: frame.visibility, cached: false, seconds, key })
}

/// Removes the entries of scene `stem` under keys other than `key`.
fn remove_stale(cache: &Path, stem: &str, key: &str) {
    let Ok(entries) = std::fs::read_dir(cache) else { return };
    let prefix = format!("{stem}-");
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = name.strip_prefix(&prefix) else { continue };
        // `<16 hex digits>.` exactly: another scene's stem may start with this one's.
        let is_entry = rest.len() > 17
            && rest.as_bytes()[16] == b'.'
            && rest[..16].bytes().all(|b| b.is_ascii_hexdigit());
        if is_entry && !rest.starts_with(key) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}
