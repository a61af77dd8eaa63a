//! Where each method's shadow cost goes: one profiled render of each family's best setting
//! gives the cost heat map and the split of its shadow cost into prepare, table lookups,
//! traced rays, shaft tests and the rest.
//!
//! The split: per pixel, the shading time is fitted by least squares as
//! `a + b rays + c shafts + d lookups` (coefficients kept non-negative: a negative one is
//! dropped and the rest refitted). The fitted per-unit costs times the image's counts are
//! each kind's share of the pixels' shading time; the shadow cost less its prepare is split
//! in those proportions, and what the counts do not explain (shading, per-point overhead)
//! is "the rest". Timing each ray instead would cost about as much as a short ray.

use super::sweep::Setting;
use renderer::util::pixel_cost::PixelCost;
use renderer::{RenderSettings, Scene, render};

/// A method's shadow cost split (seconds, summing to the shadow cost).
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct CostSplit {
    pub prepare: f64,
    pub lookups: f64,
    pub rays: f64,
    pub shafts: f64,
    pub rest: f64,
}

impl CostSplit {
    /// The parts in drawing order, named.
    pub fn parts(&self) -> [(&'static str, f64); 5] {
        [
            ("prepare", self.prepare),
            ("table lookups", self.lookups),
            ("traced rays", self.rays),
            ("shaft tests", self.shafts),
            ("the rest", self.rest),
        ]
    }
}

/// One profiled render of `setting`: its per-pixel costs.
pub(super) fn profiled(
    scene: &Scene,
    setting: &Setting,
    settings: &RenderSettings,
) -> Result<Vec<PixelCost>, String> {
    let settings = RenderSettings { profile: true, ..*settings };
    let mut methods: Vec<_> = scene.lights.iter().map(|_| setting.method.build(setting.samples)).collect();
    let frame = render(scene, &mut methods, &settings, &|_| {}).map_err(|e| e.to_string())?;
    Ok(frame.costs.expect("profiled"))
}

/// Splits `shadow_cost` (of which `prepare` is the prepare) by the fit over `costs`,
/// measured with `threads` threads (the pixels' times add up over threads: their sum over
/// `threads` is wall time).
pub fn split(costs: &[PixelCost], shadow_cost: f64, prepare: f64, threads: usize) -> CostSplit {
    let prepare = prepare.clamp(0.0, shadow_cost.max(0.0));
    let shading = (shadow_cost - prepare).max(0.0);
    let unit = fit(costs);
    let work = renderer::util::pixel_cost::totals(costs).1;
    let wall = 1.0 / threads.max(1) as f64;
    let mut parts = [unit[1] * work.rays as f64, unit[2] * work.shafts as f64, unit[3] * work.lookups as f64]
        .map(|e| e * wall);
    // The fit is an estimate: parts that exceed the measured cost are scaled down to it.
    let sum: f64 = parts.iter().sum();
    if sum > shading && sum > 0.0 {
        parts = parts.map(|p| p * shading / sum);
    }
    let [rays, shafts, lookups] = parts;
    CostSplit { prepare, lookups, rays, shafts, rest: (shading - rays - shafts - lookups).max(0.0) }
}

/// Least-squares per-unit costs [intercept, per ray, per shaft, per lookup] of the pixels'
/// time, non-negative; a count that never varies (a method with no lookups) costs 0.
pub fn fit(costs: &[PixelCost]) -> [f64; 4] {
    let x = |c: &PixelCost| [1.0, c.work.rays as f64, c.work.shafts as f64, c.work.lookups as f64];
    // A count that never varies over the pixels (a method with no lookups, or none of its
    // queries testing a shaft) is confounded with the intercept: it costs 0.
    let mut active = [true; 4];
    for (k, on) in active.iter_mut().enumerate().skip(1) {
        let first = costs.first().map_or(0.0, |c| x(c)[k]);
        *on = costs.iter().any(|c| x(c)[k] != first);
    }
    for _ in 0..4 {
        // Normal equations over the active columns.
        let idx: Vec<usize> = (0..4).filter(|&k| active[k]).collect();
        let n = idx.len();
        let (mut a, mut b) = (vec![vec![0.0f64; n]; n], vec![0.0f64; n]);
        for c in costs {
            let row = x(c);
            for (i, &ki) in idx.iter().enumerate() {
                b[i] += row[ki] * c.time_s as f64;
                for (j, &kj) in idx.iter().enumerate() {
                    a[i][j] += row[ki] * row[kj];
                }
            }
        }
        let Some(sol) = solve(a, b) else {
            // Singular all the same (counts proportional to each other): drop the last count
            // still active.
            match idx.iter().rev().find(|&&k| k > 0) {
                Some(&k) => {
                    active[k] = false;
                    continue;
                }
                None => return [0.0; 4],
            }
        };
        let mut coef = [0.0; 4];
        for (i, &k) in idx.iter().enumerate() {
            coef[k] = sol[i];
        }
        match (1..4).find(|&k| active[k] && coef[k] < 0.0) {
            Some(k) => active[k] = false,
            None => return coef.map(|c| c.max(0.0)),
        }
    }
    [0.0; 4]
}

/// Gaussian elimination with partial pivoting; None when singular.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..n {
        let pivot = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() <= 1e-12 * scale {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        let (top, below) = a.split_at_mut(col + 1);
        let pivot_row = &top[col];
        for (i, r) in below.iter_mut().enumerate() {
            let f = r[col] / pivot_row[col];
            for (x, p) in r[col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            b[col + 1 + i] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|k| a[i][k] * x[k]).sum();
        x[i] = (b[i] - s) / a[i][i];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use renderer::util::pixel_cost::Work;

    fn pixel(time_s: f32, rays: u64, shafts: u64, lookups: u64) -> PixelCost {
        PixelCost { time_s, work: Work { rays, shafts, lookups, fallbacks: 0 } }
    }

    #[test]
    fn the_fit_recovers_known_unit_costs_and_the_split_adds_up() {
        // 1 µs per pixel, 100 ns per ray, 300 ns per shaft, 10 ns per lookup.
        let costs: Vec<PixelCost> = (0..200u64)
            .map(|i| {
                let (r, s, l) = (i % 17, (i / 3) % 5, (i * 7) % 50);
                pixel((1e-6 + 1e-7 * r as f64 + 3e-7 * s as f64 + 1e-8 * l as f64) as f32, r, s, l)
            })
            .collect();
        let c = fit(&costs);
        for (got, want) in c.iter().zip([1e-6, 1e-7, 3e-7, 1e-8]) {
            assert!((got - want).abs() < 1e-3 * want, "{c:?}");
        }
        let s = split(&costs, 1.0, 0.25, 1);
        let sum: f64 = s.parts().iter().map(|p| p.1).sum();
        assert!((sum - 1.0).abs() < 1e-9, "{s:?}");
        assert!(s.rays > 0.0 && s.shafts > 0.0 && s.lookups > 0.0 && s.rest > 0.0, "{s:?}");
    }

    #[test]
    fn lookups_are_fitted_when_rays_and_shafts_are_all_zero() {
        // pcss: no rays, no shafts, 10 ns per lookup.
        let costs: Vec<PixelCost> =
            (0..100u64).map(|i| pixel((1e-6 + 1e-8 * (i % 37) as f64) as f32, 0, 0, i % 37)).collect();
        let c = fit(&costs);
        assert!((c[3] - 1e-8).abs() < 1e-3 * 1e-8, "{c:?}");
        assert_eq!((c[1], c[2]), (0.0, 0.0));
    }

    #[test]
    fn a_count_that_never_varies_costs_nothing() {
        // No lookups anywhere (traced): the fit drops that column.
        let costs: Vec<PixelCost> =
            (0..50u64).map(|i| pixel((1e-6 + 1e-7 * i as f64) as f32, i, 0, 0)).collect();
        let c = fit(&costs);
        assert_eq!(c[3], 0.0);
        assert_eq!(c[2], 0.0);
        assert!((c[1] - 1e-7).abs() < 1e-3 * 1e-7, "{c:?}");
        let s = split(&costs, 0.5, 0.0, 2);
        assert_eq!(s.lookups, 0.0);
    }
}
