//! Which estimator of the shadow term V = int v g dA / int g dA (g = cos_x cos_y / r^2) gives
//! the lowest error per cost, measured on an analytic scene (no renderer): a 1 x 1 m square
//! light facing down at height H above a floor (normal +Y), an opaque rectangular card
//! parallel to the floor at H/3, floor points across the penumbra (0.02 < V < 0.98). The
//! exact V is Lambert's polygon formula on the blocked polygon (the card's central projection
//! onto the light's plane, clipped to the light) against the whole light.
//!
//! Estimators, N stratified jittered samples each (an nx x ny grid):
//!  1. `area`: uniform over the light, the unweighted fraction visible (the old term; biased);
//!  2. `ratio`: the same samples, sum v g / sum g;
//!  3. `norm`: the same samples, the smaller set weighed against the exact G = int g dA
//!     (`renderer::methods::irradiance_share`): 1 - a sum_blocked g / G or a sum_visible g / G;
//!  4. `solid`: the spherical rectangle sampled by solid angle (Urena, Fajardo and King 2013),
//!     strata in its unit square, each sample weighted by cos_x: sum v cos_x / sum cos_x.
//!
//! Prints the RMSE and bias per height and N (64 seeds per point), the cost of the sampling
//! and weighting per sample (the verdicts read from a table, not traced), and the self-checks
//! of the exact V and of the sampler. Results: `docs/notes/2026-11-28-visibility-estimators.md`.
//!
//! ```sh
//! cargo run --release --example visibility_estimators
//! ```

mod accuracy;
mod checks;
mod cost;
mod estimators;
mod rng;
mod scene;
mod spherical_rect;

use accuracy::{Errors, all_errors, summarise};
use checks::self_checks;
use cost::costs;
use glam::{DVec2, DVec3};
use scene::{Card, Light, Point};
use std::time::Instant;

const HEIGHTS: [f64; 5] = [0.3, 0.6, 1.0, 2.0, 5.0];
const SAMPLES: [u32; 5] = [16, 64, 256, 1024, 4096];
const SEEDS: u64 = 64;
const NAMES: [&str; 4] = ["1 area", "2 ratio", "3 norm", "4 solid"];
/// The penumbra: points whose exact V lies strictly between these.
const PENUMBRA: (f64, f64) = (0.02, 0.98);
/// Floor points: a grid of this spacing over [-1.2, 1.2]^2, offset so that no card edge's
/// shadow lines up with the strata.
const GRID_STEP: f64 = 0.1;
const GRID_OFFSET: DVec2 = DVec2::new(0.0137, 0.0291);

fn main() {
    let start = Instant::now();
    // Two cards (heights set per H): one with its edges along the light's, one turned 30
    // degrees; both cast an umbra under the light's middle.
    let cards = [
        Card::new(DVec2::new(0.1, 0.05), DVec2::new(0.2, 0.2), 0.0, 0.0),
        Card::new(DVec2::new(-0.05, 0.1), DVec2::new(0.25, 0.15), 30.0, 0.0),
    ];
    self_checks(&cards);

    println!(
        "## Accuracy\n\n{SEEDS} seeds per point. RMSE: per point over the seeds, then the mean over the \
         penumbra points ({} < V < {}). Bias: the RMS over points of each point's bias, the seeds' noise \
         taken out (0: none above the noise; resolves about 0.07 x RMSE).\n",
        PENUMBRA.0, PENUMBRA.1
    );
    let steps = (2.4 / GRID_STEP).round() as i32;
    // Per height: every point's errors and its card.
    let mut per_height: Vec<Vec<([Errors; SAMPLES.len()], usize)>> = Vec::new();
    let mut timing_points = Vec::new();
    for (hi, &h) in HEIGHTS.iter().enumerate() {
        let light = Light::at(h);
        let (mut points, mut card_of) = (Vec::new(), Vec::new());
        for (ci, card) in cards.iter().enumerate() {
            let card = Card { height: h / 3.0, ..*card };
            for j in 0..=steps {
                for i in 0..=steps {
                    let q = DVec2::new(i as f64, j as f64) * GRID_STEP - 1.2 + GRID_OFFSET;
                    let pt = Point::new(DVec3::new(q.x, 0.0, q.y), light, card);
                    if pt.v_exact > PENUMBRA.0 && pt.v_exact < PENUMBRA.1 {
                        points.push(pt);
                        card_of.push(ci);
                    }
                }
            }
        }
        let errors = all_errors(&points, hi << 20);
        let (sum_ab, max_ab) = points
            .iter()
            .map(|p| p.area_exact - p.v_exact)
            .fold((0.0, 0.0f64), |(s, m), b| (s + b.abs(), m.max(b.abs())));
        println!(
            "### H = {h}: {} points ({} and {} of the two cards); area fraction - V, exact: mean |.| {:.4}, max {:.4}\n",
            points.len(),
            card_of.iter().filter(|&&c| c == 0).count(),
            card_of.iter().filter(|&&c| c == 1).count(),
            sum_ab / points.len() as f64,
            max_ab
        );
        println!("| N | RMSE {} | bias {} |", NAMES.join(" | RMSE "), NAMES.join(" | bias "));
        println!("|---|{}", "---|".repeat(8));
        for (ni, &n) in SAMPLES.iter().enumerate() {
            let s = summarise(errors.iter(), ni);
            let f = |x: &[f64; 4]| x.iter().map(|v| format!("{v:.5}")).collect::<Vec<_>>().join(" | ");
            println!("| {n} | {} | {} |", f(&s.rmse), f(&s.bias));
        }
        println!();
        per_height.push(errors.into_iter().zip(card_of).collect());
        if hi == 2 {
            timing_points = points;
        }
    }
    let all = || per_height.iter().flatten();
    let rmse = |hi: Option<usize>, card: Option<usize>, ni: usize| {
        let pick = move |(_, c): &&([Errors; SAMPLES.len()], usize)| card.is_none_or(|k| *c == k);
        match hi {
            Some(hi) => summarise(per_height[hi].iter().filter(pick).map(|(e, _)| e), ni).rmse,
            None => summarise(all().filter(pick).map(|(e, _)| e), ni).rmse,
        }
    };

    println!("## Convergence and ratios\n");
    println!("Slope of log RMSE against log N (least squares over the five N), per height:\n");
    println!("| H | {} |", NAMES.join(" | "));
    println!("|---|{}", "---|".repeat(4));
    let xs: Vec<f64> = SAMPLES.iter().map(|&n| (n as f64).ln()).collect();
    let mx = xs.iter().sum::<f64>() / xs.len() as f64;
    for (hi, &h) in HEIGHTS.iter().enumerate() {
        let rows: Vec<[f64; 4]> = (0..SAMPLES.len()).map(|ni| rmse(Some(hi), None, ni)).collect();
        let slopes: Vec<String> = (0..4)
            .map(|k| {
                let ys: Vec<f64> = rows.iter().map(|r| r[k].ln()).collect();
                let my = ys.iter().sum::<f64>() / ys.len() as f64;
                let cov: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
                let var: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
                format!("{:.2}", cov / var)
            })
            .collect();
        println!("| {h} | {} |", slopes.join(" | "));
    }
    println!(
        "\nRMSE relative to estimator 2 (ratio) at the same N (N = 16 / 256 / 4096), per height and card \
         (A: edges along the light's, B: turned 30 degrees):\n"
    );
    println!("| H | 3 / 2, both cards | 4 / 2, both cards | 4 / 2, card A | 4 / 2, card B |");
    println!("|---|---|---|---|---|");
    for (hi, &h) in HEIGHTS.iter().chain([f64::NAN].iter()).enumerate() {
        let hi = (hi < HEIGHTS.len()).then_some(hi);
        let r = |k: usize, card: Option<usize>| {
            [0, 2, 4]
                .iter()
                .map(|&ni| {
                    let e = rmse(hi, card, ni);
                    format!("{:.2}", e[k] / e[1])
                })
                .collect::<Vec<_>>()
                .join(" / ")
        };
        let label = if hi.is_some() { format!("{h}") } else { "all".to_string() };
        println!("| {label} | {} | {} | {} | {} |", r(2, None), r(3, None), r(3, Some(0)), r(3, Some(1)));
    }

    println!("\n## Cost\n");
    let n = 1024;
    let (per_sample, g_total, setup) = costs(&timing_points, n);
    println!(
        "Sampling and weighting alone (the verdicts read from a table), one thread, N = {n}, the {} points \
         at H = 1, best of 7 runs. Estimators 2 and 3 weigh every sample (as `traced` does); 3 also \
         needs G per point, 4 the spherical rectangle's set-up:\n",
        timing_points.len()
    );
    println!("| estimator | ns / sample | more than 1 | per point | per sample at N = 16 / 1024 |");
    println!("|---|---|---|---|---|");
    println!("| 1 area | {:.2} | 0 | - | - |", per_sample[0]);
    println!("| 2 ratio | {:.2} | {:.2} | - | - |", per_sample[1], per_sample[1] - per_sample[0]);
    let per_point =
        |name: &str, ns: f64| format!("{name}: {ns:.0} ns | {:.2} / {:.3}", ns / 16.0, ns / 1024.0);
    println!(
        "| 3 norm | {:.2} | {:.2} | {} |",
        per_sample[1],
        per_sample[1] - per_sample[0],
        per_point("G", g_total)
    );
    for (name, t) in [("4 solid (f64 map)", per_sample[2]), ("4 solid (f32 map)", per_sample[3])] {
        println!("| {name} | {t:.2} | {:.2} | {} |", t - per_sample[0], per_point("set-up", setup));
    }

    println!(
        "\nCost to reach estimator 2's RMSE, relative to 2 (below 1: cheaper), at N = 64 and {n}: \
         (RMSE_k / RMSE_2)^(1 / 0.75) x (ray + c_k) / (ray + c_2), with RMSE falling as N^-0.75 (the \
         slopes above) and c the sampling and weighting per sample plus the per-point work / N; a \
         shadow ray of 100 / 300 ns; the last column with the sampling free (the limit of a slow ray):\n"
    );
    println!("| H | N | 3 norm | 4 solid, f64 map | 4 solid, f32 map | 3, 4 with sampling free |");
    println!("|---|---|---|---|---|---|");
    for (hi, &h) in HEIGHTS.iter().chain([f64::NAN].iter()).enumerate() {
        let hi = (hi < HEIGHTS.len()).then_some(hi);
        let label = if hi.is_some() { format!("{h}") } else { "all".to_string() };
        for n in [64, n] {
            let ni = SAMPLES.iter().position(|&s| s == n).expect("a measured N");
            // The cost of a sample besides its ray: sampling, weighting, its share of the point's work.
            let cost = [
                per_sample[1],
                per_sample[1] + g_total / n as f64,
                per_sample[2] + setup / n as f64,
                per_sample[3] + setup / n as f64,
            ];
            let e = rmse(hi, None, ni);
            let samples = |k: usize| (e[k] / e[1]).powf(1.0 / 0.75);
            let rel = |k: usize, c: f64| {
                [100.0, 300.0]
                    .iter()
                    .map(|&ray| format!("{:.2}", samples(k) * (ray + c) / (ray + cost[0])))
                    .collect::<Vec<_>>()
                    .join(" / ")
            };
            println!(
                "| {label} | {n} | {} | {} | {} | {:.2}, {:.2} |",
                rel(2, cost[1]),
                rel(3, cost[2]),
                rel(3, cost[3]),
                samples(2),
                samples(3)
            );
        }
    }
    println!("\n(total {:.1} s)", start.elapsed().as_secs_f64());
}
