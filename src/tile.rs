//! `render --tile K/N`: one band of a frame's rows, written so that `penumbra merge`
//! ([`crate::merge`]) gives back the whole render's bytes.
//!
//! Tiles are bands of whole rows, tile K holding rows `[K H / N, (K + 1) H / N)`: every
//! output is row-major and every pixel a pure function of (scene, settings, seed), so a band
//! is a contiguous slice of each buffer, and an EXR of the band's scanlines round-trips its
//! f32 exactly. A tile writes `PATH.exr` (its radiance), with `--aov` each light's
//! `PATH.visibility.<k>.exr` and the surface AOVs, with `--profile` `PATH.cost.exr` (plus a `missed.Y` layer: the
//! heat map marks misses) and `PATH.trace.json`, and its report `PATH.json`. No PNG: 8-bit
//! sRGB would lose what the merge needs.

use crate::cli_error::{CliError, OutputError};
use crate::output::StagedFiles;
use glam::Vec3;
use renderer::{Frame, SceneError, SceneFile, SurfaceAovs};
use std::hash::{DefaultHasher, Hasher};
use std::path::{Path, PathBuf};

/// Which tile of how many (`--tile K/N`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileSpec {
    pub index: u32,
    pub count: u32,
}

/// Most tiles a frame may be split into.
pub const MAX_TILES: u32 = 65536;

impl TileSpec {
    /// Parses `K/N` (0 <= K < N): clap's value parser for `--tile`.
    pub fn parse(text: &str) -> Result<TileSpec, String> {
        let bad = || format!("expected K/N, tile K (0-based) of N, such as 3/16; got \"{text}\"");
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (index, count) =
            (k.trim().parse::<u32>().map_err(|_| bad())?, n.trim().parse::<u32>().map_err(|_| bad())?);
        if count == 0 || count > MAX_TILES {
            return Err(format!("N must be in 1..={MAX_TILES}, got {count}"));
        }
        if index >= count {
            return Err(format!("K is 0-based and must be below N = {count}, got {index}"));
        }
        Ok(TileSpec { index, count })
    }

    /// The rows of a `height`-row frame this tile holds. Needs `count <= height` (checked
    /// by [`TileSpec::check`]), so that no tile is empty.
    pub fn rows(&self, height: u32) -> std::ops::Range<u32> {
        let at = |k: u32| (k as u64 * height as u64 / self.count as u64) as u32;
        at(self.index)..at(self.index + 1)
    }

    /// Refuses more tiles than the frame has rows.
    pub fn check(&self, height: u32, scene_path: &Path) -> Result<(), SceneError> {
        if self.count > height {
            return Err(SceneError::new(
                scene_path,
                "--tile",
                format!("{} tiles of a {height}-row image: at most one tile per row", self.count),
            ));
        }
        Ok(())
    }
}

/// The settings that change a tile's pixels, beside the scene's files.
pub struct FingerprintInputs<'a> {
    pub scene_path: &'a Path,
    /// The scene file's text when it is not read from `scene_path` (the embedded default).
    pub embedded: Option<&'a str>,
    pub file: &'a SceneFile,
    /// The chosen method's settings, code-only fields included (their `Debug` form).
    pub method: String,
    pub samples: u32,
    pub size: [u32; 4],
    pub seed: u64,
    pub count: u32,
    pub aov: bool,
    pub profile: bool,
}

/// A hex hash of the scene's files (the scene file, each model's glTF, buffers and images),
/// the pixel-changing settings (size, spp, depth, seed, method and its settings, samples,
/// material shading, tile count, AOVs) and the program's version. Threads are left out: they change no byte.
/// Std's SipHash: stable within one build, which is what one farm's tiles share; tiles of
/// two builds may refuse to merge, the safe side.
pub fn fingerprint(f: &FingerprintInputs) -> Result<String, CliError> {
    let mut h = DefaultHasher::new();
    let mut write = |bytes: &[u8]| {
        // Length-prefixed, so that no two lists of inputs hash the same bytes.
        h.write_usize(bytes.len());
        h.write(bytes);
    };
    write(concat!("penumbra ", env!("CARGO_PKG_VERSION")).as_bytes());
    let read = |p: &Path| {
        std::fs::read(p)
            .map_err(|e| SceneError::new(p, "--tile", format!("cannot read for the fingerprint: {e}")))
    };
    match f.embedded {
        Some(text) => write(text.as_bytes()),
        None => write(&read(f.scene_path)?),
    }
    for model in &f.file.model {
        for path in crate::scene_files::model_files(&SceneFile::resolve(f.scene_path, &model.path)) {
            write(&read(&path)?);
        }
    }
    write(f.method.as_bytes());
    // A flag may change it (`--shading`); the scene file's bytes alone would not say.
    write(f.file.materials.shading.name().as_bytes());
    let numbers = [f.samples as u64, f.size[0] as u64, f.size[1] as u64, f.size[2] as u64, f.size[3] as u64];
    for v in numbers.into_iter().chain([f.seed, f.count as u64, f.aov as u64, f.profile as u64]) {
        write(&v.to_le_bytes());
    }
    Ok(format!("{:016x}", h.finish()))
}

/// A hash of a tile's pixels as its files hold them (the radiance, each visibility layer, the
/// cost layers), kept in its report: the merge hashes what it reads in the same order, so a
/// file of another render or another tile beside the report is refused.
pub struct PixelDigest(DefaultHasher);

impl Default for PixelDigest {
    fn default() -> Self {
        PixelDigest(DefaultHasher::new())
    }
}

impl PixelDigest {
    pub fn floats(&mut self, values: impl Iterator<Item = f32>) {
        values.for_each(|v| self.0.write_u32(v.to_bits()));
    }
    pub fn counts(&mut self, values: impl Iterator<Item = u32>) {
        values.for_each(|v| self.0.write_u32(v));
    }
    pub fn hex(&self) -> String {
        format!("{:016x}", self.0.finish())
    }
}

/// The digest of `frame`'s pixels (and the surface AOVs, `--aov`'s) as
/// [`stage_tile_images`] writes them.
pub fn frame_digest(frame: &Frame, surface: Option<&SurfaceAovs>) -> String {
    let mut d = PixelDigest::default();
    d.floats(frame.radiance.iter().flat_map(|c| c.to_array()));
    for vis in frame.visibility.iter().filter(|_| surface.is_some()) {
        d.floats(vis.iter().copied());
    }
    if let Some(s) = surface {
        digest_surface(&mut d, s);
    }
    if let Some(costs) = &frame.costs {
        d.floats(costs.iter().map(|c| c.time_s));
        let clamp = |n: u64| n.min(u32::MAX as u64) as u32;
        d.counts(costs.iter().map(|c| clamp(c.work.rays)));
        d.counts(costs.iter().map(|c| clamp(c.work.shafts)));
        d.counts(costs.iter().map(|c| clamp(c.work.lookups)));
        d.counts(crate::frame_files::missed_pixels(frame, costs.len()).into_iter().map(u32::from));
    }
    d.hex()
}

/// Adds the surface AOVs to a digest, as their files hold them (RGB or one channel).
pub fn digest_surface(d: &mut PixelDigest, s: &SurfaceAovs) {
    for (k, (_, rgb)) in crate::frame_files::SURFACE_LAYERS.iter().enumerate() {
        let layer = crate::frame_files::surface_layer(s, k);
        if *rgb {
            d.floats(layer.iter().flat_map(|c| c.to_array()));
        } else {
            d.floats(layer.iter().map(|c| c.x));
        }
    }
}

/// Stages a tile's pixels beside `png` (which is not written): the radiance EXR and, as
/// asked, the AOVs (`surface` given with `--aov`) and the cost layers. Returns their paths.
pub fn stage_tile_images(
    png: &Path,
    frame: &Frame,
    surface: Option<&SurfaceAovs>,
    staged: &mut StagedFiles,
) -> Result<Vec<PathBuf>, CliError> {
    let (width, rows) = (frame.width, frame.rows.len() as u32);
    let exr = png.with_extension("exr");
    crate::output::check_finite(&frame.radiance).map_err(|e| {
        OutputError::new(&exr, "--out", format!("the radiance overflowed f32 (lights too bright?): {e}"))
    })?;
    crate::frame_files::create_output_folder(png)?;
    let io = |e: String| OutputError::new(png, "--out", e);
    staged.exr(&exr, width, rows, &frame.radiance).map_err(io)?;
    let mut outputs = vec![exr];
    if let Some(surface) = surface {
        for (k, vis) in frame.visibility.iter().enumerate() {
            let path = png.with_extension(format!("visibility.{k}.exr"));
            let rgb: Vec<Vec3> = vis.iter().map(|&v| Vec3::splat(v)).collect();
            staged.exr(&path, width, rows, &rgb).map_err(io)?;
            outputs.push(path);
        }
        outputs.extend(crate::frame_files::stage_surface(png, [width, rows], surface, staged)?);
    }
    if let Some(costs) = &frame.costs {
        let path = png.with_extension("cost.exr");
        let missed = crate::frame_files::missed_pixels(frame, costs.len());
        let bytes = crate::profile::cost_exr(width, rows, costs, Some(&missed))
            .map_err(|e| SceneError::new(&path, "", e))?;
        staged.bytes(&path, &bytes).map_err(io)?;
        outputs.push(path);
    }
    Ok(outputs)
}

/// The `tile` section of a tile's report; `pixels` is the digest of its pixels
/// ([`frame_digest`]).
pub fn tile_info(
    spec: TileSpec,
    fingerprint: &str,
    (aov, profile, pixels): (bool, bool, String),
    scene: &renderer::Scene,
    frame: &Frame,
) -> crate::run_report::TileInfo {
    crate::run_report::TileInfo {
        index: spec.index,
        count: spec.count,
        rows: [frame.rows.start, frame.rows.end],
        fingerprint: fingerprint.to_string(),
        pixels,
        aov,
        profile,
        prepare_counters: frame.prepare_counters.clone(),
        tally: frame.tally.clone(),
        scene_warnings: scene.warnings.clone(),
        method_warnings: frame.method_warnings.clone(),
    }
}
