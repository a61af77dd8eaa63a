//! The settings swept: every method's, in order ([`sweep`]), and the `edge_table` cost
//! order that `--max-run-seconds` skips by ([`cost_order`], [`no_costlier`]).

use crate::config::{BlendName, MethodName, ShadowsConfig};

/// One setting of the sweep.
#[derive(Debug, Clone)]
pub struct Setting {
    pub label: String,
    pub config: ShadowsConfig,
    /// `edge_table` at its defaults with 1024 samples: the row the equal-error speedup is
    /// computed for.
    pub is_edge_table_default: bool,
}

fn setting(label: String, config: ShadowsConfig) -> Setting {
    Setting { label, config, is_edge_table_default: false }
}

/// Label prefix of the plain traced reference: reported, but not a candidate of the
/// equal-error speedup (that compares with `traced` as it ships, shaft-culled).
pub const PLAIN_TRACED: &str = "traced plain";

/// The settings swept, in order.
pub fn sweep(quick: bool) -> Vec<Setting> {
    let base = ShadowsConfig::default();
    let mut out = Vec::new();
    let traced_ns: &[u32] = if quick { &[4, 16, 64] } else { &[4, 16, 64, 256, 1024] };
    for &n in traced_ns {
        out.push(setting(
            format!("traced N={n}"),
            ShadowsConfig { method: MethodName::Traced, samples: n, ..base.clone() },
        ));
    }
    let n = if quick { 64 } else { 1024 };
    // The plain reference at the top count: every ray traced, no shaft culling (the same
    // bits as `traced N=1024`, so the cost of culling's absence is read off side by side).
    let mut plain = ShadowsConfig { method: MethodName::Traced, samples: n, ..base.clone() };
    plain.traced.shaft_culling = Some(false);
    out.push(setting(format!("{PLAIN_TRACED} N={n}"), plain));
    out.push(setting(
        format!("depth_march 256 N={n}"),
        ShadowsConfig { method: MethodName::DepthMarch, samples: n, ..base.clone() },
    ));
    let maps: &[u32] = if quick { &[256] } else { &[256, 512] };
    // The default's grid, and in the full sweep the previous default's and a finer one
    // (each once, whatever the default: a repeated setting would repeat a row's label).
    let default_grid = ShadowsConfig::default().edge_table.params().grid;
    let mut grids = vec![default_grid];
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
            for blend in [BlendName::Nearest, BlendName::Trilinear] {
                let mut c = ShadowsConfig { method: MethodName::EdgeTable, samples: n, ..base.clone() };
                c.edge_table.depth_map = Some(map);
                c.edge_table.grid = Some(grid);
                c.edge_table.blend = Some(blend);
                let blend_name = match blend {
                    BlendName::Nearest => "nearest",
                    BlendName::Trilinear => "trilinear",
                };
                let label = format!("edge_table {map} {} {blend_name} N={n}", grid_name(grid));
                let is_default = c.edge_table.params() == ShadowsConfig::default().edge_table.params();
                out.push(Setting { label, config: c, is_edge_table_default: is_default });
            }
        }
    }
    // Sample counts at the default parameters.
    let counts: &[u32] = if quick { &[16] } else { &[64, 256] };
    for &m in counts {
        out.push(setting(
            format!("edge_table 256 {} nearest N={m}", grid_name(default_grid)),
            ShadowsConfig { method: MethodName::EdgeTable, samples: m, ..base.clone() },
        ));
    }
    let taps: &[u32] = if quick { &[64] } else { &[64, 256, 1024] };
    for &t in taps {
        out.push(setting(
            format!("pcss 256 N={t}"),
            ShadowsConfig { method: MethodName::Pcss, samples: t, ..base.clone() },
        ));
    }
    out
}

/// The `edge_table` parameters that only make a run costlier as they grow: (depth map,
/// grid, blend (nearest 0, trilinear 1), samples).
pub(super) fn cost_order(c: &ShadowsConfig) -> Option<(u32, [u32; 3], u32, u32)> {
    if c.method != MethodName::EdgeTable {
        return None;
    }
    let p = c.edge_table.params();
    let blend = match p.blend {
        shadow_plugin::Blend::Nearest => 0,
        shadow_plugin::Blend::Trilinear => 1,
    };
    Some((p.depth_map.resolution, p.grid, blend, c.samples))
}

/// Whether `a` is at most `b` in every cost parameter.
pub(super) fn no_costlier(a: (u32, [u32; 3], u32, u32), b: (u32, [u32; 3], u32, u32)) -> bool {
    a.0 <= b.0 && a.1.iter().zip(&b.1).all(|(x, y)| x <= y) && a.2 <= b.2 && a.3 <= b.3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sweep_holds_every_family_and_one_edge_table_default() {
        for quick in [false, true] {
            let s = sweep(quick);
            for m in [MethodName::Traced, MethodName::DepthMarch, MethodName::EdgeTable, MethodName::Pcss] {
                assert!(s.iter().any(|x| x.config.method == m), "{m:?} missing (quick {quick})");
            }
            assert_eq!(s.iter().filter(|x| x.is_edge_table_default).count(), 1, "quick {quick}");
        }
        let full: Vec<(u32, bool)> = sweep(false)
            .iter()
            .filter(|x| x.config.method == MethodName::Traced)
            .map(|x| (x.config.samples, x.config.traced.params(x.config.samples).shaft_culling))
            .collect();
        // Shaft-culled at every count, and the plain reference at the top one.
        assert_eq!(full, vec![(4, true), (16, true), (64, true), (256, true), (1024, true), (1024, false)]);
    }

    #[test]
    fn costlier_edge_table_settings_are_the_ones_skipped() {
        let et = |map: u32, grid: [u32; 3], blend: BlendName, samples: u32| {
            let mut c = ShadowsConfig { method: MethodName::EdgeTable, samples, ..ShadowsConfig::default() };
            c.edge_table.depth_map = Some(map);
            c.edge_table.grid = Some(grid);
            c.edge_table.blend = Some(blend);
            cost_order(&c).unwrap()
        };
        let slow = et(256, [4, 4, 2], BlendName::Trilinear, 1024);
        assert!(no_costlier(slow, et(512, [4, 4, 2], BlendName::Trilinear, 1024)));
        assert!(no_costlier(slow, et(256, [8, 8, 4], BlendName::Trilinear, 1024)));
        assert!(!no_costlier(slow, et(256, [8, 8, 4], BlendName::Nearest, 1024)));
        assert!(!no_costlier(slow, et(512, [4, 4, 2], BlendName::Trilinear, 256)));
        assert_eq!(cost_order(&ShadowsConfig::default()), None, "traced is never skipped");
    }
}
