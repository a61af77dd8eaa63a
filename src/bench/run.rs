//! Timing one setting on one scene: `--repeats` renders, their prepare and render times,
//! and the run's peak resident memory.

use super::sweep::Setting;
use renderer::{Frame, RenderSettings, Scene, render};
use std::time::Duration;

/// Resets the process' peak-RSS counter (Linux: `clear_refs` 5), so the next read is the
/// peak since now, and returns the resident memory now (MiB), or None where that cannot be
/// done (not Linux).
fn reset_peak_rss() -> Option<f64> {
    std::fs::write("/proc/self/clear_refs", "5").ok()?;
    status_mib("VmRSS:")
}

/// A `/proc/self/status` field in MiB.
fn status_mib(field: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix(field))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map(|kb| kb / 1024.0)
}

pub(super) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

pub(super) struct Run {
    pub(super) frame: Frame,
    pub(super) prepare: Vec<f64>,
    pub(super) render: Vec<f64>,
    /// shadow_prepare + render per repeat.
    pub(super) totals: Vec<f64>,
    pub(super) peak: f64,
}

pub(super) fn run_setting(
    scene: &Scene,
    setting: &Setting,
    settings: &RenderSettings,
    repeats: u32,
    max_run_seconds: f64,
) -> Result<Run, String> {
    let mut first = None;
    let (mut prepare, mut render_t, mut peak) = (Vec::new(), Vec::new(), 0.0f64);
    let mut totals = Vec::new();
    for _ in 0..repeats {
        // A long run is timed once: its noise is small against it, and repeating it would
        // take the time the rest of the sweep needs.
        if prepare.last().zip(render_t.last()).is_some_and(|(p, r): (&f64, &f64)| p + r > max_run_seconds) {
            break;
        }
        // The run's own peak: the high-water mark above what was resident when it started
        // (the allocator keeps what earlier runs freed, so the bare mark would carry over).
        let base = reset_peak_rss();
        let mut methods: Vec<_> =
            scene.lights.iter().map(|_| setting.method.build(setting.samples)).collect();
        let frame = render(scene, &mut methods, settings, &|_| {}).map_err(|e| e.to_string())?;
        drop(methods);
        let run_peak = base.zip(status_mib("VmHWM:")).map_or(f64::NAN, |(b, hwm)| (hwm - b).max(0.0));
        peak = if peak.is_nan() { peak } else { peak.max(run_peak) };
        prepare.push(secs(frame.shadow_prepare));
        render_t.push(secs(frame.render));
        totals.push(secs(frame.shadow_prepare) + secs(frame.render));
        first.get_or_insert(frame);
    }
    Ok(Run { frame: first.expect("repeats >= 1"), prepare, render: render_t, totals, peak })
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}
