//! The frame's files, staged all or nothing: the PNG, the EXR, each light's visibility and
//! `--profile`'s cost images. What `render`, `render --tile` and `merge` write alike.

use crate::cli_error::{CliError, OutputError};
use crate::output::StagedFiles;
use crate::profile;
use glam::Vec3;
use renderer::{Frame, SurfaceAovs};
use std::path::{Path, PathBuf};

/// A frame's pixels as the outputs write them: a whole render's, or a merge's tiles'.
pub struct Pixels<'a> {
    pub width: u32,
    pub height: u32,
    pub radiance: &'a [glam::Vec3],
    /// Per light, as [`renderer::Frame::visibility`].
    pub visibility: &'a [Vec<f32>],
    /// The primary hits' surface (with `--aov`).
    pub surface: Option<&'a SurfaceAovs>,
}

/// The surface AOVs' files beside `PATH.png` (`PATH.<name>.exr`), in the order tiles digest
/// them, and whether each is a colour (RGB) or one value (every channel equal).
pub const SURFACE_LAYERS: [(&str, bool); 4] =
    [("base_color", true), ("metallic", false), ("roughness", false), ("normal", true)];

/// Surface AOV `k` of [`SURFACE_LAYERS`] as RGB pixels.
pub fn surface_layer(s: &SurfaceAovs, k: usize) -> Vec<Vec3> {
    let grey = |v: &[f32]| v.iter().map(|&x| Vec3::splat(x)).collect();
    match k {
        0 => s.base_color.clone(),
        1 => grey(&s.metallic),
        2 => grey(&s.roughness),
        _ => s.normal.clone(),
    }
}

/// Stages the surface AOVs of `s` beside `png` (`rows` rows of `width`). Returns their paths.
pub fn stage_surface(
    png: &Path,
    [width, rows]: [u32; 2],
    s: &SurfaceAovs,
    staged: &mut StagedFiles,
) -> Result<Vec<PathBuf>, CliError> {
    let mut outputs = Vec::new();
    for (k, (name, _)) in SURFACE_LAYERS.iter().enumerate() {
        let path = png.with_extension(format!("{name}.exr"));
        staged
            .exr(&path, width, rows, &surface_layer(s, k))
            .map_err(|e| OutputError::new(png, "--out", e))?;
        outputs.push(path);
    }
    Ok(outputs)
}

/// Creates the folder `png` goes in.
pub fn create_output_folder(png: &Path) -> Result<(), CliError> {
    if let Some(dir) = png.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| OutputError::new(dir, "--out", format!("cannot create the folder: {e}")))?;
    }
    Ok(())
}

/// Stages the PNG, the EXR beside it and, with `aov`, each light's visibility EXR and PNG and
/// the surface AOVs, after creating the output folder. Returns their paths in that order.
pub fn stage_images(
    png: &Path,
    px: &Pixels,
    aov: bool,
    staged: &mut StagedFiles,
) -> Result<Vec<PathBuf>, CliError> {
    let (width, height) = (px.width, px.height);
    // A NaN or an infinity never reaches a file: refuse before anything is staged.
    let exr = png.with_extension("exr");
    crate::output::check_finite(px.radiance).map_err(|e| {
        OutputError::new(&exr, "--out", format!("the radiance overflowed f32 (lights too bright?): {e}"))
    })?;
    create_output_folder(png)?;
    let io = |e: String| OutputError::new(png, "--out", e);
    let mut outputs = vec![png.to_path_buf()];
    staged.png(png, width, height, px.radiance).map_err(io)?;
    staged.exr(&exr, width, height, px.radiance).map_err(io)?;
    outputs.push(exr);
    if aov {
        for (k, vis) in px.visibility.iter().enumerate() {
            let path = png.with_extension(format!("visibility.{k}.exr"));
            let rgb: Vec<glam::Vec3> = vis.iter().map(|&v| glam::Vec3::splat(v)).collect();
            staged.exr(&path, width, height, &rgb).map_err(io)?;
            outputs.push(path);
            // The same as grey for any image viewer: visibility 0..1 as linear grey (so the
            // PNG's sRGB encoding shows it as a viewer shows radiance), misses in blue.
            let path = png.with_extension(format!("visibility.{k}.png"));
            let grey: Vec<glam::Vec3> = vis
                .iter()
                .map(|&v| if v < 0.0 { glam::Vec3::new(0.0, 0.05, 0.35) } else { glam::Vec3::splat(v) })
                .collect();
            staged.png(&path, width, height, &grey).map_err(io)?;
            outputs.push(path);
        }
        if let Some(surface) = px.surface {
            outputs.extend(stage_surface(png, [width, height], surface, staged)?);
        }
    }
    Ok(outputs)
}

/// The pixels no primary ray hits (read off the first light's visibility; none without a
/// light), which the cost heat map marks.
pub fn missed_pixels(frame: &Frame, pixels: usize) -> Vec<bool> {
    match frame.visibility.first() {
        Some(v) => v.iter().map(|&v| v < 0.0).collect(),
        None => vec![false; pixels],
    }
}

/// Stages `--profile`'s images beside `png`: the cost EXR and its heat map (`missed`: the
/// pixels it marks). Returns their paths.
pub fn stage_profile(
    png: &Path,
    [width, height]: [u32; 2],
    costs: &[renderer::util::pixel_cost::PixelCost],
    missed: &[bool],
    staged: &mut StagedFiles,
) -> Result<Vec<PathBuf>, CliError> {
    let (exr, heat) = (png.with_extension("cost.exr"), png.with_extension("cost.png"));
    let exr_bytes =
        profile::cost_exr(width, height, costs, None).map_err(|e| OutputError::new(&exr, "--out", e))?;
    staged.bytes(&exr, &exr_bytes).map_err(|e| OutputError::new(&exr, "--out", e))?;
    let png_bytes =
        profile::cost_png(width, height, costs, missed).map_err(|e| OutputError::new(&heat, "--out", e))?;
    staged.bytes(&heat, &png_bytes).map_err(|e| OutputError::new(&heat, "--out", e))?;
    Ok(vec![exr, heat])
}
