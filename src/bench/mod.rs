//! `penumbra bench SCENE.toml...`: every shadow method and setting against the traced truth,
//! run time against error.
//!
//! Per scene: `none` (the cost floor, and which pixels each light reaches), the truth
//! (`traced` at `--truth-samples`, cached: [`truth`]), then the sweep ([`sweep`]): `traced`
//! at N = 16, 64, 256, 1024, `depth_march`, `edge_table` over depth-map sizes, grids, blend
//! modes and sample counts, and `pcss`. Every setting runs `--repeats` times; times are
//! medians, errors come from the first run (every run gives the same bytes). The shadow
//! cost of a run is `shadow_prepare + render - render(none)`, medians of each.
//!
//! Outputs, under `--out` (default `out/bench`): `results.csv` and `results.json` (every row),
//! per scene `<stem>/plot.png` (+ `.svg`: error against cost, log-log, a line per method,
//! the Pareto front ringed), `<stem>/truth.png`, and for each method its best setting's
//! image and error heat map; `index.html` with all of it; and a summary on stdout.
//! `--quick`: a tiny image, the truth at 256 samples, a short sweep, one repeat (for CI).

mod html;
pub mod metrics;
pub mod plot;
mod report;
mod run;
mod sweep;
pub mod truth;

pub use report::{Row, SceneResult, Speedup};
pub use sweep::{PLAIN_TRACED, Setting, sweep};

use crate::config::{MethodName, ShadowsConfig};
use glam::Vec3;
use renderer::output::StagedFiles;
use renderer::{Frame, RenderSettings, Scene, SceneError, SceneFile};
use report::equal_error_speedup;
use run::{median, run_setting};
use std::path::PathBuf;
use sweep::{cost_order, no_costlier};

/// `penumbra bench` options.
#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    /// Scene files (TOML).
    #[arg(required = true)]
    pub scenes: Vec<PathBuf>,
    /// Output folder. Default: out/bench (out/bench-quick with --quick, so that a quick run
    /// neither overwrites a full report nor evicts its cached truths).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Runs per setting (times are medians).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeats: u32,
    /// Light samples of the traced truth.
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub truth_samples: u32,
    /// Truth cache folder. Default: OUT/truth-cache.
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Image width; default: the scene's, scaled down to at most 320 (keeping its aspect).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: Option<u32>,
    /// Image height; default: the scene's, scaled like the width.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// A setting whose first run takes longer than this is not repeated, and `edge_table`
    /// settings at least as costly by construction (no smaller map, grid, blend or sample
    /// count) are then skipped and listed. Runs are not interrupted.
    #[arg(long, default_value_t = 10.0, value_parser = positive_seconds)]
    pub max_run_seconds: f64,
    /// CI mode: 64 pixels wide, truth at 256 samples, a short sweep, one repeat.
    #[arg(long)]
    pub quick: bool,
    /// No per-run progress lines on stderr.
    #[arg(long)]
    pub quiet: bool,
}

fn positive_seconds(v: &str) -> Result<f64, String> {
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("must be a finite number of seconds > 0, got {v:?}")),
    }
}

impl BenchArgs {
    /// The output folder.
    pub fn out_dir(&self) -> PathBuf {
        self.out
            .clone()
            .unwrap_or_else(|| PathBuf::from(if self.quick { "out/bench-quick" } else { "out/bench" }))
    }
}

/// The default bench image width (scenes are scaled down to it).
pub const BENCH_WIDTH: u32 = 320;
/// `--quick`'s image width and truth sample count.
pub const QUICK_WIDTH: u32 = 64;
pub const QUICK_TRUTH_SAMPLES: u32 = 256;

/// The bench's image size for a scene of `w` x `h`.
fn bench_size(args: &BenchArgs, w: u32, h: u32) -> (u32, u32) {
    let target = if args.quick { QUICK_WIDTH } else { BENCH_WIDTH };
    let scale = (target as f64 / w as f64).min(1.0);
    let dw = ((w as f64 * scale).round() as u32).max(1);
    let dh = ((h as f64 * scale).round() as u32).max(1);
    match (args.width, args.height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w2), None) => (w2, ((h as f64 * w2 as f64 / w as f64).round() as u32).max(1)),
        (None, Some(h2)) => (((w as f64 * h2 as f64 / h as f64).round() as u32).max(1), h2),
        (None, None) => (dw, dh),
    }
}

/// An error heat map: |ours - truth| of visibility (the largest over lights), black (0) to
/// red to yellow to white (>= 0.5); misses dark blue, pixels no light reaches dark grey.
fn heat_map(reach: &[Vec<f32>], truth: &[Vec<f32>], ours: &[Vec<f32>]) -> Vec<Vec3> {
    let n = truth.first().map_or(0, Vec::len);
    (0..n)
        .map(|i| {
            if truth[0][i] < 0.0 {
                return Vec3::new(0.0, 0.0, 0.05);
            }
            let mut err = -1.0f32;
            for k in 0..truth.len() {
                if reach[k][i] > 0.0 {
                    err = err.max((ours[k][i] - truth[k][i]).abs());
                }
            }
            if err < 0.0 {
                return Vec3::splat(0.01);
            }
            let t = (err / 0.5).clamp(0.0, 1.0) * 3.0;
            // Written as linear radiance: the power undoes the PNG's sRGB encoding, so the
            // ramp shows evenly.
            Vec3::new(t.min(1.0), (t - 1.0).clamp(0.0, 1.0), (t - 2.0).clamp(0.0, 1.0)).powf(2.2)
        })
        .collect()
}

fn family(m: MethodName) -> &'static str {
    m.as_str()
}

/// Runs the bench. Progress lines go to stderr unless `--quiet`; the summary is returned.
pub fn run_bench(args: &BenchArgs) -> Result<String, SceneError> {
    let out = args.out_dir();
    let (threads, pool) = crate::thread_pool(args.threads, &out)?;
    let repeats = if args.quick { 1 } else { args.repeats };
    let truth_samples =
        if args.quick { QUICK_TRUTH_SAMPLES.min(args.truth_samples) } else { args.truth_samples };
    let cache = args.cache.clone().unwrap_or_else(|| out.join("truth-cache"));
    let settings_list = sweep(args.quick);
    let log = |s: String| {
        if !args.quiet {
            eprintln!("{s}");
        }
    };

    // Check every scene file before the long part.
    let mut files = Vec::new();
    for path in &args.scenes {
        let file = SceneFile::load(path)?;
        crate::config::ShadowsConfig::from_table(&file.shadows, path)?;
        // Loaded once here too (then dropped), so that a broken model or a scene without a
        // light stops the bench before any scene's sweep, not after.
        if Scene::load(&file, path)?.lights.is_empty() {
            return Err(SceneError::new(path, "light", "the bench needs at least one light"));
        }
        files.push((path.clone(), file));
    }
    let mut stems: Vec<String> = Vec::new();
    for (path, _) in &files {
        let stem = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        if ["index", "results", "truth-cache"].contains(&stem.as_str()) {
            return Err(SceneError::new(
                path,
                "bench",
                format!("a scene may not be named {stem}: outputs would clash"),
            ));
        }
        if stems.contains(&stem) {
            return Err(SceneError::new(
                path,
                "bench",
                format!("two scenes named {stem}: outputs would clash"),
            ));
        }
        stems.push(stem);
    }
    std::fs::create_dir_all(&out)
        .map_err(|e| SceneError::new(&out, "--out", format!("cannot create the folder: {e}")))?;

    let mut staged = StagedFiles::default();
    let io = |e: String| SceneError::new(&out, "--out", e);
    let mut results = Vec::new();
    pool.install(|| -> Result<(), SceneError> {
        for ((path, file), stem) in files.iter().zip(&stems) {
            let scene = Scene::load(file, path)?;
            let (width, height) = bench_size(args, file.image.width, file.image.height);
            let settings = RenderSettings { width, height, spp: 1, seed: args.seed };
            let scene_dir = out.join(stem);
            std::fs::create_dir_all(&scene_dir).map_err(|e| {
                SceneError::new(&scene_dir, "--out", format!("cannot create the folder: {e}"))
            })?;
            log(format!("{}: {} triangles, {width}x{height}", path.display(), scene.stats.triangles));

            let none_cfg = ShadowsConfig { method: MethodName::None, ..ShadowsConfig::default() };
            let none = run_setting(&scene, &none_cfg, &settings, repeats, args.max_run_seconds)
                .map_err(|e| SceneError::new(path, "bench", e))?;
            // The cost floor: what every method pays (primary rays, shading, collecting the
            // visible points), median of prepare + render.
            let none_total = median(none.totals.clone());
            let reach = none.frame.visibility.clone();

            let truth = truth::truth(&cache, stem, path, file, &scene, &settings, truth_samples)?;
            log(format!(
                "  truth: traced N={truth_samples} {} ({:.1} s)",
                if truth.cached { "from the cache" } else { "rendered" },
                truth.seconds
            ));
            let fixed = scene.stats.load.as_secs_f64() + scene.stats.bvh.as_secs_f64();

            let mut rows = Vec::new();
            // Per family: (rmse, label, frame) of the best setting so far.
            let mut best: Vec<(&'static str, f64, String, Frame)> = Vec::new();
            // edge_table settings whose first run took longer than --max-run-seconds.
            let mut too_long: Vec<(u32, [u32; 3], u32, u32)> = Vec::new();
            let mut skipped = Vec::new();
            for s in &settings_list {
                if let Some(order) = cost_order(&s.config)
                    && too_long.iter().any(|&t| no_costlier(t, order))
                {
                    log(format!(
                        "  {:<40} skipped: a cheaper setting took over {} s",
                        s.label, args.max_run_seconds
                    ));
                    skipped.push(format!(
                        "{} (a setting no costlier took over {} s)",
                        s.label, args.max_run_seconds
                    ));
                    continue;
                }
                // A method that cannot run this setting (say, masks over the memory budget) is
                // listed as skipped with its reason; the rest of the sweep goes on.
                let run = match run_setting(&scene, &s.config, &settings, repeats, args.max_run_seconds) {
                    Ok(run) => run,
                    Err(e) => {
                        log(format!("  {:<40} skipped: {e}", s.label));
                        skipped.push(format!("{} ({e})", s.label));
                        continue;
                    }
                };
                let errors = metrics::errors(
                    &reach,
                    &truth.visibility,
                    &run.frame.visibility,
                    &truth.radiance,
                    &run.frame.radiance,
                );
                let (prep, rend) = (median(run.prepare.clone()), median(run.render.clone()));
                if let Some(order) = cost_order(&s.config)
                    && run.prepare[0] + run.render[0] > args.max_run_seconds
                {
                    too_long.push(order);
                }
                let counter = |k: &str| run.frame.counters.get(k).copied().unwrap_or(0);
                let row = Row {
                    scene: stem.clone(),
                    method: family(s.config.method).to_string(),
                    setting: s.label.clone(),
                    samples: s.config.samples,
                    edge_table_default: s.is_edge_table_default,
                    width,
                    height,
                    repeats: run.prepare.len() as u32,
                    shadow_prepare_s: prep,
                    render_s: rend,
                    total_s: fixed + prep + rend,
                    shadow_cost_s: median(run.totals.clone()) - none_total,
                    peak_rss_mib: run.peak,
                    method_mib: (counter("mask_bytes") + counter("depth_map_bytes")) as f64 / 1048576.0,
                    fallbacks: counter("fallbacks"),
                    errors,
                };
                log(format!(
                    "  {:<40} cost {:>8.3} s  RMSE {:.4}  penumbra {:.4}",
                    s.label, row.shadow_cost_s, errors.rmse, errors.penumbra_rmse
                ));
                let fam = family(s.config.method);
                match best.iter_mut().find(|b| b.0 == fam) {
                    // A NaN error (no lit pixel) never counts as the best.
                    Some(b) if errors.rmse.is_nan() || errors.rmse >= b.1 => {}
                    Some(b) => *b = (fam, errors.rmse, s.label.clone(), run.frame),
                    None => best.push((fam, errors.rmse, s.label.clone(), run.frame)),
                }
                rows.push(row);
            }

            // Images: the truth, and each family's best setting with its error heat map.
            staged.png(&scene_dir.join("truth.png"), width, height, &truth.radiance).map_err(io)?;
            let mut best_files = Vec::new();
            for (fam, _, label, frame) in &best {
                let img = format!("{stem}/{fam}.png");
                let heat = format!("{stem}/{fam}.error.png");
                staged.png(&out.join(&img), width, height, &frame.radiance).map_err(io)?;
                let hm = heat_map(&reach, &truth.visibility, &frame.visibility);
                staged.png(&out.join(&heat), width, height, &hm).map_err(io)?;
                best_files.push((fam.to_string(), label.clone(), img, heat));
            }

            // The plot, written at once (plotters writes its own files): to temporary names,
            // staged like the rest.
            let series: Vec<plot::Series> = best
                .iter()
                .map(|(fam, ..)| plot::Series {
                    family: fam,
                    points: rows
                        .iter()
                        .filter(|r| r.method == *fam)
                        .map(|r| (r.shadow_cost_s, r.errors.rmse))
                        .collect(),
                })
                .collect();
            let tmp_png = scene_dir.join(format!(".plot.{}.png", std::process::id()));
            let tmp_svg = scene_dir.join(format!(".plot.{}.svg", std::process::id()));
            let title = format!("{stem}: visibility RMSE against shadow cost ({width}x{height})");
            let drawn = plot::draw(&title, &series, &tmp_png, &tmp_svg);
            let (png_bytes, svg_bytes) = (std::fs::read(&tmp_png), std::fs::read(&tmp_svg));
            let _ = std::fs::remove_file(&tmp_png);
            let _ = std::fs::remove_file(&tmp_svg);
            drawn.map_err(io)?;
            for (bytes, name) in [(png_bytes, "plot.png"), (svg_bytes, "plot.svg")] {
                staged.bytes(&scene_dir.join(name), &bytes.map_err(|e| io(e.to_string()))?).map_err(io)?;
            }

            let speedup = equal_error_speedup(&rows);
            results.push(SceneResult {
                stem: stem.clone(),
                path: path.display().to_string(),
                triangles: scene.stats.triangles,
                width,
                height,
                truth_samples,
                truth_cached: truth.cached,
                truth_seconds: truth.seconds,
                rows,
                best: best_files,
                speedup,
                skipped,
            });
        }
        Ok(())
    })?;

    staged.bytes(&out.join("results.csv"), report::csv(&results).as_bytes()).map_err(io)?;
    let json = report::json(args, threads, repeats, &results);
    staged
        .bytes(&out.join("results.json"), &serde_json::to_vec_pretty(&json).expect("serialises"))
        .map_err(io)?;
    staged.bytes(&out.join("index.html"), html::html(threads, repeats, &results).as_bytes()).map_err(io)?;
    staged.commit().map_err(io)?;
    Ok(report::summary(args, &results))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bench_size_scales_scenes_down_to_the_bench_width() {
        let args = |w: Option<u32>, h: Option<u32>, quick: bool| BenchArgs {
            scenes: vec![],
            out: None,
            repeats: 1,
            truth_samples: 1,
            cache: None,
            width: w,
            height: h,
            threads: None,
            seed: 0,
            quick,
            quiet: true,
            max_run_seconds: 10.0,
        };
        assert_eq!(bench_size(&args(None, None, false), 640, 480), (320, 240));
        assert_eq!(bench_size(&args(None, None, false), 200, 100), (200, 100));
        assert_eq!(bench_size(&args(None, None, true), 640, 480), (64, 48));
        assert_eq!(bench_size(&args(Some(100), None, false), 640, 480), (100, 75));
        assert_eq!(bench_size(&args(Some(10), Some(20), false), 640, 480), (10, 20));
    }
}
