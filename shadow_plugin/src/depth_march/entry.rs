//! `depth_march`'s registry entry: its help line, its section of the key reference
//! (`keys.md`), its bench sweep and its plot colour. The CLI's registry no longer lists it
//! (retired, docs/notes/2026-11-26-retired-depth-march.md); a registry that does reads it
//! as before.

use super::DepthMarchParams;
use bench_entry::top_samples;
use bench_entry::{BenchEntry, SweepSetting};
use renderer::MethodEntry;

impl MethodEntry for DepthMarchParams {
    const ABOUT: &'static str = "Each shadow ray marched through the same depth map (walls and floors)";
    const KEYS_DOC: &'static str = include_str!("keys.md");
}

impl BenchEntry for DepthMarchParams {
    const COLOUR: [u8; 3] = [31, 119, 180];
    const BENCH_RANK: u32 = 10;
    /// The defaults at the top sample count: the per-ray baseline of the edge tables.
    fn sweep(quick: bool) -> Vec<SweepSetting> {
        let n = top_samples(quick);
        vec![SweepSetting::new(format!("depth_march 256 N={n}"), DepthMarchParams::default(), n)]
    }
}
