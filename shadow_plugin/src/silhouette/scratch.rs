//! One point's working memory, per thread (allocated once, reused by every query): the
//! shaft's candidates, the active edges and flagged triangles' regions (an `EdgeScratch`,
//! filled in `silhouette_edges`), the samples with their counts and marks, and the strata
//! grid's bins; with the passes that fill these.

use super::counting::EdgeRows;
use crate::silhouette_edges::EdgeScratch;
use glam::DVec2;
use renderer::methods::sample_stream::LightSample;
use std::cell::RefCell;

#[derive(Default)]
pub(super) struct Scratch {
    /// The shaft's candidates, the active edges and the flagged triangles' regions.
    pub(super) edges: EdgeScratch,
    pub(super) samples: Vec<LightSample>,
    pub(super) rel: Vec<i32>,
    pub(super) uncertain: Vec<bool>,
    /// Per sample: [`MIXED`] where only alpha-tested triangles with holes may block it beyond
    /// the opaque count, then [`MIXED_LIT`] or [`MIXED_BLOCKED`] once tested against them.
    pub(super) mixed: Vec<u8>,
    /// One side's (sample, alpha-only region) pairs where the region holds the sample: the
    /// triangles a [`MIXED`] sample is tested against (sample in the high half, region in the
    /// low; sorted by sample there).
    pub(super) mixed_pairs: Vec<u64>,
    /// The counted samples of one side binned by cell of the strata grid (row-major): the
    /// cells' starts, each sample's index in `samples`, light coordinates, count and band
    /// mark, in bin order. ([`Scratch::test_regions`] bins its samples in them first, with
    /// its region marks in `near`.)
    pub(super) starts: Vec<u32>,
    pub(super) cursor: Vec<u32>,
    pub(super) cell_of: Vec<u32>,
    pub(super) order: Vec<u32>,
    pub(super) a: Vec<f32>,
    pub(super) b: Vec<f32>,
    pub(super) grid_rel: Vec<i32>,
    pub(super) near: Vec<u8>,
    /// The active edges' work over the strata rows, and the steps that move runs of cells
    /// at once (a difference array over the cells).
    pub(super) plans: Vec<EdgeRows>,
    pub(super) cell_steps: Vec<i32>,
    /// Cell by cell (`query::count_cells`): which cells' samples are drawn.
    pub(super) drawn: Vec<bool>,
    /// Per sample (or cell), bit k of word k / 64: the final verdict, unblocked; the smaller
    /// set is weighed from it, one set bit at a time.
    pub(super) lit: Vec<u64>,
}

thread_local! {
    pub(super) static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

impl Scratch {
    /// Bins this side's counted samples by cell of the strata grid (a counting sort, so that
    /// a row's cells i0..i1 are one range of `order`): an edge then visits only the rows and
    /// columns it can reach, also for samples the horizon warp moved off their strata.
    pub(super) fn bin(&mut self, (nx, ny): (u32, u32), below: bool) {
        let (nx, ny) = (nx as usize, ny as usize);
        let cells = nx * ny;
        let Scratch { samples, uncertain, starts, cursor, cell_of, order, a, b, grid_rel, near, .. } = self;
        // Counted samples lie in [0, 1]^2; f32 rounding may bin one just past its cell's
        // border, which the counting's `CELL_MARGIN` covers.
        let cell = |x: &LightSample| strata_cell(x, nx, ny);
        starts.clear();
        starts.resize(cells + 1, 0);
        // Each sample's cell, or `u32::MAX` where it is not counted on this side.
        cell_of.clear();
        cell_of.extend(
            samples
                .iter()
                .zip(uncertain.iter())
                .map(|(x, &u)| if !u && (x.height < 0.0) == below { cell(x) as u32 } else { u32::MAX }),
        );
        for &c in cell_of.iter().filter(|&&c| c != u32::MAX) {
            starts[c as usize + 1] += 1;
        }
        for c in 0..cells {
            starts[c + 1] += starts[c];
        }
        let total = starts[cells] as usize;
        cursor.clear();
        cursor.extend_from_slice(&starts[..cells]);
        order.resize(total, 0);
        a.resize(total, 0.0);
        b.resize(total, 0.0);
        grid_rel.clear();
        grid_rel.resize(total, 0);
        near.clear();
        near.resize(total, 0);
        for (k, &c) in cell_of.iter().enumerate().filter(|&(_, &c)| c != u32::MAX) {
            let x = &samples[k];
            let pos = cursor[c as usize] as usize;
            cursor[c as usize] += 1;
            (order[pos], a[pos], b[pos]) = (k as u32, x.a, x.b);
        }
    }

    /// Marks this side's samples that a flagged triangle's region holds: traced (uncertain),
    /// or [`MIXED`] where only alpha-tested ones with holes do. The samples are indexed by
    /// cell of the strata grid first, so that a region visits only the cells its box
    /// overlaps (glass-vase-flowers: every sample against every region's box was ~30% of the
    /// method's time).
    pub(super) fn test_regions(&mut self, (nx, ny): (u32, u32), below: bool) {
        let (nx, ny) = (nx as usize, ny as usize);
        let Scratch {
            edges: EdgeScratch { regions, .. },
            samples,
            uncertain,
            mixed,
            starts,
            cursor,
            order,
            a,
            b,
            near,
            mixed_pairs,
            ..
        } = self;
        // f32 rounding or the horizon warp may put a sample a little off its cell: clamped
        // here, and a region visits a cell of margin around its box.
        let cell = |x: &LightSample| strata_cell(x, nx, ny);
        let tested = |k: usize| !uncertain[k] && !samples[k].proven && (samples[k].height < 0.0) == below;
        starts.clear();
        starts.resize(nx * ny + 1, 0);
        for k in (0..samples.len()).filter(|&k| tested(k)) {
            starts[cell(&samples[k]) + 1] += 1;
        }
        for c in 0..nx * ny {
            starts[c + 1] += starts[c];
        }
        cursor.clear();
        cursor.extend_from_slice(&starts[..nx * ny]);
        let total = starts[nx * ny] as usize;
        order.resize(total, 0);
        // The binned samples' coordinates in bin order (a region reads one run of them per
        // row of its box), and per position: 1 held by an alpha-only region, 2 by another.
        a.resize(total, 0.0);
        b.resize(total, 0.0);
        near.clear();
        near.resize(total, 0);
        for k in (0..samples.len()).filter(|&k| tested(k)) {
            let c = cell(&samples[k]);
            let pos = cursor[c] as usize;
            (order[pos], a[pos], b[pos]) = (k as u32, samples[k].a, samples[k].b);
            cursor[c] += 1;
        }
        // The cells the box overlaps, and the next one where the box ends within 1e-4 of a
        // cell's border: a sample is binned where it landed, by the f32 product a nx, whose
        // rounding (2e-6 of a cell at 32 x 32) is all that may put one inside the box in a
        // cell beside it. (Clamped, then truncated: floor, no libm call.) A cell of margin
        // all round tested 9 cells for a leaf in one (glass-vase-flowers: 27% of the time).
        let span = |lo: f64, hi: f64, n: usize| {
            let top = n as f64 - 1.0;
            let first = if lo.is_finite() { (lo * n as f64 - 1e-4).clamp(0.0, top) } else { 0.0 };
            let last = if hi.is_finite() { (hi * n as f64 + 1e-4).clamp(0.0, top) } else { top };
            (first as usize, last as usize)
        };
        mixed_pairs.clear();
        for (index, r) in regions.iter().enumerate() {
            let ((i0, i1), (j0, j1)) = (span(r.lo.x, r.hi.x, nx), span(r.lo.y, r.hi.y, ny));
            for j in j0..=j1 {
                for pos in starts[i0 + nx * j] as usize..starts[i1 + nx * j + 1] as usize {
                    // An alpha-only region records every sample it holds (its triangle is one
                    // to test); another makes the sample traced.
                    if near[pos] == 2 || !r.holds(DVec2::new(a[pos] as f64, b[pos] as f64)) {
                        continue;
                    }
                    if r.alpha_only {
                        near[pos] = 1;
                        mixed_pairs.push((order[pos] as u64) << 32 | index as u64);
                    } else {
                        near[pos] = 2;
                    }
                }
            }
        }
        for (&k, &m) in order.iter().zip(near.iter()) {
            match m {
                2 => uncertain[k as usize] = true,
                1 => mixed[k as usize] = MIXED,
                _ => {}
            }
        }
    }
}

/// [`Scratch::mixed`]'s marks.
pub(super) const MIXED: u8 = 1;
pub(super) const MIXED_LIT: u8 = 2;
pub(super) const MIXED_BLOCKED: u8 = 3;

/// The strata cell (row-major in an `nx` x `ny` grid) where a sample landed, clamped to the
/// grid (a negative coordinate saturates to 0).
#[inline(always)]
fn strata_cell(x: &LightSample, nx: usize, ny: usize) -> usize {
    let i = ((x.a * nx as f32) as usize).min(nx - 1);
    let j = ((x.b * ny as f32) as usize).min(ny - 1);
    i + nx * j
}
