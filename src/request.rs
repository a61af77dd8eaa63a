//! One render request: the scene file with the command line's overrides merged into its
//! table, typed and checked once ([`SceneFile::parse_with`], then `[shadows]` through the
//! registry). Every range is the scene file's (`renderer::load::scene_file`); an error about a
//! value a flag gave names the flag. After this, nothing downstream checks a setting again.

use crate::shadows_config::ShadowsConfig;
use renderer::load::scene_file::Override;
use renderer::{SceneError, SceneFile};
use std::path::{Path, PathBuf};

/// The default scene, embedded so that `penumbra` with no arguments works anywhere.
pub const DEFAULT_SCENE: &str = include_str!("../scenes/default.toml");

/// The name the default scene's errors and outputs go by.
pub const DEFAULT_SCENE_NAME: &str = "scenes/default.toml";

/// The command line's values for scene-file keys (each `None` leaves the file's).
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    /// `--shadows`: `[shadows].method`.
    pub shadows: Option<String>,
    /// `--samples`: `[shadows].samples`.
    pub samples: Option<u32>,
    /// `--width`, `--height`, `--spp`: `[image]`'s.
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub spp: Option<u32>,
    /// `--max-depth`: `[integrator].max_depth`.
    pub max_depth: Option<u32>,
}

impl Overrides {
    /// Each value given, at its key, named by its flag.
    fn list(&self) -> Vec<Override> {
        let whole = |key, source, v: Option<u32>| {
            v.map(|v| Override { key, source, value: toml::Value::Integer(v.into()) })
        };
        let method = self.shadows.as_ref().map(|m| Override {
            key: "shadows.method",
            source: "--shadows",
            value: toml::Value::String(m.clone()),
        });
        [
            method,
            whole("shadows.samples", "--samples", self.samples),
            whole("image.width", "--width", self.width),
            whole("image.height", "--height", self.height),
            whole("image.spp", "--spp", self.spp),
            whole("integrator.max_depth", "--max-depth", self.max_depth),
        ]
        .into_iter()
        .flatten()
        .collect()
    }
}

/// A scene file with its overrides, checked: what to render.
#[derive(Debug, Clone)]
pub struct Request {
    /// The scene file's path (or [`DEFAULT_SCENE_NAME`]), which errors name.
    pub scene_path: PathBuf,
    /// The embedded default scene's text, when no file was given.
    pub embedded: Option<&'static str>,
    /// The scene file with the overrides in place: `file.image.width` is the width rendered.
    pub file: SceneFile,
    /// `file.shadows`, typed: the chosen method and its sample count.
    pub shadows: ShadowsConfig,
}

impl Request {
    /// The scene file at `scene` (else the embedded default scene) with `overrides` merged
    /// in, typed and checked once.
    pub fn read(scene: Option<&Path>, overrides: &Overrides) -> Result<Self, SceneError> {
        let (scene_path, text, embedded) = match scene {
            Some(p) => (p.to_path_buf(), SceneFile::read(p)?, None),
            None => (PathBuf::from(DEFAULT_SCENE_NAME), DEFAULT_SCENE.to_string(), Some(DEFAULT_SCENE)),
        };
        let overrides = overrides.list();
        let file = SceneFile::parse_with(&text, &scene_path, &overrides)?;
        let shadows = ShadowsConfig::from_table(&file.shadows, &scene_path)
            .map_err(|e| Override::relabel(&overrides, e))?;
        Ok(Self { scene_path, embedded, file, shadows })
    }
}
