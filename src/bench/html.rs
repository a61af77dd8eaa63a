//! The HTML report, `index.html`: per scene the plot, the table and the images side by side.

use super::report::{SceneResult, speedup_text};
use std::fmt::Write as _;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The HTML report: per scene the plot, the table and the images side by side.
pub(super) fn html(threads: usize, repeats: u32, results: &[SceneResult]) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>penumbra bench</title>\n<style>\
body{{font-family:sans-serif;margin:2em;max-width:1400px}}table{{border-collapse:collapse;font-size:13px}}\
td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}td:first-child,th:first-child{{text-align:left}}\
tr.default{{background:#fde}}figure{{display:inline-block;margin:4px;vertical-align:top}}\
figcaption{{font-size:12px;max-width:330px}}img.px{{image-rendering:pixelated}}img.plot{{max-width:900px;width:100%}}\
span.bar{{display:inline-flex;height:16px;border:1px solid #999}}span.bar span{{display:inline-block;height:16px}}\
span.key{{display:inline-block;width:10px;height:10px;margin-right:3px}}div.best{{margin-top:8px}}</style></head><body>\n\
<h1>penumbra bench</h1>\n<p>{} scene(s), {} thread(s), median of {} run(s) per setting. Shadow cost = \
shadow_prepare + render time above <code>none</code>. Errors are against <code>traced</code> at the truth's \
sample count, over the pixels each light reaches. Data: <a href=\"results.csv\">results.csv</a>, \
<a href=\"results.json\">results.json</a>. Error heat maps: |visibility error|, black 0 to white &ge; 0.5. \
Cost heat maps: each pixel's shading time (a profiled run of the best setting), log scale. Bars: the \
shadow cost split into prepare, table lookups, traced rays, shaft tests and the rest, the middle three by a \
least-squares fit of the pixels' times on their counts.</p>\n",
        results.len(),
        threads,
        repeats
    );
    for r in results {
        scene_head(&mut h, r);
        table(&mut h, r);
        images(&mut h, r);
    }
    h.push_str("</body></html>\n");
    h
}

/// A scene's heading: its file, size, truth and equal-error speedup, and its plot.
fn scene_head(h: &mut String, r: &SceneResult) {
    let _ = write!(
        h,
        "<h2>{}</h2>\n<p>{} ({} triangles), {}x{}, truth: traced N={}{}. Equal-error speedup of \
{} (default, highlighted): on visibility RMSE {}; on the image's relative RMSE {}; on penumbra RMSE {}.</p>\n<p><img class=\"plot\" src=\"{}/plot.png\" alt=\"{} plot\"><br>\
<small>x: shadow cost (s), y: visibility RMSE, both log; a line per method; the Pareto front ringed \
(<a href=\"{}/plot.svg\">SVG</a>).</small></p>\n",
        esc(&r.stem),
        esc(&r.path),
        r.triangles,
        r.width,
        r.height,
        r.truth_samples,
        if r.truth_cached { ", from the cache" } else { "" },
        esc(r.headline.unwrap_or("the headline setting")),
        esc(&speedup_text(&r.speedup, r.headline)),
        esc(&speedup_text(&r.speedup_image, r.headline)),
        esc(&speedup_text(&r.speedup_penumbra, r.headline)),
        esc(&r.stem),
        esc(&r.stem),
        esc(&r.stem)
    );
}

/// A scene's table, a line per setting (the headline, `edge_table`'s default, highlighted),
/// and the settings skipped.
fn table(h: &mut String, r: &SceneResult) {
    h.push_str(
        "<table><tr><th>setting</th><th>shadow cost (s)</th><th>prepare (s)</th><th>render (s)</th>\
<th>RMSE</th><th>penumbra RMSE</th><th>p99</th><th>max</th><th>leak</th><th>false shadow</th>\
<th>image rel. RMSE</th><th>rays traced</th><th>lookups / point</th><th>prepare share</th>\
<th>peak RSS (MiB)</th><th>method (MiB)</th></tr>\n",
    );
    for row in &r.rows {
        let e = &row.errors;
        let _ = writeln!(
            h,
            "<tr{}><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.4}</td><td>{:.4}</td>\
<td>{:.3}</td><td>{:.3}</td><td>{:.2}%</td><td>{:.3}%</td><td>{:.4}</td><td>{:.1}%</td><td>{:.0}</td>\
<td>{:.1}%</td><td>{:.0}</td><td>{:.1}</td></tr>",
            if row.headline { " class=\"default\"" } else { "" },
            esc(&row.setting),
            row.shadow_cost_s,
            row.shadow_prepare_s,
            row.render_s,
            e.rmse,
            e.penumbra_rmse,
            e.p99,
            e.max,
            100.0 * e.leak_rate,
            100.0 * e.false_shadow_rate,
            e.image_relative_rmse,
            100.0 * row.traced_ray_share,
            row.lookups_per_query,
            100.0 * row.prepare_share,
            row.peak_rss_mib,
            row.method_mib
        );
    }
    h.push_str("</table>\n");
    if !r.skipped.is_empty() {
        let _ = writeln!(h, "<p>Skipped: {}.</p>", esc(&r.skipped.join("; ")));
    }
}

/// A scene's images: the truth, and per family its best setting's image, error heat map
/// and cost heat map side by side, and a bar splitting its shadow cost.
fn images(h: &mut String, r: &SceneResult) {
    // Every image of a scene is rendered at the bench's resolution (64 wide with --quick) and
    // shown 320 wide, pixels kept sharp: the truth used to be shown at its own size, so at
    // 64x48 it looked like a thumbnail rendered smaller than the rest.
    let enlarged = if r.width < 320 { ", shown enlarged" } else { "" };
    let _ = writeln!(
        h,
        "<div><figure><img class=\"px\" src=\"{0}/truth.png\" alt=\"truth\" width=\"320\"><figcaption>truth \
(traced N={1}): {2}x{3} pixels, the bench's resolution{4}</figcaption></figure></div>",
        esc(&r.stem),
        r.truth_samples,
        r.width,
        r.height,
        enlarged
    );
    // The bars share one scale per scene: the costliest method's shadow cost.
    let widest =
        r.best.iter().map(|b| b.cost_split_s.parts().iter().map(|p| p.1).sum::<f64>()).fold(0.0, f64::max);
    for b in &r.best {
        let _ = writeln!(
            h,
            "<div class=\"best\"><figure><img class=\"px\" src=\"{}\" alt=\"{}\" width=\"320\"><figcaption>{} (best {})</figcaption></figure>\
<figure><img src=\"{}\" alt=\"{} error\" width=\"320\"><figcaption>{}: |visibility error|</figcaption></figure>\
<figure><img src=\"{}\" alt=\"{} cost\" width=\"320\"><figcaption>{}: shading time per pixel, log scale</figcaption></figure>",
            esc(&b.image),
            esc(&b.family),
            esc(&b.label),
            esc(&b.family),
            esc(&b.error_map),
            esc(&b.family),
            esc(&b.label),
            esc(&b.cost_map),
            esc(&b.family),
            esc(&b.label)
        );
        bar(h, b, widest);
        h.push_str("</div>\n");
    }
}

/// Colours of the cost split's parts, in [`CostSplit::parts`] order.
const PART_COLOURS: [&str; 5] = ["#6a51a3", "#e6550d", "#3182bd", "#31a354", "#bbbbbb"];

/// A horizontal bar of `b`'s shadow cost split, `widest` seconds spanning 600 px.
fn bar(h: &mut String, b: &super::report::BestFigures, widest: f64) {
    let parts = b.cost_split_s.parts();
    let total: f64 = parts.iter().map(|p| p.1).sum();
    let _ = write!(
        h,
        "<p class=\"bar\"><b>{}</b> shadow cost {:.3} s:<br><span class=\"bar\">",
        esc(&b.family),
        total
    );
    for ((name, secs), colour) in parts.iter().zip(PART_COLOURS) {
        let px = if widest > 0.0 { 600.0 * secs / widest } else { 0.0 };
        let _ = write!(
            h,
            "<span style=\"width:{px:.1}px;background:{colour}\" title=\"{name}: {secs:.3} s\"></span>"
        );
    }
    h.push_str("</span><br><small>");
    let legend: Vec<String> = parts
        .iter()
        .zip(PART_COLOURS)
        .map(|((name, secs), colour)| {
            format!("<span class=\"key\" style=\"background:{colour}\"></span>{name} {secs:.3} s")
        })
        .collect();
    h.push_str(&legend.join(" &nbsp; "));
    h.push_str("</small></p>\n");
}
