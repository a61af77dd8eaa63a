//! `penumbra merge --out PATH.png TILE.json...`: the tiles of `render --tile` ([`crate::tile`])
//! assembled into the files the single render writes, the same bytes (the report's timings
//! aside). Every tile is read and checked before anything is staged, and the outputs are
//! committed together: a bad set of tiles writes nothing.

use crate::cli_error::{CliError, OutputError};
use crate::frame_files::{Pixels, SURFACE_LAYERS, stage_images, stage_profile};
use crate::output::StagedFiles;
use crate::run_report::{ProfileTotals, RunReport, TileInfo, TileRun, Timings};
use crate::tile::PixelDigest;
use glam::Vec3;

use renderer::load::scene_file::MAX_PRIMARY_SAMPLES;
use renderer::util::pixel_cost::{PixelCost, Work};
use renderer::{FrameTally, SceneError, SurfaceAovs};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `penumbra merge` options.
#[derive(Debug, Clone, clap::Args)]
pub struct MergeArgs {
    /// Output PNG; the EXR, the JSON report and the AOVs the tiles carry go beside it.
    #[arg(long)]
    pub out: PathBuf,
    /// Every tile's report (PATH.json of `render --tile K/N --out PATH.png`), in any order.
    #[arg(required = true, value_name = "TILE.json")]
    pub tiles: Vec<PathBuf>,
    /// No summary on stdout. Warnings and errors still go to stderr.
    #[arg(long)]
    pub quiet: bool,
}

/// One tile: its report's path, the report, and its `tile` section.
struct Tile {
    json: PathBuf,
    report: RunReport,
    info: TileInfo,
}

/// The frame's pixels, assembled from its tiles.
struct Assembled {
    radiance: Vec<Vec3>,
    visibility: Vec<Vec<f32>>,
    /// With `--aov`: the primary hits' surface.
    surface: Option<SurfaceAovs>,
    /// With `--profile`: each pixel's cost, and whether its primary rays all missed.
    costs: Option<(Vec<PixelCost>, Vec<bool>)>,
}

/// Merges `args.tiles` into `args.out` and its siblings; returns the merged report.
pub fn run_merge(args: &MergeArgs) -> Result<RunReport, CliError> {
    let t0 = std::time::Instant::now();
    let png = &args.out;
    if png.extension().and_then(|e| e.to_str()) != Some("png") {
        return Err(SceneError::new(png, "--out", "must name a .png file").into());
    }
    crate::output::check_writable_folder(png.parent().unwrap_or(Path::new("")))
        .map_err(|e| OutputError::new(png, "--out", e))?;
    let mut tiles = args.tiles.iter().map(|p| read_tile(p)).collect::<Result<Vec<_>, _>>()?;
    check_tiles(&tiles)?;
    tiles.sort_by_key(|t| t.info.index);
    let json_path = png.with_extension("json");
    if let Some(t) = tiles.iter().find(|t| same_file(&t.json, &json_path)) {
        return Err(SceneError::new(
            png,
            "--out",
            format!("would overwrite the tile report {}", t.json.display()),
        )
        .into());
    }
    let pixels = assemble(&tiles)?;

    let first = &tiles[0];
    let (width, height) = (first.report.width, first.report.height);
    let mut staged = StagedFiles::default();
    let px = Pixels {
        width,
        height,
        radiance: &pixels.radiance,
        visibility: &pixels.visibility,
        surface: pixels.surface.as_ref(),
    };
    let mut outputs = stage_images(png, &px, first.info.aov, &mut staged)?;
    if let Some((costs, missed)) = &pixels.costs {
        outputs.extend(stage_profile(png, [width, height], costs, missed, &mut staged)?);
    }
    outputs.push(json_path.clone());
    let report = merged_report(&tiles, &outputs, t0.elapsed().as_secs_f64());
    let json = serde_json::to_vec_pretty(&report).expect("the report serialises");
    let io = |e: String| OutputError::new(png, "--out", e);
    staged.bytes(&json_path, &json).map_err(io)?;
    staged.commit().map_err(io)?;
    Ok(report)
}

fn same_file(a: &Path, b: &Path) -> bool {
    a == b || matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
}

/// Reads a tile's report.
fn read_tile(json: &Path) -> Result<Tile, SceneError> {
    let bytes = std::fs::read(json).map_err(|e| SceneError::new(json, "", format!("cannot read: {e}")))?;
    let report: RunReport = serde_json::from_slice(&bytes)
        .map_err(|e| SceneError::new(json, "", format!("not a tile report (truncated?): {e}")))?;
    let Some(info) = report.tile.clone() else {
        return Err(SceneError::new(
            json,
            "tile",
            "a whole render's report, not a tile's (render tiles with --tile K/N)",
        ));
    };
    Ok(Tile { json: json.to_path_buf(), report, info })
}

/// Every tile of one frame, each once: the same scene and settings (the fields a user can
/// read first, then the fingerprint of the files behind them), no tile missing or given twice.
fn check_tiles(tiles: &[Tile]) -> Result<(), SceneError> {
    let first = &tiles[0];
    let expected = identity(first);
    let n = first.info.count;
    // Hand-edited or corrupt numbers are errors, not allocations or divisions by zero.
    let side = renderer::load::scene_file::MAX_IMAGE_SIDE;
    for (key, v, max) in [
        ("width", first.report.width, side),
        ("height", first.report.height, side),
        ("tile.count", n, first.report.height.min(crate::tile::MAX_TILES)),
    ] {
        if v == 0 || v > max {
            return Err(SceneError::new(&first.json, key, format!("must be in 1..={max}, got {v}")));
        }
    }
    let (r, most) = (&first.report, MAX_PRIMARY_SAMPLES);
    if r.width as u64 * r.height as u64 * r.spp as u64 > most {
        return Err(SceneError::new(
            &first.json,
            "spp",
            format!("width x height x spp must be at most {most}"),
        ));
    }
    let mut seen: Vec<Option<&Path>> = vec![None; n as usize];
    for t in tiles {
        for ((key, want), (_, got)) in expected.iter().zip(identity(t)) {
            if *want != got {
                let why = if *key == "tile.fingerprint" {
                    "the scene's files, the method's settings or the penumbra build differ".to_string()
                } else {
                    format!("{got}, but {want} in {}", first.json.display())
                };
                return Err(SceneError::new(&t.json, *key, format!("a tile of another render: {why}")));
            }
        }
        let k = t.info.index;
        if k >= n {
            return Err(SceneError::new(&t.json, "tile.index", format!("{k} is not below tile.count = {n}")));
        }
        let rows = crate::tile::TileSpec { index: k, count: n }.rows(t.report.height);
        if t.info.rows != [rows.start, rows.end] {
            return Err(SceneError::new(&t.json, "tile.rows", format!("not tile {k} of {n}'s rows")));
        }
        if let Some(other) = seen[k as usize] {
            return Err(SceneError::new(
                &t.json,
                "tile.index",
                format!("tile {k} of {n} is given twice (also {})", other.display()),
            ));
        }
        seen[k as usize] = Some(&t.json);
        prepared_alike(t, first)?;
    }
    let missing: Vec<String> =
        seen.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(k, _)| k.to_string()).collect();
    if !missing.is_empty() {
        let list = if missing.len() > 8 {
            format!("{} and {} more", missing[..8].join(", "), missing.len() - 8)
        } else {
            missing.join(", ")
        };
        return Err(SceneError::new(
            &first.json,
            "tile.index",
            format!("tile(s) {list} of {n} missing: give every tile's report"),
        ));
    }
    Ok(())
}

/// Whether `t` prepared as `first` did: the same prepare counters and warnings, and query
/// counters not below them (every tile's `prepare` sees the same frame).
fn prepared_alike(t: &Tile, first: &Tile) -> Result<(), SceneError> {
    let below = t.info.prepare_counters.iter().find(|(k, v)| t.report.counters.get(*k).is_none_or(|c| c < v));
    if let Some((name, _)) = below {
        return Err(SceneError::new(&t.json, format!("counters.{name}"), "below its value after prepare"));
    }
    if (&t.info.scene_warnings, &t.info.method_warnings)
        != (&first.info.scene_warnings, &first.info.method_warnings)
    {
        return Err(SceneError::new(
            &t.json,
            "tile.method_warnings",
            format!("its scene or shadow method warned differently from {}'s", first.json.display()),
        ));
    }
    if t.info.prepare_counters != first.info.prepare_counters {
        return Err(SceneError::new(
            &t.json,
            "tile.prepare_counters",
            format!("its shadow method prepared differently from {}'s", first.json.display()),
        ));
    }
    Ok(())
}

/// What two tiles of one frame share: the settings a user can read, then the fingerprint of
/// the files behind them.
fn identity(t: &Tile) -> [(&'static str, String); 15] {
    let r = &t.report;
    [
        ("method", r.method.clone()),
        ("samples", r.samples.to_string()),
        ("width", r.width.to_string()),
        ("height", r.height.to_string()),
        ("spp", r.spp.to_string()),
        ("max_depth", r.max_depth.to_string()),
        ("shading", r.shading.clone()),
        ("seed", r.seed.to_string()),
        ("lights", r.lights.to_string()),
        ("triangles", r.triangles.to_string()),
        ("degenerate_triangles", r.degenerate_triangles.to_string()),
        ("tile.count", t.info.count.to_string()),
        ("tile.aov", t.info.aov.to_string()),
        ("tile.profile", t.info.profile.to_string()),
        ("tile.fingerprint", t.info.fingerprint.clone()),
    ]
}

/// Reads every tile's pixels (sorted by index) into the frame's buffers.
fn assemble(tiles: &[Tile]) -> Result<Assembled, SceneError> {
    let (first, lights) = (&tiles[0], tiles[0].report.lights);
    let pixels = first.report.width as usize * first.report.height as usize;
    let mut out = Assembled {
        radiance: Vec::with_capacity(pixels),
        visibility: Vec::new(),
        surface: first.info.aov.then(SurfaceAovs::default),
        costs: first.info.profile.then(|| (Vec::with_capacity(pixels), Vec::with_capacity(pixels))),
    };
    for t in tiles {
        // Named as `render --tile` names them beside its report (PATH.png's siblings).
        let base = &t.json;
        let size = (t.report.width as usize, (t.info.rows[1] - t.info.rows[0]) as usize);
        let mut digest = PixelDigest::default();
        let mut rgb = read_channels(&base.with_extension("exr"), size, &["R", "G", "B"])?
            .into_iter()
            .map(Channel::f32s);
        let (r, g, b) = (rgb.next().unwrap(), rgb.next().unwrap(), rgb.next().unwrap());
        let radiance = r.iter().zip(&g).zip(&b).map(|((&r, &g), &b)| Vec3::new(r, g, b));
        let start = out.radiance.len();
        out.radiance.extend(radiance);
        digest.floats(out.radiance[start..].iter().flat_map(|c| c.to_array()));
        // Each light's layer is allocated as its first file is read: a report that claims
        // more lights than there are files fails at the first missing one.
        for k in 0..if first.info.aov { lights } else { 0 } {
            let path = base.with_extension(format!("visibility.{k}.exr"));
            let layer = read_channels(&path, size, &["R"])?.remove(0).f32s();
            digest.floats(layer.iter().copied());
            if out.visibility.len() == k {
                out.visibility.push(Vec::with_capacity(pixels));
            }
            out.visibility[k].extend(layer);
        }
        if let Some(surface) = &mut out.surface {
            read_surface(base, size, surface, &mut digest)?;
        }
        if let Some((costs, missed)) = &mut out.costs {
            let path = base.with_extension("cost.exr");
            let mut c =
                read_channels(&path, size, &["time.Y", "rays.Y", "shafts.Y", "lookups.Y", "missed.Y"])?;
            let counts: Vec<Vec<u32>> = c[1..].iter().map(Channel::u32s).collect();
            let times = c.swap_remove(0).f32s();
            digest.floats(times.iter().copied());
            counts.iter().for_each(|layer| digest.counts(layer.iter().copied()));
            for (i, time_s) in times.into_iter().enumerate() {
                let [rays, shafts, lookups] = [0, 1, 2].map(|j| counts[j][i] as u64);
                costs.push(PixelCost { time_s, work: Work { rays, shafts, lookups, fallbacks: 0 } });
                missed.push(counts[3][i] != 0);
            }
        }
        if digest.hex() != t.info.pixels {
            return Err(SceneError::new(
                &t.json,
                "tile.pixels",
                "the pixel files beside it are not the ones this render wrote (of another render or tile?)",
            ));
        }
    }
    Ok(out)
}

/// Appends a tile's surface AOVs (beside its report `base`, `size` pixels) to `surface`,
/// digesting each as [`crate::tile::digest_surface`] does.
fn read_surface(
    base: &Path,
    size: (usize, usize),
    surface: &mut SurfaceAovs,
    digest: &mut PixelDigest,
) -> Result<(), SceneError> {
    for (name, rgb) in SURFACE_LAYERS {
        let path = base.with_extension(format!("{name}.exr"));
        let names: &[&str] = if rgb { &["R", "G", "B"] } else { &["R"] };
        let c: Vec<Vec<f32>> = read_channels(&path, size, names)?.into_iter().map(Channel::f32s).collect();
        if rgb {
            let pixels: Vec<Vec3> = (0..c[0].len()).map(|i| Vec3::new(c[0][i], c[1][i], c[2][i])).collect();
            digest.floats(pixels.iter().flat_map(|p| p.to_array()));
            let out = if name == "base_color" { &mut surface.base_color } else { &mut surface.normal };
            out.extend(pixels);
        } else {
            digest.floats(c[0].iter().copied());
            let out = if name == "metallic" { &mut surface.metallic } else { &mut surface.roughness };
            out.extend(&c[0]);
        }
    }
    Ok(())
}

/// The named channels of `path`'s first layer, which must be `size` pixels.
fn read_channels(path: &Path, size: (usize, usize), names: &[&str]) -> Result<Vec<Channel>, SceneError> {
    use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
    let bad = |e: String| SceneError::new(path, "", e);
    let image = read_all_flat_layers_from_file(path)
        .map_err(|e| bad(format!("cannot read the tile's pixels: {e}")))?;
    let layer = image.layer_data.first().ok_or_else(|| bad("no layer".into()))?;
    if (layer.size.x(), layer.size.y()) != size {
        let (w, h) = (layer.size.x(), layer.size.y());
        return Err(bad(format!("{w}x{h} pixels, where the tile's report says {}x{}", size.0, size.1)));
    }
    names
        .iter()
        .map(|name| {
            let channel = layer.channel_data.list.iter().find(|c| c.name.to_string() == *name);
            match channel.map(|c| &c.sample_data) {
                Some(FlatSamples::F32(v)) => Ok(Channel::F32(v.clone())),
                Some(FlatSamples::U32(v)) => Ok(Channel::U32(v.clone())),
                _ => Err(bad(format!("no f32 or u32 channel {name}"))),
            }
        })
        .collect()
}

/// A channel's samples as the tiles write them: f32 values or u32 counts.
enum Channel {
    F32(Vec<f32>),
    U32(Vec<u32>),
}

impl Channel {
    fn f32s(self) -> Vec<f32> {
        match self {
            Channel::F32(v) => v,
            Channel::U32(v) => v.into_iter().map(|n| n as f32).collect(),
        }
    }
    fn u32s(&self) -> Vec<u32> {
        match self {
            Channel::F32(v) => v.iter().map(|&x| x as u32).collect(),
            Channel::U32(v) => v.clone(),
        }
    }
}

/// The merged report: the first tile's, with the counters and profile totals summed (what
/// `prepare` counted, once), the frame's warnings from the summed tallies, the timings
/// summed and each tile's kept.
fn merged_report(tiles: &[Tile], outputs: &[PathBuf], merge_s: f64) -> RunReport {
    let first = &tiles[0];
    let prepare = &first.info.prepare_counters;
    let mut counters: BTreeMap<String, u64> = prepare.clone();
    let mut tally = FrameTally::default();
    let mut timings = Timings::default();
    let mut profile: Option<ProfileTotals> = None;
    for t in tiles {
        for (k, v) in &t.report.counters {
            *counters.entry(k.clone()).or_insert(0) += v - prepare.get(k).copied().unwrap_or(0); // checked: not below
        }
        tally.add(&t.info.tally);
        timings.add(&t.report.timings_s);
        if let Some(p) = &t.report.profile {
            profile.get_or_insert_with(ProfileTotals::default).add(p);
        }
    }
    // The merge's own time: reading the tiles and writing the frame.
    timings.write += merge_s;
    timings.total += merge_s;
    let warnings = first
        .info
        .scene_warnings
        .iter()
        .cloned()
        .chain(tally.warnings())
        .chain(first.info.method_warnings.iter().cloned())
        .collect();
    let runs = tiles
        .iter()
        .map(|t| TileRun {
            index: t.info.index,
            rows: t.info.rows,
            threads: t.report.threads,
            timings_s: t.report.timings_s.clone(),
        })
        .collect();
    RunReport {
        threads: tiles.iter().map(|t| t.report.threads).max().unwrap_or(1),
        timings_s: timings,
        profile,
        counters,
        outputs: outputs.iter().map(|p| p.display().to_string()).collect(),
        warnings,
        tile: None,
        tiles: Some(runs),
        ..first.report.clone()
    }
}
