//! The occluders' silhouette edges, shared by the methods that answer a point from them
//! (`silhouette` counts `traced`'s samples with them).
//!
//! Per light: connectivity once per mesh (`welding.rs`), the edge set with its potential
//! silhouette edges and the triangles flagged as left out of the counting (`edges.rs`:
//! alpha-tested with holes, near the light's plane, zero-area; alpha classes in `alpha.rs`),
//! a BVH over them with normal cones (`edge_tree.rs`), and the kept instances' edges once per
//! stored mesh (`kept.rs`). Per point: the candidates of its shaft (`candidate.rs`), read
//! from one walk per block of neighbouring points (`blocks.rs`), their exact weights seen
//! from the ray origin, and their projections onto the light's plane clipped to the slab
//! between the origin's plane and the light's (`projection.rs`), with the flagged triangles'
//! regions.

pub(crate) mod alpha;
pub(crate) mod blocks;
pub(crate) mod candidate;
pub(crate) mod edge_tree;
pub(crate) mod edges;
pub(crate) mod kept;
pub(crate) mod projection;
pub(crate) mod welding;

/// A uniform [0, 1) stream (xorshift64, 53 bits) for the edge methods' randomised unit tests.
#[cfg(test)]
pub(crate) fn uniform(mut state: u64) -> impl FnMut() -> f64 {
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}
