//! `edge_table`'s memory budget as a user meets it: a depth map or masks that would not fit
//! are refused from an estimate, before they are built, in one line naming the file, the
//! setting and the memory it would need (exit 2, nothing written). The budget is set through
//! `PENUMBRA_MASK_BUDGET_MIB` so that the answers do not depend on the machine.

use crate::common::folders;
use folders::temp_dir;
use std::path::Path;
use std::process::{Command, Output};

const SCENE: &str = card_scene!("[shadows]\nmethod = \"edge_table\"\nsamples = 1024\n");

/// Renders `scene` (written as s.toml in `dir`) under a budget of `budget_mib` MiB.
fn render(dir: &Path, scene: &str, budget_mib: &str, extra: &[&str]) -> Output {
    std::fs::write(dir.join("s.toml"), scene).unwrap();
    Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["render", "s.toml", "--quiet", "--out", "o.png"])
        .args(extra)
        .env("PENUMBRA_MASK_BUDGET_MIB", budget_mib)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// The one line of a refused render (exit 2, nothing written).
fn refusal(dir: &Path, o: &Output) -> String {
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(!dir.join("o.png").exists() && !dir.join("o.json").exists(), "something was written");
    stderr.trim_end().to_string()
}

/// `depth_map = 8192` (the largest accepted) needs 80 bytes per pixel at the peak of its
/// build, 5.0 GiB: over a 4 GiB budget it is refused before the map is built (it took 41 s
/// and 4.9 GiB to build on a 2-core machine).
#[test]
fn a_depth_map_over_the_budget_is_refused_with_the_memory_it_needs() {
    let dir = temp_dir("map");
    let scene = format!("{SCENE}\n[shadows.edge_table]\ndepth_map = 8192\n");
    let line = refusal(&dir, &render(&dir, &scene, "4096", &[]));
    // The budget left: 4 GiB less the 376 visible points the frame holds (so "4.0 GiB").
    assert_eq!(
        line,
        "error: s.toml: shadows: edge_table: depth_map = 8192 needs about 5.0 GiB to build (8192 x 8192 \
         pixels, 80 bytes each), more than the 4.0 GiB left of the memory budget; use a smaller depth_map \
         (each halving needs a quarter)"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A 64 x 64 x 1 grid at 4096 samples: 4096 masks of several MiB each, estimated from one
/// mask per depth level marched but not built, and refused before any mask is built (it used
/// to be refused only once the built masks passed the budget: 39 s and 11.9 GB on a 2-core
/// machine at its default budget).
#[test]
fn masks_over_the_budget_are_refused_with_the_memory_they_need() {
    let dir = temp_dir("masks");
    let scene = format!("{SCENE}\n[shadows.edge_table]\ngrid = [64, 64, 1]\n");
    let line = refusal(&dir, &render(&dir, &scene, "4096", &["--samples", "4096"]));
    let (head, tail) = line.split_once(" GiB (4096 masks of about ").expect(&line);
    let need: f64 = head
        .strip_prefix("error: s.toml: shadows: edge_table: the masks need about ")
        .expect(&line)
        .parse()
        .unwrap();
    assert!(need > 4.0, "{line}");
    assert!(
        tail.ends_with(
            ": grid [64, 64, 1] x 4096 samples), more than the 4.0 GiB left of the memory budget; use a \
             smaller grid, fewer samples or a smaller depth map"
        ),
        "{line}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The user's report: masks needing some 200 GiB behind an 8192^2 depth map were refused
/// only after the map was built (22-63 s and 5 GB on a 2-core machine). The masks are now
/// estimated on a coarse map first: refused before the large map is built (measured: 0.64 s,
/// 112 MB peak).
#[test]
fn impossible_masks_are_refused_before_the_depth_map_is_built() {
    let dir = temp_dir("masks_early");
    let scene = format!("{SCENE}\n[shadows.edge_table]\ndepth_map = 8192\ngrid = [16, 16, 16]\n");
    let line = refusal(&dir, &render(&dir, &scene, "8192", &["--samples", "4096"]));
    assert!(line.starts_with("error: s.toml: shadows: edge_table: the masks need "), "{line}");
    assert!(line.contains("grid [16, 16, 16] x 4096 samples"), "{line}");
    assert!(line.ends_with("(estimated on a 256^2 map, before the 8192^2 one was built)"), "{line}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The default grid's masks at 1024 samples: refused under a budget that holds the map but
/// not the masks (naming grid and samples as before), built under a larger one, where the
/// estimate made before building is within 5% of the bytes the masks took.
#[test]
fn the_mask_estimate_matches_the_masks_built() {
    let dir = temp_dir("estimate");
    let line = refusal(&dir, &render(&dir, SCENE, "8", &[]));
    for needle in ["s.toml: shadows: edge_table: the masks need about ", "grid [2, 2, 8] x 1024 samples"] {
        assert!(line.contains(needle), "{line:?} does not name {needle:?}");
    }
    let o = render(&dir, SCENE, "4096", &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("o.json")).unwrap()).unwrap();
    let built = report["counters"]["mask_bytes"].as_u64().unwrap() as f64;
    let estimated = report["counters"]["mask_bytes_estimated"].as_u64().unwrap() as f64;
    assert!(built > 1e6, "{built} bytes of masks");
    assert!((estimated / built - 1.0).abs() < 0.05, "estimated {estimated} bytes, built {built}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A budget of 0 refuses even the smallest map, naming `depth_map`.
#[test]
fn a_zero_budget_refuses_the_map_first() {
    let dir = temp_dir("zero");
    let line = refusal(&dir, &render(&dir, SCENE, "0", &[]));
    assert!(
        line.starts_with("error: s.toml: shadows: edge_table: depth_map = 256 needs about 5.0 MiB"),
        "{line}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A light that faces away from everything reaches no receiver: its masks once sat at an
/// infinite depth and marched without end (24 GB at 40x32 pixels, then the OOM killer).
/// Now the frame renders under a 64 MiB budget, black where only that light would shine, and
/// warns of the light.
#[test]
fn a_light_facing_away_from_the_scene_costs_edge_table_almost_nothing() {
    let dir = temp_dir("facing-away");
    let away = SCENE.replace("v = [0.0, 0.0, 0.5]\nradiance", "v = [0.0, 0.0, -0.5]\nradiance");
    assert_ne!(away, SCENE);
    std::fs::write(dir.join("s.toml"), &away).unwrap();
    // Under a 2 GiB address-space limit: were the endless march back, the child's allocation
    // would fail here and the test with it, not the machine's memory (and CI with it).
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 2097152 && exec '{}' render s.toml --quiet --out o.png",
            env!("CARGO_BIN_EXE_penumbra")
        ))
        .env("PENUMBRA_MASK_BUDGET_MIB", "64")
        .current_dir(&dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{:?}: {stderr}", o.status);
    assert!(stderr.contains("light 0 reaches no visible point"), "{stderr}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("o.json")).unwrap()).unwrap();
    let bytes = report["counters"]["mask_bytes"].as_u64().unwrap()
        + report["counters"]["depth_map_bytes"].as_u64().unwrap();
    assert!(bytes < 4 << 20, "{bytes} bytes of masks and depth map for a light that reaches nothing");
    std::fs::remove_dir_all(&dir).unwrap();
}
