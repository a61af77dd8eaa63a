//! The depth on every piece of the arrangement: from the boundary walk through crossings
//! and round shared vertices (sorted exactly by angle), and, for a component none of them
//! reaches, by counting the jumps along one path from the boundary. Every value reached
//! twice must agree, every loop of jumps must close: otherwise the arrangement is refused
//! as inconsistent.

use super::{Arrangement, Clipped, Failure, orient};
use glam::DVec2;

impl Arrangement {
    /// Sets a segment's base, or checks it against the one it has.
    fn assign(&mut self, s: usize, base: i32) -> Result<(), Failure> {
        match self.base[s] {
            Some(b) if b != base => Err(Failure::Inconsistent),
            Some(_) => Ok(()),
            None => {
                self.base[s] = Some(base);
                self.queue.push(s as u32);
                Ok(())
            }
        }
    }

    /// Every segment's base: from the boundary, through crossings and shared vertices, and
    /// by counting for components reached by none.
    pub(super) fn propagate(&mut self) -> Result<(), Failure> {
        let n = self.segs.len();
        self.base.clear();
        self.base.resize(n, None);
        self.queue.clear();
        for e in 0..self.boundary.len() {
            let b = self.boundary[e];
            let after = self.boundary_rel[e];
            let before = after
                - if b.end == 1 {
                    self.segs[b.seg as usize].seg.jump
                } else {
                    -self.segs[b.seg as usize].seg.jump
                };
            let s = b.seg as usize;
            let base = if b.end == 1 {
                // Right side of the last piece = the piece before.
                before - self.cum[self.starts[s] as usize + s + self.pieces(s) - 1]
            } else {
                after
            };
            self.assign(s, base)?;
        }
        loop {
            while let Some(s) = self.queue.pop() {
                self.spread(s as usize)?;
            }
            match self.base.iter().position(Option::is_none) {
                None => return Ok(()),
                Some(s) => {
                    let base = self.count_anchor(s)?;
                    self.assign(s, base)?;
                }
            }
        }
    }

    /// From segment `s` (its base known) to the segments crossing it and sharing its ends.
    fn spread(&mut self, s: usize) -> Result<(), Failure> {
        let base = self.base[s].expect("spread only known segments");
        let jump = self.segs[s].seg.jump;
        for k in self.starts[s] as usize..self.starts[s + 1] as usize {
            let id = self.list[k] as usize;
            let c = self.crossings[id];
            let (me_i, other) = if c.i == s as u32 { (true, c.j as usize) } else { (false, c.i as usize) };
            let (my_pos, other_pos) =
                if me_i { (self.pos[id][0], self.pos[id][1]) } else { (self.pos[id][1], self.pos[id][0]) };
            // The other's right side just before the crossing: on my side where the other
            // starts, and before or after the crossing along me as my start lies on its right.
            let (other_start_right_of_me, my_start_right_of_other) =
                if me_i { (c.j0_right_of_i, c.i0_right_of_j) } else { (c.i0_right_of_j, c.j0_right_of_i) };
            let piece = if my_start_right_of_other { my_pos } else { my_pos + 1 } as usize;
            let right = self.right(s, base, piece);
            let d = if other_start_right_of_me { right } else { right + jump };
            let other_base = d - self.cum[self.starts[other] as usize + other + other_pos as usize];
            self.assign(other, other_base)?;
        }
        for end in 0..2 {
            let g = self.group_of[s][end];
            if g != u32::MAX && !self.group_done[g as usize] {
                self.group_done[g as usize] = true;
                self.around_vertex(g as usize)?;
            }
        }
        Ok(())
    }

    /// Round a shared vertex: its ends sorted by angle (exactly), the depth stepped sector
    /// to sector; every member's base from the one known.
    fn around_vertex(&mut self, g: usize) -> Result<(), Failure> {
        let (lo, hi) = (self.group_starts[g] as usize, self.group_starts[g + 1] as usize);
        let v = {
            let e = self.ends[lo];
            DVec2::new(f64::from_bits(e.0), f64::from_bits(e.1))
        };
        let mut sectors = std::mem::take(&mut self.sectors);
        sectors.clear();
        sectors.extend(self.ends[lo..hi].iter().map(|e| (e.2, e.3)));
        let other = |segs: &[Clipped], (s, end): (u32, u8)| {
            let c = &segs[s as usize].seg;
            if end == 0 { c.p1 } else { c.p0 }
        };
        let upper = |q: DVec2| q.y > v.y || (q.y == v.y && q.x > v.x);
        let segs = &self.segs;
        let mut degenerate = false;
        sectors.sort_by(|&a, &b| {
            let (qa, qb) = (other(segs, a), other(segs, b));
            match (upper(qa), upper(qb)) {
                (true, false) => std::cmp::Ordering::Less,
                (false, true) => std::cmp::Ordering::Greater,
                _ => match orient(v, qa, qb) {
                    1 => std::cmp::Ordering::Less,
                    -1 => std::cmp::Ordering::Greater,
                    _ => {
                        degenerate |= a != b;
                        std::cmp::Ordering::Equal
                    }
                },
            }
        });
        if degenerate {
            self.sectors = sectors;
            return Err(Failure::Degenerate);
        }
        // Sector m lies after member m (counter-clockwise); crossing an outgoing member
        // counter-clockwise goes from its right to its left.
        let step = |segs: &[Clipped], (s, end): (u32, u8)| {
            let j = segs[s as usize].seg.jump;
            if end == 0 { j } else { -j }
        };
        let total: i32 = sectors.iter().map(|&m| step(&self.segs, m)).sum();
        if total != 0 {
            self.sectors = sectors;
            return Err(Failure::Inconsistent);
        }
        // Relative sector depths: sector m = sum of steps of members 0..=m.
        let mut known = None;
        let mut d = 0;
        for &(s, end) in sectors.iter() {
            let before = d;
            d += step(&self.segs, (s, end));
            if let Some(base) = self.base[s as usize] {
                // Its right side's depth, relative: outgoing -> sector before; incoming -> after.
                let right_rel = if end == 0 { before } else { d };
                let piece = if end == 0 { 0 } else { self.pieces(s as usize) - 1 };
                known = Some(self.right(s as usize, base, piece) - right_rel);
                break;
            }
        }
        let offset = known.expect("a vertex is reached from one of its members");
        let mut d = 0;
        for &(s, end) in sectors.iter() {
            let before = d;
            d += step(&self.segs, (s, end));
            let right_rel = if end == 0 { before } else { d };
            let piece = if end == 0 { 0 } else { self.pieces(s as usize) - 1 };
            let base = offset + right_rel - self.cum[self.starts[s as usize] as usize + s as usize + piece];
            if let Err(f) = self.assign(s as usize, base) {
                self.sectors = sectors;
                return Err(f);
            }
        }
        self.sectors = sectors;
        Ok(())
    }

    /// A base for segment `s` counted along one path from a boundary piece (D inside it
    /// known) to a point of one of its pieces: the jumps of the segments the path crosses,
    /// summed. Paths that pass exactly through an end are tried again from other points
    /// (the longest boundary pieces, at a few fractions along each); none clean is
    /// degenerate.
    fn count_anchor(&self, s: usize) -> Result<i32, Failure> {
        const FRACTIONS: [f64; 3] = [0.5, 0.381_966_011_250_105_1, 0.723_606_797_749_979];
        let mut longest = [(0.0f64, DVec2::ZERO, DVec2::ZERO, 0i32); 4];
        self.for_boundary_pieces(|a, b, rel, _| {
            let len = (b - a).length();
            if let Some(k) = longest.iter().position(|x| len > x.0) {
                longest[k..].rotate_right(1);
                longest[k] = (len, a, b, rel);
            }
        });
        let seg = self.segs[s].seg;
        for &(_, a, b, rel) in longest.iter().filter(|x| x.0 > 0.0) {
            for f in FRACTIONS {
                let from = a + f * (b - a);
                let from_side = orient(seg.p0, seg.p1, from);
                if from_side == 0 {
                    continue;
                }
                for k in 0..self.pieces(s) {
                    let (pa, pb) = self.piece_ends(s, k);
                    for g in FRACTIONS {
                        let Some(d) = self.count_path(from, pa + g * (pb - pa), s) else { continue };
                        // D on the side of `s` facing `from`, at its piece k.
                        let right = if from_side > 0 { rel + d - seg.jump } else { rel + d };
                        return Ok(right - self.cum[self.starts[s] as usize + s + k]);
                    }
                }
            }
        }
        Err(Failure::Degenerate)
    }

    /// The depth change along the open path from -> to over every segment but `skip`, or
    /// `None` where the path touches an end or runs through a crossing point.
    fn count_path(&self, from: DVec2, to: DVec2, skip: usize) -> Option<i32> {
        let mut d = 0;
        for (j, c) in self.segs.iter().enumerate() {
            if j == skip {
                continue;
            }
            let (p, q) = (c.seg.p0, c.seg.p1);
            let (o1, o2) = (orient(p, q, from), orient(p, q, to));
            let (o3, o4) = (orient(from, to, p), orient(from, to, q));
            if o1 * o2 > 0 || o3 * o4 > 0 {
                continue;
            }
            if o1 == 0 || o2 == 0 || o3 == 0 || o4 == 0 {
                return None;
            }
            d += if o1 < 0 { c.seg.jump } else { -c.seg.jump };
        }
        Some(d)
    }
}
