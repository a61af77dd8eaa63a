//! A candidate edge as the per-point passes read it, and its weight over a block of origins:
//! what the block walks (`blocks.rs`, over the edge tree) and the kept instances' walks
//! (`kept.rs`) hand the counting.

use super::edge_tree::EdgeRecord;
use glam::{DVec3, Vec3, Vec3A};

/// Why a point's candidates cannot be handed over: it is then traced whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum GatherRefusal {
    /// More candidates than the caller pays for (`max_candidates`): the walk stops there.
    TooManyCandidates,
    /// The walk could not finish (a tree deeper than the traversal's stack), or the point
    /// has no shaft.
    NoShaft,
    /// The shaft meets a kept instance the counting does not answer for (`kept.rs`).
    KeptInstance,
}

/// A candidate's weight is not the same over the block: each point computes its own.
pub(crate) const VARIES: i8 = i8::MIN;

/// A candidate edge as the per-point passes read it: flat, in the walk's order (no scattered
/// vertex loads per point).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    pub(crate) a: Vec3A,
    pub(crate) b: Vec3A,
    /// The third corners of its faces (the first `faces`; none for an edge of more than
    /// two, whose faces are read from the set by `edge`).
    pub(crate) thirds: [Vec3; 2],
    pub(crate) edge: u32,
    /// Its weight over the whole block, or [`VARIES`].
    pub(crate) weight: i8,
    pub(crate) faces: u8,
}

impl Candidate {
    pub(super) fn new(r: &EdgeRecord, weight: i8) -> Candidate {
        Candidate { a: r.a, b: r.b, thirds: r.thirds, edge: r.edge, weight, faces: r.faces }
    }
}

/// An edge's weight for every origin within `radius` of `centre`, or [`VARIES`]: each face's
/// orientation orient3d(o, e0, e1, c) = N . (e0 - o) is affine in o and moves by at most
/// |N| radius over the ball; a face is counted only where its sign holds over the whole ball
/// by more than the f64 rounding (then each point's own exact predicate gives the same sign).
/// N's components are rounded by under 2^-52 of `scale` each: 1e-12 of it is far over.
pub(super) fn block_weight(r: &EdgeRecord, centre: DVec3, radius: f64) -> i8 {
    if r.faces == 0 {
        return VARIES;
    }
    let d = r.a.as_dvec3() - centre;
    let spread = d.abs().element_sum() + 3.0 * radius;
    let mut weight = 0i8;
    for k in 0..r.faces as usize {
        let n = r.planes[k];
        let det = n.dot(d);
        let bound = n.length() * radius * (1.0 + 1e-9) + 1e-12 * r.scale[k] * spread;
        if det > bound {
            weight += 1;
        } else if det < -bound {
            weight -= 1;
        } else {
            return VARIES;
        }
    }
    weight
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::silhouette_edges::edges::{Edge, EdgeSet};
    use crate::silhouette_edges::projection::exact_orient_sign;

    /// Where a block keeps an edge's weight, every origin in its ball has that weight by the
    /// exact predicate (random edges with two faces, random balls, some touching a plane).
    #[test]
    fn a_kept_weight_is_every_origin_s_exact_weight() {
        let mut next = crate::silhouette_edges::uniform(0x0b10_c5ee_d000_0001);
        let mut point = |s: f64| DVec3::new(next(), next(), next()) * 2.0 * s - DVec3::splat(s);
        let (mut kept, mut varies) = (0, 0);
        for _ in 0..3000 {
            let vertices: Vec<Vec3> = (0..4).map(|_| point(1.0).as_vec3()).collect();
            let set = EdgeSet {
                vertices,
                edges: vec![Edge { a: 0, b: 1, first: 0, count: 2 }],
                thirds: vec![2, 3],
                ..EdgeSet::default()
            };
            let (centre, radius) = (point(2.0), 0.5 * point(1.0).x.abs());
            let w = block_weight(&EdgeRecord::new(&set, 0), centre, radius);
            if w == VARIES {
                varies += 1;
                continue;
            }
            kept += 1;
            let v = |i: usize| set.vertices[i].as_dvec3();
            for _ in 0..50 {
                let d = point(1.0);
                let o = centre + radius * d / d.length().max(1.0);
                let exact: i32 = [2, 3].iter().map(|&c| exact_orient_sign(o, v(0), v(1), v(c))).sum();
                assert_eq!(exact, w as i32, "origin {o}, ball {centre} r {radius}");
            }
        }
        assert!(kept > 1000 && varies > 100, "{kept} kept, {varies} varying");
    }
}
