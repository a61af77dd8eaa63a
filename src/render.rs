//! `penumbra render`: the request read and checked ([`crate::request`]), the scene loaded,
//! the frame rendered with one plugin per light, and every output (PNG, EXR, AOVs, the
//! profile, the run report) staged and written together, or nothing.

use crate::cli_error::{CliError, OutputError};
use crate::frame_files::{Pixels, missed_pixels, stage_images, stage_profile};
use crate::output::StagedFiles;
use crate::progress::PhaseProgress;
use crate::request::{Overrides, Request};
use crate::run_report::{RunReport, Timings};
use crate::shadows_config::ShadowsConfig;
use crate::threads::thread_pool_traced;
use crate::{flags, memory, methods, profile, run_report, tile};
use renderer::{
    Frame, KeepInstances, LoadOptions, RenderSettings, Scene, SceneError, SceneFile, SurfaceAovs,
};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `penumbra render` options (the contract's command line).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct RenderArgs {
    /// Scene file (TOML). Without one, the embedded default scene.
    pub scene: Option<PathBuf>,
    /// The values its flags give for scene-file keys (and a study's code-only method).
    #[command(flatten)]
    pub keys: Overrides,
    /// Output PNG; the EXR and JSON report go beside it. Default: out/<scene-stem>.png.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also write each light k's visibility: PATH.visibility.<k>.exr (f32, -1 where nothing
    /// is hit) and PATH.visibility.<k>.png (grey, 8-bit sRGB; misses in blue); and the
    /// primary hits' surface: PATH.base_color.exr (linear RGB), PATH.metallic.exr,
    /// PATH.roughness.exr (grey) and PATH.normal.exr (the shading normal's xyz), each the
    /// mean over the pixel's samples that hit, 0 where none does.
    #[arg(long)]
    pub aov: bool,
    /// Also write where shading time goes: PATH.cost.exr (per pixel: shading time, rays,
    /// shafts, lookups), PATH.cost.png (a heat map of the time, log scale) and
    /// PATH.trace.json (the run's phases as a Chrome trace: open it in https://ui.perfetto.dev
    /// or chrome://tracing). Timing outputs differ from run to run; the others do not.
    #[arg(long)]
    pub profile: bool,
    /// Worker threads (default: all cores). The output bytes do not depend on it.
    #[arg(long, allow_negative_numbers = true, value_parser = flags::whole(1..=1024))]
    pub threads: Option<u32>,
    /// Seed of every random stream.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true, value_parser = flags::seed)]
    pub seed: u64,
    /// No progress bar and no summary on stdout. Warnings and errors still go to stderr.
    #[arg(long)]
    pub quiet: bool,
    /// Render only tile K (0-based) of N, a band of rows, for a farm: writes the tile's
    /// report at PATH.json and its pixels beside it (PATH.exr, and the AOVs and cost layers
    /// when asked; no PNG). `penumbra merge` assembles the tiles into the whole render's
    /// bytes.
    #[arg(long, value_name = "K/N", value_parser = tile::TileSpec::parse)]
    pub tile: Option<tile::TileSpec>,
    /// Code only (no flag): whether to keep instances unflattened, instead of the method's
    /// rule (kept only where the flattened scene does not fit). For tests that compare the
    /// two on scenes that fit.
    #[arg(skip)]
    pub keep_instances: Option<KeepInstances>,
}

/// What a finished render reports back.
#[derive(Debug, Clone)]
pub struct RenderOutcome {
    pub report: RunReport,
    pub png: PathBuf,
}

/// Loads, renders and writes everything `args` asks for. Nothing is written unless all of
/// it succeeds.
pub fn run_render(args: &RenderArgs) -> Result<RenderOutcome, CliError> {
    let t_total = Instant::now();
    let plan = plan_render(args)?;
    let trace = args.profile.then(profile::Trace::start);
    let (threads, pool) = thread_pool_traced(args.threads, &plan.scene_path, trace.as_ref())?;
    let progress = PhaseProgress::new(args.quiet);

    let outcome = pool.install(|| {
        progress.phase("loading the scene and building the BVH", 0);
        // Only methods that trace through the scene's queries render kept instances.
        let keep = args.keep_instances.unwrap_or(match methods::registered(plan.shadows.name()) {
            Some(m) if m.traces_kept_instances => KeepInstances::Shared,
            _ => KeepInstances::Never,
        });
        let options = LoadOptions { memory_limit: memory::available_bytes(), keep };
        let scene = Scene::load_with(&plan.file, &plan.scene_path, options)?;
        let loaded = t_total.elapsed();
        let (frame, surface) = render_frame(&plan, &scene, (args.seed, args.profile, args.aov), &progress)?;
        let png = &plan.png;

        // Outputs: all staged, then committed together.
        progress.phase("writing the outputs", 0);
        let t_write = Instant::now();
        let mut staged = StagedFiles::default();
        let outputs = tracing::info_span!("write").in_scope(|| {
            if plan.tile.is_some() {
                return tile::stage_tile_images(png, &frame, surface.as_ref(), &mut staged);
            }
            let [width, height] = plan.size();
            let px = Pixels {
                width,
                height,
                radiance: &frame.radiance,
                visibility: &frame.visibility,
                surface: surface.as_ref(),
            };
            let mut outputs = stage_images(png, &px, args.aov, &mut staged)?;
            if let Some(costs) = &frame.costs {
                let missed = missed_pixels(&frame, costs.len());
                outputs.extend(stage_profile(png, plan.size(), costs, &missed, &mut staged)?);
            }
            Ok::<_, CliError>(outputs)
        })?;
        Ok::<_, CliError>((scene, frame, surface, staged, outputs, loaded, t_write))
    });
    progress.finish();
    let (scene, frame, surface, mut staged, mut outputs, loaded, t_write) = outcome?;
    drop(pool);
    let io = |e: String| OutputError::new(&plan.png, "--out", e);
    // The trace ends here (every span closed) and is staged with the rest: part of `write`.
    if let Some(trace) = trace {
        let path = plan.png.with_extension("trace.json");
        staged.bytes(&path, &trace.finish()).map_err(io)?;
        outputs.push(path);
    }
    let json_path = plan.png.with_extension("json");
    outputs.push(json_path.clone());
    let phases = Phases { loaded, write: t_write.elapsed(), total: t_total.elapsed() };
    let mut report = build_report(&plan, args.seed, threads, &scene, &frame, &outputs, phases);
    if let Some((spec, fingerprint)) = &plan.tile {
        let (pixels, aov) = (tile::frame_digest(&frame, surface.as_ref()), args.aov);
        report.tile = Some(tile::tile_info(*spec, fingerprint, (aov, args.profile, pixels), &scene, &frame));
        // The frame's own warnings wait for the merge: a tile of sky is not a black image.
        report.warnings = scene.warnings.iter().chain(&frame.method_warnings).cloned().collect();
    }
    let json = serde_json::to_vec_pretty(&report).expect("the report serialises");
    staged.bytes(&json_path, &json).map_err(io)?;
    staged.commit().map_err(io)?;
    Ok(RenderOutcome { report, png: plan.png.clone() })
}

/// The phases the command line times itself: everything up to the loaded scene (reading
/// the scene file, the pool, the glTF files, the BVH), writing the outputs, and the whole.
struct Phases {
    loaded: std::time::Duration,
    write: std::time::Duration,
    total: std::time::Duration,
}

/// What to render and where: the request (the scene file with the command line's overrides,
/// checked), the size it gives, and the outputs.
struct RenderPlan {
    scene_path: PathBuf,
    file: SceneFile,
    shadows: ShadowsConfig,
    png: PathBuf,
    /// `--tile`, and the fingerprint its report carries.
    tile: Option<(tile::TileSpec, String)>,
}

impl RenderPlan {
    /// The image's width and height in pixels.
    fn size(&self) -> [u32; 2] {
        [self.file.image.width, self.file.image.height]
    }
}

/// The request `args` make, checked, and where its outputs go, before anything is loaded or
/// rendered.
fn plan_render(args: &RenderArgs) -> Result<RenderPlan, CliError> {
    let request = Request::read(args.scene.as_deref(), &args.keys)?;
    request.check_frame_size()?;
    let Request { scene_path, embedded, file, shadows, .. } = request;
    // Checked here, before anything is loaded: read again (with the machine's free memory)
    // when the frame begins.
    memory::budget_override()?;
    let png = png_path(args, &scene_path)?;
    let (image, max_depth) = (&file.image, file.integrator.max_depth);
    let (width, height, spp) = (image.width, image.height, image.spp);
    let mut plan = RenderPlan { scene_path, file, shadows, png, tile: None };
    if let Some(spec) = args.tile {
        spec.check(height, &plan.scene_path)?;
        let fingerprint = tile::fingerprint(&tile::FingerprintInputs {
            scene_path: &plan.scene_path,
            embedded,
            file: &plan.file,
            method: format!("{:?}", plan.shadows.method()),
            samples: plan.shadows.samples,
            size: [width, height, spp, max_depth],
            seed: args.seed,
            count: spec.count,
            aov: args.aov,
            profile: args.profile,
        })?;
        plan.tile = Some((spec, fingerprint));
    }
    Ok(plan)
}

/// The PNG to write: `--out`, or else out/<scene-stem>.png.
fn png_path(args: &RenderArgs, scene_path: &Path) -> Result<PathBuf, CliError> {
    let png = match &args.out {
        Some(p) => p.clone(),
        None => {
            let stem =
                scene_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or("render".into());
            PathBuf::from("out").join(format!("{stem}.png"))
        }
    };
    if png.extension().and_then(|e| e.to_str()) != Some("png") {
        return Err(SceneError::new(&png, "--out", "must name a .png file").into());
    }
    // Before the render, not after it (the files themselves are still written all or
    // nothing, at the end).
    let folder = png.parent().unwrap_or(Path::new(""));
    crate::output::check_writable_folder(folder).map_err(|e| OutputError::new(&png, "--out", e))?;
    Ok(png)
}

/// Renders `scene` with one of `plan`'s shadow methods per light, each phase shown on
/// `progress`; with `aov`, also the surface AOVs of the rows rendered, their pass counted in
/// the frame's `render` time (it casts primary rays).
fn render_frame(
    plan: &RenderPlan,
    scene: &Scene,
    (seed, profile, aov): (u64, bool, bool),
    progress: &PhaseProgress,
) -> Result<(Frame, Option<SurfaceAovs>), CliError> {
    let mut methods: Vec<_> = scene.lights.iter().map(|_| plan.shadows.build()).collect();
    let memory_budget_bytes = memory::memory_budget_bytes()?;
    let [width, height] = plan.size();
    let settings = RenderSettings {
        width,
        height,
        spp: plan.file.image.spp,
        seed,
        memory_budget_bytes,
        profile,
        max_depth: plan.file.integrator.max_depth,
    };
    let rows = plan.tile.as_ref().map_or(0..height, |(t, _)| t.rows(height));
    let mut frame =
        renderer::render_rows(scene, &mut methods, &settings, rows.clone(), &|p| progress.report(p))
            .map_err(|e| SceneError::new(&plan.scene_path, "shadows", e.to_string()))?;
    let surface = aov.then(|| {
        let t = Instant::now();
        let surface = renderer::surface_aovs(scene, &settings, rows);
        frame.render += t.elapsed();
        surface
    });
    Ok((frame, surface))
}

/// The run's report; `outputs` lists every file written (the report last), `t_total` is
/// when the run began.
fn build_report(
    plan: &RenderPlan,
    seed: u64,
    threads: usize,
    scene: &Scene,
    frame: &Frame,
    outputs: &[PathBuf],
    phases: Phases,
) -> RunReport {
    RunReport {
        scene: plan.scene_path.display().to_string(),
        method: plan.shadows.name().to_string(),
        samples: plan.shadows.samples,
        width: plan.file.image.width,
        height: plan.file.image.height,
        spp: plan.file.image.spp,
        max_depth: plan.file.integrator.max_depth,
        shading: plan.file.materials.shading.name().to_string(),
        threads,
        seed,
        lights: scene.lights.len(),
        triangles: scene.stats.triangles,
        unique_triangles: scene.unique_triangles(),
        instances: scene.instances.len() as u64,
        kept_instances: scene.kept_instances(),
        degenerate_triangles: scene.stats.degenerate_triangles,
        timings_s: Timings {
            // Everything before the BVH build counts as loading (the scene file, the pool,
            // the glTF files, the f32 conversion).
            load: (phases.loaded - scene.stats.bvh).as_secs_f64(),
            bvh: scene.stats.bvh.as_secs_f64(),
            visible_points: frame.visible_points.as_secs_f64(),
            shadow_prepare: frame.shadow_prepare.as_secs_f64(),
            render: frame.render.as_secs_f64(),
            write: phases.write.as_secs_f64(),
            total: phases.total.as_secs_f64(),
        },
        profile: frame.costs.as_deref().map(|c| run_report::ProfileTotals::of(c, &frame.vertex_queries)),
        counters: frame.counters.clone(),
        outputs: outputs.iter().map(|p| p.display().to_string()).collect(),
        warnings: scene.warnings.iter().chain(&frame.warnings).cloned().collect(),
        tile: None,
        tiles: None,
    }
}
