//! The per-light edge set: vertices welded at bit-identical positions, every edge with its
//! incident opaque triangles, and the potential silhouette edges for this light (queried
//! through [`super::edge_tree::EdgeTree`]).
//!
//! An edge changes a segment's depth complexity only where the segment's plane has the
//! edge's faces on one side (a silhouette as seen along it). Seen from a light point `s`, the
//! two faces of a manifold edge are on one side iff `s` is on the same side of both face
//! planes; if every point of the (slightly grown) light is on opposite sides of them, no
//! shadow ray ever crosses the edge as a silhouette and it is dropped (coplanar neighbours
//! always are). Boundary and non-manifold edges are always kept.
//!
//! Alpha-tested triangles are classified first (`alpha.rs`): ones the test never cuts are
//! counted as opaque, ones it always cuts are dropped (no ray ever stops on them).
//!
//! Triangles the counting cannot answer for are flagged and left out of it (the edges they
//! share become boundary edges of the rest): alpha-tested ones the test may or may not cut
//! (holes under a texture), ones near or across the light's plane (shadow rays stop short of
//! the light by a fraction of their length, so whether they count depends on the point),
//! and zero-area ones (their weight is 0, but an f32 ray test may still graze them). A
//! sample whose ray may meet one is traced.

use super::alpha::{self, AlphaClass};
use super::welding::{InstanceEdges, Templates, Welded, instance_side, pack_side, unpack_side};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use renderer::{RectLight, Scene};

/// Triangle flags: what a point whose shaft meets the triangle must do.
pub const ALPHA: u8 = 1;
pub const NEAR_LIGHT: u8 = 2;
pub const ZERO_AREA: u8 = 4;

/// One edge between welded vertices `a < b`, with the third vertices of its incident opaque
/// triangles at `thirds[first..first + count]`.
#[derive(Debug, Clone, Copy)]
pub struct Edge {
    pub a: u32,
    pub b: u32,
    pub first: u32,
    pub count: u32,
}

/// The edge set of one light (see the module doc).
#[derive(Debug, Default)]
pub struct EdgeSet {
    /// Welded vertex positions.
    pub vertices: Vec<Vec3>,
    /// The potential silhouette edges.
    pub edges: Vec<Edge>,
    /// Third vertices of the edges' incident triangles.
    pub thirds: Vec<u32>,
    /// Per edge: whether its first incident triangle's winding runs a -> b (orients the
    /// faces' normals alike across a consistently wound mesh: [`super::edge_tree`]'s cones).
    pub forward: Vec<bool>,
    /// Per triangle slot: the triangle's welded vertices (for zero-area triangles' bands).
    pub corners: Vec<[u32; 3]>,
    /// Per triangle slot: [`ALPHA`], [`NEAR_LIGHT`], [`ZERO_AREA`].
    pub flags: Vec<u8>,
    /// The slots of the flagged triangles.
    pub flagged: Vec<u32>,
    /// Where each group of `edges` ends (edges of one instance, or the sorted rest): the
    /// edge tree is built per group.
    pub group_ends: Vec<u32>,
    /// Counts for the run report.
    pub stats: EdgeStats,
}

#[derive(Debug, Default, Clone, Copy)]
pub struct EdgeStats {
    pub edges: u64,
    pub potential: u64,
    pub boundary: u64,
    pub non_manifold: u64,
    /// Alpha-tested triangles the test may or may not cut: flagged [`ALPHA`].
    pub alpha_triangles: u64,
    /// Alpha-tested triangles the test never cuts: counted as opaque.
    pub alpha_opaque_triangles: u64,
    /// Alpha-tested triangles the test always cuts: dropped.
    pub alpha_clear_triangles: u64,
    pub near_light_triangles: u64,
    pub zero_area_triangles: u64,
}

impl EdgeSet {
    /// Bytes held (the run report's memory).
    pub fn bytes(&self) -> u64 {
        (self.vertices.len() * 12
            + self.edges.len() * 16
            + self.thirds.len() * 4
            + self.forward.len()
            + self.flagged.len() * 4
            + self.corners.len() * 12
            + self.flags.len()
            + self.group_ends.len() * 4) as u64
    }

    /// The welded corners of the triangle in `slot` (a flagged one's, for its region).
    pub fn triangle(&self, slot: u32) -> [DVec3; 3] {
        self.corners[slot as usize].map(|i| self.vertices[i as usize].as_dvec3())
    }

    /// The edge set of `scene`'s triangles for `light`.
    pub fn build(scene: &Scene, light: &RectLight) -> EdgeSet {
        let n = scene.triangles.len();
        let mut set = EdgeSet { flags: vec![0; n], ..EdgeSet::default() };
        let welded = super::welding::weld(&mut set.vertices, &mut set.corners, scene);
        let near = near_light_band(scene, light);
        let classes = alpha::classify(scene);
        // Per triangle, in parallel (8.2 M on boulder-field: 65 ms on one thread).
        let (normal, centre) = (light.normal.as_dvec3(), light.center.as_dvec3());
        let corners = &set.corners;
        set.flags.par_iter_mut().enumerate().for_each(|(slot, flags)| {
            let tri = &scene.triangles[slot];
            let v = [Vec3::from(tri.v0), Vec3::from(tri.v1), Vec3::from(tri.v2)];
            match classes[slot] {
                AlphaClass::NoTest | AlphaClass::Opaque => {}
                // Never met by any ray: neither flagged nor counted, whatever its position.
                AlphaClass::Clear => return,
                AlphaClass::Mixed => *flags |= ALPHA,
            }
            // Plus the rounding of this triangle's own coordinates (not the scene's largest:
            // a quad 10^6 m away flagged every triangle within 10 m of the light).
            let band = near + 1e-5 * v.iter().map(|x| x.abs().max_element()).fold(0.0f32, f32::max) as f64;
            if v.iter().any(|x| normal.dot(x.as_dvec3() - centre) < band) {
                *flags |= NEAR_LIGHT;
            }
            let [c0, c1, c2] = corners[slot];
            if c0 == c1 || c1 == c2 || c0 == c2 || zero_area(v) {
                *flags |= ZERO_AREA;
            }
        });
        set.stats.alpha_opaque_triangles =
            classes.iter().filter(|&&c| c == AlphaClass::Opaque).count() as u64;
        set.stats.alpha_clear_triangles = classes.iter().filter(|&&c| c == AlphaClass::Clear).count() as u64;
        set.flagged = (0..n as u32).filter(|&slot| set.flags[slot as usize] != 0).collect();
        set.stats.alpha_triangles = set.flags.iter().filter(|&&f| f & ALPHA != 0).count() as u64;
        set.stats.near_light_triangles = set.flags.iter().filter(|&&f| f & NEAR_LIGHT != 0).count() as u64;
        set.stats.zero_area_triangles = set.flags.iter().filter(|&&f| f & ZERO_AREA != 0).count() as u64;
        set.link_edges(scene, light, &classes, &welded);
        set
    }

    /// Every edge of the opaque (unflagged, not clear), non-degenerate triangles with its
    /// incident triangles; keeps the potential silhouette edges. An instance all of whose
    /// triangles count takes its mesh's edges ([`MeshEdges`], found once per mesh); the
    /// sides of the others, of loose triangles and of the meshes' boundaries are sorted.
    fn link_edges(&mut self, scene: &Scene, light: &RectLight, classes: &[AlphaClass], welded: &Welded) {
        let counted = |slot: usize| self.flags[slot] == 0 && classes[slot] != AlphaClass::Clear;
        let templates = Templates::new(scene, counted);
        // The sorted sides: the triangles of instances not whole, loose triangles, and the
        // whole instances' boundary sides; an edge is a run (first, count) of them.
        let mut sides: Vec<u128> = Vec::new();
        for (slot, c) in self.corners.iter().enumerate() {
            if counted(slot) && templates.of(scene, scene.origins[slot].instance).is_none() {
                sides.extend((0..3).map(|k| pack_side(c[k], c[(k + 1) % 3], c[(k + 2) % 3])));
            }
        }
        for (i, inst) in scene.instances.iter().enumerate() {
            if let Some(t) = templates.of(scene, i as u32) {
                sides.extend(t.single.iter().map(|&p| instance_side(welded, i as u32, inst.mirrored, p)));
            }
        }
        sides.par_sort_unstable();
        let runs: Vec<&[u128]> = sides.chunk_by(|x, y| x >> 64 == y >> 64).collect();
        // Which edges to keep, in parallel (1.5 M plane tests on metal-rough-spheres): the
        // sorted runs, then each whole instance's copy of its mesh's edges, only the kept
        // ones made.
        let corners = light_corners_grown(light);
        let keep = |run: &[u128]| {
            let s = |k: usize| unpack_side(run[k]);
            run.len() != 2 || self.silhouette_somewhere(s(0).0, s(0).1, s(0).2, s(1).2, &corners)
        };
        let keep_sorted: Vec<bool> = runs.par_iter().map(|run| keep(run)).collect();
        let copies: Vec<InstanceEdges> = (0..scene.instances.len() as u32)
            .into_par_iter()
            .map(|i| match templates.of(scene, i) {
                Some(t) => InstanceEdges::new(t, welded, (i, scene.instances[i as usize].mirrored), keep),
                None => InstanceEdges::default(),
            })
            .collect();
        for (run, keep) in runs.iter().zip(keep_sorted) {
            self.push_edge(run, keep);
        }
        self.group_ends.push(self.edges.len() as u32);
        for copy in &copies {
            let mut first = 0;
            for &n in &copy.lens {
                self.push_edge(&copy.sides[first..first + n as usize], true);
                first += n as usize;
            }
            self.stats.edges += copy.dropped[0];
            self.stats.non_manifold += copy.dropped[1];
            if !copy.lens.is_empty() {
                self.group_ends.push(self.edges.len() as u32);
            }
        }
        self.stats.potential = self.edges.len() as u64;
    }

    /// Counts the edge of the sides `run` in the stats, and adds it to the set if `keep`.
    fn push_edge(&mut self, run: &[u128], keep: bool) {
        let (a, b, _, forward) = unpack_side(run[0]);
        self.stats.edges += 1;
        match run.len() {
            1 => self.stats.boundary += 1,
            2 => {}
            _ => self.stats.non_manifold += 1,
        }
        if keep {
            self.edges.push(Edge { a, b, first: self.thirds.len() as u32, count: run.len() as u32 });
            self.thirds.extend(run.iter().map(|&p| unpack_side(p).2));
            self.forward.push(forward);
        }
    }

    /// Whether some point of the light sees the edge (a, b) with both faces (third vertices
    /// `c0`, `c1`) on one side: false only where every grown light corner is strictly on
    /// opposite sides of the two face planes (by more than the f64 rounding), which by
    /// linearity holds over the whole rectangle.
    fn silhouette_somewhere(&self, a: u32, b: u32, c0: u32, c1: u32, corners: &[DVec3; 4]) -> bool {
        let v = |i: u32| self.vertices[i as usize].as_dvec3();
        let (a, b, c0, c1) = (v(a), v(b), v(c0), v(c1));
        let n0 = (b - a).cross(c0 - a);
        let n1 = (b - a).cross(c1 - a);
        let side = |n: DVec3, s: DVec3| {
            let d = n.dot(s - a);
            // Rounding of d: a few ulps of its terms' magnitudes.
            let bound = 1e-12 * n.abs().dot((s - a).abs());
            if d > bound {
                1
            } else if d < -bound {
                -1
            } else {
                0
            }
        };
        let s0 = corners.map(|s| side(n0, s));
        let s1 = corners.map(|s| side(n1, s));
        let opposite = |x: i32, y: i32| s0.iter().all(|&s| s == x) && s1.iter().all(|&s| s == y);
        !(opposite(1, -1) || opposite(-1, 1))
    }
}

/// The light's corners grown by 1% of its size: samples are drawn in f32 and may stray a
/// rounding outside the rectangle.
pub(super) fn light_corners_grown(light: &RectLight) -> [DVec3; 4] {
    let (c, u, v) = (light.center.as_dvec3(), light.u.as_dvec3(), light.v.as_dvec3());
    let (hu, hv) = (0.51 * u, 0.51 * v);
    [c - hu - hv, c + hu - hv, c + hu + hv, c - hu + hv]
}

/// Height over the light's plane under which a triangle counts as near the light: shadow
/// rays stop `SHADOW_EPSILON` of their length short of the (offset) light point, so a
/// triangle within that fraction of the farthest point's height, or across the plane, may
/// or may not be met depending on the point. Twice that, plus the light's coordinates'
/// rounding (each triangle adds its own).
pub(super) fn near_light_band(scene: &Scene, light: &RectLight) -> f64 {
    let n = light.normal.as_dvec3();
    let c = light.center.as_dvec3();
    let mut far = 0.0f64;
    let (lo, hi) = (scene.bounds_min.as_dvec3(), scene.bounds_max.as_dvec3());
    for i in 0..8 {
        let x = DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        far = far.max(n.dot(x - c).abs());
    }
    let scale = light.corners().iter().map(|c| c.abs().max_element()).fold(0.0f32, f32::max) as f64;
    2.0 * renderer::geometry::ray_origin::SHADOW_EPSILON as f64 * far + 1e-5 * scale
}

/// Whether the triangle has exactly zero area: its cross product is zero in f64 from the
/// f32 corners (differences of f32 values are exact in f64 at the spreads scenes have, and
/// products of two of them are exact).
fn zero_area(v: [Vec3; 3]) -> bool {
    let (a, b, c) = (v[0].as_dvec3(), v[1].as_dvec3(), v[2].as_dvec3());
    (b - a).cross(c - a) == DVec3::ZERO
}
