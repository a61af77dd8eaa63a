//! The settings swept: every method's, in order ([`sweep`]), and the `edge_table` cost
//! order that `--max-run-seconds` skips by ([`cost_order`], [`no_costlier`]).

use renderer::{ShadowMethod, TracedParams, Unshadowed};
use shadow_plugin::{Blend, DepthMarchParams, EdgeTableParams, PcssParams, PublishedParams, Reading};
use std::sync::Arc;

/// The `edge_table` parameters that only make a run costlier as they grow: (depth map,
/// grid, blend (nearest 0, trilinear 1), samples).
pub(super) type CostOrder = (u32, [u32; 3], u32, u32);

/// One setting of the sweep.
#[derive(Debug, Clone)]
pub struct Setting {
    pub label: String,
    /// The method and its parameters (code-only switches included).
    pub method: Arc<dyn ShadowMethod>,
    /// Light samples per shading point.
    pub samples: u32,
    /// `edge_table`'s cost order; `None` for the other methods (never skipped).
    pub cost: Option<CostOrder>,
    /// `edge_table` at its defaults with the sweep's top sample count (1024; 64 with
    /// `--quick`): the row the equal-error speedup is computed for.
    pub is_edge_table_default: bool,
}

/// A setting of `method` with `samples`.
pub fn setting(label: String, method: impl ShadowMethod + 'static, samples: u32) -> Setting {
    Setting { label, method: Arc::new(method), samples, cost: None, is_edge_table_default: false }
}

/// The no-shadow floor every cost is measured against.
pub(super) fn none_setting() -> Setting {
    setting("none".into(), Unshadowed {}, 1)
}

fn edge_table(label: String, p: EdgeTableParams, samples: u32) -> Setting {
    let cost = Some(cost_order(&p, samples));
    let is_edge_table_default = p == EdgeTableParams::default();
    Setting { cost, is_edge_table_default, ..setting(label, p, samples) }
}

/// Label prefix of the plain traced reference: reported, but not a candidate of the
/// equal-error speedup (that compares with `traced` as it ships, shaft-culled).
pub const PLAIN_TRACED: &str = "traced plain";

/// The settings swept, in order.
pub fn sweep(quick: bool) -> Vec<Setting> {
    let mut out = Vec::new();
    let traced_ns: &[u32] = if quick { &[4, 16, 64] } else { &[4, 16, 64, 256, 1024] };
    for &n in traced_ns {
        out.push(setting(format!("traced N={n}"), TracedParams::new(n), n));
    }
    let n = if quick { 64 } else { 1024 };
    // The plain reference at the top count: every ray traced, no shaft culling (the same
    // bits as `traced N=1024`, so the cost of culling's absence is read off side by side).
    out.push(setting(format!("{PLAIN_TRACED} N={n}"), TracedParams::plain(n), n));
    out.push(setting(format!("depth_march 256 N={n}"), DepthMarchParams::default(), n));
    // The exact reading (the default) over sample counts: its error is sampling noise like
    // traced's, so its own curve meets traced's; the default row is the top count.
    let counts: &[u32] = if quick { &[16] } else { &[16, 64, 256] };
    for &m in counts {
        out.push(Setting {
            is_edge_table_default: false,
            ..edge_table(format!("edge_table exact N={m}"), EdgeTableParams::default(), m)
        });
    }
    out.push(edge_table(format!("edge_table exact N={n}"), EdgeTableParams::default(), n));
    // The published (approximate) reading: its previous default's grid, and in the full
    // sweep a finer map and grids, nearest and trilinear.
    let published = EdgeTableParams {
        reading: Reading::Published(PublishedParams::DEFAULT),
        ..EdgeTableParams::default()
    };
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
                out.push(edge_table(label, p, n));
            }
        }
    }
    let taps: &[u32] = if quick { &[64] } else { &[64, 256, 1024] };
    for &t in taps {
        out.push(setting(format!("pcss 256 N={t}"), PcssParams::default(), t));
    }
    out
}

fn cost_order(p: &EdgeTableParams, samples: u32) -> CostOrder {
    // The exact reading has no blend; it sorts before the published one's nearest.
    let blend = match p.reading {
        Reading::Exact => 0,
        Reading::Published(PublishedParams { blend: Blend::Nearest, .. }) => 1,
        Reading::Published(PublishedParams { blend: Blend::Trilinear, .. }) => 2,
    };
    (p.resolution, p.grid, blend, samples)
}

/// Whether `a` is at most `b` in every cost parameter.
pub(super) fn no_costlier(a: CostOrder, b: CostOrder) -> bool {
    a.0 <= b.0 && a.1.iter().zip(&b.1).all(|(x, y)| x <= y) && a.2 <= b.2 && a.3 <= b.3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sweep_holds_every_family_and_one_edge_table_default() {
        for quick in [false, true] {
            let s = sweep(quick);
            for m in ["traced", "depth_march", "edge_table", "pcss"] {
                assert!(s.iter().any(|x| x.method.name() == m), "{m} missing (quick {quick})");
            }
            assert_eq!(s.iter().filter(|x| x.is_edge_table_default).count(), 1, "quick {quick}");
        }
        let full: Vec<(u32, bool)> = sweep(false)
            .iter()
            .filter(|x| x.method.name() == "traced")
            .map(|x| (x.samples, !x.label.starts_with(PLAIN_TRACED)))
            .collect();
        // Shaft-culled at every count, and the plain reference at the top one.
        assert_eq!(full, vec![(4, true), (16, true), (64, true), (256, true), (1024, true), (1024, false)]);
        let plain =
            format!("{:?}", sweep(false).iter().find(|x| x.label.starts_with(PLAIN_TRACED)).unwrap().method);
        assert_eq!(plain, format!("{:?}", TracedParams::plain(1024)));
    }

    #[test]
    fn costlier_edge_table_settings_are_the_ones_skipped() {
        let et = |map: u32, grid: [u32; 3], blend: Blend, samples: u32| {
            let reading = Reading::Published(PublishedParams { blend, ..PublishedParams::DEFAULT });
            let p = EdgeTableParams { resolution: map, grid, reading, ..EdgeTableParams::default() };
            edge_table(String::new(), p, samples).cost.unwrap()
        };
        let slow = et(256, [4, 4, 2], Blend::Trilinear, 1024);
        assert!(no_costlier(slow, et(512, [4, 4, 2], Blend::Trilinear, 1024)));
        assert!(no_costlier(slow, et(256, [8, 8, 4], Blend::Trilinear, 1024)));
        assert!(!no_costlier(slow, et(256, [8, 8, 4], Blend::Nearest, 1024)));
        assert!(!no_costlier(slow, et(512, [4, 4, 2], Blend::Trilinear, 256)));
        assert_eq!(sweep(true)[0].cost, None, "traced is never skipped");
    }
}
