//! The occluders' silhouette edges, shared by the methods that answer a point from them
//! (`silhouette` counts `traced`'s samples with them).
//!
//! Per light ([`OccluderEdges`], `occluders.rs`): connectivity once per mesh (`welding.rs`),
//! the edge set with its potential silhouette edges and the triangles flagged as left out of
//! the counting (`edges.rs`: alpha-tested with holes, near the light's plane, zero-area;
//! alpha classes in `alpha.rs`), a BVH over them with normal cones (`edge_tree.rs`), and the
//! kept instances' edges once per stored mesh (`kept.rs`).
//!
//! Per point ([`EdgeScratch`], `gather.rs`): the candidates its shaft meets (`candidate.rs`),
//! read from one walk per block of neighbouring points (`blocks.rs`), and the flagged
//! triangles in it; then, seen from its ray origin, the candidates' exact weights and the
//! active ones' projections onto the light's plane, clipped to the slab between the origin's
//! plane and the light's, and the flagged triangles' clipped projections (`projection.rs`).

mod alpha;
mod blocks;
mod candidate;
mod edge_tree;
pub(crate) mod edges;
mod gather;
mod kept;
mod occluders;
pub(crate) mod projection;
mod welding;

pub(crate) use candidate::GatherRefusal;
pub(crate) use gather::EdgeScratch;
pub(crate) use occluders::OccluderEdges;

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
