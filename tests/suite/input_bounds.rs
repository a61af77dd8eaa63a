//! Bounded input and honest output, as a user meets them on the command line: out-of-range
//! albedo and radiance are one-line errors (exit 2, nothing written); a NaN or an infinity
//! never reaches a file; suspicious scenes render with `warning:` lines on stderr (even with
//! --quiet) and the same lines under `warnings` in the run report; glTF load errors name the
//! file that failed; SIGINT/SIGTERM leave no temporary file.

use crate::common;
use crate::common::folders;
use folders::penumbra;

use common::gltf_writer::{
    GltfBuilder, TRIANGLES, TempDir, primitive, write_png_header_only, write_png_rgba,
};
use serde_json::json;
use std::path::Path;
use std::process::{Command, Output};

const CAMERA_AND_LIGHT: &str = r#"
[camera]
position = [0.0, 2.0, 3.0]
look_at = [0.0, 0.0, 0.0]

[image]
width = 24
height = 16

[[light]]
center = [0.2, 1.5, 0.1]
u = [0.5, 0.0, 0.0]
v = [0.0, 0.0, 0.5]
radiance = [4.0, 4.0, 4.0]

[shadows]
method = "traced"
samples = 16
"#;

const FLOOR: &str = "[[quad]]\ncenter = [0.0, 0.0, 0.0]\nu = [40.0, 0.0, 0.0]\nv = [0.0, 0.0, -40.0]\n";

/// Renders `scene` (written to `<dir>/s.toml`) to `<dir>/out/img.png` with `extra` flags.
fn render(dir: &TempDir, scene: &str, extra: &[&str]) -> Output {
    std::fs::write(dir.join("s.toml"), scene).unwrap();
    let mut args = vec!["render", "s.toml", "--out", "out/img.png"];
    args.extend_from_slice(extra);
    penumbra(&args, &dir.path)
}

/// An error: exit status 2, one line on stderr containing each of `parts`, no output folder
/// content.
fn assert_error(o: &Output, dir: &TempDir, parts: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    for p in parts {
        assert!(err.contains(p), "{p:?} not in {err}");
    }
    let written: Vec<_> =
        std::fs::read_dir(dir.join("out")).map(|d| d.flatten().collect()).unwrap_or_default();
    assert!(written.is_empty(), "written: {written:?}");
}

/// A success whose stderr and report both carry a warning containing `part`.
fn assert_warning(o: &Output, dir: &TempDir, part: &str) -> Vec<String> {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.lines().any(|l| l.starts_with("warning: ") && l.contains(part)), "{part:?} not in {err}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("out/img.json")).unwrap()).unwrap();
    let warnings: Vec<String> =
        report["warnings"].as_array().unwrap().iter().map(|w| w.as_str().unwrap().to_string()).collect();
    assert!(warnings.iter().any(|w| w.contains(part)), "{part:?} not in {warnings:?}");
    assert_eq!(warnings.len(), err.lines().filter(|l| l.starts_with("warning: ")).count());
    warnings
}

#[test]
fn a_plain_scene_has_no_warnings() {
    let dir = TempDir::new("bounds-plain");
    let o = render(&dir, &format!("{CAMERA_AND_LIGHT}{FLOOR}"), &["--quiet"]);
    assert!(o.status.success());
    assert_eq!(String::from_utf8_lossy(&o.stderr), "");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("out/img.json")).unwrap()).unwrap();
    assert_eq!(report["warnings"], json!([]));
}

#[test]
fn albedo_outside_zero_one_is_an_error() {
    let dir = TempDir::new("bounds-albedo");
    let scene = format!("{CAMERA_AND_LIGHT}{FLOOR}color = [1e38, 0.5, 0.5]\n");
    assert_error(&render(&dir, &scene, &[]), &dir, &["s.toml: quad[0].color: ", "[0, 1]"]);
    let scene = format!("{CAMERA_AND_LIGHT}{FLOOR}color = [0.5, -0.1, 0.5]\n");
    assert_error(&render(&dir, &scene, &[]), &dir, &["quad[0].color"]);
}

#[test]
fn nan_or_infinite_radiance_is_an_error() {
    let dir = TempDir::new("bounds-radiance");
    for bad in ["nan", "inf"] {
        let scene =
            format!("{CAMERA_AND_LIGHT}{FLOOR}").replace("radiance = [4.0,", &format!("radiance = [{bad},"));
        assert_error(&render(&dir, &scene, &[]), &dir, &["s.toml: light[0].radiance: must be finite"]);
    }
}

/// A finite radiance near f32's largest value overflows in shading: the output would hold
/// infinities, so it is an error naming the output and the count, and nothing is written.
#[test]
fn radiance_that_overflows_writes_nothing() {
    let dir = TempDir::new("bounds-overflow");
    // 5 cm above the floor the light subtends nearly a hemisphere: E = L x ~2.9 > f32::MAX.
    // Lambertian shading multiplies the albedo by L E (the glTF BRDF weighs E first, and
    // 0.5 / pi x 2.9 L stays finite).
    let scene = format!("{CAMERA_AND_LIGHT}{FLOOR}")
        .replace("radiance = [4.0, 4.0, 4.0]", "radiance = [3e38, 0.5, 0.5]")
        .replace("center = [0.2, 1.5, 0.1]", "center = [0.0, 0.05, 0.0]");
    assert_error(
        &render(&dir, &scene, &["--aov", "--shading", "diffuse"]),
        &dir,
        &["out/img.exr: ", "values are not finite", "nothing written"],
    );
}

#[test]
fn light_facing_away_is_a_warning_even_with_quiet() {
    let dir = TempDir::new("bounds-away");
    // v = -z: the light faces up, away from the floor below it.
    let scene = format!("{CAMERA_AND_LIGHT}{FLOOR}").replace("v = [0.0, 0.0, 0.5]", "v = [0.0, 0.0, -0.5]");
    let o = render(&dir, &scene, &["--quiet"]);
    assert_eq!(String::from_utf8_lossy(&o.stdout), "", "--quiet prints no summary");
    let w =
        assert_warning(&o, &dir, "light 0 reaches no visible point: every point the camera sees is behind");
    assert!(w.iter().any(|w| w.starts_with("the camera sees nothing lit")), "{w:?}");
}

/// A light of 1e-30 m 1.5 m from the camera is one point in f32: its irradiance cannot be
/// computed, so it is an error naming the key (not a black image).
#[test]
fn light_too_small_for_f32_is_an_error() {
    let dir = TempDir::new("bounds-tiny-light");
    let scene = format!("{CAMERA_AND_LIGHT}{FLOOR}")
        .replace("u = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 0.5]", "u = [1e-30, 0.0, 0.0]\nv = [0.0, 0.0, 1e-30]");
    assert_error(&render(&dir, &scene, &[]), &dir, &["s.toml: light[0].u: ", "too small for f32", "spaced"]);
    // Below f32's smallest normal number even as an edge: named by the same key.
    let scene = scene.replace("1e-30", "1e-40");
    assert_error(&render(&dir, &scene, &[]), &dir, &["s.toml: light[0].u: ", "outside what f32 holds"]);
}

/// A camera 10^7 m away, where f32 spacing is 1 m, cannot hold the 0.5 m light in its
/// render space: the error blames the camera's distance, named by its key (it blamed the
/// light's size), and says what to do.
#[test]
fn camera_too_far_for_the_light_is_an_error_naming_the_camera() {
    let dir = TempDir::new("bounds-far-camera");
    let scene = format!("{CAMERA_AND_LIGHT}{FLOOR}");
    let position = scene.lines().find(|l| l.starts_with("position")).expect("a camera position").to_string();
    let scene = scene.replacen(&position, "position = [0.0, 2.0, 1e7]", 1);
    assert_error(
        &render(&dir, &scene, &[]),
        &dir,
        &[
            "s.toml: camera.position: the camera is 1.000e7 m from the light",
            "spaced 1.000e0 m",
            "move the camera nearer",
        ],
    );
}

#[test]
fn camera_inside_a_closed_box_is_a_warning() {
    let dir = TempDir::new("bounds-box");
    // A closed 2 m cube around the camera at (0, 2, 3); the light above it, outside.
    let mut scene = CAMERA_AND_LIGHT.replace("center = [0.2, 1.5, 0.1]", "center = [0.0, 4.0, 3.0]");
    for (c, u, v) in [
        ([0.0, 1.0, 3.0], [2.0, 0.0, 0.0], [0.0, 0.0, -2.0]),
        ([0.0, 3.0, 3.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
        ([-1.0, 2.0, 3.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]),
        ([1.0, 2.0, 3.0], [0.0, 2.0, 0.0], [0.0, 0.0, -2.0]),
        ([0.0, 2.0, 2.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
        ([0.0, 2.0, 4.0], [2.0, 0.0, 0.0], [0.0, -2.0, 0.0]),
    ] {
        scene += &format!("[[quad]]\ncenter = {c:?}\nu = {u:?}\nv = {v:?}\n");
    }
    let o = render(&dir, &scene, &[]);
    let w =
        assert_warning(&o, &dir, "the camera sees nothing lit: none of 384 visible point(s) receives light");
    assert!(w.iter().any(|w| w.contains("light 0 reaches no visible point")), "{w:?}");
}

#[test]
fn camera_seeing_no_geometry_is_a_warning() {
    let dir = TempDir::new("bounds-empty");
    let scene = format!(
        "{CAMERA_AND_LIGHT}[[quad]]\ncenter = [0.0, 0.0, 9.0]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 0.0, -1.0]\n"
    );
    assert_warning(
        &render(&dir, &scene, &[]),
        &dir,
        "the camera sees nothing: no primary ray hits any geometry",
    );
}

#[test]
fn far_geometry_is_a_warning_with_its_precision() {
    let dir = TempDir::new("bounds-far");
    let scene = format!(
        "{CAMERA_AND_LIGHT}{FLOOR}[[quad]]\ncenter = [1e6, 0.0, 0.0]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 0.0, -1.0]\n"
    );
    let o = render(&dir, &scene, &[]);
    assert_warning(
        &o,
        &dir,
        "2 triangle(s) too far from the camera for f32 to keep their shape: the farthest 1.000e6 m away, where f32 positions are spaced 6.250e-2 m",
    );
    assert_warning(&o, &dir, "the visible part lies within");
}

/// One glTF mesh: a floor of two triangles plus one with a repeated vertex (zero area).
fn floor_with_a_degenerate_triangle(base_color: [f32; 4]) -> GltfBuilder {
    let mut b = GltfBuilder::new();
    let p = [[-5.0, 0.0, -5.0], [5.0, 0.0, -5.0], [5.0, 0.0, 5.0], [-5.0, 0.0, 5.0]];
    let pos = b.positions(&p);
    let idx = b.indices_u16(&[0, 2, 1, 0, 3, 2, 0, 1, 1]);
    let mat = b.material(json!({"pbrMetallicRoughness": {"baseColorFactor": base_color}}));
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], Some(idx), TRIANGLES, Some(mat))]);
    let node = b.node(json!({"mesh": mesh}));
    let scene = b.scene(&[node]);
    b.set_default_scene(scene);
    b
}

fn model_scene(model: &str) -> String {
    format!("[[model]]\npath = \"{model}\"\n{CAMERA_AND_LIGHT}")
}

#[test]
fn dropped_degenerate_triangle_is_a_warning() {
    let dir = TempDir::new("bounds-degenerate");
    floor_with_a_degenerate_triangle([0.8, 0.8, 0.8, 1.0]).write(&dir.path, "floor");
    let o = render(&dir, &model_scene("floor.gltf"), &[]);
    assert_warning(&o, &dir, "1 triangle(s) dropped: zero area (repeated or collinear vertices)");
}

#[test]
fn base_color_factor_outside_zero_one_is_an_error() {
    let dir = TempDir::new("bounds-basecolor");
    floor_with_a_degenerate_triangle([2.0, 0.8, 0.8, 1.0]).write(&dir.path, "floor");
    let o = render(&dir, &model_scene("floor.gltf"), &[]);
    assert_error(&o, &dir, &["floor.gltf: materials[0].pbrMetallicRoughness.baseColorFactor: ", "[0, 1]"]);
}

#[test]
fn missing_bin_is_named() {
    let dir = TempDir::new("bounds-missing-bin");
    floor_with_a_degenerate_triangle([0.8; 4]).write(&dir.path, "floor");
    std::fs::remove_file(dir.join("floor.bin")).unwrap();
    let o = render(&dir, &model_scene("floor.gltf"), &[]);
    assert_error(&o, &dir, &["floor.gltf: buffers[0].uri: cannot read ", "floor.bin: No such file"]);
    // Present but short: named with both lengths.
    floor_with_a_degenerate_triangle([0.8; 4]).write(&dir.path, "floor");
    let bin = std::fs::read(dir.join("floor.bin")).unwrap();
    std::fs::write(dir.join("floor.bin"), &bin[..bin.len() / 2]).unwrap();
    let o = render(&dir, &model_scene("floor.gltf"), &[]);
    assert_error(&o, &dir, &["floor.gltf: buffers[0].byteLength: ", "floor.bin has "]);
}

/// Buffer URIs that lead out of the model's folder (an absolute path, a `file:` URI, `..`
/// past the folder) load, with a warning naming the model, the key, the URI and the file
/// read; a URI inside the folder gets none.
/// The user's report: a glTF whose buffer URI is an absolute path to a file that is not the
/// model's (say /etc/passwd) failed with "index 28525 out of range", and the warning naming
/// the file it read was never printed. The error names it now.
#[test]
fn a_uri_reading_the_wrong_file_is_named_in_the_error() {
    let dir = TempDir::new("bounds-uri-wrong-file");
    std::fs::create_dir_all(dir.join("models")).unwrap();
    let passwd = dir.join("passwd");
    std::fs::write(&passwd, "root:x:0:0:root:/root:/bin/bash\n".repeat(64)).unwrap();
    let b = floor_with_a_degenerate_triangle([0.8; 4]);
    let uri = passwd.display().to_string();
    common::gltf_writer::write_json(&dir.join("models/floor.gltf"), &b.json(&uri));
    let o = render(&dir, &model_scene("models/floor.gltf"), &[]);
    assert_error(&o, &dir, &["models/floor.gltf", &format!("it reads {uri}, outside the model's folder")]);
}

#[test]
fn a_uri_out_of_the_models_folder_is_a_warning() {
    let dir = TempDir::new("bounds-uri");
    std::fs::create_dir_all(dir.join("models")).unwrap();
    std::fs::create_dir_all(dir.join("shared")).unwrap();
    let b = floor_with_a_degenerate_triangle([0.8; 4]);
    b.write(&dir.join("shared"), "floor"); // the .bin the URIs below name
    let bin = dir.join("shared/floor.bin");
    let absolute = bin.display().to_string();
    let cases = [
        (absolute.clone(), "an absolute path", absolute.clone()),
        (format!("file://{absolute}"), "an absolute file: URI", absolute.clone()),
        (
            "../shared/floor.bin".to_string(),
            "a relative path out of the model's folder",
            "models/../shared/floor.bin".into(),
        ),
    ];
    for (uri, what, file) in cases {
        common::gltf_writer::write_json(&dir.join("models/floor.gltf"), &b.json(&uri));
        let o = render(&dir, &model_scene("models/floor.gltf"), &[]);
        let expected = format!(
            "models/floor.gltf: buffers[0].uri {uri:?} is {what}: it reads {file}, outside the model's folder \
             (glTF expects URIs relative to the file; the model breaks when moved or shared)"
        );
        let warnings = assert_warning(&o, &dir, &expected);
        assert!(warnings.contains(&expected), "{warnings:?}");
    }
    // Inside the folder: no such warning.
    std::fs::copy(&bin, dir.join("models/floor.bin")).unwrap();
    common::gltf_writer::write_json(&dir.join("models/floor.gltf"), &b.json("./floor.bin"));
    let o = render(&dir, &model_scene("models/floor.gltf"), &[]);
    let warnings = assert_warning(&o, &dir, "dropped");
    assert!(!warnings.iter().any(|w| w.contains("outside the model's folder")), "{warnings:?}");
}

#[test]
fn truncated_glb_is_named() {
    let dir = TempDir::new("bounds-glb");
    let glb = floor_with_a_degenerate_triangle([0.8; 4]).write_glb(&dir.path, "floor");
    let o = render(&dir, &model_scene("floor.glb"), &[]);
    assert!(o.status.success(), "the whole .glb loads: {}", String::from_utf8_lossy(&o.stderr));
    let bytes = std::fs::read(&glb).unwrap();
    std::fs::remove_dir_all(dir.join("out")).unwrap();
    std::fs::write(&glb, &bytes[..bytes.len() - 20]).unwrap();
    let o = render(&dir, &model_scene("floor.glb"), &[]);
    let declared = bytes.len();
    let message =
        format!("floor.glb: the .glb is truncated: {} bytes, its header declares {declared}", declared - 20);
    assert_error(&o, &dir, &[&message]);
}

/// Sends `signal` to a render as soon as a staged temporary file appears in its output
/// folder (a 2048 x 2048 image with AOVs: ~0.2 s of writing), then checks the exit status and
/// that no temporary file is left. A run that finishes before any temporary file is seen is
/// retried (at most 4 times), so a fast machine cannot make the test vacuous.
fn interrupted_while_writing(signal: &str, status: i32) {
    let dir = TempDir::new(&format!("bounds-signal-{signal}"));
    std::fs::write(dir.join("s.toml"), format!("{CAMERA_AND_LIGHT}{FLOOR}")).unwrap();
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    for attempt in 0..4 {
        let mut child = Command::new(env!("CARGO_BIN_EXE_penumbra"))
            .args(["render", "s.toml", "--out", "out/img.png", "--aov", "--shadows", "none", "--quiet"])
            .args(["--width", "2048", "--height", "2048"])
            .current_dir(&dir.path)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let staged = |out: &Path| {
            std::fs::read_dir(out)
                .unwrap()
                .flatten()
                .any(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        };
        let seen = loop {
            if staged(&out) {
                break true;
            }
            if child.try_wait().unwrap().is_some() {
                break false;
            }
            std::thread::sleep(std::time::Duration::from_micros(200));
        };
        if !seen {
            let _ = std::fs::remove_dir_all(&out);
            std::fs::create_dir_all(&out).unwrap();
            eprintln!("attempt {attempt}: finished before a temporary file was seen; again");
            continue;
        }
        let kill =
            Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status().unwrap();
        assert!(kill.success());
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(status), "{err}");
        assert!(err.contains(&format!("interrupted by SIG{signal}")), "{err}");
        let left: Vec<_> = std::fs::read_dir(&out).unwrap().flatten().map(|e| e.file_name()).collect();
        assert!(!left.iter().any(|n| n.to_string_lossy().ends_with(".tmp")), "left behind: {left:?}");
        return;
    }
    panic!("no run was caught while writing its outputs");
}

#[test]
fn sigterm_while_writing_leaves_no_temporary_file() {
    interrupted_while_writing("TERM", 143);
}

#[test]
fn sigint_while_writing_leaves_no_temporary_file() {
    interrupted_while_writing("INT", 130);
}

#[test]
fn a_path_depth_outside_two_to_sixty_four_is_an_error() {
    let dir = TempDir::new("bounds-depth");
    let scene = format!("{CAMERA_AND_LIGHT}{FLOOR}");
    for depth in ["0", "1", "65"] {
        assert_error(
            &render(&dir, &scene, &["--max-depth", depth]),
            &dir,
            &["--max-depth: ", "2..=64", &format!("got {depth}")],
        );
    }
    let scene = format!("{CAMERA_AND_LIGHT}{FLOOR}[integrator]\nmax_depth = 1\n");
    assert_error(
        &render(&dir, &scene, &[]),
        &dir,
        &["s.toml: integrator.max_depth: ", "2 = direct light only"],
    );
    let scene = format!("{CAMERA_AND_LIGHT}{FLOOR}[integrator]\nmax_dept = 3\n");
    assert_error(&render(&dir, &scene, &[]), &dir, &["s.toml: integrator.max_dept"]);
}

/// A 10 m floor model whose material reads the base colour texture `uri` (beside the .gltf)
/// and whose node is `node` with the mesh added (a transform, say).
fn textured_floor(uri: &str, node: serde_json::Value) -> GltfBuilder {
    let mut b = GltfBuilder::new();
    let pos = b.positions(&[[-5.0, 0.0, -5.0], [5.0, 0.0, -5.0], [5.0, 0.0, 5.0], [-5.0, 0.0, 5.0]]);
    let uv = b.texcoords(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    let idx = b.indices_u16(&[0, 2, 1, 0, 3, 2]);
    let tex = b.texture_png(uri);
    let mat = b.material(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": tex}}}));
    let mesh =
        b.mesh(vec![primitive(&[("POSITION", pos), ("TEXCOORD_0", uv)], Some(idx), TRIANGLES, Some(mat))]);
    let mut node = node;
    node["mesh"] = json!(mesh);
    let node = b.node(node);
    let scene = b.scene(&[node]);
    b.set_default_scene(scene);
    b
}

/// A texture larger than the memory the load may use is refused before it is decoded, in
/// one line naming the image, its size in pixels and bytes and the limit (it was the image
/// crate's "Memory limit exceeded", naming none of them). 10^6 x 10^6 RGBA8 is 3.6 TiB.
#[test]
fn a_texture_over_the_memory_available_is_named_with_its_size_and_the_limit() {
    let dir = TempDir::new("bounds-huge-texture");
    write_png_header_only(&dir.join("huge.png"), 1_000_000, 1_000_000);
    textured_floor("huge.png", json!({})).write(&dir.path, "floor");
    let o = render(&dir, &model_scene("floor.gltf"), &[]);
    assert_error(
        &o,
        &dir,
        &[
            "floor.gltf: images[0].uri: ",
            "huge.png (textures[0], materials[0].pbrMetallicRoughness.baseColorTexture)",
            "is 1000000 x 1000000 pixels",
            "GiB of memory the load may use",
            "downscale",
        ],
    );
}

/// A texture over the image crate's own default limit (512 MiB decoded) loads where the
/// memory allows it: 11,600^2 RGBA8 is 513 MiB (16,384^2, 1 GiB, was refused the same way).
#[test]
fn a_texture_over_the_image_crates_default_limit_loads() {
    let dir = TempDir::new("bounds-large-texture");
    write_png_rgba(&dir.join("large.png"), 11_600, 11_600, |_, _| [200, 200, 200, 255]);
    textured_floor("large.png", json!({})).write(&dir.path, "floor");
    let o = render(&dir, &model_scene("floor.gltf"), &["--quiet"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Node transforms whose product overflows f32 (a 3e38 scale; two nested 1e30 scales) drop
/// their mesh's triangles with a warning naming the node (it said "zero area").
#[test]
fn a_node_transform_overflowing_f32_is_a_warning_naming_the_node() {
    let dir = TempDir::new("bounds-overflowing-node");
    write_png_rgba(&dir.join("grey.png"), 1, 1, |_, _| [200, 200, 200, 255]);
    let scene = format!("{}{FLOOR}", model_scene("floor.gltf"));
    textured_floor("grey.png", json!({"scale": [3e38, 3e38, 3e38]})).write(&dir.path, "floor");
    let w = assert_warning(
        &render(&dir, &scene, &[]),
        &dir,
        "floor.gltf: the transform of nodes[0] overflows f32",
    );
    assert!(w.iter().any(|w| w.contains("nodes[0]") && w.contains("2 triangle(s) dropped")), "{w:?}");
    assert!(!w.iter().any(|w| w.contains("zero area")), "{w:?}");
    // The mesh's node scales by 1e30 under a parent that does too: 1e60 in world space.
    let mut b = textured_floor("grey.png", json!({"scale": [1e30, 1e30, 1e30]}));
    let parent = b.node(json!({"scale": [1e30, 1e30, 1e30], "children": [0]}));
    let mut doc = b.json("floor.bin");
    doc["scenes"][0]["nodes"] = json!([parent]);
    common::gltf_writer::write_json(&dir.join("floor.gltf"), &doc);
    let w = assert_warning(
        &render(&dir, &scene, &[]),
        &dir,
        "floor.gltf: the transform of nodes[0] overflows f32",
    );
    assert!(w.iter().any(|w| w.contains("nodes[0]") && w.contains("2 triangle(s) dropped")), "{w:?}");
    assert!(!w.iter().any(|w| w.contains("zero area")), "{w:?}");
}

/// A number f32 cannot hold (1e39) in a node's matrix is named by its key path, not by the
/// JSON's line and column alone.
#[test]
fn a_number_out_of_f32_range_is_named_by_its_key_path() {
    let dir = TempDir::new("bounds-f32-range");
    write_png_rgba(&dir.join("grey.png"), 1, 1, |_, _| [200, 200, 200, 255]);
    let b = textured_floor("grey.png", json!({}));
    b.write(&dir.path, "floor");
    let mut doc = b.json("floor.bin");
    let mut matrix = vec![json!(0.0); 16];
    for i in [0, 5, 10, 15] {
        matrix[i] = json!(1.0);
    }
    matrix[5] = json!(1e39);
    doc["nodes"][0]["matrix"] = json!(matrix);
    common::gltf_writer::write_json(&dir.join("floor.gltf"), &doc);
    let o = render(&dir, &model_scene("floor.gltf"), &[]);
    assert_error(&o, &dir, &["floor.gltf: nodes[0].matrix[5]: ", "1e39"]);
}
