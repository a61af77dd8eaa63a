//! Precision that does not depend on the scene's size: render space is centred on the camera,
//! so geometry far from what the camera sees cannot cost the visible part its precision, and
//! triangles are degenerate only relative to their own size.

use crate::common;

use renderer::methods::traced::{Traced, TracedParams};
use renderer::{Frame, KeepInstances, LightShadowing, LoadOptions, RenderSettings, Scene, SceneFile, render};
use std::collections::HashSet;
use std::path::Path;

/// The default scene at a test size, with `extra` TOML appended.
fn default_scene(extra: &str) -> Scene {
    let text = format!("{}\n{extra}", penumbra::DEFAULT_SCENE);
    let path = Path::new("scenes/default.toml");
    let file = SceneFile::parse(&text, path).unwrap();
    Scene::load(&file, path).unwrap()
}

/// One 1 m quad, facing up, at `x` metres along +x: far outside the default camera's view.
fn far_quad(x: f64) -> String {
    format!("[[quad]]\ncenter = [{x:e}, 0.0, 0.0]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 0.0, -1.0]\n")
}

/// The frame `traced` renders of `scene` at 160 x 120, 64 samples, seed 7, direct light.
fn traced_frame(scene: &Scene) -> Frame {
    frame_with(scene, Box::new(Traced::new(TracedParams::CULLED, 64)))
}

/// The frame `method` renders of `scene` at 160 x 120, seed 7, direct light.
fn frame_with(scene: &Scene, method: Box<dyn LightShadowing>) -> Frame {
    let mut methods = vec![method];
    let settings = RenderSettings {
        width: 160,
        height: 120,
        spp: 1,
        seed: 7,
        memory_budget_bytes: 1 << 30,
        profile: false,
        max_depth: 2,
    };
    render(scene, &mut methods, &settings, &|_| {}).unwrap()
}

/// Traced visibility (light 0) of `scene` ([`traced_frame`]).
fn visibility(scene: &Scene) -> Vec<f32> {
    traced_frame(scene).visibility.swap_remove(0)
}

fn triangle_bits(scene: &Scene) -> HashSet<[u32; 9]> {
    scene
        .triangles
        .iter()
        .map(|t| {
            let v = [t.v0, t.v1, t.v2].map(|v| v.to_array().map(f32::to_bits));
            [v[0][0], v[0][1], v[0][2], v[1][0], v[1][1], v[1][2], v[2][0], v[2][1], v[2][2]]
        })
        .collect()
}

/// The user's measurement: one 1 m quad out of view at 10^4..10^8 m changed the default
/// image (by up to 27/255 at 10^4 m, black at 10^8 m). Render space is the camera's now, so
/// the visible triangles are stored bit for bit as without the quad, and the traced
/// visibility is the same bits: the bound is 0 (the BVH differs, but traced visibility does
/// not depend on BVH order and shaft culling is exact).
/// Ray origins are offset by each hit's own error bound (no scene-sized epsilon), so nothing
/// else moves either.
#[test]
fn a_far_quad_out_of_view_changes_nothing_visible() {
    let base = default_scene("");
    let base_bits = triangle_bits(&base);
    let base_vis = visibility(&base);
    assert!(base_vis.iter().filter(|&&v| v > 0.0 && v < 1.0).count() > 500, "the test image has penumbrae");
    for x in [1e4, 1e6, 1e8] {
        let scene = default_scene(&far_quad(x));
        assert!(triangle_bits(&scene).is_superset(&base_bits), "at {x:e} m: visible triangles moved");
        let vis = visibility(&scene);
        let max = vis.iter().zip(&base_vis).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert_eq!(max, 0.0, "far quad at {x:e} m changes the traced visibility by {max}");
    }
}

#[test]
fn far_geometry_is_counted_and_warned_about_with_its_precision() {
    let base = default_scene("");
    assert!(base.warnings.is_empty(), "{:?}", base.warnings);
    assert_eq!(base.stats.degenerate_triangles, 0);

    let near = default_scene(&far_quad(1e4));
    assert_eq!(near.stats.triangles, base.stats.triangles + 2);
    assert!(near.warnings.is_empty(), "1 m at 10^4 m is kept to 1e-3 m: {:?}", near.warnings);

    let mid = default_scene(&far_quad(1e6));
    assert_eq!((mid.stats.triangles, mid.stats.imprecise_triangles), (base.stats.triangles + 2, 2));
    let w = mid.warnings.join("\n");
    assert!(w.contains("2 triangle(s) too far from the camera") && w.contains("6.250e-2 m"), "{w}");

    let far = default_scene(&far_quad(1e8));
    assert_eq!((far.stats.triangles, far.stats.collapsed_in_f32), (base.stats.triangles, 2));
    assert_eq!(far.stats.degenerate_triangles, 2);
    let w = far.warnings.join("\n");
    assert!(w.contains("2 triangle(s) dropped: too small for f32") && w.contains("8.000e0 m"), "{w}");

    // The render adds how precise the visible part is.
    let mut methods: Vec<Box<dyn LightShadowing>> = vec![Box::new(renderer::Unshadowed {})];
    let settings = RenderSettings {
        width: 32,
        height: 24,
        spp: 1,
        seed: 0,
        memory_budget_bytes: 1 << 30,
        profile: false,
        max_depth: 2,
    };
    let frame = render(&mid, &mut methods, &settings, &|_| {}).unwrap();
    let line = frame.warnings.iter().find(|w| w.starts_with("the visible part")).expect("a precision line");
    // The farthest visible point is the back wall's corner, 6.3 m away: spacing 2^-21 m.
    assert!(line.contains(", where f32 positions are spaced 4.768e-7 m; 0 of 768 visible"), "{line}");
}

/// A scene of one floor quad, a card and a light, every length scaled by `s`, camera too.
fn scaled_scene(s: f64) -> String {
    format!(
        r#"
[camera]
position = [0.0, {cy:e}, {cz:e}]
look_at = [0.0, 0.0, 0.0]
[image]
width = 40
height = 30
[[quad]]
center = [0.0, 0.0, 0.0]
u = [{f:e}, 0.0, 0.0]
v = [0.0, 0.0, {nf:e}]
[[quad]]
center = [0.0, {h:e}, 0.0]
u = [{c:e}, 0.0, 0.0]
v = [0.0, 0.0, {nc:e}]
[[light]]
center = [0.0, {ly:e}, 0.0]
u = [{l:e}, 0.0, 0.0]
v = [0.0, 0.0, {l:e}]
radiance = [1.0, 1.0, 1.0]
"#,
        cy = 2.0 * s,
        cz = 3.0 * s,
        f = 4.0 * s,
        nf = -4.0 * s,
        h = 0.5 * s,
        c = 0.5 * s,
        nc = -0.5 * s,
        ly = 1.5 * s,
        l = 0.5 * s,
    )
    .replace("v = [0.0, 0.0, ", "v = [0.0, 0.0, ")
}

fn load_text(text: &str) -> Result<Scene, renderer::SceneError> {
    let path = Path::new("scaled.toml");
    Scene::load(&SceneFile::parse(text, path)?, path)
}

/// A 1e-20 m and a 1e20 m scene are real geometry: all four triangles kept, none dropped,
/// no warning (each triangle is precise relative to its own size, the camera being as near
/// as the scene is small).
#[test]
fn tiny_and_huge_triangles_are_kept() {
    for s in [1e-20, 1.0, 1e20] {
        let scene = load_text(&scaled_scene(s)).unwrap_or_else(|e| panic!("scale {s:e}: {e}"));
        assert_eq!((scene.stats.triangles, scene.stats.degenerate_triangles), (4, 0), "scale {s:e}");
        assert!(scene.warnings.is_empty(), "scale {s:e}: {:?}", scene.warnings);
        assert!(scene.lights[0].normal.is_finite() && scene.lights[0].normal.y < -0.99, "scale {s:e}");
    }
}

/// Rendering them: the visibility at 1e-20 and 1e20 equals the unit scene's (same bits up to
/// f32 rounding: the tolerance is 1/64, one of 64 light samples flipping at an edge, on at
/// most 1% of the pixels). At these scales the ray-triangle test's edge functions and a shadow
/// ray's squared length leave f32's range: the first are always f64, the second rescaled.
#[test]
fn tiny_and_huge_scenes_render_as_the_unit_scene() {
    let vis = |s: f64| visibility(&load_text(&scaled_scene(s)).unwrap());
    let unit = vis(1.0);
    assert!(unit.iter().any(|&v| v > 0.0));
    for s in [1e-20, 1e20] {
        let v = vis(s);
        let bad = v.iter().zip(&unit).filter(|(a, b)| (*a - *b).abs() > 1.0 / 64.0).count();
        assert!(bad <= unit.len() / 100, "scale {s:e}: {bad} pixels differ");
    }
}

/// A zero-area triangle is dropped and named; a quad too small for f32 at its distance from
/// the camera is dropped and named with the spacing there.
#[test]
fn dropped_triangles_are_warned_about() {
    let unit = scaled_scene(1.0);
    // 1e-20 m wide, 0.5 m from the camera's origin-centred space: f32 spacing there is 6e-8 m.
    let tiny =
        format!("{unit}\n[[quad]]\ncenter = [0.0, 0.1, 0.0]\nu = [1e-20, 0.0, 0.0]\nv = [0.0, 0.0, 1e-20]\n");
    let scene = load_text(&tiny).unwrap();
    assert_eq!((scene.stats.triangles, scene.stats.collapsed_in_f32), (4, 2));
    assert!(
        scene.warnings[0].starts_with("2 triangle(s) dropped: too small for f32"),
        "{:?}",
        scene.warnings
    );

    let mut geometry = renderer::load::gltf_load::Geometry::default();
    let p = glam::DVec3::new(0.0, 0.0, -1.0);
    geometry.triangles.push(renderer::load::gltf_load::SourceTriangle {
        p: [p, p + glam::DVec3::X, p + 2.0 * glam::DVec3::X],
        n: None,
        uv: [glam::Vec2::ZERO; 3],
        material: 0,
        origin: renderer::geometry::instances::TriangleOrigin::LOOSE,
    });
    geometry.materials.push(renderer::geometry::material::Material::diffuse([0.5; 3]));
    let camera = renderer::Camera::look_at(glam::Vec3::ZERO, -glam::Vec3::Z, glam::Vec3::Y, 40.0);
    let scene = Scene::build(geometry, vec![], camera, glam::DVec3::ZERO, Default::default());
    assert_eq!((scene.stats.triangles, scene.stats.zero_area), (0, 1));
    assert_eq!(scene.warnings, ["1 triangle(s) dropped: zero area (repeated or collinear vertices)"]);
}

/// The default scene with its 12 m floor enlarged to `size` metres a side: what users write
/// for "an infinite floor".
fn huge_floor_scene(size: f64) -> Scene {
    let floor = "u = [12.0, 0.0, 0.0]\nv = [0.0, 0.0, -12.0]";
    assert!(penumbra::DEFAULT_SCENE.contains(floor));
    let text = penumbra::DEFAULT_SCENE.replacen(
        floor,
        &format!("u = [{size:e}, 0.0, 0.0]\nv = [0.0, 0.0, {:e}]", -size),
        1,
    );
    let path = Path::new("scenes/default.toml");
    Scene::load(&SceneFile::parse(&text, path).unwrap(), path).unwrap()
}

/// Traced visibility and radiance of `scene` ([`traced_frame`]).
fn frame_of(scene: &Scene) -> (Vec<f32>, Vec<glam::Vec3>) {
    let mut frame = traced_frame(scene);
    (frame.visibility.swap_remove(0), frame.radiance)
}

/// The user's report: the default scene's floor enlarged to 10^6 m put 1.35% of pixels'
/// visibility off by more than 0.1 (a speckled floor, acne), 10^8 m 41% (black streaks,
/// holes where primary rays missed the floor), and from 10^12 m every shadow was gone. Hit
/// points now come from f64 barycentrics (their error the rounding to f32 at the hit, not
/// the triangle's size), so up to 10^12 m the image is the 100 m floor's: the same hits (-1
/// where a primary ray misses), visibility within 0.003 mean and 0.2% of the pixels off by
/// more than 0.1 (one of 64 samples flipping where a hit moves by its rounding), radiance
/// within the same bounds relative to the pixel (measured: 0 at 10^4..10^8 m, 3e-5 mean
/// visibility at 10^12 m, 0 pixels off). Beyond, the intersector's own f64 rounding of t
/// (~1e-14 of the floor's reach) exceeds the camera's height: the load warns, naming the
/// triangle.
#[test]
fn a_huge_floor_renders_as_a_small_one_or_is_named() {
    let (base_vis, base_rgb) = frame_of(&huge_floor_scene(100.0));
    for size in [1e4, 1e6, 1e8, 1e12, 1e14, 1e20] {
        let scene = huge_floor_scene(size);
        let named = scene
            .warnings
            .iter()
            .any(|w| w.contains("too large for the intersector") && w.contains("corner at"));
        assert_eq!(named, size > 1e12, "floor {size:e} m: {:?}", scene.warnings);
        let (vis, rgb) = frame_of(&scene);
        let n = vis.len() as f64;
        let hits_differ = vis.iter().zip(&base_vis).filter(|(a, b)| (**a < 0.0) != (**b < 0.0)).count();
        let mean = vis.iter().zip(&base_vis).map(|(a, b)| (a - b).abs() as f64).sum::<f64>() / n;
        let off = vis.iter().zip(&base_vis).filter(|(a, b)| (*a - *b).abs() > 0.1).count() as f64 / n;
        let rel =
            |a: glam::Vec3, b: glam::Vec3| ((a - b).abs().max_element() / b.max_element().max(1e-3)) as f64;
        let rgb_mean = rgb.iter().zip(&base_rgb).map(|(a, b)| rel(*a, *b)).sum::<f64>() / n;
        let rgb_off = rgb.iter().zip(&base_rgb).filter(|(a, b)| rel(**a, **b) > 0.1).count() as f64 / n;
        eprintln!(
            "floor {size:e} m: hits differ {hits_differ}, visibility mean {mean:.5}, off {:.3}%, radiance mean \
             {rgb_mean:.5}, off {:.3}%, named {named}",
            100.0 * off,
            100.0 * rgb_off,
        );
        if named {
            continue;
        }
        assert_eq!(hits_differ, 0, "floor {size:e} m");
        assert!(mean <= 0.003 && off <= 0.002, "floor {size:e} m: visibility mean {mean}, {off} off");
        assert!(
            rgb_mean <= 0.003 && rgb_off <= 0.002,
            "floor {size:e} m: radiance mean {rgb_mean}, {rgb_off} off"
        );
    }
}

/// Shadow rays `traced` casts for the default scene with `extra` appended
/// ([`traced_frame`]), and the scene's triangle count.
fn shadow_rays(extra: &str) -> (u64, u64) {
    let scene = default_scene(extra);
    (traced_frame(&scene).counters["shadow_rays"], scene.stats.triangles)
}

/// The user's report: one 1 m quad out of view at 10^6 m made every render ~9x slower
/// (13.5x the shadow rays), and a quad at 10^20 m under the floor or a model scaled by
/// 10^30 ~10x: the shafts' margin grew with the scene's largest coordinate, so culling
/// stopped. Margins now follow each triangle's own distance, so far geometry costs only its
/// own culling: the rays within 1.3x of the scene without it (measured: equal).
#[test]
fn far_or_huge_geometry_out_of_view_costs_no_rays() {
    let dir = common::gltf_writer::TempDir::new("far_or_huge_geometry");
    let mut b = common::gltf_writer::GltfBuilder::new();
    let pos = b.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, -1.0], [0.0, 0.0, -1.0]]);
    let idx = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let mesh = b.mesh(vec![common::gltf_writer::primitive(&[("POSITION", pos)], Some(idx), 4, None)]);
    let node = b.node(serde_json::json!({ "mesh": mesh }));
    let scene = b.scene(&[node]);
    b.set_default_scene(scene);
    let model = b.write(&dir.path, "quad");
    let (base, triangles) = shadow_rays("");
    for (what, extra) in [
        ("a 1 m quad at 10^6 m", far_quad(1e6)),
        (
            "a 10^6 m quad 10^20 m under the floor",
            "[[quad]]\ncenter = [0.0, -1e20, 0.0]\nu = [1e6, 0.0, 0.0]\nv = [0.0, 0.0, -1e6]\n".to_string(),
        ),
        (
            "a model scaled by 10^30, out of view",
            format!("[[model]]\npath = {:?}\nscale = 1e30\ntranslate = [5e30, 0.0, 0.0]\n", model.display()),
        ),
    ] {
        let (rays, with) = shadow_rays(&extra);
        eprintln!("{what}: {rays} shadow rays, {base} without it");
        assert_eq!(with, triangles + 2, "{what}: its two triangles are kept");
        assert!(rays as f64 <= 1.3 * base as f64, "{what}: {rays} shadow rays against {base}");
    }
}

/// The user's report: the default scene's floor enlarged to 10^10 or 10^12 m, or one 10^19 m
/// quad hidden 1 m under it, made `traced` cast 6.9x the shadow rays (3-5x the time): the
/// shaft test's triangle-plane axis squared the huge triangle's normal in f32, which
/// overflowed (edges over ~4e9 m), so no shaft beside it could be proven clear. That axis now
/// falls back to f64 there: the rays within 1.3x of the 12 m floor's (measured: equal, and
/// 1.00002x at 10^12 m).
#[test]
fn a_huge_triangle_beside_the_points_costs_no_rays() {
    let base = traced_frame(&default_scene("")).counters["shadow_rays"];
    let hidden = "[[quad]]\ncenter = [0.0, -1.0, 0.0]\nu = [1e19, 0.0, 0.0]\nv = [0.0, 0.0, -1e19]\n";
    for (what, scene) in [
        ("a 10^10 m floor", huge_floor_scene(1e10)),
        ("a 10^12 m floor", huge_floor_scene(1e12)),
        ("a 10^19 m quad under the floor", default_scene(hidden)),
    ] {
        let rays = traced_frame(&scene).counters["shadow_rays"];
        eprintln!("{what}: {rays} shadow rays, {base} with the 12 m floor");
        assert!(rays as f64 <= 1.3 * base as f64, "{what}: {rays} shadow rays against {base}");
    }
}

/// `edge_table`'s depth map keeps one rounding margin for every triangle, from the scene's
/// largest coordinate, so far geometry costs it rays (a 1 m quad at 10^6 m: 1.9x; `traced`
/// and `silhouette` 1.0x): the render says so in a warning, and not for the scene alone.
#[test]
fn edge_table_warns_where_far_geometry_widens_its_margins() {
    let dir = common::gltf_writer::TempDir::new("edge_table_far_margin");
    let warned = |extra: &str| {
        let scene = dir.join("s.toml");
        std::fs::write(&scene, format!("{}\n{extra}", penumbra::DEFAULT_SCENE)).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_penumbra"))
            .args([
                "render",
                scene.to_str().unwrap(),
                "--shadows",
                "edge_table",
                "--width",
                "64",
                "--height",
                "48",
            ])
            .arg("--out")
            .arg(dir.join("s.png"))
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stderr)
            .lines()
            .any(|l| l.contains("edge_table: geometry") && l.contains("widens"))
    };
    assert!(!warned(""), "the default scene alone");
    assert!(warned(&far_quad(1e6)), "a 1 m quad at 10^6 m");
}

/// `edge_table`'s work (shadow rays traced, edge lookups) on the default scene with its floor
/// enlarged, 160 x 120 at 64 samples.
fn edge_table_work(size: f64) -> u64 {
    let edge_table = shadow_plugin::EdgeTable::new(shadow_plugin::EdgeTableParams::default(), 64);
    let frame = frame_with(&huge_floor_scene(size), Box::new(edge_table));
    let c = &frame.counters;
    ["shadow_rays", "fallback_shadow_rays", "edge_lookups"]
        .iter()
        .map(|k| c.get(*k).copied().unwrap_or(0))
        .sum()
}

/// The user's report: `edge_table` on the default scene with a 10^6 m floor cost 19-31x its
/// cost at 10^5 m (164 MB of masks, 65.6 M edge lookups against 0.26 M): the depth map's
/// scene-sized rounding margins (1.9 m against the light's 4.3 m reach) sent the masks
/// marching ever further. Past 1/8 of the reach no map is built and every ray is traced: the
/// work within 1.5x of the 10^5 m floor's (measured: 0.62x; before, 113x).
#[test]
fn edge_table_has_no_cliff_at_a_huge_floor() {
    let base = edge_table_work(1e5);
    for size in [3e5, 1e6, 1e7] {
        let work = edge_table_work(size);
        eprintln!("floor {size:e} m: {work} rays and lookups, {base} at 10^5 m");
        assert!(work as f64 <= 1.5 * base as f64, "floor {size:e} m: {work} against {base}");
    }
}

/// A mesh placed twice, once by a node whose 3e38 scale takes it out of f32's range: those
/// triangles are dropped with one warning naming the node (not "farther from the camera than
/// f32 can hold" or "zero area"), whether the placements are kept as instances or flattened,
/// and counted alike.
#[test]
fn a_node_placing_its_mesh_beyond_f32_is_named_kept_or_flattened() {
    use common::gltf_writer::{GltfBuilder, TRIANGLES, TempDir, primitive};
    let dir = TempDir::new("precision-node-overflow");
    let mut b = GltfBuilder::new();
    let pos = b.positions(&[[-5.0, 0.0, -5.0], [5.0, 0.0, -5.0], [5.0, 0.0, 5.0], [-5.0, 0.0, 5.0]]);
    let idx = b.indices_u16(&[0, 2, 1, 0, 3, 2]);
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], Some(idx), TRIANGLES, None)]);
    let near = b.node(serde_json::json!({"mesh": mesh}));
    let far = b.node(serde_json::json!({"mesh": mesh, "scale": [3e38, 3e38, 3e38]}));
    let s = b.scene(&[near, far]);
    b.set_default_scene(s);
    b.write(&dir.path, "pair");
    let text = format!("[[model]]\npath = \"pair.gltf\"\n{}", penumbra::DEFAULT_SCENE);
    let path = dir.join("scene.toml");
    let file = SceneFile::parse(&text, &path).unwrap();
    let load = |keep| Scene::load_with(&file, &path, LoadOptions { memory_limit: None, keep }).unwrap();
    let (flat, kept) = (load(KeepInstances::Never), load(KeepInstances::Always));
    assert!(kept.instanced.is_some(), "the placements are kept");
    for scene in [&flat, &kept] {
        let named: Vec<_> = scene.warnings.iter().filter(|w| w.contains("overflows f32")).collect();
        assert_eq!(named.len(), 1, "{:?}", scene.warnings);
        assert!(named[0].contains("pair.gltf: the transform of nodes[1] overflows f32"), "{named:?}");
        assert!(named[0].contains("2 triangle(s) dropped"), "{named:?}");
        assert!(!scene.warnings.iter().any(|w| w.contains("than f32 can hold") || w.contains("zero area")));
    }
    assert_eq!(flat.stats.triangles, kept.stats.triangles);
    assert_eq!(flat.stats.degenerate_triangles, 2);
    assert_eq!(kept.stats.degenerate_triangles, 2);
}
