//! Shaft culling (Haines & Wallace 1994, in spirit): one conservative BVH query that proves a
//! whole bundle of shadow rays unblocked, so that none of them need tracing.
//!
//! The shaft of a shading point is the convex hull of its ray origin (the apex: exactly the
//! origin [`crate::geometry::ray_origin::offset_origin`] gives every ray above the tangent plane) and
//! the light's rectangle, cut by a plane just under the apex, parallel to the tangent plane
//! (the receiver's own surface lies below it) and by a plane just in front of the light (rays stop
//! short of the light: [`crate::geometry::ray_origin::shadow_ray`]). Every shadow ray from the point to
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
//! the rays' rounding (gamma(16) of their length) and gamma(32) of the apex's magnitude; the
//! f64 intersector's acceptance (relative to each triangle's own distance from the ray's
//! origin) lies inside each test's rounding, so no margin grows with the scene's size.
//! The two faces that must separate touching geometry take no such slack: the cut sits just
//! under the apex (its height `h_o` over the point less gamma(8) of it, the rounding of
//! `h_o`), and covered rays end at least `h_o` above the point ([`covers`]); the light's face
//! sits at half of `SHADOW_EPSILON x` the apex's height over the light's plane, where every
//! ray ends at least that far in front (it stops that fraction of its length short of a
//! point not behind the plane).

use crate::geometry::instanced::{InstancedScene, Placed};
use crate::geometry::light::RectLight;
use crate::geometry::point::ShadingPoint;
use crate::geometry::ray_origin::{SHADOW_EPSILON, gamma, offset_origin};
use crate::geometry::scene::Scene;
use crate::geometry::shaft_plane;
use glam::{Vec3, Vec3A};
use obvhs::bvh2::node::Bvh2Node;

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

/// Whether the shadow ray from surface point `point` (from `origin`) to light point `target`
/// (error bound `target_error`) lies in that point's shafts: its target is at least the
/// apex's height `h_o` over the tangent plane (and `2 SHADOW_EPSILON` of it: the ray stops
/// that fraction short), plus the target's error (twice: its rounding and its offset) and
/// gamma(16) of its distance, so the whole ray stays at or above `h_o`, over the cut.
#[inline]
pub fn covers(point: &ShadingPoint, origin: Vec3, target: Vec3, target_error: Vec3) -> bool {
    let w = target - point.p;
    Cover::new(point, origin, target_error).covers(point.n_geom.dot(w), w)
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
    pub fn new(point: &ShadingPoint, origin: Vec3, target_error: Vec3) -> Self {
        let h_o = point.n_geom.dot(origin - point.p);
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
pub fn covers_light(point: &ShadingPoint, origin: Vec3, light: &RectLight) -> bool {
    let (p, n_geom) = (point.p, point.n_geom);
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
    /// Four sides (the origin with each light edge), the light's plane, the cut above the
    /// tangent plane, and two optional depth clips ([`Shaft::clip_depth`]; inactive: never
    /// outside).
    faces: [Face; 8],
    /// The hull's vertices (the origin and the light's corners): a superset of the cut shaft,
    /// for the triangle-plane axis.
    vertices: [Vec3A; 5],
    /// How far covered rays may stray outside the hull of `vertices` (light-point error,
    /// ray rounding, the intersector's acceptance): the triangle-plane axis's slack, per unit
    /// of its normal's length.
    slack: f32,
}

impl Shaft {
    /// The shaft of surface point `point` (its geometric normal on the side the light is
    /// tested from) toward `light`.
    ///
    /// It holds every shadow ray of [`crate::geometry::ray_origin::shadow_ray`] from the point to a
    /// light point the [`covers`] test accepts. `None` if the light's rectangle is degenerate or the
    /// apex is not clearly in front of it.
    pub fn new(light: &RectLight, point: &ShadingPoint) -> Option<Shaft> {
        Self::to_part(light, [0.0, 1.0], [0.0, 1.0], point)
    }

    /// The shaft to the part `a in [a0, a1], b in [b0, b1]` of the light (the coordinates of
    /// [`RectLight::point`]).
    pub fn to_part(light: &RectLight, a: [f32; 2], b: [f32; 2], point: &ShadingPoint) -> Option<Shaft> {
        let origin = offset_origin(point, point.n_geom);
        Self::with_apex(light, a, b, point, origin)
    }

    /// [`Shaft::to_part`] for rays that all start at `apex`, above the point's tangent plane
    /// (its own error bound is not read).
    pub(crate) fn with_apex(
        light: &RectLight,
        a: [f32; 2],
        b: [f32; 2],
        point: &ShadingPoint,
        apex: Vec3,
    ) -> Option<Shaft> {
        let (p, n_geom) = (point.p, point.n_geom);
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
        // No term of the scene's size: the intersector works in f64 relative to the ray's
        // origin, so what it accepts beyond a triangle (~1e-14 of the triangle's distance
        // from the apex) lies far inside each test's own f32 rounding of that distance. A far
        // triangle once widened every shaft (a 1 m quad at 10^6 m: 13.5x the rays).
        let slack = 3.0 * e_light + gamma(16) * reach + gamma(32) * apex.abs().max_element();
        let mut faces = side_faces(&hull, slack)?;
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

    /// The hull of a ball (`centre`, `radius`) and the light, without a cut: it holds the
    /// hull [`Shaft::without_cut`] of every apex inside the ball (the radius is in every
    /// separating axis's slack; the light's face is where the ball's lowest point would put
    /// it): whatever meets the hull of an apex in the ball (grown by that apex's own slack)
    /// it cannot separate. (Not a superset of what an apex's own shaft keeps: that shaft's
    /// rounding margins may keep a little more.)
    /// For queries shared by neighbouring points. `None` where the ball is not clearly in
    /// front of the light.
    pub fn around_ball(light: &RectLight, centre: Vec3, radius: f32) -> Option<Shaft> {
        if !is_positive(light.area()) || radius.is_nan() || radius < 0.0 {
            return None;
        }
        let corners =
            [light.point(0.0, 0.0), light.point(1.0, 0.0), light.point(1.0, 1.0), light.point(0.0, 1.0)];
        let e_light = light.max_point_error().element_sum();
        let reach =
            corners.iter().map(|&c| (c - centre).abs().element_sum()).fold(0.0, f32::max) + 2.0 * radius;
        let height = light.normal.dot(centre - light.center) - radius;
        let in_front = 0.5 * SHADOW_EPSILON * height;
        if !is_positive(in_front - 2.0 * gamma(8) * reach) || !reach.is_finite() {
            return None;
        }
        let c = Vec3A::from(centre);
        let hull = [c, corners[0].into(), corners[1].into(), corners[2].into(), corners[3].into()];
        let magnitude = centre.abs().max_element() + radius;
        // The radius in the slack: every separating axis (side faces, a triangle's plane)
        // then allows for the ball (a unit normal's rounding: 1e-5 of the radius more).
        let slack = 3.0 * e_light + gamma(16) * reach + gamma(32) * magnitude + radius * (1.0 + 1e-5);
        let mut faces = side_faces(&hull, slack)?;
        let n_light = Vec3A::from(light.normal);
        faces[4] = Face { normal: -n_light, anchor: light.center.into(), offset: -in_front, slack: 0.0 };
        Some(Shaft { faces, vertices: hull, slack })
    }

    /// The whole hull of the apex and the light, without the cut under the apex: it holds
    /// every segment from the apex to the light, also those that dip under the point's
    /// tangent plane (methods that reason about all of them, not only the covered rays).
    pub fn without_cut(mut self) -> Shaft {
        self.faces[5].offset = f32::INFINITY;
        self
    }

    /// The part of the shaft between two planes parallel to the light's: points `x` with
    /// `axis . (x - origin)` (the depth along the light's unit normal `axis`, from its centre
    /// `origin`) in `[lo, hi]`, widened by `slack` plus the rounding of each evaluation.
    /// Proving this part clear proves clear the part of every covered ray inside that depth
    /// range; the rest of each ray is another test's business. `lo = -inf` or `hi = inf`
    /// leave that side open.
    pub fn clip_depth(mut self, axis: Vec3, origin: Vec3, lo: f32, hi: f32, slack: f32) -> Shaft {
        let (axis, origin) = (Vec3A::from(axis), Vec3A::from(origin));
        if hi.is_finite() {
            self.faces[6] = Face { normal: axis, anchor: origin, offset: hi, slack };
        }
        if lo.is_finite() {
            self.faces[7] = Face { normal: -axis, anchor: origin, offset: -lo, slack };
        }
        self
    }

    /// Whether the box `[min, max]` lies wholly outside one face.
    #[inline]
    pub fn box_outside(&self, min: Vec3A, max: Vec3A) -> bool {
        self.faces.iter().any(|f| {
            // The box corner deepest inside the face: if even it is outside, all are.
            let v = Vec3A::select(f.normal.cmpge(Vec3A::ZERO), min, max);
            f.outside(v)
        })
    }

    /// Whether the segment `a b` lies wholly outside one face (a superset of the segments
    /// that meet the shaft is kept).
    #[inline]
    pub fn segment_outside(&self, a: Vec3A, b: Vec3A) -> bool {
        self.faces.iter().any(|f| f.outside(a) && f.outside(b))
    }

    /// [`Shaft::segment_outside`] for a shaft with no cut and no depth clips
    /// ([`Shaft::without_cut`], [`Shaft::around_ball`]): its four sides and the light's face
    /// only (the others are never outside: skipping them saves a third of the test, which
    /// `silhouette` runs per candidate edge and point).
    #[inline]
    pub fn segment_outside_hull(&self, a: Vec3A, b: Vec3A) -> bool {
        debug_assert!(self.faces[5..].iter().all(|f| f.offset == f32::INFINITY));
        self.faces[..5].iter().any(|f| f.outside(a) && f.outside(b))
    }

    /// Whether the triangle is separated from the shaft by one of its faces or by its own
    /// plane.
    #[inline]
    pub fn triangle_outside(&self, v0: Vec3A, v1: Vec3A, v2: Vec3A) -> bool {
        if self.faces.iter().any(|f| f.outside(v0) && f.outside(v1) && f.outside(v2)) {
            return true;
        }
        // The triangle's normal as an axis: any axis separates if the projections do, so a
        // sliver's inexact normal costs nothing; the triangle's own vertices are projected
        // too (not assumed at 0), each projection with its rounding. In f32 where its
        // products stay finite and normal; in f64 otherwise (a triangle over ~4e9 m wide
        // overflowed |n|^2 and disabled every shaft next to it: `traced` cast 6.9x the rays
        // beside a 1e10 m floor).
        let (hull, slack) = (&self.vertices, self.slack);
        match shaft_plane::separates(hull, slack, [v0, v1, v2]) {
            Some(separated) => separated,
            None => shaft_plane::separates_f64(hull, slack, [v0, v1, v2]),
        }
    }
}

/// The four side faces of the hull of `hull[0]` (the apex) and the light's corners
/// `hull[1..]` (unused faces after them: never outside). `None` if a side is degenerate.
fn side_faces(hull: &[Vec3A; 5], slack: f32) -> Option<[Face; 8]> {
    let apex = hull[0];
    let corners = &hull[1..];
    // Unused faces (the depth clips until set) have a zero normal and an infinite offset:
    // nothing is outside them.
    let mut faces = [Face { normal: Vec3A::ZERO, anchor: Vec3A::ZERO, offset: f32::INFINITY, slack: 0.0 }; 8];
    // Orientation: the centre of the hull is inside every side face.
    let centre = 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
    let inner = 0.2 * apex + 0.8 * centre;
    for i in 0..4 {
        let (a, b) = (corners[i], corners[(i + 1) % 4]);
        // The light edge crossed with the long edge to the apex: two well-separated
        // directions. Any direction is a valid axis: the offset below is the hull's own
        // largest projection on it, so the normal's rounding costs nothing.
        let mut n = (b - a).cross(apex - a);
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
                let w = v - apex;
                n.dot(w) + gamma(5) * n.abs().dot(w.abs())
            })
            .fold(f32::NEG_INFINITY, f32::max);
        faces[i] = Face { normal: n, anchor: apex, offset, slack };
    }
    Some(faces)
}

impl Scene {
    /// Whether no triangle of the scene can meet `shaft` (alpha-tested ones count as solid):
    /// `true` proves every ray the shaft covers unblocked.
    pub fn shaft_clear(&self, shaft: &Shaft) -> bool {
        crate::util::pixel_cost::count_shaft();
        self.shaft_triangles(shaft, |_| false)
    }

    /// Calls `visit` with the slot of every triangle the shaft test cannot separate from
    /// `shaft` (a superset of those that meet it), in BVH order, until `visit` returns
    /// `false`; returns whether every call returned `true` (also when there was none).
    ///
    /// A kept instance's triangle (`Scene::instanced`) the shaft cannot separate ends the walk
    /// with `false`, unvisited (it has no slot): a proof of clearance fails there, and a
    /// method that needs every triangle refuses such scenes.
    pub fn shaft_triangles(&self, shaft: &Shaft, mut visit: impl FnMut(usize) -> bool) -> bool {
        if let Some(inst) = &self.instanced {
            let clear = |k: usize| {
                let p = &inst.placed[inst.tlas.primitive_indices[k] as usize];
                shaft.box_outside(p.bounds.min, p.bounds.max) || kept_clear(inst, p, shaft)
            };
            if !shaft_leaves(&inst.tlas, shaft, |_| false, |first, count| (first..first + count).all(clear)) {
                return false;
            }
        }
        let Some(bvh) = &self.bvh else { return true };
        shaft_leaves(
            bvh,
            shaft,
            |_| false,
            |first, count| {
                for (k, tri) in self.triangles[first..first + count].iter().enumerate() {
                    if !shaft.triangle_outside(tri.v0, tri.v1, tri.v2) && !visit(first + k) {
                        return false;
                    }
                }
                true
            },
        )
    }
}

/// Whether the shaft separates every triangle of the kept instance `p`: its mesh's tree
/// walked with each box carried into render space (in f64, grown by 2^-20 of its reach for
/// the f32 rounding; the tree's boxes already hold the placed corners' rounding), each leaf's
/// triangles placed as the flattened scene holds them and tested as it tests them.
fn kept_clear(inst: &InstancedScene, p: &Placed, shaft: &Shaft) -> bool {
    let linear = p.placing.linear().abs();
    let outside = |n: &Bvh2Node, _: usize| {
        let (lo, hi) = inst.render_box(p, &linear, &n.aabb);
        shaft.box_outside(lo, hi)
    };
    leaves_not_outside(&inst.meshes[p.mesh as usize].bvh, outside, |first, count| {
        (first..first + count).all(|slot| {
            let t = inst.render_triangle(p, slot);
            shaft.triangle_outside(t.v0, t.v1, t.v2)
        })
    })
}

/// Calls `leaf(first, count)` for every leaf of `bvh` whose box the shaft does not exclude
/// (its primitives are `first..first + count`, in the tree's order), until `leaf` returns
/// `false`; returns whether every call returned `true`. Any tree over any primitives: the
/// scene's triangles, or a method's own (silhouette edges). A node for which `skip(index)`
/// holds is not entered (the caller's own bound proves its subtree irrelevant).
pub fn shaft_leaves(
    bvh: &obvhs::bvh2::Bvh2,
    shaft: &Shaft,
    skip: impl Fn(usize) -> bool,
    leaf: impl FnMut(usize, usize) -> bool,
) -> bool {
    let outside =
        |node: &Bvh2Node, index: usize| shaft.box_outside(node.aabb.min, node.aabb.max) || skip(index);
    leaves_not_outside(bvh, outside, leaf)
}

/// Calls `leaf(first, count)` for every leaf of `bvh` reached through nodes for which
/// `outside(node, index)` is false, until `leaf` returns `false`; returns whether every call
/// returned `true`. The walk [`shaft_leaves`] and the kept instances' walks (their boxes
/// carried into render space first) share.
pub fn leaves_not_outside(
    bvh: &obvhs::bvh2::Bvh2,
    outside: impl Fn(&Bvh2Node, usize) -> bool,
    mut leaf: impl FnMut(usize, usize) -> bool,
) -> bool {
    let nodes = &bvh.nodes;
    if nodes.is_empty() {
        return true;
    }
    // A fixed stack: Bvh2 depth is bounded by obvhs's build (max_depth); 64 entries cover
    // any tree a scene of < 2^32 triangles builds here, and a deeper one is answered
    // `false` (the caller's conservative answer), never wrongly.
    let mut stack = [0u32; 64];
    let mut top = 0usize;
    let mut node_visit = |index: u32, stack: &mut [u32; 64], top: &mut usize| -> bool {
        let node = &nodes[index as usize];
        if outside(node, index as usize) {
            return true;
        }
        if node.prim_count == 0 {
            if *top == stack.len() {
                return false;
            }
            stack[*top] = node.first_index;
            *top += 1;
            return true;
        }
        leaf(node.first_index as usize, node.prim_count as usize)
    };
    if !node_visit(0, &mut stack, &mut top) {
        return false;
    }
    while top > 0 {
        top -= 1;
        let first = stack[top];
        for index in [first, first + 1] {
            if !node_visit(index, &mut stack, &mut top) {
                return false;
            }
        }
    }
    true
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

/// Which parts of the light `point` sees through a clear shaft: bit `x + LEAVES * y` is set
/// when no triangle can meet the shaft to leaf (x, y), where light sample (i, j) of an
/// `nx` x `ny` strata grid lies in leaf (i * lx / nx, j * ly / ny), `lx = min(LEAVES, nx)`
/// (likewise y). Tests the whole light, then halves each part that is not clear, down to
/// leaves or parts of fewer than [`MIN_SAMPLES_PER_SHAFT`] samples; returns the mask and how
/// many shafts it tested.
pub fn clear_leaves(
    scene: &Scene,
    light: &RectLight,
    point: &ShadingPoint,
    strata: (u32, u32),
) -> (u64, u32) {
    clear_leaves_mapped(scene, light, point, strata, true, |a, b| (a, b))
}

/// [`clear_leaves`] for samples drawn through a map of the strata square onto the light:
/// `part(a, b)` gives a part of the light (a, b ranges) holding the image of the strata block
/// `a x b` (e.g. [`crate::geometry::horizon_warp::HorizonWarp::bounds`]). Without
/// `subdivide`, only the whole light is tested.
pub fn clear_leaves_mapped(
    scene: &Scene,
    light: &RectLight,
    point: &ShadingPoint,
    strata: (u32, u32),
    subdivide: bool,
    part: impl Fn([f32; 2], [f32; 2]) -> ([f32; 2], [f32; 2]),
) -> (u64, u32) {
    let (nx, ny) = (strata.0 as usize, strata.1 as usize);
    let (lx, ly) = leaves_per_axis(strata);
    if lx == 0 || ly == 0 {
        return (0, 0);
    }
    let apex = offset_origin(point, point.n_geom);
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
        let Some(shaft) = Shaft::with_apex(light, a, b, point, apex) else { continue };
        tests += 1;
        if scene.shaft_clear(&shaft) {
            mask |= leaf_rect_bits([x0, x1], [y0, y1]);
            continue;
        }
        if !subdivide {
            break;
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
#[path = "shaft_tests.rs"]
mod tests;
