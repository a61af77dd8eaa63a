//! One light's occluder edges, built once per light and read by every point: the edge set
//! (`edges.rs`), its tree (`edge_tree.rs`) and the kept instances' edges (`kept.rs`), under
//! an identity the per-thread block caches (`blocks.rs`) key their entries by.

use super::blocks::WalkedBlocks;
use super::edge_tree::EdgeTree;
use super::edges::EdgeSet;
use super::kept::KeptEdges;
use renderer::{RectLight, Scene};
use std::sync::atomic::{AtomicU64, Ordering};

/// The occluders' edges for one light (see the module doc). The run report reads
/// `edges.stats`, `kept.counted` and `kept.mesh_edges`.
#[derive(Debug, Default)]
pub(crate) struct OccluderEdges {
    /// The potential silhouette edges and the flagged triangles, by slot.
    pub(crate) edges: EdgeSet,
    pub(crate) tree: EdgeTree,
    pub(crate) kept: KeptEdges,
    /// This build's identity: never 0 (an unbuilt one's), never reused in this process.
    pub(crate) id: u64,
    /// The blocks' walks, shared by the threads.
    pub(crate) walked: WalkedBlocks,
}

impl OccluderEdges {
    /// The edges of `scene`'s occluders for `light`.
    pub(crate) fn build(scene: &Scene, light: &RectLight) -> OccluderEdges {
        let edges = EdgeSet::build(scene, light);
        let tree = EdgeTree::build(&edges);
        let kept = KeptEdges::build(scene, light);
        static NEXT_ID: AtomicU64 = AtomicU64::new(1);
        let id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        OccluderEdges { edges, tree, kept, id, walked: WalkedBlocks::default() }
    }

    /// Bytes held (the run report's memory).
    pub(crate) fn bytes(&self) -> u64 {
        self.edges.bytes() + self.tree.bytes() + self.kept.bytes() + self.walked.bytes()
    }
}
