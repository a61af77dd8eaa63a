//! The counting, row by row of the strata grid: each sample's count relative to the
//! reference point R, along the path R -> C_j = (R.a, y_j) -> M = (a, y_j) -> (a, b): up the
//! reference column to the row's own height y_j (the middle of its strip), along the row at
//! that height to the sample's column, then the short way within the strip to the sample.
//!
//! D changes only where the path crosses a projected edge, by the edge's weight, so the
//! count is a sum over crossings, and any path gives the same sum. This one makes every
//! decision a single comparison against the edge itself, and shares two legs per row:
//! - the column leg R -> C_j is the same for the whole row: an edge moves whole rows;
//! - the row leg at height y_j crosses an edge iff y_j lies strictly between its ends'
//!   heights and C_j and M are on opposite sides of its line: every cell beyond the line's
//!   crossing of y_j moves at once, only the cells the line passes through are tested;
//! - the last leg, within the strip, crosses an edge iff a lies strictly between its ends'
//!   a and M and the sample are on opposite sides of its line: only the cells the edge's
//!   part in the strip spans are tested.
//!
//! So an edge touches the cells it passes through, and moves runs of cells and rows: a small
//! edge (a dense mesh's silhouette) costs a cell or two, not the whole row it sits in (which
//! the path along the sample's own height needed: a row leg at each sample's height).
//! Each decision is exact once the points tested are clear of the line's band and the
//! coordinates compared are clear of the ends' by their rounding; a sample where one is not
//! is traced, and a row whose C_j or y_j is not (rare: a band's width in a strip's height)
//! is traced whole.

use crate::silhouette_edges::projection::ActiveEdge;
use glam::DVec2;
use std::ops::Range;

/// How far (in light coordinates) a tested coordinate must be from an end's to be on a
/// definite side of it: the end's rounding to f32 (at most half an ulp of 1.02) and its
/// projection's f64 rounding, with room to spare.
const END_GAP: f32 = 4.0 * f32::EPSILON;

/// Whether `r` can be the reference point: clear of every edge's band, and its column clear
/// of every end's a (so that each column test is exact).
pub(super) fn is_reference(active: &[ActiveEdge], r: DVec2) -> bool {
    let (ra, rb) = (r.x as f32, r.y as f32);
    active.iter().all(|e| {
        e.side_at(ra, rb).abs() > 4.0 * e.path_band
            && (r.x - e.p0.x).abs() > END_GAP as f64 * 4.0
            && (r.x - e.p1.x).abs() > END_GAP as f64 * 4.0
    })
}

/// The heights a sample binned in row `j` of `ny` may have: [j/ny, (j+1)/ny] grown by the
/// f32 rounding of its binning (every counted sample lies on the light).
fn strip(j: usize, ny: usize) -> (f64, f64) {
    (j as f64 / ny as f64 - CELL_MARGIN, (j + 1) as f64 / ny as f64 + CELL_MARGIN)
}

/// Row `j`'s own height y_j, where its row leg runs: the middle of its strip (unless an edge
/// conflicts with it: [`RowHeights`]).
fn row_height(j: usize, ny: usize) -> f64 {
    (j as f64 + 0.5) * (1.0 / ny as f64)
}

/// The rows whose strips meet [lo, hi].
fn rows_meeting(lo: f64, hi: f64, ny: usize) -> Range<usize> {
    // Clamped, then truncated: floor for the values kept (no libm call without SSE4.1).
    let row = |y: f64| (y * ny as f64).clamp(0.0, ny as f64 - 1.0) as usize;
    if lo.is_nan() || hi.is_nan() || lo > hi {
        return 0..0;
    }
    row(lo - 1e-5)..row(hi + 1e-5) + 1
}

/// One edge's constants, as the counting reads them.
#[derive(Debug, Clone)]
pub(super) struct EdgeRows {
    side: [f32; 3],
    band: f32,
    path_band: f32,
    weight: i32,
    p0: DVec2,
    p1: DVec2,
    /// How far from its line a sample within the band may be (light units), plus the ends'
    /// gap: the margin of the cells tested around the edge.
    reach: f64,
    /// The ends' a (f32, ascending): the last leg crosses only strictly between them.
    ends_a: [f32; 2],
    /// The edge's box grown by `reach` (a0, a1, b0, b1; f32): a sample within the band and
    /// in it is near the edge itself, where `traced`'s f32 test may go either way.
    near_box: [f32; 4],
    /// side(R.a, y) = column + sb y (f64): C_j's side.
    column: f64,
    /// The side R is on.
    r_pos: bool,
    /// Whether the edge crosses the reference column (its ends' a on both sides of R.a).
    crosses_column: bool,
    /// Where the edge crosses the reference column: the rows whose strips come near the
    /// crossing (C_j's side decided per row), and the rows wholly beyond it from R (empty
    /// both where it does not cross).
    column_near: Range<usize>,
    column_beyond: Range<usize>,
    /// The rows the edge's part may lie in (its row and last legs).
    pub(super) rows: Range<usize>,
}

impl EdgeRows {
    pub(super) fn new(e: &ActiveEdge, r: DVec2, ny: usize) -> EdgeRows {
        let (ra, rb) = (r.x as f32, r.y as f32);
        let [s0, sa, sb] = e.side;
        let grad = (sa as f64 * sa as f64 + sb as f64 * sb as f64).sqrt();
        // A sample within the band of the line is at most this far from it.
        let reach = if grad > 0.0 { e.band as f64 / grad } else { f64::INFINITY } + END_GAP as f64;
        let (lo, hi) = (e.p0.min(e.p1), e.p0.max(e.p1));
        let column = s0 as f64 + sa as f64 * r.x;
        let crosses_column = (r.x > e.p0.x) != (r.x > e.p1.x);
        let (mut column_near, mut column_beyond) = (0..0, 0..0);
        if crosses_column && sb != 0.0 {
            let y_c = -column / sb as f64;
            let g = 2.0 * e.path_band as f64 / (sb as f64).abs() + 1e-6;
            column_near = rows_meeting(y_c - g, y_c + g, ny);
            // R below the crossing: the rows above it are beyond.
            column_beyond = if r.y < y_c { column_near.end..ny } else { 0..column_near.start };
        }
        EdgeRows {
            side: e.side,
            band: e.band,
            path_band: e.path_band,
            weight: e.weight,
            p0: e.p0,
            p1: e.p1,
            reach,
            ends_a: [lo.x as f32, hi.x as f32],
            near_box: [
                (lo.x - reach) as f32,
                (hi.x + reach) as f32,
                (lo.y - reach) as f32,
                (hi.y + reach) as f32,
            ],
            column,
            r_pos: e.side_at(ra, rb) > 0.0,
            crosses_column,
            column_near,
            column_beyond,
            rows: rows_meeting(lo.y - reach, hi.y + reach, ny),
        }
    }

    /// The step crossing into the side `pos` adds.
    fn step(&self, pos: bool) -> i32 {
        if pos { self.weight } else { -self.weight }
    }

    /// The side of C = (R.a, y), or `None` where C lies within (twice) the band of the line.
    fn corner_side(&self, y: f64) -> Option<bool> {
        let v = self.column + self.side[2] as f64 * y;
        (v.abs() > 2.0 * self.path_band as f64).then_some(v > 0.0)
    }

    /// Whether height `y` cannot be row `j`'s own: within the ends' gap of an end's height
    /// (in a row the edge's part may lie in), or C = (R.a, y) within the band of the line
    /// where a leg reads C's side (the row leg crosses y there, or the edge crosses the
    /// column).
    fn conflicts(&self, j: usize, y: f64) -> bool {
        let in_rows = self.rows.contains(&j);
        let gap = END_GAP as f64;
        if in_rows && ((y - self.p0.y).abs() <= gap || (y - self.p1.y).abs() <= gap) {
            return true;
        }
        let spans = in_rows && (self.p0.y < y) != (self.p1.y < y);
        (spans || self.crosses_column) && self.corner_side(y).is_none() || spans && self.side[1] == 0.0
    }

    /// The rows whose own height this edge may conflict with: its rows, and the rows near
    /// its crossing of the reference column.
    fn conflict_rows(&self) -> [Range<usize>; 2] {
        [self.rows.clone(), self.column_near.clone()]
    }

    /// The a-range of the edge's part with heights in [lo, hi] (None: no part there).
    fn a_range(&self, lo: f64, hi: f64) -> Option<(f64, f64)> {
        // Wholly within the heights (a small edge in its strip): the whole edge.
        if lo <= self.p0.y.min(self.p1.y) && self.p0.y.max(self.p1.y) <= hi {
            return Some((self.p0.x.min(self.p1.x), self.p0.x.max(self.p1.x)));
        }
        let d = self.p1 - self.p0;
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        if d.y != 0.0 {
            let (ta, tb) = ((lo - self.p0.y) / d.y, (hi - self.p0.y) / d.y);
            (t0, t1) = (t0.max(ta.min(tb)), t1.min(ta.max(tb)));
        } else if self.p0.y < lo || self.p0.y > hi {
            return None;
        }
        if t0.is_nan() || t1.is_nan() || t0 > t1 {
            return None;
        }
        let (x0, x1) = (self.p0.x + t0 * d.x, self.p0.x + t1 * d.x);
        Some((x0.min(x1), x0.max(x1)))
    }
}

/// What one edge does in one row: the cells tested sample by sample, the runs of cells that
/// move at once, or the whole row traced.
enum RowWork {
    Cells { exact: Range<usize>, runs: [(Range<usize>, i32); 2], leg: Option<bool> },
    Conflict,
}

/// Edge `p`'s work in row `j`, whose own height is `y` (see the module doc). `leg`: whether
/// the row leg at `y` lies strictly between the ends' heights, with C_j's side
/// (`Some(pos_c)`).
fn row_work(p: &EdgeRows, j: usize, y: f64, (nx, ny): (usize, usize)) -> Option<RowWork> {
    let (y0, y1) = strip(j, ny);
    let gap = END_GAP as f64;
    if (y - p.p0.y).abs() <= gap || (y - p.p1.y).abs() <= gap {
        return Some(RowWork::Conflict);
    }
    let (xa, xb) = p.a_range(y0 - p.reach, y1 + p.reach)?;
    let spans = (p.p0.y < y) != (p.p1.y < y);
    let cell = |x: f64| (x * nx as f64).clamp(0.0, nx as f64 - 1.0) as usize;
    let mut g = p.reach + 2.0 * CELL_MARGIN;
    let mut runs = [(0..0, 0), (0..0, 0)];
    let mut leg = None;
    if spans {
        let Some(pos_c) = p.corner_side(y) else { return Some(RowWork::Conflict) };
        let sa = p.side[1] as f64;
        if sa == 0.0 {
            return Some(RowWork::Conflict);
        }
        // Cells clear of the line's crossing of y_j by twice the band: one side for every M.
        g = g.max(2.0 * p.path_band as f64 / sa.abs() + 2.0 * CELL_MARGIN);
        let (i0, i1) = (cell(xa - g), cell(xb + g));
        // Right of the line (growing a) is the + side where sa > 0; the run on the side
        // other than C_j's crosses.
        let right_pos = sa > 0.0;
        if right_pos != pos_c {
            runs[0] = (i1 + 1..nx, p.step(right_pos));
        } else {
            runs[1] = (0..i0, p.step(!right_pos));
        }
        leg = Some(pos_c);
        return Some(RowWork::Cells { exact: i0..i1 + 1, runs, leg });
    }
    Some(RowWork::Cells { exact: cell(xa - g)..cell(xb + g) + 1, runs, leg })
}

/// The samples of one row's tested cells (light coordinates, counts, near marks).
pub(super) struct Row<'a> {
    pub(super) a: &'a [f32],
    pub(super) b: &'a [f32],
    pub(super) rel: &'a mut [i32],
    pub(super) near: &'a mut [u8],
}

/// One edge's share of the counts of one row's tested samples: its row leg's crossing at
/// height `y` (where `leg` holds C_j's side) and its last leg's, and the samples whose
/// tests are not certain marked near (traced). Flat and branch-free (vectorised).
#[inline(always)]
fn count_row(p: &EdgeRows, y: f32, leg: Option<bool>, row: Row) {
    let [s0, sa, sb] = p.side;
    let at_y = s0 + sb * y;
    let [x_lo, x_hi] = p.ends_a;
    let [box_a0, box_a1, box_b0, box_b1] = p.near_box;
    let (w, band, path_band) = (p.weight, p.band, p.path_band);
    let (spans, pos_c) = (leg.is_some(), leg.unwrap_or(false));
    let n = row.rel.len().min(row.near.len()).min(row.a.len()).min(row.b.len());
    let (a, b, rel, near) = (&row.a[..n], &row.b[..n], &mut row.rel[..n], &mut row.near[..n]);
    for k in 0..n {
        let (x, yb) = (a[k], b[k]);
        let v_m = at_y + sa * x;
        let v_s = s0 + sa * x + sb * yb;
        let (pos_m, pos_s) = (v_m > 0.0, v_s > 0.0);
        let row_leg = spans & (pos_m != pos_c);
        let between = (x > x_lo) & (x < x_hi);
        let last_leg = between & (pos_m != pos_s);
        let step = if row_leg { if pos_m { w } else { -w } } else { 0 };
        let last_step = if last_leg { if pos_s { w } else { -w } } else { 0 };
        // Near the line where a leg reads the side: M on the row leg's crossing, M or the
        // sample beside the edge's span of a; the sample near the edge itself (its ray may
        // meet the triangle either way in f32, whatever the path: beside a short steep
        // edge, just past its span of a); or a within the ends' gap of an end's a.
        let wide = (x > x_lo - END_GAP) & (x < x_hi + END_GAP);
        let in_box = (x > box_a0) & (x < box_a1) & (yb > box_b0) & (yb < box_b1);
        let near_m = (v_m.abs() < path_band) & (spans | wide);
        let near_s = (v_s.abs() < band) & (wide | in_box);
        let near_end = ((x - x_lo).abs() < END_GAP) | ((x - x_hi).abs() < END_GAP);
        rel[k] += step + last_step;
        near[k] |= (near_m | near_s | near_end) as u8;
    }
}

/// The samples binned by cell of the strata grid (row-major; cell `c`'s are
/// `starts[c]..starts[c + 1]`), each inside the cell grown by [`CELL_MARGIN`]: light
/// coordinates, counts, near marks.
pub(super) struct Binned<'a> {
    pub(super) grid: (usize, usize),
    pub(super) starts: &'a [u32],
    pub(super) a: &'a mut [f32],
    pub(super) b: &'a mut [f32],
    pub(super) rel: &'a mut [i32],
    pub(super) near: &'a mut [u8],
}

/// How far a binned sample may lie outside its cell (the f32 rounding of its binning).
const CELL_MARGIN: f64 = 1e-6;

/// Every edge's share of the counts: per sample in the cells it passes through, by runs of
/// cells and whole rows (into `cell_steps`, a difference array over the cells) elsewhere.
/// `draw(cells, a, b)` fills the cells' samples before they are tested (`false`: give up).
pub(super) fn count_edges(
    plans: &[EdgeRows],
    s: Binned,
    cell_steps: &mut [i32],
    mut draw: impl FnMut(Range<usize>, &mut [f32], &mut [f32]) -> bool,
) -> bool {
    let (nx, ny) = s.grid;
    let heights = RowHeights::new(plans, ny);
    let mut conflicts = heights.conflicts;
    for p in plans {
        // The column leg: every row whose C_j is on the other side of the line from R. The
        // rows' own heights grow with j, so those clear of the crossing beyond it are one run
        // of cells; the few near it are decided one by one.
        if p.crosses_column {
            let (near, beyond) = (p.column_near.clone(), p.column_beyond.clone());
            let step = p.step(!p.r_pos);
            if !beyond.is_empty() {
                cell_steps[beyond.start * nx] += step;
                cell_steps[beyond.end * nx] -= step;
            }
            for j in near {
                match p.corner_side(heights.at(j)) {
                    _ if conflicts.holds(j) => {}
                    Some(pos) if pos != p.r_pos => {
                        cell_steps[j * nx] += step;
                        cell_steps[(j + 1) * nx] -= step;
                    }
                    Some(_) => {}
                    None => conflicts.mark(j),
                }
            }
        }
        for j in p.rows.clone() {
            if conflicts.holds(j) {
                continue;
            }
            let y = heights.at(j);
            let (exact, runs, leg) = match row_work(p, j, y, s.grid) {
                None => continue,
                Some(RowWork::Conflict) => {
                    conflicts.mark(j);
                    continue;
                }
                Some(RowWork::Cells { exact, runs, leg }) => (exact, runs, leg),
            };
            for (run, step) in runs {
                if !run.is_empty() {
                    cell_steps[j * nx + run.start] += step;
                    cell_steps[j * nx + run.end] -= step;
                }
            }
            let cells = j * nx + exact.start..j * nx + exact.end;
            if !draw(cells.clone(), s.a, s.b) {
                return false;
            }
            let range = s.starts[cells.start] as usize..s.starts[cells.end] as usize;
            let row = Row {
                a: &s.a[range.clone()],
                b: &s.b[range.clone()],
                rel: &mut s.rel[range.clone()],
                near: &mut s.near[range],
            };
            count_row(p, y as f32, leg, row);
        }
    }
    if conflicts.any {
        for j in (0..ny).filter(|&j| conflicts.holds(j)) {
            let cells = j * nx..(j + 1) * nx;
            if !draw(cells.clone(), s.a, s.b) {
                return false;
            }
            s.near[s.starts[cells.start] as usize..s.starts[cells.end] as usize].fill(1);
        }
    }
    true
}

/// Where each row's own height may go, in its strip (fractions of it), tried in order where
/// the middle conflicts with an edge ([`EdgeRows::conflicts`]): a vertex's projection
/// within rounding of it, or C_j within an edge's band (flight-helmet: about one row in a
/// hundred at the middle).
const HEIGHTS: [f64; 7] = [0.5, 0.3, 0.7, 0.15, 0.85, 0.4, 0.6];

/// Every row's own height: its strip's middle, or where that conflicts with an edge, the
/// first of [`HEIGHTS`] that conflicts with none; rows with none are traced whole.
struct RowHeights {
    /// Per row (the first 256: a square grid of `MAX_TRACED_SAMPLES` has that many; a row
    /// past them, on an odd N's narrow grid, cannot move and is traced whole if it
    /// conflicts): a height other than the middle, or NaN.
    moved: [f64; 256],
    ny: usize,
    conflicts: Conflicts,
}

impl RowHeights {
    fn new(plans: &[EdgeRows], ny: usize) -> RowHeights {
        let mut h = RowHeights { moved: [f64::NAN; 256], ny, conflicts: Conflicts::default() };
        let mut middle = Conflicts::default();
        for p in plans {
            for rows in p.conflict_rows() {
                for j in rows {
                    if !middle.holds(j) && p.conflicts(j, row_height(j, ny)) {
                        middle.mark(j);
                    }
                }
            }
        }
        if !middle.any {
            return h;
        }
        for j in (0..ny).filter(|&j| middle.holds(j)) {
            let free = HEIGHTS[1..]
                .iter()
                .map(|f| (j as f64 + f) / ny as f64)
                .find(|&y| plans.iter().all(|p| !p.conflicts(j, y)));
            match (free, h.moved.get_mut(j)) {
                (Some(y), Some(slot)) => *slot = y,
                _ => h.conflicts.mark(j),
            }
        }
        h
    }

    fn at(&self, j: usize) -> f64 {
        match self.moved.get(j) {
            Some(&y) if !y.is_nan() => y,
            _ => row_height(j, self.ny),
        }
    }
}

/// The rows traced whole, as bits for the first 256 rows; a row past them (an odd N's
/// narrow grid, 1018 = 2 x 509: rare, slow, never wrong) marks every row.
#[derive(Default, Clone, Copy)]
struct Conflicts {
    bits: [u64; 4],
    any: bool,
    beyond: bool,
}

impl Conflicts {
    fn mark(&mut self, j: usize) {
        self.any = true;
        match self.bits.get_mut(j / 64) {
            Some(word) => *word |= 1 << (j % 64),
            None => self.beyond = true,
        }
    }

    fn holds(&self, j: usize) -> bool {
        self.beyond || self.bits.get(j / 64).is_some_and(|w| w >> (j % 64) & 1 != 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An edge of a counter-clockwise triangle in light coordinates: side = orient2d(p0, p1,
    /// s) > 0 inside, weight 1, so the count is the number of triangles holding the sample.
    fn edge(p0: DVec2, p1: DVec2, band: f32) -> ActiveEdge {
        let d = p1 - p0;
        let side = [(d.y * p0.x - d.x * p0.y) as f32, -d.y as f32, d.x as f32];
        ActiveEdge { side, band, path_band: band / 4.0, p0, p1, weight: 1 }
    }

    fn inside(t: &[DVec2; 3], s: DVec2) -> bool {
        (0..3).all(|k| (t[(k + 1) % 3] - t[k]).perp_dot(s - t[k]) > 0.0)
    }

    /// A sample within an edge's band and near the edge itself is traced (its ray may meet
    /// the triangle either way in `traced`'s f32 test), also beside a short, nearly vertical
    /// edge just past its span of a, where no leg of the counting path crosses it.
    #[test]
    fn a_sample_in_the_band_beside_an_edge_is_traced() {
        let (nx, ny) = (32usize, 32usize);
        let cells = nx * ny;
        // Both ends above row 12's height (12.5 / 32): its row leg does not cross.
        let e = edge(DVec2::new(0.5, 0.395), DVec2::new(0.5 + 1e-8, 0.4), 1e-5);
        let r = DVec2::new(0.25, 0.75);
        assert!(is_reference(&[e], r));
        let plans = [EdgeRows::new(&e, r, ny)];
        let mut a: Vec<f32> = (0..cells).map(|c| ((c % nx) as f32 + 0.5) / nx as f32).collect();
        let mut b: Vec<f32> = (0..cells).map(|c| ((c / nx) as f32 + 0.5) / ny as f32).collect();
        // Cell (16, 12): 5e-4 right of the edge (half its band's reach), within its heights.
        let k = 16 + nx * 12;
        (a[k], b[k]) = (0.5005, 0.397);
        assert!(e.side_at(a[k], b[k]).abs() < e.band);
        let starts: Vec<u32> = (0..=cells as u32).collect();
        let (mut rel, mut near, mut steps) = (vec![0; cells], vec![0u8; cells], vec![0; cells + 1]);
        let binned =
            Binned { grid: (nx, ny), starts: &starts, a: &mut a, b: &mut b, rel: &mut rel, near: &mut near };
        assert!(count_edges(&plans, binned, &mut steps, |_, _, _| true));
        assert_ne!(near[k], 0, "a sample within the band beside the edge was settled");
    }

    /// On random triangles (large ones spanning many rows, small ones inside one cell, ones
    /// crossing the reference column or reaching past the light), every sample the counting
    /// does not mark near gets exactly the number of triangles holding it less the number
    /// holding the reference point; jittered samples binned by cell, or one per cell drawn
    /// only where asked.
    #[test]
    fn counts_equal_the_triangles_holding_each_sample() {
        let mut next = crate::silhouette_edges::uniform(0x0dd5_eed5_1234_abcd);
        let (mut settled, mut near_total) = (0u64, 0u64);
        // N = 1024 and 4096 (a tiny edge then sits in a smaller part of its row).
        for trial in 0..300 {
            let (nx, ny) = if trial < 200 { (32usize, 32usize) } else { (64, 64) };
            let mut tris = Vec::new();
            let mut active = Vec::new();
            for _ in 0..(1 + trial % 12) {
                let size = [0.002, 0.05, 0.6, 1.2][(next() * 4.0) as usize];
                let c = DVec2::new(next() * 1.02 - 0.01, next() * 1.02 - 0.01);
                let t = [0; 3].map(|_| c + size * DVec2::new(next() - 0.5, next() - 0.5));
                let t = t.map(|p| p.clamp(DVec2::splat(-0.01), DVec2::splat(1.01)));
                let t = if (t[1] - t[0]).perp_dot(t[2] - t[0]) > 0.0 { t } else { [t[0], t[2], t[1]] };
                let band = (1e-6 * (t[1] - t[0]).length()) as f32 + 1e-7;
                active.extend((0..3).map(|k| edge(t[k], t[(k + 1) % 3], band)));
                tris.push(t);
            }
            let Some(r) = [[0.5, 0.5], [0.3125, 0.6875], [0.125, 0.875]]
                .map(|[a, b]| DVec2::new(a, b))
                .into_iter()
                .find(|&r| is_reference(&active, r))
            else {
                continue;
            };
            let holding = |s: DVec2| tris.iter().filter(|t| inside(t, s)).count() as i32;
            let plans: Vec<_> = active.iter().map(|e| EdgeRows::new(e, r, ny)).collect();
            // Jittered samples, one per cell, binned (the general path) or drawn on demand.
            let cells = nx * ny;
            let mut a: Vec<f32> = (0..cells).map(|c| ((c % nx) as f64 + next()) as f32 / nx as f32).collect();
            let mut b: Vec<f32> = (0..cells).map(|c| ((c / nx) as f64 + next()) as f32 / ny as f32).collect();
            let truth: Vec<f32> = a.iter().chain(&b).copied().collect();
            for lazy in [false, true] {
                let starts: Vec<u32> = (0..=cells as u32).collect();
                let (mut rel, mut near, mut steps) = (vec![0; cells], vec![0u8; cells], vec![0; cells + 1]);
                if lazy {
                    a.fill(f32::NAN);
                    b.fill(f32::NAN);
                }
                let binned = Binned {
                    grid: (nx, ny),
                    starts: &starts,
                    a: &mut a,
                    b: &mut b,
                    rel: &mut rel,
                    near: &mut near,
                };
                assert!(count_edges(&plans, binned, &mut steps, |range, a, b| {
                    for c in range {
                        (a[c], b[c]) = (truth[c], truth[cells + c]);
                    }
                    true
                }));
                let mut step = 0;
                for c in 0..cells {
                    step += steps[c];
                    let s = DVec2::new(truth[c] as f64, truth[cells + c] as f64);
                    if near[c] != 0 {
                        near_total += 1;
                        continue;
                    }
                    settled += 1;
                    assert_eq!(
                        rel[c] + step,
                        holding(s) - holding(r),
                        "trial {trial}, sample {s}, lazy {lazy}"
                    );
                }
            }
        }
        assert!(settled > 900_000, "{settled} samples settled");
        assert!(near_total * 1000 < settled, "{near_total} near of {settled}");
    }
}
