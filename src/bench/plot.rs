//! Error against shadow cost, log-log, one line per method family, the Pareto front marked:
//! a PNG (and the same plot as SVG) per scene, drawn with plotters.
//!
//! Text needs a font: plotters is built without its system-font loader (which needs
//! fontconfig's C library at build time), so the first font found among `PENUMBRA_FONT` and
//! a few usual system paths is registered at run time. Without one the plots are drawn
//! without text, and the HTML report's captions name the axes.

use crate::fonts::have_font;
use crate::methods::{Registered, find_in};
use plotters::prelude::*;
use std::path::Path;

/// One method family's points: (shadow cost in s, visibility RMSE).
pub struct Series<'a> {
    pub family: &'a str,
    pub style: Style,
    pub points: Vec<(f64, f64)>,
}

/// How a family is drawn: its colour (fixed, so every scene's plot reads the same), and
/// whether its points are joined into a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Style {
    pub colour: [u8; 3],
    pub line: bool,
}

/// The style `methods` registers for `family` ([`renderer::MethodEntry::COLOUR`] and
/// [`renderer::MethodEntry::PLOT_LINE`]); a family not registered: purple points.
pub fn style(methods: &[Registered], family: &str) -> Style {
    find_in(methods, family).map_or(Style { colour: [148, 103, 189], line: false }, |m| Style {
        colour: m.colour,
        line: m.plot_line,
    })
}

/// The points that can be drawn on log axes: finite errors (NaN means no lit pixel), a
/// cost at or below zero (within the noise of the `none` baseline) or a zero error drawn
/// at the axis' floor.
fn finite(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    points
        .iter()
        .filter(|(c, e)| c.is_finite() && e.is_finite())
        .map(|&(c, e)| (c.max(1e-4), e.max(1e-4)))
        .collect()
}

/// Indices (into the flattened points, family by family) of the points no other point beats
/// on both cost and error.
pub fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0).then(points[a].1.total_cmp(&points[b].1)));
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// Draws the plot for one scene to `png` (width x height pixels) and `svg`.
pub fn draw(title: &str, series: &[Series], png: &Path, svg: &Path) -> Result<(), String> {
    let (w, h) = (900u32, 600u32);
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        chart(&root, title, series).map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    image::save_buffer_with_format(png, &rgb, w, h, image::ColorType::Rgb8, image::ImageFormat::Png)
        .map_err(|e| format!("{}: {e}", png.display()))?;
    let root = SVGBackend::new(svg, (w, h)).into_drawing_area();
    chart(&root, title, series).map_err(|e| e.to_string())?;
    root.present().map_err(|e| format!("{}: {e}", svg.display()))
}

fn chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    series: &[Series],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let all: Vec<(f64, f64)> = series.iter().flat_map(|s| finite(&s.points)).collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for &(c, e) in &all {
        (x0, x1, y0, y1) = (x0.min(c), x1.max(c), y0.min(e), y1.max(e));
    }
    if all.is_empty() {
        (x0, x1, y0, y1) = (1e-3, 1.0, 1e-3, 1.0);
    }
    // Each axis starts at a power of ten (plotters labels a log axis only at decade-based
    // ticks, so a range inside one decade could show none); the error axis gets headroom
    // for the legend.
    let decade_below = |v: f64| 10f64.powf((v / 1.5).log10().floor());
    let (x0, x1, y0, y1) = (decade_below(x0), x1 * 1.5, decade_below(y0), y1 * 4.0);
    let text = have_font();
    let mut builder = ChartBuilder::on(root);
    builder.margin(20).x_label_area_size(if text { 45 } else { 10 }).y_label_area_size(if text {
        70
    } else {
        10
    });
    if text {
        builder.caption(title, ("sans-serif", 22));
    }
    let mut chart = builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("shadow cost (s): shadow_prepare + render time above `none`")
            .y_desc("visibility RMSE against the truth")
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .label_style(("sans-serif", 14));
    } else {
        mesh.disable_x_mesh().disable_y_mesh().x_labels(0).y_labels(0);
    }
    mesh.draw()?;
    for s in series {
        let [r, g, b] = s.style.colour;
        let c = RGBColor(r, g, b);
        let mut pts = finite(&s.points);
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        // A family of one parameter (traced's N) is a curve; the other families' settings
        // differ in several ways at once, so they are points, not a line.
        let line = if s.style.line {
            chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
        } else {
            chart.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
        };
        if text {
            line.label(s.family)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        }
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
    }
    // The Pareto front: black rings on its points and a dashed staircase through them.
    let front = pareto(&all);
    let mut front_pts: Vec<(f64, f64)> = front.iter().map(|&i| all[i]).collect();
    front_pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart.draw_series(front_pts.iter().map(|&p| Circle::new(p, 8, BLACK.stroke_width(2))))?;
    chart.draw_series(DashedLineSeries::new(staircase(&front_pts), 6, 4, BLACK.stroke_width(1)))?;
    if text {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .position(SeriesLabelPosition::UpperRight)
            .draw()?;
    }
    Ok(())
}

/// The corners of a staircase through `points` (sorted by cost): from each point level to
/// the next one's cost, then to it.
fn staircase(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut stairs = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        if i > 0 {
            stairs.push((p.0, points[i - 1].1));
        }
        stairs.push(p);
    }
    stairs
}

/// A log axis's tick value without float noise (0.30000000000000004 prints as 0.3).
fn tick_label(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".to_string() } else { s.to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_have_no_float_noise() {
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(10.0), "10");
        assert_eq!(tick_label(0.001), "0.001");
        assert_eq!(tick_label(2.5e-7), "0");
        assert_eq!(tick_label(-2.5e-7), "0");
    }

    #[test]
    fn each_method_keeps_its_colour() {
        let methods = crate::methods::METHODS;
        let colour = |family: &str| style(methods, family).colour;
        assert_eq!(colour("traced"), [90, 90, 90]);
        assert_eq!(colour("edge_table"), [214, 39, 40]);
        assert_eq!(colour("pcss"), [44, 160, 44]);
        assert_eq!(colour("none"), [148, 103, 189]);
        assert_eq!(colour("unregistered"), [148, 103, 189]);
        // Curves: the families of one parameter (N), as each method's entry says.
        for m in methods {
            assert_eq!(style(methods, m.name).line, m.plot_line, "{}", m.name);
        }
        assert!(style(methods, "traced").line);
        for family in ["edge_table", "pcss"] {
            assert!(!style(methods, family).line, "{family} is points, not a curve");
        }
    }

    #[test]
    fn the_pareto_front_keeps_only_undominated_points() {
        // (cost, error): b beats a on both; c is cheaper than b but worse; d is dominated
        // by c; e is the most accurate.
        let pts = [(1.0, 0.5), (0.8, 0.3), (0.1, 0.6), (0.2, 0.7), (5.0, 0.01)];
        assert_eq!(pareto(&pts), vec![2, 1, 4]);
    }
}
