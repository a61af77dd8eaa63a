//! `pcss` in the registry: its help line, its section of the key reference (`keys.md`), its
//! bench sweep and its plot colour.

use super::PcssParams;
use bench_entry::{BenchEntry, SweepSetting};
use renderer::MethodEntry;

impl MethodEntry for PcssParams {
    const ABOUT: &'static str = "Percentage-closer soft shadows (Fernando 2005) on the same depth map";
    const KEYS_DOC: &'static str = include_str!("keys.md");
    /// Its map is ray cast, its frustum fitted over kept instances' placed vertices too.
    const TRACES_KEPT_INSTANCES: bool = true;
}

impl BenchEntry for PcssParams {
    const COLOUR: [u8; 3] = [44, 160, 44];
    const BENCH_RANK: u32 = 30;
    /// The defaults over PCF tap counts.
    fn sweep(quick: bool) -> Vec<SweepSetting> {
        let taps: &[u32] = if quick { &[64] } else { &[64, 256, 1024] };
        taps.iter().map(|&t| SweepSetting::new(format!("pcss 256 N={t}"), PcssParams::default(), t)).collect()
    }
}
