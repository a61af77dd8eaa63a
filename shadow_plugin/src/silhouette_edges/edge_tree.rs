//! The query structure over one light's potential silhouette edges and flagged triangles: a
//! BVH of their boxes, traversed with a point's shaft.
//!
//! Why its own tree: gathering through the scene's BVH visited every triangle in the shaft
//! to reach the few that own a potential edge (flight-helmet: 26% of the method's time at
//! 80x60, every triangle of its dense meshes); this tree holds only what the counting reads.
//! Rejected: a grid of lists over the light's directions (Laine et al.'s hemicube): one list
//! per direction cell still holds every edge a wedge of points may see, and the shaft test
//! the renderer already has prunes the same way.
//!
//! Each node also bounds its edges' face planes ([`Cone`]): an edge between two faces weighs
//! 0 from an origin in front of both faces or behind both, so a node whose every face plane
//! has the origin on one side holds no active edge and is not entered. On a finely
//! tessellated smooth mesh (metal-rough-spheres: 2,400 candidate edges per point, 93 active)
//! most of the shaft's edges are of that kind: the smooth surface's interior seen from one
//! side.

use super::edges::EdgeSet;
use glam::{DVec3, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use rayon::prelude::*;
use renderer::geometry::scene_bvh::{self, SubTree};
use renderer::geometry::shaft::{self, Shaft};
use std::time::Duration;

/// An item is an edge id, or a flagged triangle's slot with this bit set.
const TRIANGLE: u32 = 1 << 31;

/// The tree and its items in leaf order.
#[derive(Default)]
pub struct EdgeTree {
    bvh: Option<Bvh2>,
    items: Vec<u32>,
    /// Per item (leaf order): an edge's record (a flagged triangle's slot holds a blank one),
    /// so that a walk reads its leaves' edges from one run of memory.
    pub records: Vec<EdgeRecord>,
    /// Per node: the bound of its items' face planes.
    cones: Vec<Cone>,
}

/// A bound on a set of planes through points `x` with unit normals `g`: every `g` within
/// `spread` of the unit `axis`, every `x` within `reach` of `centre` and within `depth` of
/// it along the axis. Then for any origin o, `g . (o - x)` lies within
/// `axis . (o - centre) +- (depth + spread (|o - centre| + reach))`. An infinite spread
/// bounds nothing (boundary and non-manifold edges, flagged triangles: never pruned).
#[derive(Debug, Clone, Copy)]
pub(super) struct Cone {
    axis: DVec3,
    pub(super) centre: DVec3,
    spread: f64,
    pub(super) reach: f64,
    depth: f64,
}

impl Cone {
    pub(super) const NONE: Cone =
        Cone { axis: DVec3::Z, centre: DVec3::ZERO, spread: f64::INFINITY, reach: 0.0, depth: 0.0 };

    /// Whether every origin within `radius` of `o` is strictly on one and the same side of
    /// every plane the cone bounds, with a margin for the f64 evaluation (relative 1e-9 of
    /// the magnitudes involved: far above its rounding). Over the ball `axis . (o - centre)`
    /// moves by at most the radius, and the distance from the centre grows by at most it.
    pub(super) fn one_side(&self, o: DVec3, radius: f64) -> bool {
        if !self.spread.is_finite() {
            return false;
        }
        let d = o - self.centre;
        let dist = d.length() + radius;
        let margin = 1e-9 * (o.abs().max_element() + self.centre.abs().max_element() + dist + self.reach);
        self.axis.dot(d).abs() - radius > self.depth + self.spread * (dist + self.reach) + margin
    }

    /// The cone of planes `(g, x)`.
    fn of(planes: &[(DVec3, DVec3)]) -> Cone {
        let sum: DVec3 = planes.iter().map(|p| p.0).sum();
        let Some(axis) = sum.try_normalize() else { return Cone::NONE };
        let (lo, hi) = planes
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
        let centre = 0.5 * (lo + hi);
        let mut cone = Cone { axis, centre, spread: 0.0, reach: 0.0, depth: 0.0 };
        for &(g, x) in planes {
            cone.spread = cone.spread.max((g - axis).length());
            cone.reach = cone.reach.max((x - centre).length());
            cone.depth = cone.depth.max(axis.dot(x - centre).abs());
        }
        cone
    }

    /// A cone holding both (see the module doc's bound, applied to each child's).
    fn merge(a: &Cone, b: &Cone) -> Cone {
        if !(a.spread.is_finite() && b.spread.is_finite()) {
            return Cone::NONE;
        }
        let Some(axis) = (a.axis + b.axis).try_normalize() else { return Cone::NONE };
        let centre = 0.5 * (a.centre + b.centre);
        let mut cone = Cone { axis, centre, spread: 0.0, reach: 0.0, depth: 0.0 };
        for k in [a, b] {
            let turn = (axis - k.axis).length();
            cone.spread = cone.spread.max(turn + k.spread);
            cone.reach = cone.reach.max((k.centre - centre).length() + k.reach);
            cone.depth = cone.depth.max(axis.dot(k.centre - centre).abs() + k.depth + turn * k.reach);
        }
        cone
    }
}

/// An edge as the queries read it: its ends, and its faces' planes for weights over a block.
#[derive(Debug, Clone, Copy)]
pub struct EdgeRecord {
    pub a: Vec3A,
    pub b: Vec3A,
    /// N_k = (b - a) x (c_k - a) for its faces (f64, from the f32 vertices): orient3d(o, a,
    /// b, c_k) = N_k . (a - o).
    pub planes: [DVec3; 2],
    /// |b - a| |c_k - a|: a bound on each component of N_k's products (its rounding).
    pub scale: [f64; 2],
    /// The third corners of its faces (the first `faces`).
    pub thirds: [Vec3; 2],
    /// The edge's id in the set (its faces' third vertices), or `u32::MAX` (a kept
    /// instance's edge: `thirds` hold its faces).
    pub edge: u32,
    /// How many faces `planes` holds: 1 or 2, or 0 where the edge has more (never known
    /// over a block).
    pub faces: u8,
}

impl EdgeRecord {
    const BLANK: EdgeRecord = EdgeRecord {
        a: Vec3A::ZERO,
        b: Vec3A::ZERO,
        planes: [DVec3::ZERO; 2],
        scale: [0.0; 2],
        thirds: [Vec3::ZERO; 2],
        edge: u32::MAX,
        faces: 0,
    };

    pub(super) fn new(set: &EdgeSet, id: u32) -> EdgeRecord {
        let e = set.edges[id as usize];
        let v = |i: u32| set.vertices[i as usize];
        if e.count > 2 {
            let (a, b) = (v(e.a).into(), v(e.b).into());
            return EdgeRecord { a, b, edge: id, ..EdgeRecord::BLANK };
        }
        let mut thirds = [Vec3::ZERO; 2];
        for (k, &c) in set.thirds[e.first as usize..(e.first + e.count) as usize].iter().enumerate() {
            thirds[k] = v(c);
        }
        EdgeRecord { edge: id, ..EdgeRecord::from_points(v(e.a), v(e.b), &thirds[..e.count as usize]) }
    }

    /// The record of the edge (a, b) between the faces of third corners `thirds` (one or
    /// two), with no id in a set.
    pub(super) fn from_points(a: Vec3, b: Vec3, thirds: &[Vec3]) -> EdgeRecord {
        let mut record =
            EdgeRecord { a: a.into(), b: b.into(), faces: thirds.len() as u8, ..EdgeRecord::BLANK };
        let (a, b) = (a.as_dvec3(), b.as_dvec3());
        for (k, &c) in thirds.iter().enumerate() {
            let (p, q) = (b - a, c.as_dvec3() - a);
            record.planes[k] = p.cross(q);
            record.scale[k] = p.length() * q.length();
            record.thirds[k] = c;
        }
        record
    }
}

impl std::fmt::Debug for EdgeTree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EdgeTree").field("items", &self.items.len()).finish()
    }
}

impl EdgeTree {
    /// The tree over `set`'s edges and flagged triangles.
    pub fn build(set: &EdgeSet) -> EdgeTree {
        let vertex = |i: u32| Vec3A::from(set.vertices[i as usize]);
        let mut boxes = Vec::with_capacity(set.edges.len() + set.flagged.len());
        let mut items = Vec::with_capacity(boxes.capacity());
        for (id, e) in set.edges.iter().enumerate() {
            let (a, b) = (vertex(e.a), vertex(e.b));
            boxes.push(Aabb::new(a.min(b), a.max(b)));
            items.push(id as u32);
        }
        for &slot in &set.flagged {
            let [a, b, c] = set.corners[slot as usize].map(vertex);
            boxes.push(Aabb::new(a.min(b).min(c), a.max(b).max(c)));
            items.push(slot | TRIANGLE);
        }
        if boxes.is_empty() {
            return EdgeTree::default();
        }
        // One tree per group (each instance's edges; the rest, flagged triangles with them),
        // built in parallel, joined under a tree over the groups.
        let mut ends: Vec<usize> = set.group_ends.iter().map(|&e| e as usize).collect();
        ends.pop(); // the last group runs on over the flagged triangles
        ends.push(boxes.len());
        let bvh = build_grouped(&boxes, &ends);
        let items: Vec<u32> = bvh.primitive_indices.iter().map(|&i| items[i as usize]).collect();
        let cones = cones(&bvh, |pos| planes(items[pos], set));
        // In parallel, as the leaves' cones (boulder-field, 2.2 M edges: 0.3 s each alone).
        let records = items
            .par_iter()
            .map(|&item| if item & TRIANGLE == 0 { EdgeRecord::new(set, item) } else { EdgeRecord::BLANK })
            .collect();
        EdgeTree { bvh: Some(bvh), items, records, cones }
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        let nodes = self.bvh.as_ref().map_or(0, |b| b.nodes.len() * std::mem::size_of_val(&b.nodes[0]));
        (nodes + self.items.len() * 8 + self.records.len() * std::mem::size_of::<EdgeRecord>()) as u64
    }

    /// The edges (their positions in [`EdgeTree::records`]) and flagged triangles (slots)
    /// the shaft test cannot separate from `shaft` (a hull: no cut, no depth clips), into
    /// `edges` and `triangles`; `false` where the tree is too deep for the traversal's stack
    /// (then the lists are incomplete). Nodes whose every edge weighs 0 from every origin
    /// within `radius` of `origin` (the rays' origins: one point's, or a block's around its
    /// centre with `shaft` from [`Shaft::around_ball`]) are skipped. The walk stops (`false`)
    /// once more than `max_edges` edges are found (the caller sees it by their count).
    pub fn gather(
        &self,
        set: &EdgeSet,
        shaft: &Shaft,
        (origin, radius): (DVec3, f64),
        edges: &mut Vec<u32>,
        triangles: &mut Vec<u32>,
        max_edges: usize,
    ) -> bool {
        let Some(bvh) = &self.bvh else { return true };
        let vertex = |i: u32| Vec3A::from(set.vertices[i as usize]);
        let smooth = |node: usize| self.cones[node].one_side(origin, radius);
        shaft::shaft_leaves(bvh, shaft, smooth, |first, count| {
            for (pos, &item) in (first..).zip(&self.items[first..first + count]) {
                if item & TRIANGLE == 0 {
                    let r = &self.records[pos];
                    if !shaft.segment_outside_hull(r.a, r.b) {
                        edges.push(pos as u32);
                        if edges.len() > max_edges {
                            return false;
                        }
                    }
                } else {
                    let slot = item & !TRIANGLE;
                    let [a, b, c] = set.corners[slot as usize].map(vertex);
                    if !shaft.triangle_outside(a, b, c) {
                        triangles.push(slot);
                    }
                }
            }
            true
        })
    }
}

/// A tree over `boxes` made of one tree per group (group k: `ends[k - 1]..ends[k]`, empty
/// ones skipped), each built on its own (obvhs builds on one thread, deterministically;
/// the groups in parallel), joined under a tree over the groups' bounds split at the
/// median of their centres. Measured (silhouette's prepare, with the leaves' cones and the
/// records also made in parallel; one build over every edge before): boulder-field (2.2 M
/// edges in 100 instances) 1.78 -> 1.02 s, metal-rough-spheres (279 k in 98) 0.19 ->
/// 0.11 s; the walks on the joined tree cost the same (flight-helmet, sauerbraten-zdm2,
/// glass-vase-flowers, toy-car within 1%).
fn build_grouped(boxes: &[Aabb], ends: &[usize]) -> Bvh2 {
    let ranges: Vec<std::ops::Range<usize>> = ends
        .iter()
        .scan(0, |start, &end| Some(std::mem::replace(start, end)..end))
        .filter(|r| !r.is_empty())
        .collect();
    // A fast build: the tree is rebuilt per light and frame, and its queries are few (one
    // per block of points) against the thousands of rays of the scene's own tree.
    let params = obvhs::BvhBuildParams::fast_build();
    let trees: Vec<Bvh2> = ranges
        .par_iter()
        .map(|r| obvhs::bvh2::builder::build_bvh2(&boxes[r.clone()], params, &mut Duration::default()))
        .collect();
    if trees.len() == 1 {
        let mut tree = trees.into_iter().next().expect("one tree");
        let start = ranges[0].start as u32;
        tree.primitive_indices.iter_mut().for_each(|i| *i += start);
        return tree;
    }
    let trees: Vec<SubTree> = trees
        .into_iter()
        .zip(&ranges)
        .map(|(t, r)| SubTree {
            nodes: t.nodes,
            items: t.primitive_indices.iter().map(|&i| r.start as u32 + i).collect(),
        })
        .collect();
    scene_bvh::join(&trees)
}

/// The face planes of an item: an edge between exactly two faces gives both, with normals
/// oriented so that it weighs 0 exactly where the origin is on one side of both
/// (orient3d(o, e0, e1, c) = -N . (o - e0), N = (e1 - e0) x (c - e0): the weight is 0 iff
/// the two N . (o - e0) differ in sign; the second N is negated to compare like signs, and
/// both follow the first face's winding so that neighbours on a consistently wound mesh
/// agree). Anything else: `None` (never pruned).
fn planes(item: u32, set: &EdgeSet) -> Option<[(DVec3, DVec3); 2]> {
    if item & TRIANGLE != 0 {
        return None;
    }
    let e = set.edges[item as usize];
    if e.count != 2 {
        return None;
    }
    let v = |i: u32| set.vertices[i as usize].as_dvec3();
    let (a, b) = (v(e.a), v(e.b));
    let third = &set.thirds[e.first as usize..e.first as usize + 2];
    let n0 = (b - a).cross(v(third[0]) - a).try_normalize()?;
    let n1 = (b - a).cross(v(third[1]) - a).try_normalize()?;
    let s = if set.forward[item as usize] { 1.0 } else { -1.0 };
    Some([(s * n0, a), (-s * n1, a)])
}

/// The tree's nodes, each before its children (reversed: children before parents).
pub(super) fn parents_first(bvh: &Bvh2) -> Vec<usize> {
    let mut order = Vec::with_capacity(bvh.nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        order.push(i);
        let node = &bvh.nodes[i];
        if node.prim_count == 0 {
            stack.extend([node.first_index as usize, node.first_index as usize + 1]);
        }
    }
    order
}

/// Every node's cone, children before parents (a node's children follow it in obvhs's
/// layout: built by an explicit post-order walk), from `planes` of each item by its
/// position in leaf order.
pub(super) fn cones(bvh: &Bvh2, planes: impl Fn(usize) -> Option<[(DVec3, DVec3); 2]> + Sync) -> Vec<Cone> {
    let mut cones = vec![Cone::NONE; bvh.nodes.len()];
    let order = parents_first(bvh);
    // The leaves' cones (most of the work) in parallel, then the merges children first.
    let leaf_cones: Vec<(usize, Cone)> = order
        .par_iter()
        .filter(|&&i| bvh.nodes[i].prim_count != 0)
        .map_init(Vec::new, |planes_buf, &i| {
            let node = &bvh.nodes[i];
            planes_buf.clear();
            let range = node.first_index as usize..(node.first_index + node.prim_count) as usize;
            let mut all = true;
            for pos in range {
                match planes(pos) {
                    Some(p) => planes_buf.extend(p),
                    None => all = false,
                }
            }
            (i, if all { Cone::of(planes_buf) } else { Cone::NONE })
        })
        .collect();
    for (i, cone) in leaf_cones {
        cones[i] = cone;
    }
    for &i in order.iter().rev() {
        let node = &bvh.nodes[i];
        if node.prim_count == 0 {
            let first = node.first_index as usize;
            cones[i] = Cone::merge(&cones[first], &cones[first + 1]);
        }
    }
    cones
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tree joined from groups' trees holds every item once, each leaf's box holds its
    /// items' boxes and each inner node's its children's (random boxes, random groups, some
    /// empty, one group alone).
    #[test]
    fn a_joined_tree_holds_every_item_once_in_boxes_that_bound_them() {
        let mut uniform = crate::silhouette_edges::uniform(0x6a09_e667_f3bc_c908);
        let mut next = || uniform() as f32;
        for round in 0..40 {
            let n = 1 + (next() * 300.0) as usize;
            let boxes: Vec<Aabb> = (0..n)
                .map(|_| {
                    let c = Vec3A::new(next(), next(), next()) * 10.0;
                    let h = Vec3A::new(next(), next(), next()) * 0.5;
                    Aabb::new(c - h, c + h)
                })
                .collect();
            let mut ends: Vec<usize> = (0..(round % 7)).map(|_| (next() * n as f32) as usize).collect();
            ends.push(n);
            ends.sort();
            let bvh = build_grouped(&boxes, &ends);
            let mut seen = vec![0; n];
            let holds = |outer: &Aabb, inner: &Aabb| {
                outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all()
            };
            for node in &bvh.nodes {
                if node.prim_count == 0 {
                    for child in [node.first_index, node.first_index + 1] {
                        assert!(holds(&node.aabb, &bvh.nodes[child as usize].aabb), "round {round}");
                    }
                } else {
                    for k in node.first_index..node.first_index + node.prim_count {
                        let item = bvh.primitive_indices[k as usize] as usize;
                        seen[item] += 1;
                        assert!(holds(&node.aabb, &boxes[item]), "round {round}");
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1), "round {round}: {seen:?}");
        }
    }

    /// Wherever a cone (of a leaf, or merged from two) claims an origin is on one side of
    /// its planes, every plane it bounds has the origin strictly on one and the same side;
    /// and it does claim so for origins far along its axis.
    #[test]
    fn a_cone_prunes_only_where_every_plane_agrees() {
        let mut uniform = crate::silhouette_edges::uniform(0x2545_f491_4f6c_dd1d);
        let mut next = || uniform() * 2.0 - 1.0;
        let (mut claimed, mut far_claimed, mut ball_claimed) = (0, 0, 0);
        for _ in 0..300 {
            // Two clusters of planes: normals near one direction, points in a small patch.
            let cluster = |next: &mut dyn FnMut() -> f64, normal: DVec3| -> Vec<(DVec3, DVec3)> {
                let centre = DVec3::new(next(), next(), next());
                (0..8)
                    .map(|_| {
                        let g = (normal + 0.2 * DVec3::new(next(), next(), next())).normalize();
                        (g, centre + 0.1 * DVec3::new(next(), next(), next()))
                    })
                    .collect()
            };
            let n = DVec3::new(next(), next(), 1.0).normalize();
            let a = cluster(&mut next, n);
            let b = cluster(&mut next, (n + 0.3 * DVec3::X).normalize());
            let merged = Cone::merge(&Cone::of(&a), &Cone::of(&b));
            let planes: Vec<_> = a.iter().chain(&b).copied().collect();
            for _ in 0..50 {
                let o = 4.0 * DVec3::new(next(), next(), next());
                if merged.one_side(o, 0.0) {
                    claimed += 1;
                    let sides: Vec<bool> = planes.iter().map(|(g, x)| g.dot(o - *x) > 0.0).collect();
                    assert!(sides.iter().all(|&s| s == sides[0]), "a plane on the other side at {o}");
                    assert!(planes.iter().all(|(g, x)| g.dot(o - *x) != 0.0));
                }
            }
            far_claimed += merged.one_side(merged.centre + 100.0 * merged.axis, 0.0) as u32;
            // Over a ball: every origin in it on one and the same side of every plane.
            for _ in 0..20 {
                let (o, radius) = (4.0 * DVec3::new(next(), next(), next()), next().abs());
                if merged.one_side(o, radius) {
                    ball_claimed += 1;
                    let side = planes[0].0.dot(o - planes[0].1) > 0.0;
                    for _ in 0..20 {
                        let d = DVec3::new(next(), next(), next());
                        let x = o + radius * d / d.length().max(1.0);
                        assert!(planes.iter().all(|(g, p)| (g.dot(x - *p) > 0.0) == side), "{x} in ball {o}");
                    }
                }
            }
        }
        assert!(claimed > 1000, "only {claimed} origins pruned");
        assert_eq!(far_claimed, 300);
        assert!(ball_claimed > 300, "only {ball_claimed} balls pruned");
    }
}
