//! Paths over glTF materials (`[materials] shading = "gltf"`): at every vertex the lights'
//! direct light through the shadow methods ([`crate::integrator::reflect`]), then a bounce
//! drawn from the BRDF (cosine for the diffuse lobe, GGX visible normals for the specular
//! one, [`crate::shading::brdf::GltfBrdf::sample`]).
//!
//! What a bounce meets adds its emission: an emissive surface that is not a light in full
//! (nothing else samples it); a light (a `[[light]]` rectangle the ray crosses, or an
//! emissive glTF rectangle made a light, whose triangles it hits) only through a specular
//! lobe sharper than the LTC fit ([`Reflector::sharp`]): the lights' other light is the
//! methods' (the strategies split the lobes; see `reflect`'s module doc). Depth as in
//! [`crate::integrator::path`]: the camera ray is the first segment, so at `max_depth = 2`
//! the one BSDF ray of a vertex still finds the lights and emitters it reflects, and goes no
//! further.

use crate::geometry::ray_origin::offset_origin;
use crate::geometry::scene::{Scene, SurfaceHit};
use crate::integrator::path::{PathContext, PathId, RR_START, VertexQueries};
use crate::integrator::reflect::{Reflector, direct};
use crate::interface::lobe::lobe_frame;
use glam::{Vec3, Vec3A};
use obvhs::ray::Ray;

/// How far a light's crossing must lie before a hit to count (its own triangles, where
/// it has them, are met instead), as a share of the hit's distance.
const LIGHT_BEFORE_HIT: f32 = 1e-4;

/// The radiance a primary hit sends toward the camera: its emission, its direct light, and
/// what its path gathers; `seen(k, V)` hears the primary hit's V of each light.
pub fn radiance(
    ctx: &PathContext,
    hit: &SurfaceHit,
    id: &PathId,
    stats: &mut [VertexQueries],
    seen: impl FnMut(usize, f32),
) -> Vec3 {
    let scene = ctx.scene;
    let surface = scene.surface(hit);
    let wo = (scene.camera.position - hit.point.p).normalize_or_zero();
    let r = Reflector::new(&surface, hit.point.n_shading, wo);
    let mut l = surface.emission + direct(ctx, &hit.point, &r, (id, 1), stats, seen);
    l += gather(ctx, (hit, r), id, stats);
    l
}

/// What the path from the primary hit gathers past it: vertices 2 to `max_depth`.
fn gather(
    ctx: &PathContext,
    (first, mut r): (&SurfaceHit, Reflector),
    id: &PathId,
    stats: &mut [VertexQueries],
) -> Vec3 {
    let scene = ctx.scene;
    let mut rng = id.bounce_rng();
    let (mut beta, mut point, mut l) = (Vec3::ONE, first.point, Vec3::ZERO);
    let emitters = scene.materials.iter().any(|m| m.emission != Vec3::ZERO);
    for vertex in 2..=ctx.max_depth {
        let last = vertex == ctx.max_depth;
        if last && !r.sharp() && !emitters {
            break;
        }
        let Some(frame) = lobe_frame(r.n, r.wo) else { break };
        let to_local = |w: Vec3| Vec3::new(frame[0].dot(w), frame[1].dot(w), frame[2].dot(w));
        let wo = to_local(r.wo);
        let u = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
        let Some(s) = r.brdf.sample(wo, u) else { break };
        let d = (frame[0] * s.wi.x + frame[1] * s.wi.y + frame[2] * s.wi.z).normalize();
        // The sharp specular lobe's share of the sample: what lights it meets add.
        let sharp = if r.sharp() && s.pdf > 0.0 {
            r.brdf.eval(wo, s.wi).specular * (s.wi.z / s.pdf)
        } else {
            Vec3::ZERO
        };
        let origin = offset_origin(&point, d);
        let hit = scene.intersect(Ray::new(Vec3A::from(origin), Vec3A::from(d), 0.0, f32::INFINITY));
        if sharp != Vec3::ZERO {
            l += beta * sharp * lights_crossed(scene, origin, d, hit.as_ref());
        }
        let Some(next) = hit else { break };
        let surface = scene.surface(&next);
        if surface.emission != Vec3::ZERO && !on_a_light(scene, &next) {
            l += beta * s.weight * surface.emission;
        }
        beta *= s.weight;
        if last {
            break;
        }
        let next_r = Reflector::new(&surface, next.point.n_shading, -d);
        l += beta * direct(ctx, &next.point, &next_r, (id, vertex), stats, |_, _| {});
        if vertex >= RR_START {
            let survive = beta.max_element().min(0.95);
            if survive <= 0.0 || rng.next_f32() >= survive {
                break;
            }
            beta /= survive;
        }
        (point, r) = (next.point, next_r);
    }
    l
}

/// The radiance of the lights the ray from `origin` along `d` meets before `hit` (or on
/// it: an emissive rectangle made a light is met as its own triangles), from their
/// emitting side.
fn lights_crossed(scene: &Scene, origin: Vec3, d: Vec3, hit: Option<&SurfaceHit>) -> Vec3 {
    let t_hit = hit.map_or(f32::INFINITY, |h| h.t);
    let mut sum = Vec3::ZERO;
    for light in &scene.lights {
        let Some(t) = light.crossing(origin, d) else { continue };
        if t < t_hit * (1.0 - LIGHT_BEFORE_HIT) || hit.is_some_and(|h| light.holds(h.point.p)) {
            sum += light.radiance;
        }
    }
    sum
}

/// Whether `hit` lies on a light's rectangle: its emission is that light's, which the
/// methods and [`lights_crossed`] count.
fn on_a_light(scene: &Scene, hit: &SurfaceHit) -> bool {
    scene.lights.iter().any(|light| light.holds(hit.point.p))
}
