//! The query structure over one light's potential silhouette edges and flagged triangles: a
//! BVH of their boxes, traversed with a point's shaft.
//!
//! Why its own tree: gathering through the scene's BVH visited every triangle in the shaft
//! to reach the few that own a potential edge (flight-helmet: 26% of the method's time at
//! 80x60, every triangle of its dense meshes); this tree holds only what the counting reads.
//! Rejected: a grid of lists over the light's directions (Laine et al.'s hemicube): one list
//! per direction cell still holds every edge a wedge of points may see, and the shaft test
//! the renderer already has prunes the same way.

use super::edges::EdgeSet;
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use renderer::geometry::shaft::{self, Shaft};
use std::time::Duration;

/// An item is an edge id, or a flagged triangle's slot with this bit set.
const TRIANGLE: u32 = 1 << 31;

/// The tree and its items in leaf order.
#[derive(Default)]
pub struct EdgeTree {
    bvh: Option<Bvh2>,
    items: Vec<u32>,
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
        // A fast build: the tree is rebuilt per light and frame, and its queries are few
        // (one per point) against the thousands of rays of the scene's own tree.
        let params = obvhs::BvhBuildParams::fast_build();
        let bvh = obvhs::bvh2::builder::build_bvh2(&boxes, params, &mut Duration::default());
        let items = bvh.primitive_indices.iter().map(|&i| items[i as usize]).collect();
        EdgeTree { bvh: Some(bvh), items }
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        let nodes = self.bvh.as_ref().map_or(0, |b| b.nodes.len() * std::mem::size_of_val(&b.nodes[0]));
        (nodes + self.items.len() * 8) as u64
    }

    /// The edges and flagged triangles the shaft test cannot separate from `shaft`, into
    /// `edges` and `triangles`; `false` where the tree is too deep for the traversal's stack
    /// (then the lists are incomplete).
    pub fn gather(
        &self,
        set: &EdgeSet,
        shaft: &Shaft,
        edges: &mut Vec<u32>,
        triangles: &mut Vec<u32>,
    ) -> bool {
        let Some(bvh) = &self.bvh else { return true };
        let vertex = |i: u32| Vec3A::from(set.vertices[i as usize]);
        shaft::shaft_leaves(bvh, shaft, |first, count| {
            for &item in &self.items[first..first + count] {
                if item & TRIANGLE == 0 {
                    let e = set.edges[item as usize];
                    if !shaft.segment_outside(vertex(e.a), vertex(e.b)) {
                        edges.push(item);
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
