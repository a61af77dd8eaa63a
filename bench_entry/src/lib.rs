//! What the bench knows of a shadow method: the settings it sweeps, its colour and line in the
//! plots, and where its settings go in the sweep ([`BenchEntry`]). A method says it in its own
//! folder (its `entry.rs`), beside its help line and key reference ([`renderer::MethodEntry`]),
//! so that the CLI's registry is one line per method; the words live here, not in the
//! renderer, which speaks rendering only. `traced` and `none`'s entries are here too: the
//! renderer defines them, the bench compares everything with them.

use renderer::{ShadowMethod, TracedParams, Unshadowed};
use std::sync::Arc;

/// One setting of the bench's sweep: a method with its parameters (code-only switches
/// included), a sample count, and how the bench treats it.
#[derive(Debug, Clone)]
pub struct SweepSetting {
    /// The row's label (`results.csv`'s `setting`): unique over the whole sweep.
    pub label: String,
    pub method: Arc<dyn ShadowMethod>,
    /// Light samples per shading point.
    pub samples: u32,
    /// Where the setting stands in its method's cost order, parameter by parameter, each
    /// only making a run costlier as it grows; `None`: never skipped. Once a setting's first
    /// run takes longer than `--max-run-seconds`, the later settings of the same method that
    /// are at least as costly in every parameter ([`no_costlier`]) are skipped.
    pub cost: Option<Vec<u32>>,
    /// The row the equal-error speedup is computed for (at most one in a sweep; the CSV's
    /// `headline` column).
    pub headline: bool,
    /// One of the runs the headline is compared with: the speedup is the cost of the
    /// cheapest reference run at or below the headline's error over the headline's cost.
    pub reference: bool,
}

impl SweepSetting {
    /// `method` with `samples`, labelled `label`: never skipped, neither headline nor reference.
    pub fn new(label: String, method: impl ShadowMethod + 'static, samples: u32) -> Self {
        Self { label, method: Arc::new(method), samples, cost: None, headline: false, reference: false }
    }
}

/// Whether cost order `a` is at most `b` in every parameter (orders of different lengths
/// are not comparable: never).
pub fn no_costlier(a: &[u32], b: &[u32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x <= y)
}

/// The sample count the bench compares methods at: 1024, 64 in its quick sweep.
pub const fn top_samples(quick: bool) -> u32 {
    if quick { 64 } else { 1024 }
}

/// A method as the bench sweeps and plots it.
pub trait BenchEntry {
    /// Its colour in the bench's plots (sRGB), the same on every scene.
    const COLOUR: [u8; 3];

    /// Whether the plot joins its points into a line: for a family of one parameter (a
    /// sample count); settings that differ in several ways at once are points.
    const PLOT_LINE: bool = false;

    /// Where its settings go in the bench's sweep, and so in `results.csv`: lowest first,
    /// ties in the registry's order.
    const BENCH_RANK: u32 = u32::MAX;

    /// The settings the bench sweeps (`quick`: the short sweep of `--quick`), in order.
    fn sweep(quick: bool) -> Vec<SweepSetting>;
}

/// Label prefix of the bench's plain traced reference: reported, but not a reference of the
/// equal-error speedup (that compares with `traced` as it ships, shaft-culled).
pub const PLAIN_LABEL: &str = "traced plain";

impl BenchEntry for TracedParams {
    const COLOUR: [u8; 3] = [90, 90, 90];
    /// One parameter (N): a curve.
    const PLOT_LINE: bool = true;
    const BENCH_RANK: u32 = 0;

    /// Shaft-culled over sample counts (the references of the equal-error speedup), then the
    /// plain reference at the top count: every ray traced, no shaft culling (the same bits as
    /// `traced N=1024`, so the cost of culling's absence is read off side by side).
    fn sweep(quick: bool) -> Vec<SweepSetting> {
        let counts: &[u32] = if quick { &[4, 16, 64] } else { &[4, 16, 64, 256, 1024] };
        let mut out: Vec<SweepSetting> = counts
            .iter()
            .map(|&n| SweepSetting {
                reference: true,
                ..SweepSetting::new(format!("traced N={n}"), TracedParams::CULLED, n)
            })
            .collect();
        let n = top_samples(quick);
        out.push(SweepSetting::new(format!("{PLAIN_LABEL} N={n}"), TracedParams::PLAIN, n));
        out
    }
}

impl BenchEntry for Unshadowed {
    /// The colour the plots give a family they do not know (`none` is never plotted).
    const COLOUR: [u8; 3] = [148, 103, 189];
    /// None: the bench runs `none` on its own, as the cost floor of every setting.
    fn sweep(_quick: bool) -> Vec<SweepSetting> {
        Vec::new()
    }
}
