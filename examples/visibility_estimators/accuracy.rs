//! Accuracy: every estimator's error against the exact V, over the seeds and the points.

use crate::estimators::{area_fraction, normalised, ratio, solid_angle_tally, uniform_tally};
use crate::rng::{Rng, mix64};
use crate::scene::Point;
use crate::spherical_rect::SphericalRect;
use crate::{SAMPLES, SEEDS};
use glam::Vec3;

/// Sums of the error and its square over the seeds, per estimator.
#[derive(Default, Clone, Copy)]
pub struct Errors {
    sum: [f64; 4],
    sum2: [f64; 4],
}

pub fn seed_of(point: usize, n: u32, seed: u64, stream: u64) -> u64 {
    mix64(point as u64 ^ mix64((n as u64) << 32 ^ seed << 8 ^ stream))
}

/// The errors of every estimator at one point, per N.
fn point_errors(index: usize, pt: &Point) -> [Errors; SAMPLES.len()] {
    let rect = SphericalRect::of(pt);
    let mut out = [Errors::default(); SAMPLES.len()];
    for (e, &n) in out.iter_mut().zip(SAMPLES.iter()) {
        for s in 0..SEEDS {
            let blocked = |_: usize, y: Vec3| pt.card.blocks(pt.p, y.as_dvec3());
            let t = uniform_tally::<true>(pt, n, &mut Rng::new(seed_of(index, n, s, 0)), blocked);
            let (sv, sa) = solid_angle_tally(pt, &rect, n, &mut Rng::new(seed_of(index, n, s, 1)), blocked);
            let est = [area_fraction(&t), ratio(&t), normalised(&t, 1.0 / n as f64, pt.g_total), sv / sa];
            for (k, v) in est.iter().enumerate() {
                let err = v - pt.v_exact;
                e.sum[k] += err;
                e.sum2[k] += err * err;
            }
        }
    }
    out
}

/// Every point's errors, over the available threads (each point's seeds are its own: the
/// result does not depend on the thread count).
pub fn all_errors(points: &[Point], base: usize) -> Vec<[Errors; SAMPLES.len()]> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = points.len().div_ceil(threads).max(1);
    std::thread::scope(|scope| {
        let handles: Vec<_> = points
            .chunks(chunk)
            .enumerate()
            .map(|(c, pts)| {
                scope.spawn(move || {
                    pts.iter()
                        .enumerate()
                        .map(|(i, pt)| point_errors(base + c * chunk + i, pt))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("a worker")).collect()
    })
}

/// Over a set of points at one N: the mean of the per-point RMSE, and the RMS over points of
/// the bias with the seeds' noise taken out: mean(bias_hat^2 - s^2 / m) estimates mean(bias^2)
/// without the noise's share (negative, shown as 0, where no bias shows above the noise).
pub struct Summary {
    pub rmse: [f64; 4],
    pub bias: [f64; 4],
}

pub fn summarise<'a>(errors: impl Iterator<Item = &'a [Errors; SAMPLES.len()]>, ni: usize) -> Summary {
    let mut s = Summary { rmse: [0.0; 4], bias: [0.0; 4] };
    let m = SEEDS as f64;
    let mut count = 0;
    for e in errors {
        count += 1;
        for k in 0..4 {
            let mean = e[ni].sum[k] / m;
            let var = (e[ni].sum2[k] - m * mean * mean) / (m - 1.0);
            s.rmse[k] += (e[ni].sum2[k] / m).sqrt();
            s.bias[k] += mean * mean - var / m;
        }
    }
    for k in 0..4 {
        s.rmse[k] /= count as f64;
        s.bias[k] = (s.bias[k] / count as f64).max(0.0).sqrt();
    }
    s
}
