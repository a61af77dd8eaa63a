//! Cost: each estimator's sampling and weighting per sample, and its per-point work.

use crate::accuracy::seed_of;
use crate::estimators::{area_fraction, ratio, solid_angle_tally, solid_angle_tally_f32, uniform_tally};
use crate::rng::Rng;
use crate::scene::{Point, lambert};
use crate::spherical_rect::{SphericalRect, SphericalRectF32};
use std::hint::black_box;
use std::time::Instant;

/// ns per sample of each estimator's sampling and weighting, the verdicts read from a table
/// (drawn beforehand with the same seeds) and every sample's target kept (`black_box`: a ray
/// would need it): [area, ratio/norm (both sums), solid (f64 map), solid (f32 map)]; and ns
/// per point of the exact G (estimator 3) and of the spherical rectangle's set-up (4).
pub fn costs(points: &[Point], n: u32) -> ([f64; 4], f64, f64) {
    let tables: Vec<(Vec<bool>, Vec<bool>)> = points
        .iter()
        .enumerate()
        .map(|(i, pt)| {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            uniform_tally::<false>(pt, n, &mut Rng::new(seed_of(i, n, 0, 0)), |_, y| {
                a.push(pt.card.blocks(pt.p, y.as_dvec3()));
                false
            });
            let rect = SphericalRect::of(pt);
            solid_angle_tally(pt, &rect, n, &mut Rng::new(seed_of(i, n, 0, 1)), |_, y| {
                b.push(pt.card.blocks(pt.p, y.as_dvec3()));
                false
            });
            (a, b)
        })
        .collect();
    let rects: Vec<SphericalRect> = points.iter().map(SphericalRect::of).collect();
    let samples = (points.len() as u64 * n as u64) as f64;
    let best_of = |f: &mut dyn FnMut() -> f64| (0..7).map(|_| f()).fold(f64::INFINITY, f64::min);
    let area = best_of(&mut || {
        let start = Instant::now();
        for (i, pt) in points.iter().enumerate() {
            let table = &tables[i].0;
            let t = uniform_tally::<false>(pt, n, &mut Rng::new(seed_of(i, n, 0, 0)), |j, y| {
                black_box(y);
                table[j]
            });
            black_box(area_fraction(&t));
        }
        start.elapsed().as_secs_f64() * 1e9 / samples
    });
    let weighed = best_of(&mut || {
        let start = Instant::now();
        for (i, pt) in points.iter().enumerate() {
            let table = &tables[i].0;
            let t = uniform_tally::<true>(pt, n, &mut Rng::new(seed_of(i, n, 0, 0)), |j, y| {
                black_box(y);
                table[j]
            });
            black_box(ratio(&t));
        }
        start.elapsed().as_secs_f64() * 1e9 / samples
    });
    let solid = best_of(&mut || {
        let start = Instant::now();
        for (i, pt) in points.iter().enumerate() {
            let table = &tables[i].1;
            let (v, a) = solid_angle_tally(pt, &rects[i], n, &mut Rng::new(seed_of(i, n, 0, 1)), |j, y| {
                black_box(y);
                table[j]
            });
            black_box(v / a);
        }
        start.elapsed().as_secs_f64() * 1e9 / samples
    });
    let rects32: Vec<SphericalRectF32> = rects.iter().map(SphericalRectF32::of).collect();
    let solid32 = best_of(&mut || {
        let start = Instant::now();
        for (i, pt) in points.iter().enumerate() {
            let table = &tables[i].1;
            let (v, a) =
                solid_angle_tally_f32(pt, &rects32[i], n, &mut Rng::new(seed_of(i, n, 0, 1)), |j, y| {
                    black_box(y);
                    table[j]
                });
            black_box(v / a);
        }
        start.elapsed().as_secs_f64() * 1e9 / samples
    });
    let reps = 200;
    let per_point = (points.len() * reps) as f64;
    let g_total = best_of(&mut || {
        let start = Instant::now();
        for _ in 0..reps {
            for pt in points {
                black_box(lambert(&black_box(pt.light).corners(), black_box(pt.p), pt.n));
            }
        }
        start.elapsed().as_secs_f64() * 1e9 / per_point
    });
    let setup = best_of(&mut || {
        let start = Instant::now();
        for _ in 0..reps {
            for pt in points {
                black_box(SphericalRect::of(black_box(pt)));
            }
        }
        start.elapsed().as_secs_f64() * 1e9 / per_point
    });
    ([area, weighed, solid, solid32], g_total, setup)
}
