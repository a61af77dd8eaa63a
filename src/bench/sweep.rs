//! The settings swept: every registered method's own ([`renderer::MethodEntry::sweep`]),
//! method by method in order of their bench rank ([`sweep`]). What a setting is to the
//! bench (its cost order for `--max-run-seconds`, the headline row, the references of the
//! equal-error speedup) is said by the setting itself ([`Setting`]), never by a method's name.

use crate::methods::Registered;
pub(super) use bench_entry::no_costlier;
use renderer::Unshadowed;

/// One setting of the sweep.
pub use bench_entry::SweepSetting as Setting;

/// The no-shadow floor every cost is measured against.
pub(super) fn none_setting() -> Setting {
    Setting::new("none".into(), Unshadowed {}, 1)
}

/// The settings swept, in order: each method's (its own order), the methods by bench rank,
/// ties in `methods`' order.
pub fn sweep(quick: bool, methods: &[Registered]) -> Vec<Setting> {
    let mut ranked: Vec<&Registered> = methods.iter().collect();
    ranked.sort_by_key(|m| m.bench_rank);
    ranked.iter().flat_map(|m| (m.sweep)(quick)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::METHODS;
    use bench_entry::PLAIN_LABEL;
    use renderer::TracedParams;

    #[test]
    fn the_sweep_holds_every_family_and_one_headline() {
        for quick in [false, true] {
            let s = sweep(quick, METHODS);
            // Every method but `none` (the cost floor, run on its own) has settings.
            for m in METHODS.iter().filter(|m| m.name != Unshadowed::NAME) {
                assert!(s.iter().any(|x| x.method.name() == m.name), "{} missing (quick {quick})", m.name);
            }
            assert_eq!(s.iter().filter(|x| x.headline).count(), 1, "quick {quick}");
            let mut labels: Vec<&str> = s.iter().map(|x| x.label.as_str()).collect();
            labels.sort();
            labels.dedup();
            assert_eq!(labels.len(), s.len(), "labels are unique (quick {quick})");
        }
        let full: Vec<(u32, bool)> = sweep(false, METHODS)
            .iter()
            .filter(|x| x.method.name() == "traced")
            .map(|x| (x.samples, !x.label.starts_with(PLAIN_LABEL)))
            .collect();
        // Shaft-culled at every count, and the plain reference at the top one.
        assert_eq!(full, vec![(4, true), (16, true), (64, true), (256, true), (1024, true), (1024, false)]);
        let plain = format!(
            "{:?}",
            sweep(false, METHODS).iter().find(|x| x.label.starts_with(PLAIN_LABEL)).unwrap().method
        );
        assert_eq!(plain, format!("{:?}", TracedParams::PLAIN));
        // The equal-error speedup's references: traced as it ships, the plain one aside.
        let references: Vec<bool> = sweep(false, METHODS)
            .iter()
            .filter(|x| x.reference)
            .map(|x| x.method.name() == "traced" && !x.label.starts_with(PLAIN_LABEL))
            .collect();
        assert_eq!(references, vec![true; 5]);
    }

    /// `results.csv`'s rows, in order: the methods' settings as the bench ran them before
    /// the registry said them (a method added later goes after them, filtered out here; the
    /// retired `depth_march`'s one row, after traced's, is gone).
    #[test]
    fn the_sweep_keeps_its_labels_and_order() {
        let shipped = ["traced", "edge_table", "pcss", "silhouette"];
        let labels = |quick: bool| -> Vec<String> {
            sweep(quick, METHODS)
                .into_iter()
                .filter(|x| shipped.contains(&x.method.name()))
                .map(|x| format!("{} {}{}", x.label, x.samples, if x.headline { " headline" } else { "" }))
                .collect()
        };
        let mut full = vec![];
        for n in [4, 16, 64, 256, 1024] {
            full.push(format!("traced N={n} {n}"));
        }
        full.push("traced plain N=1024 1024".into());
        for n in [16, 64, 256] {
            full.push(format!("edge_table exact N={n} {n}"));
        }
        full.push("edge_table exact N=1024 1024".into());
        for map in [256, 512] {
            for grid in ["2x2x8", "4x4x4", "8x8x4"] {
                for blend in ["nearest", "trilinear"] {
                    full.push(format!("edge_table published {map} {grid} {blend} N=1024 1024"));
                }
            }
        }
        for n in [64, 256, 1024] {
            full.push(format!("pcss 256 N={n} {n}"));
        }
        // The headline: the fast exact method at the top count.
        for n in [64, 256, 1024, 4096] {
            full.push(format!("silhouette N={n} {n}{}", if n == 1024 { " headline" } else { "" }));
        }
        assert_eq!(labels(false), full);
        let quick = [
            "traced N=4 4",
            "traced N=16 16",
            "traced N=64 64",
            "traced plain N=64 64",
            "edge_table exact N=16 16",
            "edge_table exact N=64 64",
            "edge_table published 256 2x2x8 nearest N=64 64",
            "edge_table published 256 2x2x8 trilinear N=64 64",
            "pcss 256 N=64 64",
            "silhouette N=16 16",
            "silhouette N=64 64 headline",
        ];
        assert_eq!(labels(true), quick);
    }

    #[test]
    fn only_settings_of_one_method_at_least_as_costly_are_skipped() {
        assert!(no_costlier(&[256, 4, 4, 2, 2, 1024], &[512, 4, 4, 2, 2, 1024]));
        assert!(!no_costlier(&[256, 4, 4, 2, 2, 1024], &[256, 8, 8, 4, 1, 1024]));
        assert!(!no_costlier(&[1, 2], &[1, 2, 3]), "orders of different lengths never compare");
        assert_eq!(sweep(true, METHODS)[0].cost, None, "traced is never skipped");
    }
}
