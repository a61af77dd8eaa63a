//! Three things a user tries with glTF materials, each through `penumbra render` on a scene
//! file and a small glTF written here, checked by what the user sees (the image, the
//! warnings on stderr and in the run report, the exit status):
//!
//! 1. an emissive rectangle with an emissiveTexture: not a light (one warning says why), an
//!    error saying why and what to do when it is the only emitter, its emission seen by the
//!    camera and gathered by bounces;
//! 2. a pane of KHR_materials_transmission 1: opaque, its full shadow cast, the extension
//!    named once as not honoured;
//! 3. KHR_texture_transform's README example: the whole quad shows the texture's lower-left
//!    quadrant.
//!
//! Every expected number is computed here in f64 from what the files hold (bytes, factors,
//! corners), never by the renderer's code.

use crate::common;
use crate::common::folders;

use common::gltf_writer::{GltfBuilder, TRIANGLES, TempDir, primitive, write_png_rgba};
use common::material_quad::{Quad, scene_toml, write_quad};
use folders::penumbra;
use glam::{DVec3, Vec3};
use renderer::RectLight;
use serde_json::{Value, json};
use std::f64::consts::PI;
use std::path::Path;
use std::process::Output;

/// The sRGB transfer function's inverse, in f64, for an 8-bit code.
fn srgb(code: u8) -> f64 {
    let c = code as f64 / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

fn srgb3(codes: [u8; 3]) -> DVec3 {
    DVec3::new(srgb(codes[0]), srgb(codes[1]), srgb(codes[2]))
}

/// A rectangle with corners `c` (in order around it) and coordinates `uv`, facing `front`
/// (its triangles wound counter-clockwise seen from there), as a mesh of `material`.
fn rectangle(
    b: &mut GltfBuilder,
    c: [[f32; 3]; 4],
    uv: [[f32; 2]; 4],
    front: DVec3,
    material: usize,
) -> usize {
    let p = c.map(|p| DVec3::from(p.map(f64::from)));
    let winding = (p[1] - p[0]).cross(p[2] - p[0]);
    let ind: [u16; 6] = if winding.dot(front) > 0.0 { [0, 1, 2, 0, 2, 3] } else { [0, 2, 1, 0, 3, 2] };
    let n = front.normalize().as_vec3().to_array();
    let attributes =
        [("POSITION", b.positions(&c)), ("NORMAL", b.normals(&[n; 4])), ("TEXCOORD_0", b.texcoords(&uv))];
    let ind = b.indices_u16(&ind);
    b.mesh(vec![primitive(&attributes, Some(ind), TRIANGLES, Some(material))])
}

/// Places `meshes` (one node each) as the file's scene and writes `<stem>.gltf` into `dir`.
fn write_scene(mut b: GltfBuilder, meshes: &[usize], dir: &TempDir, stem: &str) {
    let nodes: Vec<usize> = meshes.iter().map(|&m| b.node(json!({"mesh": m}))).collect();
    let s = b.scene(&nodes);
    b.set_default_scene(s);
    b.write(&dir.path, stem);
}

/// The floor: 4 x 4 m at y = 0, facing +y.
fn floor(b: &mut GltfBuilder, material: usize) -> usize {
    let c = [[-2.0, 0.0, 2.0], [2.0, 0.0, 2.0], [2.0, 0.0, -2.0], [-2.0, 0.0, -2.0]];
    rectangle(b, c, [[0.0; 2]; 4], DVec3::Y, material)
}

/// `penumbra render SCENE --out out.png ARGS` in `dir`, which must succeed.
fn render(dir: &Path, scene: &str, args: &[&str]) -> Output {
    let mut all = vec!["render", scene, "--quiet", "--out", "out.png"];
    all.extend_from_slice(args);
    let o = penumbra(&all, dir);
    assert!(o.status.success(), "{all:?}: {}", String::from_utf8_lossy(&o.stderr));
    o
}

/// The lines of stderr that are warnings containing `needle`, and the run report's.
fn warnings_naming(dir: &Path, o: &Output, needle: &str) -> (Vec<String>, Vec<String>) {
    let stderr: Vec<String> = String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| l.starts_with("warning: ") && l.contains(needle))
        .map(String::from)
        .collect();
    let report: Value = serde_json::from_slice(&std::fs::read(dir.join("out.json")).unwrap()).unwrap();
    let listed = report["warnings"]
        .as_array()
        .expect("the report's warnings")
        .iter()
        .filter_map(|w| w.as_str())
        .filter(|w| w.contains(needle))
        .map(String::from)
        .collect();
    (stderr, listed)
}

fn read_exr(path: &Path) -> image::Rgb32FImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).into_rgb32f()
}

fn pixel(img: &image::Rgb32FImage, x: u32, y: u32) -> DVec3 {
    Vec3::from(img.get_pixel(x, y).0).as_dvec3()
}

// -------------------------------------------------------------------------------------------
// 1. An emissive rectangle with an emissiveTexture
// -------------------------------------------------------------------------------------------

/// The glowing rectangle's texture: its top half and its bottom half (sRGB codes), its
/// emissiveFactor and KHR_materials_emissive_strength.
const GLOW_TOP: [u8; 3] = [255, 128, 64];
const GLOW_BOTTOM: [u8; 3] = [64, 200, 255];
const GLOW_FACTOR: [f64; 3] = [1.0, 0.5, 0.25];
const GLOW_STRENGTH: f64 = 4.0;
/// The floor's base colour (grey), metallic 0, roughness 1.
const FLOOR_RHO: f64 = 0.5;
/// The glowing rectangle: x = 0.75, y in [0.25, 1.25], z in [-0.5, 0.5], facing -x (toward
/// the floor's middle); its texture's top row at the top (y > 0.75).
const GLOW_X: f64 = 0.75;
const GLOW_Y: [f64; 2] = [0.25, 1.25];
const GLOW_HALF_Z: f64 = 0.5;

/// The emission of the glow's half with texel `codes`: factor x strength x the texel.
fn glow_emission(codes: [u8; 3]) -> DVec3 {
    DVec3::from(GLOW_FACTOR) * GLOW_STRENGTH * srgb3(codes)
}

/// Writes `<stem>.gltf`: the floor, the glowing rectangle (material 1, its emissiveTexture a
/// 1 x 2 PNG of [`GLOW_TOP`] over [`GLOW_BOTTOM`], sampled NEAREST) and, with `lamp`, an
/// untextured emissive rectangle 1 m under the floor facing down, the scene's light: it
/// lights nothing anyone sees.
fn write_glow(dir: &TempDir, stem: &str, lamp: bool) {
    write_png_rgba(&dir.join("glow.png"), 1, 2, |_, y| {
        let c = if y == 0 { GLOW_TOP } else { GLOW_BOTTOM };
        [c[0], c[1], c[2], 255]
    });
    let mut b = GltfBuilder::new();
    b.use_extension("KHR_materials_emissive_strength");
    b.texture_png_sampled("glow.png", json!({"magFilter": 9728, "minFilter": 9728}));
    let grey = b.material(json!({"pbrMetallicRoughness": {
        "baseColorFactor": [FLOOR_RHO, FLOOR_RHO, FLOOR_RHO, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let glow = b.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0},
        "emissiveFactor": GLOW_FACTOR,
        "emissiveTexture": {"index": 0},
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": GLOW_STRENGTH}},
    }));
    let mut meshes = vec![floor(&mut b, grey)];
    // Corners top-left, top-right, bottom-right, bottom-left seen from -x (where +z is to the
    // right): u along +z, v down.
    let (x, [lo, hi], z) = (GLOW_X as f32, GLOW_Y.map(|y| y as f32), GLOW_HALF_Z as f32);
    let c = [[x, hi, -z], [x, hi, z], [x, lo, z], [x, lo, -z]];
    meshes.push(rectangle(&mut b, c, [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], DVec3::NEG_X, glow));
    if lamp {
        let white = b.material(json!({"emissiveFactor": [1.0, 1.0, 1.0]}));
        let c = [[-0.5, -1.0, -0.5], [0.5, -1.0, -0.5], [0.5, -1.0, 0.5], [-0.5, -1.0, 0.5]];
        meshes.push(rectangle(&mut b, c, [[0.0; 2]; 4], DVec3::NEG_Y, white));
    }
    write_scene(b, &meshes, dir, stem);
}

/// A scene file of model `<stem>.gltf` without `[[light]]`, seen from `position` toward
/// `look_at` (up `up`, a vertical field of `yfov` degrees).
fn glow_toml(stem: &str, position: [f64; 3], look_at: [f64; 3], up: [f64; 3], yfov: f64) -> String {
    format!(
        "[[model]]\npath = \"{stem}.gltf\"\n[camera]\nposition = {position:?}\nlook_at = {look_at:?}\n\
         up = {up:?}\nyfov_deg = {yfov:?}\n"
    )
}

const GLOW_WARNING: &str = "glow.gltf: materials[1].emissiveTexture: an emissive rectangle with an \
     emissiveTexture is not an area light (its radiance varies over it): the camera and bounces see \
     its emission, no shadow method samples it";

/// Not a light: one warning line names the file and the texture and says why, on stderr and
/// in the report (under diffuse shading, that it shows no emission); the only emitter of a
/// scene without `[[light]]`: one error line saying why and to give a `[[light]]`, exit 2,
/// nothing written.
#[test]
fn a_textured_emissive_rectangle_is_not_a_light_and_says_why() {
    let dir = TempDir::new("cases_glow_words");
    write_glow(&dir, "glow", true);
    let toml = glow_toml("glow", [-1.5, 0.75, 0.0], [GLOW_X, 0.75, 0.0], [0.0, 1.0, 0.0], 30.0);
    std::fs::write(dir.join("glow.toml"), toml).unwrap();
    let o = render(&dir.path, "glow.toml", &["--width", "8", "--height", "8"]);
    let (stderr, listed) = warnings_naming(&dir.path, &o, "emissiveTexture");
    eprintln!("{}", stderr.join("\n"));
    assert_eq!(stderr, [format!("warning: {GLOW_WARNING}")], "one line on stderr");
    assert_eq!(listed, [GLOW_WARNING], "one line in the report");

    let o = render(&dir.path, "glow.toml", &["--width", "8", "--height", "8", "--shading", "diffuse"]);
    let (stderr, _) = warnings_naming(&dir.path, &o, "emissiveTexture");
    assert_eq!(stderr.len(), 1, "{stderr:?}");
    assert!(
        stderr[0].contains("(its radiance varies over it): diffuse shading shows no emission"),
        "{stderr:?}"
    );

    write_glow(&dir, "alone", false);
    let toml = glow_toml("alone", [-1.5, 0.75, 0.0], [GLOW_X, 0.75, 0.0], [0.0, 1.0, 0.0], 30.0);
    std::fs::write(dir.join("alone.toml"), toml).unwrap();
    let o = penumbra(&["render", "alone.toml", "--out", "alone.png"], &dir.path);
    let stderr = String::from_utf8_lossy(&o.stderr);
    eprint!("{stderr}");
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    for words in [
        "alone.toml: light: no [[light]] given",
        "alone.gltf: materials[1].emissiveTexture",
        "an emissive rectangle with an emissiveTexture is not an area light (its radiance varies over it)",
        "give a [[light]]",
    ] {
        assert!(stderr.contains(words), "{stderr:?} does not say {words:?}");
    }
    assert!(!dir.join("alone.png").exists() && !dir.join("alone.exr").exists());
}

/// The camera sees each half of the glow as factor x strength x its texel, sRGB-decoded,
/// within 1e-3 relative (direct light only: nothing lights the glow, so its pixels hold its
/// emission alone).
#[test]
fn the_camera_sees_a_textured_emitters_emission() {
    let dir = TempDir::new("cases_glow_camera");
    write_glow(&dir, "glow", true);
    // 2.25 m in front of the glow, 30 degrees: the glow's halves fill rows 8 and 24 of 32
    // (0.30 m above and below the line between them).
    let toml = glow_toml("glow", [-1.5, 0.75, 0.0], [GLOW_X, 0.75, 0.0], [0.0, 1.0, 0.0], 30.0);
    std::fs::write(dir.join("glow.toml"), toml).unwrap();
    render(&dir.path, "glow.toml", &["--width", "32", "--height", "32", "--spp", "4", "--max-depth", "2"]);
    let img = read_exr(&dir.join("out.exr"));
    for (row, codes) in [(8, GLOW_TOP), (24, GLOW_BOTTOM)] {
        let want = glow_emission(codes);
        for x in 12..20 {
            let got = pixel(&img, x, row);
            let err = ((got - want) / want).abs().max_element();
            assert!(err < 1e-3, "pixel ({x}, {row}): {got} against {want} (relative {err:.2e})");
        }
    }
}

/// Writes `<stem>.gltf`: the grey floor and a 0.6 m square lamp 1.5 m above it facing down,
/// an untextured emissive material named "lamp" (radiance `lamp` x 50).
fn write_lamp(dir: &TempDir, stem: &str, lamp: f64) {
    let mut b = GltfBuilder::new();
    b.use_extension("KHR_materials_emissive_strength");
    let grey = b.material(json!({"pbrMetallicRoughness": {
        "baseColorFactor": [FLOOR_RHO, FLOOR_RHO, FLOOR_RHO, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let glow = b.material(json!({"name": "lamp", "emissiveFactor": [lamp, lamp, lamp],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 50.0}}}));
    let c = [[-0.3, 1.5, -0.3], [0.3, 1.5, -0.3], [0.3, 1.5, 0.3], [-0.3, 1.5, 0.3]];
    let meshes = [floor(&mut b, grey), rectangle(&mut b, c, [[0.0; 2]; 4], DVec3::NEG_Y, glow)];
    write_scene(b, &meshes, dir, stem);
}

/// The lamp scene with a `[[light]]` of its size at height `y`, seen from where the lamp is
/// out of the frame.
fn lamp_toml(stem: &str, y: f64) -> String {
    format!(
        "[[model]]\npath = \"{stem}.gltf\"\n[camera]\nposition = [0.0, 1.0, 2.5]\nlook_at = [0.0, 0.0, 0.0]\n\
         yfov_deg = 30.0\n[integrator]\nmax_depth = 2\n[[light]]\ncenter = [0.0, {y:?}, 0.0]\n\
         u = [0.6, 0.0, 0.0]\nv = [0.0, 0.0, 0.6]\nradiance = [50.0, 50.0, 50.0]\n"
    )
}

/// A scene file's `[[light]]` lights the scene alone: a model's emissive surface off it is no
/// light (no method samples it; bounce rays find it by chance), which one warning says,
/// naming the material. Laid over the lamp, the light counts the lamp's hits as its own: no
/// warning, and the very bytes of the scene whose lamp does not emit (the lamp once, not
/// twice). Diffuse shading shows no emission: no warning.
#[test]
fn an_emitter_off_the_scene_files_lights_is_named_and_one_under_a_light_counts_once() {
    let dir = TempDir::new("cases_lamp");
    write_lamp(&dir, "lamp", 1.0);
    write_lamp(&dir, "dark", 0.0);
    let args = ["--width", "32", "--height", "24", "--shadows", "traced", "--samples", "64"];
    let words =
        "lamp.gltf: materials[1] (\"lamp\") emits but is not a light, since the scene file gives [[light]]";

    std::fs::write(dir.join("below.toml"), lamp_toml("lamp", 1.4)).unwrap();
    let o = render(&dir.path, "below.toml", &args);
    let (stderr, listed) = warnings_naming(&dir.path, &o, "materials[1]");
    eprintln!("{}", stderr.join("\n"));
    assert_eq!(stderr.len(), 1, "one line: {stderr:?}");
    assert!(stderr[0].starts_with(&format!("warning: {words}")), "{stderr:?}");
    assert!(stderr[0].contains("drop [[light]]") && listed.len() == 1, "{stderr:?} {listed:?}");
    let o = render(&dir.path, "below.toml", &[&args[..], &["--shading", "diffuse"]].concat());
    assert_eq!(warnings_naming(&dir.path, &o, "materials[1]").0, Vec::<String>::new());

    std::fs::write(dir.join("over.toml"), lamp_toml("lamp", 1.5)).unwrap();
    std::fs::write(dir.join("dark.toml"), lamp_toml("dark", 1.5)).unwrap();
    let o = render(&dir.path, "over.toml", &args);
    assert!(
        !String::from_utf8_lossy(&o.stderr).contains("warning"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let over = std::fs::read(dir.join("out.exr")).unwrap();
    render(&dir.path, "dark.toml", &args);
    assert!(
        over == std::fs::read(dir.join("out.exr")).unwrap(),
        "the lamp under its light was counted twice"
    );
}

/// Appendix B's BRDF of the floor (a dielectric of base colour `rho`, roughness 1) times
/// cos(wi), with the height-correlated Smith visibility, in f64: the truth the bounce is held
/// to. `n` is the floor's normal (+y).
fn floor_brdf_cos(rho: f64, wo: DVec3, wi: DVec3) -> f64 {
    let (cos_o, cos_i) = (wo.y, wi.y);
    if cos_o <= 0.0 || cos_i <= 0.0 {
        return 0.0;
    }
    let alpha2: f64 = 1.0; // (roughness^2)^2 at roughness 1
    let h = (wo + wi).normalize();
    let d = alpha2 / (PI * (h.y * h.y * (alpha2 - 1.0) + 1.0).powi(2));
    let vis = 0.5
        / (cos_i * (cos_o * cos_o * (1.0 - alpha2) + alpha2).sqrt()
            + cos_o * (cos_i * cos_i * (1.0 - alpha2) + alpha2).sqrt());
    let f = 0.04 + 0.96 * (1.0 - wo.dot(h).abs()).powi(5);
    ((1.0 - f) * rho / PI + f * d * vis) * cos_i
}

/// The floor's radiance at `p` toward `eye` from the glow alone: the integral over the glow
/// of f cos_p cos_q / r^2 L(q) dA (the midpoint rule on n x n cells per half), and the
/// cosine part alone per half (for the check against Lambert's formula).
fn floor_radiance(p: DVec3, eye: DVec3, n: usize) -> (DVec3, [f64; 2]) {
    let wo = (eye - p).normalize();
    let mid = 0.5 * (GLOW_Y[0] + GLOW_Y[1]);
    let mut sum = DVec3::ZERO;
    let mut cosine = [0.0; 2];
    for (k, (y0, codes)) in [(mid, GLOW_TOP), (GLOW_Y[0], GLOW_BOTTOM)].into_iter().enumerate() {
        let (dy, dz) = ((mid - GLOW_Y[0]) / n as f64, 2.0 * GLOW_HALF_Z / n as f64);
        let mut radiance_sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let q = DVec3::new(GLOW_X, y0 + (i as f64 + 0.5) * dy, -GLOW_HALF_Z + (j as f64 + 0.5) * dz);
                let d = q - p;
                let (r2, wi) = (d.length_squared(), d.normalize());
                let cos_q = wi.dot(DVec3::X); // the glow faces -x: toward p is +x from q's view
                let g = cos_q / r2 * dy * dz;
                radiance_sum += floor_brdf_cos(FLOOR_RHO, wo, wi) * g;
                cosine[k] += wi.y * g;
            }
        }
        sum += glow_emission(codes) * radiance_sum;
    }
    (sum, cosine)
}

/// Bounces gather the glow: a floor lit by nothing but it (the scene's light faces away)
/// shows, at max_depth 3, the glow's light reflected by the floor's BRDF. The truth: that
/// integral by quadrature over both halves of the glow, averaged over the floor patch the
/// camera sees (straight down, so the pixels' samples cover it evenly); its cosine part
/// agrees with `RectLight::irradiance_factor` (Lambert's polygon formula) within 1e-4 (the
/// midpoint rule's error: 2e-5 measured on the half nearer the floor). The
/// image's mean is held to it within 4 standard errors of the mean (the standard error from
/// the pixels' spread, which the truth's own variation over the patch only widens).
#[test]
fn bounces_gather_a_textured_emitters_light() {
    let dir = TempDir::new("cases_glow_bounce");
    write_glow(&dir, "glow", true);
    let (height, yfov_deg, side) = (3.0, 4.0, 32u32);
    let toml = glow_toml("glow", [0.0, height, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, -1.0], yfov_deg);
    std::fs::write(dir.join("floor.toml"), toml).unwrap();
    let o = render(
        &dir.path,
        "floor.toml",
        &["--width", "32", "--height", "32", "--spp", "1024", "--max-depth", "3", "--seed", "7"],
    );
    assert_eq!(warnings_naming(&dir.path, &o, "emissiveTexture").0.len(), 1);
    let img = read_exr(&dir.join("out.exr"));
    let pixels: Vec<DVec3> = img.pixels().map(|p| Vec3::from(p.0).as_dvec3()).collect();
    let count = pixels.len() as f64;
    let mean = pixels.iter().sum::<DVec3>() / count;
    let spread = pixels.iter().map(|p| (*p - mean) * (*p - mean)).sum::<DVec3>() / (count - 1.0);
    let standard_error = (spread / count).map(f64::sqrt);

    // The patch seen: the square of half-side height x tan(yfov / 2) about the origin.
    let eye = DVec3::new(0.0, height, 0.0);
    let half = height * (yfov_deg.to_radians() / 2.0).tan();
    let grid = 16;
    let mut truth = DVec3::ZERO;
    for a in 0..grid {
        for b in 0..grid {
            let at = |k: usize| -half + (k as f64 + 0.5) * 2.0 * half / grid as f64;
            truth += floor_radiance(DVec3::new(at(a), 0.0, at(b)), eye, 100).0;
        }
    }
    truth /= (grid * grid) as f64;
    // The quadrature's cosine part against Lambert's formula, per half, at the patch's centre.
    let (_, cosine) = floor_radiance(DVec3::ZERO, eye, 100);
    let mid = 0.5 * (GLOW_Y[0] + GLOW_Y[1]);
    for (k, centre_y) in [0.5 * (mid + GLOW_Y[1]), 0.5 * (GLOW_Y[0] + mid)].into_iter().enumerate() {
        let centre = Vec3::new(GLOW_X as f32, centre_y as f32, 0.0);
        // u x v along -x: the half emits toward the floor's middle.
        let u = Vec3::new(0.0, 0.0, 2.0 * GLOW_HALF_Z as f32);
        let v = Vec3::new(0.0, (mid - GLOW_Y[0]) as f32, 0.0);
        let lambert = RectLight::new(centre, u, v, Vec3::ONE).irradiance_factor_f64(Vec3::ZERO, Vec3::Y);
        assert!((cosine[k] - lambert).abs() < 1e-4 * lambert, "half {k}: {} against {lambert}", cosine[k]);
    }
    eprintln!(
        "floor under the glow: {mean:.5} against {truth:.5} (standard error {standard_error:.5}, {side}x{side} px)"
    );
    for c in 0..3 {
        assert!(truth[c] > 0.0 && mean[c] > 0.0);
        assert!(standard_error[c] < 0.01 * truth[c], "too noisy to tell: {standard_error}");
        assert!((mean[c] - truth[c]).abs() < 4.0 * standard_error[c], "channel {c}: {mean} against {truth}");
    }
}

// -------------------------------------------------------------------------------------------
// 2. A pane of KHR_materials_transmission 1
// -------------------------------------------------------------------------------------------

/// A pane of transmissionFactor 1 renders opaque: the file's warning names
/// KHR_materials_transmission as not honoured, once on stderr and once in the report, and the
/// floor under the pane gets V = 0 from `traced` (its umbra: |x|, |z| < 0.325 m), while the
/// floor beyond its shadow gets V = 1.
#[test]
fn a_transmissive_pane_is_opaque_and_announced() {
    let dir = TempDir::new("cases_pane");
    let mut b = GltfBuilder::new();
    b.use_extension("KHR_materials_transmission");
    let grey = b.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0]}}));
    let glass = b.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}},
    }));
    let floor = floor(&mut b, grey);
    // 0.6 x 0.6 m, 1 m up, under a 0.5 x 0.5 m light 3 m up.
    let c = [[-0.3, 1.0, 0.3], [0.3, 1.0, 0.3], [0.3, 1.0, -0.3], [-0.3, 1.0, -0.3]];
    let pane = rectangle(&mut b, c, [[0.0; 2]; 4], DVec3::Y, glass);
    write_scene(b, &[floor, pane], &dir, "pane");
    // The camera between the pane and the floor, looking straight down with 120 degrees:
    // the floor within 0.87 m of the middle.
    let toml = "[[model]]\npath = \"pane.gltf\"\n[camera]\nposition = [0.0, 0.5, 0.0]\n\
                look_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nyfov_deg = 120.0\n\
                [[light]]\ncenter = [0.0, 3.0, 0.0]\nu = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 0.5]\n\
                radiance = [1.0, 1.0, 1.0]\n";
    std::fs::write(dir.join("pane.toml"), toml).unwrap();
    let o =
        render(&dir.path, "pane.toml", &["--width", "32", "--height", "32", "--aov", "--shadows", "traced"]);
    let (stderr, listed) = warnings_naming(&dir.path, &o, "KHR_materials_transmission");
    eprintln!("{}", stderr.join("\n"));
    let line = "pane.gltf: material extensions not honoured (shaded as metallic-roughness): \
                KHR_materials_transmission";
    assert_eq!(stderr.len(), 1, "one line on stderr: {stderr:?}");
    assert!(stderr[0].starts_with("warning: ") && stderr[0].ends_with(line), "{stderr:?}");
    assert_eq!(listed.len(), 1, "one line in the report: {listed:?}");
    assert!(listed[0].ends_with(line), "{listed:?}");

    let v = read_exr(&dir.join("out.visibility.0.exr"));
    // The middle 4 x 4 pixels see the floor within 0.22 m of the middle: the umbra.
    for y in 14..18 {
        for x in 14..18 {
            assert_eq!(v.get_pixel(x, y).0[0], 0.0, "under the pane at pixel ({x}, {y})");
        }
    }
    // The corners see the floor 0.87 m out along both axes: every light point's ray passes
    // the pane's plane at least 0.49 m out, beyond its 0.3.
    for (x, y) in [(0, 0), (31, 0), (0, 31), (31, 31)] {
        assert_eq!(v.get_pixel(x, y).0[0], 1.0, "beyond the shadow at pixel ({x}, {y})");
    }
}

// -------------------------------------------------------------------------------------------
// 3. KHR_texture_transform's README example
// -------------------------------------------------------------------------------------------

/// The quadrants of a 2 x 2 base-colour texture (sRGB codes): top-left, top-right,
/// bottom-left, bottom-right, each of its own hue.
const QUADRANTS: [[u8; 3]; 4] = [[230, 40, 40], [40, 200, 40], [60, 90, 220], [220, 200, 40]];

/// A colour's chromaticity: each channel's share of the sum.
fn ratios(c: DVec3) -> DVec3 {
    c / c.element_sum()
}

/// The extension README's example (offset [0, 1], rotation pi/2, scale [0.5, 0.5]) shows the
/// texture's lower-left quadrant over the whole quad, as the Khronos sample viewer, three.js
/// and Blender show it. Rendered with `--shading diffuse`: each pixel is then the base
/// colour times the irradiance (white light) times V over pi, so its R:G:B is the texel's
/// linear colour's; glTF shading would add the dielectric's white specular and move them.
/// Every pixel inside the quad (its neighbours too) within 1e-3 of the lower-left texel's
/// chromaticity, and at least 0.1 from every other quadrant's.
#[test]
fn the_texture_transform_readme_example_shows_the_lower_left_quadrant() {
    let dir = TempDir::new("cases_transform");
    write_png_rgba(&dir.join("quadrants.png"), 2, 2, |x, y| {
        let c = QUADRANTS[(2 * y + x) as usize];
        [c[0], c[1], c[2], 255]
    });
    let transform =
        json!({"offset": [0.0, 1.0], "rotation": std::f64::consts::FRAC_PI_2, "scale": [0.5, 0.5]});
    let q = Quad {
        material: json!({"pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": transform}}}}),
        extensions_used: vec!["KHR_texture_transform"],
        ..Quad::default()
    };
    write_quad(&dir, "q", &q, &["quadrants.png"]);
    std::fs::write(dir.join("q.toml"), scene_toml("q", "gltf")).unwrap();
    render(
        &dir.path,
        "q.toml",
        &["--shading", "diffuse", "--width", "48", "--height", "48", "--max-depth", "2"],
    );
    let img = read_exr(&dir.join("out.exr"));
    let lit = |x: u32, y: u32| pixel(&img, x, y).min_element() > 0.0;
    let want = ratios(srgb3(QUADRANTS[2]));
    let mut inside = 0;
    for y in 1..img.height() - 1 {
        for x in 1..img.width() - 1 {
            if !(y - 1..=y + 1).all(|j| (x - 1..=x + 1).all(|i| lit(i, j))) {
                continue;
            }
            inside += 1;
            let got = ratios(pixel(&img, x, y));
            assert!((got - want).abs().max_element() < 1e-3, "pixel ({x}, {y}): {got} against {want}");
        }
    }
    assert!(inside > 150, "{inside} pixels inside the quad");
    for (k, other) in QUADRANTS.iter().enumerate().filter(|(k, _)| *k != 2) {
        let d = (ratios(srgb3(*other)) - want).abs().max_element();
        assert!(d > 0.1, "quadrant {k} is not told apart ({d})");
    }
}
