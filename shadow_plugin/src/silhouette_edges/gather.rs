//! One point's edges, per thread (allocated once, reused by every point): the candidates
//! its shaft meets and the flagged triangles in it ([`EdgeScratch::gather`]), then, seen
//! from its ray origin, the active edges' projections and the flagged triangles' regions
//! ([`EdgeScratch::activate`]).

use super::blocks::{Blocks, vertex_a};
use super::candidate::{Candidate, GatherRefusal, VARIES};
use super::edges::ALPHA;
use super::occluders::OccluderEdges;
use super::projection::{ActiveEdge, Frame, Region, exact_orient_sign, orient_sign, push};
use glam::DVec3;
use renderer::geometry::shaft::Shaft;
use renderer::{RectLight, Scene};

/// One point's edges (see the module doc).
#[derive(Default)]
pub(crate) struct EdgeScratch {
    /// The blocks' candidate lists (shared by neighbouring points).
    blocks: Blocks,
    pub(crate) candidates: Vec<Candidate>,
    /// Edge ids of a walk for one point alone.
    walked: Vec<u32>,
    /// Flagged triangles in the shaft (left out of the counting), by slot in the edge set
    /// (`edges.flags[slot]`: [`ALPHA`], `NEAR_LIGHT`, `ZERO_AREA`; `edges.triangle(slot)`).
    pub(crate) excluded: Vec<u32>,
    /// The candidates active for this point: weight != 0, projection over the light.
    pub(crate) active: Vec<ActiveEdge>,
    /// The excluded triangles' projections over the light, grown by their bands.
    pub(crate) regions: Vec<Region>,
}

impl EdgeScratch {
    /// The shaft's candidates: potential silhouette edges, and flagged triangles. Read from
    /// the block of `origin` ([`Blocks`]), filtered by the point's own shaft; walked for the
    /// point alone where no block applies. Refused where a block holds more than
    /// `max_candidates`, a walk cannot finish, or the shaft meets a kept instance not
    /// counted.
    pub(crate) fn gather(
        &mut self,
        occluders: &OccluderEdges,
        light: &RectLight,
        scene: &Scene,
        shaft: &Shaft,
        origin: DVec3,
        max_candidates: usize,
    ) -> Result<(), GatherRefusal> {
        self.candidates.clear();
        self.excluded.clear();
        let (set, tree) = (&occluders.edges, &occluders.tree);
        // A block with more candidates than the counting pays for is refused before any is
        // filtered, its walk stopped early.
        match self.blocks.list(occluders, light, scene, origin.as_vec3(), max_candidates) {
            Some(Ok(list)) => {
                self.candidates
                    .extend(list.candidates.iter().filter(|c| !shaft.segment_outside_hull(c.a, c.b)));
                for &slot in list.triangles {
                    let [a, b, c] = set.corners[slot as usize].map(|i| vertex_a(set, i));
                    if !shaft.triangle_outside(a, b, c) {
                        self.excluded.push(slot);
                    }
                }
                Ok(())
            }
            // Too many candidates, or a tree too deep for the traversal's stack.
            Some(Err(why)) => Err(why),
            None => {
                self.walked.clear();
                let (walked, excluded) = (&mut self.walked, &mut self.excluded);
                let complete = tree.gather(set, shaft, (origin, 0.0), walked, excluded, usize::MAX);
                self.candidates
                    .extend(self.walked.iter().map(|&p| Candidate::new(&tree.records[p as usize], VARIES)));
                let mut count = 0;
                let budget = (&mut count, usize::MAX);
                let kept_complete = occluders.kept.gather(
                    scene,
                    shaft,
                    (origin, 0.0),
                    false,
                    &mut self.candidates,
                    budget,
                )?;
                if complete && kept_complete { Ok(()) } else { Err(GatherRefusal::NoShaft) }
            }
        }
    }

    /// The candidates active for this point (weight != 0 and over the light), with the
    /// bands the counting needs, and the excluded triangles' regions.
    pub(crate) fn activate(&mut self, occluders: &OccluderEdges, frame: &Frame) {
        self.active.clear();
        let active = &mut self.active;
        for_each_weighed(&self.candidates, occluders, frame, |e0, e1, n, weight| {
            push(active, frame, e0, e1, n, weight)
        });
        self.find_regions(occluders, frame);
    }

    /// The candidates with weight != 0 for this point, as `(e0, e1, n, weight)`, without the
    /// counting's bands (`analytic` needs only the projection: the bands were a third of its
    /// activation), and the excluded triangles' regions.
    pub(crate) fn weigh(
        &mut self,
        occluders: &OccluderEdges,
        frame: &Frame,
        emit: impl FnMut(DVec3, DVec3, DVec3, i32),
    ) {
        for_each_weighed(&self.candidates, occluders, frame, emit);
        self.find_regions(occluders, frame);
    }

    /// The excluded triangles' projections over the light, grown by their bands.
    fn find_regions(&mut self, occluders: &OccluderEdges, frame: &Frame) {
        let set = &occluders.edges;
        self.regions.clear();
        for &slot in &self.excluded {
            if let Some(mut region) = Region::new(frame, set.triangle(slot)) {
                region.slot = slot;
                region.alpha_only = set.flags[slot as usize] == ALPHA;
                self.regions.push(region);
            }
        }
    }
}

/// Calls `emit(e0, e1, n, weight)` for every candidate whose weight seen from `frame.o` is
/// not 0 (`n` = (e0 - o) x (e1 - o)).
fn for_each_weighed(
    candidates: &[Candidate],
    occluders: &OccluderEdges,
    frame: &Frame,
    mut emit: impl FnMut(DVec3, DVec3, DVec3, i32),
) {
    let set = &occluders.edges;
    let vertex = |i: u32| set.vertices[i as usize].as_dvec3();
    for c in candidates {
        let (e0, e1) = (c.a.as_dvec3(), c.b.as_dvec3());
        let (d0, d1) = (e0 - frame.o, e1 - frame.o);
        let n = d0.cross(d1);
        let mut weight = c.weight as i32;
        if c.weight == VARIES {
            let n_abs = DVec3::new(
                (d0.y * d1.z).abs() + (d0.z * d1.y).abs(),
                (d0.z * d1.x).abs() + (d0.x * d1.z).abs(),
                (d0.x * d1.y).abs() + (d0.y * d1.x).abs(),
            );
            let face = |c: DVec3| {
                orient_sign(n, n_abs, c, frame.o).unwrap_or_else(|| exact_orient_sign(frame.o, e0, e1, c))
            };
            weight = c.thirds[..c.faces as usize].iter().map(|t| face(t.as_dvec3())).sum();
            if c.faces == 0 {
                // More than two faces: read from the set.
                let edge = set.edges[c.edge as usize];
                let thirds = &set.thirds[edge.first as usize..(edge.first + edge.count) as usize];
                weight = thirds.iter().map(|&t| face(vertex(t))).sum();
            }
        }
        if weight != 0 {
            emit(e0, e1, n, weight);
        }
    }
}
