//! One render request: the scene file with the command line's values merged into its table
//! ([`Override`]), typed and checked by the scene file's own checks, with the same ranges and
//! words, so that an error about a value a flag gave names the flag. The file is first
//! checked as written (a value a flag replaces must still be valid there, and an error with
//! no key keeps its byte offset); nothing downstream checks a setting again.

use crate::shadows_config::ShadowsConfig;
use renderer::load::scene_file::{MAX_PRIMARY_SAMPLES, Override};
use renderer::{SceneError, SceneFile, ShadowMethod};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The default scene, embedded so that `penumbra` with no arguments works anywhere.
pub const DEFAULT_SCENE: &str = include_str!("../scenes/default.toml");

/// The name the default scene's errors and outputs go by.
pub const DEFAULT_SCENE_NAME: &str = "scenes/default.toml";

/// The command line's values for scene-file keys (each `None` leaves the file's), the flags
/// of `render` ([`crate::render::RenderArgs`] flattens them in).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct Overrides {
    /// Shadow method; overrides `[shadows].method`.
    #[arg(long, value_parser = crate::methods::value_parser())]
    pub shadows: Option<String>,
    /// Light samples per shading point; overrides `[shadows].samples` (each method's own
    /// limit: 65536 for `traced`).
    #[arg(long, allow_negative_numbers = true,
          value_parser = crate::flags::key_value(1..=renderer::methods::sample_stream::MAX_TRACED_SAMPLES))]
    pub samples: Option<u32>,
    /// Image width in pixels, 1..=16384; overrides `[image].width`.
    #[arg(long, allow_negative_numbers = true, value_parser = crate::flags::key_value(renderer::load::scene_file::IMAGE_SIDE))]
    pub width: Option<u32>,
    /// Image height in pixels, 1..=16384; overrides `[image].height`.
    #[arg(long, allow_negative_numbers = true, value_parser = crate::flags::key_value(renderer::load::scene_file::IMAGE_SIDE))]
    pub height: Option<u32>,
    /// Primary samples per pixel, 1..=4096 (1 = the pixel centre); overrides `[image].spp`.
    #[arg(long, allow_negative_numbers = true, value_parser = crate::flags::key_value(renderer::load::scene_file::SPP))]
    pub spp: Option<u32>,
    /// Longest light path, counted as Mitsuba 3 counts it, 2..=64: 2 = direct light only, 5 =
    /// three indirect bounces; overrides `[integrator].max_depth` (default: the scene file's,
    /// else 5; every scene shipped here sets 2).
    #[arg(long, allow_negative_numbers = true, value_parser = crate::flags::depth_value)]
    pub max_depth: Option<u32>,
    /// How materials are shaded: `gltf` (as the files define them: normal textures bend the
    /// shading normal) or `diffuse` (every surface a two-sided Lambertian of its base colour
    /// with its interpolated normal, the renders of before materials were read); overrides
    /// `[materials].shading` (default `gltf`).
    #[arg(long, value_name = "gltf|diffuse")]
    pub shading: Option<String>,
    /// Code only (no flag): these settings in place of the chosen method's, for studies that
    /// switch what a scene file cannot (a plugin's code-only fields).
    #[arg(skip)]
    pub method: Option<Arc<dyn ShadowMethod>>,
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
            self.shading.as_ref().map(|s| Override {
                key: "materials.shading",
                source: "--shading",
                value: toml::Value::String(s.clone()),
            }),
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
    /// The flags' values, for errors about the request as a whole.
    overrides: Vec<Override>,
}

impl Request {
    /// The scene file at `scene` (else the embedded default scene) with `overrides` merged
    /// in, typed and checked.
    pub fn read(scene: Option<&Path>, overrides: &Overrides) -> Result<Self, SceneError> {
        let (scene_path, text, embedded) = match scene {
            Some(p) => (p.to_path_buf(), SceneFile::read(p)?, None),
            None => (PathBuf::from(DEFAULT_SCENE_NAME), DEFAULT_SCENE.to_string(), Some(DEFAULT_SCENE)),
        };
        let as_written = SceneFile::parse(&text, &scene_path)?;
        let shadows = ShadowsConfig::from_table(&as_written.shadows, &scene_path)?;
        let list = overrides.list();
        if list.is_empty() && overrides.method.is_none() {
            return Ok(Self { scene_path, embedded, file: as_written, shadows, overrides: list });
        }
        let relabel = |e| Override::relabel(&list, e);
        // A study's method alone changes no key: the file as written stands.
        let file =
            if list.is_empty() { as_written } else { SceneFile::parse_with(&text, &scene_path, &list)? };
        let method = overrides.method.clone();
        let shadows =
            ShadowsConfig::from_table_in(&file.shadows, &scene_path, crate::methods::METHODS, method)
                .map_err(relabel)?;
        Ok(Self { scene_path, embedded, file, shadows, overrides: list })
    }

    /// Refuses a frame whose primary samples (width x height x spp) would not fit: every one
    /// is kept for the shadow methods' `prepare`. A render's check, not the scene file's (the
    /// bench renders a file at its own size).
    pub fn check_frame_size(&self) -> Result<(), SceneError> {
        let im = &self.file.image;
        if im.width as u64 * im.height as u64 * im.spp as u64 > MAX_PRIMARY_SAMPLES {
            let message =
                format!("width x height x spp must be at most {MAX_PRIMARY_SAMPLES} (about 6 GB of samples)");
            return Err(Override::relabel(
                &self.overrides,
                SceneError::new(&self.scene_path, "image.spp", message),
            ));
        }
        Ok(())
    }
}
