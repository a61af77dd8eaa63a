//! Heat maps of a per-pixel quantity on a log scale, with a legend, as PNG bytes: the
//! render's cost heat map (`--profile`) and the bench report's.

use plotters::prelude::*;

/// Narrowest heat map drawn: a smaller image is scaled up by a whole factor (nearest pixel)
/// so that the legend's labels fit and the map reads on a page.
pub const MIN_WIDTH: u32 = 320;
/// Largest side a heat map is scaled up to.
const MAX_SIDE: u32 = 4096;
/// Legend band under the map, in pixels.
const LEGEND_HEIGHT: u32 = 56;
/// Colour of pixels with no value (no primary hit): outside the ramp.
pub const MISS: [u8; 3] = [40, 110, 160];
/// The ramp, dark to bright (an inferno-like scale: even in lightness, readable in grey).
const RAMP: [[f32; 3]; 5] =
    [[0.0, 0.0, 4.0], [87.0, 16.0, 110.0], [188.0, 55.0, 84.0], [249.0, 142.0, 9.0], [252.0, 255.0, 164.0]];

/// The whole factor a `width` x `height` map is scaled up by to be at least [`MIN_WIDTH`]
/// wide, as far as it stays within `MAX_SIDE` pixels a side (a 1-pixel-wide image 16384
/// high is drawn as it is).
pub fn readable_scale(width: u32, height: u32) -> u32 {
    MIN_WIDTH.div_ceil(width.max(1)).max(1).min((MAX_SIDE / height.max(1)).max(1))
}

/// The ramp's colour at t in [0, 1].
pub fn ramp(t: f64) -> [u8; 3] {
    let x = t.clamp(0.0, 1.0) as f32 * (RAMP.len() - 1) as f32;
    let i = (x as usize).min(RAMP.len() - 2);
    let f = x - i as f32;
    std::array::from_fn(|c| (RAMP[i][c] + f * (RAMP[i + 1][c] - RAMP[i][c])).round() as u8)
}

/// The value range shown: the 0.5th and 99.9th percentiles of the positive values (a few
/// pixels a thread was preempted in do not set the scale; values beyond are clamped), at
/// least a factor 10 apart (a flat image still gets a scale). None when nothing is positive.
pub fn log_range(values: &[Option<f64>]) -> Option<(f64, f64)> {
    let mut positive: Vec<f64> =
        values.iter().flatten().copied().filter(|v| *v > 0.0 && v.is_finite()).collect();
    if positive.is_empty() {
        return None;
    }
    positive.sort_by(f64::total_cmp);
    let at = |q: f64| positive[((positive.len() - 1) as f64 * q).round() as usize];
    let (lo, hi) = (at(0.005), at(0.999));
    Some((lo.min(hi / 10.0), hi))
}

/// Where `v` falls on the log scale [lo, hi], in [0, 1] (0 for values <= lo, including 0).
pub fn log_position(v: f64, (lo, hi): (f64, f64)) -> f64 {
    if v <= lo { 0.0 } else { ((v / lo).ln() / (hi / lo).ln()).clamp(0.0, 1.0) }
}

/// A duration in seconds as a short label: "3 µs", "20 ms", "1.5 s".
pub fn seconds_label(s: f64) -> String {
    let (v, unit) = if s < 1e-6 {
        (s * 1e9, "ns")
    } else if s < 1e-3 {
        (s * 1e6, "µs")
    } else if s < 1.0 {
        (s * 1e3, "ms")
    } else {
        (s, "s")
    };
    if v < 10.0 && (v - v.round()).abs() > 0.05 { format!("{v:.1} {unit}") } else { format!("{v:.0} {unit}") }
}

/// A PNG of `values` (row-major, `width` x `height`; None drawn in [`MISS`]) on a log scale,
/// scaled up to at least [`MIN_WIDTH`], with a legend: the ramp, decade ticks labelled in
/// seconds, `title` and the miss colour. Labels need a font ([`crate::fonts::have_font`]);
/// without one the ramp and ticks are drawn alone.
pub fn log_heat_map_png(
    width: u32,
    height: u32,
    values: &[Option<f64>],
    title: &str,
) -> Result<Vec<u8>, String> {
    assert_eq!(values.len(), width as usize * height as usize);
    let scale = readable_scale(width, height);
    let (w, h) = (width * scale, height * scale + LEGEND_HEIGHT);
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    let range = log_range(values);
    let (ws, wu) = (width as usize, w as usize);
    for y in 0..(height * scale) as usize {
        for x in 0..wu {
            let v = values[(y / scale as usize) * ws + x / scale as usize];
            let c = match (v, range) {
                (None, _) => MISS,
                (Some(v), Some(r)) => ramp(log_position(v, r)),
                (Some(_), None) => ramp(0.0),
            };
            let i = (y * wu + x) * 3;
            buf[i..i + 3].copy_from_slice(&c);
        }
    }
    draw_legend(&mut buf, (w, h), height * scale, range, title)?;
    let mut png = std::io::Cursor::new(Vec::new());
    image::write_buffer_with_format(&mut png, &buf, w, h, image::ColorType::Rgb8, image::ImageFormat::Png)
        .map_err(|e| e.to_string())?;
    Ok(png.into_inner())
}

/// The legend band from row `top` of the `size` buffer down: a ramp with decade ticks.
fn draw_legend(
    buf: &mut [u8],
    size: (u32, u32),
    top: u32,
    range: Option<(f64, f64)>,
    title: &str,
) -> Result<(), String> {
    let (w, _) = size;
    let (x0, x1) = (8i32, w as i32 - 8);
    let (y0, y1) = (top as i32 + 22, top as i32 + 36);
    let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
    let err = |e: DrawingAreaErrorKind<_>| e.to_string();
    for x in x0..x1 {
        let [r, g, b] = ramp((x - x0) as f64 / (x1 - x0 - 1).max(1) as f64);
        root.draw(&PathElement::new(vec![(x, y0), (x, y1)], RGBColor(r, g, b))).map_err(err)?;
    }
    let font = crate::fonts::have_font();
    let text = |s: &str, pos: (i32, i32)| {
        Text::new(s.to_string(), pos, ("sans-serif", 12).into_font().color(&BLACK))
    };
    if font {
        let [r, g, b] = MISS;
        root.draw(&Rectangle::new(
            [(x1 - 10, top as i32 + 4), (x1, top as i32 + 14)],
            RGBColor(r, g, b).filled(),
        ))
        .map_err(err)?;
        root.draw(&text("no hit", (x1 - 52, top as i32 + 4))).map_err(err)?;
        let scale = if range.is_some() { " (log scale)" } else { ": nothing measured" };
        root.draw(&text(&format!("{title}{scale}"), (x0, top as i32 + 4))).map_err(err)?;
    }
    let Some((lo, hi)) = range else { return Ok(()) };
    let mut decade = 10f64.powf(lo.log10().ceil());
    while decade <= hi * 1.0001 {
        let x = x0 + (log_position(decade, (lo, hi)) * (x1 - x0 - 1) as f64).round() as i32;
        // The tick above the ramp, its label centred below it.
        root.draw(&PathElement::new(vec![(x, y0 - 4), (x, y0)], BLACK)).map_err(err)?;
        if font {
            let label = seconds_label(decade);
            let half = 3 * label.chars().count() as i32;
            root.draw(&text(&label, ((x - half).clamp(x0, x1 - 2 * half), y1 + 4))).map_err(err)?;
        }
        decade *= 10.0;
    }
    root.present().map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_positions_and_labels() {
        let r = (1e-6, 1e-3);
        assert_eq!(log_position(1e-6, r), 0.0);
        assert!((log_position(1e-3, r) - 1.0).abs() < 1e-12);
        assert!((log_position(1e-5, r) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(log_position(0.0, r), 0.0);
        assert_eq!(log_range(&[None, Some(0.0), Some(2e-6), Some(5e-4)]), Some((2e-6, 5e-4)));
        assert_eq!(log_range(&[Some(1.0), Some(1.0)]), Some((0.1, 1.0)));
        assert_eq!(log_range(&[None, Some(0.0)]), None);
        assert_eq!(seconds_label(1e-5), "10 µs");
        assert_eq!(seconds_label(2.5e-3), "2.5 ms");
        assert_eq!(seconds_label(3.0), "3 s");
        assert_eq!(ramp(0.0), [0, 0, 4]);
        assert_eq!(ramp(1.0), [252, 255, 164]);
    }

    #[test]
    fn a_small_map_is_scaled_up_and_misses_are_marked() {
        let values = vec![None, Some(1e-6), Some(1e-5), Some(1e-4)];
        let png = log_heat_map_png(2, 2, &values, "t").unwrap();
        let img = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!(img.width(), MIN_WIDTH);
        assert_eq!(img.height(), MIN_WIDTH + LEGEND_HEIGHT);
        assert_eq!(img.get_pixel(0, 0).0, MISS);
        assert_eq!(img.get_pixel(MIN_WIDTH / 2, 0).0, ramp(0.0)); // the smallest value
        assert_eq!(img.get_pixel(MIN_WIDTH - 1, MIN_WIDTH - 1).0, ramp(1.0)); // the largest
    }
}
