//! The scene file (TOML), typed. Every table rejects unknown keys; every error names the
//! file and the key. Values given outside the file (the command line's flags, [`Override`])
//! are merged into its table before it is typed, so that they are checked by the file's own
//! checks, with the same ranges in the same words. The `[shadows]` table is kept raw
//! here: only the CLI knows every shadow method, so it types that table itself (see
//! `penumbra::shadows_config`).

use crate::geometry::material::Shading;
use crate::util::error::SceneError;
use crate::util::keys::{deserialize_toml, deserialize_value};
use serde::Deserialize;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

/// A whole scene file, as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// glTF 2.0 files (.gltf or .glb), zero or more.
    #[serde(default)]
    pub model: Vec<ModelDesc>,
    /// Rectangles of geometry (floors, walls, cards), zero or more.
    #[serde(default)]
    pub quad: Vec<QuadDesc>,
    pub camera: CameraDesc,
    #[serde(default)]
    pub image: ImageDesc,
    /// Rectangular area lights. When empty, emissive rectangles in the models become lights.
    #[serde(default)]
    pub light: Vec<LightDesc>,
    /// How light is gathered: the path depth.
    #[serde(default)]
    pub integrator: IntegratorDesc,
    /// How the models' materials are shaded.
    #[serde(default)]
    pub materials: MaterialsDesc,
    /// The shadow method and its parameters, typed by the composition root (the CLI).
    #[serde(default)]
    pub shadows: toml::Table,
}

/// `[integrator]`: diffuse path tracing with next-event estimation at every vertex.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorDesc {
    /// Longest path, counted as Mitsuba 3 counts it: 2 = direct light only, 5 = three
    /// indirect bounces (the default, pbrt's depth).
    #[serde(default = "default_max_depth")]
    pub max_depth: u32,
}

fn default_max_depth() -> u32 {
    crate::integrator::path::DEFAULT_MAX_DEPTH
}

impl Default for IntegratorDesc {
    fn default() -> Self {
        Self { max_depth: default_max_depth() }
    }
}

/// `[materials]`: how the glTF materials are shaded. Serialize gives its keys at their
/// defaults, which the key reference is held to.
#[derive(Debug, Clone, Default, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialsDesc {
    /// `"gltf"` (the default): as the files define them (normal textures bend the shading
    /// normal); `"diffuse"`: every surface a two-sided Lambertian of its base colour with its
    /// interpolated normal, the renders of before materials were read.
    #[serde(default)]
    pub shading: Shading,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelDesc {
    /// Relative to the scene file.
    pub path: PathBuf,
    /// Applied after the file's own node transforms: p' = translate + rotate(scale * p).
    #[serde(default)]
    pub translate: [f64; 3],
    #[serde(default = "one")]
    pub scale: f64,
    #[serde(default)]
    pub rotate_y_deg: f64,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadDesc {
    pub center: [f64; 3],
    /// Full edge vectors: corners are center +- u/2 +- v/2.
    pub u: [f64; 3],
    pub v: [f64; 3],
    /// Linear albedo, each channel in [0, 1].
    #[serde(default = "default_quad_color")]
    pub color: [f32; 3],
}

fn default_quad_color() -> [f32; 3] {
    [0.8, 0.8, 0.8]
}

/// Either an explicit look-at camera or `from_gltf = true`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Use the first camera of the first model (its node transform and yfov).
    #[serde(default)]
    pub from_gltf: bool,
    pub position: Option<[f64; 3]>,
    pub look_at: Option<[f64; 3]>,
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// Full vertical field of view in degrees.
    #[serde(default = "default_yfov")]
    pub yfov_deg: f64,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_yfov() -> f64 {
    40.0
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageDesc {
    #[serde(default = "default_size")]
    pub width: u32,
    #[serde(default = "default_size")]
    pub height: u32,
    /// Primary samples per pixel: 1 = one ray through the pixel centre.
    #[serde(default = "default_spp")]
    pub spp: u32,
}

fn default_size() -> u32 {
    512
}
fn default_spp() -> u32 {
    1
}

impl Default for ImageDesc {
    fn default() -> Self {
        Self { width: default_size(), height: default_size(), spp: default_spp() }
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightDesc {
    pub center: [f64; 3],
    /// Full edge vectors, perpendicular to each other; n = normalize(cross(u, v)).
    pub u: [f64; 3],
    pub v: [f64; 3],
    /// Emitted radiance, only toward n.
    pub radiance: [f32; 3],
}

/// Largest image side accepted; beyond it a typo (an extra zero) would allocate gigabytes.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Largest supersampling rate accepted.
pub const MAX_SPP: u32 = 4096;

/// The image's sides and primary samples per pixel: each range is checked by these words
/// ([`range_message`]) for the scene file's key and the command line's flag alike.
pub const IMAGE_SIDE: RangeInclusive<u32> = 1..=MAX_IMAGE_SIDE;
pub const SPP: RangeInclusive<u32> = 1..=MAX_SPP;

/// Most primary samples a frame keeps (width x height x spp): every one is kept for the
/// shadow methods' `prepare`, about 100 bytes each.
pub const MAX_PRIMARY_SAMPLES: u64 = 1 << 26;

/// A value for one of the scene file's keys given elsewhere (a flag), in its place.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// The key's path: `image.width`, `shadows.samples`.
    pub key: &'static str,
    /// What gave it, named by errors about it instead of the key: `--width`.
    pub source: &'static str,
    pub value: toml::Value,
}

impl Override {
    /// `e` naming the source of the override its key has, if any, instead of the key.
    pub fn relabel(overrides: &[Override], mut e: SceneError) -> SceneError {
        if let Some(o) = overrides.iter().find(|o| o.key == e.key) {
            e.key = o.source.to_string();
        }
        e
    }

    /// `table` with this value at its key (the tables on the way made if absent; a value on
    /// the way that is not a table is left for typing to refuse).
    fn apply(&self, table: &mut toml::Table) {
        let mut parts: Vec<&str> = self.key.split('.').collect();
        let last = parts.pop().expect("a key has a name");
        let mut t = table;
        for part in parts {
            let entry = t.entry(part).or_insert_with(|| toml::Value::Table(toml::Table::new()));
            let Some(inner) = entry.as_table_mut() else { return };
            t = inner;
        }
        t.insert(last.to_string(), self.value.clone());
    }
}

/// The error for a whole-number setting outside `range` (or not a whole number): the range,
/// and what was given.
pub fn range_message(range: &RangeInclusive<u32>, got: &dyn std::fmt::Display) -> String {
    format!("must be in {}..={}, got {got}", range.start(), range.end())
}

impl SceneFile {
    /// Reads and validates a scene file. Relative model paths stay relative; resolve them
    /// with [`SceneFile::resolve`].
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        Self::parse(&Self::read(path)?, path)
    }

    /// The text of the scene file at `path`.
    pub fn read(path: &Path) -> Result<String, SceneError> {
        std::fs::read_to_string(path)
            .map_err(|e| SceneError::new(path, "", format!("cannot read scene file: {e}")))
    }

    /// Parses scene text; `path` names the file in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        Self::parse_with(text, path, &[])
    }

    /// Parses scene text with `overrides` in place of the file's values, then checks the
    /// whole once. An error about an overridden key names its source (the flag).
    pub fn parse_with(text: &str, path: &Path, overrides: &[Override]) -> Result<Self, SceneError> {
        let scene: SceneFile = if overrides.is_empty() {
            deserialize_toml(text, path, "")?
        } else {
            let mut table: toml::Table = deserialize_toml(text, path, "")?;
            overrides.iter().for_each(|o| o.apply(&mut table));
            deserialize_value(toml::Value::Table(table), path, "")
                .map_err(|e| Override::relabel(overrides, e))?
        };
        scene.validate(path).map_err(|e| Override::relabel(overrides, e))?;
        Ok(scene)
    }

    /// The model path as the file system sees it (relative to the scene file's folder).
    pub fn resolve(scene_path: &Path, model_path: &Path) -> PathBuf {
        match scene_path.parent() {
            Some(dir) if model_path.is_relative() => dir.join(model_path),
            _ => model_path.to_path_buf(),
        }
    }

    fn validate(&self, path: &Path) -> Result<(), SceneError> {
        let err = |key: String, msg: &str| Err(SceneError::new(path, key, msg));
        for (i, m) in self.model.iter().enumerate() {
            if !finite3(m.translate) {
                return err(format!("model[{i}].translate"), "must be finite");
            }
            if !(m.scale.is_finite() && m.scale > 0.0) {
                return err(format!("model[{i}].scale"), "must be a finite number > 0");
            }
            if !m.rotate_y_deg.is_finite() {
                return err(format!("model[{i}].rotate_y_deg"), "must be finite");
            }
        }
        for (i, q) in self.quad.iter().enumerate() {
            for (k, v) in [("center", q.center), ("u", q.u), ("v", q.v)] {
                if !finite3(v) {
                    return err(format!("quad[{i}].{k}"), "must be finite");
                }
            }
            if spans_zero_area(q.u, q.v) {
                return err(format!("quad[{i}].u"), "u and v span zero area");
            }
            if !q.color.iter().all(|c| (0.0..=1.0).contains(c)) {
                return err(
                    format!("quad[{i}].color"),
                    &format!("an albedo: each channel must be in [0, 1], got {:?}", q.color),
                );
            }
        }
        let c = &self.camera;
        if c.from_gltf {
            if c.position.is_some() || c.look_at.is_some() {
                return err(
                    "camera.from_gltf".into(),
                    "give either from_gltf = true or position/look_at, not both",
                );
            }
            if self.model.is_empty() {
                return err("camera.from_gltf".into(), "needs at least one [[model]]");
            }
        } else {
            let (Some(pos), Some(at)) = (c.position, c.look_at) else {
                let key = if c.position.is_none() { "camera.position" } else { "camera.look_at" };
                return err(key.into(), "missing (or set camera.from_gltf = true)");
            };
            if !finite3(pos) {
                return err("camera.position".into(), "must be finite");
            }
            if !finite3(at) {
                return err("camera.look_at".into(), "must be finite");
            }
            let forward = sub(at, pos);
            if dot(forward, forward) <= 0.0 {
                return err("camera.look_at".into(), "equals camera.position");
            }
            if !finite3(c.up) || cross_len(forward, c.up) <= 1e-12 * len(forward) * len(c.up) {
                return err("camera.up".into(), "must be finite and not parallel to the view direction");
            }
        }
        if !(c.yfov_deg.is_finite() && c.yfov_deg > 0.0 && c.yfov_deg < 180.0) {
            return err("camera.yfov_deg".into(), "must be in (0, 180)");
        }
        let im = &self.image;
        for (k, v) in [("width", im.width), ("height", im.height)] {
            if !IMAGE_SIDE.contains(&v) {
                return err(format!("image.{k}"), &range_message(&IMAGE_SIDE, &v));
            }
        }
        if !SPP.contains(&im.spp) {
            return err("image.spp".into(), &range_message(&SPP, &im.spp));
        }
        let depth = self.integrator.max_depth;
        if !crate::integrator::path::DEPTH_RANGE.contains(&depth) {
            return err("integrator.max_depth".into(), &crate::integrator::path::depth_message(&depth));
        }
        for (i, l) in self.light.iter().enumerate() {
            validate_light(l, &format!("light[{i}]"), path)?;
        }
        Ok(())
    }
}

/// Checks a light rectangle: finite, non-zero area, perpendicular edges, radiance >= 0, each
/// edge a length f32 holds. (Whether f32 holds it at its distance from the camera is checked
/// when the scene is built: `scene_load::light_in_render_space`.)
pub fn validate_light(l: &LightDesc, key: &str, path: &Path) -> Result<(), SceneError> {
    let err = |k: &str, msg: &str| Err(SceneError::new(path, format!("{key}.{k}"), msg));
    for (k, v) in [("center", l.center), ("u", l.u), ("v", l.v)] {
        if !finite3(v) {
            return err(k, "must be finite");
        }
    }
    let (lu, lv) = (len(l.u), len(l.v));
    if lu == 0.0 {
        return err("u", "zero-length edge: the light has zero area");
    }
    if lv == 0.0 {
        return err("v", "zero-length edge: the light has zero area");
    }
    for (k, length) in [("u", lu), ("v", lv)] {
        if !(f32::MIN_POSITIVE as f64..=f32::MAX as f64).contains(&length) {
            return err(
                k,
                &format!(
                    "the edge is {length:.3e} m long, outside what f32 holds ({:.1e} to {:.1e} m): \
                     the light's area cannot be computed",
                    f32::MIN_POSITIVE,
                    f32::MAX
                ),
            );
        }
    }
    if spans_zero_area(l.u, l.v) {
        return err("v", "parallel to u: the light has zero area");
    }
    if dot(l.u, l.v).abs() > 1e-4 * lu * lv {
        return err("v", "must be perpendicular to u (a rectangle)");
    }
    if !l.radiance.iter().all(|c| c.is_finite() && *c >= 0.0) {
        return err("radiance", "must be finite and >= 0");
    }
    Ok(())
}

fn finite3(v: [f64; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn len(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
/// Whether edge vectors `u` and `v` span no area relative to their own lengths (so a 1e-20 m
/// quad spans some).
fn spans_zero_area(u: [f64; 3], v: [f64; 3]) -> bool {
    use glam::DVec3;
    crate::geometry::precision::is_degenerate([DVec3::ZERO, DVec3::from(u), DVec3::from(v)])
}
fn cross_len(a: [f64; 3], b: [f64; 3]) -> f64 {
    len([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[camera]
position = [0.0, 1.0, 3.0]
look_at = [0.0, 0.0, 0.0]

[[light]]
center = [0.0, 2.0, 0.0]
u = [0.5, 0.0, 0.0]
v = [0.0, 0.0, 0.5]
radiance = [1.0, 1.0, 1.0]
"#;

    fn parse(text: &str) -> Result<SceneFile, SceneError> {
        SceneFile::parse(text, Path::new("s.toml"))
    }

    #[test]
    fn minimal_scene_parses_with_defaults() {
        let s = parse(MINIMAL).unwrap();
        assert_eq!((s.image.width, s.image.height, s.image.spp), (512, 512, 1));
        assert_eq!(s.camera.yfov_deg, 40.0);
        assert!(s.shadows.is_empty());
    }

    #[test]
    fn unknown_key_is_named_with_its_table() {
        let e = parse(&MINIMAL.replace("look_at", "lookat")).unwrap_err();
        assert_eq!(e.key, "camera.lookat", "{e}");
        let e = parse(&format!("{MINIMAL}\n[image]\nwidht = 3\n")).unwrap_err();
        assert_eq!(e.key, "image.widht", "{e}");
        let e =
            parse(&format!("{MINIMAL}\n[[quad]]\ncenter=[0,0,0]\nu=[1,0,0]\nv=[0,0,1]\ncolour=[1,1,1]\n"))
                .unwrap_err();
        assert_eq!(e.key, "quad[0].colour", "{e}");
    }

    #[test]
    fn wrong_type_names_key_and_syntax_error_names_offset() {
        let e = parse(&format!("{MINIMAL}\n[image]\nwidth = \"big\"\n")).unwrap_err();
        assert_eq!(e.key, "image.width", "{e}");
        let e = parse("[camera\nposition = 1").unwrap_err();
        assert!(e.key.starts_with("byte "), "{e}");
        assert_eq!(e.to_string().lines().count(), 1);
    }

    #[test]
    fn zero_area_and_skewed_lights_are_rejected() {
        let e = parse(&MINIMAL.replace("u = [0.5, 0.0, 0.0]", "u = [0.0, 0.0, 0.0]")).unwrap_err();
        assert_eq!(e.key, "light[0].u");
        let e = parse(&MINIMAL.replace("u = [0.5, 0.0, 0.0]", "u = [0.5, 0.0, 0.1]")).unwrap_err();
        assert_eq!(e.key, "light[0].v");
        let e = parse(&MINIMAL.replace("u = [0.5, 0.0, 0.0]", "u = [0.5, nan, 0.0]")).unwrap_err();
        assert_eq!(e.key, "light[0].u");
    }

    #[test]
    fn materials_shading_is_typed_and_named() {
        assert_eq!(parse(MINIMAL).unwrap().materials.shading, Shading::Gltf);
        let s = parse(&format!("{MINIMAL}\n[materials]\nshading = \"diffuse\"\n")).unwrap();
        assert_eq!(s.materials.shading, Shading::Diffuse);
        let e = parse(&format!("{MINIMAL}\n[materials]\nshading = \"phong\"\n")).unwrap_err();
        assert_eq!(e.key, "materials.shading", "{e}");
        let e = parse(&format!("{MINIMAL}\n[materials]\nshadin = \"gltf\"\n")).unwrap_err();
        assert_eq!(e.key, "materials.shadin", "{e}");
    }

    #[test]
    fn camera_must_be_complete() {
        let e = parse(&MINIMAL.replace("look_at = [0.0, 0.0, 0.0]", "")).unwrap_err();
        assert_eq!(e.key, "camera.look_at");
        let e =
            parse(&MINIMAL.replace("look_at = [0.0, 0.0, 0.0]", "look_at = [0.0, 1.0, 3.0]")).unwrap_err();
        assert_eq!(e.key, "camera.look_at");
    }
}
