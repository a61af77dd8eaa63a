//! The real scenes beside the checkout, `../shared/gltf`, which the scene files of
//! `scenes/gltf` and `scenes/bench` name. A clone without them still passes its suite: each
//! test that reads them asks [`scenes_present`] first and returns early, and one line for
//! the whole `cargo test` run says which tests did not run and how to get the scenes. CI
//! must run them all: there (the `CI` variable set) their absence fails the test.

#![allow(dead_code)] // each test binary uses a different subset

use std::io::Write;
use std::path::PathBuf;

/// Every test that reads `../shared`, as its test file and name: the skip note lists them.
pub const READERS: &[&str] = &[
    "shared_scenes (all 12)",
    "exact_edge_table::shared_and_bench_scenes_agree_with_the_bvh",
    "silhouette::shared_scenes_agree_with_the_bvh",
    "silhouette::points_with_more_edges_than_the_counting_pays_for",
    "silhouette::shared_scenes_with_kept_instances_agree_with_the_bvh",
    "bench::a_changed_model_buffer_renders_the_truth_anew",
    "instances::metal_rough_spheres_kept_answers_as_flattened",
    "materials::generated_tangents_agree_with_flight_helmets_own",
    "material_shading::diffuse_reads_nothing_but_base_colour_on_every_shared_scene",
];

/// Where to read how to get the scenes.
const HOW_TO_GET: &str = "README.md, \"The scenes\"";

/// The scene files of `scenes/gltf` (one per shared model), sorted.
pub fn gltf_scene_files() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/gltf");
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("scenes/gltf")
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    scenes
}

/// `../shared/gltf`, beside the checkout.
pub fn gltf_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf")
}

/// True when `../shared/gltf` is there. When it is not: under CI (`CI` set, not "false" or
/// "0") a panic naming it; elsewhere false, after one line on stderr for the whole run (the
/// first skipping test of a `cargo test` writes it, past the harness's output capture).
/// `reader` is the caller's entry in [`READERS`].
pub fn scenes_present(reader: &str) -> bool {
    assert!(READERS.contains(&reader), "{reader}: add it to tests/common/shared.rs READERS");
    let dir = gltf_dir();
    if dir.is_dir() {
        return true;
    }
    let shown = dir.display();
    if std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0") {
        panic!("{shown} is missing and CI must run every test: put the shared scenes there ({HOW_TO_GET})");
    }
    if first_note_of_this_run() {
        let note = format!(
            "note: {shown} is missing, so these tests did not run: {}; to run them, put the shared \
             scenes there ({HOW_TO_GET})\n",
            READERS.join(", ")
        );
        // Straight to the file descriptor: libtest captures only print!/eprint!, and shows a
        // passing test's captured output to no one.
        let _ = std::io::stderr().lock().write_all(note.as_bytes());
    }
    false
}

/// True for the first caller of one `cargo test` run, across its test binaries and threads:
/// they share a parent process (cargo), so a marker file named by that process (its id and
/// start time, which a reused id does not share) is created once.
fn first_note_of_this_run() -> bool {
    #[cfg(unix)]
    let run = {
        let parent = std::os::unix::process::parent_id();
        let started = std::fs::read_to_string(format!("/proc/{parent}/stat"))
            .ok()
            .and_then(|s| s.rsplit(')').next().and_then(|r| r.split_whitespace().nth(19).map(String::from)))
            .unwrap_or_default();
        format!("{parent}-{started}")
    };
    #[cfg(not(unix))]
    let run = std::process::id().to_string();
    let marker = std::env::temp_dir().join(format!("penumbra-shared-missing-noted-{run}"));
    std::fs::OpenOptions::new().write(true).create_new(true).open(marker).is_ok()
}
