//! The models' emissive rectangles made lights, for a scene file without `[[light]]`: each
//! emissive primitive fitted with a rectangle and placed in render space. One whose material
//! has an emissiveTexture stays a surface that emits: its radiance varies over it, and a
//! light has one radiance, the one every shadow method weighs its V by (weighing V by the
//! texture would change every method). The scene says so in one warning per texture, and
//! when no light is left, the error says why and what to do.

use crate::geometry::light::RectLight;
use crate::geometry::material::Shading;
use crate::load::gltf_load::{EmitterCandidate, Geometry};
use crate::load::scene_file::{LightDesc, validate_light};
use crate::load::scene_load::light_in_render_space;
use crate::util::error::SceneError;
use glam::DVec3;
use std::path::Path;

/// Why an emissive rectangle with an emissiveTexture is not a light, in its warning and in
/// the error of a scene it would be the only light of.
const VARIES: &str =
    "an emissive rectangle with an emissiveTexture is not an area light (its radiance varies over it)";

/// The emissive rectangles of `geometry` as lights in render space (world minus
/// `world_offset`; double-sided ones facing `scene_centre`, world space; `scene_extent` the
/// geometry's diagonal). One f32 cannot hold is skipped with a line in `warnings`, and so is
/// one with an emissive texture (one line per texture). No light at all is an error under
/// the key `light` of `scene_path`.
pub(super) fn emitter_lights(
    geometry: &Geometry,
    (scene_centre, scene_extent): (DVec3, f64),
    world_offset: DVec3,
    scene_path: &Path,
    warnings: &mut Vec<String>,
) -> Result<Vec<RectLight>, SceneError> {
    let mut found = Vec::new();
    // Each emissive texture once: one material may cover many rectangles.
    let mut textured: Vec<&str> = Vec::new();
    for e in &geometry.emitters {
        let Some(desc) = rectangle_light(e, scene_centre) else { continue };
        if validate_light(&desc, "emitter", scene_path).is_err() {
            continue;
        }
        if let Some(key) = &e.emissive_texture {
            if !textured.contains(&key.as_str()) {
                textured.push(key);
            }
            continue;
        }
        match light_in_render_space(&desc, world_offset, scene_extent) {
            Ok(light) => found.push(light),
            Err(e) => warnings.push(format!("an emissive rectangle is not a light: {}", e.message)),
        }
    }
    if found.is_empty() {
        return Err(SceneError::new(scene_path, "light", no_light(&textured)));
    }
    // What the user will see of it: glTF shading shows emission, diffuse shading none.
    let seen = match geometry.shading {
        Shading::Gltf => "the camera and bounces see its emission, no shadow method samples it",
        Shading::Diffuse => {
            "diffuse shading shows no emission (`--shading gltf` shows it to the camera and bounces)"
        }
    };
    warnings.extend(textured.iter().map(|key| format!("{key}: {VARIES}: {seen}")));
    Ok(found)
}

/// Why a scene file without `[[light]]` has no light, `textured` naming the emissive
/// textures of the rectangles that are not lights for theirs.
fn no_light(textured: &[&str]) -> String {
    match textured {
        [] => "no [[light]] given and the models have no emissive rectangles".into(),
        [first, rest @ ..] => {
            let more = if rest.is_empty() { String::new() } else { format!(" and {} more", rest.len()) };
            format!(
                "no [[light]] given, and the models' emissive rectangles all have an emissiveTexture \
                 ({first}{more}): {VARIES}, and a scene needs a light: give a [[light]]"
            )
        }
    }
}

/// Fits a rectangle to an emissive primitive: the smallest-area rectangle aligned with one
/// of its triangle edges that contains every vertex, accepted when the triangles are
/// coplanar and their total area equals the rectangle's (to 0.1%).
fn rectangle_light(e: &EmitterCandidate, scene_centre: DVec3) -> Option<LightDesc> {
    let mut normal = DVec3::ZERO;
    let mut area = 0.0;
    for t in &e.triangles {
        let c = (t[1] - t[0]).cross(t[2] - t[0]);
        normal += c;
        area += 0.5 * c.length();
    }
    let normal = normal.try_normalize()?;
    let origin = e.triangles[0][0];
    let scale = e.triangles.iter().flatten().map(|p| (*p - origin).length()).fold(0.0, f64::max);
    if e.triangles.iter().flatten().any(|p| (*p - origin).dot(normal).abs() > 1e-4 * scale) {
        return None; // not planar
    }
    let mut best: Option<(f64, DVec3, DVec3, DVec3)> = None;
    for t in e.triangles.iter().take(16) {
        for k in 0..3 {
            let Some(a) = (t[(k + 1) % 3] - t[k]).reject_from(normal).try_normalize() else { continue };
            let b = normal.cross(a);
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in e.triangles.iter().flatten() {
                let d = *p - origin;
                let (x, y) = (d.dot(a), d.dot(b));
                lo = [lo[0].min(x), lo[1].min(y)];
                hi = [hi[0].max(x), hi[1].max(y)];
            }
            let rect_area = (hi[0] - lo[0]) * (hi[1] - lo[1]);
            if best.is_none_or(|(best_area, ..)| rect_area < best_area) {
                let centre = origin + a * 0.5 * (lo[0] + hi[0]) + b * 0.5 * (lo[1] + hi[1]);
                best = Some((rect_area, centre, a * (hi[0] - lo[0]), b * (hi[1] - lo[1])));
            }
        }
    }
    let (rect_area, center, mut u, v) = best?;
    if rect_area.is_nan() || rect_area <= 0.0 || (rect_area - area).abs() > 1e-3 * rect_area {
        return None;
    }
    // Emit toward the front face; a double-sided emitter faces the scene's centre.
    let mut facing = normal;
    if e.double_sided && (scene_centre - center).dot(facing) < 0.0 {
        facing = -facing;
    }
    if u.cross(v).dot(facing) < 0.0 {
        u = -u;
    }
    Some(LightDesc {
        center: center.to_array(),
        u: u.to_array(),
        v: v.to_array(),
        radiance: e.radiance.to_array(),
    })
}
