//! Materials at the command line: `[materials] shading` and `--shading`, bad material
//! values refused (one line naming the file and the glTF key, exit 2, nothing written), the
//! surface AOVs, and `diffuse` giving the renders without normal maps, byte for byte, on
//! every shared scene.

use crate::common;
use crate::common::folders;

use common::gltf_writer::TempDir;
use common::material_quad::{Quad, code, decoded, scene_toml, texel_png, write_quad};
use folders::penumbra;
use glam::Vec3;
use renderer::geometry::material::Material;
use renderer::{LightShadowing, RenderSettings, Scene, SceneFile, Shading, Traced, TracedParams, render};
use serde_json::json;
use std::path::Path;

/// Runs a render that must fail as bad input: exit 2, one line naming each of `names`,
/// nothing but the inputs left in `dir`.
fn assert_refused(dir: &Path, args: &[&str], names: &[&str]) {
    let o = penumbra(args, dir);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{args:?}: not one line: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    // Shown with --nocapture: the words a user reads.
    eprint!("{stderr}");
    for n in names {
        assert!(stderr.contains(n), "{args:?}: {stderr:?} does not name {n:?}");
    }
    let outputs: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png") && n.starts_with("out") || n.ends_with(".exr"))
        .collect();
    assert!(outputs.is_empty(), "{args:?} wrote {outputs:?}");
}

#[test]
fn bad_material_values_are_refused_naming_the_gltf_key() {
    let dir = TempDir::new("bad_materials");
    texel_png(&dir, "t.png", [128, 128, 255]);
    let emissive = |strength: f64| {
        json!({"emissiveFactor": [1.0, 1.0, 1.0],
               "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}})
    };
    let cases = [
        (
            json!({"pbrMetallicRoughness": {"metallicFactor": 1.5}}),
            "materials[0].pbrMetallicRoughness.metallicFactor",
        ),
        (
            json!({"pbrMetallicRoughness": {"roughnessFactor": -0.25}}),
            "materials[0].pbrMetallicRoughness.roughnessFactor",
        ),
        (json!({"emissiveFactor": [0.0, 2.0, 0.0]}), "materials[0].emissiveFactor"),
        (emissive(-1.0), "materials[0].extensions.KHR_materials_emissive_strength.emissiveStrength"),
        // A third texture-coordinate set in one material.
        (
            json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                            "metallicRoughnessTexture": {"index": 0, "texCoord": 1}},
                   "normalTexture": {"index": 0, "texCoord": 2}}),
            "materials[0].normalTexture.texCoord",
        ),
        (
            json!({"normalTexture": {"index": 0,
                   "extensions": {"KHR_texture_transform": {"offset": "left"}}}}),
            "materials[0].normalTexture.extensions.KHR_texture_transform",
        ),
    ];
    for (i, (material, key)) in cases.into_iter().enumerate() {
        let stem = format!("bad{i}");
        write_quad(&dir, &stem, &Quad { material, ..Quad::default() }, &["t.png"]);
        std::fs::write(dir.join(&format!("{stem}.toml")), scene_toml(&stem, "gltf")).unwrap();
        let gltf = format!("{stem}.gltf");
        assert_refused(&dir.path, &["render", &format!("{stem}.toml"), "--out", "out.png"], &[&gltf, key]);
    }
    // Attributes of the wrong shape, read only where a material reads them.
    let mut q = Quad { material: json!({"normalTexture": {"index": 0}}), ..Quad::default() };
    q.uv1 = Some([[0.0; 2]; 4]);
    write_quad(&dir, "tangent", &Quad { tangent: Some([1.0, 0.0, 0.0, 1.0]), ..q }, &["t.png"]);
    let text = std::fs::read_to_string(dir.join("tangent.gltf")).unwrap();
    // The TANGENT accessor (the last written) as a VEC3.
    let text = text.replacen("\"VEC4\"", "\"VEC3\"", 1);
    std::fs::write(dir.join("tangent.gltf"), text).unwrap();
    std::fs::write(dir.join("tangent.toml"), scene_toml("tangent", "gltf")).unwrap();
    assert_refused(
        &dir.path,
        &["render", "tangent.toml", "--out", "out.png"],
        &["meshes[0].primitives[0].attributes.TANGENT"],
    );
    // Diffuse shading reads no tangents: the same file renders.
    let o = penumbra(
        &[
            "render",
            "tangent.toml",
            "--shading",
            "diffuse",
            "--width",
            "8",
            "--height",
            "8",
            "--out",
            "d.png",
        ],
        &dir.path,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn the_shading_flag_and_key_are_checked_and_named() {
    let dir = TempDir::new("shading_flag");
    write_quad(&dir, "q", &Quad::default(), &[]);
    std::fs::write(dir.join("q.toml"), scene_toml("q", "gltf")).unwrap();
    assert_refused(
        &dir.path,
        &["render", "q.toml", "--shading", "phong", "--out", "out.png"],
        &["--shading", "phong"],
    );
    std::fs::write(dir.join("p.toml"), scene_toml("q", "phong")).unwrap();
    assert_refused(&dir.path, &["render", "p.toml", "--out", "out.png"], &["p.toml", "materials.shading"]);
    std::fs::write(dir.join("k.toml"), scene_toml("q", "gltf").replace("shading =", "shade =")).unwrap();
    assert_refused(&dir.path, &["render", "k.toml", "--out", "out.png"], &["materials.shade"]);
    let o = penumbra(
        &["render", "p.toml", "--shading", "diffuse", "--width", "8", "--height", "8", "--out", "d.png"],
        &dir.path,
    );
    assert!(!o.status.success(), "the file's own value is checked as written");
    let o = penumbra(
        &["render", "q.toml", "--shading", "diffuse", "--width", "8", "--height", "8", "--out", "d.png"],
        &dir.path,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("d.json")).unwrap()).unwrap();
    assert_eq!(report["shading"], "diffuse");
}

/// `--aov` writes the primary hits' base colour (x COLOR_0), metallic, roughness and the
/// bent shading normal, each the mean over the pixel's samples that hit (0 where none does).
/// The truth: the quad's bytes and factors, decoded here.
#[test]
fn surface_aovs_hold_the_primary_hits_material() {
    let dir = TempDir::new("surface_aovs");
    texel_png(&dir, "mr.png", [0, 51, 204]);
    let a = 25f64.to_radians();
    let n_bytes = [code(a.sin()), code(0.0), code(a.cos())];
    texel_png(&dir, "n.png", n_bytes);
    let q = Quad {
        material: json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicRoughnessTexture": {"index": 0}},
            "normalTexture": {"index": 1},
        }),
        tangent: Some([1.0, 0.0, 0.0, 1.0]),
        color_u8: Some([[255, 0, 255, 255]; 4]),
        ..Quad::default()
    };
    write_quad(&dir, "q", &q, &["mr.png", "n.png"]);
    // Seen from straight above, 8 m up with a 30 degree view: the 2 m quad fills the middle.
    let toml = scene_toml("q", "gltf").replace("position = [0.0, 5.0, 5.0]", "position = [0.0, 8.0, 0.001]");
    std::fs::write(dir.join("q.toml"), toml).unwrap();
    let o = penumbra(
        &["render", "q.toml", "--aov", "--width", "16", "--height", "16", "--spp", "4", "--out", "a.png"],
        &dir.path,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let read = |name: &str| image::open(dir.join(&format!("a.{name}.exr"))).unwrap().into_rgb32f();
    let (base, metallic, roughness, normal) =
        (read("base_color"), read("metallic"), read("roughness"), read("normal"));
    let [x, y, z] = n_bytes.map(decoded);
    let bent = Vec3::new(x as f32, z as f32, -y as f32).normalize();
    let (centre, corner) = ((8, 8), (0, 0));
    let at = |img: &image::Rgb32FImage, (i, j): (u32, u32)| Vec3::from(img.get_pixel(i, j).0);
    assert!((at(&base, centre) - Vec3::new(0.5, 0.0, 0.5)).abs().max_element() < 1e-6);
    assert!((at(&metallic, centre) - Vec3::splat(0.8)).abs().max_element() < 1e-6);
    assert!((at(&roughness, centre) - Vec3::splat(0.2)).abs().max_element() < 1e-6);
    assert!((at(&normal, centre) - bent).length() < 1e-3, "{} against {bent}", at(&normal, centre));
    for img in [&base, &metallic, &roughness, &normal] {
        assert_eq!(at(img, corner), Vec3::ZERO, "a pixel that sees nothing");
    }
}

const READER: &str = "material_shading::diffuse_reads_nothing_but_base_colour_on_every_shared_scene";

/// `diffuse` renders every shared scene from its base colours alone: the same bits with
/// every other material property (metallic, roughness, normal, metallic-roughness and
/// emissive textures, emission) taken away; `gltf` shading differs on every scene. Against
/// the renders of before materials were read: the `diffuse` images of every shared scene are
/// the same bytes as the previous build's (checked by hand at 80 x 60, 16 samples, with the
/// binary of 7c5e613; `tests/path_tracing.rs` holds the Lambertian formula bit for bit).
#[test]
fn diffuse_reads_nothing_but_base_colour_on_every_shared_scene() {
    if !common::shared::scenes_present(READER) {
        return;
    }
    let settings = RenderSettings {
        width: 48,
        height: 36,
        spp: 1,
        seed: 5,
        memory_budget_bytes: u64::MAX,
        profile: false,
        max_depth: 2,
    };
    let radiance = |scene: &Scene| {
        let mut methods: Vec<Box<dyn LightShadowing>> =
            scene.lights.iter().map(|_| Box::new(Traced::new(TracedParams::CULLED, 16)) as _).collect();
        render(scene, &mut methods, &settings, &|_| {}).unwrap().radiance
    };
    let mut shaded_differently = 0;
    let scenes = common::sweep(common::shared::gltf_scene_files(), 1);
    for path in &scenes {
        let mut file = SceneFile::load(path).unwrap();
        file.materials.shading = Shading::Diffuse;
        let mut scene = Scene::load(&file, path).unwrap();
        let diffuse = radiance(&scene);
        for m in scene.materials.iter_mut() {
            let base = Material {
                base_color: m.base_color,
                base_color_texture: m.base_color_texture,
                alpha: m.alpha,
                ..Material::diffuse([0.0; 3])
            };
            *m = base;
        }
        assert!(radiance(&scene) == diffuse, "{}", path.display());
        file.materials.shading = Shading::Gltf;
        if radiance(&Scene::load(&file, path).unwrap()) != diffuse {
            shaded_differently += 1;
        }
    }
    assert_eq!(shaded_differently, scenes.len(), "every scene has a specular lobe");
}
