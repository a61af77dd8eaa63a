//! The path-tracing host: an integrating sphere against its analytic balance, max_depth = 2
//! as the direct-light formula bit for bit, convergence with spp, and the same bytes for any
//! thread count.

use crate::common;

use common::sphere::sphere;
use glam::{DVec3, Vec3};
use renderer::geometry::material::Shading;
use renderer::{
    Camera, Frame, LightShadowing, RectLight, RenderSettings, Scene, Traced, TracedParams, render,
};

fn traced(scene: &Scene, samples: u32) -> Vec<Box<dyn LightShadowing>> {
    scene
        .lights
        .iter()
        .map(|_| Box::new(Traced::new(TracedParams::CULLED, samples)) as Box<dyn LightShadowing>)
        .collect()
}

fn frame(scene: &Scene, settings: &RenderSettings) -> Frame {
    render(scene, &mut traced(scene, 16), settings, &|_| {}).unwrap()
}

fn settings(width: u32, height: u32, spp: u32, max_depth: u32) -> RenderSettings {
    RenderSettings { width, height, spp, seed: 1, memory_budget_bytes: 1 << 30, profile: false, max_depth }
}

/// In a closed sphere of albedo rho every point sees every area element under the same
/// kernel 1 / (4 pi R^2), so the light the walls reflect onto each other is the same
/// everywhere: E_walls = rho / (1 - rho) * Phi / A, with Phi = pi L_e A_light the light's
/// flux (all of it lands on the walls). The indirect radiance rho / pi * E_walls is what a
/// deep path adds to the direct-light image (the same direct bits: same seeds). Within 1%.
#[test]
fn an_integrating_sphere_holds_its_analytic_balance() {
    let rho = 0.5f32;
    let geometry = sphere(1.0, 4, rho, false);
    let area: f64 =
        geometry.triangles.iter().map(|t| 0.5 * (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length()).sum();
    let l_e = 10.0f32;
    // A small light at the centre, facing down.
    let light =
        RectLight::new(Vec3::ZERO, Vec3::new(0.2, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.2), Vec3::splat(l_e));
    let a_light = light.area() as f64;
    let camera = Camera::look_at(Vec3::new(0.0, -0.3, 0.0), Vec3::new(1.0, -0.5, 0.2), Vec3::Y, 70.0);
    let mut scene = Scene::build(geometry, vec![light], camera, DVec3::ZERO, Default::default());
    // The balance is the Lambertian walls'.
    scene.shading_mode = Shading::Diffuse;
    let deep = frame(&scene, &settings(64, 64, 64, 64));
    let direct = frame(&scene, &settings(64, 64, 64, 2));
    let n = deep.radiance.len() as f64;
    let measured: f64 =
        deep.radiance.iter().zip(&direct.radiance).map(|(d, s)| (d.x - s.x) as f64).sum::<f64>() / n;
    let expected = (rho * rho) as f64 * l_e as f64 * a_light / ((1.0 - rho) as f64 * area);
    println!(
        "integrating sphere: indirect radiance {measured:.6}, analytic {expected:.6} ({:+.2}%)",
        100.0 * (measured / expected - 1.0)
    );
    assert!((measured / expected - 1.0).abs() < 0.01, "{measured} against {expected}");
    // Grey in, grey out: the channels agree bit for bit.
    assert!(deep.radiance.iter().all(|c| c.x == c.y && c.y == c.z));
}

/// The default scene, shaded Lambertian (the formula below is the diffuse renderer's).
fn default_scene() -> Scene {
    let mut file =
        renderer::SceneFile::parse(penumbra::DEFAULT_SCENE, std::path::Path::new("default.toml")).unwrap();
    file.materials.shading = Shading::Diffuse;
    Scene::load(&file, std::path::Path::new("default.toml")).unwrap()
}

/// max_depth = 2 is the direct-light renderer: each pixel's radiance is albedo x L x E x V /
/// pi of its primary hit, in that order of operations, bit for bit; deeper paths only add.
#[test]
fn max_depth_two_is_the_direct_light_formula_bit_for_bit() {
    let scene = default_scene();
    let (w, h) = (64u32, 48u32);
    let two = frame(&scene, &settings(w, h, 1, 2));
    let five = frame(&scene, &settings(w, h, 1, 5));
    let light = &scene.lights[0];
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let d = scene.camera.ray_direction(x as f32 + 0.5, y as f32 + 0.5, w, h).normalize();
            let ray = obvhs::ray::Ray::new(scene.camera.position.into(), d.into(), 0.0, f32::INFINITY);
            let Some(hit) = scene.intersect(ray) else { continue };
            let e = light.irradiance_factor(hit.point.p, hit.point.n_shading);
            let v = two.visibility[0][i];
            let expected = if e > 0.0 {
                scene.albedo(&hit) * light.radiance * (e * v) * std::f32::consts::FRAC_1_PI
            } else {
                Vec3::ZERO
            };
            assert_eq!(two.radiance[i], expected, "pixel ({x}, {y})");
            assert!(
                five.radiance[i].cmpge(two.radiance[i]).all(),
                "pixel ({x}, {y}): indirect light only adds"
            );
            checked += 1;
        }
    }
    assert!(checked > 1000);
    // The visibility AOV is the primary hits' either way.
    assert_eq!(two.visibility, five.visibility);
    let brighter = five.radiance.iter().zip(&two.radiance).filter(|(a, b)| a != b).count();
    // The scene is open: a floor bounce mostly leaves it (one path per pixel here); about a
    // third of the pixels catch a wall or an object (993 of 3072 when written).
    assert!(brighter * 5 > checked, "{brighter} of {checked} pixels gained indirect light");
}

fn rmse(a: &[Vec3], b: &[Vec3]) -> f64 {
    let s: f64 = a.iter().zip(b).map(|(x, y)| (*x - *y).length_squared() as f64).sum();
    (s / a.len() as f64).sqrt()
}

/// Image RMSE against a 1024-spp reference halves for 4x the spp (the reference's own noise
/// adds about 3% at 64 spp: the band is 0.40 to 0.60).
#[test]
fn path_traced_images_converge_with_spp() {
    let scene = default_scene();
    let reference = frame(&scene, &RenderSettings { seed: 99, ..settings(24, 18, 1024, 5) });
    let at = |spp: u32| rmse(&frame(&scene, &settings(24, 18, spp, 5)).radiance, &reference.radiance);
    let (e16, e64) = (at(16), at(64));
    println!("image RMSE: spp 16 {e16:.5}, spp 64 {e64:.5}, ratio {:.3}", e64 / e16);
    assert!((0.40..=0.60).contains(&(e64 / e16)), "{e16} -> {e64}");
}

#[test]
fn paths_give_the_same_bytes_with_any_thread_count() {
    let scene = default_scene();
    let s = settings(40, 30, 4, 5);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| frame(&scene, &s))
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.radiance, two.radiance);
    assert_eq!(one.counters, two.counters);
    assert!(one.counters["shadow_queries_vertex_2"] > 0);
}
