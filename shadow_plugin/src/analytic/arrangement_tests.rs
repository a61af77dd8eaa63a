//! The arrangement against brute force: random overlapping polygons (each adds its winding
//! number to D), every face's depth checked at random points by counting windings, and the
//! level sets' areas summing to the domain's.

use super::*;
use crate::silhouette_edges::uniform;

/// A random star-shaped polygon (simple), in either orientation: it adds 1 to D inside.
pub(in crate::analytic) fn polygon(next: &mut impl FnMut() -> f64) -> Vec<DVec2> {
    let centre = DVec2::new(1.4 * next() - 0.2, 1.4 * next() - 0.2);
    let n = 3 + (next() * 6.0) as usize;
    // Gaps under pi between consecutive corners keep it simple.
    let step = std::f64::consts::TAU / n as f64;
    let angles: Vec<f64> = (0..n).map(|k| (k as f64 + 0.9 * next()) * step).collect();
    let mut pts: Vec<DVec2> =
        angles.iter().map(|&a| centre + (0.05 + 0.4 * next()) * DVec2::new(a.cos(), a.sin())).collect();
    if next() < 0.4 {
        pts.reverse();
    }
    pts
}

/// The polygon's edges with their jumps: D rises by its winding inside.
pub(in crate::analytic) fn edges(poly: &[DVec2], out: &mut Vec<Segment>) {
    let area: f64 = (0..poly.len()).map(|k| poly[k].perp_dot(poly[(k + 1) % poly.len()])).sum();
    let jump = if area > 0.0 { 1 } else { -1 };
    for k in 0..poly.len() {
        out.push(Segment { p0: poly[k], p1: poly[(k + 1) % poly.len()], jump });
    }
}

pub(in crate::analytic) fn winding(poly: &[DVec2], p: DVec2) -> i32 {
    let mut w = 0;
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        if a.y <= p.y {
            if b.y > p.y && (b - a).perp_dot(p - a) > 0.0 {
                w += 1;
            }
        } else if b.y <= p.y && (b - a).perp_dot(p - a) < 0.0 {
            w -= 1;
        }
    }
    w
}

/// The face depth at `p` as the arrangement holds it: the first piece straight above p
/// (a segment's, or the boundary's), its side facing p.
fn rel_at(arr: &Arrangement, p: DVec2) -> Option<i32> {
    let mut best: Option<(f64, i32)> = None;
    let mut offer = |a: DVec2, b: DVec2, left: i32, right: i32| {
        if (a.x - p.x) * (b.x - p.x) >= 0.0 || a.x == b.x {
            return;
        }
        let t = (p.x - a.x) / (b.x - a.x);
        let y = a.y + t * (b.y - a.y);
        if y <= p.y {
            return;
        }
        // Below the piece is its left side when it runs right to left.
        let below = if b.x < a.x { left } else { right };
        if best.is_none_or(|(by, _)| y < by) {
            best = Some((y, below));
        }
    };
    arr.for_boundary_pieces(|a, b, rel, _| offer(a, b, rel, i32::MIN));
    for s in 0..arr.segs.len() {
        let base = arr.base[s].unwrap();
        for k in 0..arr.pieces(s) {
            let (a, b) = arr.piece_ends(s, k);
            let right = arr.right(s, base, k);
            offer(a, b, right + arr.segs[s].seg.jump, right);
        }
    }
    best.map(|(_, d)| d).filter(|&d| d != i32::MIN)
}

fn shoelace(arr: &Arrangement, level: i32) -> f64 {
    let mut area = 0.0;
    arr.boundary_of(level, |a, b| area += 0.5 * a.perp_dot(b));
    area
}

pub(in crate::analytic) fn domain(next: &mut impl FnMut() -> f64, clipped: bool) -> Vec<DVec2> {
    let square = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0)];
    if !clipped {
        return square.to_vec();
    }
    // The square clipped by a random line through its middle region (the horizon).
    let (p, angle) = (DVec2::new(0.2 + 0.6 * next(), 0.2 + 0.6 * next()), next() * std::f64::consts::TAU);
    let n = DVec2::new(angle.cos(), angle.sin());
    let mut out = Vec::new();
    for k in 0..4 {
        let (a, b) = (square[k], square[(k + 1) % 4]);
        let (ga, gb) = (n.dot(a - p), n.dot(b - p));
        if ga >= 0.0 {
            out.push(a);
        }
        if (ga >= 0.0) != (gb >= 0.0) {
            out.push(a + ga / (ga - gb) * (b - a));
        }
    }
    out
}

#[test]
fn faces_have_the_winding_depth_and_levels_tile_the_domain() {
    let mut next = uniform(0x5eed_1234_abcd_9876);
    let mut arr = Arrangement::default();
    let (mut checked, mut built) = (0, 0);
    for round in 0..400 {
        let polys: Vec<Vec<DVec2>> = (0..1 + round % 6).map(|_| polygon(&mut next)).collect();
        let mut segs = Vec::new();
        for p in &polys {
            edges(p, &mut segs);
        }
        let dom = domain(&mut next, round % 3 == 0);
        arr.build(&dom, &segs).expect("random polygons are in general position");
        built += 1;
        // The levels' areas sum to the domain's, each non-negative.
        let (lo, hi) = (arr.min_rel, arr.min_rel + 8);
        let mut total = 0.0;
        for level in lo..=hi {
            let a = shoelace(&arr, level);
            assert!(a > -1e-12, "round {round}: level {level} has area {a}");
            total += a;
        }
        let dom_area: f64 = (0..dom.len()).map(|k| 0.5 * dom[k].perp_dot(dom[(k + 1) % dom.len()])).sum();
        assert!(
            (total - dom_area).abs() < 1e-12,
            "round {round}: levels {total} against the domain's {dom_area}"
        );
        // Every face's depth differs from the brute-force winding sum by one constant.
        let mut offset = None;
        for _ in 0..60 {
            let p = DVec2::new(next(), next());
            if dom.iter().enumerate().any(|(k, &a)| orient(a, dom[(k + 1) % dom.len()], p) < 0) {
                continue;
            }
            let Some(rel) = rel_at(&arr, p) else { continue };
            let d: i32 = polys.iter().map(|q| winding(q, p).abs()).sum();
            let o = *offset.get_or_insert(d - rel);
            assert_eq!(d - rel, o, "round {round}: point {p}");
            checked += 1;
        }
        // The target lies in a face of the lowest depth.
        let t = arr.target;
        let d: i32 = polys.iter().map(|q| winding(q, t).abs()).sum();
        if let Some(o) = offset {
            assert_eq!(d - o, arr.min_rel, "round {round}: the target {t} is not in a lowest face");
        }
    }
    assert_eq!(built, 400);
    assert!(checked > 10_000, "only {checked} points checked");
}

/// Checks an arrangement of `polys` over `dom` against brute force: the levels' areas sum
/// to the domain's, and every face's depth differs from the winding sum by one constant.
fn check(arr: &Arrangement, polys: &[Vec<DVec2>], dom: &[DVec2], next: &mut impl FnMut() -> f64) -> usize {
    let total: f64 = (arr.min_rel..arr.min_rel + 12).map(|l| shoelace(arr, l)).sum();
    let dom_area: f64 = (0..dom.len()).map(|k| 0.5 * dom[k].perp_dot(dom[(k + 1) % dom.len()])).sum();
    assert!((total - dom_area).abs() < 1e-12, "levels {total} against the domain's {dom_area}");
    let (mut offset, mut checked) = (None, 0);
    for _ in 0..80 {
        let p = DVec2::new(next(), next());
        let Some(rel) = rel_at(arr, p) else { continue };
        let d: i32 = polys.iter().map(|q| winding(q, p).abs()).sum();
        assert_eq!(d - rel, *offset.get_or_insert(d - rel), "point {p}");
        checked += 1;
    }
    checked
}

/// Rectangles on a coarse grid (exact binary fractions): their sides overlap along shared
/// lines (merged, jumps summed: a duplicated edge cancels) and their corners fall exactly
/// on other sides (T-junctions, split there).
#[test]
fn collinear_overlaps_merge_and_t_junctions_split() {
    let mut next = uniform(0x0123_4567_89ab_cdef);
    let dom = domain(&mut next, false);
    let mut arr = Arrangement::default();
    let grid = |x: f64| (x * 8.0).floor() / 8.0;
    let mut checked = 0;
    for round in 0..300 {
        let polys: Vec<Vec<DVec2>> = (0..2 + round % 5)
            .map(|_| {
                let (x0, y0) = (grid(1.2 * next() - 0.1), grid(1.2 * next() - 0.1));
                let (w, h) = (0.125 * (1.0 + (next() * 4.0).floor()), 0.125 * (1.0 + (next() * 4.0).floor()));
                let r = vec![
                    DVec2::new(x0, y0),
                    DVec2::new(x0 + w, y0),
                    DVec2::new(x0 + w, y0 + h),
                    DVec2::new(x0, y0 + h),
                ];
                if next() < 0.5 { r.into_iter().rev().collect() } else { r }
            })
            .collect();
        let mut segs = Vec::new();
        for p in &polys {
            edges(p, &mut segs);
        }
        // A lone T-junction does not close: refused. Closed ones must be exact.
        match arr.build(&dom, &segs) {
            Ok(()) => checked += check(&arr, &polys, &dom, &mut next),
            Err(f) => panic!("round {round}: {f:?} for {polys:?}"),
        }
    }
    assert!(checked > 5000, "only {checked} points checked");
}

#[test]
fn a_shared_vertex_is_stepped_round() {
    // Two triangles meeting at one corner (a bow tie): both cover their insides once.
    let dom = domain(&mut uniform(1), false);
    let v = DVec2::new(0.5, 0.5);
    let mut segs = Vec::new();
    edges(&[v, DVec2::new(0.9, 0.3), DVec2::new(0.9, 0.7)], &mut segs);
    edges(&[v, DVec2::new(0.1, 0.7), DVec2::new(0.1, 0.3)], &mut segs);
    let mut arr = Arrangement::default();
    arr.build(&dom, &segs).unwrap();
    // Each triangle is 0.4 x 0.4 / 2 = 0.08: the lit area is 1 - 0.16.
    assert!((shoelace(&arr, arr.min_rel) - 0.84).abs() < 1e-12);
    assert!((shoelace(&arr, arr.min_rel + 1) - 0.16).abs() < 1e-12);
}
