//! Silhouette edges on kept instances ([`renderer::Scene::instanced`]): each stored mesh's edges
//! are found once, in the mesh's own space, under a tree with normal cones; a point's walk
//! enters the mesh's tree for every instance its shaft meets and places each edge it keeps
//! in render space with the loader's arithmetic ([`InstancedScene::render_triangle`]'s:
//! the bits `traced` tests). Weights and counting then see the flattened scene's edges. An
//! instance's edges never pair with another's: two sides on one line are two edges whose
//! weights add up to the welded edge's.
//!
//! Pruning stays exact across the move. A node's box is carried into render space grown for
//! the placed corners' f32 rounding (as `traced`'s shaft culling carries its boxes). Its
//! cone is tested in the mesh's space (an affine map keeps which side of a plane a point
//! lies on), with the ball of origins carried there and grown by how far the f32 rounding
//! of the placed corners can tilt a face's plane at that distance (`tilt_margin`).
//!
//! An instance the counting cannot answer for is not counted: a point whose shaft meets it is
//! refused ([`GatherRefusal::KeptInstance`]; `silhouette` traces it whole). These are the ones with an
//! alpha-tested material, a triangle near the light's plane (as [`super::edges`] flags
//! them), or a nearly singular transform. An edge of more than two faces is split into
//! edges of one face (the counts are sums over faces).

use super::candidate::{Candidate, GatherRefusal, VARIES, block_weight};
use super::edge_tree::{Cone, EdgeRecord, cones, parents_first};
use super::welding::{pack_side, unpack_side};
use glam::{DMat3, DVec3, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use rayon::prelude::*;
use renderer::geometry::instanced::{InstancedScene, Placed, StoredMesh};
use renderer::geometry::instances::position_key;
use renderer::geometry::material::AlphaMode;
use renderer::geometry::shaft::{self, Shaft};
use renderer::{RectLight, Scene};
use std::time::Duration;

/// The kept instances' edges for one light.
#[derive(Default)]
pub(crate) struct KeptEdges {
    meshes: Vec<MeshEdges>,
    /// Per placed instance: how its edges are carried, or `None` where it is not counted.
    instances: Vec<Option<Carry>>,
    /// The light's corners grown as [`super::edges`] grows them (render space).
    light_corners: [DVec3; 4],
    /// Counted instances, and the unique edges of their meshes (the run report).
    pub(crate) counted: u64,
    pub(crate) mesh_edges: u64,
}

/// What bounds one instance's move between render space and its mesh's.
#[derive(Clone, Copy)]
struct Carry {
    /// Frobenius norms of the linear parts: mesh to render (`stretch`), render to mesh
    /// (`shrink`, so that a render-space altitude h is at least the mesh's over `shrink`).
    stretch: f64,
    shrink: f64,
    /// A bound on the rounding of a placed corner (render space): f32's, and the world
    /// placing's f64 ([`renderer::geometry::instances::Placing::rounding`]).
    rounding: f64,
    /// The placing's linear part, entries made positive (the boxes' move).
    linear_abs: DMat3,
    /// The largest term of the move into the mesh's space's translation: its rounding
    /// scales with it.
    move_scale: f64,
}

impl Carry {
    fn new(p: &Placed) -> Carry {
        let (lo, hi) = (Vec3::from(p.bounds.min), Vec3::from(p.bounds.max));
        let reach = lo.abs().max(hi.abs()).max_element() as f64;
        let linear = p.placing.linear();
        let norm = |m: DMat3| {
            (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt()
        };
        Carry {
            stretch: norm(linear),
            shrink: norm(DMat3::from_mat4(p.to_mesh)),
            rounding: reach * (1.0 / (1u64 << 22) as f64) + p.world_rounding,
            linear_abs: linear.abs(),
            move_scale: p.to_mesh.w_axis.truncate().abs().max_element(),
        }
    }
}

/// One stored mesh's edges (see the module doc).
#[derive(Default)]
struct MeshEdges {
    bvh: Option<Bvh2>,
    /// In leaf order.
    edges: Vec<MeshEdge>,
    cones: Vec<Cone>,
    /// Per node: the largest 1 / altitude of its edges' faces (mesh space).
    thin: Vec<f64>,
    /// A ball holding the mesh.
    centre: DVec3,
    radius: f64,
}

/// An edge in its mesh's space (the file's f32 positions, exact in f64), with the third
/// corners of its one or two faces.
#[derive(Clone, Copy)]
struct MeshEdge {
    a: DVec3,
    b: DVec3,
    thirds: [DVec3; 2],
    faces: u8,
    /// Whether its first face's winding runs a -> b (orients the cones' normals alike).
    forward: bool,
    /// Unit normals of (b - a) x (c_k - a) (zero for a face of no area).
    normals: [DVec3; 2],
    /// 1 / the smallest altitude of its faces ([`thinness`]).
    thin: f64,
}

impl std::fmt::Debug for KeptEdges {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KeptEdges")
            .field("meshes", &self.meshes.len())
            .field("counted", &self.counted)
            .finish()
    }
}

impl KeptEdges {
    /// The edges of `scene`'s kept instances for `light` (empty without any).
    pub(crate) fn build(scene: &Scene, light: &RectLight) -> KeptEdges {
        let Some(inst) = &scene.instanced else { return KeptEdges::default() };
        let meshes: Vec<MeshEdges> = inst.meshes.par_iter().map(MeshEdges::build).collect();
        let near = super::edges::near_light_band(scene, light);
        let (normal, centre) = (light.normal.as_dvec3(), light.center.as_dvec3());
        let mut kept = KeptEdges {
            mesh_edges: meshes.iter().map(|m| m.edges.len() as u64).sum(),
            light_corners: super::edges::light_corners_grown(light),
            ..Default::default()
        };
        for p in &inst.placed {
            let (lo, hi) = (Vec3::from(p.bounds.min), Vec3::from(p.bounds.max));
            let reach = lo.abs().max(hi.abs()).max_element() as f64;
            // Every corner of the box over the band (a triangle's own band adds 1e-5 of its
            // largest coordinate: at most the box's).
            let clear_of_light = (0..8).all(|i| {
                let x = DVec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x } as f64,
                    if i & 2 == 0 { lo.y } else { hi.y } as f64,
                    if i & 4 == 0 { lo.z } else { hi.z } as f64,
                );
                // A relative 1e-9 over the f64 rounding of each vertex's own test.
                normal.dot(x - centre) >= (near + 1e-5 * reach) + 1e-9 * (x.abs().max_element() + reach)
            });
            let alpha =
                p.materials.iter().any(|&m| !matches!(scene.materials[m as usize].alpha, AlphaMode::Opaque));
            let carry = Carry::new(p);
            let counted = clear_of_light && !alpha && !p.brute && carry.shrink.is_finite();
            kept.counted += counted as u64;
            kept.instances.push(counted.then_some(carry));
        }
        kept.meshes = meshes;
        kept
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> u64 {
        let mesh = |m: &MeshEdges| {
            let nodes = m.bvh.as_ref().map_or(0, |b| b.nodes.len() * std::mem::size_of_val(&b.nodes[0]));
            nodes
                + m.edges.len() * std::mem::size_of::<MeshEdge>()
                + m.cones.len() * std::mem::size_of::<Cone>()
                + m.thin.len() * 8
        };
        (self.meshes.iter().map(mesh).sum::<usize>()
            + self.instances.len() * std::mem::size_of::<Option<Carry>>()) as u64
    }

    /// Appends the kept instances' candidates for `shaft` (a hull) to `out`: with `weights`,
    /// each with its weight over the ball (`origin`, `radius`) and those of weight 0 left
    /// out; else [`VARIES`] (a single origin, `radius` 0). `walked` counts the edges the
    /// shaft test keeps; the walk stops with `Ok(false)` once it exceeds `max_walked`.
    /// `Err` where the shaft meets an instance that is not counted.
    pub(crate) fn gather(
        &self,
        scene: &Scene,
        shaft: &Shaft,
        (origin, radius): (DVec3, f64),
        weights: bool,
        out: &mut Vec<Candidate>,
        (walked, max_walked): (&mut usize, usize),
    ) -> Result<bool, GatherRefusal> {
        let Some(inst) = &scene.instanced else { return Ok(true) };
        let mut refused = None;
        let complete = shaft::shaft_leaves(
            &inst.tlas,
            shaft,
            |_| false,
            |first, count| {
                for &pi in &inst.tlas.primitive_indices[first..first + count] {
                    let p = &inst.placed[pi as usize];
                    if shaft.box_outside(p.bounds.min, p.bounds.max) {
                        continue;
                    }
                    let Some(carry) = &self.instances[pi as usize] else {
                        refused = Some(GatherRefusal::KeptInstance);
                        return false;
                    };
                    let mesh = &self.meshes[p.mesh as usize];
                    let walk =
                        Walk { inst, p, carry, shaft, origin, radius, weights, light: &self.light_corners };
                    if !mesh.walk(&walk, out, walked, max_walked) {
                        return false;
                    }
                }
                true
            },
        );
        match refused {
            Some(why) => Err(why),
            None => Ok(complete),
        }
    }
}

/// One instance's walk: where it is, the shaft and the origins' ball (render space).
struct Walk<'a> {
    inst: &'a InstancedScene,
    p: &'a Placed,
    carry: &'a Carry,
    shaft: &'a Shaft,
    origin: DVec3,
    radius: f64,
    weights: bool,
    light: &'a [DVec3; 4],
}

impl Walk<'_> {
    /// A mesh point placed in render space: [`InstancedScene::render_triangle`]'s bits.
    #[inline(always)]
    fn place(&self, x: DVec3) -> Vec3 {
        (self.p.placing.point(x) - self.inst.offset).as_vec3()
    }
}

impl MeshEdges {
    fn build(mesh: &StoredMesh) -> MeshEdges {
        let edges = mesh_edges(&mesh.points);
        if edges.is_empty() {
            return MeshEdges::default();
        }
        let boxes: Vec<Aabb> = edges
            .iter()
            .map(|e| {
                let (a, b) = (Vec3A::from(e.a.as_vec3()), Vec3A::from(e.b.as_vec3()));
                Aabb::new(a.min(b), a.max(b))
            })
            .collect();
        let params = obvhs::BvhBuildParams::fast_build();
        let bvh = obvhs::bvh2::builder::build_bvh2(&boxes, params, &mut Duration::default());
        let edges: Vec<MeshEdge> = bvh.primitive_indices.iter().map(|&i| edges[i as usize]).collect();
        let cones = cones(&bvh, |pos| planes(&edges[pos]));
        let thin = node_max(&bvh, |pos| edges[pos].thin);
        let (lo, hi) = (mesh.points.iter().flatten())
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let centre = 0.5 * (lo + hi);
        MeshEdges { bvh: Some(bvh), edges, cones, thin, centre, radius: 0.5 * (hi - lo).length() }
    }

    /// Walks this mesh's tree for one instance (see [`KeptEdges::gather`]); `false` where it
    /// stopped (too many edges, or a tree deeper than the traversal's stack).
    fn walk(&self, w: &Walk, out: &mut Vec<Candidate>, walked: &mut usize, max_walked: usize) -> bool {
        let Some(bvh) = &self.bvh else { return true };
        let m = InMesh::new(self, w);
        let outside = |node: &Bvh2Node, index: usize| {
            let (lo, hi) = w.inst.render_box(w.p, &w.carry.linear_abs, &node.aabb);
            w.shaft.box_outside(lo, hi) || m.smooth(index)
        };
        shaft::leaves_not_outside(bvh, outside, |first, count| {
            m.leaf(&self.edges[first..first + count], out, walked, max_walked)
        })
    }
}

/// One instance's walk of its mesh's tree, in the mesh's space: the origins' ball and the
/// light carried there, with bounds on the move's rounding.
struct InMesh<'a> {
    mesh: &'a MeshEdges,
    w: &'a Walk<'a>,
    /// The origins' centre in the mesh's space, and the move's rounding (f64, and the
    /// inverse's own; far over).
    y: DVec3,
    moved: f64,
    /// The light's grown corners in the mesh's space, their rounding, a ball holding them,
    /// and a bound on their distance to any point of the mesh.
    corners: [DVec3; 4],
    light_moved: f64,
    light_centre: DVec3,
    light_radius: f64,
    light_far: f64,
}

impl<'a> InMesh<'a> {
    fn new(mesh: &'a MeshEdges, w: &'a Walk<'a>) -> Self {
        let (to_mesh, shrink) = (&w.p.to_mesh, w.carry.shrink);
        let y = to_mesh.transform_point3(w.origin);
        let moved =
            1e-9 * (y.abs().max_element() + shrink * w.origin.abs().max_element() + w.carry.move_scale);
        let corners = w.light.map(|s| to_mesh.transform_point3(s));
        let light_moved = (corners.iter().zip(w.light))
            .map(|(m, s)| {
                1e-9 * (m.abs().max_element() + shrink * s.abs().max_element() + w.carry.move_scale)
            })
            .fold(0.0, f64::max);
        let light_centre = 0.25 * corners.iter().sum::<DVec3>();
        let light_radius = corners.iter().map(|&s| (s - light_centre).length()).fold(0.0, f64::max);
        let light_far = (light_centre - mesh.centre).length() + light_radius + mesh.radius;
        InMesh { mesh, w, y, moved, corners, light_moved, light_centre, light_radius, light_far }
    }

    /// How far (render space) the placed corners' f32 rounding can move a face's plane at
    /// distance `far` from it, for faces of 1 / altitude `thin` (mesh space; h, the
    /// render-space altitude, is at least the mesh's over `shrink`). Each corner moves by at
    /// most d = `rounding`: at a point whose projection on the plane has barycentric
    /// coordinates of magnitudes summing to at most 1 + 4 far / h, the plane moves by d
    /// times that, plus far (1 - cos tilt) for the normal's tilt (at most 4 d / h): under
    /// d (1 + 4.8 far / h) while d / h <= 0.05; 8 d (1 + far / h) is over it. `None` where
    /// d / h may exceed 0.05 (the bound is not small; NaN too).
    fn tilt(&self, thin: f64, far: f64) -> Option<f64> {
        let c = self.w.carry;
        let tilt = thin * c.shrink;
        (tilt * c.rounding <= 0.05).then_some(8.0 * c.rounding * (1.0 + far * tilt))
    }

    /// Whether a node's faces have the whole ball of origins on one side (their edges weigh
    /// 0), or the whole light (no edge of it is a silhouette seen from the light: no shadow
    /// ray's plane crosses it as one).
    fn smooth(&self, node: usize) -> bool {
        let (cone, thin, c, w) = (&self.mesh.cones[node], self.mesh.thin[node], self.w.carry, self.w);
        let reach = (self.y - cone.centre).length() + cone.reach;
        let origins = self
            .tilt(thin, c.stretch * reach + w.radius)
            .is_some_and(|m| cone.one_side(self.y, (w.radius + m) * c.shrink + self.moved));
        let reach = (self.light_centre - cone.centre).length() + cone.reach + self.light_radius;
        let radius = |m: f64| self.light_radius + m * c.shrink + self.light_moved;
        origins
            || self.tilt(thin, c.stretch * reach).is_some_and(|m| cone.one_side(self.light_centre, radius(m)))
    }

    /// [`Self::smooth`]'s two tests for one edge of two faces, before it is placed.
    fn needed(&self, e: &MeshEdge) -> bool {
        if e.faces != 2 {
            return true;
        }
        let (c, w) = (self.w.carry, self.w);
        let [n0, n1] = e.normals;
        let d = self.y - e.a;
        let Some(m) = self.tilt(e.thin, c.stretch * d.length() + w.radius) else { return true };
        let m = (w.radius + m) * c.shrink + self.moved;
        let (s0, s1) = (n0.dot(d), n1.dot(d));
        if (s0 > m && s1 < -m) || (s0 < -m && s1 > m) {
            return false;
        }
        let Some(m) = self.tilt(e.thin, c.stretch * self.light_far) else { return true };
        let m = m * c.shrink + self.light_moved;
        let side = |n: DVec3| {
            let d = self.corners.map(|s| n.dot(s - e.a));
            if d.iter().all(|&x| x > m) {
                1
            } else if d.iter().all(|&x| x < -m) {
                -1
            } else {
                0
            }
        };
        let (s0, s1) = (side(n0), side(n1));
        s0 == 0 || s0 != -s1
    }

    /// A leaf's edges the shaft test keeps, placed, into `out` (see [`KeptEdges::gather`]).
    fn leaf(
        &self,
        edges: &[MeshEdge],
        out: &mut Vec<Candidate>,
        walked: &mut usize,
        max_walked: usize,
    ) -> bool {
        let w = self.w;
        for e in edges.iter().filter(|e| self.needed(e)) {
            let (a, b) = (w.place(e.a), w.place(e.b));
            if w.shaft.segment_outside_hull(a.into(), b.into()) {
                continue;
            }
            *walked += 1;
            if *walked > max_walked {
                return false;
            }
            let thirds = [w.place(e.thirds[0]), w.place(e.thirds[1])];
            let record = EdgeRecord::from_points(a, b, &thirds[..e.faces as usize]);
            let weight = if w.weights { block_weight(&record, w.origin, w.radius) } else { VARIES };
            if weight != 0 {
                out.push(Candidate::new(&record, weight));
            }
        }
        true
    }
}

/// A stored mesh's edges: its slots' corners welded by bit-identical position, the sides
/// sorted into edges. A triangle whose welded corners repeat has no area, and the loader
/// keeps none such (it would be zero-area in every placing): left out.
fn mesh_edges(points: &[[DVec3; 3]]) -> Vec<MeshEdge> {
    let mut keys: Vec<u128> = Vec::with_capacity(3 * points.len());
    for (slot, c) in points.iter().enumerate() {
        keys.extend((0..3).map(|k| position_key(c[k].as_vec3(), (3 * slot + k) as u32)));
    }
    keys.par_sort_unstable();
    let mut id = vec![0u32; 3 * points.len()];
    let mut canonical = 0u32;
    for (n, &k) in keys.iter().enumerate() {
        if n == 0 || keys[n - 1] >> 32 != k >> 32 {
            canonical = k as u32;
        }
        id[k as u32 as usize] = canonical;
    }
    let at = |i: u32| points[i as usize / 3][i as usize % 3];
    let mut sides: Vec<u128> = Vec::with_capacity(3 * points.len());
    for slot in 0..points.len() {
        let c = [0, 1, 2].map(|k| id[3 * slot + k]);
        if c[0] != c[1] && c[1] != c[2] && c[0] != c[2] {
            sides.extend((0..3).map(|k| pack_side(c[k], c[(k + 1) % 3], c[(k + 2) % 3])));
        }
    }
    sides.par_sort_unstable();
    let mut edges = Vec::with_capacity(sides.len() / 2 + 1);
    for run in sides.chunk_by(|x, y| x >> 64 == y >> 64) {
        let (lo, hi, _, forward) = unpack_side(run[0]);
        let edge = |faces: &[u128], forward: bool| {
            let mut thirds = [DVec3::ZERO; 2];
            for (k, &s) in faces.iter().enumerate() {
                thirds[k] = at(unpack_side(s).2);
            }
            let (a, b) = (at(lo), at(hi));
            let normals = thirds.map(|c| (b - a).cross(c - a).normalize_or_zero());
            let mut e = MeshEdge { a, b, thirds, faces: faces.len() as u8, forward, normals, thin: 0.0 };
            e.thin = thinness(&e);
            e
        };
        if run.len() <= 2 {
            edges.push(edge(run, forward));
        } else {
            edges.extend(run.iter().map(|&s| edge(&[s], unpack_side(s).3)));
        }
    }
    edges
}

/// The face planes of an edge of two faces, oriented as [`super::edge_tree`]'s are.
fn planes(e: &MeshEdge) -> Option<[(DVec3, DVec3); 2]> {
    if e.faces != 2 {
        return None;
    }
    let n0 = (e.b - e.a).cross(e.thirds[0] - e.a).try_normalize()?;
    let n1 = (e.b - e.a).cross(e.thirds[1] - e.a).try_normalize()?;
    let s = if e.forward { 1.0 } else { -1.0 };
    Some([(s * n0, e.a), (-s * n1, e.a)])
}

/// 1 / the smallest altitude of the edge's faces (infinite for a face of no area).
fn thinness(e: &MeshEdge) -> f64 {
    let mut thin = 0.0f64;
    for &c in &e.thirds[..e.faces as usize] {
        let [p, q, r] = [e.a, e.b, c];
        let area2 = (q - p).cross(r - p).length();
        let longest = (q - p).length().max((r - q).length()).max((p - r).length());
        thin = thin.max(if area2 > 0.0 { longest / area2 } else { f64::INFINITY });
    }
    thin
}

/// Per node: the largest `value` of its items (by position in leaf order).
fn node_max(bvh: &Bvh2, value: impl Fn(usize) -> f64) -> Vec<f64> {
    let mut out = vec![0.0f64; bvh.nodes.len()];
    for &i in parents_first(bvh).iter().rev() {
        let node = &bvh.nodes[i];
        let first = node.first_index as usize;
        out[i] = if node.prim_count == 0 {
            out[first].max(out[first + 1])
        } else {
            (first..first + node.prim_count as usize).map(&value).fold(0.0, f64::max)
        };
    }
    out
}

#[cfg(test)]
#[path = "kept_tests.rs"]
mod tests;
