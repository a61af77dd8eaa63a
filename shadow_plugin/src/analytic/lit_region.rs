//! Which light points the opaque geometry leaves visible, answered from the arrangement's
//! own boundary of the lowest depth instead of a ray through the scene: the leaves' samples
//! ask it thousands of times a point ([`super::alpha`]), where a ray through the BVH was
//! most of glass-vase-flowers' cost.
//!
//! The boundary's pieces are oriented with the visible region on their left (their loops
//! close: each crossing is computed once and shared). A point is inside where a ray from it
//! towards +x crosses them with a positive winding; pieces are binned by rows of y so a
//! point tests only the pieces of its row.

use glam::DVec2;

/// Reused memory: the pieces, and per row of y the pieces that reach it (CSR).
#[derive(Debug, Default)]
pub(super) struct LitRegion {
    pieces: Vec<(DVec2, DVec2)>,
    starts: Vec<u32>,
    list: Vec<u32>,
    next: Vec<u32>,
    y0: f64,
    row: f64,
    rows: usize,
    lo: DVec2,
    hi: DVec2,
}

impl LitRegion {
    /// Starts a new region: no pieces.
    pub(super) fn clear(&mut self) {
        self.pieces.clear();
    }

    /// One oriented piece of the boundary (visible region on the left of a -> b).
    pub(super) fn push(&mut self, a: DVec2, b: DVec2) {
        self.pieces.push((a, b));
    }

    /// Bins the pieces pushed since [`LitRegion::clear`] into rows (two rows a piece: a point
    /// then tests about one piece past the ones crossing its row).
    pub(super) fn finish(&mut self) {
        let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
        for &(a, b) in &self.pieces {
            (lo, hi) = (lo.min(a.min(b)), hi.max(a.max(b)));
        }
        (self.lo, self.hi) = (lo, hi);
        self.rows = (2 * self.pieces.len()).clamp(1, 1024);
        self.y0 = lo.y;
        self.row = if hi.y > lo.y { (hi.y - lo.y) / self.rows as f64 } else { 1.0 };
        self.starts.clear();
        self.starts.resize(self.rows + 1, 0);
        for k in 0..self.pieces.len() {
            for r in self.span(k) {
                self.starts[r + 1] += 1;
            }
        }
        for r in 0..self.rows {
            self.starts[r + 1] += self.starts[r];
        }
        self.list.clear();
        self.list.resize(self.starts[self.rows] as usize, 0);
        let mut next = std::mem::take(&mut self.next);
        next.clear();
        next.extend_from_slice(&self.starts);
        for k in 0..self.pieces.len() {
            for r in self.span(k) {
                self.list[next[r] as usize] = k as u32;
                next[r] += 1;
            }
        }
        self.next = next;
    }

    /// The rows piece `k` reaches.
    fn span(&self, k: usize) -> std::ops::RangeInclusive<usize> {
        let (a, b) = self.pieces[k];
        let row = |y: f64| (((y - self.y0) / self.row).max(0.0) as usize).min(self.rows - 1);
        row(a.y.min(b.y))..=row(a.y.max(b.y))
    }

    /// The box of the boundary: no visible point lies outside it.
    pub(super) fn bounds(&self) -> (DVec2, DVec2) {
        (self.lo, self.hi)
    }

    /// Whether `q` is inside the visible region (a point on its boundary may go either way).
    pub(super) fn holds(&self, q: DVec2) -> bool {
        if !(q.y >= self.lo.y && q.y <= self.hi.y && q.x <= self.hi.x) {
            return false;
        }
        let r = (((q.y - self.y0) / self.row).max(0.0) as usize).min(self.rows - 1);
        let mut winding = 0i32;
        for &k in &self.list[self.starts[r] as usize..self.starts[r + 1] as usize] {
            let (a, b) = self.pieces[k as usize];
            // Half-open in y, so a ray through a shared end counts it once.
            if (a.y <= q.y) == (b.y <= q.y) {
                continue;
            }
            let x = a.x + (q.y - a.y) * (b.x - a.x) / (b.y - a.y);
            if x > q.x {
                winding += if b.y > a.y { 1 } else { -1 };
            }
        }
        winding > 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square with a square hole, against the plain answer on a grid of points.
    #[test]
    fn square_with_a_hole() {
        let mut region = LitRegion::default();
        let loop_of = |c: [(f64, f64); 4]| c.map(|(x, y)| DVec2::new(x, y));
        let outer = loop_of([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]);
        // The hole turns clockwise: the region is on its left.
        let hole = loop_of([(0.3, 0.3), (0.3, 0.6), (0.6, 0.6), (0.6, 0.3)]);
        region.clear();
        for corners in [outer, hole] {
            for k in 0..4 {
                region.push(corners[k], corners[(k + 1) % 4]);
            }
        }
        region.finish();
        for i in 0..50 {
            for j in 0..50 {
                let q = DVec2::new(-0.2 + i as f64 * 0.0291, -0.2 + j as f64 * 0.0293);
                let in_outer = q.x > 0.0 && q.x < 1.0 && q.y > 0.0 && q.y < 1.0;
                let in_hole = q.x > 0.3 && q.x < 0.6 && q.y > 0.3 && q.y < 0.6;
                assert_eq!(region.holds(q), in_outer && !in_hole, "{q}");
            }
        }
    }
}
