//! Shaft culling (Haines & Wallace 1994, in spirit): one conservative BVH query that proves a
//! whole bundle of shadow rays unblocked, so that none of them need tracing.
//!
//! The shaft of a shading point is the convex hull of its ray origin (the apex: exactly the
//! origin [`crate::ray_origin::offset_origin`] gives every ray above the tangent plane) and
//! the light's rectangle, cut by a plane just under the apex, parallel to the tangent plane
//! (the receiver's own surface lies below it) and by a plane just in front of the light (rays stop
//! short of the light: [`crate::ray_origin::shadow_ray`]). Every shadow ray from the point to
//! a light sample that [`covers`] accepts lies inside it. If no triangle can meet the shaft,
//! each of those rays is unblocked, and a traced query gives the same bits without tracing
//! them.
//!
//! The test is conservative: a triangle counts unless one separating plane is found among
//! the shaft's faces (all three vertices outside one face) or the triangle's own plane (every
//! shaft vertex on one side). A triangle it cannot separate makes the shaft "not clear" and
//! the caller traces, so a miss costs speed, never accuracy. Alpha-tested triangles count as
//! solid for the same reason.
//!
//! Margins (no scene-sized epsilon): each face is anchored at a point and a vertex counts as
//! outside only by more than gamma(5) of `|normal| . |vertex - anchor|`, the rounding of its
//! own evaluation. The side faces' offsets are the largest projection of the hull's own
//! vertices, plus the light points' error bound (3x: sample, corner, the target's offset),
//! the rays' rounding (gamma(16) of their length) and gamma(32) of the scene's largest
//! coordinate for the intersector's acceptance rounding: slack there only costs culling.
//! The two faces that must separate touching geometry take no such slack: the cut sits just
//! under the apex (its height `h_o` over the point less gamma(8) of it, the rounding of
//! `h_o`), and covered rays end at least `h_o` above the point ([`covers`]); the light's face
//! sits at half of `SHADOW_EPSILON x` the apex's height over the light's plane, where every
//! ray ends at least that far in front (it stops that fraction of its length short of a
//! point not behind the plane).

use crate::light::RectLight;
use crate::ray_origin::{SHADOW_EPSILON, gamma, offset_origin};
use crate::scene::Scene;
use glam::{Vec3, Vec3A};

/// `x > 0` (false for NaN).
#[inline]
fn is_positive(x: f32) -> bool {
    x > 0.0
}

/// A plane `normal . (x - anchor) <= offset` bounding the shaft (inside). A point is outside
/// by more than `slack` plus the rounding of its own evaluation.
#[derive(Debug, Clone, Copy)]
struct Face {
    normal: Vec3A,
    anchor: Vec3A,
    offset: f32,
    slack: f32,
}

impl Face {
    #[inline]
    fn outside(&self, v: Vec3A) -> bool {
        let w = v - self.anchor;
        self.normal.dot(w) > self.offset + self.slack + gamma(5) * self.normal.abs().dot(w.abs())
    }
}

/// Whether the shadow ray from surface point `p` (origin `origin`, geometric normal
/// `n_geom`) to light point `target` (error bound `target_error`) lies in that point's
/// shafts: its target is at least the apex's height `h_o` over the tangent plane (and
/// `2 SHADOW_EPSILON` of it: the ray stops that fraction short), plus the target's error
/// (twice: its rounding and its offset) and gamma(16) of its distance, so the whole ray stays
/// at or above `h_o`, over the cut.
#[inline]
pub fn covers(p: Vec3, origin: Vec3, n_geom: Vec3, target: Vec3, target_error: Vec3) -> bool {
    let w = target - p;
    Cover::new(p, origin, n_geom, target_error).covers(n_geom.dot(w), w)
}

/// [`covers`] with its per-point terms evaluated once: for every target whose error bound is
/// at most `target_error` in each component (e.g. [`RectLight::max_point_error`] for any
/// point of the light), [`Cover::covers`] accepts only rays [`covers`] accepts with the
/// target's own bound (the same expression, and f32 rounding is monotone). With the exact
/// bound it is [`covers`], bit for bit.
#[derive(Debug, Clone, Copy)]
pub struct Cover {
    /// `h_o (1 + 2 SHADOW_EPSILON) + 2 (sum of the target's error)`.
    floor: f32,
}

impl Cover {
    #[inline]
    pub fn new(p: Vec3, origin: Vec3, n_geom: Vec3, target_error: Vec3) -> Self {
        let h_o = n_geom.dot(origin - p);
        Cover {
            floor: h_o * (1.0 + 2.0 * SHADOW_EPSILON)
                + 2.0 * (target_error.x + target_error.y + target_error.z),
        }
    }

    /// Whether the ray to the target at `w = target - p` (`height = n_geom . w`) is covered.
    #[inline]
    pub fn covers(&self, height: f32, w: Vec3) -> bool {
        height >= self.floor + gamma(16) * w.abs().element_sum()
    }
}

/// Whether [`covers`] accepts every point of `light` (within its error bound), from its
/// corners: the height over the tangent plane is affine, so the lowest sample is no lower
/// than the lowest corner less the corners' and the sample's rounding; the distance term is
/// taken at the farthest corner.
pub fn covers_light(p: Vec3, origin: Vec3, n_geom: Vec3, light: &RectLight) -> bool {
    let corners = light.corners();
    let e = light.max_point_error().element_sum();
    let far = corners.iter().map(|&c| (c - p).abs().element_sum()).fold(0.0, f32::max) + e;
    let h_o = n_geom.dot(origin - p);
    corners
        .iter()
        .all(|&c| n_geom.dot(c - p) >= h_o * (1.0 + 2.0 * SHADOW_EPSILON) + 4.0 * e + gamma(16) * far)
}

/// The shaft from one shading point to a rectangular light (see the module docs).
#[derive(Debug, Clone, Copy)]
pub struct Shaft {
    /// Four sides (the origin with each light edge), the light's plane and the cut above the
    /// tangent plane.
    faces: [Face; 6],
    /// The hull's vertices (the origin and the light's corners): a superset of the cut shaft,
    /// for the triangle-plane axis.
    vertices: [Vec3A; 5],
    /// How far covered rays may stray outside the hull of `vertices` (light-point error,
    /// ray rounding, the intersector's acceptance): the triangle-plane axis's slack, per unit
    /// of its normal's length.
    slack: f32,
}

impl Shaft {
    /// The shaft of surface point `p` (error bound `p_error`, unit geometric normal `n_geom`,
    /// on the side the light is tested from) toward `light`, in a scene whose coordinates are
    /// at most `scene_bound` in magnitude ([`Scene::coordinate_bound`]).
    ///
    /// It holds every shadow ray of [`crate::ray_origin::shadow_ray`] from `p` to a light
    /// point the [`covers`] test accepts. `None` if the light's rectangle is degenerate or the
    /// apex is not clearly in front of it.
    pub fn new(light: &RectLight, p: Vec3, p_error: Vec3, n_geom: Vec3, scene_bound: f32) -> Option<Shaft> {
        Self::to_part(light, [0.0, 1.0], [0.0, 1.0], p, p_error, n_geom, scene_bound)
    }

    /// The shaft to the part `a in [a0, a1], b in [b0, b1]` of the light (the coordinates of
    /// [`RectLight::point`]).
    pub fn to_part(
        light: &RectLight,
        a: [f32; 2],
        b: [f32; 2],
        p: Vec3,
        p_error: Vec3,
        n_geom: Vec3,
        scene_bound: f32,
    ) -> Option<Shaft> {
        let origin = offset_origin(p, p_error, n_geom, n_geom);
        Self::with_apex(light, a, b, p, n_geom, origin, scene_bound)
    }

    /// [`Shaft::to_part`] for rays that all start at `apex`, above `p`'s tangent plane.
    pub(crate) fn with_apex(
        light: &RectLight,
        a: [f32; 2],
        b: [f32; 2],
        p: Vec3,
        n_geom: Vec3,
        apex: Vec3,
        scene_bound: f32,
    ) -> Option<Shaft> {
        if !is_positive((a[1] - a[0]) * (b[1] - b[0])) || !is_positive(light.area()) {
            return None;
        }
        let corners = [
            light.point(a[0], b[0]),
            light.point(a[1], b[0]),
            light.point(a[1], b[1]),
            light.point(a[0], b[1]),
        ];
        let e_light = light.max_point_error().element_sum();
        let reach = corners.iter().map(|&c| (c - apex).abs().element_sum()).fold(0.0, f32::max);
        // The apex's height over the light's plane: every ray ends at least SHADOW_EPSILON of
        // it in front of the plane, less its rounding (gamma(8) of its length). Too close to
        // the plane for that margin: trace every ray.
        let height = light.normal.dot(apex - light.center);
        let in_front = 0.5 * SHADOW_EPSILON * height;
        if !is_positive(in_front - 2.0 * gamma(8) * reach) || !reach.is_finite() {
            return None;
        }
        let h_o = n_geom.dot(apex - p);
        if !is_positive(h_o) {
            return None;
        }
        let apex_a = Vec3A::from(apex);
        let hull = [apex_a, corners[0].into(), corners[1].into(), corners[2].into(), corners[3].into()];
        let slack = 3.0 * e_light + gamma(16) * reach + gamma(32) * scene_bound.max(apex.abs().max_element());
        let mut faces = [Face { normal: Vec3A::ZERO, anchor: Vec3A::ZERO, offset: 0.0, slack: 0.0 }; 6];
        // Orientation: the centre of the hull is inside every side face.
        let centre = 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
        let inner = Vec3A::from(0.2 * apex + 0.8 * centre);
        for i in 0..4 {
            let (a, b) = (Vec3A::from(corners[i]), Vec3A::from(corners[(i + 1) % 4]));
            // The light edge crossed with the long edge to the apex: two well-separated
            // directions. Any direction is a valid axis: the offset below is the hull's own
            // largest projection on it, so the normal's rounding costs nothing.
            let mut n = (b - a).cross(apex_a - a);
            let len = n.length();
            if !is_positive(len) || !len.is_finite() {
                return None;
            }
            n /= len;
            if n.dot(inner - a) > 0.0 {
                n = -n;
            }
            let offset = hull
                .iter()
                .map(|&v| {
                    let w = v - apex_a;
                    n.dot(w) + gamma(5) * n.abs().dot(w.abs())
                })
                .fold(f32::NEG_INFINITY, f32::max);
            faces[i] = Face { normal: n, anchor: apex_a, offset, slack };
        }
        // The light's plane: inside is n_light . (x - centre) >= in_front.
        let n_light = Vec3A::from(light.normal);
        faces[4] = Face { normal: -n_light, anchor: light.center.into(), offset: -in_front, slack: 0.0 };
        // The cut: n_geom . (x - p) >= h_o (1 - gamma(8)), under the apex by more than the
        // rounding of h_o (o - p is exact, its dot product has terms of one sign). Covered
        // rays stay at >= h_o ([`covers`]); the receiver's own surface lies at most its error
        // bound from p, h_o, plus its tilt against n_geom: below the cut unless p's actual
        // rounding nearly reaches its bound or the triangle is large against its distance
        // from the origin (then the shaft is not clear and the rays are traced).
        let n = Vec3A::from(n_geom);
        faces[5] = Face { normal: -n, anchor: p.into(), offset: -(h_o * (1.0 - gamma(8))), slack: 0.0 };
        Some(Shaft { faces, vertices: hull, slack })
    }

    /// Whether the box `[min, max]` lies wholly outside one face.
    #[inline]
    fn box_outside(&self, min: Vec3A, max: Vec3A) -> bool {
        self.faces.iter().any(|f| {
            // The box corner deepest inside the face: if even it is outside, all are.
            let v = Vec3A::select(f.normal.cmpge(Vec3A::ZERO), min, max);
            f.outside(v)
        })
    }

    /// Whether the triangle is separated from the shaft by one of its faces or by its own
    /// plane.
    #[inline]
    fn triangle_outside(&self, v0: Vec3A, v1: Vec3A, v2: Vec3A) -> bool {
        if self.faces.iter().any(|f| f.outside(v0) && f.outside(v1) && f.outside(v2)) {
            return true;
        }
        // The triangle's normal as an axis: any axis separates if the projections do, so a
        // sliver's inexact normal costs nothing; the triangle's own vertices are projected
        // too (not assumed at 0), each projection with its rounding.
        let (e1, e2) = (v1 - v0, v2 - v0);
        let n = e1.cross(e2);
        let len = n.length();
        if !is_positive(len) || !len.is_finite() {
            return false;
        }
        let na = n.abs();
        let proj = |w: Vec3A| (n.dot(w), gamma(5) * na.dot(w.abs()));
        let (mut tri_lo, mut tri_hi) = (0.0f32, 0.0f32);
        for w in [e1, e2] {
            let (s, r) = proj(w);
            tri_lo = tri_lo.min(s - r);
            tri_hi = tri_hi.max(s + r);
        }
        let margin = self.slack * len;
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for v in self.vertices {
            let (s, r) = proj(v - v0);
            lo = lo.min(s - r);
            hi = hi.max(s + r);
        }
        lo > tri_hi + margin || hi < tri_lo - margin
    }
}

impl Scene {
    /// Whether no triangle of the scene can meet `shaft` (alpha-tested ones count as solid):
    /// `true` proves every ray the shaft covers unblocked.
    pub fn shaft_clear(&self, shaft: &Shaft) -> bool {
        let Some(bvh) = &self.bvh else { return true };
        let nodes = &bvh.nodes;
        if nodes.is_empty() {
            return true;
        }
        // A fixed stack: Bvh2 depth is bounded by obvhs's build (max_depth); 64 entries cover
        // any tree a scene of < 2^32 triangles builds here, and a deeper one is answered
        // "not clear" (trace), never wrongly.
        let mut stack = [0u32; 64];
        let mut top = 0usize;
        let visit = |index: u32, stack: &mut [u32; 64], top: &mut usize| -> Option<bool> {
            let node = &nodes[index as usize];
            if shaft.box_outside(node.aabb.min, node.aabb.max) {
                return None;
            }
            if node.prim_count == 0 {
                if *top == stack.len() {
                    return Some(false);
                }
                stack[*top] = node.first_index;
                *top += 1;
                return None;
            }
            let first = node.first_index as usize;
            for tri in &self.triangles[first..first + node.prim_count as usize] {
                if !shaft.triangle_outside(tri.v0, tri.v1, tri.v2) {
                    return Some(false);
                }
            }
            None
        };
        if let Some(found) = visit(0, &mut stack, &mut top) {
            return found;
        }
        while top > 0 {
            top -= 1;
            let first = stack[top];
            for index in [first, first + 1] {
                if let Some(found) = visit(index, &mut stack, &mut top) {
                    return found;
                }
            }
        }
        true
    }
}

/// Leaves per light axis of [`clear_leaves`]'s subdivision: the light splits into up to
/// `LEAVES` x `LEAVES` parts, each proven clear or not on its own.
pub const LEAVES: usize = 4;

/// A part of the light is tested only if it holds at least this many samples: a shaft test
/// costs a few rays' worth of traversal, more where it fails deep in a large scene.
/// Measured at 240x180 (render seconds, culling off -> on, thresholds 1 / 16 / 64 / 256):
/// at N = 64 a threshold of 1 made sauerbraten-zdm2 1.7x slower than no culling, 64 left it
/// even (0.44 s); at N = 1024, 64 gave 5.6 -> 4.4 s there, 1.74 -> 0.79 s on
/// monobloc-chair, 3.96 -> 2.20 s on toy-car and 1.84 -> 0.56 s on the default scene,
/// within noise of the best threshold everywhere.
pub const MIN_SAMPLES_PER_SHAFT: usize = 64;

/// Which parts of the light `p` sees through a clear shaft: bit `x + LEAVES * y` is set when
/// no triangle can meet the shaft to leaf (x, y), where light sample (i, j) of an `nx` x `ny`
/// strata grid lies in leaf (i * lx / nx, j * ly / ny), `lx = min(LEAVES, nx)` (likewise y).
/// Tests the whole light, then halves each part that is not clear, down to leaves or parts of
/// fewer than [`MIN_SAMPLES_PER_SHAFT`] samples; returns the mask and how many shafts it
/// tested.
pub fn clear_leaves(
    scene: &Scene,
    light: &RectLight,
    p: Vec3,
    p_error: Vec3,
    n_geom: Vec3,
    strata: (u32, u32),
) -> (u64, u32) {
    clear_leaves_mapped(scene, light, p, p_error, n_geom, strata, |a, b| (a, b))
}

/// [`clear_leaves`] for samples drawn through a map of the strata square onto the light:
/// `part(a, b)` gives a part of the light (a, b ranges) holding the image of the strata block
/// `a x b` (e.g. [`crate::light_sampling::HorizonWarp::bounds`]).
#[allow(clippy::too_many_arguments)]
pub fn clear_leaves_mapped(
    scene: &Scene,
    light: &RectLight,
    p: Vec3,
    p_error: Vec3,
    n_geom: Vec3,
    strata: (u32, u32),
    part: impl Fn([f32; 2], [f32; 2]) -> ([f32; 2], [f32; 2]),
) -> (u64, u32) {
    let (nx, ny) = (strata.0 as usize, strata.1 as usize);
    let (lx, ly) = leaves_per_axis(strata);
    if lx == 0 || ly == 0 {
        return (0, 0);
    }
    let apex = offset_origin(p, p_error, n_geom, n_geom);
    let scene_bound = scene.coordinate_bound();
    // The first stratum of leaf x (of l leaves over n strata); the light coordinate of the
    // leaf's lower edge is that over n.
    let first = |x: usize, n: usize, l: usize| (x * n).div_ceil(l);
    let mut mask = 0u64;
    let mut tests = 0u32;
    // Leaf rectangles [x0, x1) x [y0, y1) still to test: at most 1 + 3 per split level.
    let mut todo = [[0usize; 4]; 16];
    let mut top = 1;
    todo[0] = [0, lx, 0, ly];
    while top > 0 {
        top -= 1;
        let [x0, x1, y0, y1] = todo[top];
        let (i0, i1) = (first(x0, nx, lx), first(x1, nx, lx));
        let (j0, j1) = (first(y0, ny, ly), first(y1, ny, ly));
        if (i1 - i0) * (j1 - j0) < MIN_SAMPLES_PER_SHAFT {
            continue;
        }
        let a = [i0 as f32 / nx as f32, i1 as f32 / nx as f32];
        let b = [j0 as f32 / ny as f32, j1 as f32 / ny as f32];
        let (a, b) = part(a, b);
        let Some(shaft) = Shaft::with_apex(light, a, b, p, n_geom, apex, scene_bound) else { continue };
        tests += 1;
        if scene.shaft_clear(&shaft) {
            mask |= leaf_rect_bits([x0, x1], [y0, y1]);
            continue;
        }
        let (xm, ym) = ((x0 + x1) / 2, (y0 + y1) / 2);
        for (xa, xb) in [(x0, xm), (xm, x1)] {
            for (ya, yb) in [(y0, ym), (ym, y1)] {
                if xa < xb && ya < yb && (xb - xa, yb - ya) != (x1 - x0, y1 - y0) {
                    todo[top] = [xa, xb, ya, yb];
                    top += 1;
                }
            }
        }
    }
    (mask, tests)
}

/// The first stratum (of `n`) of leaf `x` (of `l` leaves on that axis): samples
/// `first_stratum(x) <= i < first_stratum(x + 1)` lie in leaf `x` ([`leaf_bit`]).
#[inline]
pub fn first_stratum(x: u32, n: u32, l: usize) -> u32 {
    (x * n).div_ceil(l as u32)
}

/// Leaves per axis for an `nx` x `ny` strata grid: at most [`LEAVES`], at most one per
/// stratum.
pub fn leaves_per_axis(strata: (u32, u32)) -> (usize, usize) {
    (LEAVES.min(strata.0 as usize), LEAVES.min(strata.1 as usize))
}

/// The mask bits of leaves [x0, x1) x [y0, y1).
fn leaf_rect_bits(x: [usize; 2], y: [usize; 2]) -> u64 {
    (y[0]..y[1]).flat_map(|j| (x[0]..x[1]).map(move |i| 1u64 << (i + LEAVES * j))).fold(0, |m, b| m | b)
}

/// Every leaf bit of an `nx` x `ny` strata grid: [`clear_leaves`]'s mask when the whole light
/// is clear.
pub fn all_leaves(strata: (u32, u32)) -> u64 {
    let (lx, ly) = leaves_per_axis(strata);
    leaf_rect_bits([0, lx], [0, ly])
}

/// The leaf of light sample (i, j) of an `nx` x `ny` strata grid, as a bit of
/// [`clear_leaves`]'s mask.
#[inline]
pub fn leaf_bit(i: u32, j: u32, strata: (u32, u32)) -> u64 {
    let (lx, ly) = leaves_per_axis(strata);
    1 << (i * lx as u32 / strata.0 + LEAVES as u32 * (j * ly as u32 / strata.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::gltf_load::Geometry;
    use crate::ray_origin::point_error;
    use crate::sampling::Rng;
    use crate::shadowing::{LightShadowing, PrepareContext, ShadowQuery};
    use crate::traced::{Traced, TracedParams};
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
        let shaft = Shaft::new(&s.lights[0], p, point_error(p), n, s.coordinate_bound()).expect("a shaft");
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
                    p,
                    p_error: point_error(p),
                    n_geom: ramp_normal,
                    n_shading: ramp_normal,
                    pixel: [0, 0],
                    seed: k,
                }
            } else {
                let p = Vec3::new(r(-3.0, 3.0), 0.0, r(-3.0, 3.0));
                let tilt = r(0.0, 1.48);
                let az = r(0.0, std::f32::consts::TAU);
                let n = Vec3::new(tilt.sin() * az.cos(), tilt.cos(), tilt.sin() * az.sin());
                ShadowQuery {
                    p,
                    p_error: point_error(p),
                    n_geom: Vec3::Y,
                    n_shading: n,
                    pixel: [0, 0],
                    seed: k,
                }
            };
            let (p, n) = (q.p, q.n_shading);
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
        let (mask, tests) = clear_leaves(&s, &s.lights[0], Vec3::ZERO, e, Vec3::Y, (32, 32));
        assert_eq!((mask.count_ones(), tests), ((LEAVES * LEAVES) as u32, 1));
        for (i, j) in [(0, 0), (31, 0), (0, 31), (31, 31), (13, 22)] {
            assert_ne!(mask & leaf_bit(i, j, (32, 32)), 0);
        }
        // 48 samples: fewer than MIN_SAMPLES_PER_SHAFT, nothing tested, nothing proven.
        assert_eq!(clear_leaves(&s, &s.lights[0], Vec3::ZERO, e, Vec3::Y, (8, 6)), (0, 0));
        // A plate over a corner of the light, seen from below its centre: the whole light
        // and one quadrant are blocked, the other three quadrants proven clear (4 leaves
        // each), and the blocked quadrant split once more.
        let plate = ([-0.25, 1.9, -0.25], [0.3, 0.0, 0.0], [0.0, 0.0, -0.3]);
        let s = scene(&[FLOOR, plate], light());
        let (mask, tests) = clear_leaves(&s, &s.lights[0], Vec3::ZERO, e, Vec3::Y, (32, 32));
        assert!(mask.count_ones() >= 12 && mask.count_ones() < 16, "mask {mask:#x}");
        assert!(tests >= 5, "{tests} tests");
    }

    fn triangles_scene(tris: &[[DVec3; 3]], light: RectLight) -> Scene {
        use crate::gltf_load::SourceTriangle;
        use crate::material::Material;
        let mut g = Geometry::default();
        g.materials.push(Material::diffuse([0.5; 3]));
        for t in tris {
            g.triangles.push(SourceTriangle { p: *t, n: None, uv: [glam::Vec2::ZERO; 3], material: 0 });
        }
        let camera = Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        Scene::build(g, vec![light], camera, DVec3::ZERO, Duration::ZERO)
    }

    fn quad_triangles(c: DVec3, u: DVec3, v: DVec3) -> [[DVec3; 3]; 2] {
        let k = |a: f64, b: f64| c + a * u + b * v;
        [[k(-0.5, -0.5), k(0.5, -0.5), k(0.5, 0.5)], [k(-0.5, -0.5), k(0.5, 0.5), k(-0.5, 0.5)]]
    }

    fn plain_and_culled(s: &Scene) -> (Traced, Traced) {
        let ctx = PrepareContext {
            scene: s,
            light: &s.lights[0],
            light_index: 0,
            visible: &[],
            seed: 0,
            mask_budget_bytes: u64::MAX,
        };
        let mut plain = Traced::new(TracedParams::plain(1024));
        let mut culled = Traced::new(TracedParams { samples: 1024, shaft_culling: true });
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
        let mut tris = quad_triangles(
            DVec3::new(0.0, -40.0, 0.0),
            DVec3::new(60.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, -60.0),
        )
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
            p,
            p_error: point_error(p),
            n_geom: Vec3::Y,
            n_shading: Vec3::Y,
            pixel: [0, 0],
            seed: 1,
        };
        let (a, b) = (plain.visibility(&s, &q), culled.visibility(&s, &q));
        assert_eq!(a, 0.0);
        assert_eq!(a.to_bits(), b.to_bits(), "plain {a} culled {b}");
        // The apex lies inside its side faces (with their slack) for every part of the light.
        for (a0, b0) in [(0.0, 0.0), (0.5, 0.5), (0.25, 0.75), (0.75, 0.0)] {
            let shaft = Shaft::to_part(
                &light,
                [a0, a0 + 0.25],
                [b0, b0 + 0.25],
                q.p,
                q.p_error,
                q.n_geom,
                s.coordinate_bound(),
            )
            .unwrap();
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
                    p,
                    p_error: point_error(p),
                    n_geom: n,
                    n_shading: n,
                    pixel: [0, 0],
                    seed: k,
                };
                differ +=
                    usize::from(plain.visibility(&s, &q).to_bits() != culled.visibility(&s, &q).to_bits());
            }
        }
        assert_eq!(differ, 0, "{differ} of 1800 points differ");
    }
}
