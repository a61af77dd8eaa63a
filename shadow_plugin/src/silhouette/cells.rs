//! The counting cell by cell, for the common point: every sample above both horizons, inside
//! the shaft, on the unwarped strata grid, no flagged triangle near (`query::wholly_above`).
//!
//! Each stratum of the grid holds exactly one sample. An edge's three tests (`count_edge`:
//! the side of its line, and the two sides of the path cone from the reference point) are
//! affine in the sample's light coordinates, so over a cell each lies in a range read off
//! the cell's corners. Where every range is clear of its threshold (by the f32 evaluation's
//! rounding, and the band for the line), the cell's sample gets the edge's step, or nothing,
//! without its position. Only cells a boundary or a band passes through need the sample: it
//! is drawn alone (the random stream jumps to its stratum) and tested as before. An edge
//! then costs a few comparisons per cell it reaches and the exact test on ~3 cells per row,
//! instead of every sample drawn, binned and tested (the default scene: ~90 -> ~25 us per
//! penumbra point at N = 1024).

use super::counting::{ActiveEdge, path_side, reach_rows};
use glam::DVec2;

/// One edge's tests over whole cells of an `nx` x `ny` grid.
pub(super) struct EdgeCells {
    /// The side of the edge's line (`ActiveEdge::side`), and the path cone's sides through
    /// r and each end (`path_side`), as the f32 coefficients the per-sample test uses.
    tests: [[f64; 3]; 3],
    /// Per test: the f32 evaluation's rounding bound (and a sample a rounding outside its
    /// cell).
    margins: [f64; 3],
    band: f64,
    r_pos: bool,
    weight: i32,
    cell: (f64, f64),
}

/// What one edge does to a cell's sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Verdict {
    /// Nothing: the path from r misses the edge, and the sample is clear of its band.
    Nothing,
    /// The count moves by this step.
    Step(i32),
    /// Decided by the sample's own position.
    Exact,
}

impl EdgeCells {
    pub(super) fn new(e: &ActiveEdge, r: DVec2, (nx, ny): (usize, usize)) -> EdgeCells {
        let widen = |c: [f32; 3]| c.map(f64::from);
        let tests = [widen(e.side), widen(path_side(r, e.p0)), widen(path_side(r, e.p1))];
        // Three products and two sums in f32, each rounding by at most half an ulp of a
        // value no larger than the sum of the terms' magnitudes; 16 ulps is ample.
        let margins = tests.map(|c| 16.0 * f32::EPSILON as f64 * (c[0].abs() + c[1].abs() + c[2].abs()));
        EdgeCells {
            tests,
            margins,
            band: e.band as f64,
            r_pos: e.side_at(r.x as f32, r.y as f32) > 0.0,
            weight: e.weight,
            cell: (1.0 / nx as f64, 1.0 / ny as f64),
        }
    }

    /// The range of test `k` over cell (i, j), grown by its margin.
    #[inline(always)]
    fn range(&self, k: usize, i: usize, j: usize) -> (f64, f64) {
        let c = &self.tests[k];
        let (x0, x1) = (i as f64 * self.cell.0, (i + 1) as f64 * self.cell.0);
        let (y0, y1) = (j as f64 * self.cell.1, (j + 1) as f64 * self.cell.1);
        let (ax, bx) = (c[1] * x0, c[1] * x1);
        let (ay, by) = (c[2] * y0, c[2] * y1);
        let m = self.margins[k];
        (c[0] + ax.min(bx) + ay.min(by) - m, c[0] + ax.max(bx) + ay.max(by) + m)
    }

    /// Whether test `k` (`>= 0`) holds over the whole cell: `Some(true)`, `Some(false)`, or
    /// `None` where the cell straddles it.
    #[inline(always)]
    fn holds(&self, k: usize, i: usize, j: usize) -> Option<bool> {
        let (lo, hi) = self.range(k, i, j);
        if lo >= 0.0 {
            Some(true)
        } else if hi < 0.0 {
            Some(false)
        } else {
            None
        }
    }

    /// The edge's verdict on cell (i, j) (one the edge reaches: [`reach_rows`]), the same
    /// as `count_edge`'s on any sample in it where not `Exact`.
    #[inline(always)]
    pub(super) fn verdict(&self, i: usize, j: usize) -> Verdict {
        let (lo, hi) = self.range(0, i, j);
        // `count_edge`: pos = v > 0, near = |v| < band, cross needs pos != r_pos.
        let pos = if lo > self.band {
            true
        } else if hi < -self.band {
            false
        } else {
            return Verdict::Exact;
        };
        if pos == self.r_pos {
            return Verdict::Nothing;
        }
        match (self.holds(1, i, j), self.holds(2, i, j)) {
            (Some(x0), Some(x1)) if x0 != x1 => Verdict::Step(if pos { self.weight } else { -self.weight }),
            (Some(_), Some(_)) => Verdict::Nothing,
            _ => Verdict::Exact,
        }
    }
}

/// One edge's verdicts on the cells it reaches, in row order (see [`EdgeCells::verdict`]).
pub(super) fn edge_verdicts(
    e: &ActiveEdge,
    r: DVec2,
    grid: (usize, usize),
    mut visit: impl FnMut(usize, Verdict),
) {
    let cells = EdgeCells::new(e, r, grid);
    reach_rows(e, r, grid, |j, i0, i1| {
        for i in i0..i1 {
            visit(i + grid.0 * j, cells.verdict(i, j));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::silhouette::counting::{Counts, count_edge};

    /// Wherever a cell's verdict is certain, every sample in the cell (its corners and
    /// random points, in f32 as the samples are) gets exactly that from `count_edge`.
    #[test]
    fn certain_verdicts_agree_with_every_sample_in_the_cell() {
        let mut uniform = crate::silhouette::uniform(0x1234_5678_9abc_def1);
        let mut next = || uniform() as f32;
        let grid = (8usize, 8usize);
        let (mut certain, mut exact) = (0u32, 0u32);
        for _ in 0..400 {
            let p0 = DVec2::new(next() as f64 * 1.2 - 0.1, next() as f64 * 1.2 - 0.1);
            let p1 = DVec2::new(next() as f64 * 1.2 - 0.1, next() as f64 * 1.2 - 0.1);
            let d = p1 - p0;
            // side(s) = orient2d(p0, p1, s), scaled like `push` does, and a band.
            let side = [(p0.y * d.x - p0.x * d.y) as f32, d.y as f32, -d.x as f32];
            let e =
                ActiveEdge { side, band: next() * 0.05, p0, p1, weight: if next() < 0.5 { 1 } else { -2 } };
            let r = DVec2::new(0.5, 0.5);
            let cells = EdgeCells::new(&e, r, grid);
            for j in 0..grid.1 {
                for i in 0..grid.0 {
                    let verdict = cells.verdict(i, j);
                    if verdict == Verdict::Exact {
                        exact += 1;
                        continue;
                    }
                    certain += 1;
                    for k in 0..12 {
                        let (u, v) = if k < 4 { ((k & 1) as f32, (k >> 1) as f32) } else { (next(), next()) };
                        let a = [(i as f32 + u) / grid.0 as f32];
                        let b = [(j as f32 + v) / grid.1 as f32];
                        let (mut rel, mut near) = ([0i32], [0u8]);
                        count_edge(&e, r, 0..1, Counts { a: &a, b: &b, rel: &mut rel, near: &mut near });
                        let want = match verdict {
                            Verdict::Step(step) => step,
                            _ => 0,
                        };
                        assert_eq!((rel[0], near[0]), (want, 0), "cell ({i}, {j}) at ({}, {})", a[0], b[0]);
                    }
                }
            }
        }
        assert!(certain > 2 * exact, "{certain} certain cells, {exact} exact");
    }
}
