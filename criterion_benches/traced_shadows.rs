//! Shadow-ray throughput of the traced method and BVH build time, on two scenes of
//! ../shared/gltf, measured on one thread (criterion's calling thread), so the throughput
//! it prints is shadow rays per second per core.
//!
//! Also the measurement behind the BVH choice (ARCHITECTURE.md): Bvh2 against CwBvh on the
//! same rays, and the build presets.
//!
//! Run: `cargo bench -p criterion_benches --bench traced_shadows` (about 3 minutes).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Vec3, Vec3A};
use obvhs::{BvhBuildParams, ray::Ray};
use renderer::geometry::ray_origin::shadow_ray;
use renderer::util::random::{Rng, stream_seed};
use renderer::{Scene, SceneFile};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

const SCENES: [&str; 2] = [
    concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/gltf/sauerbraten-zdm2.toml"),
    concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/gltf/flight-helmet.toml"),
];

/// Shadow rays in pixel order, as the renderer traces them: a 160 x 120 frame, 16 jittered
/// light samples per primary hit that the light reaches (above the horizon only).
fn shadow_rays(scene: &Scene) -> Vec<Ray> {
    let (w, h) = (160u32, 120u32);
    let light = scene.lights[0];
    let mut rays = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let d = scene.camera.ray_direction(x as f32 + 0.5, y as f32 + 0.5, w, h).normalize();
            let ray = Ray::new(Vec3A::from(scene.camera.position), Vec3A::from(d), 0.0, f32::INFINITY);
            let Some(hit) = scene.intersect(ray) else { continue };
            if light.irradiance_factor(hit.point.p, hit.point.n_shading) <= 0.0 {
                continue;
            }
            let mut rng = Rng::new(stream_seed(&[(y * w + x) as u64]));
            for i in 0..16 {
                let a = ((i % 4) as f32 + rng.next_f32()) / 4.0;
                let b = ((i / 4) as f32 + rng.next_f32()) / 4.0;
                let target: Vec3 = light.point(a, b);
                if hit.point.n_shading.dot(target - hit.point.p) <= 0.0 {
                    continue;
                }
                let target_error = light.point_error(a, b);
                if let Some(r) = shadow_ray(&hit.point, target, target_error, light.normal) {
                    rays.push(r);
                }
            }
        }
    }
    rays
}

fn load(path: &str) -> Scene {
    let path = Path::new(path);
    let file = SceneFile::load(path).unwrap_or_else(|e| panic!("{e}"));
    Scene::load(&file, path).unwrap_or_else(|e| panic!("{e}"))
}

fn bench(c: &mut Criterion) {
    for scene_path in SCENES {
        let name = Path::new(scene_path).file_stem().unwrap().to_string_lossy().into_owned();
        let scene = load(scene_path);
        let rays = shadow_rays(&scene);
        let occluded = rays.iter().filter(|r| scene.occluded(**r)).count();
        eprintln!(
            "{name}: {} triangles, {} shadow rays, {:.1}% occluded",
            scene.triangles.len(),
            rays.len(),
            100.0 * occluded as f64 / rays.len() as f64
        );

        let mut group = c.benchmark_group(format!("shadow_rays/{name}"));
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.sample_size(10).measurement_time(Duration::from_secs(4));
        // The renderer's own path: Bvh2, our triangle test, the alpha test.
        group.bench_function("scene_occluded", |b| {
            b.iter(|| rays.iter().filter(|r| scene.occluded(black_box(**r))).count())
        });
        // Bare traversals with obvhs's triangle test, Bvh2 against CwBvh (same rays).
        let tris = &scene.triangles; // already in Bvh2 order
        let bvh2 = scene.bvh.as_ref().unwrap();
        group.bench_function("bvh2_medium", |b| {
            b.iter(|| {
                rays.iter().filter(|r| !bvh2.ray_traverse_miss(**r, |r, i| tris[i].intersect(r))).count()
            })
        });
        for (preset, params) in
            [("fast", BvhBuildParams::fast_build()), ("slow", BvhBuildParams::slow_build())]
        {
            let other = obvhs::bvh2::builder::build_bvh2_from_tris(tris, params, &mut Duration::default());
            let other_tris: Vec<_> = other.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
            group.bench_function(format!("bvh2_{preset}"), |b| {
                b.iter(|| {
                    rays.iter()
                        .filter(|r| !other.ray_traverse_miss(**r, |r, i| other_tris[i].intersect(r)))
                        .count()
                })
            });
        }
        let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            tris,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let cw_tris: Vec<_> = cw.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
        group.bench_function("cwbvh_medium", |b| {
            b.iter(|| {
                rays.iter().filter(|r| !cw.ray_traverse_miss(**r, |r, i| cw_tris[i].intersect(r))).count()
            })
        });
        group.finish();

        let mut group = c.benchmark_group(format!("bvh_build/{name}"));
        group.sample_size(10).measurement_time(Duration::from_secs(3));
        for (preset, params) in [
            ("fast", BvhBuildParams::fast_build()),
            ("medium", BvhBuildParams::medium_build()),
            ("slow", BvhBuildParams::slow_build()),
        ] {
            group.bench_with_input(BenchmarkId::new("bvh2", preset), &params, |b, p| {
                b.iter(|| obvhs::bvh2::builder::build_bvh2_from_tris(tris, *p, &mut Duration::default()))
            });
        }
        group.bench_function("cwbvh/medium", |b| {
            b.iter(|| {
                obvhs::cwbvh::builder::build_cwbvh_from_tris(
                    tris,
                    BvhBuildParams::medium_build(),
                    &mut Duration::default(),
                )
            })
        });
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
