//! Indirect light: diffuse path tracing from each primary hit, with next-event estimation at
//! every vertex through the same [`LightShadowing`] query as the primary hit's.
//!
//! Depth is counted as Mitsuba 3 counts it: the camera ray is the first segment, so
//! `max_depth = 2` is direct light only (no bounce), and `max_depth = 5` adds three
//! indirect bounces (pbrt's default depth). A bounce is cosine-weighted about the shading
//! normal on the incoming ray's side, so the Lambertian BRDF times cosine over the pdf is the
//! albedo, and a bounce under the geometric plane goes on from its other side. Russian roulette
//! starts at `RR_START` vertices. A bounce ray that meets a light adds nothing: `[[light]]`
//! rectangles are not geometry (it passes through), emissive glTF rectangles keep their
//! triangles (it reflects off them by their albedo); emission arrives by next-event
//! estimation only.

use crate::geometry::point::ShadingPoint;
use crate::geometry::ray_origin::offset_origin;
use crate::geometry::scene::{Scene, SurfaceHit};
use crate::interface::lobe::{GlossyLobe, LobeVisibility};
use crate::interface::shadowing::{LightShadowing, ShadowQuery};
use crate::util::pixel_cost::Work;
use crate::util::random::{Rng, stream_seed};
use glam::{Vec3, Vec3A};
use obvhs::ray::Ray;
use std::time::Instant;

/// Depth of paths unless the scene or the command line says otherwise.
pub const DEFAULT_MAX_DEPTH: u32 = 5;
/// The depths accepted: 2 (direct light only) to 64 (Russian roulette ends nearly every
/// path long before).
pub const DEPTH_RANGE: std::ops::RangeInclusive<u32> = 2..=64;
/// The error for a depth outside it.
pub const DEPTH_RANGE_TEXT: &str = "must be in 2..=64 (2 = direct light only, 5 = three indirect bounces)";

/// The error for a depth outside [`DEPTH_RANGE`] (the scene file's key and the flag alike).
pub fn depth_message(got: &dyn std::fmt::Display) -> String {
    format!("{DEPTH_RANGE_TEXT}, got {got}")
}

/// The first vertex (1 = the primary hit) after which Russian roulette may end a path.
pub const RR_START: u32 = 3;

/// Stream tags, so different uses of one pixel's seed never share random numbers.
pub const TAG_SHADOW: u64 = 2;
const TAG_BOUNCE: u64 = 3;

/// A path's place: pixel (x, y), its index, the primary sample, the frame's seed.
#[derive(Debug, Clone, Copy)]
pub struct PathId {
    pub pixel: [u32; 2],
    pub pixel_index: u64,
    pub sample: u64,
    pub seed: u64,
}

impl PathId {
    /// The seed of light `k`'s shadow query at vertex `vertex` (1 = the primary hit, whose
    /// seeds are those of the direct-light renderer), for a method whose
    /// [`LightShadowing::seed_salt`] is `salt` (XORed into the frame's seed: the same paths,
    /// other light samples).
    pub fn shadow_seed(&self, k: usize, vertex: u32, salt: u64) -> u64 {
        let base = [self.seed ^ salt, self.pixel_index, self.sample, k as u64, TAG_SHADOW];
        if vertex == 1 {
            stream_seed(&base)
        } else {
            stream_seed(&[base[0], base[1], base[2], base[3], base[4], vertex as u64])
        }
    }

    /// The path's own stream of bounce directions and roulette.
    pub fn bounce_rng(&self) -> Rng {
        Rng::new(stream_seed(&[self.seed, self.pixel_index, self.sample, TAG_BOUNCE]))
    }
}

/// What every vertex of a frame's paths reads: the scene, each light's method, how deep
/// paths go, and whether queries are timed. Built once per pixel; `Copy`, a few words.
#[derive(Clone, Copy)]
pub struct PathContext<'a> {
    pub scene: &'a Scene,
    /// One method per light, in `scene.lights`' order.
    pub methods: &'a [Box<dyn LightShadowing>],
    /// [`crate::RenderSettings::max_depth`]: vertices 2 to `max_depth - 1` are bounces.
    pub max_depth: u32,
    /// Time each query into [`VertexQueries::seconds`] ([`crate::RenderSettings::profile`]).
    pub profile: bool,
}

/// Shadow queries per path vertex (index 0 = the primary hit): how many, the rays traced for
/// them, how many traced none, how many a depth-map method could not answer from its map
/// ([`crate::util::pixel_cost::count_fallback`]), and (profiling) their seconds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VertexQueries {
    pub queries: u64,
    pub rays: u64,
    pub without_rays: u64,
    pub fallbacks: u64,
    pub seconds: f64,
}

/// Adds `b` into `a`, index by index.
pub fn merge_vertex_queries(a: &mut Vec<VertexQueries>, b: &[VertexQueries]) {
    if a.len() < b.len() {
        a.resize(b.len(), VertexQueries::default());
    }
    for (x, y) in a.iter_mut().zip(b) {
        x.queries += y.queries;
        x.rays += y.rays;
        x.without_rays += y.without_rays;
        x.fallbacks += y.fallbacks;
        x.seconds += y.seconds;
    }
}

/// Light `k`'s visibility at `point` (vertex `vertex` of path `id`), by the light's method,
/// with `lobe`'s share where the surface is glossy, counted in `stats[vertex - 1]`.
pub fn shadow_query(
    ctx: &PathContext,
    point: &ShadingPoint,
    (id, k, vertex): (&PathId, usize, u32),
    irradiance: f32,
    lobe: Option<&GlossyLobe>,
    stats: &mut [VertexQueries],
) -> LobeVisibility {
    let method = ctx.methods[k].as_ref();
    let seed = id.shadow_seed(k, vertex, method.seed_salt());
    let q = ShadowQuery { point: *point, pixel: id.pixel, seed, irradiance };
    let (t0, w0) = (ctx.profile.then(Instant::now), Work::now());
    let v = match lobe {
        Some(lobe) => method.visibility_glossy(ctx.scene, &q, lobe),
        None => LobeVisibility::both(method.visibility(ctx.scene, &q)),
    };
    debug_assert!((0.0..=1.0).contains(&v.diffuse), "{} returned {v:?}", method.name());
    debug_assert!((0.0..=1.0).contains(&v.glossy), "{} returned {v:?}", method.name());
    let work = Work::now().since(w0);
    let s = &mut stats[vertex as usize - 1];
    s.queries += 1;
    s.rays += work.rays;
    s.without_rays += u64::from(work.rays == 0);
    s.fallbacks += work.fallbacks;
    if let Some(t0) = t0 {
        s.seconds += t0.elapsed().as_secs_f64();
    }
    v
}

/// A unit direction about `n`, cosine-distributed, from two uniform numbers.
pub fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    let (t, b) = n.any_orthonormal_pair();
    (r * phi.cos() * t + r * phi.sin() * b + (1.0 - u1).max(0.0).sqrt() * n).normalize()
}

/// The next vertex of a path leaving `point`: a cosine-weighted bounce about the shading
/// normal (on the incoming ray's side, [`ShadingPoint`]), None when it hits nothing.
///
/// A bounce under the geometric plane (a shading normal tilted past it) goes on from the
/// plane's other side, as next-event estimation's light samples under it do
/// ([`crate::methods::sample_stream::LightSample::height`]): both estimate the same
/// reflection integral over the shading hemisphere, as pbrt-v4 and Mitsuba 3 do. Ending the
/// path there, as before, dropped most of the bounces of a point seen past its shading plane,
/// whose hemisphere lies mostly under the geometric plane, while its light samples counted.
pub fn bounce(scene: &Scene, point: &ShadingPoint, rng: &mut Rng) -> Option<SurfaceHit> {
    let (u1, u2) = (rng.next_f32(), rng.next_f32());
    let d = cosine_direction(point.n_shading, u1, u2);
    // The origin on the side of the geometric plane the bounce leaves to.
    let origin = offset_origin(point, d);
    scene.intersect(Ray::new(Vec3A::from(origin), Vec3A::from(d), 0.0, f32::INFINITY))
}

/// The radiance a path from the primary hit's point `primary` (albedo `albedo`) gathers from
/// its bounces, vertices 2 to `ctx.max_depth - 1`, each with next-event estimation to every
/// light: 0 when `max_depth <= 2`.
pub fn indirect(
    ctx: &PathContext,
    primary: &ShadingPoint,
    albedo: Vec3,
    id: &PathId,
    stats: &mut [VertexQueries],
) -> Vec3 {
    let scene = ctx.scene;
    let mut rng = id.bounce_rng();
    let (mut beta, mut point, mut l) = (albedo, *primary, Vec3::ZERO);
    for vertex in 2..ctx.max_depth {
        let Some(next) = bounce(scene, &point, &mut rng) else { break };
        let a = scene.albedo(&next);
        let mut direct = Vec3::ZERO;
        for (k, light) in scene.lights.iter().enumerate() {
            let e = light.irradiance_factor(next.point.p, next.point.n_shading);
            if e <= 0.0 {
                continue;
            }
            let v = shadow_query(ctx, &next.point, (id, k, vertex), e, None, stats).diffuse;
            direct += light.radiance * (e * v);
        }
        l += beta * a * direct * std::f32::consts::FRAC_1_PI;
        beta *= a;
        if vertex >= RR_START {
            let survive = beta.max_element().min(0.95);
            if survive <= 0.0 || rng.next_f32() >= survive {
                break;
            }
            beta /= survive;
        }
        point = next.point;
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_directions_have_the_cosine_lobes_moments() {
        // E[cos] = 2/3 and E[cos^2] = 1/2 under p = cos / pi; every direction above the plane.
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut rng = Rng::new(1);
        let (mut m1, mut m2, count) = (0.0f64, 0.0f64, 200_000);
        for _ in 0..count {
            let d = cosine_direction(n, rng.next_f32(), rng.next_f32());
            assert!((d.length() - 1.0).abs() < 1e-5);
            let c = d.dot(n) as f64;
            assert!(c >= 0.0);
            m1 += c;
            m2 += c * c;
        }
        assert!((m1 / count as f64 - 2.0 / 3.0).abs() < 3e-3, "{}", m1 / count as f64);
        assert!((m2 / count as f64 - 0.5).abs() < 3e-3, "{}", m2 / count as f64);
    }

    /// A point seen past its shading plane: its shading normal (on the incoming ray's side)
    /// lies 60 degrees under the geometric plane (30 from its downward normal), so
    /// (1 + cos 30) / 2 = 93.3% of its cosine lobe points under that plane. Those bounces go
    /// on from the plane's other side and meet the wide quad 1 m under it (the rest leave
    /// upward into nothing), as its light samples under the plane are traced from there.
    /// Within 0.02 (10^4 bounces: sigma 0.0025). Ending them at the surface, as before, met
    /// none.
    #[test]
    fn a_bounce_under_the_geometric_plane_goes_on_from_its_other_side() {
        use crate::geometry::camera::Camera;
        use crate::geometry::light::RectLight;
        use crate::geometry::ray_origin::point_error;
        use crate::load::gltf_load::Geometry;
        use glam::DVec3;
        let mut g = Geometry::default();
        g.add_quad(DVec3::ZERO, DVec3::X * 4.0, DVec3::NEG_Z * 4.0, [0.5; 3]);
        g.add_quad(DVec3::NEG_Y, DVec3::X * 1000.0, DVec3::NEG_Z * 1000.0, [0.5; 3]);
        let light = RectLight::new(Vec3::Y * 2.0, Vec3::X, Vec3::Z, Vec3::ONE);
        let camera = Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        let scene = Scene::build(g, vec![light], camera, glam::DVec3::ZERO, std::time::Duration::ZERO);
        let p = Vec3::new(0.1, 0.0, 0.2);
        let tilt = 150f32.to_radians();
        let n_shading = Vec3::new(tilt.sin(), tilt.cos(), 0.0);
        let point = ShadingPoint { p, p_error: point_error(p), n_geom: Vec3::Y, n_shading };
        let mut rng = Rng::new(3);
        let count = 10_000;
        let under = (0..count)
            .filter(|_| bounce(&scene, &point, &mut rng).is_some_and(|h| h.point.p.y < -0.5))
            .count();
        let share = under as f64 / count as f64;
        let expected = (1.0 + 30f64.to_radians().cos()) / 2.0;
        assert!((share - expected).abs() < 0.02, "{share} of bounces under the plane, expected {expected}");
    }

    #[test]
    fn primary_shadow_seeds_are_the_direct_renderers() {
        let id = PathId { pixel: [3, 4], pixel_index: 99, sample: 2, seed: 7 };
        assert_eq!(id.shadow_seed(1, 1, 0), stream_seed(&[7, 99, 2, 1, TAG_SHADOW]));
        assert_ne!(id.shadow_seed(1, 2, 0), id.shadow_seed(1, 1, 0));
        assert_ne!(id.shadow_seed(1, 2, 0), id.shadow_seed(1, 3, 0));
    }
}
