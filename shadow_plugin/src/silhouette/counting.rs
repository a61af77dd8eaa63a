//! The counting loop: one edge's share of every sample's count relative to the reference
//! point, over the cells of the strata grid its path cone and band can reach.

use glam::DVec2;

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

/// orient2d(r, s, p) as an affine function of s = (a, b), in f32: the same coefficients (so
/// the same decisions) for every edge sharing the projected vertex `p`.
pub(super) fn path_side(r: DVec2, p: DVec2) -> [f32; 3] {
    let d = p - r;
    [(r.y * d.x - r.x * d.y) as f32, d.y as f32, -d.x as f32]
}

/// The counting's arrays over the strata grid.
pub(super) struct Counts<'a> {
    pub(super) a: &'a [f32],
    pub(super) b: &'a [f32],
    pub(super) rel: &'a mut [i32],
    pub(super) near: &'a mut [u8],
}

/// One edge's share of the counts relative to `r`, over the grid cells `cells`: the samples
/// whose path from r crosses its projection move by its weight, signed by their side; those
/// within its band are marked `near` (traced). Flat and branch-free (vectorised).
#[inline(always)]
pub(super) fn count_edge(e: &ActiveEdge, r: DVec2, cells: std::ops::Range<usize>, c: Counts) {
    let r_pos = e.side_at(r.x as f32, r.y as f32) > 0.0;
    let (l0, l1) = (path_side(r, e.p0), path_side(r, e.p1));
    let (side, band, w) = (e.side, e.band, e.weight);
    let (a, b) = (&c.a[cells.clone()], &c.b[cells.clone()]);
    let (rel, near) = (&mut c.rel[cells.clone()], &mut c.near[cells]);
    let n = rel.len().min(near.len()).min(a.len()).min(b.len());
    for k in 0..n {
        let (x, y) = (a[k], b[k]);
        let v = side[0] + side[1] * x + side[2] * y;
        let is_near = v.abs() < band;
        let pos = v > 0.0;
        let x0 = l0[0] + l0[1] * x + l0[2] * y >= 0.0;
        let x1 = l1[0] + l1[1] * x + l1[2] * y >= 0.0;
        let cross = (pos != r_pos) & (x0 != x1) & !is_near;
        let step = if pos { w } else { -w };
        rel[k] += if cross { step } else { 0 };
        near[k] |= is_near as u8;
    }
}

/// The cells an edge can reach, per row `j`: `i0..i1`, those its path cone (the part of the
/// light behind the edge as seen from r) or its band (around the projected segment) may
/// hold, with one row and column of margin beyond (far above the f32 tests' rounding, so
/// every cell where a test could hold is visited).
pub(super) fn reach_rows(
    e: &ActiveEdge,
    r: DVec2,
    (nx, ny): (usize, usize),
    mut row: impl FnMut(usize, usize, usize),
) {
    let (cone, n) = path_cone(r, e.p0, e.p1);
    let slope = slopes(&cone[..n]);
    let grad = (e.side[1] as f64).hypot(e.side[2] as f64);
    let g = if grad > 0.0 { e.band as f64 / grad } else { f64::INFINITY } + 1e-4;
    let (lo, hi) = (e.p0.min(e.p1) - DVec2::splat(g), e.p0.max(e.p1) + DVec2::splat(g));
    for j in 0..ny {
        let (y0, y1) = ((j as f64 - 1.0) / ny as f64, (j as f64 + 2.0) / ny as f64);
        let (mut a_lo, mut a_hi) = a_range(&cone[..n], &slope[..n], y0, y1);
        if y1 >= lo.y && y0 <= hi.y {
            (a_lo, a_hi) = (a_lo.min(lo.x), a_hi.max(hi.x));
        }
        if a_lo > a_hi {
            continue;
        }
        let i0 = ((a_lo * nx as f64).floor() - 1.0).clamp(0.0, nx as f64) as usize;
        let i1 = ((a_hi * nx as f64).floor() + 2.0).clamp(0.0, nx as f64) as usize;
        if i0 < i1 {
            row(j, i0, i1);
        }
    }
}

/// [`count_edge`] over the cells the edge can reach ([`reach_rows`]). The samples are binned
/// by cell, row-major: cell `c`'s are `starts[c]..starts[c + 1]`.
#[inline(never)]
pub(super) fn count_edge_on_grid(e: &ActiveEdge, r: DVec2, grid: (usize, usize), starts: &[u32], c: Counts) {
    let Counts { a, b, rel, near } = c;
    reach_rows(e, r, grid, |j, i0, i1| {
        let row = j * grid.0;
        let (first, last) = (starts[row + i0] as usize, starts[row + i1] as usize);
        let counts = Counts { a, b, rel: &mut *rel, near: &mut *near };
        count_edge(e, r, first..last, counts);
    });
}

/// The part of the (slightly grown) light behind segment p0 p1 as seen from r: a convex
/// polygon (at most 7 corners), and its corner count.
pub(super) fn path_cone(r: DVec2, p0: DVec2, p1: DVec2) -> ([DVec2; 8], usize) {
    let m = 1e-3;
    let mut poly = [DVec2::ZERO; 8];
    poly[..4].copy_from_slice(&[
        DVec2::new(-m, -m),
        DVec2::new(1.0 + m, -m),
        DVec2::new(1.0 + m, 1.0 + m),
        DVec2::new(-m, 1.0 + m),
    ]);
    let mut n = 4;
    let orient = |a: DVec2, b: DVec2, x: DVec2| (b - a).perp_dot(x - a);
    // Half-planes `g(x) >= -eps`, each scaled to distance: beyond the edge's line (away from
    // r), and between the rays r -> p0 and r -> p1.
    let s_edge = -orient(p0, p1, r).signum();
    let s0 = orient(r, p0, p1).signum();
    let s1 = orient(r, p1, p0).signum();
    let planes = [(p0, p1, s_edge), (r, p0, s0), (r, p1, s1)];
    for (a, b, sign) in planes {
        let len = (b - a).length();
        if len == 0.0 {
            continue;
        }
        let g = |x: DVec2| sign * orient(a, b, x) / len + 1e-4;
        let mut out = [DVec2::ZERO; 8];
        let mut m = 0;
        for k in 0..n {
            let (x, y) = (poly[k], poly[(k + 1) % n]);
            let (gx, gy) = (g(x), g(y));
            if gx >= 0.0 && m < 8 {
                out[m] = x;
                m += 1;
            }
            if (gx >= 0.0) != (gy >= 0.0) && m < 8 {
                out[m] = x + (y - x) * (gx / (gx - gy));
                m += 1;
            }
        }
        (poly, n) = (out, m);
        if n == 0 {
            break;
        }
    }
    (poly, n)
}

/// The a-range of a convex polygon over the strip y0 <= b <= y1 (empty: lo > hi): the
/// corners inside the strip, and where the sides cross its two lines. `slopes[k]` is side
/// k's da/db (from corner k to k + 1), computed once per polygon: a row then costs no
/// division (they were most of the counting's time on sauerbraten-zdm2).
pub(super) fn a_range(poly: &[DVec2], slopes: &[f64], y0: f64, y1: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let n = poly.len();
    for k in 0..n {
        let (p, q) = (poly[k], poly[(k + 1) % n]);
        if (y0..=y1).contains(&p.y) {
            (lo, hi) = (lo.min(p.x), hi.max(p.x));
        }
        let (below, above) = (p.y.min(q.y), p.y.max(q.y));
        for y in [y0, y1] {
            if below < y && y < above {
                let x = p.x + (y - p.y) * slopes[k];
                (lo, hi) = (lo.min(x), hi.max(x));
            }
        }
    }
    (lo, hi)
}

/// Side k's da/db of a polygon (0 for a horizontal side, never read: no line crosses it
/// strictly inside).
pub(super) fn slopes(poly: &[DVec2]) -> [f64; 8] {
    let mut out = [0.0; 8];
    let n = poly.len();
    for k in 0..n {
        let (p, q) = (poly[k], poly[(k + 1) % n]);
        if q.y != p.y {
            out[k] = (q.x - p.x) / (q.y - p.y);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The strip's a-range from the slopes equals clipping each side to the strip and
    /// taking its ends (to rounding), on path cones of random edges and references.
    #[test]
    fn a_range_matches_clipping_each_side() {
        let mut uniform = crate::silhouette::uniform(0x5151_7a7a_0303_9d9d);
        let mut next = || uniform() * 1.4 - 0.2;
        let clipped = |poly: &[DVec2], y0: f64, y1: f64| {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for k in 0..poly.len() {
                let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
                let (t0, t1) = if p.y == q.y {
                    if p.y < y0 || p.y > y1 { continue } else { (0.0, 1.0) }
                } else {
                    let (ta, tb) = ((y0 - p.y) / (q.y - p.y), (y1 - p.y) / (q.y - p.y));
                    (ta.min(tb).max(0.0), ta.max(tb).min(1.0))
                };
                for t in [t0, t1].into_iter().filter(|_| t0 <= t1) {
                    let x = p.x + t * (q.x - p.x);
                    (lo, hi) = (lo.min(x), hi.max(x));
                }
            }
            (lo, hi)
        };
        for _ in 0..2000 {
            let (r, p0, p1) =
                (DVec2::new(next(), next()), DVec2::new(next(), next()), DVec2::new(next(), next()));
            let (cone, n) = path_cone(r, p0, p1);
            let slope = slopes(&cone[..n]);
            for j in 0..16 {
                let (y0, y1) = (j as f64 / 16.0 - 0.05, (j + 1) as f64 / 16.0 + 0.05);
                let (a, b) = (a_range(&cone[..n], &slope[..n], y0, y1), clipped(&cone[..n], y0, y1));
                if b.0 > b.1 {
                    assert!(a.0 > a.1 || (a.1 - a.0) < 1e-12, "{a:?} for an empty strip");
                } else {
                    assert!((a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9, "{a:?} against {b:?}");
                }
            }
        }
    }
}
