//! Fits penumbra's LTC table for the glTF specular lobe `D·V·cos` (F = 1) and writes it to
//! `renderer/src/shading/ltc_table.bin` (six little-endian f32 a node; the fit's quality, on
//! stderr, goes into the header of `ltc_table.rs` by hand):
//!
//! ```text
//! cargo run --release -p renderer --example fit_ltc
//! cargo run --release -p renderer --example fit_ltc -- --probe 8   # every 8th row, stats only
//! cargo run --release -p renderer --example fit_ltc -- --tv-map FILE # also each node's TV and M
//! cargo run --release -p renderer --example fit_ltc -- --exponent K  # minimise ∫|Δp|^K instead
//! ```
//!
//! Per node of the grid of `renderer::shading::ltc` (roughness row i, view column j), an
//! isotropic matrix `M = [[a, 0, b], [0, c, 0], [d, 0, 1]]` (four free terms: a scale does not
//! change the distribution) is fitted by Nelder–Mead, warm-started from the neighbouring node,
//! minimising the L1 distance `∫ |p_ltc − p_brdf| dω` over the sphere between the LTC density
//! and the normalised lobe `D·V·cos / norm` (zero below the surface, so LTC mass leaking under
//! it counts as error). L1 because it bounds what the renderer sees: for any region A,
//! `|∫_A p_ltc − ∫_A p_brdf| <= L1/2` (the total variation distance, reported as TV).
//!
//! The integral is estimated with fixed stratified directions from both distributions,
//! combined by the balance heuristic: `Σ e(ω)/(q_brdf(ω) + q_ltc(ω)) / n²` over n² directions
//! drawn from each, q_brdf the GGX half-vector density carried to ω, q_ltc the LTC itself. The
//! directions move smoothly with M, so the objective is deterministic and continuous.
//!
//! Order: the view-normal column from roughness 1 down (start: the clamped cosine), then each
//! roughness row from the normal out to grazing, rows in parallel. `norm` and `fresnel` come
//! from `quadrature::specular_moments` (f64). Progress and the fit's measured quality go to
//! stderr and into the generated file's header.

use glam::{DMat3, DVec3};
use rayon::prelude::*;
use renderer::shading::ltc::{LTC_SIZE, LtcLobe, ltc_grid_cos_theta, ltc_grid_roughness};
use renderer::shading::quadrature::{ggx_d_f64, smith_visibility_f64, specular_moments};
use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Stratified directions per axis and per distribution in the fit's objective.
const FIT_SAMPLES: usize = 24;
/// The same for the TV measured after the fit (a finer, independent estimate).
const TV_SAMPLES: usize = 128;
/// Rings and nodes per ring of the quadrature of `norm` and `fresnel`.
const MOMENT_NODES: usize = 384;

/// The normalised target lobe at one node, with its fixed stratified directions.
struct Target {
    alpha: f64,
    wo: DVec3,
    norm: f64,
    /// (ω, p_brdf(ω), q_brdf(ω)) for the directions drawn from the lobe's half vectors.
    fixed: Vec<(DVec3, f64, f64)>,
}

impl Target {
    fn new(alpha: f64, cos_v: f64, norm: f64, n: usize) -> Self {
        let wo = DVec3::new((1.0 - cos_v * cos_v).sqrt(), 0.0, cos_v);
        let mut t = Target { alpha, wo, norm, fixed: Vec::with_capacity(n * n) };
        for (u1, u2) in grid(n) {
            let w = t.reflect_sample(u1, u2);
            t.fixed.push((w, t.p_brdf(w), t.q_brdf(w)));
        }
        t
    }

    /// Reflects `wo` about a half vector drawn from D(h)·cosθ_h (tan²θ_h = α² u/(1 − u)).
    fn reflect_sample(&self, u1: f64, u2: f64) -> DVec3 {
        let tan2 = self.alpha * self.alpha * u1 / (1.0 - u1);
        let cos_h = 1.0 / (1.0 + tan2).sqrt();
        let sin_h = (tan2 / (1.0 + tan2)).sqrt();
        let phi = TAU * u2;
        let h = DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
        2.0 * self.wo.dot(h) * h - self.wo
    }

    /// `D·V·cos / norm`, zero below the surface.
    fn p_brdf(&self, w: DVec3) -> f64 {
        if w.z <= 0.0 {
            return 0.0;
        }
        let h = (self.wo + w).normalize();
        ggx_d_f64(self.alpha, h.z) * smith_visibility_f64(self.alpha, w.z, self.wo.z) * w.z / self.norm
    }

    /// The density of [`Target::reflect_sample`]'s directions: D(h)·cosθ_h / (4 wo·h).
    fn q_brdf(&self, w: DVec3) -> f64 {
        let sum = self.wo + w;
        if sum.length_squared() < 1e-24 {
            return 0.0;
        }
        let h = sum.normalize();
        let wo_h = self.wo.dot(h);
        if h.z <= 0.0 || wo_h <= 0.0 {
            return 0.0;
        }
        ggx_d_f64(self.alpha, h.z) * h.z / (4.0 * wo_h)
    }

    /// `∫ |p_ltc − p_brdf|^k dω`, estimated as the module doc says, with the target's fixed
    /// directions and `cosines` (stratified clamped-cosine directions) carried by M.
    fn distance(&self, p: &[f64; 4], cosines: &[DVec3], k: f64) -> f64 {
        let m = matrix(p);
        let det = m.determinant();
        if !det.is_finite() || det.abs() < 1e-14 {
            return f64::INFINITY;
        }
        let lobe = LtcLobe { minv: m.inverse(), norm: 1.0, fresnel: 0.0 };
        let mut sum = 0.0;
        for &(w, p_b, q_b) in &self.fixed {
            let p_l = lobe.density(w);
            sum += term(p_l, p_b, q_b + p_l, k);
        }
        for &c in cosines {
            let w = (m * c).normalize();
            let p_l = lobe.density(w);
            sum += term(p_l, self.p_brdf(w), self.q_brdf(w) + p_l, k);
        }
        sum / self.fixed.len() as f64
    }
}

fn term(p_l: f64, p_b: f64, q: f64, k: f64) -> f64 {
    if q > 0.0 { (p_l - p_b).abs().powf(k) / q } else { 0.0 }
}

/// M from the four free terms.
fn matrix(p: &[f64; 4]) -> DMat3 {
    DMat3::from_cols(DVec3::new(p[0], 0.0, p[3]), DVec3::new(0.0, p[2], 0.0), DVec3::new(p[1], 0.0, 1.0))
}

/// Midpoints of an n × n grid on [0, 1)².
fn grid(n: usize) -> impl Iterator<Item = (f64, f64)> {
    (0..n * n).map(move |k| (((k / n) as f64 + 0.5) / n as f64, ((k % n) as f64 + 0.5) / n as f64))
}

/// Clamped-cosine directions on the midpoints of an n × n grid.
fn cosine_directions(n: usize) -> Vec<DVec3> {
    grid(n)
        .map(|(u1, u2)| {
            let (r, phi) = (u1.sqrt(), TAU * u2);
            DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).sqrt())
        })
        .collect()
}

/// Nelder–Mead on four parameters (reflection 1, expansion 2, contraction ½, shrink ½), until
/// the simplex's values agree to `1e-6` relative (the objective's own sampling error is larger) or `max_evals` evaluations.
fn nelder_mead(
    f: &dyn Fn(&[f64; 4]) -> f64,
    x0: [f64; 4],
    step: [f64; 4],
    max_evals: usize,
) -> ([f64; 4], f64) {
    let mut simplex: Vec<([f64; 4], f64)> = (0..5)
        .map(|k| {
            let mut x = x0;
            if k > 0 {
                x[k - 1] += step[k - 1];
            }
            (x, f(&x))
        })
        .collect();
    let mut evals = 5;
    let lerp = |a: &[f64; 4], b: &[f64; 4], t: f64| -> [f64; 4] {
        std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t)
    };
    while evals < max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[4].1);
        if worst - best <= 1e-6 * best.abs() + 1e-300 {
            break;
        }
        let centroid: [f64; 4] =
            std::array::from_fn(|i| simplex[..4].iter().map(|s| s.0[i]).sum::<f64>() / 4.0);
        let reflected = lerp(&centroid, &simplex[4].0, -1.0);
        let fr = f(&reflected);
        evals += 1;
        if fr < best {
            let expanded = lerp(&centroid, &simplex[4].0, -2.0);
            let fe = f(&expanded);
            evals += 1;
            simplex[4] = if fe < fr { (expanded, fe) } else { (reflected, fr) };
        } else if fr < simplex[3].1 {
            simplex[4] = (reflected, fr);
        } else {
            let contracted = if fr < worst {
                lerp(&centroid, &reflected, 0.5)
            } else {
                lerp(&centroid, &simplex[4].0, 0.5)
            };
            let fc = f(&contracted);
            evals += 1;
            if fc < fr.min(worst) {
                simplex[4] = (contracted, fc);
            } else {
                let x0 = simplex[0].0;
                for s in simplex.iter_mut().skip(1) {
                    s.0 = lerp(&x0, &s.0, 0.5);
                    s.1 = f(&s.0);
                }
                evals += 4;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    EVALUATIONS.fetch_add(evals, Ordering::Relaxed);
    simplex[0]
}

/// Objective evaluations over the whole fit, for the header.
static EVALUATIONS: AtomicUsize = AtomicUsize::new(0);

/// One node's result.
#[derive(Clone, Copy)]
struct Node {
    params: [f64; 4],
    norm: f64,
    fresnel: f64,
    tv: f64,
}

/// Fits one node from `start`: Nelder–Mead, restarted once from its best point with a fresh
/// simplex if the first run improved the distance by more than 0.1% (a simplex that travelled
/// far has often collapsed before the minimum).
fn fit_node(i: usize, j: usize, start: [f64; 4], cosines: &[DVec3], k: f64) -> Node {
    let r = ltc_grid_roughness(i);
    let cos_v = ltc_grid_cos_theta(j);
    let (norm, fresnel) = specular_moments(r * r, cos_v, MOMENT_NODES);
    let target = Target::new(r * r, cos_v, norm, FIT_SAMPLES);
    let f = |p: &[f64; 4]| target.distance(p, cosines, k);
    let (mut x, mut fx) = (start, f(&start));
    for _ in 0..2 {
        let scale = x[0].abs().min(x[2].abs()).max(1e-6);
        let step =
            [0.1 * x[0].abs(), 0.1 * x[1].abs().max(scale), 0.1 * x[2].abs(), 0.1 * x[3].abs().max(scale)];
        let (y, fy) = nelder_mead(&f, x, step, 1500);
        let gain = fx - fy;
        if fy < fx {
            (x, fx) = (y, fy);
        }
        if gain <= 1e-3 * fx {
            break;
        }
    }
    // The clamped cosine is symmetric under x → −x and y → −y: whichever mirror image the
    // search ended on, keep the xz block's determinant a − b·d and c positive, so that minv
    // keeps the orientation (edge terms keep their sign).
    if x[0] - x[1] * x[3] < 0.0 {
        (x[0], x[3]) = (-x[0], -x[3]);
    }
    x[2] = x[2].abs();
    let tv_target = Target::new(r * r, cos_v, norm, TV_SAMPLES);
    let tv = 0.5 * tv_target.distance(&x, &cosine_directions(TV_SAMPLES), 1.0);
    Node { params: x, norm, fresnel, tv }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|p| args.get(p + 1));
    let probe: Option<usize> = flag("--probe").map(|v| v.parse().expect("--probe takes a row stride"));
    let k: f64 = flag("--exponent").map_or(1.0, |v| v.parse().expect("--exponent takes a number"));
    let start = Instant::now();
    let cosines = cosine_directions(FIT_SAMPLES);

    // The view-normal column, from roughness 1 (close to the clamped cosine) down.
    let mut column = vec![[1.0, 0.0, 1.0, 0.0]; LTC_SIZE];
    let mut seed = [1.0, 0.0, 1.0, 0.0];
    for i in (0..LTC_SIZE).rev() {
        seed = fit_node(i, 0, seed, &cosines, k).params;
        column[i] = seed;
    }
    let rows: Vec<usize> =
        (0..LTC_SIZE).filter(|i| probe.is_none_or(|s| i % s == 0 || *i == LTC_SIZE - 1)).collect();
    let fitted: Vec<Vec<Node>> = rows
        .par_iter()
        .map(|&i| {
            let mut row = Vec::with_capacity(LTC_SIZE);
            let mut seed = column[i];
            for j in 0..LTC_SIZE {
                let node = fit_node(i, j, seed, &cosines, k);
                seed = node.params;
                row.push(node);
            }
            eprintln!(
                "row {i:2} (roughness {:.4}) max TV {:.4}",
                ltc_grid_roughness(i),
                max_tv(&row, 0..LTC_SIZE)
            );
            row
        })
        .collect();
    let seconds = start.elapsed().as_secs_f64();
    if let Some(path) = flag("--tv-map") {
        // Per node: row, column, roughness, view angle, TV, the four terms of M.
        let mut out = String::new();
        for (&i, row) in rows.iter().zip(&fitted) {
            for (j, n) in row.iter().enumerate() {
                let deg = ltc_grid_cos_theta(j).acos().to_degrees();
                let p = n.params;
                let _ = writeln!(
                    out,
                    "{i} {j} {:.4} {deg:.2} {:.5} {} {} {} {}",
                    ltc_grid_roughness(i),
                    n.tv,
                    p[0],
                    p[1],
                    p[2],
                    p[3]
                );
            }
        }
        std::fs::write(path, out).expect("cannot write the --tv-map file");
    }
    let summary = quality_summary(&rows, &fitted, seconds, k);
    eprint!("{summary}");
    if probe.is_none() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/shading/ltc_table.bin");
        std::fs::write(path, table_bytes(&fitted)).expect("cannot write the table");
        eprintln!("wrote {path}");
    }
}

fn max_tv(row: &[Node], cols: std::ops::Range<usize>) -> f64 {
    row[cols].iter().map(|n| n.tv).fold(0.0, f64::max)
}

/// The fit's quality by roughness band and view angle band, as comment lines.
fn quality_summary(rows: &[usize], fitted: &[Vec<Node>], seconds: f64, k: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "// Fitted in {seconds:.0} s (wall, {} threads), L{k} objective, {} evaluations of it.",
        rayon::current_num_threads(),
        EVALUATIONS.load(Ordering::Relaxed)
    );
    let _ = writeln!(s, "// Total variation distance between the LTC and the normalised lobe, max per band:");
    let _ = writeln!(s, "//   roughness          | view <= 60 deg | 60-80 deg | 80-85 deg | > 85 deg");
    let bands = [(0.0, 0.05), (0.05, 0.1), (0.1, 0.2), (0.2, 0.4), (0.4, 0.7), (0.7, 1.01)];
    let cols = |lo: f64, hi: f64| {
        let range: Vec<usize> = (0..LTC_SIZE)
            .filter(|&j| {
                let deg = ltc_grid_cos_theta(j).acos().to_degrees();
                deg >= lo && deg < hi
            })
            .collect();
        range[0]..range[range.len() - 1] + 1
    };
    let view_bands = [cols(0.0, 60.01), cols(60.01, 80.01), cols(80.01, 85.01), cols(85.01, 91.0)];
    for (lo, hi) in bands {
        let in_band: Vec<&Vec<Node>> = rows
            .iter()
            .zip(fitted)
            .filter(|(i, _)| (lo..hi).contains(&ltc_grid_roughness(**i)))
            .map(|p| p.1)
            .collect();
        if in_band.is_empty() {
            continue;
        }
        let _ = write!(s, "//   [{lo:.2}, {:.2})       ", hi.min(1.0));
        for vb in &view_bands {
            let m = in_band.iter().map(|row| max_tv(row, vb.clone())).fold(0.0, f64::max);
            let _ = write!(s, " | {m:.4}");
        }
        let _ = writeln!(s);
    }
    s
}

/// The table's bytes: per node (roughness row, then view column) `[m00, m02, m20, m22, norm,
/// fresnel]` as little-endian f32, minv scaled to m11 = 1.
fn table_bytes(fitted: &[Vec<Node>]) -> Vec<u8> {
    let mut out = Vec::new();
    for row in fitted {
        for n in row {
            let minv = matrix(&n.params).inverse();
            let minv = minv / minv.y_axis.y;
            let e = [minv.x_axis.x, minv.z_axis.x, minv.x_axis.z, minv.z_axis.z, n.norm, n.fresnel];
            assert!(e.iter().all(|v| v.is_finite()), "non-finite table entry {e:?}");
            for v in e {
                out.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
    }
    out
}
