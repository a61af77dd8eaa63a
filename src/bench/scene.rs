//! One scene's bench: the scene files checked, then per scene `none` (the cost floor), the
//! truth, every setting of the sweep timed and scored ([`Row`]), and the figures.

use super::report::{Measure, Row, SceneResult, equal_error_speedup, equal_error_speedup_on};
use super::run::{Run, median, run_setting};
use super::sweep::{Setting, no_costlier, none_setting};
use super::truth::Truth;
use super::{BENCH_WIDTH, BenchArgs, QUICK_WIDTH, cost, figures, metrics, plot, truth};
use crate::cli_error::{CliError, OutputError};
use crate::methods::Registered;
use crate::output::StagedFiles;
use crate::request::{Overrides, Request};
use renderer::{Frame, RenderSettings, Scene, SceneError, SceneFile};
use std::path::{Path, PathBuf};

/// What every scene of a bench shares.
pub(super) struct Plan<'a> {
    pub(super) args: &'a BenchArgs,
    /// The output folder.
    pub(super) out: &'a Path,
    /// Runs per setting (1 with `--quick`).
    pub(super) repeats: u32,
    pub(super) truth_samples: u32,
    /// The truth cache folder.
    pub(super) cache: PathBuf,
    /// The settings swept, in order.
    pub(super) settings: Vec<Setting>,
    /// The methods swept (their plot colours).
    pub(super) methods: &'a [Registered],
}

impl Plan<'_> {
    /// A progress line on stderr, unless `--quiet`.
    fn log(&self, s: String) {
        if !self.args.quiet {
            eprintln!("{s}");
        }
    }
}

/// Every scene file of `args`, loaded and checked before the long part, and the stem each
/// one's outputs are named by.
pub(super) fn check_scenes(args: &BenchArgs) -> Result<Vec<(PathBuf, SceneFile, String)>, SceneError> {
    let mut files = Vec::new();
    for path in &args.scenes {
        // Typed whole, `[shadows]` included, as `render` types it.
        let file = Request::read(Some(path), &Overrides::default())?.file;
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
    Ok(files.into_iter().zip(stems).map(|((path, file), stem)| (path, file, stem)).collect())
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

/// What every setting of a scene is measured against.
struct Baseline<'a> {
    stem: &'a str,
    scene: &'a Scene,
    settings: RenderSettings,
    /// Which pixels each light reaches (`none`'s visibility).
    reach: &'a [Vec<f32>],
    /// The cost floor: `none`'s median prepare + render.
    none_total: f64,
    /// Scene load + BVH build.
    fixed: f64,
    truth: &'a Truth,
}

/// Benches one scene: `none`, the truth, every setting, the figures (staged in `staged`).
pub(super) fn bench_scene(
    plan: &Plan,
    path: &Path,
    file: &SceneFile,
    stem: &str,
    staged: &mut StagedFiles,
) -> Result<SceneResult, CliError> {
    let (args, out) = (plan.args, plan.out);
    let scene = Scene::load(file, path)?;
    let (width, height) = bench_size(args, file.image.width, file.image.height);
    let memory_budget_bytes = crate::memory::memory_budget_bytes()?;
    let settings = RenderSettings {
        width,
        height,
        spp: 1,
        seed: args.seed,
        memory_budget_bytes,
        profile: false,
        max_depth: args.max_depth,
    };
    let scene_dir = out.join(stem);
    std::fs::create_dir_all(&scene_dir)
        .map_err(|e| OutputError::new(&scene_dir, "--out", format!("cannot create the folder: {e}")))?;
    plan.log(format!("{}: {} triangles, {width}x{height}", path.display(), scene.stats.triangles));

    let none = run_setting(&scene, &none_setting(), &settings, plan.repeats, args.max_run_seconds)
        .map_err(|e| SceneError::new(path, "bench", e))?;
    // The cost floor: what every method pays (primary rays, shading, collecting the
    // visible points), median of prepare + render.
    let none_total = median(none.totals.clone());
    let reach = none.frame.visibility.clone();

    let truth = truth::truth(&plan.cache, stem, path, file, &scene, &settings, plan.truth_samples)?;
    plan.log(format!(
        "  truth: traced N={} {} ({:.1} s)",
        plan.truth_samples,
        if truth.cached { "from the cache" } else { "rendered" },
        truth.seconds
    ));
    let fixed = scene.stats.load.as_secs_f64() + scene.stats.bvh.as_secs_f64();
    let base = Baseline { stem, scene: &scene, settings, reach: &reach, none_total, fixed, truth: &truth };
    let Swept { rows, best, skipped } = sweep_scene(plan, &base);

    let io = |e: String| OutputError::new(out, "--out", e);
    // Each family's best setting once more, profiled: its cost heat map and split.
    let best = profile_best(plan, &base, &rows, best).map_err(|e| SceneError::new(path, "bench", e))?;
    // Images: the truth, and each family's best setting with its error and cost heat maps.
    let best_files =
        figures::stage_images(staged, out, stem, &settings, &truth, &reach, &best).map_err(io)?;
    // The plot: error against cost, a line per family.
    let families: Vec<&str> = best.iter().map(|b| b.family).collect();
    let series = plot_series(&rows, &families, plan.methods);
    let title = format!("{stem}: visibility RMSE against shadow cost ({width}x{height})");
    figures::stage_plot(staged, &scene_dir, &title, &series).map_err(io)?;

    let speedup = equal_error_speedup(&rows);
    let speedup_image = equal_error_speedup_on(&rows, Measure::Image);
    let speedup_penumbra = equal_error_speedup_on(&rows, Measure::Penumbra);
    let headline = plan.settings.iter().find(|s| s.headline).map(|s| s.method.name());
    Ok(SceneResult {
        stem: stem.to_string(),
        path: path.display().to_string(),
        triangles: scene.stats.triangles,
        width,
        height,
        truth_samples: plan.truth_samples,
        truth_cached: truth.cached,
        truth_seconds: truth.seconds,
        rows,
        best: best_files,
        speedup,
        speedup_image,
        speedup_penumbra,
        headline,
        skipped,
    })
}

/// A scene's sweep: a row per setting run, per family the best setting's (family, RMSE,
/// label, frame), and the settings not run with why.
struct Swept {
    rows: Vec<Row>,
    best: Vec<(&'static str, f64, String, Frame)>,
    skipped: Vec<String>,
}

/// Runs every setting of the plan on the scene of `base`.
fn sweep_scene(plan: &Plan, base: &Baseline) -> Swept {
    let args = plan.args;
    let mut rows = Vec::new();
    // Per family: (rmse, label, frame) of the best setting so far.
    let mut best: Vec<(&'static str, f64, String, Frame)> = Vec::new();
    // (method, cost order) of the settings whose first run took longer than
    // --max-run-seconds.
    let mut too_long: Vec<(&str, &[u32])> = Vec::new();
    let mut skipped = Vec::new();
    for s in &plan.settings {
        let fam = s.method.name();
        if let Some(order) = &s.cost
            && too_long.iter().any(|&(f, t)| f == fam && no_costlier(t, order))
        {
            plan.log(format!(
                "  {:<40} skipped: a cheaper setting took over {} s",
                s.label, args.max_run_seconds
            ));
            skipped.push(format!("{} (a setting no costlier took over {} s)", s.label, args.max_run_seconds));
            continue;
        }
        // A method that cannot run this setting (say, masks over the memory budget) is
        // listed as skipped with its reason; the rest of the sweep goes on.
        let run = match run_setting(base.scene, s, &base.settings, plan.repeats, args.max_run_seconds) {
            Ok(run) => run,
            Err(e) => {
                plan.log(format!("  {:<40} skipped: {e}", s.label));
                skipped.push(format!("{} ({e})", s.label));
                continue;
            }
        };
        if let Some(order) = &s.cost
            && run.prepare[0] + run.render[0] > args.max_run_seconds
        {
            too_long.push((fam, order));
        }
        let row = row(base, s, &run);
        let errors = row.errors;
        plan.log(format!(
            "  {:<40} cost {:>8.3} s  RMSE {:.4}  penumbra {:.4}",
            s.label, row.shadow_cost_s, errors.rmse, errors.penumbra_rmse
        ));
        match best.iter_mut().find(|b| b.0 == fam) {
            // A NaN error (no lit pixel) never counts as the best.
            Some(b) if errors.rmse.is_nan() || errors.rmse >= b.1 => {}
            Some(b) => *b = (fam, errors.rmse, s.label.clone(), run.frame),
            None => best.push((fam, errors.rmse, s.label.clone(), run.frame)),
        }
        rows.push(row);
    }
    Swept { rows, best, skipped }
}

/// Renders each family's best setting once more with profiling, for its cost heat map and
/// the split of its shadow cost (the row's median cost and prepare).
fn profile_best(
    plan: &Plan,
    base: &Baseline,
    rows: &[Row],
    best: Vec<(&'static str, f64, String, Frame)>,
) -> Result<Vec<figures::Best>, String> {
    let threads = rayon::current_num_threads();
    let mut out = Vec::new();
    for (family, _, label, frame) in best {
        let setting = plan.settings.iter().find(|s| s.label == label).expect("a swept setting");
        let row = rows.iter().find(|r| r.setting == label).expect("a row per setting run");
        let costs = cost::profiled(base.scene, setting, &base.settings)?;
        let split = cost::split(&costs, row.shadow_cost_s, row.shadow_prepare_s, threads);
        out.push(figures::Best { family, label, frame, costs, split });
    }
    Ok(out)
}

/// The row of setting `s`, run as `run`, on the scene of `base`: its errors against the
/// truth and its times (medians over the repeats).
fn row(base: &Baseline, s: &Setting, run: &Run) -> Row {
    let truth = base.truth;
    let errors = metrics::errors(
        base.reach,
        &truth.visibility,
        &run.frame.visibility,
        &truth.radiance,
        &run.frame.radiance,
    );
    let (prep, rend) = (median(run.prepare.clone()), median(run.render.clone()));
    let counter = |k: &str| run.frame.counters.get(k).copied().unwrap_or(0);
    let queries = counter("shadow_queries").max(1) as f64;
    // Traced rays: traced's own, the exact edge_table's (whole or a field of them), the
    // published readings' fallbacks'.
    let rays = counter("shadow_rays") + counter("fallback_shadow_rays");
    let cost = median(run.totals.clone()) - base.none_total;
    Row {
        scene: base.stem.to_string(),
        method: s.method.name().to_string(),
        setting: s.label.clone(),
        samples: s.samples,
        headline: s.headline,
        reference: s.reference,
        width: base.settings.width,
        height: base.settings.height,
        repeats: run.prepare.len() as u32,
        shadow_prepare_s: prep,
        render_s: rend,
        total_s: base.fixed + prep + rend,
        shadow_cost_s: median(run.totals.clone()) - base.none_total,
        peak_rss_mib: run.peak,
        method_mib: (counter("mask_bytes") + counter("depth_map_bytes")) as f64 / 1048576.0,
        fallbacks: counter("fallbacks"),
        traced_ray_share: rays as f64 / (queries * f64::from(s.samples)),
        lookups_per_query: counter("edge_lookups") as f64 / queries,
        // Clamped to [0, 1]: at tiny sizes the render above `none` can be lost in the noise
        // (a cost at or below the prepare alone).
        prepare_share: if cost > 0.0 {
            (prep / cost).clamp(0.0, 1.0)
        } else if prep > 0.0 {
            1.0
        } else {
            0.0
        },
        errors,
    }
}

/// The plot's series: a line per family of `families` over its rows, and `traced plain`
/// (the shaft-culled curve's reference, no culling) its own grey series, not a zigzag on
/// `traced`'s line.
fn plot_series<'a>(rows: &[Row], families: &[&'a str], methods: &[Registered]) -> Vec<plot::Series<'a>> {
    let plain = |r: &&Row| r.setting.starts_with(bench_entry::PLAIN_LABEL);
    let points =
        |rows: &mut dyn Iterator<Item = &Row>| rows.map(|r| (r.shadow_cost_s, r.errors.rmse)).collect();
    let mut series: Vec<plot::Series> = families
        .iter()
        .map(|&family| plot::Series {
            family,
            style: plot::style(methods, family),
            points: points(&mut rows.iter().filter(|r| r.method == family && !plain(r))),
        })
        .collect();
    if rows.iter().any(|r| plain(&r)) {
        series.push(plot::Series {
            family: bench_entry::PLAIN_LABEL,
            style: plot::Style { colour: [127, 127, 127], line: true },
            points: points(&mut rows.iter().filter(plain)),
        });
    }
    series
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `traced plain` (one setting at the top count, no culling) is its own series: on
    /// `traced`'s line it made a zigzag (the user's report of `bench --quick`).
    #[test]
    fn traced_plain_is_its_own_series() {
        let rows = [
            super::super::report::test_row("traced", "traced N=16", 0.1, 0.02, false),
            super::super::report::test_row("traced", "traced N=64", 0.3, 0.01, false),
            super::super::report::test_row("traced", "traced plain N=64", 0.6, 0.01, false),
            super::super::report::test_row("silhouette", "silhouette N=64", 0.05, 0.01, true),
        ];
        let series = plot_series(&rows, &["traced", "silhouette"], crate::methods::METHODS);
        let names: Vec<(&str, usize)> = series.iter().map(|s| (s.family, s.points.len())).collect();
        assert_eq!(names, vec![("traced", 2), ("silhouette", 1), ("traced plain", 1)]);
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
            max_depth: 2,
        };
        assert_eq!(bench_size(&args(None, None, false), 640, 480), (320, 240));
        assert_eq!(bench_size(&args(None, None, false), 200, 100), (200, 100));
        assert_eq!(bench_size(&args(None, None, true), 640, 480), (64, 48));
        assert_eq!(bench_size(&args(Some(100), None, false), 640, 480), (100, 75));
        assert_eq!(bench_size(&args(Some(10), Some(20), false), 640, 480), (10, 20));
    }
}
