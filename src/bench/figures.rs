//! A scene's figures: the truth's image, each family's best setting's image and error heat
//! map, and the plot of error against cost.

use super::plot;
use super::truth::Truth;
use glam::Vec3;
use renderer::output::StagedFiles;
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

/// Stages `<stem>/truth.png`, and per family of `best` (family, RMSE, setting label, frame)
/// `<stem>/<family>.png` and `<stem>/<family>.error.png`. Returns per family (family,
/// setting label, image file, heat-map file), the files relative to `out`.
pub(super) fn stage_images(
    staged: &mut StagedFiles,
    out: &Path,
    stem: &str,
    settings: &RenderSettings,
    truth: &Truth,
    reach: &[Vec<f32>],
    best: &[(&'static str, f64, String, Frame)],
) -> Result<Vec<(String, String, String, String)>, String> {
    let (width, height) = (settings.width, settings.height);
    let scene_dir = out.join(stem);
    staged.png(&scene_dir.join("truth.png"), width, height, &truth.radiance)?;
    let mut best_files = Vec::new();
    for (fam, _, label, frame) in best {
        let img = format!("{stem}/{fam}.png");
        let heat = format!("{stem}/{fam}.error.png");
        staged.png(&out.join(&img), width, height, &frame.radiance)?;
        let hm = heat_map(reach, &truth.visibility, &frame.visibility);
        staged.png(&out.join(&heat), width, height, &hm)?;
        best_files.push((fam.to_string(), label.clone(), img, heat));
    }
    Ok(best_files)
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
