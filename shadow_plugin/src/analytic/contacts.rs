//! Where two projected segments meet: a proper crossing (its point computed once, shared
//! by both), nothing, an overlap along one line, or a degenerate touch; and the merge of
//! overlapping runs on one line into pieces with their jumps summed.
//!
//! Every decision is an exact orient2d, except that segments within [`ONE_LINE`] of one
//! line are taken as one (their projections are rounded: see there). A merged run's pieces
//! end only at its members' own end points, so no new point is computed: ends shared with
//! other segments stay bit-identical.

use super::segment::{Clipped, Crossing, Failure, Segment, orient};
use glam::DVec2;

/// How two segments meet.
pub(super) enum Contact {
    Apart,
    Crossing(Crossing),
    /// On one line, overlapping beyond a point.
    Overlap,
    /// An end of one lies exactly inside the other (a T-junction): that one is to be split
    /// there, at the end's own point (up to two such).
    Touch([Option<(u32, DVec2)>; 2]),
}

/// How far (in light coordinates: the light is 1 across) a segment's ends may lie from
/// another's line for the two to be one line. Edges collinear in 3D (a long wall edge and
/// the shorter ones along it, a face and its duplicate) project through rounded f64
/// arithmetic onto segments a few ulps off one line; taken as two lines they cross at a
/// hair's angle, their crossings' order along the others is lost, and the depths do not
/// close (sauerbraten-zdm2: 3,224 of 72,680 points). Merged, the boundary moves by at most
/// this much: far under any error V can show.
pub(super) const ONE_LINE: f64 = 1e-10;

/// Whether a and b lie on one line within [`ONE_LINE`] and overlap along it by more.
fn near_collinear(a: &Segment, b: &Segment) -> bool {
    let (da, db) = (a.p1 - a.p0, b.p1 - b.p0);
    let (la, lb) = (da.length(), db.length());
    if !(la > ONE_LINE && lb > ONE_LINE) {
        return false;
    }
    let off_a = |p: DVec2| da.perp_dot(p - a.p0).abs() / la;
    let off_b = |p: DVec2| db.perp_dot(p - b.p0).abs() / lb;
    if off_a(b.p0) > ONE_LINE || off_a(b.p1) > ONE_LINE || off_b(a.p0) > ONE_LINE || off_b(a.p1) > ONE_LINE {
        return false;
    }
    let u = da / la;
    let (s0, s1) = ((b.p0 - a.p0).dot(u), (b.p1 - a.p0).dot(u));
    s0.max(s1).min(la) - s0.min(s1).max(0.0) > ONE_LINE
}

/// How segments a (index i) and b (index j) meet.
pub(super) fn contact(i: u32, a: &Segment, j: u32, b: &Segment) -> Result<Contact, Failure> {
    if near_collinear(a, b) {
        return Ok(Contact::Overlap);
    }
    let (o1, o2) = (orient(a.p0, a.p1, b.p0), orient(a.p0, a.p1, b.p1));
    if o1 * o2 > 0 {
        return Ok(Contact::Apart);
    }
    let (o3, o4) = (orient(b.p0, b.p1, a.p0), orient(b.p0, b.p1, a.p1));
    if o3 * o4 > 0 {
        return Ok(Contact::Apart);
    }
    if o1 != 0 && o2 != 0 && o3 != 0 && o4 != 0 {
        // A proper crossing; its parameters from the side distances (f64, rounded).
        let e = a.p1 - a.p0;
        let f = b.p1 - b.p0;
        let (ga0, ga1) = (f.perp_dot(a.p0 - b.p0), f.perp_dot(a.p1 - b.p0));
        let ti = (ga0 / (ga0 - ga1)).clamp(0.0, 1.0);
        let (gb0, gb1) = (e.perp_dot(b.p0 - a.p0), e.perp_dot(b.p1 - a.p0));
        let tj = (gb0 / (gb0 - gb1)).clamp(0.0, 1.0);
        return Ok(Contact::Crossing(Crossing {
            i,
            j,
            ti,
            tj,
            point: a.p0 + ti * e,
            i0_right_of_j: o3 < 0,
            j0_right_of_i: o1 < 0,
        }));
    }
    let collinear = o1 == 0 && o2 == 0;
    if collinear {
        // Along the line: apart, touching at an end, or overlapping.
        let d = a.p1 - a.p0;
        let (s0, s1) = ((b.p0 - a.p0).dot(d), (b.p1 - a.p0).dot(d));
        let (lo, hi) = (s0.min(s1), s0.max(s1));
        return Ok(if hi <= 0.0 || lo >= d.length_squared() { Contact::Apart } else { Contact::Overlap });
    }
    // Touching at a shared end, or an end exactly inside the other (its line's orientation
    // 0 and the other segment's ends on both sides of or on its own line).
    let shared = [a.p0, a.p1].iter().any(|p| *p == b.p0 || *p == b.p1);
    if shared {
        return Ok(Contact::Apart);
    }
    let mut splits = [None; 2];
    let mut k = 0;
    for (o, into, point) in [(o1, i, b.p0), (o2, i, b.p1), (o3, j, a.p0), (o4, j, a.p1)] {
        if o == 0 {
            if k == 2 {
                return Err(Failure::Degenerate);
            }
            splits[k] = Some((into, point));
            k += 1;
        }
    }
    Ok(Contact::Touch(splits))
}

/// The merge's reused buffers.
#[derive(Debug, Default)]
pub(super) struct Merge {
    /// Union-find parents over the segments.
    parent: Vec<u32>,
    /// Per member of a group: (position key, point, boundary s, jump step).
    events: Vec<((f64, f64), DVec2, f64, i32)>,
    kept: Vec<Clipped>,
    members: Vec<(u32, u32)>,
}

impl Merge {
    /// Splits segments at the points `splits` names (each exactly inside its segment), so
    /// that every such end is a shared vertex; the pieces keep their segment's jump.
    pub(super) fn split(&mut self, segs: &mut Vec<Clipped>, splits: &mut [(u32, DVec2)]) {
        splits.sort_unstable_by_key(|a| a.0);
        self.kept.clear();
        let mut k = 0;
        for (index, c) in segs.iter().enumerate() {
            let start = k;
            while k < splits.len() && splits[k].0 == index as u32 {
                k += 1;
            }
            if start == k {
                self.kept.push(*c);
                continue;
            }
            // The points along the segment, from p0 (distinct; their order by the distance
            // from p0 is exact enough for points on one line: they are distinct values).
            let d = c.seg.p1 - c.seg.p0;
            let points = &mut splits[start..k];
            points.sort_unstable_by(|a, b| (a.1 - c.seg.p0).dot(d).total_cmp(&(b.1 - c.seg.p0).dot(d)));
            let (mut from, mut s0) = (c.seg.p0, c.s[0]);
            for &(_, p) in points.iter() {
                if p != from {
                    self.kept.push(Clipped {
                        seg: Segment { p0: from, p1: p, jump: c.seg.jump },
                        s: [s0, f64::NAN],
                    });
                    (from, s0) = (p, f64::NAN);
                }
            }
            self.kept
                .push(Clipped { seg: Segment { p0: from, p1: c.seg.p1, jump: c.seg.jump }, s: [s0, c.s[1]] });
        }
        std::mem::swap(segs, &mut self.kept);
    }

    /// Replaces every group of segments linked by `pairs` (overlapping on one line) with the
    /// pieces between their sorted end points, each with the sum of the jumps over it
    /// (oriented along the group's first member); pieces whose jumps cancel are dropped.
    pub(super) fn merge(&mut self, segs: &mut Vec<Clipped>, pairs: &[(u32, u32)]) {
        let n = segs.len();
        self.parent.clear();
        self.parent.extend(0..n as u32);
        for &(a, b) in pairs {
            let (ra, rb) = (find(&mut self.parent, a), find(&mut self.parent, b));
            if ra != rb {
                self.parent[ra.max(rb) as usize] = ra.min(rb);
            }
        }
        self.members.clear();
        self.kept.clear();
        for k in 0..n as u32 {
            let root = find(&mut self.parent, k);
            let grouped = pairs.iter().any(|&(a, b)| a == k || b == k) || root != k;
            if grouped {
                self.members.push((root, k));
            } else {
                self.kept.push(segs[k as usize]);
            }
        }
        self.members.sort_unstable();
        let mut start = 0;
        while start < self.members.len() {
            let root = self.members[start].0;
            let end = start + self.members[start..].iter().take_while(|m| m.0 == root).count();
            self.merge_group(segs, start..end);
            start = end;
        }
        std::mem::swap(segs, &mut self.kept);
    }

    /// One group's pieces into `kept`.
    fn merge_group(&mut self, segs: &[Clipped], range: std::ops::Range<usize>) {
        let first = segs[self.members[range.start].1 as usize].seg;
        let d = first.p1 - first.p0;
        // Points exactly on one line are ordered along it by one coordinate (the one that
        // varies most), in the direction of d.
        // Ordered by their distance along d (the points lie on one line within ONE_LINE);
        // then by position, so that equal points are adjacent.
        let key = |p: DVec2| ((p - first.p0).dot(d), p.x + p.y);
        self.events.clear();
        for &(_, k) in &self.members[range] {
            let c = segs[k as usize];
            let along = c.seg.jump * if (c.seg.p1 - c.seg.p0).dot(d) > 0.0 { 1 } else { -1 };
            let (k0, k1) = (key(c.seg.p0), key(c.seg.p1));
            let (first_end, last_end) = if k0 <= k1 { (0, 1) } else { (1, 0) };
            let point = |e: usize| if e == 0 { c.seg.p0 } else { c.seg.p1 };
            self.events.push((key(point(first_end)), point(first_end), c.s[first_end], along));
            self.events.push((key(point(last_end)), point(last_end), c.s[last_end], -along));
        }
        self.events.sort_unstable_by(|a, b| a.0.0.total_cmp(&b.0.0).then(a.0.1.total_cmp(&b.0.1)));
        // The jump over the piece that starts at the current point, stepped event by event.
        let mut acc = 0;
        let mut k = 0;
        let mut prev: Option<(DVec2, f64)> = None;
        while k < self.events.len() {
            let (point, mut s) = (self.events[k].1, self.events[k].2);
            let before = acc;
            while k < self.events.len() && self.events[k].1 == point {
                acc += self.events[k].3;
                if !self.events[k].2.is_nan() {
                    s = self.events[k].2;
                }
                k += 1;
            }
            if let Some((p0, s0)) = prev
                && before != 0
            {
                self.kept.push(Clipped { seg: Segment { p0, p1: point, jump: before }, s: [s0, s] });
            }
            prev = Some((point, s));
        }
    }
}

fn find(parent: &mut [u32], mut k: u32) -> u32 {
    while parent[k as usize] != k {
        let up = parent[parent[k as usize] as usize];
        parent[k as usize] = up;
        k = up;
    }
    k
}
