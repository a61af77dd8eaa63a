//! `silhouette` in the registry: its help line, its section of the key reference (`keys.md`),
//! its bench sweep and its plot colour.

use super::SilhouetteParams;
use bench_entry::top_samples;
use bench_entry::{BenchEntry, SweepSetting};
use renderer::MethodEntry;

impl MethodEntry for SilhouetteParams {
    const ABOUT: &'static str = "Exact soft shadows from the occluders' silhouette edges: traced's samples counted, one ray per point";
    const KEYS_DOC: &'static str = include_str!("keys.md");
    const TRACES_KEPT_INSTANCES: bool = true;
}

impl BenchEntry for SilhouetteParams {
    const COLOUR: [u8; 3] = [23, 190, 207];
    /// One parameter (N): a curve, like `traced`'s.
    const PLOT_LINE: bool = true;
    const BENCH_RANK: u32 = 40;
    /// Over sample counts: its error is `traced`'s at the same N (the same samples, settled
    /// exactly), so its curve lies on `traced`'s error axis at its own cost. The bench's
    /// headline, the fast exact method a user should pick, is its top count.
    fn sweep(quick: bool) -> Vec<SweepSetting> {
        let counts: &[u32] = if quick { &[16, 64] } else { &[64, 256, 1024, 4096] };
        counts
            .iter()
            .map(|&n| SweepSetting {
                headline: n == top_samples(quick),
                ..SweepSetting::new(format!("silhouette N={n}"), SilhouetteParams {}, n)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_headline_is_the_top_count() {
        for quick in [false, true] {
            let heads: Vec<u32> =
                SilhouetteParams::sweep(quick).iter().filter(|x| x.headline).map(|x| x.samples).collect();
            assert_eq!(heads, vec![top_samples(quick)], "quick {quick}");
        }
    }
}
