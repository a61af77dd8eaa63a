//! `penumbra bench SCENE.toml...`: every shadow method and setting against the traced truth,
//! run time against error.
//!
//! Per scene: `none` (the cost floor, and which pixels each light reaches), the truth
//! (`traced` at `--truth-samples`, cached: [`truth`]), then the sweep ([`sweep()`]): each
//! registered method's own settings ([`renderer::MethodEntry::sweep`]; today `traced` at
//! N = 4, 16, 64, 256, 1024 and `traced plain` (no shaft culling) at the top count,
//! `edge_table` over depth-map sizes, grids, blend modes and sample counts, `pcss`, and
//! `silhouette` at N = 64 to 4096). Every setting runs `--repeats` times; times are
//! medians, errors come from the first run (every run gives the same bytes). The shadow
//! cost of a run is `shadow_prepare + render - render(none)`, medians of each.
//!
//! Outputs, under `--out` (default `out/bench`): `results.csv` and `results.json` (every row),
//! per scene `<stem>/plot.png` (+ `.svg`: error against cost, log-log, a line per method,
//! the Pareto front ringed), `<stem>/truth.png`, and for each method its best setting's
//! image and error heat map; `index.html` with all of it; and a summary on stdout.
//! `--quick`: a tiny image, the truth at 256 samples, a short sweep, one repeat (for CI).

mod cost;
mod figures;
mod html;
pub mod metrics;
pub mod plot;
mod report;
mod run;
mod scene;
mod sweep;
pub mod truth;

pub use report::{Row, SceneResult, Speedup};
pub use sweep::{Setting, sweep};

use crate::cli_error::{CliError, OutputError};
use crate::methods::{METHODS, Registered};
use crate::output::StagedFiles;
use std::path::{Path, PathBuf};

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
    #[arg(long, default_value_t = 3, allow_negative_numbers = true, value_parser = crate::flags::whole(1..=100))]
    pub repeats: u32,
    /// Light samples of the traced truth: its penumbra noise (~1e-4) is under that of every
    /// method it scores at N = 1024, `analytic`'s included. A first run renders the truths
    /// (64x `traced`'s N = 1024 cost each); later runs read them from the cache.
    #[arg(long, default_value_t = 65536, allow_negative_numbers = true, value_parser = crate::flags::whole(1..=renderer::MAX_TRACED_SAMPLES))]
    pub truth_samples: u32,
    /// Truth cache folder. Default: OUT/truth-cache.
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Image width; default: the scene's, scaled down to at most 320 (keeping its aspect).
    #[arg(long, allow_negative_numbers = true, value_parser = crate::flags::whole(renderer::load::scene_file::IMAGE_SIDE))]
    pub width: Option<u32>,
    /// Image height; default: the scene's, scaled like the width.
    #[arg(long, allow_negative_numbers = true, value_parser = crate::flags::whole(renderer::load::scene_file::IMAGE_SIDE))]
    pub height: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true, value_parser = crate::flags::whole(1..=1024))]
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
    /// Render every setting, and the truth, as paths of this depth (2 = direct light only).
    /// The truth traces the very same paths (same seed; at 2, glTF shading's one BRDF ray a
    /// point sends), so the image error is the shadow method's along them, not the paths'.
    #[arg(long, default_value_t = 2, allow_negative_numbers = true, value_parser = crate::flags::depth)]
    pub max_depth: u32,
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

/// Runs the bench on every registered method. Progress lines go to stderr unless `--quiet`;
/// the summary is returned.
pub fn run_bench(args: &BenchArgs) -> Result<String, CliError> {
    run_bench_in(args, METHODS)
}

/// [`run_bench`] with the methods of `methods`: their sweeps, their plot colours.
pub fn run_bench_in(args: &BenchArgs, methods: &[Registered]) -> Result<String, CliError> {
    let out = args.out_dir();
    let (threads, pool) = crate::threads::thread_pool(args.threads, &out)?;
    let plan = scene::Plan {
        args,
        out: &out,
        repeats: if args.quick { 1 } else { args.repeats },
        truth_samples: if args.quick {
            QUICK_TRUTH_SAMPLES.min(args.truth_samples)
        } else {
            args.truth_samples
        },
        cache: args.cache.clone().unwrap_or_else(|| out.join("truth-cache")),
        settings: sweep(args.quick, methods),
        methods,
    };
    let scenes = scene::check_scenes(args)?;
    // A bad budget variable, or a folder the reports cannot be written in, is refused
    // before any scene is benched (the reports are written at the end).
    crate::memory::budget_override()?;
    crate::output::check_writable_folder(&out).map_err(|e| OutputError::new(&out, "--out", e))?;
    std::fs::create_dir_all(&out)
        .map_err(|e| OutputError::new(&out, "--out", format!("cannot create the folder: {e}")))?;

    let mut staged = StagedFiles::default();
    let mut results = Vec::new();
    pool.install(|| -> Result<(), CliError> {
        for (path, file, stem) in &scenes {
            results.push(scene::bench_scene(&plan, path, file, stem, &mut staged)?);
        }
        Ok(())
    })?;
    write_reports(args, &out, threads, plan.repeats, &results, staged)?;
    Ok(report::summary(args, &results))
}

/// Stages `results.csv`, `results.json` and `index.html` next to the scenes' figures in
/// `staged`, and commits them all.
fn write_reports(
    args: &BenchArgs,
    out: &Path,
    threads: usize,
    repeats: u32,
    results: &[SceneResult],
    mut staged: StagedFiles,
) -> Result<(), CliError> {
    let io = |e: String| OutputError::new(out, "--out", e);
    staged.bytes(&out.join("results.csv"), report::csv(results).as_bytes()).map_err(io)?;
    let json = report::json(args, threads, repeats, results);
    staged
        .bytes(&out.join("results.json"), &serde_json::to_vec_pretty(&json).expect("serialises"))
        .map_err(io)?;
    staged.bytes(&out.join("index.html"), html::html(threads, repeats, results).as_bytes()).map_err(io)?;
    Ok(staged.commit().map_err(io)?)
}
