//! Every scene of ../shared/gltf loads and renders with the traced method (small images),
//! and its pixels are sane: finite, non-negative radiance; visibility in [0, 1] or -1; some
//! of the frame lit and some of it in shadow.

use penumbra::methods::METHODS;
use penumbra::{RenderArgs, run_render};
use std::path::PathBuf;

use crate::common::{self, shared};

/// This file's tests all read ../shared: their entry in `shared::READERS`.
const READER: &str = "shared_scenes (all 12)";

fn render_small(scene: &str) -> (Vec<f32>, Vec<f32>) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = std::env::temp_dir().join(format!("penumbra-shared-{}", std::process::id()));
    let stem = scene.trim_end_matches(".toml");
    let out = dir.join(format!("{stem}.png"));
    let args = RenderArgs {
        scene: Some(root.join("scenes/gltf").join(scene)),
        keys: penumbra::request::Overrides {
            samples: Some(16),
            width: Some(64),
            height: Some(48),
            ..Default::default()
        },
        out: Some(out.clone()),
        aov: true,
        quiet: true,
        ..Default::default()
    };
    let outcome = run_render(&args).unwrap_or_else(|e| panic!("{scene}: {e}"));
    assert!(outcome.report.triangles > 0);
    let radiance = image::open(&out).unwrap().into_rgb32f().into_raw();
    let exr = image::open(out.with_extension("exr")).unwrap().into_rgb32f().into_raw();
    assert_eq!(radiance.len(), exr.len());
    let vis = image::open(out.with_extension("visibility.0.exr")).unwrap().into_rgb32f().into_raw();
    for suffix in ["png", "exr", "json", "visibility.0.exr"] {
        let _ = std::fs::remove_file(out.with_extension(suffix));
    }
    (exr, vis)
}

fn check(scene: &str) {
    if !shared::scenes_present(READER) {
        return;
    }
    let (radiance, vis) = render_small(scene);
    assert!(radiance.iter().all(|v| v.is_finite() && *v >= 0.0), "{scene}: bad radiance");
    let hits: Vec<f32> = vis.iter().step_by(3).copied().filter(|&v| v != -1.0).collect();
    assert!(hits.iter().all(|v| (0.0..=1.0).contains(v)), "{scene}: visibility out of range");
    assert!(hits.len() > 64 * 48 / 10, "{scene}: only {} pixels hit anything", hits.len());
    let lit = hits.iter().filter(|&&v| v > 0.9).count();
    let shadowed = hits.iter().filter(|&&v| v < 0.5).count();
    assert!(lit > 0 && shadowed > 0, "{scene}: {lit} lit and {shadowed} shadowed pixels");
    assert!(radiance.iter().any(|&v| v > 0.0), "{scene}: black image");
}

macro_rules! scene_tests {
    ($($name:ident => $file:literal),* $(,)?) => {
        $( #[test] fn $name() { check($file); } )*
    };
}

scene_tests! {
    cornell_box => "cornell-box.toml",
    flight_helmet => "flight-helmet.toml",
    fox => "fox.toml",
    glass_vase_flowers => "glass-vase-flowers.toml",
    metal_rough_spheres => "metal-rough-spheres.toml",
    monobloc_chair => "monobloc-chair.toml",
    palm_tree => "palm-tree.toml",
    sauerbraten_zdm2 => "sauerbraten-zdm2.toml",
    sheen_chair_floor => "sheen-chair-floor.toml",
    toy_car => "toy-car.toml",
}

/// Every scene file in `scenes/gltf`, sorted (at least the ten shared scenes).
fn shared_scene_files() -> Vec<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/gltf");
    let mut names: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 10, "{names:?}");
    names
}

/// Shaft culling (`[shadows.traced] shaft_culling`, on by default) is exact: on every shared
/// scene, culled and plain traced give the same visibility bits at every pixel, and culling
/// skips rays (64x48, 1024 samples: every level of the light's split is tested, down to
/// its 4x4 parts of 64 samples).
#[test]
fn shaft_culled_traced_gives_the_plain_traced_bits_on_every_shared_scene() {
    use renderer::{LightShadowing, RenderSettings, Scene, SceneFile, Traced, TracedParams, render};
    if !shared::scenes_present(READER) {
        return;
    }
    let names = shared_scene_files();
    let settings = RenderSettings {
        width: 64,
        height: 48,
        spp: 1,
        seed: 3,
        memory_budget_bytes: u64::MAX,
        profile: false,
        max_depth: 2,
    };
    // Outside CI (common::full_sweeps) every other scene, the ones the test above skips most.
    for (k, path) in names.into_iter().enumerate() {
        if !common::sweep_keeps(k, 1) {
            continue;
        }
        let file = SceneFile::load(&path).unwrap();
        let scene = Scene::load(&file, &path).unwrap();
        let run = |shaft_culling: bool| {
            let mut methods: Vec<Box<dyn LightShadowing>> = scene
                .lights
                .iter()
                .map(|_| Box::new(Traced::new(TracedParams { shaft_culling }, 1024)) as _)
                .collect();
            render(&scene, &mut methods, &settings, &|_| {}).unwrap()
        };
        let (plain, culled) = (run(false), run(true));
        for (k, (a, b)) in plain.visibility.iter().zip(&culled.visibility).enumerate() {
            let differ = a.iter().zip(b).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
            assert_eq!(differ, 0, "{}: light {k}: {differ} pixels differ", path.display());
        }
        let (rp, rc) = (plain.counters["shadow_rays"], culled.counters["shadow_rays"]);
        assert!(rc < rp, "{}: culled {rc} rays, plain {rp}", path.display());
    }
}

/// Every shared scene renders with indirect light under every shadow method, through the
/// command line as users run it (`--max-depth 5`, 2 spp here, small), the same bytes with 1
/// and 2 threads; the paths' bounces add light, and each method answers secondary queries.
#[test]
fn every_shared_scene_path_traces_with_every_method_deterministically() {
    if !shared::scenes_present(READER) {
        return;
    }
    let names = shared_scene_files();
    let dir = std::env::temp_dir().join(format!("penumbra-paths-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Outside CI (common::full_sweeps) each scene with one method in three, rotating, so that
    // each method still meets a third of the scenes.
    for (i, path) in names.iter().enumerate() {
        for (j, method) in METHODS.iter().map(|m| m.name).enumerate() {
            if !common::sweep_keeps_one_in(3, i + j, 0) {
                continue;
            }
            let run = |threads: u32| {
                let out = dir.join(format!("{method}-{threads}.png"));
                let args = penumbra::RenderArgs {
                    scene: Some(path.clone()),
                    keys: penumbra::request::Overrides {
                        shadows: Some(method.into()),
                        samples: Some(16),
                        width: Some(32),
                        height: Some(24),
                        spp: Some(2),
                        max_depth: Some(5),
                        ..Default::default()
                    },
                    threads: Some(threads),
                    out: Some(out.clone()),
                    quiet: true,
                    ..Default::default()
                };
                let outcome =
                    penumbra::run_render(&args).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                (std::fs::read(out.with_extension("exr")).unwrap(), outcome.report.counters)
            };
            let ((one, counters), (two, _)) = (run(1), run(2));
            assert!(one == two, "{} {method}: 1 and 2 threads differ", path.display());
            assert!(
                counters["shadow_queries_vertex_2"] > 0,
                "{} {method}: no secondary query",
                path.display()
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
