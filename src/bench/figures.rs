//! A scene's figures: the truth's image, each family's best setting's image and error heat
//! map, and the plot of error against cost.

use super::cost::CostSplit;
use super::plot;
use super::report::BestFigures;
use super::truth::Truth;
use crate::heat;
use crate::output::StagedFiles;
use glam::Vec3;
use renderer::util::pixel_cost::PixelCost;
use renderer::{Frame, RenderSettings};
use std::path::Path;

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

/// `rgb` (`width` x `height`) scaled up by a whole factor, nearest pixel, to at least
/// [`heat::MIN_WIDTH`] wide: (pixels, width, height).
fn readable(rgb: &[Vec3], width: u32, height: u32) -> (Vec<Vec3>, u32, u32) {
    let k = heat::readable_scale(width, height);
    let (w, h) = (width * k, height * k);
    let out = (0..h * w).map(|i| rgb[((i / w / k) * width + (i % w) / k) as usize]).collect();
    (out, w, h)
}

/// A family's best setting as run: family, RMSE, setting label, frame, and its profiled
/// render's per-pixel costs with its cost split.
pub(super) struct Best {
    pub family: &'static str,
    pub label: String,
    pub frame: Frame,
    pub costs: Vec<PixelCost>,
    pub split: CostSplit,
}

/// Stages `<stem>/truth.png`, and per family of `best` `<stem>/<family>.png`,
/// `<stem>/<family>.error.png` and `<stem>/<family>.cost.png` (heat maps at least
/// [`heat::MIN_WIDTH`] wide). Returns each family's figures, the files relative to `out`.
pub(super) fn stage_images(
    staged: &mut StagedFiles,
    out: &Path,
    stem: &str,
    settings: &RenderSettings,
    truth: &Truth,
    reach: &[Vec<f32>],
    best: &[Best],
) -> Result<Vec<BestFigures>, String> {
    let (width, height) = (settings.width, settings.height);
    let scene_dir = out.join(stem);
    staged.png(&scene_dir.join("truth.png"), width, height, &truth.radiance)?;
    let missed: Vec<bool> = truth.visibility.first().map_or(vec![], |v| v.iter().map(|&x| x < 0.0).collect());
    let mut figures = Vec::new();
    for b in best {
        let fam = b.family;
        let image = format!("{stem}/{fam}.png");
        let error_map = format!("{stem}/{fam}.error.png");
        let cost_map = format!("{stem}/{fam}.cost.png");
        staged.png(&out.join(&image), width, height, &b.frame.radiance)?;
        let (hm, w, h) = readable(&heat_map(reach, &truth.visibility, &b.frame.visibility), width, height);
        staged.png(&out.join(&error_map), w, h, &hm)?;
        let times: Vec<Option<f64>> = b
            .costs
            .iter()
            .enumerate()
            .map(|(i, c)| (!missed.get(i).copied().unwrap_or(false)).then_some(c.time_s as f64))
            .collect();
        let png = heat::log_heat_map_png(width, height, &times, &format!("{fam}: shading time per pixel"))?;
        staged.bytes(&out.join(&cost_map), &png)?;
        figures.push(BestFigures {
            family: fam.to_string(),
            label: b.label.clone(),
            image,
            error_map,
            cost_map,
            cost_split_s: b.split,
        });
    }
    Ok(figures)
}

/// Stages `plot.png` and `plot.svg` in `scene_dir`. The plot is drawn at once (plotters
/// writes its own files): to temporary names, read back and staged like the rest.
pub(super) fn stage_plot(
    staged: &mut StagedFiles,
    scene_dir: &Path,
    title: &str,
    series: &[plot::Series],
) -> Result<(), String> {
    let tmp_png = scene_dir.join(format!(".plot.{}.png", std::process::id()));
    let tmp_svg = scene_dir.join(format!(".plot.{}.svg", std::process::id()));
    let drawn = plot::draw(title, series, &tmp_png, &tmp_svg);
    let (png_bytes, svg_bytes) = (std::fs::read(&tmp_png), std::fs::read(&tmp_svg));
    let _ = std::fs::remove_file(&tmp_png);
    let _ = std::fs::remove_file(&tmp_svg);
    drawn?;
    for (bytes, name) in [(png_bytes, "plot.png"), (svg_bytes, "plot.svg")] {
        staged.bytes(&scene_dir.join(name), &bytes.map_err(|e| e.to_string())?)?;
    }
    Ok(())
}
