//! The bodies of the fuzz targets, shared with the stable regression test
//! `tests/fuzz_regressions.rs` (which includes this file with `#[path]`), so that a kept
//! crash input runs through exactly the code the fuzzer ran.
//!
//! Every input must end in [`Outcome::Loaded`] or [`Outcome::Refused`]: a panic, an abort,
//! a hang or an out-of-memory is a finding.

use penumbra::shadows_config::ShadowsConfig;
use renderer::{Scene, SceneError, SceneFile};
use std::path::{Path, PathBuf};

/// Whether `PENUMBRA_FUZZ_VERBOSE` is set: the targets then print each input's outcome
/// (for looking at a corpus: `PENUMBRA_FUZZ_VERBOSE=1 fuzz/target/.../gltf FILE...`).
pub fn verbose() -> bool {
    static VERBOSE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *VERBOSE.get_or_init(|| std::env::var_os("PENUMBRA_FUZZ_VERBOSE").is_some())
}

/// What one input came to.
#[derive(Debug)]
pub enum Outcome {
    /// Not an input of this target (the scene file's bytes are not UTF-8).
    Skipped,
    /// Loaded without an error.
    Loaded,
    /// Refused with an error naming the file and the key.
    Refused(SceneError),
}

impl From<Result<(), SceneError>> for Outcome {
    fn from(r: Result<(), SceneError>) -> Self {
        match r {
            Ok(()) => Outcome::Loaded,
            Err(e) => Outcome::Refused(e),
        }
    }
}

/// The `scene_file` target: the bytes as scene TOML, through `SceneFile::parse` and the
/// CLI's typing of `[shadows]`; a scene without models (quads and lights only, so nothing
/// is read from disk) is also loaded with `Scene::load`.
pub fn scene_file(data: &[u8]) -> Outcome {
    let Ok(text) = std::str::from_utf8(data) else { return Outcome::Skipped };
    let path = Path::new("fuzz/scene.toml");
    let run = || -> Result<(), SceneError> {
        let file = SceneFile::parse(text, path)?;
        ShadowsConfig::from_table(&file.shadows, path)?;
        if file.model.is_empty() {
            Scene::load(&file, path)?;
        }
        Ok(())
    };
    run().into()
}

/// A 2x2 RGBA PNG written beside the model as `t.png`: the seeds' external images point
/// at it, so their materials load and the fuzzer gets past them.
pub const TEXTURE_PNG: &[u8] = include_bytes!("t.png");

/// The `gltf` target. Its input is either a .glb (it starts with the magic `glTF`; written
/// as `m.glb`) or a .gltf JSON document, a NUL byte and the contents of its external buffer
/// (written as `m.gltf` and `b.bin`; JSON text never contains a raw NUL). Without a NUL
/// there is no `b.bin`. The model is loaded the way the CLI loads a scene: `Scene::load`
/// of a scene file whose `[[model]]` is that file, in up to three scenes, so that the
/// emissive-rectangle lights, the glTF camera and the BVH build are all reached:
///
/// 1. no `[[light]]` and a look-at camera: lights come from the model's emitters;
/// 2. if the model has none: a `[[light]]` and `camera.from_gltf = true`;
/// 3. if the model has no camera either: a `[[light]]` and a look-at camera.
pub struct GltfHarness {
    dir: PathBuf,
    /// The three scenes above, for `m.glb` and for `m.gltf`.
    scenes: [[SceneFile; 3]; 2],
}

impl GltfHarness {
    /// Uses `dir` (created if missing) for the files of every input, rewritten each time.
    pub fn new(dir: PathBuf) -> Self {
        std::fs::create_dir_all(&dir).expect("create the fuzz folder");
        std::fs::write(dir.join("t.png"), TEXTURE_PNG).expect("write t.png");
        let scene_path = dir.join("scene.toml");
        let scenes = ["m.glb", "m.gltf"].map(|model| {
            let model = format!("[[model]]\npath = \"{model}\"\n");
            let look_at = "[camera]\nposition = [0.0, 1.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n";
            let from_gltf = "[camera]\nfrom_gltf = true\n";
            let light = "[[light]]\ncenter = [0.0, 3.0, 0.0]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 0.0, -1.0]\n\
                         radiance = [1.0, 1.0, 1.0]\n";
            [
                format!("{model}{look_at}"),
                format!("{model}{from_gltf}{light}"),
                format!("{model}{look_at}{light}"),
            ]
            .map(|text| SceneFile::parse(&text, &scene_path).expect("a valid scene"))
        });
        Self { dir, scenes }
    }

    /// The folder the files are written to.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Writes `data` as described on [`GltfHarness`] and loads it.
    pub fn run(&self, data: &[u8]) -> Outcome {
        for name in ["m.glb", "m.gltf", "b.bin"] {
            let _ = std::fs::remove_file(self.dir.join(name));
        }
        let binary = data.starts_with(b"glTF");
        if binary {
            std::fs::write(self.dir.join("m.glb"), data).expect("write m.glb");
        } else {
            let (json, bin) = match data.iter().position(|&b| b == 0) {
                Some(i) => (&data[..i], Some(&data[i + 1..])),
                None => (data, None),
            };
            std::fs::write(self.dir.join("m.gltf"), json).expect("write m.gltf");
            if let Some(bin) = bin {
                std::fs::write(self.dir.join("b.bin"), bin).expect("write b.bin");
            }
        }
        let scene_path = self.dir.join("scene.toml");
        let scenes = &self.scenes[if binary { 0 } else { 1 }];
        let fallback_keys = ["light", "camera.from_gltf"];
        let mut result = Ok(());
        for (i, scene) in scenes.iter().enumerate() {
            result = Scene::load(scene, &scene_path).map(drop);
            match &result {
                Err(e) if i < 2 && e.key == fallback_keys[i] && e.file == scene_path => continue,
                _ => break,
            }
        }
        result.into()
    }
}
