//! `edge_table` in the registry: its help line, its section of the key reference
//! (`keys.md`), its bench sweep with the cost order `--max-run-seconds` skips by, and its
//! plot colour.

use super::{Blend, EdgeTableParams, PublishedParams, Reading};
use bench_entry::top_samples;
use bench_entry::{BenchEntry, SweepSetting};
use renderer::MethodEntry;
use renderer::MethodParams;
use renderer::interface::method::default_table;

impl MethodEntry for EdgeTableParams {
    const ABOUT: &'static str = "Edge-table masks (Egan & Neulander 2004) classifying each ray against conservative depth bounds; the BVH traces only what they cannot settle: exact";
    const KEYS_DOC: &'static str = include_str!("keys.md");

    /// The default's keys, and the published reading's own keys (inapplicable to the default,
    /// exact reading) with their values under `reading = "published"`.
    fn documented_keys() -> toml::Table {
        let mut keys = default_table::<Self>();
        let mut published_keys =
            toml::Table::try_from(published().table()).expect("edge_table's parameters serialise");
        published_keys.retain(|k, _| !keys.contains_key(k));
        keys.extend(published_keys);
        keys
    }
}

impl BenchEntry for EdgeTableParams {
    const COLOUR: [u8; 3] = [214, 39, 40];
    const BENCH_RANK: u32 = 20;
    /// The exact reading (the default) over sample counts; then the published reading over
    /// depth maps, grids and blends. (The headline is `silhouette`'s: the fast exact method.)
    fn sweep(quick: bool) -> Vec<SweepSetting> {
        let mut out = Vec::new();
        let n = top_samples(quick);
        // The exact reading's error is sampling noise like traced's, so its own curve meets
        // traced's; the default row is the top count.
        let counts: &[u32] = if quick { &[16] } else { &[16, 64, 256] };
        for &m in counts {
            out.push(setting(format!("edge_table exact N={m}"), EdgeTableParams::default(), m));
        }
        out.push(setting(format!("edge_table exact N={n}"), EdgeTableParams::default(), n));
        // The published (approximate) reading: its previous default's grid, and in the full
        // sweep a finer map and grids, nearest and trilinear.
        let published = published();
        let maps: &[u32] = if quick { &[256] } else { &[256, 512] };
        let mut grids = vec![published.grid];
        if !quick {
            for g in [[4, 4, 4], [8, 8, 4]] {
                if !grids.contains(&g) {
                    grids.push(g);
                }
            }
        }
        let grid_name = |g: [u32; 3]| format!("{}x{}x{}", g[0], g[1], g[2]);
        for &map in maps {
            for &grid in &grids {
                for (blend, blend_name) in [(Blend::Nearest, "nearest"), (Blend::Trilinear, "trilinear")] {
                    let reading = Reading::Published(PublishedParams { blend, ..PublishedParams::DEFAULT });
                    let p = EdgeTableParams { resolution: map, grid, reading, ..published };
                    let label = format!("edge_table published {map} {} {blend_name} N={n}", grid_name(grid));
                    out.push(setting(label, p, n));
                }
            }
        }
        out
    }
}

/// The published reading at its defaults.
fn published() -> EdgeTableParams {
    EdgeTableParams { reading: Reading::Published(PublishedParams::DEFAULT), ..EdgeTableParams::default() }
}

/// A setting of the sweep with its cost order.
fn setting(label: String, p: EdgeTableParams, samples: u32) -> SweepSetting {
    SweepSetting { cost: Some(cost_order(&p, samples)), ..SweepSetting::new(label, p, samples) }
}

/// The parameters that only make a run costlier as they grow: depth map, grid, blend (exact
/// 0, nearest 1, trilinear 2), samples.
fn cost_order(p: &EdgeTableParams, samples: u32) -> Vec<u32> {
    // The exact reading has no blend; it sorts before the published one's nearest.
    let blend = match p.reading {
        Reading::Exact => 0,
        Reading::Published(PublishedParams { blend: Blend::Nearest, .. }) => 1,
        Reading::Published(PublishedParams { blend: Blend::Trilinear, .. }) => 2,
    };
    vec![p.resolution, p.grid[0], p.grid[1], p.grid[2], blend, samples]
}

#[cfg(test)]
mod tests {
    use super::*;
    use bench_entry::no_costlier;

    #[test]
    fn costlier_edge_table_settings_are_the_ones_skipped() {
        let et = |map: u32, grid: [u32; 3], blend: Blend, samples: u32| {
            let reading = Reading::Published(PublishedParams { blend, ..PublishedParams::DEFAULT });
            let p = EdgeTableParams { resolution: map, grid, reading, ..EdgeTableParams::default() };
            setting(String::new(), p, samples).cost.unwrap()
        };
        let slow = et(256, [4, 4, 2], Blend::Trilinear, 1024);
        assert!(no_costlier(&slow, &et(512, [4, 4, 2], Blend::Trilinear, 1024)));
        assert!(no_costlier(&slow, &et(256, [8, 8, 4], Blend::Trilinear, 1024)));
        assert!(!no_costlier(&slow, &et(256, [8, 8, 4], Blend::Nearest, 1024)));
        assert!(!no_costlier(&slow, &et(512, [4, 4, 2], Blend::Trilinear, 256)));
    }

    #[test]
    fn the_sweep_holds_the_default_at_the_top_count_and_no_headline() {
        for quick in [false, true] {
            let s = EdgeTableParams::sweep(quick);
            assert!(s.iter().all(|x| !x.headline), "quick {quick}");
            let default = format!("{:?}", EdgeTableParams::default());
            assert!(
                s.iter().any(|x| x.samples == top_samples(quick) && format!("{:?}", x.method) == default)
            );
            assert!(s.iter().all(|x| x.cost.is_some() && !x.reference), "quick {quick}");
        }
    }
}
