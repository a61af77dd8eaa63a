//! What the bench reports: a [`Row`] per setting and a [`SceneResult`] per scene, the CSV
//! and JSON files of them, the equal-error speedup ([`Speedup`]) and the summary on stdout.

use super::BenchArgs;
use super::metrics::Errors;
use serde::Serialize;
use std::fmt::Write as _;

/// One row of results: a setting on a scene.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    pub scene: String,
    pub method: String,
    pub setting: String,
    pub samples: u32,
    /// The headline setting's row ([`renderer::SweepSetting::headline`]). The column is
    /// `headline` in the CSV and JSON.
    pub headline: bool,
    /// A reference of the equal-error speedup ([`renderer::SweepSetting::reference`]).
    #[serde(skip)]
    pub reference: bool,
    pub width: u32,
    pub height: u32,
    pub repeats: u32,
    /// Medians over the repeats, seconds.
    pub shadow_prepare_s: f64,
    pub render_s: f64,
    /// Scene load + BVH build (once per scene) + shadow_prepare + render.
    pub total_s: f64,
    /// shadow_prepare + render - render of `none` (medians).
    pub shadow_cost_s: f64,
    /// The run's peak resident memory above what was resident when it started (Linux;
    /// NaN elsewhere), MiB, the largest over the repeats.
    pub peak_rss_mib: f64,
    /// What the method says it holds (depth map and masks), MiB.
    pub method_mib: f64,
    pub fallbacks: u64,
    /// Rays traced through the BVH (whole or in part) over shadow queries x samples.
    pub traced_ray_share: f64,
    /// Edge-table lookups per shadow query.
    pub lookups_per_query: f64,
    /// shadow_prepare over the shadow cost, in [0, 1] (1 where the cost is within the noise).
    pub prepare_share: f64,
    #[serde(flatten)]
    pub errors: Errors,
}

/// CSV header and line of a row (every field of the JSON, in the same order).
const CSV_HEADER: &str = "scene,method,setting,samples,headline,width,height,repeats,shadow_prepare_s,render_s,total_s,shadow_cost_s,peak_rss_mib,method_mib,fallbacks,traced_ray_share,lookups_per_query,prepare_share,rmse,penumbra_rmse,p99,max,leak_rate,false_shadow_rate,penumbra_bias,image_relative_rmse,lit_pixels,penumbra_pixels,dark_pixels,bright_pixels";

/// A CSV field: quoted (quotes doubled) when it holds a comma, quote or line break. The
/// `csv` crate cannot write the flattened `Row` (serde's `flatten` goes through a map).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

fn csv_line(r: &Row) -> String {
    let e = &r.errors;
    format!(
        "{},{},{},{},{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.1},{:.3},{},{:.4},{:.1},{:.4},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{},{},{},{}",
        csv_field(&r.scene),
        r.method,
        csv_field(&r.setting),
        r.samples,
        r.headline,
        r.width,
        r.height,
        r.repeats,
        r.shadow_prepare_s,
        r.render_s,
        r.total_s,
        r.shadow_cost_s,
        r.peak_rss_mib,
        r.method_mib,
        r.fallbacks,
        r.traced_ray_share,
        r.lookups_per_query,
        r.prepare_share,
        e.rmse,
        e.penumbra_rmse,
        e.p99,
        e.max,
        e.leak_rate,
        e.false_shadow_rate,
        e.penumbra_bias,
        e.image_relative_rmse,
        e.lit_pixels,
        e.penumbra_pixels,
        e.dark_pixels,
        e.bright_pixels
    )
}

/// `results.csv`: the header, then every scene's rows.
pub(super) fn csv(results: &[SceneResult]) -> String {
    let all_rows: Vec<&Row> = results.iter().flat_map(|r| &r.rows).collect();
    let mut csv = String::from(CSV_HEADER);
    csv.push('\n');
    for r in &all_rows {
        csv.push_str(&csv_line(r));
        csv.push('\n');
    }
    csv
}

/// `results.json`: the run's parameters, per scene its facts, speedup and skipped settings,
/// and every row.
pub(super) fn json(
    args: &BenchArgs,
    threads: usize,
    repeats: u32,
    results: &[SceneResult],
) -> serde_json::Value {
    let all_rows: Vec<&Row> = results.iter().flat_map(|r| &r.rows).collect();
    serde_json::json!({
        "threads": threads,
        "repeats": repeats,
        "quick": args.quick,
        "max_depth": args.max_depth,
        "seed": args.seed,
        "scenes": results.iter().map(|s| serde_json::json!({
            "scene": s.stem, "path": s.path, "triangles": s.triangles, "width": s.width,
            "height": s.height, "truth_samples": s.truth_samples, "truth_cached": s.truth_cached,
            "truth_seconds": s.truth_seconds, "equal_error_speedup": s.speedup,
            "equal_error_speedup_image": s.speedup_image,
            "equal_error_speedup_penumbra": s.speedup_penumbra, "skipped": s.skipped,
            "best": s.best,
        })).collect::<Vec<_>>(),
        "rows": all_rows,
    })
}

/// Everything measured on one scene.
pub struct SceneResult {
    pub stem: String,
    pub path: String,
    pub triangles: u64,
    pub width: u32,
    pub height: u32,
    pub truth_samples: u32,
    pub truth_cached: bool,
    pub truth_seconds: f64,
    pub rows: Vec<Row>,
    /// Per method family, the best setting's figures.
    pub best: Vec<BestFigures>,
    /// The equal-error speedup of the headline setting (`silhouette` at the top count: the
    /// fast exact method a user should pick), if it was run: on visibility RMSE, on the final image's relative RMSE (what a
    /// user sees) and on the penumbra RMSE.
    pub speedup: Option<Speedup>,
    pub speedup_image: Option<Speedup>,
    pub speedup_penumbra: Option<Speedup>,
    /// The headline setting's method, if the sweep has one.
    pub headline: Option<&'static str>,
    /// Settings not run (see `--max-run-seconds`).
    pub skipped: Vec<String>,
}

/// A family's best setting: its label, its image, error and cost heat maps (files relative
/// to the bench folder) and where its shadow cost goes.
#[derive(Debug, Clone, Serialize)]
pub struct BestFigures {
    pub family: String,
    pub label: String,
    pub image: String,
    pub error_map: String,
    pub cost_map: String,
    pub cost_split_s: super::cost::CostSplit,
}

/// The equal-error speedup (the definition): the shadow cost of the cheapest
/// reference run (`traced` as it ships) whose RMSE is at or below the headline's
/// (`silhouette` at 1024 samples), divided by the headline's.
#[derive(Debug, Clone, Serialize)]
pub struct Speedup {
    pub headline_rmse: f64,
    pub headline_cost_s: f64,
    /// The traced run matched: the cheapest at or below the headline's error, or, when none
    /// is, the most accurate one (`at_least`).
    pub traced_setting: String,
    pub traced_cost_s: f64,
    pub ratio: f64,
    /// No traced run reached the headline's error: the speedup is at least `ratio`.
    pub at_least: bool,
    /// The match is the cheapest traced run and is strictly more accurate: a traced run
    /// with fewer samples might match too, so the speedup is at most `ratio`.
    pub at_most: bool,
    /// The traced cost at exactly the headline's error, interpolated on log-log axes between
    /// the two traced runs whose errors bracket it, over the headline's cost (None outside
    /// the traced runs' range).
    pub interpolated_ratio: Option<f64>,
}

/// Which error an equal-error speedup matches.
#[derive(Debug, Clone, Copy)]
pub enum Measure {
    Visibility,
    Image,
    Penumbra,
}

impl Measure {
    fn of(self, e: &Errors) -> f64 {
        match self {
            Measure::Visibility => e.rmse,
            Measure::Image => e.image_relative_rmse,
            Measure::Penumbra => e.penumbra_rmse,
        }
    }
}

/// [`equal_error_speedup_on`] the visibility RMSE.
pub(super) fn equal_error_speedup(rows: &[Row]) -> Option<Speedup> {
    equal_error_speedup_on(rows, Measure::Visibility)
}

/// The equal-error speedup of the headline row against the reference runs, on `measure`.
pub(super) fn equal_error_speedup_on(rows: &[Row], measure: Measure) -> Option<Speedup> {
    let rows: Vec<Row> = rows
        .iter()
        .map(|r| Row { errors: Errors { rmse: measure.of(&r.errors), ..r.errors }, ..r.clone() })
        .collect();
    let rows = &rows[..];
    let et = rows.iter().find(|r| r.headline)?;
    let mut traced: Vec<&Row> =
        rows.iter().filter(|r| r.reference && r.errors.rmse.is_finite() && r.shadow_cost_s > 0.0).collect();
    // No lit pixel (NaN errors) or a cost lost in the noise: no meaningful ratio.
    if !et.errors.rmse.is_finite() || et.shadow_cost_s <= 0.0 || traced.is_empty() {
        return None;
    }
    traced.sort_by(|a, b| a.shadow_cost_s.total_cmp(&b.shadow_cost_s));
    let cheapest = traced[0];
    let matched = traced.iter().find(|r| r.errors.rmse <= et.errors.rmse);
    let (t, at_least) = match matched {
        Some(t) => (*t, false),
        None => (*traced.iter().min_by(|a, b| a.errors.rmse.total_cmp(&b.errors.rmse))?, true),
    };
    let at_most = !at_least && std::ptr::eq(t, cheapest) && t.errors.rmse < et.errors.rmse;
    let interpolated = traced.windows(2).find_map(|w| {
        let (a, b) = (w[0], w[1]); // a cheaper and (normally) less accurate than b
        let (ea, eb) = (a.errors.rmse, b.errors.rmse);
        let e = et.errors.rmse;
        if !(eb <= e && e <= ea) || ea <= 0.0 || eb <= 0.0 || ea == eb {
            return None;
        }
        let f = (e.ln() - ea.ln()) / (eb.ln() - ea.ln());
        Some(
            (a.shadow_cost_s.ln() + f * (b.shadow_cost_s.ln() - a.shadow_cost_s.ln())).exp()
                / et.shadow_cost_s,
        )
    });
    Some(Speedup {
        headline_rmse: et.errors.rmse,
        headline_cost_s: et.shadow_cost_s,
        traced_setting: t.setting.clone(),
        traced_cost_s: t.shadow_cost_s,
        ratio: t.shadow_cost_s / et.shadow_cost_s,
        at_least,
        at_most,
        interpolated_ratio: interpolated,
    })
}

/// A ratio with two significant digits.
pub(super) fn ratio_text(r: f64) -> String {
    if r.is_nan() || r <= 0.0 || r.is_infinite() {
        return format!("{r}x");
    }
    // Decimals for two significant digits, whole numbers from 10 up.
    let decimals = (1.0 - r.log10().floor()).max(0.0) as usize;
    format!("{r:.decimals$}x")
}

/// A speedup of the headline setting, whose method is `headline`.
pub(super) fn speedup_text(s: &Option<Speedup>, headline: Option<&str>) -> String {
    let headline = headline.unwrap_or("headline");
    match s {
        None => format!("n/a (no {headline} default row, no lit pixel, or costs within the noise)"),
        Some(s) => format!(
            "{}{} ({headline} RMSE {:.4} at {:.3} s; {} at {:.3} s{}{})",
            if s.at_least {
                ">= "
            } else if s.at_most {
                "<= "
            } else {
                ""
            },
            ratio_text(s.ratio),
            s.headline_rmse,
            s.headline_cost_s,
            s.traced_setting,
            s.traced_cost_s,
            if s.at_most { ", already more accurate" } else { "" },
            s.interpolated_ratio.map_or(String::new(), |r| format!("; interpolated {}", ratio_text(r)))
        ),
    }
}

/// The one-screen summary: per scene, each family's best setting and the speedup.
pub(super) fn summary(args: &BenchArgs, results: &[SceneResult]) -> String {
    let mut s = String::new();
    for r in results {
        let _ = writeln!(
            s,
            "{} ({} triangles, {}x{}, truth traced N={}{})",
            r.stem,
            r.triangles,
            r.width,
            r.height,
            r.truth_samples,
            if r.truth_cached { ", cached" } else { "" }
        );
        for b in &r.best {
            if let Some(row) = r.rows.iter().find(|x| x.setting == b.label) {
                let _ = writeln!(
                    s,
                    "  best {:<12} {:<36} RMSE {:.4}  cost {:.3} s",
                    b.family, b.label, row.errors.rmse, row.shadow_cost_s
                );
            }
        }
        let head = r.headline;
        let _ = writeln!(
            s,
            "  equal-error speedup of {}: {}",
            head.unwrap_or("the headline setting"),
            speedup_text(&r.speedup, head)
        );
        let _ = writeln!(s, "    on image error: {}", speedup_text(&r.speedup_image, head));
        let _ = writeln!(s, "    on penumbra RMSE: {}", speedup_text(&r.speedup_penumbra, head));
        if !r.skipped.is_empty() {
            let _ = writeln!(s, "  skipped: {}", r.skipped.join("; "));
        }
    }
    let _ = writeln!(s, "wrote {}", args.out_dir().join("index.html").display());
    s
}

/// A row for tests: `method`'s setting `setting` at `cost` seconds and RMSE `rmse`.
#[cfg(test)]
pub(super) fn test_row(method: &str, setting: &str, cost: f64, rmse: f64, default: bool) -> Row {
    Row {
        scene: "s".into(),
        method: method.into(),
        setting: setting.into(),
        samples: 0,
        headline: default,
        reference: method == "traced",
        width: 1,
        height: 1,
        repeats: 1,
        shadow_prepare_s: 0.0,
        render_s: 0.0,
        total_s: 0.0,
        shadow_cost_s: cost,
        peak_rss_mib: 0.0,
        method_mib: 0.0,
        fallbacks: 0,
        traced_ray_share: 0.0,
        lookups_per_query: 0.0,
        prepare_share: 0.0,
        errors: Errors { rmse, ..Errors::default() },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use super::test_row as row;

    #[test]
    fn equal_error_speedup_takes_the_cheapest_traced_run_at_or_below_the_error() {
        let rows = vec![
            row("traced", "t16", 0.1, 0.08, false),
            row("traced", "t64", 0.4, 0.04, false),
            row("traced", "t256", 1.6, 0.02, false),
            row("edge_table", "et", 0.05, 0.04, true),
        ];
        let s = equal_error_speedup(&rows).unwrap();
        assert_eq!(s.traced_setting, "t64");
        assert!((s.ratio - 8.0).abs() < 1e-9 && !s.at_least && !s.at_most, "{s:?}");
        // Exactly at t64's error: the interpolation lands on t64's cost.
        assert!((s.interpolated_ratio.unwrap() - 8.0).abs() < 1e-9, "{s:?}");
        // Between t16 and t64 (error 0.0566, the geometric mean): cost sqrt(0.1 x 0.4).
        let mid = vec![
            row("traced", "t16", 0.1, 0.08, false),
            row("traced", "t64", 0.4, 0.04, false),
            row("edge_table", "et", 0.1, (0.08f64 * 0.04).sqrt(), true),
        ];
        let s = equal_error_speedup(&mid).unwrap();
        assert!((s.interpolated_ratio.unwrap() - 2.0).abs() < 1e-9, "{s:?}");
        // The cheapest traced run is already more accurate: an upper bound.
        let cheap = vec![row("traced", "t16", 0.1, 0.02, false), row("edge_table", "et", 0.2, 0.04, true)];
        let s = equal_error_speedup(&cheap).unwrap();
        assert!(s.at_most && (s.ratio - 0.5).abs() < 1e-9 && s.interpolated_ratio.is_none(), "{s:?}");
        assert_eq!(
            [ratio_text(0.0032), ratio_text(0.46), ratio_text(2.345), ratio_text(31.7)],
            ["0.0032x", "0.46x", "2.3x", "32x"]
        );
        // No lit pixel: no ratio.
        let dark =
            vec![row("traced", "t16", 0.1, f64::NAN, false), row("edge_table", "et", 0.2, f64::NAN, true)];
        assert!(equal_error_speedup(&dark).is_none());
        // Better than every traced run: a lower bound against the most accurate one.
        let rows = vec![row("traced", "t16", 0.1, 0.08, false), row("edge_table", "et", 0.05, 0.01, true)];
        let s = equal_error_speedup(&rows).unwrap();
        assert!(s.at_least && (s.ratio - 2.0).abs() < 1e-9, "{s:?}");
    }
}
