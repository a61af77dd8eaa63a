//! Smoothed normals: a surface reflects only between directions on one side of its shading
//! plane (pbrt-v4's `SameHemisphere`, Mitsuba 3's two-sided diffuse), at the primary hit and
//! at every path vertex alike.
//!
//! The scene: a floor with flat normals, and above its edge a wall whose vertex normals are
//! all tilted 75 degrees up from its face (`TILT`). Seen from anywhere on the floor, and from
//! the second camera below it, the wall's point lies under its shading plane but over its
//! geometric one, while the light overhead lies over the shading plane. So no light the wall
//! receives may leave it toward the floor or that camera: both answers are exactly zero.

use glam::{DVec3, Vec2, Vec3};
use renderer::geometry::material::Material;
use renderer::load::gltf_load::{Geometry, SourceTriangle};
use renderer::{
    Camera, Frame, LightShadowing, RectLight, RenderSettings, Scene, Traced, TracedParams, render,
};

/// The wall's vertex normals, from its face normal (-x) toward +y.
const TILT_DEG: f32 = 75.0;

/// A quad `corner + s u + t v` (s, t in [0, 1]) as two triangles wound so that `u x v` is
/// their face normal, with vertex normals `n` (None: flat).
fn quad(g: &mut Geometry, corner: DVec3, u: DVec3, v: DVec3, n: Option<Vec3>, material: u32) {
    let p = [corner, corner + u, corner + u + v, corner + v];
    for t in [[p[0], p[1], p[2]], [p[0], p[2], p[3]]] {
        g.triangles.push(SourceTriangle {
            p: t,
            n: n.map(|n| [n; 3]),
            uv: [Vec2::ZERO; 3],
            material,
            origin: renderer::geometry::instances::TriangleOrigin::LOOSE,
        });
    }
}

/// The floor (x in [-1, 1], y = 0, material 0) and the wall (x = 1, y in [1, 3], material 1,
/// normals tilted by `TILT_DEG`), 6 m deep, lit by a 0.5 m light 5 m up, facing down.
/// From any floor point (x, 0, z) a wall point (1, y, z') is at most 2 m away across and at
/// least 1 m up, so the direction back to the floor makes tan = 1/2 or more below the
/// horizontal: under the tilted shading plane (tan(90 - 75) = 0.27) and over the face.
fn scene(camera: Camera) -> Scene {
    let mut g = Geometry::default();
    g.materials.push(Material::diffuse([0.5; 3]));
    g.materials.push(Material::diffuse([0.8; 3]));
    let up = DVec3::Y;
    quad(&mut g, DVec3::new(-1.0, 0.0, -3.0), DVec3::Z * 6.0, DVec3::X * 2.0, None, 0);
    let tilt = TILT_DEG.to_radians();
    let n = Vec3::new(-tilt.cos(), tilt.sin(), 0.0);
    quad(&mut g, DVec3::new(1.0, 1.0, -3.0), DVec3::Z * 6.0, up * 2.0, Some(n), 1);
    let light = RectLight::new(
        Vec3::new(0.5, 5.0, 0.0),
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 0.5),
        Vec3::splat(10.0),
    );
    Scene::build(g, vec![light], camera, DVec3::ZERO, Default::default())
}

fn frame(scene: &Scene, width: u32, spp: u32, max_depth: u32) -> Frame {
    let mut methods: Vec<Box<dyn LightShadowing>> = vec![Box::new(Traced::new(TracedParams::CULLED, 16))];
    let settings = RenderSettings {
        width,
        height: width,
        spp,
        seed: 1,
        memory_budget_bytes: 1 << 30,
        profile: false,
        max_depth,
    };
    render(scene, &mut methods, &settings, &|_| {}).unwrap()
}

/// A camera over the floor sees only the floor; every bounce from it that meets anything
/// meets the wall from under its shading plane, and the light lies over it. With one bounce
/// (max_depth 3) the indirect light is the wall's reflection of the light toward the floor:
/// exactly zero, so the image is the direct-light image bit for bit. (Flipping the shading
/// normal onto the geometric normal's side, the rule before, added 23.9% of the direct
/// light here.)
#[test]
fn a_path_vertex_reflects_no_light_across_its_shading_plane() {
    let camera = Camera::look_at(Vec3::new(0.0, 0.9, 0.0), Vec3::ZERO, Vec3::Z, 90.0);
    let scene = scene(camera);
    let (direct, deep) = (frame(&scene, 32, 16, 2), frame(&scene, 32, 16, 3));
    assert!(direct.visibility[0].iter().all(|&v| v >= 0.0), "every pixel sees the floor");
    let sum = |f: &Frame| f.radiance.iter().map(|c| c.x as f64).sum::<f64>();
    let gained = sum(&deep) / sum(&direct) - 1.0;
    println!("one bounce off the tilted wall: {:+.4}% of the direct light (analytic: 0)", 100.0 * gained);
    assert!(sum(&direct) > 0.0);
    // Tolerance: none. Nothing else is reachable, so any light added crossed the plane.
    assert!(deep.radiance == direct.radiance, "light crossed the wall's shading plane: {gained:+.4}");
}

/// A camera under the wall's shading plane sees it unlit: the light lies over that plane,
/// on the other side of it from the camera. Exactly zero radiance, no tolerance (the rule
/// before lit the whole wall: the "strip seen from below its shading plane").
#[test]
fn a_surface_seen_from_under_its_shading_plane_is_not_lit_from_over_it() {
    let camera = Camera::look_at(Vec3::new(0.0, 0.2, 0.0), Vec3::new(1.0, 2.0, 0.0), Vec3::Y, 60.0);
    let scene = scene(camera);
    let width = 32;
    let f = frame(&scene, width, 1, 2);
    let mut wall = (0, 0.0f64);
    for y in 0..width {
        for x in 0..width {
            let d = scene.camera.ray_direction(x as f32 + 0.5, y as f32 + 0.5, width, width).normalize();
            let ray = obvhs::ray::Ray::new(scene.camera.position.into(), d.into(), 0.0, f32::INFINITY);
            if scene.intersect(ray).is_some_and(|h| h.material == 1) {
                let c = f.radiance[(y * width + x) as usize];
                wall = (wall.0 + 1, wall.1 + c.x as f64);
            }
        }
    }
    println!(
        "wall seen from under its shading plane: {} pixels, mean radiance {:.5}",
        wall.0,
        wall.1 / wall.0 as f64
    );
    assert!(wall.0 > 200, "{} wall pixels", wall.0);
    assert_eq!(wall.1, 0.0, "the wall is lit from across its shading plane");
}
