//! The 2D arrangement of projected edges over the light's visible domain, with the depth
//! complexity on every piece: what `analytic` integrates (the region where D is lowest).
//!
//! Input: segments in light coordinates, each with its jump `D(left) - D(right)` (left of
//! p0 -> p1), and the domain Ω, a convex polygon (the light's rectangle clipped by the
//! shading horizon), counter-clockwise. Output: per piece of every segment (between its
//! crossings with the others) the depth on both sides, and per piece of Ω's boundary the
//! depth inside, all relative to one reference; the lowest, a point inside a face that has
//! it (for the one ray that settles the constant), and the boundary of that level's region
//! as oriented pieces to integrate over.
//!
//! No faces are assembled: the depth is propagated along each segment through its sorted
//! crossings (each crossing computed once and shared by both segments, so the boundary
//! closes), across crossings to the other segment, around shared vertices (ends with
//! bit-identical coordinates, sorted by angle) and along Ω's boundary; a component reached
//! by none of these is anchored by counting along one path from the boundary. Every
//! topological decision (which side, whether two segments meet, the order round a vertex)
//! is an exact orient2d (Shewchuk's adaptive predicate); the crossing points are rounded
//! and used only to integrate, where their rounding costs O(ε) in V.
//!
//! Segments overlapping along one line (a duplicated triangle, coplanar architecture seen
//! edge-on) are merged into one run of pieces, their jumps summed ([`super::contacts`]).
//! A segment with another's end exactly inside it is split there; one along a side of Ω is
//! dropped (it separates nothing inside). Other degenerate input (a lone end inside Ω) is
//! refused ([`Failure::Degenerate`]); a propagation that reaches a
//! value twice differently, or a loop of jumps that does not close, is refused as
//! [`Failure::Inconsistent`]: the caller answers such a point another way and counts it.

use super::contacts::{Contact, Merge, contact};
use super::segment::{Clipped, Crossing, order_key};
pub use super::segment::{Failure, Segment, orient};
use glam::DVec2;

/// Most sides of the domain: the rectangle clipped by one line has at most five.
pub const MAX_DOMAIN: usize = 8;

/// A segment end on the boundary: its position, segment, and which end.
#[derive(Debug, Clone, Copy)]
struct BoundaryEnd {
    s: f64,
    p: DVec2,
    seg: u32,
    end: u8,
}

/// Reused buffers (one per thread): an arrangement allocates only while it grows.
#[derive(Debug, Default)]
pub struct Arrangement {
    domain: Vec<DVec2>,
    segs: Vec<Clipped>,
    crossings: Vec<Crossing>,
    /// Per segment, its crossings sorted along it (CSR: `starts`, `list`), and the depth
    /// change on its right before each piece (`cum`, one longer per segment than its list).
    starts: Vec<u32>,
    fill: Vec<u32>,
    list: Vec<u32>,
    cum: Vec<i32>,
    /// Per crossing, its index in i's list and in j's list.
    pos: Vec<[u32; 2]>,
    /// Per segment: D on its right at its start, relative to the reference.
    base: Vec<Option<i32>>,
    /// Interior ends sorted by position (vertex groups), and per segment end its group.
    ends: Vec<(u64, u64, u32, u8)>,
    group_of: Vec<[u32; 2]>,
    group_starts: Vec<u32>,
    group_done: Vec<bool>,
    boundary: Vec<BoundaryEnd>,
    /// D inside the boundary piece after each boundary end (the whole boundary if none).
    boundary_rel: Vec<i32>,
    queue: Vec<u32>,
    order: Vec<(u64, u32)>,
    /// The segments' boxes in `order`: x0, x1, y0, y1.
    boxes: Vec<[f64; 4]>,
    /// Pairs of segments found on one line, overlapping, and the merge's buffers.
    collinear: Vec<(u32, u32)>,
    splits: Vec<(u32, DVec2)>,
    merge: Merge,
    sectors: Vec<(u32, u8)>,
    /// The lowest relative depth and a point inside a face that has it.
    pub min_rel: i32,
    pub target: DVec2,
    /// A point beside the second longest piece of the lowest depth, if there is one: a
    /// second opinion where the ray to the first is blocked.
    pub second: Option<DVec2>,
}

impl Arrangement {
    /// Builds the arrangement of `segments` over `domain` (convex, counter-clockwise, at
    /// most [`MAX_DOMAIN`] corners, non-degenerate), with depths relative to the inside of
    /// the first boundary piece; then [`Arrangement::min_rel`] and [`Arrangement::target`].
    pub fn build(&mut self, domain: &[DVec2], segments: &[Segment]) -> Result<(), Failure> {
        self.domain.clear();
        self.domain.extend_from_slice(domain);
        self.clip_all(segments)?;
        self.find_crossings(true)?;
        if !(self.collinear.is_empty() && self.splits.is_empty()) {
            // Overlaps along one line become one run of pieces with their jumps summed, and
            // a segment with an end of another exactly inside it is split there; then the
            // crossings are found afresh (none of either is left).
            if !self.collinear.is_empty() {
                self.merge.merge(&mut self.segs, &self.collinear);
                self.find_crossings(true)?;
            }
            if !self.collinear.is_empty() {
                return Err(Failure::Degenerate);
            }
            if !self.splits.is_empty() {
                self.merge.split(&mut self.segs, &mut self.splits);
                self.find_crossings(false)?;
            }
        }
        self.sort_crossings();
        self.group_vertices()?;
        self.walk_boundary()?;
        self.propagate()?;
        self.find_min();
        Ok(())
    }

    /// Each segment clipped to the domain (Liang-Barsky on its sides), with the sides its
    /// clipped ends lie on; pieces outside or of zero length are dropped.
    fn clip_all(&mut self, segments: &[Segment]) -> Result<(), Failure> {
        self.segs.clear();
        let n = self.domain.len();
        for seg in segments {
            let (mut t0, mut t1) = (0.0f64, 1.0f64);
            let (mut side0, mut side1) = (usize::MAX, usize::MAX);
            let mut outside = false;
            for k in 0..n {
                let (a, b) = (self.domain[k], self.domain[(k + 1) % n]);
                // Inside: orient(a, b, x) >= 0 (the domain is counter-clockwise).
                let (o0, o1) = (orient(a, b, seg.p0), orient(a, b, seg.p1));
                if o0 <= 0 && o1 <= 0 {
                    // Both ends on or beyond this side's line: nothing inside. One along the
                    // side changes D only between inside and out: the boundary walk has the
                    // depth inside from the ends of the segments that meet the side.
                    outside = true;
                    break;
                }
                let e = b - a;
                let g0 = e.perp_dot(seg.p0 - a);
                let g1 = e.perp_dot(seg.p1 - a);
                if o0 <= 0 {
                    let t = if o0 == 0 { 0.0 } else { g0 / (g0 - g1) };
                    if t >= t0 {
                        (t0, side0) = (t, k);
                    }
                } else if o1 <= 0 {
                    let t = if o1 == 0 { 1.0 } else { g0 / (g0 - g1) };
                    if t <= t1 {
                        (t1, side1) = (t, k);
                    }
                }
            }
            if outside || t0 >= t1 {
                continue;
            }
            let at = |t: f64| {
                if t == 0.0 {
                    seg.p0
                } else if t == 1.0 {
                    seg.p1
                } else {
                    seg.p0 + t * (seg.p1 - seg.p0)
                }
            };
            let (p0, p1) = (at(t0), at(t1));
            if p0 == p1 {
                continue;
            }
            let s0 = if side0 == usize::MAX { f64::NAN } else { self.side_position(side0, p0) };
            let s1 = if side1 == usize::MAX { f64::NAN } else { self.side_position(side1, p1) };
            self.segs.push(Clipped { seg: Segment { p0, p1, jump: seg.jump }, s: [s0, s1] });
        }
        Ok(())
    }

    /// The boundary coordinate of `p` on side `k`: k plus its fraction along the side.
    fn side_position(&self, k: usize, p: DVec2) -> f64 {
        let n = self.domain.len();
        let (a, b) = (self.domain[k], self.domain[(k + 1) % n]);
        let e = b - a;
        let s = k as f64 + ((p - a).dot(e) / e.length_squared()).clamp(0.0, 1.0);
        // The last side's end is the first corner.
        if s >= n as f64 { 0.0 } else { s }
    }

    /// Every crossing of two segments, by a sweep over their x-ranges; collinear overlaps
    /// and ends exactly inside others are listed (where `allow_contacts`, else refused).
    fn find_crossings(&mut self, allow_contacts: bool) -> Result<(), Failure> {
        self.crossings.clear();
        self.collinear.clear();
        self.splits.clear();
        self.order.clear();
        let key = |c: &Clipped| order_key(c.seg.p0.x.min(c.seg.p1.x));
        self.order.extend(self.segs.iter().enumerate().map(|(i, c)| (key(c), i as u32)));
        self.order.sort_unstable_by_key(|o| o.0);
        // The boxes in sweep order, side by side: the inner loop reads them in a row (it
        // read each segment where it lay, a tenth of the softbox's time).
        self.boxes.clear();
        self.boxes.extend(self.order.iter().map(|&(_, i)| {
            let s = self.segs[i as usize].seg;
            [s.p0.x.min(s.p1.x), s.p0.x.max(s.p1.x), s.p0.y.min(s.p1.y), s.p0.y.max(s.p1.y)]
        }));
        for x in 0..self.order.len() {
            let i = self.order[x].1 as usize;
            let a = self.segs[i].seg;
            let [_, ax1, ay0, ay1] = self.boxes[x];
            for (y, b_box) in self.boxes.iter().enumerate().skip(x + 1) {
                if b_box[0] > ax1 {
                    break;
                }
                if b_box[3] < ay0 || b_box[2] > ay1 {
                    continue;
                }
                let j = self.order[y].1;
                let b = self.segs[j as usize].seg;
                match contact(i as u32, &a, j, &b)? {
                    Contact::Apart => {}
                    Contact::Crossing(c) => self.crossings.push(c),
                    Contact::Overlap if allow_contacts => self.collinear.push((i as u32, j)),
                    Contact::Touch(splits) if allow_contacts => {
                        self.splits.extend(splits.into_iter().flatten())
                    }
                    Contact::Overlap | Contact::Touch(_) => return Err(Failure::Degenerate),
                }
            }
        }
        Ok(())
    }

    /// Each segment's crossings sorted along it, their positions, and the running depth
    /// change on its right.
    fn sort_crossings(&mut self) {
        let n = self.segs.len();
        self.starts.clear();
        self.starts.resize(n + 1, 0);
        for c in &self.crossings {
            self.starts[c.i as usize + 1] += 1;
            self.starts[c.j as usize + 1] += 1;
        }
        for k in 0..n {
            self.starts[k + 1] += self.starts[k];
        }
        self.list.clear();
        self.list.resize(self.starts[n] as usize, 0);
        let mut fill = std::mem::take(&mut self.fill);
        fill.clear();
        fill.extend_from_slice(&self.starts[..n]);
        for (id, c) in self.crossings.iter().enumerate() {
            for s in [c.i, c.j] {
                self.list[fill[s as usize] as usize] = id as u32;
                fill[s as usize] += 1;
            }
        }
        self.fill = fill;
        let param = |c: &Crossing, s: u32| if c.i == s { c.ti } else { c.tj };
        self.pos.clear();
        self.pos.resize(self.crossings.len(), [0, 0]);
        self.cum.clear();
        self.cum.resize(self.starts[n] as usize + n, 0);
        for s in 0..n {
            let (lo, hi) = (self.starts[s] as usize, self.starts[s + 1] as usize);
            let crossings = &self.crossings;
            self.list[lo..hi].sort_unstable_by(|&x, &y| {
                param(&crossings[x as usize], s as u32).total_cmp(&param(&crossings[y as usize], s as u32))
            });
            let mut d = 0;
            let cum0 = lo + s;
            self.cum[cum0] = 0;
            for (k, &id) in self.list[lo..hi].iter().enumerate() {
                let c = &self.crossings[id as usize];
                // Crossing the other segment from its right to its left raises D by its jump.
                let (other, start_right) =
                    if c.i == s as u32 { (c.j, c.i0_right_of_j) } else { (c.i, c.j0_right_of_i) };
                let jump = self.segs[other as usize].seg.jump;
                d += if start_right { jump } else { -jump };
                self.cum[cum0 + k + 1] = d;
                self.pos[id as usize][(c.i != s as u32) as usize] = k as u32;
            }
        }
    }

    /// Groups the ends inside the domain by their exact position: shared vertices.
    fn group_vertices(&mut self) -> Result<(), Failure> {
        self.ends.clear();
        for (k, c) in self.segs.iter().enumerate() {
            for end in 0..2u8 {
                if c.s[end as usize].is_nan() {
                    let p = if end == 0 { c.seg.p0 } else { c.seg.p1 };
                    self.ends.push((p.x.to_bits(), p.y.to_bits(), k as u32, end));
                }
            }
        }
        self.ends.sort_unstable();
        self.group_of.clear();
        self.group_of.resize(self.segs.len(), [u32::MAX; 2]);
        self.group_starts.clear();
        let mut k = 0;
        while k < self.ends.len() {
            let mut m = k + 1;
            while m < self.ends.len() && self.ends[m].0 == self.ends[k].0 && self.ends[m].1 == self.ends[k].1
            {
                m += 1;
            }
            // A lone end: its jump cannot close round it (an end on another segment).
            if m - k < 2 {
                return Err(Failure::Degenerate);
            }
            let g = self.group_starts.len() as u32;
            self.group_starts.push(k as u32);
            for e in &self.ends[k..m] {
                self.group_of[e.2 as usize][e.3 as usize] = g;
            }
            k = m;
        }
        self.group_starts.push(self.ends.len() as u32);
        self.group_done.clear();
        self.group_done.resize(self.group_starts.len() - 1, false);
        Ok(())
    }

    /// The ends on the boundary in counter-clockwise order, and D inside each boundary
    /// piece relative to the first; the jumps round the whole boundary must sum to 0.
    fn walk_boundary(&mut self) -> Result<(), Failure> {
        self.boundary.clear();
        for (k, c) in self.segs.iter().enumerate() {
            for end in 0..2u8 {
                let s = c.s[end as usize];
                if !s.is_nan() {
                    let p = if end == 0 { c.seg.p0 } else { c.seg.p1 };
                    self.boundary.push(BoundaryEnd { s, p, seg: k as u32, end });
                }
            }
        }
        self.boundary.sort_unstable_by(|a, b| a.s.total_cmp(&b.s));
        self.boundary_rel.clear();
        let mut d = 0;
        for e in &self.boundary {
            // Arriving (end 1): the piece after is on the segment's left.
            let jump = self.segs[e.seg as usize].seg.jump;
            d += if e.end == 1 { jump } else { -jump };
            self.boundary_rel.push(d);
        }
        if d != 0 {
            return Err(Failure::Inconsistent);
        }
        Ok(())
    }

    /// D on the right of piece `k` of segment `s` (given its base).
    #[inline]
    fn right(&self, s: usize, base: i32, k: usize) -> i32 {
        base + self.cum[self.starts[s] as usize + s + k]
    }

    fn pieces(&self, s: usize) -> usize {
        (self.starts[s + 1] - self.starts[s]) as usize + 1
    }

    /// Piece `k` of segment `s`: its start and end points.
    fn piece_ends(&self, s: usize, k: usize) -> (DVec2, DVec2) {
        let seg = self.segs[s].seg;
        let (lo, n) = (self.starts[s] as usize, self.pieces(s));
        let point = |m: usize| self.crossings[self.list[lo + m] as usize].point;
        let a = if k == 0 { seg.p0 } else { point(k - 1) };
        let b = if k + 1 == n { seg.p1 } else { point(k) };
        (a, b)
    }

    /// Every straight piece of the boundary, counter-clockwise (split at the domain's
    /// corners and at the segments' ends, whose own points are used), with D inside it and
    /// the side it lies on.
    fn for_boundary_pieces(&self, mut f: impl FnMut(DVec2, DVec2, i32, usize)) {
        let n = self.domain.len();
        let m = self.boundary.len();
        if m == 0 {
            for k in 0..n {
                // No end on it: the whole boundary is the reference, depth 0.
                f(self.domain[k], self.domain[(k + 1) % n], 0, k);
            }
            return;
        }
        for e in 0..m {
            let (from, to) = (self.boundary[e], self.boundary[(e + 1) % m]);
            let rel = self.boundary_rel[e];
            let end = if e + 1 == m { to.s + n as f64 } else { to.s };
            let (mut a, mut corner) = (from.p, from.s.floor() + 1.0);
            while corner < end {
                let c = self.domain[corner as usize % n];
                f(a, c, rel, (corner as usize + n - 1) % n);
                (a, corner) = (c, corner + 1.0);
            }
            f(a, to.p, rel, (corner as usize + n - 1) % n);
        }
    }

    /// The lowest depth over every piece of positive length, and two points inside faces
    /// with it: beside the middles of its longest pieces, those with the most room.
    fn find_min(&mut self) {
        /// The longest pieces of the lowest depth a target is chosen from.
        const CANDIDATES: usize = 4;
        let mut min = i32::MAX;
        // The two longest pieces of the lowest depth: (length, middle, inward normal, its
        // segment or usize::MAX, its side or usize::MAX).
        type Piece = (f64, DVec2, DVec2, usize, usize);
        let none: Piece = (f64::NEG_INFINITY, DVec2::ZERO, DVec2::ZERO, usize::MAX, usize::MAX);
        let mut best = [none; CANDIDATES];
        let mut consider = |rel: i32, (a, b): (DVec2, DVec2), inward_left: bool, owner: (usize, usize)| {
            let len = (b - a).length();
            if len <= 0.0 || rel > min {
                return;
            }
            if rel < min {
                (min, best) = (rel, [none; CANDIDATES]);
            }
            let d = (b - a) / len;
            let normal = if inward_left { d.perp() } else { -d.perp() };
            let piece = (len, 0.5 * (a + b), normal, owner.0, owner.1);
            if let Some(k) = best.iter().position(|b| len > b.0) {
                best[k..].rotate_right(1);
                best[k] = piece;
            }
        };
        self.for_boundary_pieces(|a, b, rel, side| consider(rel, (a, b), true, (usize::MAX, side)));
        for s in 0..self.segs.len() {
            let base = self.base[s].expect("every segment has its base");
            let jump = self.segs[s].seg.jump;
            for k in 0..self.pieces(s) {
                let ends = self.piece_ends(s, k);
                let right = self.right(s, base, k);
                consider(right + jump, ends, true, (s, usize::MAX));
                consider(right, ends, false, (s, usize::MAX));
            }
        }
        self.min_rel = min;
        // Of the longest pieces, the two with the most room beside them: a sliver between
        // two nearly parallel segments (a T-junction's projection) may share the lowest
        // count with the face that is lit, and its ray may then be blocked.
        let mut points = [(f64::NEG_INFINITY, DVec2::ZERO); CANDIDATES];
        for (point, piece) in points.iter_mut().zip(best.iter().filter(|b| b.0 > 0.0)) {
            *point = self.inside(*piece);
        }
        points.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
        self.target = points[0].1;
        self.second = (points[1].0 > 0.0).then_some(points[1].1);
    }

    /// A point inside the face beside a piece: off its middle, a quarter of the way to the
    /// nearest other segment or side; and that room.
    fn inside(&self, (len, mid, normal, seg, side): (f64, DVec2, DVec2, usize, usize)) -> (f64, DVec2) {
        let mut room = 0.5 * len;
        for (j, c) in self.segs.iter().enumerate() {
            if j != seg {
                room = room.min(distance_to_segment(mid, c.seg.p0, c.seg.p1));
            }
        }
        let n = self.domain.len();
        for k in (0..n).filter(|&k| k != side) {
            room = room.min(distance_to_segment(mid, self.domain[k], self.domain[(k + 1) % n]));
        }
        (room, mid + 0.25 * room * normal)
    }

    /// The oriented pieces bounding the region of depth `level` (counter-clockwise round
    /// it: the region on their left), each given to `f` once.
    pub fn boundary_of(&self, level: i32, mut f: impl FnMut(DVec2, DVec2)) {
        self.for_boundary_pieces(|a, b, rel, _| {
            if rel == level {
                f(a, b);
            }
        });
        for s in 0..self.segs.len() {
            let base = self.base[s].expect("every segment has its base");
            let jump = self.segs[s].seg.jump;
            for k in 0..self.pieces(s) {
                let right = self.right(s, base, k);
                let (l, r) = (right + jump == level, right == level);
                if l != r {
                    let (a, b) = self.piece_ends(s, k);
                    if l { f(a, b) } else { f(b, a) }
                }
            }
        }
    }

    /// Counters: crossings, and pieces (each crossing splits two segments).
    pub fn sizes(&self) -> (usize, usize) {
        (self.crossings.len(), self.segs.len() + 2 * self.crossings.len())
    }
}

fn distance_to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let d = b - a;
    let t = ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
    (p - (a + t * d)).length()
}

#[path = "propagate.rs"]
mod propagate;

#[cfg(test)]
#[path = "arrangement_tests.rs"]
pub(super) mod tests;
