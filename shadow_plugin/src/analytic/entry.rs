//! `analytic` in the registry: its help line, its section of the key reference (`keys.md`),
//! its bench sweep and its plot colour.

use super::AnalyticParams;
use bench_entry::{BenchEntry, SweepSetting, top_samples};
use renderer::MethodEntry;

impl MethodEntry for AnalyticParams {
    const ABOUT: &'static str =
        "Noise-free soft shadows: the light's visible part integrated from the occluders' silhouette edges";
    const KEYS_DOC: &'static str = include_str!("keys.md");
    const TRACES_KEPT_INSTANCES: bool = true;
}

impl BenchEntry for AnalyticParams {
    const COLOUR: [u8; 3] = [214, 39, 40];
    const BENCH_RANK: u32 = 45;
    /// One setting: its exact points have no sample count; the counted ones (alpha-tested
    /// leaves, degenerate points) use the bench's top count.
    fn sweep(quick: bool) -> Vec<SweepSetting> {
        let n = top_samples(quick);
        vec![SweepSetting::new(format!("analytic N={n}"), AnalyticParams {}, n)]
    }
}
