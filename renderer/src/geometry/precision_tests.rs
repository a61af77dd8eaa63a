//! Precision that does not depend on the scene's size: thin occluders next to surfaces far
//! from the origin, lit planes far from the origin, tiny and huge triangles; and the
//! measurements behind the choice of the ray-origin rule against Wächter & Binder's.

use crate::geometry::camera::Camera;
use crate::geometry::light::RectLight;
use crate::geometry::material::Material;
use crate::geometry::point::ShadingPoint;
use crate::geometry::ray_origin::{point_error, shadow_ray};
use crate::geometry::scene::{LoadStats, Scene, SurfaceHit, TriangleShading, bvh_params};
use crate::geometry::shaft::Shaft;
use crate::interface::shadowing::{LightShadowing, PrepareContext, ShadowQuery};
use crate::load::gltf_load::Geometry;
use crate::methods::traced::{Traced, TracedParams};
use glam::{DQuat, DVec3, EulerRot, Vec2, Vec3, Vec3A};
use obvhs::{ray::Ray, triangle::Triangle};
use std::time::Duration;

/// The rejected alternative, kept to measure against (never used by the renderer):
/// Wächter & Binder, Ray Tracing Gems ch. 6, "A Fast and Robust Method for Avoiding
/// Self-Intersection". Each component moves `256 n_i` ulps (integer arithmetic on its bits),
/// or `n_i / 65536` absolute within 1/32 of the origin; no error bound is carried.
pub(crate) fn wachter_binder_origin(p: Vec3, n_geom: Vec3, toward: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = if toward.dot(n_geom) < 0.0 { -n_geom } else { n_geom };
    let one = |p: f32, n: f32| {
        if p.abs() < ORIGIN {
            return p + FLOAT_SCALE * n;
        }
        let of = (INT_SCALE * n) as i32;
        let of = if p < 0.0 { -of } else { of };
        f32::from_bits((p.to_bits() as i32 + of) as u32)
    };
    Vec3::new(one(p.x, n.x), one(p.y, n.y), one(p.z, n.z))
}

/// A shadow ray by Wächter & Binder's rule: both ends offset by it, nothing else.
fn wachter_binder_ray(hit: &SurfaceHit, target: Vec3, light_normal: Vec3) -> Option<Ray> {
    let o = wachter_binder_origin(hit.point.p, hit.point.n_geom, target - hit.point.p);
    let end = wachter_binder_origin(target, light_normal, o - target);
    let d = end - o;
    let dist = d.length();
    (dist > 0.0).then(|| Ray::new(Vec3A::from(o), Vec3A::from(d / dist), 0.0, dist))
}

/// Which rule a measurement traces with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Rule {
    /// The renderer's: the hit's own error bound ([`crate::geometry::ray_origin`]).
    ErrorBound,
    WachterBinder,
}

/// Plain visibility of `light` from `hit` over an `n x n` grid of sample centres, with
/// `rule`: the fraction of samples above the horizon whose ray is unblocked.
pub(crate) fn plain_visibility(
    scene: &Scene,
    light: &RectLight,
    hit: &SurfaceHit,
    n: u32,
    rule: Rule,
) -> f32 {
    let (mut above, mut clear) = (0, 0);
    for j in 0..n {
        for i in 0..n {
            let (a, b) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let target = light.point(a, b);
            if hit.point.n_shading.dot(target - hit.point.p) <= 0.0 {
                continue;
            }
            above += 1;
            let ray = match rule {
                Rule::ErrorBound => shadow_ray(&hit.point, target, light.point_error(a, b), light.normal),
                Rule::WachterBinder => wachter_binder_ray(hit, target, light.normal),
            };
            clear += usize::from(ray.is_none_or(|r| !scene.occluded(r)));
        }
    }
    if above == 0 { 1.0 } else { clear as f32 / above as f32 }
}

fn prepared(scene: &Scene, mut t: Traced) -> Traced {
    let ctx = PrepareContext::for_light(scene, 0);
    t.prepare(&ctx).unwrap();
    t
}

/// `traced` (plain and shaft-culled, 256 samples) at a hit: both answers, which must agree.
fn traced_at(scene: &Scene, hit: &SurfaceHit, seed: u64) -> f32 {
    let q = ShadowQuery { point: hit.point, pixel: [0, 0], seed, irradiance: 0.0 };
    let plain = prepared(scene, Traced::new(TracedParams::PLAIN, 256)).visibility(scene, &q);
    let culled = prepared(scene, Traced::new(TracedParams::CULLED, 256)).visibility(scene, &q);
    assert_eq!(plain.to_bits(), culled.to_bits(), "plain {plain} culled {culled} at {}", hit.point.p);
    plain
}

/// A scene of quads (local center, u, v), turned by `turn` about the origin: render space
/// = world, no recentring, so positions keep their magnitude.
fn turned_scene(
    quads: &[(DVec3, DVec3, DVec3)],
    light: (DVec3, DVec3, DVec3),
    turn: DQuat,
    shift: DVec3,
) -> Scene {
    let to_world = |x: DVec3| turn * x + shift;
    let mut g = Geometry::default();
    for &(c, u, v) in quads {
        g.add_quad(to_world(c), turn * u, turn * v, [0.5; 3]);
    }
    let light = RectLight::new(
        to_world(light.0).as_vec3(),
        (turn * light.1).as_vec3(),
        (turn * light.2).as_vec3(),
        Vec3::ONE,
    );
    let camera = Camera::look_at(
        to_world(DVec3::new(0.0, 5.0, 5.0)).as_vec3(),
        to_world(DVec3::ZERO).as_vec3(),
        Vec3::Y,
        40.0,
    );
    Scene::build(g, vec![light], camera, DVec3::ZERO, Duration::ZERO)
}

const TURN: (f64, f64, f64) = (0.4, 0.3, 0.5);

fn turn() -> DQuat {
    DQuat::from_euler(EulerRot::XYZ, TURN.0, TURN.1, TURN.2)
}

/// A 2 mm wide rope (a ribbon 10 m long) `clearance` above a 200 m floor at local x = `at`,
/// under a 0.2 m light 2 m up: receivers under the rope's centre line within
/// `1 mm - clearance x 0.1 / (2 - clearance)` of it see no part of the light (the umbra).
/// Returns the floor hits of rays aimed at local (at + k 0.01, 0, z) for |z| <= `umbra`,
/// seen from 0.5 m up and 2 m aside (their lines of sight pass beside the rope).
fn rope_case(clearance: f64, at: f64, umbra: f64) -> (Scene, Vec<SurfaceHit>) {
    let floor = (DVec3::ZERO, DVec3::new(200.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -200.0));
    let rope = (DVec3::new(at, clearance, 0.0), DVec3::new(10.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -0.002));
    let light = (DVec3::new(at, 2.0, 0.0), DVec3::new(0.2, 0.0, 0.0), DVec3::new(0.0, 0.0, 0.2));
    let turn = turn();
    let scene = turned_scene(&[floor, rope], light, turn, DVec3::ZERO);
    let umbra_half_width = 0.001 - clearance * 0.1 / (2.0 - clearance);
    let mut hits = Vec::new();
    for k in 0..8 {
        for j in 0..9 {
            let x = at + 0.01 * k as f64 - 0.037;
            let z = umbra * (j as f64 / 4.0 - 1.0);
            let eye = turn * DVec3::new(x, 0.5, 2.0);
            let aim = turn * DVec3::new(x, 0.0, z);
            let d = (aim - eye).normalize();
            let ray = Ray::new(Vec3A::from(eye.as_vec3()), Vec3A::from(d.as_vec3()), 0.0, f32::INFINITY);
            let hit = scene.intersect(ray).expect("the floor");
            // The floor, near where aimed (the rope is >= 4 mm off these lines of sight), and
            // inside the umbra (the f32 hit lies ~1e-4 from the aim at 90 m).
            let local = turn.inverse() * hit.point.p.as_dvec3();
            assert!((hit.point.p.as_dvec3() - aim).length() < 1e-3, "hit {} aim {aim}", hit.point.p);
            assert!(local.y.abs() < 1e-4 && local.z.abs() < umbra_half_width, "hit {local} off the umbra");
            hits.push(hit);
        }
    }
    (scene, hits)
}

/// The case: a 2 mm rope 3 mm above a 200 m floor, 90 m from the scene's centre on
/// a floor turned off the axes, casts its whole umbra: V = 0 exactly (256 samples, plain and
/// culled), where the scene-scaled epsilon (2.8 mm here) left 0.2 mm between ray origin and
/// rope.
#[test]
fn a_rope_3mm_above_a_200m_floor_casts_its_full_umbra() {
    for at in [0.0, 45.0, 90.0] {
        // Umbra half-width 1 - 3 x 0.05 = 0.85 mm; aimed at up to 0.7 mm.
        let (scene, hits) = rope_case(0.003, at, 0.0007);
        for (k, hit) in hits.iter().enumerate() {
            assert_eq!(traced_at(&scene, hit, k as u64), 0.0, "rope at {at}: receiver {}", hit.point.p);
        }
    }
}

/// The measurement behind the choice: at 90 m on the turned floor, a rope 1 mm above the
/// floor is in the bound rule's reach (its offset there is ~0.1 mm) but not in Wächter &
/// Binder's (256 ulps of coordinates of 64-128 m: up to ~2 mm).
#[test]
fn the_error_bound_rule_catches_a_rope_1mm_up_at_90m_where_wachter_binder_leaks() {
    let (scene, hits) = rope_case(0.001, 90.0, 0.0008);
    let light = scene.lights[0];
    let (mut bound_leaks, mut wb_leaks, mut offset_bound, mut offset_wb) = (0, 0, 0.0f32, 0.0f32);
    for hit in &hits {
        bound_leaks += usize::from(plain_visibility(&scene, &light, hit, 16, Rule::ErrorBound) > 0.0);
        wb_leaks += usize::from(plain_visibility(&scene, &light, hit, 16, Rule::WachterBinder) > 0.0);
        let up = light.center - hit.point.p;
        offset_bound = offset_bound
            .max(crate::geometry::ray_origin::offset_origin(&hit.point, up).distance(hit.point.p));
        offset_wb =
            offset_wb.max(wachter_binder_origin(hit.point.p, hit.point.n_geom, up).distance(hit.point.p));
    }
    eprintln!(
        "rope 1 mm up at 90 m: leaking receivers, error bound {bound_leaks} / W&B {wb_leaks} of {}; \
         largest offset {offset_bound:e} / {offset_wb:e}",
        hits.len()
    );
    assert_eq!(bound_leaks, 0);
    // Measured: 23 of 72 (W&B's offset steps with each coordinate's binary exponent).
    assert!(wb_leaks >= 10, "W&B leaked at {wb_leaks} of {}", hits.len());
}

/// A lit plane far from the origin (10^4 and 10^6 units, turned off the axes, no
/// recentring) with nothing over it: V = 1 exactly at every receiver (no acne), with
/// `traced` plain and culled.
#[test]
fn a_lit_plane_far_from_the_origin_has_no_acne() {
    for far in [1e4, 1e6] {
        let shift = DVec3::new(far, 0.7 * far, -0.4 * far);
        let turn = turn();
        let plane = (DVec3::ZERO, DVec3::new(200.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -200.0));
        let light = (DVec3::new(0.0, 10.0, 0.0), DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.0, 0.0, 2.0));
        let scene = turned_scene(&[plane], light, turn, shift);
        let eye = turn * DVec3::new(3.0, 20.0, 30.0) + shift;
        let mut points = 0;
        for j in 0..12 {
            for i in 0..12 {
                let aim = turn * DVec3::new(-40.0 + 7.0 * i as f64, 0.0, -40.0 + 7.0 * j as f64) + shift;
                let d = (aim - eye).normalize();
                let ray = Ray::new(Vec3A::from(eye.as_vec3()), Vec3A::from(d.as_vec3()), 0.0, f32::INFINITY);
                let hit = scene.intersect(ray).expect("the plane");
                assert_eq!(
                    traced_at(&scene, &hit, (i + 12 * j) as u64),
                    1.0,
                    "at {far}: receiver {}",
                    hit.point.p
                );
                points += 1;
            }
        }
        assert_eq!(points, 144);
    }
}

/// A scene of raw triangles, without `Scene::build`'s checks (which drop triangles whose f32
/// cross product underflows or overflows: that policy is the loader's): render space =
/// world.
fn raw_scene(tris: &[[Vec3; 3]], light: RectLight) -> Scene {
    let triangles: Vec<Triangle> =
        tris.iter().map(|t| Triangle { v0: t[0].into(), v1: t[1].into(), v2: t[2].into() }).collect();
    let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&triangles, bvh_params(), &mut Duration::default());
    let triangles: Vec<Triangle> = bvh.primitive_indices.iter().map(|&i| triangles[i as usize]).collect();
    let shading = triangles
        .iter()
        .map(|_| TriangleShading { n: [Vec3::Y; 3], uv: [Vec2::ZERO; 3], material: 0 })
        .collect();
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in tris.iter().flatten() {
        lo = lo.min(*t);
        hi = hi.max(*t);
    }
    Scene {
        origins: vec![crate::geometry::instances::TriangleOrigin::LOOSE; triangles.len()],
        triangles,
        shading,
        extras: Default::default(),
        meshes: Vec::new(),
        instances: Vec::new(),
        materials: vec![Material::diffuse([0.5; 3])],
        textures: Vec::new(),
        bvh: Some(bvh),
        instanced: None,
        bounds_min: lo,
        bounds_max: hi,
        lights: vec![light],
        camera: Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0),
        world_offset: DVec3::ZERO,
        any_alpha_test: false,
        shading_mode: Default::default(),
        normal_maps: false,
        stats: LoadStats::default(),
        warnings: Vec::new(),
    }
}

/// Triangles 1e-20 and 1e20 across (f32 products of their coordinates underflow / overflow;
/// the test's edge functions are f64) are hit by a ray through them and shadow a receiver in their umbra
/// completely (V = 0, 256 samples, plain and culled).
#[test]
fn tiny_and_huge_triangles_are_hit_and_occlude() {
    for s in [1e-20f32, 1e20] {
        // The occluder in the plane y = h, around the receiver's vertical.
        let h = if s < 1.0 { 1e-21 } else { 1.0 };
        let tri = [Vec3::new(-s, h, -s), Vec3::new(s, h, -s), Vec3::new(0.0, h, s)];
        // The receiver sits under the triangle's inside (the tiny one's incentre is at
        // z ~ -0.38 s), so the light (0.1 wide, 1 above, facing down) is seen through it only.
        let p = if s < 1.0 { Vec3::new(0.0, 0.0, -0.38 * s) } else { Vec3::ZERO };
        let light =
            RectLight::new(Vec3::new(0.0, 1.0 + 2.0 * h, 0.0), 0.1 * Vec3::X, 0.1 * Vec3::Z, Vec3::ONE);
        let scene = raw_scene(&[tri], light);
        // Hit: straight up from the receiver.
        let up = Ray::new(Vec3A::from(p), Vec3A::Y, 0.0, f32::INFINITY);
        let hit = scene.intersect(up).unwrap_or_else(|| panic!("the {s} triangle is missed"));
        assert!((hit.t - h).abs() <= 1e-6 * h, "{s}: t {} for {h}", hit.t);
        assert_eq!(hit.point.n_geom, -Vec3::Y, "{s}: normal");
        assert!(hit.point.p_error.is_finite() && hit.point.p.is_finite());
        // Occludes: a receiver facing up, at p.
        let below = SurfaceHit {
            t: 0.0,
            point: ShadingPoint { p, p_error: point_error(p), n_geom: Vec3::Y, n_shading: Vec3::Y },
            uv: Vec2::ZERO,
            material: 0,
            triangle: 0,
            kept: None,
            front_face: true,
        };
        assert_eq!(traced_at(&scene, &below, 1), 0.0, "the {s} triangle does not occlude");
        // And its shaft is not proven clear.
        let shaft = Shaft::new(&light, &below.point).unwrap();
        assert!(!scene.shaft_clear(&shaft));
    }
}

/// The false-occlusion measurement (run by hand: `cargo test -p renderer --lib --
/// --ignored measure_false_occlusion --nocapture`, scenes in `PENUMBRA_SCENES`,
/// colon-separated). Per scene at 320 x 240: the primary hits the light reaches whose
/// whole-light shaft, built from each rule's own origin, is clear (nothing can block them),
/// and of those the points with any of the 64 shadow rays the shaft covers reported blocked
/// under each rule (false occlusion: the shaft proves nothing can block them).
#[test]
#[ignore]
fn measure_false_occlusion() {
    let scenes = std::env::var("PENUMBRA_SCENES").unwrap_or_else(|_| "../scenes/default.toml".into());
    for path in scenes.split(':') {
        let path = std::path::Path::new(path);
        let file = crate::load::scene_file::SceneFile::load(path).unwrap_or_else(|e| panic!("{e}"));
        let scene = Scene::load(&file, path).unwrap_or_else(|e| panic!("{e}"));
        let (w, h) = (320u32, 240u32);
        for (k, light) in scene.lights.iter().enumerate() {
            let mut counts = [(0usize, 0usize, 0usize); 2];
            // Rays (above the geometric tangent plane) whose closest hit is the receiver's own
            // triangle, at every lit point: self-intersection proper.
            let mut self_hits = [0usize; 2];
            let mut lit_rays = 0usize;
            for y in 0..h {
                for x in 0..w {
                    let d = scene.camera.ray_direction(x as f32 + 0.5, y as f32 + 0.5, w, h).normalize();
                    let ray =
                        Ray::new(Vec3A::from(scene.camera.position), Vec3A::from(d), 0.0, f32::INFINITY);
                    let Some(hit) = scene.intersect(ray) else { continue };
                    if light.irradiance_factor(hit.point.p, hit.point.n_shading) <= 0.0 {
                        continue;
                    }
                    for j in 0..8 {
                        for i in 0..8 {
                            let (a, b) = ((i as f32 + 0.5) / 8.0, (j as f32 + 0.5) / 8.0);
                            let (target, e) = (light.point(a, b), light.point_error(a, b));
                            if hit.point.n_geom.dot(target - hit.point.p) <= 0.0 {
                                continue;
                            }
                            lit_rays += 1;
                            let rays = [
                                shadow_ray(&hit.point, target, e, light.normal),
                                wachter_binder_ray(&hit, target, light.normal),
                            ];
                            for (r, ray) in rays.into_iter().enumerate() {
                                self_hits[r] += usize::from(
                                    ray.and_then(|ray| scene.intersect(ray))
                                        .is_some_and(|c| c.triangle == hit.triangle),
                                );
                            }
                        }
                    }
                    for (r, rule) in [Rule::ErrorBound, Rule::WachterBinder].into_iter().enumerate() {
                        let apex = match rule {
                            Rule::ErrorBound => {
                                crate::geometry::ray_origin::offset_origin(&hit.point, hit.point.n_geom)
                            }
                            Rule::WachterBinder => {
                                wachter_binder_origin(hit.point.p, hit.point.n_geom, hit.point.n_geom)
                            }
                        };
                        let Some(shaft) = Shaft::with_apex(light, [0.0, 1.0], [0.0, 1.0], &hit.point, apex)
                        else {
                            continue;
                        };
                        if !scene.shaft_clear(&shaft) {
                            continue;
                        }
                        counts[r].0 += 1;
                        // The rays the shaft covers (above the geometric tangent plane, with
                        // the margins of `covers`): nothing can block them.
                        let mut blocked = 0;
                        for j in 0..8 {
                            for i in 0..8 {
                                let (a, b) = ((i as f32 + 0.5) / 8.0, (j as f32 + 0.5) / 8.0);
                                let (target, e) = (light.point(a, b), light.point_error(a, b));
                                if !crate::geometry::shaft::covers(&hit.point, apex, target, e) {
                                    continue;
                                }
                                let ray = match rule {
                                    Rule::ErrorBound => shadow_ray(&hit.point, target, e, light.normal),
                                    Rule::WachterBinder => wachter_binder_ray(&hit, target, light.normal),
                                };
                                blocked += usize::from(ray.is_some_and(|r| scene.occluded(r)));
                            }
                        }
                        if blocked > 0 {
                            counts[r].1 += 1;
                            counts[r].2 += blocked;
                        }
                    }
                }
            }
            eprintln!(
                "{} light {k}: clear-shaft points / falsely occluded points / rays: error bound {:?}, W&B {:?}; \
                 self hits of {lit_rays} rays: {:?}",
                path.display(),
                counts[0],
                counts[1],
                self_hits
            );
        }
    }
}
