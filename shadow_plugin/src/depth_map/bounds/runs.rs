//! Per pixel, the runs of overlapping depth ranges, and their 2 x 2 block bounds (see the
//! parent module).

use super::{NO_COVER, OPAQUE, Raster};
use rayon::prelude::*;

/// What one pixel's depth ranges say: the first run of overlapping ranges `[a1, b1]`, where
/// the next begins (`a2`; free space between), and the end of the first run holding an opaque
/// range (a bound on the nearest opaque sheet; -inf where none).
#[derive(Clone, Copy)]
pub(super) struct Runs {
    a1: f32,
    b1: f32,
    a2: f32,
    far: f32,
}

const EMPTY: Runs = Runs { a1: f32::INFINITY, b1: f32::INFINITY, a2: f32::INFINITY, far: f32::NEG_INFINITY };

/// Per pixel, its [`Runs`].
pub(super) fn pixel_runs(ranges: Vec<(u32, f32, f32, bool)>, n: usize) -> Vec<Runs> {
    // Bucketed by pixel (a counting sort: linear, where one comparison sort of metal-rough-
    // spheres' 3 M ranges took most of its prepare), then each pixel's few sorted by depth.
    let mut start = vec![0usize; n + 1];
    for r in &ranges {
        start[r.0 as usize + 1] += 1;
    }
    for k in 0..n {
        start[k + 1] += start[k];
    }
    let mut next = start.clone();
    let mut sorted = vec![(0u32, 0.0f32, 0.0f32, false); ranges.len()];
    for r in ranges {
        sorted[next[r.0 as usize]] = r;
        next[r.0 as usize] += 1;
    }
    sorted.par_chunk_by_mut(|a, b| a.0 == b.0).for_each(|pixel| {
        pixel.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.2.total_cmp(&b.2)).then(a.3.cmp(&b.3)));
    });
    let ranges = sorted;
    let mut runs = vec![EMPTY; n];
    let mut k = 0;
    while k < ranges.len() {
        let pixel = ranges[k].0;
        let mut end = k;
        while end < ranges.len() && ranges[end].0 == pixel {
            end += 1;
        }
        // Walk the runs in order of their nearest depth (ranges are sorted by it).
        let (mut lo, mut hi, mut opaque) = (ranges[k].1, ranges[k].2, ranges[k].3);
        let mut r = Runs { a1: lo, b1: f32::NAN, a2: f32::INFINITY, far: f32::NEG_INFINITY };
        for &(_, a, b, o) in &ranges[k + 1..end] {
            if a <= hi {
                hi = hi.max(b);
                opaque |= o;
                continue;
            }
            // A run ends at `hi`.
            if r.b1.is_nan() {
                (r.b1, r.a2) = (hi, a);
            }
            if opaque && r.far == f32::NEG_INFINITY {
                r.far = hi;
            }
            (lo, hi, opaque) = (a, b, o);
        }
        let _ = lo;
        if r.b1.is_nan() {
            r.b1 = hi;
        }
        if opaque && r.far == f32::NEG_INFINITY {
            r.far = hi;
        }
        runs[pixel as usize] = r;
        k = end;
    }
    runs
}

/// The 2 x 2 block bounds of a raster: its first run and where the next begins over the four
/// pixels (near 0 where one is off the map), far where all four are covered; and near over
/// the pixels of each block on the map (for the pyramid that picks regions: a border block's
/// 0 would make every region reaching it reach to the light).
pub(super) fn blocks(r: &Raster, runs: &[Runs], res: usize) -> Blocks {
    let n = res * res;
    let mut b = Blocks {
        near2: vec![0.0; n],
        end2: vec![0.0; n],
        next2: vec![0.0; n],
        far2: vec![f32::NAN; n],
        near_on_map: vec![f32::INFINITY; n],
    };
    for j in 0..res {
        for i in 0..res {
            let ks = [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)];
            let on_map: Vec<usize> =
                ks.iter().filter(|(a, b)| *a < res && *b < res).map(|(a, b)| b * res + a).collect();
            let k = j * res + i;
            b.near_on_map[k] = on_map.iter().map(|&p| r.near[p]).fold(f32::INFINITY, f32::min);
            if on_map.len() < 4 {
                continue;
            }
            // The union of the four pixels' first runs and everything from their next runs on.
            let mut iv: Vec<(f32, f32)> = on_map
                .iter()
                .flat_map(|&p| [(runs[p].a1, runs[p].b1), (runs[p].a2, f32::INFINITY)])
                .collect();
            iv.sort_by(|x, y| x.0.total_cmp(&y.0));
            let (a1, mut b1) = iv[0];
            let mut a2 = f32::INFINITY;
            for &(a, e) in &iv[1..] {
                if a <= b1 {
                    b1 = b1.max(e);
                } else {
                    a2 = a;
                    break;
                }
            }
            (b.near2[k], b.end2[k], b.next2[k]) = (a1, b1, a2);
            if on_map.iter().all(|&p| r.flags[p] == OPAQUE) {
                b.far2[k] = on_map.iter().map(|&p| runs[p].far).fold(f32::NEG_INFINITY, f32::max);
            }
            // One opaque triangle over the whole block is a cover of its own, whatever other
            // geometry's edges do there; the nearer of the two ends counts.
            let id = r.cover[on_map[0]].0;
            if id != NO_COVER.0 && on_map.iter().all(|&p| r.cover[p].0 == id) {
                let far = on_map.iter().map(|&p| r.cover[p].1).fold(f32::NEG_INFINITY, f32::max);
                if b.far2[k].is_nan() || far < b.far2[k] {
                    b.far2[k] = far;
                }
            }
        }
    }
    b
}

/// [`blocks`]' arrays.
pub(super) struct Blocks {
    pub(super) near2: Vec<f32>,
    pub(super) end2: Vec<f32>,
    pub(super) next2: Vec<f32>,
    pub(super) far2: Vec<f32>,
    pub(super) near_on_map: Vec<f32>,
}
