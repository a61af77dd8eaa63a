//! The counting, row by row of the strata grid: each sample's count relative to the
//! reference point R, along the path R -> (R.a, b) -> (a, b) (up the reference column, then
//! along the sample's own row).
//!
//! D changes only where the path crosses a projected edge, by the edge's weight, so the
//! count is a sum over crossings, and any path gives the same sum. This one makes every
//! decision a single comparison against the edge itself:
//! - the row leg (height b, from the column to a) crosses an edge iff b lies strictly between
//!   the heights of its ends and the leg's two ends are on opposite sides of its line;
//! - the column leg crosses it iff R.a lies strictly between its ends' a and R and the corner
//!   (R.a, b) are on opposite sides of its line.
//!
//! Both are exact once the points tested are clear of the line's band and b (or R.a) is
//! clear of the ends' coordinates by their rounding; a sample where either fails is traced.
//! An edge then touches only the rows its heights span (and, if it crosses the reference
//! column, moves whole rows at once), instead of every sample behind it as seen from R:
//! a small edge costs one or two rows, whatever its distance from R.

use glam::DVec2;
use std::ops::Range;

/// An edge active for this point, as affine functions of a sample's light coordinates.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct ActiveEdge {
    /// `side(a, b) = s0 + sa a + sb b`: orient3d(o, e0, e1, s) scaled to O(1), the sign of the
    /// sample's side. In f32, like the samples: the band covers its rounding.
    pub(super) side: [f32; 3],
    /// |side| under this: the sample is traced.
    pub(super) band: f32,
    /// The clipped projection's ends.
    pub(super) p0: DVec2,
    pub(super) p1: DVec2,
    /// The sum of the incident faces' orientations.
    pub(super) weight: i32,
}

impl ActiveEdge {
    #[inline(always)]
    pub(super) fn side_at(&self, a: f32, b: f32) -> f32 {
        self.side[0] + self.side[1] * a + self.side[2] * b
    }
}

/// How far (in light coordinates) a tested coordinate must be from an end's to be on a
/// definite side of it: the end's rounding to f32 (at most half an ulp of 1.02) and its
/// projection's f64 rounding, with room to spare.
const END_GAP: f32 = 4.0 * f32::EPSILON;

/// Whether `r` can be the reference point: clear of every edge's band, and its column clear
/// of every end's a (so that each column test is exact).
pub(super) fn is_reference(active: &[ActiveEdge], r: DVec2) -> bool {
    let (ra, rb) = (r.x as f32, r.y as f32);
    active.iter().all(|e| {
        e.side_at(ra, rb).abs() > 4.0 * e.band
            && (r.x - e.p0.x).abs() > END_GAP as f64 * 4.0
            && (r.x - e.p1.x).abs() > END_GAP as f64 * 4.0
    })
}

/// The heights a sample binned in row `j` of `ny` may have: [j/ny, (j+1)/ny] grown by the
/// f32 rounding of its binning (every counted sample lies on the light).
fn strip(j: usize, ny: usize) -> (f64, f64) {
    (j as f64 / ny as f64 - CELL_MARGIN, (j + 1) as f64 / ny as f64 + CELL_MARGIN)
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

/// One edge's tests, as the per-sample loop reads them.
#[derive(Debug, Clone, Copy)]
pub(super) struct EdgeTests {
    side: [f32; 3],
    /// side(R.a, b) = column + side[2] b: the corner's side.
    column: f32,
    band: f32,
    /// The ends' heights (f32): the row leg crosses iff b is above exactly one.
    heights: [f32; 2],
    /// Where a sample near the line is near the edge: its box grown by the band.
    near_box: [f32; 4],
    r_pos: bool,
    weight: i32,
}

/// One edge's work over the rows: the rows its row legs may cross (`rows`), the rows where
/// its column crossing falls (tested per sample, `column_rows`), and the rows wholly beyond
/// that crossing as seen from R, which move by `column_step` at once.
#[derive(Debug, Clone)]
pub(super) struct EdgeRows {
    pub(super) tests: EdgeTests,
    pub(super) rows: Range<usize>,
    pub(super) column_rows: Range<usize>,
    pub(super) beyond: Range<usize>,
    pub(super) column_step: i32,
}

impl EdgeRows {
    pub(super) fn new(e: &ActiveEdge, r: DVec2, ny: usize) -> EdgeRows {
        let (ra, rb) = (r.x as f32, r.y as f32);
        let r_pos = e.side_at(ra, rb) > 0.0;
        let [s0, sa, sb] = e.side;
        let grad = (sa as f64 * sa as f64 + sb as f64 * sb as f64).sqrt();
        // A sample within the band of the line is at most this far from it.
        let reach = if grad > 0.0 { e.band as f64 / grad } else { f64::INFINITY } + END_GAP as f64;
        let (lo, hi) = (e.p0.min(e.p1), e.p0.max(e.p1));
        let near_box =
            [(lo.x - reach) as f32, (hi.x + reach) as f32, (lo.y - reach) as f32, (hi.y + reach) as f32];
        let tests = EdgeTests {
            side: e.side,
            column: s0 + sa * ra,
            band: e.band,
            heights: [e.p0.y as f32, e.p1.y as f32],
            near_box,
            r_pos,
            weight: e.weight,
        };
        let rows = rows_meeting(lo.y - reach, hi.y + reach, ny);
        let (mut column_rows, mut beyond, mut column_step) = (0..0, 0..0, 0);
        if (r.x > e.p0.x) != (r.x > e.p1.x) && sb != 0.0 {
            // The line meets the column at height y_c; within `gap` of it the corner's side is
            // left to each sample's test (twice the band: the f32 test's rounding stays
            // inside it, so a row beyond has one side for every sample).
            let y_c = -(s0 as f64 + sa as f64 * r.x) / sb as f64;
            let gap = 2.0 * e.band as f64 / (sb as f64).abs() + 1e-6;
            column_rows = rows_meeting(y_c - gap, y_c + gap, ny);
            // The rows beyond y_c from R: the corner is on the other side of the line.
            let far_up = rb as f64 <= y_c;
            beyond = if far_up { column_rows.end..ny } else { 0..column_rows.start };
            let y = if far_up { y_c + gap } else { y_c - gap };
            let pos = (s0 as f64 + sa as f64 * r.x + sb as f64 * y) > 0.0;
            debug_assert!(beyond.is_empty() || pos != r_pos);
            column_step = if pos { e.weight } else { -e.weight };
            debug_assert!(beyond.clone().all(|j| {
                let (l, h) = strip(j, ny);
                l > y_c + gap || h < y_c - gap
            }));
        }
        EdgeRows { tests, rows, column_rows, beyond, column_step }
    }
}

/// The samples of one row (light coordinates, counts, near marks), and which legs to test.
pub(super) struct Row<'a> {
    pub(super) a: &'a [f32],
    pub(super) b: &'a [f32],
    pub(super) rel: &'a mut [i32],
    pub(super) near: &'a mut [u8],
}

/// One edge's share of one row's counts: the row leg's crossing (`row_leg`), the column
/// leg's (`column_leg`, where the column crossing falls in this row), and the samples whose
/// tests are not certain marked near (traced). Flat and branch-free (vectorised).
#[inline(always)]
pub(super) fn count_row(t: &EdgeTests, row_leg: bool, column_leg: bool, row: Row) {
    let [s0, sa, sb] = t.side;
    let [h0, h1] = t.heights;
    let [x_lo, x_hi, y_lo, y_hi] = t.near_box;
    let (w, band, column, r_pos) = (t.weight, t.band, t.column, t.r_pos);
    let n = row.rel.len().min(row.near.len()).min(row.a.len()).min(row.b.len());
    let (a, b, rel, near) = (&row.a[..n], &row.b[..n], &mut row.rel[..n], &mut row.near[..n]);
    for k in 0..n {
        let (x, y) = (a[k], b[k]);
        let v = s0 + sa * x + sb * y;
        let vc = column + sb * y;
        let (pos, pos_c) = (v > 0.0, vc > 0.0);
        let spans = (y > h0) != (y > h1);
        let crosses_row = row_leg & spans & (pos != pos_c);
        let crosses_column = column_leg & (pos_c != r_pos);
        let step = if crosses_row { if pos { w } else { -w } } else { 0 };
        let column_step = if crosses_column { if pos_c { w } else { -w } } else { 0 };
        let in_box = (x > x_lo) & (x < x_hi) & (y > y_lo) & (y < y_hi);
        // Near the line and either near the edge, or where the row leg reads its side (a
        // shallow line beside the edge's box): traced.
        let near_sample = row_leg & (v.abs() < band) & (in_box | spans);
        // Where both legs may cross (the corner beside the edge, away from its ends), a
        // wrong side for the corner moves one crossing to the other leg and the sum stands;
        // where one leg alone may, the corner's side decides it.
        let near_corner = (vc.abs() < band) & ((row_leg & spans) != column_leg);
        let near_end = row_leg & (((y - h0).abs() < END_GAP) | ((y - h1).abs() < END_GAP));
        rel[k] += step + column_step;
        near[k] |= (near_sample | near_corner | near_end) as u8;
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

/// What one edge does to one row's cells (see [`row_work`]): a run of cells whose samples
/// all move by a step, and the cells whose samples are tested one by one.
struct RowWork {
    run: Range<usize>,
    step: i32,
    exact: Range<usize>,
    row_leg: bool,
    column_leg: bool,
}

/// One edge's work on row `j`. Where the edge spans the row's strip (both ends beyond it)
/// and the corner's side is the same over the strip, its row legs cross exactly for the
/// samples beyond its line from the column: the cells wholly beyond (by twice the band)
/// form one run, and only the cells the line passes through are tested per sample. Else
/// the whole row is.
fn row_work(p: &EdgeRows, j: usize, (nx, ny): (usize, usize)) -> Option<RowWork> {
    let (row_leg, column_leg) = (p.rows.contains(&j), p.column_rows.contains(&j));
    let whole = RowWork { run: 0..0, step: 0, exact: 0..nx, row_leg, column_leg };
    if !row_leg {
        return column_leg.then_some(whole);
    }
    let t = &p.tests;
    let (y0, y1) = strip(j, ny);
    let gap = 2.0 * END_GAP as f64;
    let [h0, h1] = t.heights.map(f64::from);
    let spans = (h0.min(h1) < y0 - gap) && (h0.max(h1) > y1 + gap);
    let [s0, sa, sb] = t.side.map(f64::from);
    let band = 2.0 * t.band as f64;
    let column = |y: f64| t.column as f64 + sb * y;
    let (c0, c1) = (column(y0), column(y1));
    let corner_certain = (c0 > band && c1 > band) || (c0 < -band && c1 < -band);
    if column_leg || !spans || !corner_certain || sa == 0.0 {
        return Some(whole);
    }
    let pos_corner = c0 > 0.0;
    // The line's a at the strip's two edges, and the cells it may pass within the band of.
    let (xa, xb) = (-(s0 + sb * y0) / sa, -(s0 + sb * y1) / sa);
    let g = band / sa.abs() + 2.0 * CELL_MARGIN;
    let cell = |x: f64| (x * nx as f64).clamp(0.0, nx as f64 - 1.0) as usize;
    let (i0, i1) = (cell(xa.min(xb) - g), cell(xa.max(xb) + g));
    // The side grows with a where sa > 0: the cells right of the line are on the + side.
    let right_pos = sa > 0.0;
    let (run, far_pos) = if right_pos != pos_corner { (i1 + 1..nx, right_pos) } else { (0..i0, !right_pos) };
    let step = if far_pos { t.weight } else { -t.weight };
    Some(RowWork { run, step, exact: i0..i1 + 1, row_leg, column_leg: false })
}

/// Every edge's share of the counts: per sample where its legs may cross, by runs of cells
/// and whole rows (into `cell_steps`, a difference array over the cells) where they
/// certainly do. `draw(cells, a, b)` fills the cells' samples before they are tested
/// (`false`: give up).
pub(super) fn count_edges(
    plans: &[EdgeRows],
    s: Binned,
    cell_steps: &mut [i32],
    mut draw: impl FnMut(Range<usize>, &mut [f32], &mut [f32]) -> bool,
) -> bool {
    let nx = s.grid.0;
    for p in plans {
        for j in p.beyond.clone() {
            cell_steps[j * nx] += p.column_step;
            cell_steps[(j + 1) * nx] -= p.column_step;
        }
        for j in row_union(&p.rows, &p.column_rows) {
            let Some(w) = row_work(p, j, s.grid) else { continue };
            if !w.run.is_empty() {
                cell_steps[j * nx + w.run.start] += w.step;
                cell_steps[j * nx + w.run.end] -= w.step;
            }
            let cells = j * nx + w.exact.start..j * nx + w.exact.end;
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
            count_row(&p.tests, w.row_leg, w.column_leg, row);
        }
    }
    true
}

/// The rows of `x` or `y` (and any between them: the caller skips rows in neither).
pub(super) fn row_union(x: &Range<usize>, y: &Range<usize>) -> Range<usize> {
    match (x.is_empty(), y.is_empty()) {
        (true, _) => y.clone(),
        (_, true) => x.clone(),
        _ => x.start.min(y.start)..x.end.max(y.end),
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
        ActiveEdge { side, band, p0, p1, weight: 1 }
    }

    fn inside(t: &[DVec2; 3], s: DVec2) -> bool {
        (0..3).all(|k| (t[(k + 1) % 3] - t[k]).perp_dot(s - t[k]) > 0.0)
    }

    /// On random triangles (large ones spanning many rows, small ones inside one cell, ones
    /// crossing the reference column or reaching past the light), every sample the counting
    /// does not mark near gets exactly the number of triangles holding it less the number
    /// holding the reference point; jittered samples binned by cell, or one per cell drawn
    /// only where asked.
    #[test]
    fn counts_equal_the_triangles_holding_each_sample() {
        let mut next = crate::silhouette::uniform(0x0dd5_eed5_1234_abcd);
        let (nx, ny) = (32usize, 32usize);
        let (mut settled, mut near_total) = (0u64, 0u64);
        for trial in 0..200 {
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
        assert!(settled > 300_000, "{settled} samples settled");
        assert!(near_total * 1000 < settled, "{near_total} near of {settled}");
    }
}
