//! glTF's `alphaMode = BLEND` read as coverage: a pane of alpha a stops a share a of what
//! crosses it, for every shadow method and for camera rays, the same bytes with any thread
//! count.
//!
//! The scene: a 2 x 2 BLEND pane at height 1 over an opaque floor, a 0.5 x 0.5 light at
//! height 4 facing down. Every floor point within 0.8 of the pane's centre (in x and z)
//! sees the whole light through the pane (a ray to it crosses height 1 within 0.66 of the
//! centre), so its V is the pane's transmission, 1 - a: the truth, from the definition of
//! coverage. Each ray meets the pane at a point of its own, and the pattern is white noise,
//! so V from N rays is a binomial share: standard deviation sqrt(a (1 - a) / N), which
//! stratifying the light does not lower. The tolerances below are stated in those terms.

use crate::common;

use common::gltf_writer::{TempDir, write_png_rgba};
use common::material_quad::{Quad, write_quad};
use glam::{DVec3, Vec3};
use renderer::geometry::point::ShadingPoint;
use renderer::geometry::ray_origin::point_error;
use renderer::{
    KeepInstances, LightShadowing, LoadOptions, PrepareContext, Scene, SceneFile, ShadowMethod, ShadowQuery,
};
use serde_json::{Value, json};
use shadow_plugin::{AnalyticParams, EdgeTableParams, PcssParams, SilhouetteParams};

/// The scene file: the pane model `stem`, the floor, the light, a camera above the pane.
fn scene_toml(stem: &str, shading: &str) -> String {
    format!(
        "[[model]]\npath = \"{stem}.gltf\"\n\
         [[quad]]\ncenter = [0.0, 0.0, 0.0]\nu = [8.0, 0.0, 0.0]\nv = [0.0, 0.0, -8.0]\n\
         [camera]\nposition = [0.0, 6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\n\
         [[light]]\ncenter = [0.0, 4.0, 0.0]\nu = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 0.5]\nradiance = [1.0, 1.0, 1.0]\n\
         [materials]\nshading = \"{shading}\"\n"
    )
}

/// Writes the pane (`q`'s material and attributes, moved to height 1) as `<stem>.gltf`.
fn write_pane(dir: &TempDir, stem: &str, q: Quad, textures: &[&str]) {
    let q = Quad { node: json!({"translation": [0.0, 1.0, 0.0]}), ..q };
    write_quad(dir, stem, &q, textures);
}

/// A BLEND material of constant alpha `a` (a blue-grey pane).
fn blend(a: f32) -> Value {
    json!({"pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.5, 0.8, a]}, "alphaMode": "BLEND",
           "doubleSided": true})
}

fn load(dir: &TempDir, stem: &str, shading: &str, keep: KeepInstances) -> Scene {
    let path = dir.join(&format!("{stem}.toml"));
    std::fs::write(&path, scene_toml(stem, shading)).unwrap();
    let file = SceneFile::parse(&scene_toml(stem, shading), &path).unwrap();
    Scene::load_with(&file, &path, LoadOptions { memory_limit: None, keep }).unwrap()
}

/// An n x n grid of floor points over |x|, |z| <= r (render space).
fn floor_grid(scene: &Scene, n: u32, r: f64) -> Vec<ShadingPoint> {
    let mut points = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let at = |k: u32| -r + 2.0 * r * k as f64 / (n - 1) as f64;
            let p = (DVec3::new(at(i), 0.0, at(j)) - scene.world_offset).as_vec3();
            points.push(ShadingPoint { p, p_error: point_error(p), n_geom: Vec3::Y, n_shading: Vec3::Y });
        }
    }
    points
}

/// The floor points under the pane: an 8 x 8 grid over |x|, |z| <= 0.8.
fn floor_points(scene: &Scene) -> Vec<ShadingPoint> {
    floor_grid(scene, 8, 0.8)
}

/// The methods compared, by the names the scene file gives them.
const METHODS: [&str; 5] = ["traced", "silhouette", "analytic", "edge_table", "pcss"];

fn method(name: &str, samples: u32) -> Box<dyn LightShadowing> {
    match name {
        "traced" => renderer::TracedParams::default().build(samples),
        "silhouette" => SilhouetteParams::default().build(samples),
        "analytic" => AnalyticParams::default().build(samples),
        "edge_table" => EdgeTableParams::default().build(samples),
        "pcss" => PcssParams::default().build(samples),
        _ => unreachable!("{name}"),
    }
}

/// V of light 0 at each floor point by `name` at N = `samples`, prepared as for a camera
/// that sees the floor over |x|, |z| <= 2.2, the pane's shadow and around it (the depth-map
/// methods fit their map to what the camera sees).
fn visibilities(scene: &Scene, name: &str, samples: u32) -> Vec<f32> {
    let points = floor_points(scene);
    let seen = floor_grid(scene, 48, 2.2);
    let mut m = method(name, samples);
    let ctx = PrepareContext { visible: &seen, ..PrepareContext::for_light(scene, 0) };
    m.prepare(&ctx).unwrap_or_else(|e| panic!("{name}: {e:?}"));
    points
        .iter()
        .enumerate()
        .map(|(k, &point)| {
            let q = ShadowQuery { point, pixel: [k as u32, 0], seed: 0x5eed + k as u64, irradiance: 0.0 };
            m.visibility(scene, &q)
        })
        .collect()
}

fn mean(v: &[f32]) -> f64 {
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}

/// The root-mean-square distance of `v` from `truth`.
fn rms(v: &[f32], truth: f64) -> f64 {
    (v.iter().map(|&x| (x as f64 - truth).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

/// (1) Under a pane of alpha 0.3 the floor keeps 70% of the light, by every method. The
/// binomial standard deviation of one point's V at N rays is sigma = sqrt(0.21 / N); of the
/// mean over the 64 points, sigma / 8. `traced`; `silhouette`, which traces the samples the
/// pane may take (`traced`'s bits); `analytic`, which samples what its leaves hide (more
/// samples than N: its strata over the leaves, refined where neighbours disagree, so its
/// spread is under sigma): the mean within 4.5 of its deviations (plus the thresholds'
/// 2^-17), every point within 5 sigma, and the spread about 0.7 shrinking as 1/sqrt(N) from
/// N = 256 to 4096 (the ratio 4 within 3.2 to 5: each rms over 64 points is within ~9% of
/// its expectation). The depth-map methods, `edge_table` (exact: rays its bounds cannot
/// decide are traced) and `pcss` (its map's rays are a fixed draw of the pattern, shared by
/// neighbouring points): their mean within 0.02. Measured at N = 4096: mean V 0.7004
/// (`traced`, `silhouette`), 0.6999 (`analytic`), 0.6988 (`edge_table`), 0.6998 (`pcss`).
#[test]
fn a_pane_of_alpha_03_keeps_70_percent_of_the_light() {
    let dir = TempDir::new("blend_v");
    write_pane(&dir, "pane", Quad { material: blend(0.3), ..Quad::default() }, &[]);
    let scene = load(&dir, "pane", "gltf", KeepInstances::Never);
    let truth = 0.7;
    let exact = |n: u32| (0.21 / n as f64).sqrt();
    let traced = visibilities(&scene, "traced", 4096);
    for name in METHODS {
        let v = visibilities(&scene, name, 4096);
        if name == "silhouette" {
            // It traces the samples the pane may take (the light's whole area here), with
            // `traced`'s samples and rays: the same pattern, so the same bits.
            assert!(v.iter().zip(&traced).all(|(a, b)| a.to_bits() == b.to_bits()), "{v:?}\n{traced:?}");
        }
        let (m, spread) = (mean(&v), rms(&v, truth));
        let worst = v.iter().map(|&x| (x as f64 - truth).abs()).fold(0.0, f64::max);
        eprintln!("{name}: N = 4096: mean V {m:.4}, rms about 0.7 {spread:.4}, worst {worst:.4}");
        if matches!(name, "edge_table" | "pcss") {
            assert!((m - truth).abs() < 0.02, "{name}: mean V {m}");
            continue;
        }
        let sigma = exact(4096);
        assert!((m - truth).abs() < 4.5 * sigma / 8.0 + 1.0 / 131072.0, "{name}: mean V {m}");
        assert!(worst < 5.0 * sigma, "{name}: a point's V is {worst} from 0.7 (sigma {sigma})");
        let coarse = rms(&visibilities(&scene, name, 256), truth);
        let ratio = coarse / spread;
        eprintln!(
            "{name}: rms about 0.7 at N = 256 {coarse:.4} (binomial {:.4}), ratio {ratio:.2}",
            exact(256)
        );
        assert!((3.2..=5.0).contains(&ratio), "{name}: rms {coarse} at N = 256, {spread} at 4096");
    }
}

/// (3) A BLEND pane of alpha 1 is opaque (V = 0 under it, exactly, by every method), one of
/// alpha 0 is not there (V = 1 exactly): no method reads it as a partial pane.
#[test]
fn blend_alpha_one_is_opaque_and_zero_is_clear_exactly() {
    let dir = TempDir::new("blend_exact");
    for (a, want) in [(1.0f32, 0.0f32), (0.0, 1.0)] {
        let stem = format!("pane{a}");
        write_pane(&dir, &stem, Quad { material: blend(a), ..Quad::default() }, &[]);
        let scene = load(&dir, &stem, "gltf", KeepInstances::Never);
        for name in METHODS {
            let v = visibilities(&scene, name, 256);
            assert!(v.iter().all(|&x| x == want), "{name}, alpha {a}: V {v:?}, want {want} everywhere");
        }
    }
}

/// Alpha is factor x texture x COLOR_0: a texture of alpha code 77 (0.302) and a factor 1
/// keep 0.698 of the light; a COLOR_0 alpha of 128 (0.502) keeps 0.498, and under
/// `shading = "diffuse"` (which reads no COLOR_0, as its base colour does not) the pane is
/// opaque. `traced` at N = 4096, the mean of 64 points within 4.5 binomial deviations.
#[test]
fn the_texture_and_color_0_scale_the_coverage() {
    let dir = TempDir::new("blend_sources");
    write_png_rgba(&dir.join("a77.png"), 1, 1, |_, _| [255, 255, 255, 77]);
    let textured = Quad {
        material: json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "alphaMode": "BLEND"}),
        ..Quad::default()
    };
    write_pane(&dir, "textured", textured, &["a77.png"]);
    let colored = Quad { material: blend(1.0), color_u8: Some([[255, 255, 255, 128]; 4]), ..Quad::default() };
    write_pane(&dir, "colored", colored, &[]);
    let cases = [
        ("textured", "gltf", 77.0 / 255.0),
        ("colored", "gltf", 128.0 / 255.0),
        ("colored", "diffuse", 1.0f64),
    ];
    for (stem, shading, alpha) in cases {
        let scene = load(&dir, stem, shading, KeepInstances::Never);
        let m = mean(&visibilities(&scene, "traced", 4096));
        let (truth, sigma) = (1.0 - alpha, (alpha * (1.0 - alpha) / (4096.0 * 64.0)).sqrt());
        eprintln!("{stem}, {shading}: mean V {m:.4}, truth {truth:.4}");
        assert!(
            (m - truth).abs() <= 4.5 * sigma + 1.0 / 131072.0,
            "{stem}, {shading}: mean V {m}, want {truth}"
        );
    }
}

/// The pattern is keyed by the triangle's instance and index in its mesh, not by where the
/// BVH stores it: a pane kept as an instance (its own tree) gives `traced` the flattened
/// pane's bits at every point.
#[test]
fn a_kept_pane_reads_the_flattened_pattern() {
    let dir = TempDir::new("blend_kept");
    write_pane(&dir, "pane", Quad { material: blend(0.3), ..Quad::default() }, &[]);
    let flat = load(&dir, "pane", "gltf", KeepInstances::Never);
    let kept = load(&dir, "pane", "gltf", KeepInstances::Always);
    assert_eq!(kept.kept_instances(), 1);
    let (a, b) = (visibilities(&flat, "traced", 1024), visibilities(&kept, "traced", 1024));
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "{a:?}\n{b:?}");
    assert!(a.iter().any(|&x| x != 0.0 && x != 1.0));
}

/// A frame of `stem`'s scene by `traced`, direct light only, the camera above the pane and
/// the light moved off to +x (just above the pane's height): its rays to the floor in view
/// pass beside the pane.
fn frame(dir: &TempDir, stem: &str, spp: u32) -> renderer::Frame {
    use renderer::{RenderSettings, render};
    let path = dir.join(&format!("{stem}.toml"));
    let light = "center = [6.0, 1.5, 0.0]\nu = [0.0, 0.0, 0.5]\nv = [0.0, 0.5, 0.0]\nradiance = [200.0, 200.0, 200.0]";
    let toml = scene_toml(stem, "gltf").replace(
        "center = [0.0, 4.0, 0.0]\nu = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 0.5]\nradiance = [1.0, 1.0, 1.0]",
        light,
    );
    assert!(toml.contains(light));
    let file = SceneFile::parse(&toml, &path).unwrap();
    let scene = Scene::load(&file, &path).unwrap();
    let settings = RenderSettings {
        width: 32,
        height: 32,
        spp,
        seed: 11,
        memory_budget_bytes: u64::MAX,
        profile: false,
        max_depth: 2,
    };
    let mut methods = vec![renderer::TracedParams::default().build(64)];
    render(&scene, &mut methods, &settings, &|_| {}).unwrap()
}

/// (2) The camera sees through a pane of alpha 0.3: each camera sample meets the pane (and
/// sees what the opaque pane, alpha 1, shows there) or passes it (and sees what no pane,
/// alpha 0, shows), so a pixel's radiance is 0.3 of the first and 0.7 of the second in
/// expectation. The light is off to the side: nothing in view is shadowed by the pane, so
/// the three frames' samples differ by the pane alone (and agree to the bit beside it). The
/// share fitted over every pixel and channel (least squares: sum (mix - clear) . (opaque -
/// clear) / sum |opaque - clear|^2) is 0.3 within 4.5 of its binomial deviation at 64 spp.
#[test]
fn the_camera_sees_through_a_pane_of_alpha_03() {
    let dir = TempDir::new("blend_camera");
    let pane = |a: f32| {
        let mut m = blend(a);
        m["pbrMetallicRoughness"]["metallicFactor"] = json!(0.0);
        Quad { material: m, ..Quad::default() }
    };
    for (stem, a) in [("mix", 0.3), ("opaque", 1.0), ("clear", 0.0)] {
        write_pane(&dir, stem, pane(a), &[]);
    }
    let spp = 64;
    let [mix, opaque, clear] = ["mix", "opaque", "clear"].map(|s| frame(&dir, s, spp).radiance);
    let (mut num, mut den, mut fourth, mut pixels) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for ((m, o), c) in mix.iter().zip(&opaque).zip(&clear) {
        let (m, o, c) = (m.as_dvec3(), o.as_dvec3(), c.as_dvec3());
        if o == c {
            // Beside the pane: the three frames agree to the bit.
            assert_eq!(m, o);
            continue;
        }
        let d2 = (o - c).length_squared();
        (num, den, fourth, pixels) = (num + (m - c).dot(o - c), den + d2, fourth + d2 * d2, pixels + 1);
    }
    let share = num / den;
    // Per pixel, m - c is (o - c) times a binomial share of spp samples (variance
    // 0.21 / spp): the fit's variance is 0.21 / spp x sum |o - c|^4 / (sum |o - c|^2)^2.
    let sigma = (0.21 / spp as f64 * fourth).sqrt() / den;
    eprintln!("camera: share of the pane {share:.4} over {pixels} pixels (sigma {sigma:.4})");
    assert!(pixels > 200, "the pane covers only {pixels} pixels");
    assert!((share - 0.3).abs() < 4.5 * sigma, "share {share}, sigma {sigma}");
}

/// (4) A render through a pane of alpha 0.3 gives the same bytes with 1 and 2 threads, by
/// every method, with bounces (the pattern is keyed by the point, never by the thread).
#[test]
fn blend_renders_the_same_bytes_with_one_and_two_threads() {
    let dir = TempDir::new("blend_threads");
    write_pane(&dir, "pane", Quad { material: blend(0.3), ..Quad::default() }, &[]);
    let path = dir.join("pane.toml");
    std::fs::write(&path, scene_toml("pane", "gltf").replace("[0.0, 6.0, 0.0]", "[0.0, 3.0, 4.0]")).unwrap();
    for name in METHODS {
        let run = |threads: u32| {
            let out = dir.join(&format!("{name}-{threads}.png"));
            let args = penumbra::RenderArgs {
                scene: Some(path.clone()),
                keys: penumbra::request::Overrides {
                    shadows: Some(name.into()),
                    samples: Some(64),
                    width: Some(40),
                    height: Some(30),
                    spp: Some(2),
                    max_depth: Some(4),
                    ..Default::default()
                },
                threads: Some(threads),
                out: Some(out.clone()),
                quiet: true,
                ..Default::default()
            };
            penumbra::run_render(&args).unwrap_or_else(|e| panic!("{name}: {e}"));
            std::fs::read(out.with_extension("exr")).unwrap()
        };
        assert!(run(1) == run(2), "{name}: 1 and 2 threads differ");
    }
}
