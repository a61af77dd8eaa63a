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

pub mod metrics;
pub mod plot;
pub mod truth;

use crate::config::{BlendName, MethodName, ShadowsConfig};
use crate::methods::build_shadowing;
use glam::Vec3;
use metrics::Errors;
use renderer::output::StagedFiles;
use renderer::{Frame, RenderSettings, Scene, SceneError, SceneFile, render};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Duration;

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

/// One setting of the sweep.
#[derive(Debug, Clone)]
pub struct Setting {
    pub label: String,
    pub config: ShadowsConfig,
    /// `edge_table` at its defaults with 1024 samples: the row the equal-error speedup is
    /// computed for.
    pub is_edge_table_default: bool,
}

fn setting(label: String, config: ShadowsConfig) -> Setting {
    Setting { label, config, is_edge_table_default: false }
}

/// Label prefix of the plain traced reference: reported, but not a candidate of the
/// equal-error speedup (that compares with `traced` as it ships, shaft-culled).
pub const PLAIN_TRACED: &str = "traced plain";

/// The settings swept, in order.
pub fn sweep(quick: bool) -> Vec<Setting> {
    let base = ShadowsConfig::default();
    let mut out = Vec::new();
    let traced_ns: &[u32] = if quick { &[4, 16, 64] } else { &[4, 16, 64, 256, 1024] };
    for &n in traced_ns {
        out.push(setting(
            format!("traced N={n}"),
            ShadowsConfig { method: MethodName::Traced, samples: n, ..base.clone() },
        ));
    }
    let n = if quick { 64 } else { 1024 };
    // The plain reference at the top count: every ray traced, no shaft culling (the same
    // bits as `traced N=1024`, so the cost of culling's absence is read off side by side).
    let mut plain = ShadowsConfig { method: MethodName::Traced, samples: n, ..base.clone() };
    plain.traced.shaft_culling = Some(false);
    out.push(setting(format!("{PLAIN_TRACED} N={n}"), plain));
    out.push(setting(
        format!("depth_march 256 N={n}"),
        ShadowsConfig { method: MethodName::DepthMarch, samples: n, ..base.clone() },
    ));
    let maps: &[u32] = if quick { &[256] } else { &[256, 512] };
    // The default's grid, and in the full sweep the previous default's and a finer one
    // (each once, whatever the default: a repeated setting would repeat a row's label).
    let default_grid = ShadowsConfig::default().edge_table.params().grid;
    let mut grids = vec![default_grid];
    if !quick {
        for g in [[4, 4, 4], [8, 8, 4]] {
            if !grids.contains(&g) {
                grids.push(g);
            }
        }
    }
    let grid_name = |g: [u32; 3]| format!("{}x{}x{}", g[0], g[1], g[2]);
    for &map in maps {
        for &grid in &grids {
            for blend in [BlendName::Nearest, BlendName::Trilinear] {
                let mut c = ShadowsConfig { method: MethodName::EdgeTable, samples: n, ..base.clone() };
                c.edge_table.depth_map = Some(map);
                c.edge_table.grid = Some(grid);
                c.edge_table.blend = Some(blend);
                let blend_name = match blend {
                    BlendName::Nearest => "nearest",
                    BlendName::Trilinear => "trilinear",
                };
                let label = format!("edge_table {map} {} {blend_name} N={n}", grid_name(grid));
                let is_default = c.edge_table.params() == ShadowsConfig::default().edge_table.params();
                out.push(Setting { label, config: c, is_edge_table_default: is_default });
            }
        }
    }
    // Sample counts at the default parameters.
    let counts: &[u32] = if quick { &[16] } else { &[64, 256] };
    for &m in counts {
        out.push(setting(
            format!("edge_table 256 {} nearest N={m}", grid_name(default_grid)),
            ShadowsConfig { method: MethodName::EdgeTable, samples: m, ..base.clone() },
        ));
    }
    let taps: &[u32] = if quick { &[64] } else { &[64, 256, 1024] };
    for &t in taps {
        out.push(setting(
            format!("pcss 256 N={t}"),
            ShadowsConfig { method: MethodName::Pcss, samples: t, ..base.clone() },
        ));
    }
    out
}

/// One row of results: a setting on a scene.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    pub scene: String,
    pub method: String,
    pub setting: String,
    pub samples: u32,
    pub edge_table_default: bool,
    pub width: u32,
    pub height: u32,
    pub repeats: u32,
    /// Medians over the repeats, seconds.
    pub shadow_prepare_s: f64,
    pub render_s: f64,
    /// Scene load + BVH build (once per scene) + shadow_prepare + render.
    pub total_s: f64,
    /// shadow_prepare + render - render of `none` (medians).
    pub shadow_cost_s: f64,
    /// The run's peak resident memory above what was resident when it started (Linux;
    /// NaN elsewhere), MiB, the largest over the repeats.
    pub peak_rss_mib: f64,
    /// What the method says it holds (depth map and masks), MiB.
    pub method_mib: f64,
    pub fallbacks: u64,
    #[serde(flatten)]
    pub errors: Errors,
}

/// CSV header and line of a row (every field of the JSON, in the same order).
const CSV_HEADER: &str = "scene,method,setting,samples,edge_table_default,width,height,repeats,shadow_prepare_s,render_s,total_s,shadow_cost_s,peak_rss_mib,method_mib,fallbacks,rmse,penumbra_rmse,p99,max,leak_rate,false_shadow_rate,penumbra_bias,image_relative_rmse,lit_pixels,penumbra_pixels,dark_pixels,bright_pixels";

/// A CSV field: quoted (quotes doubled) when it holds a comma, quote or line break. The
/// `csv` crate cannot write the flattened `Row` (serde's `flatten` goes through a map).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

fn csv_line(r: &Row) -> String {
    let e = &r.errors;
    format!(
        "{},{},{},{},{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.1},{:.3},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{},{},{},{}",
        csv_field(&r.scene),
        r.method,
        csv_field(&r.setting),
        r.samples,
        r.edge_table_default,
        r.width,
        r.height,
        r.repeats,
        r.shadow_prepare_s,
        r.render_s,
        r.total_s,
        r.shadow_cost_s,
        r.peak_rss_mib,
        r.method_mib,
        r.fallbacks,
        e.rmse,
        e.penumbra_rmse,
        e.p99,
        e.max,
        e.leak_rate,
        e.false_shadow_rate,
        e.penumbra_bias,
        e.image_relative_rmse,
        e.lit_pixels,
        e.penumbra_pixels,
        e.dark_pixels,
        e.bright_pixels
    )
}

/// Resets the process' peak-RSS counter (Linux: `clear_refs` 5), so the next read is the
/// peak since now.
/// Resets the process' peak-RSS counter and returns the resident memory now (MiB), or None
/// where that cannot be done (not Linux).
fn reset_peak_rss() -> Option<f64> {
    std::fs::write("/proc/self/clear_refs", "5").ok()?;
    status_mib("VmRSS:")
}

/// A `/proc/self/status` field in MiB.
fn status_mib(field: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix(field))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map(|kb| kb / 1024.0)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

struct Run {
    frame: Frame,
    prepare: Vec<f64>,
    render: Vec<f64>,
    /// shadow_prepare + render per repeat.
    totals: Vec<f64>,
    peak: f64,
}

fn run_setting(
    scene: &Scene,
    config: &ShadowsConfig,
    settings: &RenderSettings,
    repeats: u32,
    max_run_seconds: f64,
) -> Result<Run, String> {
    let mut first = None;
    let (mut prepare, mut render_t, mut peak) = (Vec::new(), Vec::new(), 0.0f64);
    let mut totals = Vec::new();
    for _ in 0..repeats {
        // A long run is timed once: its noise is small against it, and repeating it would
        // take the time the rest of the sweep needs.
        if prepare.last().zip(render_t.last()).is_some_and(|(p, r): (&f64, &f64)| p + r > max_run_seconds) {
            break;
        }
        // The run's own peak: the high-water mark above what was resident when it started
        // (the allocator keeps what earlier runs freed, so the bare mark would carry over).
        let base = reset_peak_rss();
        let mut methods: Vec<_> = scene.lights.iter().map(|_| build_shadowing(config)).collect();
        let frame = render(scene, &mut methods, settings, &|_| {}).map_err(|e| e.to_string())?;
        drop(methods);
        let run_peak = base.zip(status_mib("VmHWM:")).map_or(f64::NAN, |(b, hwm)| (hwm - b).max(0.0));
        peak = if peak.is_nan() { peak } else { peak.max(run_peak) };
        prepare.push(secs(frame.shadow_prepare));
        render_t.push(secs(frame.render));
        totals.push(secs(frame.shadow_prepare) + secs(frame.render));
        first.get_or_insert(frame);
    }
    Ok(Run { frame: first.expect("repeats >= 1"), prepare, render: render_t, totals, peak })
}

/// The `edge_table` parameters that only make a run costlier as they grow: (depth map,
/// grid, blend (nearest 0, trilinear 1), samples).
fn cost_order(c: &ShadowsConfig) -> Option<(u32, [u32; 3], u32, u32)> {
    if c.method != MethodName::EdgeTable {
        return None;
    }
    let p = c.edge_table.params();
    let blend = match p.blend {
        shadow_plugin::Blend::Nearest => 0,
        shadow_plugin::Blend::Trilinear => 1,
    };
    Some((p.depth_map.resolution, p.grid, blend, c.samples))
}

/// Whether `a` is at most `b` in every cost parameter.
fn no_costlier(a: (u32, [u32; 3], u32, u32), b: (u32, [u32; 3], u32, u32)) -> bool {
    a.0 <= b.0 && a.1.iter().zip(&b.1).all(|(x, y)| x <= y) && a.2 <= b.2 && a.3 <= b.3
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}

/// Everything measured on one scene.
pub struct SceneResult {
    pub stem: String,
    pub path: String,
    pub triangles: u64,
    pub width: u32,
    pub height: u32,
    pub truth_samples: u32,
    pub truth_cached: bool,
    pub truth_seconds: f64,
    pub rows: Vec<Row>,
    /// Per method family: (setting label, image file, heat-map file), the best setting's.
    pub best: Vec<(String, String, String, String)>,
    /// The equal-error speedup of `edge_table` (default, 1024 samples), if it was run.
    pub speedup: Option<Speedup>,
    /// Settings not run (see `--max-run-seconds`).
    pub skipped: Vec<String>,
}

/// The equal-error speedup (the definition): the shadow cost of the cheapest
/// `traced` run whose RMSE is at or below `edge_table`'s (defaults, 1024 samples), divided
/// by `edge_table`'s.
#[derive(Debug, Clone, Serialize)]
pub struct Speedup {
    pub edge_table_rmse: f64,
    pub edge_table_cost_s: f64,
    /// The traced run matched: the cheapest at or below edge_table's error, or, when none
    /// is, the most accurate one (`at_least`).
    pub traced_setting: String,
    pub traced_cost_s: f64,
    pub ratio: f64,
    /// No traced run reached edge_table's error: the speedup is at least `ratio`.
    pub at_least: bool,
    /// The match is the cheapest traced run and is strictly more accurate: a traced run
    /// with fewer samples might match too, so the speedup is at most `ratio`.
    pub at_most: bool,
    /// The traced cost at exactly edge_table's error, interpolated on log-log axes between
    /// the two traced runs whose errors bracket it, over edge_table's cost (None outside
    /// the traced runs' range).
    pub interpolated_ratio: Option<f64>,
}

fn equal_error_speedup(rows: &[Row]) -> Option<Speedup> {
    let et = rows.iter().find(|r| r.edge_table_default)?;
    let mut traced: Vec<&Row> = rows
        .iter()
        .filter(|r| {
            r.method == "traced"
                && !r.setting.starts_with(PLAIN_TRACED)
                && r.errors.rmse.is_finite()
                && r.shadow_cost_s > 0.0
        })
        .collect();
    // No lit pixel (NaN errors) or a cost lost in the noise: no meaningful ratio.
    if !et.errors.rmse.is_finite() || et.shadow_cost_s <= 0.0 || traced.is_empty() {
        return None;
    }
    traced.sort_by(|a, b| a.shadow_cost_s.total_cmp(&b.shadow_cost_s));
    let cheapest = traced[0];
    let matched = traced.iter().find(|r| r.errors.rmse <= et.errors.rmse);
    let (t, at_least) = match matched {
        Some(t) => (*t, false),
        None => (*traced.iter().min_by(|a, b| a.errors.rmse.total_cmp(&b.errors.rmse))?, true),
    };
    let at_most = !at_least && std::ptr::eq(t, cheapest) && t.errors.rmse < et.errors.rmse;
    let interpolated = traced.windows(2).find_map(|w| {
        let (a, b) = (w[0], w[1]); // a cheaper and (normally) less accurate than b
        let (ea, eb) = (a.errors.rmse, b.errors.rmse);
        let e = et.errors.rmse;
        if !(eb <= e && e <= ea) || ea <= 0.0 || eb <= 0.0 || ea == eb {
            return None;
        }
        let f = (e.ln() - ea.ln()) / (eb.ln() - ea.ln());
        Some(
            (a.shadow_cost_s.ln() + f * (b.shadow_cost_s.ln() - a.shadow_cost_s.ln())).exp()
                / et.shadow_cost_s,
        )
    });
    Some(Speedup {
        edge_table_rmse: et.errors.rmse,
        edge_table_cost_s: et.shadow_cost_s,
        traced_setting: t.setting.clone(),
        traced_cost_s: t.shadow_cost_s,
        ratio: t.shadow_cost_s / et.shadow_cost_s,
        at_least,
        at_most,
        interpolated_ratio: interpolated,
    })
}

/// A ratio with two significant digits.
fn ratio_text(r: f64) -> String {
    if r.is_nan() || r <= 0.0 || r.is_infinite() {
        return format!("{r}x");
    }
    // Decimals for two significant digits, whole numbers from 10 up.
    let decimals = (1.0 - r.log10().floor()).max(0.0) as usize;
    format!("{r:.decimals$}x")
}

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
            let mask_budget_bytes = crate::memory::mask_budget_bytes();
            let settings = RenderSettings { width, height, spp: 1, seed: args.seed, mask_budget_bytes };
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

    let all_rows: Vec<&Row> = results.iter().flat_map(|r| &r.rows).collect();
    let mut csv = String::from(CSV_HEADER);
    csv.push('\n');
    for r in &all_rows {
        csv.push_str(&csv_line(r));
        csv.push('\n');
    }
    staged.bytes(&out.join("results.csv"), csv.as_bytes()).map_err(io)?;
    let json = serde_json::json!({
        "threads": threads,
        "repeats": repeats,
        "quick": args.quick,
        "seed": args.seed,
        "scenes": results.iter().map(|s| serde_json::json!({
            "scene": s.stem, "path": s.path, "triangles": s.triangles, "width": s.width,
            "height": s.height, "truth_samples": s.truth_samples, "truth_cached": s.truth_cached,
            "truth_seconds": s.truth_seconds, "equal_error_speedup": s.speedup, "skipped": s.skipped,
        })).collect::<Vec<_>>(),
        "rows": all_rows,
    });
    staged
        .bytes(&out.join("results.json"), &serde_json::to_vec_pretty(&json).expect("serialises"))
        .map_err(io)?;
    staged.bytes(&out.join("index.html"), html(threads, repeats, &results).as_bytes()).map_err(io)?;
    staged.commit().map_err(io)?;
    Ok(summary(args, &results))
}

fn speedup_text(s: &Option<Speedup>) -> String {
    match s {
        None => "n/a (no edge_table default row, no lit pixel, or costs within the noise)".into(),
        Some(s) => format!(
            "{}{} (edge_table RMSE {:.4} at {:.3} s; {} at {:.3} s{}{})",
            if s.at_least {
                ">= "
            } else if s.at_most {
                "<= "
            } else {
                ""
            },
            ratio_text(s.ratio),
            s.edge_table_rmse,
            s.edge_table_cost_s,
            s.traced_setting,
            s.traced_cost_s,
            if s.at_most { ", already more accurate" } else { "" },
            s.interpolated_ratio.map_or(String::new(), |r| format!("; interpolated {}", ratio_text(r)))
        ),
    }
}

/// The one-screen summary: per scene, each family's best setting and the speedup.
fn summary(args: &BenchArgs, results: &[SceneResult]) -> String {
    let mut s = String::new();
    for r in results {
        let _ = writeln!(
            s,
            "{} ({} triangles, {}x{}, truth traced N={}{})",
            r.stem,
            r.triangles,
            r.width,
            r.height,
            r.truth_samples,
            if r.truth_cached { ", cached" } else { "" }
        );
        for (fam, label, ..) in &r.best {
            if let Some(row) = r.rows.iter().find(|x| &x.setting == label) {
                let _ = writeln!(
                    s,
                    "  best {:<12} {:<36} RMSE {:.4}  cost {:.3} s",
                    fam, label, row.errors.rmse, row.shadow_cost_s
                );
            }
        }
        let _ = writeln!(s, "  equal-error speedup of edge_table: {}", speedup_text(&r.speedup));
        if !r.skipped.is_empty() {
            let _ = writeln!(s, "  skipped: {}", r.skipped.join("; "));
        }
    }
    let _ = writeln!(s, "wrote {}", args.out_dir().join("index.html").display());
    s
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The HTML report: per scene the plot, the table and the images side by side.
fn html(threads: usize, repeats: u32, results: &[SceneResult]) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>penumbra bench</title>\n<style>\
body{{font-family:sans-serif;margin:2em;max-width:1400px}}table{{border-collapse:collapse;font-size:13px}}\
td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}td:first-child,th:first-child{{text-align:left}}\
tr.default{{background:#fde}}figure{{display:inline-block;margin:4px;vertical-align:top}}\
figcaption{{font-size:12px;max-width:330px}}img.plot{{max-width:900px;width:100%}}</style></head><body>\n\
<h1>penumbra bench</h1>\n<p>{} scene(s), {} thread(s), median of {} run(s) per setting. Shadow cost = \
shadow_prepare + render time above <code>none</code>. Errors are against <code>traced</code> at the truth's \
sample count, over the pixels each light reaches. Data: <a href=\"results.csv\">results.csv</a>, \
<a href=\"results.json\">results.json</a>. Heat maps: |visibility error|, black 0 to white &ge; 0.5.</p>\n",
        results.len(),
        threads,
        repeats
    );
    for r in results {
        let _ = write!(
            h,
            "<h2>{}</h2>\n<p>{} ({} triangles), {}x{}, truth: traced N={}{}. Equal-error speedup of \
edge_table (default, highlighted): {}.</p>\n<p><img class=\"plot\" src=\"{}/plot.png\" alt=\"{} plot\"><br>\
<small>x: shadow cost (s), y: visibility RMSE, both log; a line per method; the Pareto front ringed \
(<a href=\"{}/plot.svg\">SVG</a>).</small></p>\n",
            esc(&r.stem),
            esc(&r.path),
            r.triangles,
            r.width,
            r.height,
            r.truth_samples,
            if r.truth_cached { ", from the cache" } else { "" },
            esc(&speedup_text(&r.speedup)),
            esc(&r.stem),
            esc(&r.stem),
            esc(&r.stem)
        );
        h.push_str(
            "<table><tr><th>setting</th><th>shadow cost (s)</th><th>prepare (s)</th><th>render (s)</th>\
<th>RMSE</th><th>penumbra RMSE</th><th>p99</th><th>max</th><th>leak</th><th>false shadow</th>\
<th>image rel. RMSE</th><th>peak RSS (MiB)</th><th>method (MiB)</th></tr>\n",
        );
        for row in &r.rows {
            let e = &row.errors;
            let _ = writeln!(
                h,
                "<tr{}><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.4}</td><td>{:.4}</td>\
<td>{:.3}</td><td>{:.3}</td><td>{:.2}%</td><td>{:.3}%</td><td>{:.4}</td><td>{:.0}</td><td>{:.1}</td></tr>",
                if row.edge_table_default { " class=\"default\"" } else { "" },
                esc(&row.setting),
                row.shadow_cost_s,
                row.shadow_prepare_s,
                row.render_s,
                e.rmse,
                e.penumbra_rmse,
                e.p99,
                e.max,
                100.0 * e.leak_rate,
                100.0 * e.false_shadow_rate,
                e.image_relative_rmse,
                row.peak_rss_mib,
                row.method_mib
            );
        }
        h.push_str("</table>\n");
        if !r.skipped.is_empty() {
            let _ = writeln!(h, "<p>Skipped: {}.</p>", esc(&r.skipped.join("; ")));
        }
        h.push_str("<div>\n");
        let _ = writeln!(
            h,
            "<figure><img src=\"{0}/truth.png\" alt=\"truth\"><figcaption>truth (traced N={1})</figcaption></figure>",
            esc(&r.stem),
            r.truth_samples
        );
        for (fam, label, img, heat) in &r.best {
            let _ = writeln!(
                h,
                "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{} (best {})</figcaption></figure>\
<figure><img src=\"{}\" alt=\"{} error\"><figcaption>{}: |error|</figcaption></figure>",
                esc(img),
                esc(fam),
                esc(label),
                esc(fam),
                esc(heat),
                esc(fam),
                esc(label)
            );
        }
        h.push_str("</div>\n");
    }
    h.push_str("</body></html>\n");
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(method: &str, setting: &str, cost: f64, rmse: f64, default: bool) -> Row {
        Row {
            scene: "s".into(),
            method: method.into(),
            setting: setting.into(),
            samples: 0,
            edge_table_default: default,
            width: 1,
            height: 1,
            repeats: 1,
            shadow_prepare_s: 0.0,
            render_s: 0.0,
            total_s: 0.0,
            shadow_cost_s: cost,
            peak_rss_mib: 0.0,
            method_mib: 0.0,
            fallbacks: 0,
            errors: Errors { rmse, ..Errors::default() },
        }
    }

    #[test]
    fn equal_error_speedup_takes_the_cheapest_traced_run_at_or_below_the_error() {
        let rows = vec![
            row("traced", "t16", 0.1, 0.08, false),
            row("traced", "t64", 0.4, 0.04, false),
            row("traced", "t256", 1.6, 0.02, false),
            row("edge_table", "et", 0.05, 0.04, true),
        ];
        let s = equal_error_speedup(&rows).unwrap();
        assert_eq!(s.traced_setting, "t64");
        assert!((s.ratio - 8.0).abs() < 1e-9 && !s.at_least && !s.at_most, "{s:?}");
        // Exactly at t64's error: the interpolation lands on t64's cost.
        assert!((s.interpolated_ratio.unwrap() - 8.0).abs() < 1e-9, "{s:?}");
        // Between t16 and t64 (error 0.0566, the geometric mean): cost sqrt(0.1 x 0.4).
        let mid = vec![
            row("traced", "t16", 0.1, 0.08, false),
            row("traced", "t64", 0.4, 0.04, false),
            row("edge_table", "et", 0.1, (0.08f64 * 0.04).sqrt(), true),
        ];
        let s = equal_error_speedup(&mid).unwrap();
        assert!((s.interpolated_ratio.unwrap() - 2.0).abs() < 1e-9, "{s:?}");
        // The cheapest traced run is already more accurate: an upper bound.
        let cheap = vec![row("traced", "t16", 0.1, 0.02, false), row("edge_table", "et", 0.2, 0.04, true)];
        let s = equal_error_speedup(&cheap).unwrap();
        assert!(s.at_most && (s.ratio - 0.5).abs() < 1e-9 && s.interpolated_ratio.is_none(), "{s:?}");
        assert_eq!(
            [ratio_text(0.0032), ratio_text(0.46), ratio_text(2.345), ratio_text(31.7)],
            ["0.0032x", "0.46x", "2.3x", "32x"]
        );
        // No lit pixel: no ratio.
        let dark =
            vec![row("traced", "t16", 0.1, f64::NAN, false), row("edge_table", "et", 0.2, f64::NAN, true)];
        assert!(equal_error_speedup(&dark).is_none());
        // Better than every traced run: a lower bound against the most accurate one.
        let rows = vec![row("traced", "t16", 0.1, 0.08, false), row("edge_table", "et", 0.05, 0.01, true)];
        let s = equal_error_speedup(&rows).unwrap();
        assert!(s.at_least && (s.ratio - 2.0).abs() < 1e-9, "{s:?}");
    }

    #[test]
    fn the_sweep_holds_every_family_and_one_edge_table_default() {
        for quick in [false, true] {
            let s = sweep(quick);
            for m in [MethodName::Traced, MethodName::DepthMarch, MethodName::EdgeTable, MethodName::Pcss] {
                assert!(s.iter().any(|x| x.config.method == m), "{m:?} missing (quick {quick})");
            }
            assert_eq!(s.iter().filter(|x| x.is_edge_table_default).count(), 1, "quick {quick}");
        }
        let full: Vec<(u32, bool)> = sweep(false)
            .iter()
            .filter(|x| x.config.method == MethodName::Traced)
            .map(|x| (x.config.samples, x.config.traced.params(x.config.samples).shaft_culling))
            .collect();
        // Shaft-culled at every count, and the plain reference at the top one.
        assert_eq!(full, vec![(4, true), (16, true), (64, true), (256, true), (1024, true), (1024, false)]);
    }

    #[test]
    fn costlier_edge_table_settings_are_the_ones_skipped() {
        let et = |map: u32, grid: [u32; 3], blend: BlendName, samples: u32| {
            let mut c = ShadowsConfig { method: MethodName::EdgeTable, samples, ..ShadowsConfig::default() };
            c.edge_table.depth_map = Some(map);
            c.edge_table.grid = Some(grid);
            c.edge_table.blend = Some(blend);
            cost_order(&c).unwrap()
        };
        let slow = et(256, [4, 4, 2], BlendName::Trilinear, 1024);
        assert!(no_costlier(slow, et(512, [4, 4, 2], BlendName::Trilinear, 1024)));
        assert!(no_costlier(slow, et(256, [8, 8, 4], BlendName::Trilinear, 1024)));
        assert!(!no_costlier(slow, et(256, [8, 8, 4], BlendName::Nearest, 1024)));
        assert!(!no_costlier(slow, et(512, [4, 4, 2], BlendName::Trilinear, 256)));
        assert_eq!(cost_order(&ShadowsConfig::default()), None, "traced is never skipped");
    }

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
