//! Alpha-tested triangles with holes: no closed form follows a texture's cutoff, so the
//! opaque geometry is integrated exactly and only what the leaves take from the visible
//! region is estimated by samples. Jittered strata over the box of the leaves' projections
//! within the visible region's box (not the whole light); a sample counts where the opaque
//! geometry leaves it visible (the arrangement's own boundary, [`LitRegion`]) and a leaf
//! whose region holds it meets the line to it (alpha-tested, [`LeafMap`]): no ray through
//! the scene. A cell whose neighbours disagree (an edge or a cutoff crosses it, likely) is
//! refined into 2 x 2 sub-samples: where the noise is. The noise is that of the leaves'
//! share alone.

use super::lambert::LightPlane;
use super::lit_region::LitRegion;
use super::rows::Rows;
use super::segment::inside_convex;
use crate::silhouette_edges::edges::EdgeSet;
use crate::silhouette_edges::projection::Region;
use glam::{DVec2, Vec3};
use renderer::util::random::{mix64, strata, stream_seed};
use renderer::{RectLight, Scene};

/// What one side's alpha estimate needs: the light, the rays' origin, the flags of the
/// triangles left out of the counting, their projections, and the triangles.
pub(super) struct Leaves<'a> {
    pub light: &'a RectLight,
    pub origin: Vec3,
    pub flags: &'a [u8],
    pub regions: &'a [Region],
    pub edges: &'a EdgeSet,
}

/// A leaf seen from the origin, as a function of light coordinates: where the line from the
/// origin to light point q meets the leaf's plane, its barycentric weights are `n_i(q) /
/// sum`, each n_i affine in q (the volume spanned with the opposite side), and the meeting
/// is at t = `depth / sum` of the way to the light. No ray is built: a test costs three
/// affine forms and the alpha lookup (the ray's setup and watertight test were ~20% of
/// glass-vase-flowers' time).
struct LeafMap {
    n: [[f64; 3]; 3],
    depth: f64,
    slot: usize,
}

impl LeafMap {
    fn new(leaves: &Leaves, slot: u32) -> LeafMap {
        let o = leaves.origin.as_dvec3();
        let l = leaves.light;
        let (u, v) = (l.u.as_dvec3(), l.v.as_dvec3());
        let corner = l.center.as_dvec3() - 0.5 * (u + v) - o;
        let w = leaves.edges.triangle(slot).map(|x| x - o);
        let n = [0, 1, 2].map(|i| {
            let k = w[(i + 1) % 3].cross(w[(i + 2) % 3]);
            [k.dot(corner), k.dot(u), k.dot(v)]
        });
        let normal = (w[1] - w[0]).cross(w[2] - w[0]);
        LeafMap { n, depth: normal.dot(w[0]), slot: slot as usize }
    }

    /// Whether the leaf hides light point `q` from the origin (alpha test honoured).
    #[inline]
    fn hides(&self, scene: &Scene, q: DVec2) -> bool {
        let b = self.n.map(|[c, x, y]| c + x * q.x + y * q.y);
        let sum = b[0] + b[1] + b[2];
        let inside =
            (b[0] >= 0.0 && b[1] >= 0.0 && b[2] >= 0.0) || (b[0] <= 0.0 && b[1] <= 0.0 && b[2] <= 0.0);
        let t = self.depth / sum;
        inside
            && sum != 0.0
            && t > 0.0
            && t < 1.0
            && !scene.cut_out_at(self.slot, (b[1] / sum) as f32, (b[2] / sum) as f32)
    }
}

/// Most (region, cell) tests per stratum before a point is counted instead: a guard against
/// dense foliage over a large light. At 32 no point of the ten `scenes/gltf` scenes or the
/// softbox is counted (at 4, 4,178 flight-helmet points were, at `traced`'s noise: its
/// penumbra RMSE 1.6e-3 against 1.6e-4 at 32, for 1.75x against 1.9x `traced`'s cost).
const MAX_TESTS_PER_STRATUM: u64 = 32;

/// A cell's sample, once known: outside the part or the visible region, visible, or hidden
/// by a leaf (each cell is weighed once).
const UNKNOWN: u8 = 0;
const SKIP: u8 = 1;
const VISIBLE: u8 = 2;
const HIDDEN: u8 = 3;

/// Sub-strata per axis of a cell whose neighbours disagree (some hidden, some not): an edge
/// or a leaf's cutoff likely crosses it, and its 2 x 2 sub-samples replace its sample. The
/// decision reads only the neighbours' samples, never the cell's own, so the estimate stays
/// unbiased.
const REFINE: u64 = 2;

/// The grid of strata over the leaves' box: cell edges, and each cell's state.
struct Grid<'a> {
    xs: &'a [f64],
    ys: &'a [f64],
    nx: u64,
    key: u64,
}

impl Grid<'_> {
    /// Cell (i, j)'s sub-sample `k` of `n * n` (k = 0, n = 1: its one sample), and its area.
    /// `n` is 1 or [`REFINE`] (constants: no division on the hot path).
    #[inline(always)]
    fn sample(&self, (i, j): (u64, u64), k: u64, n: u64) -> (DVec2, f64) {
        let c = j * self.nx + i;
        let r = mix64(self.key ^ (c * REFINE * REFINE + k + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ n);
        let (u, v) =
            ((r >> 40) as f64 / (1u64 << 24) as f64, (r >> 16 & 0xff_ffff) as f64 / (1u64 << 24) as f64);
        let (i, j) = (i as usize, j as usize);
        let scale = 1.0 / n as f64;
        let (w, h) = ((self.xs[i + 1] - self.xs[i]) * scale, (self.ys[j + 1] - self.ys[j]) * scale);
        let (a, b) = ((k % n) as f64, (k / n) as f64);
        (DVec2::new(self.xs[i] + (a + u) * w, self.ys[j] + (b + v) * h), w * h)
    }

    /// The cells whose cuts overlap [a, b] along one axis (infinite ends: to the grid's end).
    fn span(a: f64, b: f64, cuts: &[f64]) -> std::ops::RangeInclusive<u64> {
        let n = cuts.len() - 1;
        let first = cuts.partition_point(|&x| x <= a).saturating_sub(1).min(n - 1);
        let last = cuts.partition_point(|&x| x < b).saturating_sub(1).min(n - 1);
        first as u64..=last.max(first) as u64
    }

    /// Every cell (index, (i, j)) under region `r`'s box, in order.
    fn cells_of(&self, r: &Region) -> impl Iterator<Item = (usize, (u64, u64))> + '_ {
        let (xs, nx) = (Self::span(r.lo.x, r.hi.x, self.xs), self.nx);
        Self::span(r.lo.y, r.hi.y, self.ys)
            .flat_map(move |j| xs.clone().map(move |i| ((j * nx + i) as usize, (i, j))))
    }
}

/// What a sample has been found to be (each is weighed once).
fn settle(
    (scene, lit, part): (&Scene, &LitRegion, &[DVec2]),
    (r, leaf): (&Region, &LeafMap),
    q: impl FnOnce() -> DVec2,
    state: &mut u8,
    tests: &mut u64,
) -> bool {
    if *state == SKIP || *state == HIDDEN {
        return false;
    }
    let q = q();
    if !r.holds(q) {
        return false;
    }
    if *state == UNKNOWN {
        let seen = inside_convex(part, q) && lit.holds(q);
        *state = if seen { VISIBLE } else { SKIP };
        if !seen {
            return false;
        }
    }
    *tests += 1;
    if leaf.hides(scene, q) {
        *state = HIDDEN;
        return true;
    }
    false
}

/// Reused memory of [`hidden_by_leaves`]: the cells' states, their sub-samples' states, the
/// refined cells' first sub-state, and the grid's cuts; and [`hidden_on_rows`]' leaves.
#[derive(Default)]
pub(super) struct LeafScratch {
    maps: Vec<(usize, LeafMap)>,
    /// Per row, where its maps' positions in `on_row` begin (rows' estimates).
    row_maps: Vec<u32>,
    fill: Vec<u32>,
    on_row: Vec<u32>,
    cells: Vec<u8>,
    subs: Vec<u8>,
    refined: Vec<u32>,
    xs: Vec<f64>,
    ys: Vec<f64>,
}

/// The weights the leaves' estimates sum: Lambert's, and a glossy lobe's where the query
/// has one ([`super::lobe`]; 0 under the fit's horizon by its own cosine).
#[derive(Clone, Copy)]
pub(super) struct Planes<'a> {
    pub cosine: &'a LightPlane,
    pub lobe: Option<&'a LightPlane>,
}

impl Planes<'_> {
    #[inline]
    fn add(&self, q: DVec2, area: f64, sums: &mut [f64; 2]) {
        sums[0] += self.cosine.weight(q) * area;
        if let Some(lobe) = self.lobe {
            sums[1] += lobe.weight(q) * area;
        }
    }
}

/// The estimated sums (in [`LightPlane::edge_term`]'s units, positive) of the part of the
/// visible region the leaves hide, over the convex `part`, with `samples` strata over the
/// leaves' box and the point's `seed`; and the leaf tests it made. `None` where the leaves'
/// boxes would cost more tests than [`MAX_TESTS_PER_STRATUM`].
pub(super) fn hidden_by_leaves(
    scene: &Scene,
    planes: Planes,
    (leaves, lit): (&Leaves, &LitRegion),
    (part, m): (&[DVec2], &mut LeafScratch),
    (samples, seed): (u32, u64),
) -> Option<([f64; 2], u64)> {
    let alpha = |r: &&Region| leaves.flags[r.slot as usize] & crate::silhouette_edges::edges::ALPHA != 0;
    let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
    for r in leaves.regions.iter().filter(alpha) {
        (lo, hi) = (lo.min(r.lo), hi.max(r.hi));
    }
    let (plo, phi) =
        part.iter().fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(l, h), &q| (l.min(q), h.max(q)));
    let (llo, lhi) = lit.bounds();
    let (lo, hi) = (lo.max(plo).max(llo), hi.min(phi).min(lhi));
    if !(lo.x < hi.x && lo.y < hi.y) {
        return Some(([0.0; 2], 0));
    }
    let (nx, ny) = strata(samples);
    let cuts = |n: u32, a: f64, b: f64, out: &mut Vec<f64>| {
        out.clear();
        out.extend((0..n).map(|i| a + (b - a) * i as f64 / n as f64));
        out.push(b);
    };
    cuts(nx, lo.x, hi.x, &mut m.xs);
    cuts(ny, lo.y, hi.y, &mut m.ys);
    let grid = Grid { xs: &m.xs, ys: &m.ys, nx: nx as u64, key: stream_seed(&[seed, 0xa1fa]) };
    let visits: usize = leaves.regions.iter().filter(alpha).map(|r| grid.cells_of(r).count()).sum();
    if visits as u64 > MAX_TESTS_PER_STRATUM * (nx * ny) as u64 {
        return None;
    }
    let ctx = (scene, lit, part);
    let mut tests = 0u64;
    // One sample a cell, each tested against the leaves holding it until one hides it.
    m.cells.clear();
    m.cells.resize((nx * ny) as usize, UNKNOWN);
    for r in leaves.regions.iter().filter(alpha) {
        let leaf = LeafMap::new(leaves, r.slot);
        for (c, ij) in grid.cells_of(r) {
            settle(ctx, (r, &leaf), || grid.sample(ij, 0, 1).0, &mut m.cells[c], &mut tests);
        }
    }
    refine(&m.cells, (nx as usize, ny as usize), &mut m.refined);
    m.subs.clear();
    m.subs.resize(m.refined.iter().filter(|&&k| k != u32::MAX).count() * (REFINE * REFINE) as usize, UNKNOWN);
    for r in leaves.regions.iter().filter(alpha) {
        let leaf = LeafMap::new(leaves, r.slot);
        for (c, ij) in grid.cells_of(r) {
            let first = m.refined[c];
            if first == u32::MAX {
                continue;
            }
            for k in 0..REFINE * REFINE {
                let state = &mut m.subs[first as usize + k as usize];
                settle(ctx, (r, &leaf), || grid.sample(ij, k, REFINE).0, state, &mut tests);
            }
        }
    }
    let mut sum = [0.0; 2];
    for (c, &first) in m.refined.iter().enumerate() {
        let ij = (c as u64 % grid.nx, c as u64 / grid.nx);
        if first == u32::MAX {
            if m.cells[c] == HIDDEN {
                let (q, area) = grid.sample(ij, 0, 1);
                planes.add(q, area, &mut sum);
            }
            continue;
        }
        for k in 0..REFINE * REFINE {
            if m.subs[first as usize + k as usize] == HIDDEN {
                let (q, area) = grid.sample(ij, k, REFINE);
                planes.add(q, area, &mut sum);
            }
        }
    }
    Some((sum, tests))
}

/// Per cell, the first of its sub-states if its four neighbours disagree (`u32::MAX`: not
/// refined).
fn refine(cells: &[u8], (nx, ny): (usize, usize), refined: &mut Vec<u32>) {
    refined.clear();
    let mut next = 0u32;
    for j in 0..ny {
        for i in 0..nx {
            let mut seen = [false; 2];
            let mut look = |i: usize, j: usize| seen[(cells[j * nx + i] == HIDDEN) as usize] = true;
            if i > 0 {
                look(i - 1, j);
            }
            if i + 1 < nx {
                look(i + 1, j);
            }
            if j > 0 {
                look(i, j - 1);
            }
            if j + 1 < ny {
                look(i, j + 1);
            }
            if seen[0] && seen[1] {
                refined.push(next);
                next += (REFINE * REFINE) as u32;
            } else {
                refined.push(u32::MAX);
            }
        }
    }
}

/// What leaves take from the rows' intervals at depth `level` ([`Rows`], where the edges are
/// many), in the rows' units (weight times length): `per_row` jittered cells along each row
/// over the part's width, each tested against the leaves whose regions hold it (their
/// projective maps: no ray) until one hides it. And the tests it made.
pub(super) fn hidden_on_rows(
    scene: &Scene,
    (planes, leaves): (Planes, &Leaves),
    (rows, level): (&Rows, i32),
    (per_row, seed): (u32, u64),
    m: &mut LeafScratch,
) -> ([f64; 2], u64) {
    let is_alpha = |r: &Region| leaves.flags[r.slot as usize] & crate::silhouette_edges::edges::ALPHA != 0;
    m.maps.clear();
    for (k, r) in leaves.regions.iter().enumerate().filter(|(_, r)| is_alpha(r)) {
        m.maps.push((k, LeafMap::new(leaves, r.slot)));
    }
    let (lo, hi) = rows.rows().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), r| (l.min(r.1), h.max(r.2)));
    let dx = (hi - lo) / per_row as f64;
    let key = stream_seed(&[seed, 0x0005_1eaf]);
    let (mut hidden, mut tests) = ([0.0; 2], 0u64);
    // Each row's leaves, in the maps' order (CSR): scanning every map on every row was a
    // tenth of the softbox's rows.
    let ys = rows.ys();
    let span = |r: &Region| (ys.partition_point(|&y| y < r.lo.y), ys.partition_point(|&y| y <= r.hi.y));
    m.row_maps.clear();
    m.row_maps.resize(ys.len() + 1, 0);
    for (k, _) in &m.maps {
        let (a, b) = span(&leaves.regions[*k]);
        (a..b).for_each(|j| m.row_maps[j + 1] += 1);
    }
    for j in 0..ys.len() {
        m.row_maps[j + 1] += m.row_maps[j];
    }
    m.fill.clear();
    m.fill.extend_from_slice(&m.row_maps[..ys.len()]);
    m.on_row.clear();
    m.on_row.resize(m.row_maps[ys.len()] as usize, 0);
    for (at, (k, _)) in m.maps.iter().enumerate() {
        let (a, b) = span(&leaves.regions[*k]);
        for j in a..b {
            m.on_row[m.fill[j] as usize] = at as u32;
            m.fill[j] += 1;
        }
    }
    for (j, (y, x0, x1)) in rows.rows().enumerate() {
        // Only cells meeting the row's intervals at `level` can hold a visible sample: the
        // rest start skipped (a sample never leaves its cell's bounds), a row with none is
        // passed whole (they were ~20% of the softbox's rows time).
        let seen = rows.level_intervals(j, level);
        if seen.is_empty() {
            continue;
        }
        let last_cell = per_row as usize - 1;
        m.cells.clear();
        m.cells.resize(per_row as usize, SKIP);
        for &(_, a, b, _) in seen {
            if !(a.is_finite() && b.is_finite()) {
                m.cells.fill(UNKNOWN);
                break;
            }
            // One cell over each way, for the roundings.
            let first = (((a - lo) / dx).max(0.0) as usize).saturating_sub(1).min(last_cell);
            let last = (((b - lo) / dx).max(0.0) as usize + 1).min(last_cell);
            m.cells[first..=last.max(first)].fill(UNKNOWN);
        }
        for &at in &m.on_row[m.row_maps[j] as usize..m.row_maps[j + 1] as usize] {
            let (k, map) = &m.maps[at as usize];
            let r = &leaves.regions[*k];
            let (a, b) = (r.lo.x.max(x0), r.hi.x.min(x1));
            if a >= b || a.is_nan() || b.is_nan() {
                continue;
            }
            let first = ((a - lo) / dx).max(0.0) as usize;
            let last = (((b - lo) / dx).max(0.0) as usize).min(per_row as usize - 1);
            for i in first..=last.max(first).min(per_row as usize - 1) {
                let state = &mut m.cells[i];
                if *state == SKIP || *state == HIDDEN {
                    continue;
                }
                let c = (j as u64) << 32 | i as u64;
                let u =
                    (mix64(key ^ c.wrapping_mul(0x9e37_79b9_7f4a_7c15)) >> 11) as f64 / (1u64 << 53) as f64;
                let q = DVec2::new(lo + (i as f64 + u) * dx, y);
                if !r.holds(q) {
                    continue;
                }
                if *state == UNKNOWN {
                    *state = if rows.at_level(j, level, q.x) { VISIBLE } else { SKIP };
                    if *state == SKIP {
                        continue;
                    }
                }
                tests += 1;
                if map.hides(scene, q) {
                    *state = HIDDEN;
                    planes.add(q, dx, &mut hidden);
                }
            }
        }
    }
    (hidden, tests)
}
