//! Tests of `shaft.rs`: shafts are conservative (culled bits equal plain tracing), and
//! their margins hold at the precision edge.

use super::*;
use crate::geometry::camera::Camera;
use crate::geometry::ray_origin::point_error;
use crate::interface::shadowing::{LightShadowing, PrepareContext, ShadowQuery};
use crate::load::gltf_load::Geometry;
use crate::methods::traced::{Traced, TracedParams};
use crate::util::random::Rng;
use glam::DVec3;
use std::time::Duration;

type Quad = ([f64; 3], [f64; 3], [f64; 3]);

fn scene(quads: &[Quad], light: RectLight) -> Scene {
    let mut g = Geometry::default();
    for (c, u, v) in quads {
        g.add_quad(DVec3::from(*c), DVec3::from(*u), DVec3::from(*v), [0.5; 3]);
    }
    let camera = Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
    Scene::build(g, vec![light], camera, DVec3::ZERO, Duration::ZERO)
}

/// 1 x 1 light at height 2 facing down, over a 20 x 20 floor.
fn light() -> RectLight {
    RectLight::new(Vec3::new(0.0, 2.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE)
}
const FLOOR: Quad = ([0.0, 0.0, 0.0], [20.0, 0.0, 0.0], [0.0, 0.0, -20.0]);

fn clear(s: &Scene, p: Vec3, n: Vec3) -> bool {
    let point = ShadingPoint { p, p_error: point_error(p), n_geom: n, n_shading: n };
    let shaft = Shaft::new(&s.lights[0], &point).expect("a shaft");
    s.shaft_clear(&shaft)
}

#[test]
fn the_receivers_own_surface_and_a_ceiling_flush_with_the_light_leave_it_clear() {
    // The floor under the point and a ceiling in the light's plane, with a hole for it.
    let ceiling = ([0.0, 2.0, 0.0], [30.0, 0.0, 0.0], [0.0, 0.0, 30.0]);
    let s = scene(&[FLOOR, ceiling], light());
    // The ceiling quad covers the light itself, but from below: it lies in the light's
    // plane, and rays stop short of it. (Traced agrees: nothing blocks.)
    assert!(clear(&s, Vec3::new(0.3, 0.0, -0.2), Vec3::Y));
    assert!(clear(&s, Vec3::new(-4.0, 0.0, 3.0), Vec3::Y));
}

/// A floor 10^10 or 10^12 m wide, or a 10^19 m quad a metre under it, leaves clear the shaft
/// of a point on a wall above it (only the huge triangle's own plane separates it there; its
/// normal's square overflowed f32, so no such shaft was ever clear); the same quads across
/// the shaft block it.
#[test]
fn a_huge_triangle_beside_the_shaft_leaves_it_clear() {
    for (size, y) in [(1e10, 0.0), (1e12, 0.0), (1e19, -1.0), (1e10, 1.0), (1e19, 1.0)] {
        let s = scene(&[([0.0, y, 0.0], [size, 0.0, 0.0], [0.0, 0.0, -size])], light());
        let under = y <= 0.0;
        for (p, n) in [(Vec3::new(-1.0, 0.5, 0.0), Vec3::X), (Vec3::new(0.2, 0.7, 1.5), Vec3::NEG_Z)] {
            assert_eq!(clear(&s, p, n), under, "quad {size:e} m at y = {y}, point {p}");
        }
    }
}

#[test]
fn an_occluder_inside_the_shaft_is_found_and_one_just_outside_is_not() {
    // From P = origin, the shaft to the light (x, z in [-0.5, 0.5] at y = 2) is
    // |x|, |z| <= y / 4 at height y. A 0.1 x 0.1 plate at y = 1 spans |x| <= 0.25 there.
    let p = Vec3::ZERO;
    let inside = ([0.2, 1.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.0, -0.1]);
    assert!(!clear(&scene(&[FLOOR, inside], light()), p, Vec3::Y));
    // Its near edge at x = 0.25 + 1e-3: outside by 1e-3, ~ 500 times the side faces' slack.
    let outside = ([0.301, 1.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.0, -0.1]);
    assert!(clear(&scene(&[FLOOR, outside], light()), p, Vec3::Y));
    // Behind the light (y > 2): outside.
    let above = ([0.0, 2.5, 0.0], [0.4, 0.0, 0.0], [0.0, 0.0, -0.4]);
    assert!(clear(&scene(&[FLOOR, above], light()), p, Vec3::Y));
    // A huge slanted plane passing between P and the light: its vertices lie far outside
    // every face, only its own plane can decide, and it crosses the shaft.
    let slanted = ([0.0, 1.0, 0.0], [100.0, 10.0, 0.0], [0.0, 0.0, -100.0]);
    assert!(!clear(&scene(&[FLOOR, slanted], light()), p, Vec3::Y));
    // The same plane lowered below P's side: separated by its plane.
    let below = ([0.0, -3.0, 0.0], [100.0, 10.0, 0.0], [0.0, 0.0, -100.0]);
    assert!(clear(&scene(&[FLOOR, below], light()), p, Vec3::Y));
}

/// Culled and plain traced visibility are the same bits over random occluders and points
/// (on the floor with shading normals up to 85 degrees off, so part of the light may be
/// below the horizon; and on a ramp the light grazes), and culling skips most rays.
#[test]
fn culling_gives_the_plain_traced_bits() {
    let mut rng = Rng::new(7);
    let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    // The ramp: x in [3, 5], rising 1 in 2 towards +x, facing -x and up.
    let ramp_normal = Vec3::new(-1.0, 2.0, 0.0).normalize();
    let mut quads = vec![FLOOR, ([4.0, 0.5, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, -4.0])];
    for _ in 0..40 {
        let c = [r(-2.0, 2.0) as f64, r(0.05, 1.8) as f64, r(-2.0, 2.0) as f64];
        let u = [r(0.02, 0.4) as f64, r(-0.2, 0.2) as f64, r(-0.1, 0.1) as f64];
        let v = [r(-0.1, 0.1) as f64, r(-0.2, 0.2) as f64, r(0.02, 0.4) as f64];
        quads.push((c, u, v));
    }
    let s = scene(&quads, light());
    let (plain, culled) = plain_and_culled(&s);
    let (mut partial, mut points) = (0, 0);
    for k in 0..800u64 {
        let q = if k % 4 == 3 {
            let x = r(3.05, 4.95);
            let p = Vec3::new(x, 0.5 * (x - 3.0), r(-1.9, 1.9));
            ShadowQuery {
                point: ShadingPoint {
                    p,
                    p_error: point_error(p),
                    n_geom: ramp_normal,
                    n_shading: ramp_normal,
                },
                pixel: [0, 0],
                seed: k,
                irradiance: 0.0,
            }
        } else {
            let p = Vec3::new(r(-3.0, 3.0), 0.0, r(-3.0, 3.0));
            let tilt = r(0.0, 1.48);
            let az = r(0.0, std::f32::consts::TAU);
            let n = Vec3::new(tilt.sin() * az.cos(), tilt.cos(), tilt.sin() * az.sin());
            ShadowQuery {
                point: ShadingPoint { p, p_error: point_error(p), n_geom: Vec3::Y, n_shading: n },
                pixel: [0, 0],
                seed: k,
                irradiance: 0.0,
            }
        };
        let (p, n) = (q.point.p, q.point.n_shading);
        let (a, b) = (plain.visibility(&s, &q), culled.visibility(&s, &q));
        assert_eq!(a.to_bits(), b.to_bits(), "point {p} normal {n}: plain {a} culled {b}");
        points += 1;
        partial += usize::from(a > 0.0 && a < 1.0);
    }
    let rays = |t: &Traced| t.counters().into_iter().find(|c| c.0 == "shadow_rays").unwrap().1;
    // Not vacuous: many points are in penumbra, and culling skipped most rays.
    assert!(partial > points / 10, "{partial} of {points} in penumbra");
    assert!(rays(&culled) * 2 < rays(&plain), "culled {} plain {}", rays(&culled), rays(&plain));
}

#[test]
fn leaves_cover_the_strata_grid_and_parts_below_the_threshold_are_not_tested() {
    let s = scene(&[FLOOR], light());
    // Open sky: the whole light is clear in one test, every leaf set.
    let e = point_error(Vec3::ZERO);
    let origin = ShadingPoint { p: Vec3::ZERO, p_error: e, n_geom: Vec3::Y, n_shading: Vec3::Y };
    let (mask, tests) = clear_leaves(&s, &s.lights[0], &origin, (32, 32));
    assert_eq!((mask.count_ones(), tests), ((LEAVES * LEAVES) as u32, 1));
    for (i, j) in [(0, 0), (31, 0), (0, 31), (31, 31), (13, 22)] {
        assert_ne!(mask & leaf_bit(i, j, (32, 32)), 0);
    }
    // 48 samples: fewer than MIN_SAMPLES_PER_SHAFT, nothing tested, nothing proven.
    assert_eq!(clear_leaves(&s, &s.lights[0], &origin, (8, 6)), (0, 0));
    // A plate over a corner of the light, seen from below its centre: the whole light
    // and one quadrant are blocked, the other three quadrants proven clear (4 leaves
    // each), and the blocked quadrant split once more.
    let plate = ([-0.25, 1.9, -0.25], [0.3, 0.0, 0.0], [0.0, 0.0, -0.3]);
    let s = scene(&[FLOOR, plate], light());
    let (mask, tests) = clear_leaves(&s, &s.lights[0], &origin, (32, 32));
    assert!(mask.count_ones() >= 12 && mask.count_ones() < 16, "mask {mask:#x}");
    assert!(tests >= 5, "{tests} tests");
}

fn triangles_scene(tris: &[[DVec3; 3]], light: RectLight) -> Scene {
    use crate::geometry::material::Material;
    use crate::load::gltf_load::SourceTriangle;
    let mut g = Geometry::default();
    g.materials.push(Material::diffuse([0.5; 3]));
    for t in tris {
        g.triangles.push(SourceTriangle {
            p: *t,
            n: None,
            uv: [glam::Vec2::ZERO; 3],
            material: 0,
            origin: crate::geometry::instances::TriangleOrigin::LOOSE,
        });
    }
    let camera = Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
    Scene::build(g, vec![light], camera, DVec3::ZERO, Duration::ZERO)
}

fn quad_triangles(c: DVec3, u: DVec3, v: DVec3) -> [[DVec3; 3]; 2] {
    let k = |a: f64, b: f64| c + a * u + b * v;
    [[k(-0.5, -0.5), k(0.5, -0.5), k(0.5, 0.5)], [k(-0.5, -0.5), k(0.5, 0.5), k(-0.5, 0.5)]]
}

fn plain_and_culled(s: &Scene) -> (Traced, Traced) {
    let ctx = PrepareContext::for_light(s, 0);
    let mut plain = Traced::new(TracedParams::PLAIN, 1024);
    let mut culled = Traced::new(TracedParams::CULLED, 1024);
    plain.prepare(&ctx).unwrap();
    culled.prepare(&ctx).unwrap();
    (plain, culled)
}

/// Regression (found by review): a small light 80 units away makes each part's shaft
/// long and thin. Side faces computed from the two long edges lost enough precision to
/// prove clear a shaft that a small triangle 0.17 above the point blocks completely
/// (plain 0, culled 0.5).
#[test]
fn a_long_thin_shaft_is_not_proven_clear_through_a_blocker() {
    let light = RectLight::new(
        Vec3::new(3.0, 40.0, -2.0),
        Vec3::new(0.1, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 0.1),
        Vec3::ONE,
    );
    let mut tris =
        quad_triangles(DVec3::new(0.0, -40.0, 0.0), DVec3::new(60.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -60.0))
            .to_vec();
    // The review's triangle, moved by (4.34e-4, 0, 3.98e-4) onto the central ray from the
    // apex of the one rule for ray origins (it sat on the ray from the old origin, 1e-3
    // higher, which crosses its height ~5e-4 further from the light).
    let shift = DVec3::new(4.34e-4, 0.0, 3.98e-4);
    tris.push([
        DVec3::new(-27.38235, -39.83867, -29.864786) + shift,
        DVec3::new(-27.382542, -39.838837, -29.864096) + shift,
        DVec3::new(-27.381868, -39.839005, -29.864344) + shift,
    ]);
    let s = triangles_scene(&tris, light);
    let (plain, culled) = plain_and_culled(&s);
    let p = Vec3::new(-27.44314, -40.0, -29.92025);
    let q = ShadowQuery {
        point: ShadingPoint { p, p_error: point_error(p), n_geom: Vec3::Y, n_shading: Vec3::Y },
        pixel: [0, 0],
        seed: 1,
        irradiance: 0.0,
    };
    let (a, b) = (plain.visibility(&s, &q), culled.visibility(&s, &q));
    assert_eq!(a, 0.0);
    assert_eq!(a.to_bits(), b.to_bits(), "plain {a} culled {b}");
    // The apex lies inside its side faces (with their slack) for every part of the light.
    for (a0, b0) in [(0.0, 0.0), (0.5, 0.5), (0.25, 0.75), (0.75, 0.0)] {
        let shaft = Shaft::to_part(&light, [a0, a0 + 0.25], [b0, b0 + 0.25], &q.point).unwrap();
        for f in &shaft.faces[..4] {
            assert!(!f.outside(shaft.vertices[0]), "apex outside a side face of part ({a0}, {b0})");
        }
    }
}

/// Regression (found by review): points on a wall just below the light's plane, under a
/// ceiling flush with the light, in a rotated frame (so the ceiling's vertices round off
/// the plane): their rays reach the light at a grazing angle, and the light-plane face
/// must not separate the ceiling they may hit.
#[test]
fn a_ceiling_flush_with_the_light_is_not_separated_from_grazing_rays() {
    use glam::DQuat;
    let mut differ = 0;
    for rot in 0..6u64 {
        let mut rng = Rng::new(100 + rot);
        let mut angle = || rng.next_f32() as f64 * 6.0;
        let turn = DQuat::from_euler(glam::EulerRot::XYZ, angle(), angle(), angle());
        let to_world = |x: DVec3| turn * x + DVec3::new(0.3, -0.7, 1.1);
        let light = RectLight::new(
            to_world(DVec3::new(0.0, 2.0, 0.0)).as_vec3(),
            (turn * DVec3::X).as_vec3(),
            (turn * DVec3::Z).as_vec3(),
            Vec3::ONE,
        );
        let tris: Vec<[DVec3; 3]> =
            quad_triangles(DVec3::ZERO, DVec3::new(20.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -20.0))
                .into_iter()
                .chain(quad_triangles(
                    DVec3::new(0.0, 2.0, 0.0),
                    DVec3::new(30.0, 0.0, 0.0),
                    DVec3::new(0.0, 0.0, 30.0),
                ))
                .map(|t| t.map(to_world))
                .collect();
        let s = triangles_scene(&tris, light);
        let (plain, culled) = plain_and_culled(&s);
        let mut rng = Rng::new(5 + rot);
        let n = (turn * DVec3::NEG_X).as_vec3();
        for k in 0..300u64 {
            let below = 10f64.powf(-7.0 + 5.5 * rng.next_f32() as f64);
            let p = to_world(DVec3::new(3.0, 2.0 - below, rng.next_f32() as f64 - 0.5)).as_vec3();
            let q = ShadowQuery {
                point: ShadingPoint { p, p_error: point_error(p), n_geom: n, n_shading: n },
                pixel: [0, 0],
                seed: k,
                irradiance: 0.0,
            };
            differ += usize::from(plain.visibility(&s, &q).to_bits() != culled.visibility(&s, &q).to_bits());
        }
    }
    assert_eq!(differ, 0, "{differ} of 1800 points differ");
}

/// The any-hit query with a skip set: two stacked plates over a point; a ray up through
/// both is blocked while either counts, and passes when both are skipped. Slots 0..1 are the
/// lower plate's, 2..3 the upper's.
#[test]
fn occluded_except_passes_only_the_skipped_triangles() {
    let lower = quad_triangles(DVec3::new(0.0, 0.5, 0.0), DVec3::X, DVec3::Z);
    let upper = quad_triangles(DVec3::new(0.0, 1.0, 0.0), DVec3::X, DVec3::Z);
    let s = triangles_scene(&[lower[0], lower[1], upper[0], upper[1]], light());
    let light = &s.lights[0];
    let origin = Vec3::new(0.05, 0.0, 0.05);
    let target = light.point(0.5, 0.5);
    let ends = (light.point_error(0.5, 0.5), light.normal);
    let blocked = |skip: &dyn Fn(usize) -> bool| s.segment_occluded_from_except(origin, target, ends, skip);
    assert!(s.segment_occluded_from(origin, target, ends.0, ends.1));
    assert!(blocked(&|_| false));
    assert!(blocked(&|slot| slot < 2), "the upper plate still blocks");
    assert!(blocked(&|slot| slot >= 2), "the lower plate still blocks");
    assert!(!blocked(&|_| true), "nothing left to block");
}

/// A ball's shaft holds every shaft of an apex inside the ball: random balls under a light,
/// random apexes in them, random segments and small triangles; whatever an apex's own hull
/// cannot separate, the ball's cannot either, and segments along a ray from the apex to the
/// light are never separated. Far segments are (the test can fail).
#[test]
fn a_ball_shaft_holds_the_shaft_of_every_apex_inside_it() {
    let mut rng = Rng::new(0x5eed_ba11);
    let mut next = move || rng.next_f32();
    let l = light();
    let (mut kept, mut separated_far) = (0u32, 0u32);
    for _ in 0..200 {
        let centre = Vec3::new(4.0 * next() - 2.0, 1.5 * next() - 0.5, 4.0 * next() - 2.0);
        let radius = 0.2 * next() * next();
        let Some(ball) = Shaft::around_ball(&l, centre, radius) else { continue };
        for _ in 0..20 {
            let dir = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or_zero();
            let apex = centre + 0.999 * radius * next() * dir;
            let n = Vec3::Y;
            let point =
                ShadingPoint { p: apex - 1e-3 * n, p_error: point_error(apex), n_geom: n, n_shading: n };
            let Some(own) =
                Shaft::with_apex(&l, [0.0, 1.0], [0.0, 1.0], &point, apex).map(Shaft::without_cut)
            else {
                continue;
            };
            for _ in 0..20 {
                let target = l.point(next(), next());
                let (t0, t1) = (0.05 + 0.9 * next(), 0.05 + 0.9 * next());
                let (a, b) = (apex.lerp(target, t0), apex.lerp(target, t1));
                assert!(!ball.segment_outside(a.into(), b.into()), "a ray's piece separated");
                let s = 1e-3 * Vec3::new(next(), next(), next());
                assert!(!ball.triangle_outside(
                    a.into(),
                    (a + s).into(),
                    (a - Vec3::new(s.y, s.z, s.x)).into()
                ));
                // Any segment: kept by the apex's own shaft, kept by the ball's.
                let (x, y) = (
                    Vec3::new(6.0 * next() - 3.0, 2.5 * next() - 0.5, 6.0 * next() - 3.0),
                    Vec3::new(6.0 * next() - 3.0, 2.5 * next() - 0.5, 6.0 * next() - 3.0),
                );
                if !own.segment_outside(x.into(), x.lerp(y, 0.05).into()) {
                    kept += 1;
                    assert!(!ball.segment_outside(x.into(), x.lerp(y, 0.05).into()));
                }
            }
            let far = centre + Vec3::new(0.0, -3.0 - radius, 0.0);
            separated_far += ball.segment_outside(far.into(), (far + Vec3::X * 0.1).into()) as u32;
        }
    }
    assert!(kept > 500, "only {kept} segments kept by the apexes' shafts");
    assert!(separated_far > 3000, "far segments separated only {separated_far} times");
}
