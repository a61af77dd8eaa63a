//! The loaders' fuzz targets (fuzz/, `cargo +nightly fuzz`) on stable: every input a fuzzer
//! found that crashed, hung or ran out of memory is kept under
//! `tests/fuzz_regressions/<target>/` and run here through the target's own code
//! (fuzz/src/lib.rs, included below), with the outcome it must now have. The committed
//! seeds are checked too: a seed that stops loading no longer leads the fuzzer anywhere.

#[path = "../../fuzz/src/lib.rs"]
#[allow(dead_code)] // `verbose` serves the fuzz targets only
mod fuzz_harness;

use fuzz_harness::{GltfHarness, Outcome};
use std::path::{Path, PathBuf};

/// What a kept input must come to now.
enum Expect {
    Loaded,
    /// Refused with an error whose key is this and whose message contains the text.
    Refused(&'static str, &'static str),
}

/// Every file under tests/fuzz_regressions/, by target and file name. `handmade-*` inputs
/// were written by hand for holes seen while fixing the fuzzers' findings; the others are
/// the fuzzers' inputs as found. `camera-collapses-in-f32.gltf` is ../shared's monobloc
/// chair (CC0, Poly Haven) and `bvh-deeper-than-max-depth.gltf` its glass vase and flowers
/// (CC0, Eric Chadwick and Rico Cilliers), with bytes changed by the fuzzer.
const EXPECTED: &[(&str, &str, Expect)] = &[
    // Scene::load: position - world_offset and look_at - world_offset round to one f32;
    // Camera::from_frame's debug assertion fired (release: a NaN camera, a blank image) when
    // render space was centred on the models; centred on the camera, the scene loads.
    ("gltf", "camera-collapses-in-f32.gltf", Expect::Loaded),
    // gltf::Gltf::open allocated the .glb header's length (4 GiB) before reading.
    ("gltf", "glb-header-length-4gib.glb", Expect::Refused("", "its header declares 4294966196")),
    ("gltf", "handmade-glb-length-below-12.glb", Expect::Refused("", "GLB header length 4 does not fit")),
    // gltf's Image::source unwrapped the missing mimeType of a bufferView image.
    ("gltf", "image-view-without-mimetype.glb", Expect::Refused("images[0]", "bufferView but no mimeType")),
    // gltf's image import sliced a bufferView beyond its buffer.
    ("gltf", "image-view-outside-buffer.glb", Expect::Refused("images[0]", "lies outside its buffer")),
    // gltf-json's validation indexed the accessors by POSITION before checking the index.
    ("gltf", "position-accessor-out-of-range.gltf", Expect::Refused("", "POSITION: no accessor 0")),
    // gltf's import unwrapped the percent-decoding of a relative URI (%FF, %C0: not UTF-8).
    ("gltf", "handmade-buffer-uri-not-utf8.gltf", Expect::Refused("", "buffers[0].uri: its %-escapes")),
    ("gltf", "handmade-image-uri-not-utf8.glb", Expect::Refused("images[0]", "uri: its %-escapes")),
    // obvhs left Bvh2::max_depth (127) below the tree's depth (143), which sizes its traversal
    // stacks (its debug validation fired); Scene::build now raises it. Loads.
    ("gltf", "bvh-deeper-than-max-depth.gltf", Expect::Loaded),
    // A chain of 25 nodes each listing the next twice: 2^24 visits (a timeout), and a node
    // listing itself twice: 2^256.
    ("gltf", "handmade-node-dag-hang.gltf", Expect::Refused("nodes[24]", "reached twice")),
    ("gltf", "handmade-node-self-loop.gltf", Expect::Refused("nodes[0]", "reached twice")),
    // gltf's reader asserted on a byteStride (5) under a VEC3 float's 12 bytes.
    (
        "gltf",
        "byte-stride-under-element-size.gltf",
        Expect::Refused("meshes[0].primitives[0].attributes.POSITION", "byteStride 5"),
    ),
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The files of a folder, sorted; none if it does not exist.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries.map(|e| e.expect("a folder entry").path()).filter(|p| p.is_file()).collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

/// A per-process folder for the glTF target's files, removed when dropped.
struct Scratch(GltfHarness);

impl Scratch {
    fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("penumbra-fuzz-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        Self(GltfHarness::new(dir))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(self.0.dir());
    }
}

/// Runs `input` through `target`'s code; a panic is reported as an error, not raised.
fn run(target: &str, gltf: &GltfHarness, input: &Path) -> Result<Outcome, String> {
    let data = std::fs::read(input).map_err(|e| format!("cannot read: {e}"))?;
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match target {
        "scene_file" => fuzz_harness::scene_file(&data),
        "gltf" => gltf.run(&data),
        _ => panic!("unknown target {target}"),
    }))
    .map_err(|p| {
        let msg =
            p.downcast_ref::<String>().cloned().or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()));
        format!("panicked: {}", msg.unwrap_or_default())
    })
}

#[test]
fn kept_fuzz_inputs_are_errors_or_scenes_not_crashes() {
    let scratch = Scratch::new("regressions");
    let base = root().join("tests/fuzz_regressions");
    let mut failures = Vec::new();
    let mut seen = 0;
    for target in ["scene_file", "gltf"] {
        for input in files(&base.join(target)) {
            seen += 1;
            let name = input.file_name().unwrap().to_string_lossy().into_owned();
            let Some((.., expect)) = EXPECTED.iter().find(|(t, n, _)| *t == target && *n == name) else {
                failures.push(format!("{target}/{name}: not in EXPECTED (add its outcome)"));
                continue;
            };
            match (run(target, &scratch.0, &input), expect) {
                (Ok(Outcome::Loaded), Expect::Loaded) => {}
                (Ok(Outcome::Refused(e)), Expect::Refused(key, text))
                    if e.key == *key && e.message.contains(text) => {}
                (got, _) => failures.push(format!("{target}/{name}: got {got:?}")),
            }
        }
    }
    assert_eq!(seen, EXPECTED.len(), "an EXPECTED entry has no file");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn seeds_load() {
    let scratch = Scratch::new("seeds");
    let mut failures = Vec::new();
    let seeds = files(&root().join("fuzz/seeds/gltf"));
    assert!(seeds.len() >= 6, "the hand-made glTF seeds are missing");
    for seed in seeds {
        match run("gltf", &scratch.0, &seed) {
            Ok(Outcome::Loaded) => {}
            got => failures.push(format!("{}: {got:?}", seed.display())),
        }
    }
    let mut scenes = files(&root().join("scenes"));
    for sub in ["bench", "gltf"] {
        scenes.extend(files(&root().join("scenes").join(sub)));
    }
    for scene in scenes {
        match run("scene_file", &scratch.0, &scene) {
            Ok(Outcome::Loaded) => {}
            got => failures.push(format!("{}: {got:?}", scene.display())),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The fix behind `bvh-deeper-than-max-depth.gltf`: obvhs sizes its traversal stacks by
/// `Bvh2::max_depth`, so it must exceed the tree's depth (the build alone left 127 for 143).
/// The input's meshes are now shared, so its tree is joined from copies of one mesh's
/// (`scene_bvh`), which starts from obvhs's default stack of 96: still too small for it.
#[test]
fn bvh_max_depth_covers_the_tree() {
    let scratch = Scratch::new("bvh-depth");
    let input = root().join("tests/fuzz_regressions/gltf/bvh-deeper-than-max-depth.gltf");
    let data = std::fs::read(&input).expect("read the input");
    // Writes m.gltf and b.bin into the scratch folder, and loads them.
    assert!(matches!(scratch.0.run(&data), Outcome::Loaded));
    let scene_path = scratch.0.dir().join("scene.toml");
    let text = "[[model]]\npath = \"m.gltf\"\n[camera]\nposition = [0.0, 1.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n\
                [[light]]\ncenter = [0.0, 3.0, 0.0]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 0.0, -1.0]\n\
                radiance = [1.0, 1.0, 1.0]\n";
    let file = renderer::SceneFile::parse(text, &scene_path).expect("a valid scene");
    let scene = renderer::Scene::load(&file, &scene_path).expect("the input loads");
    let bvh = scene.bvh.as_ref().expect("triangles");
    let depth = bvh.depth(0);
    assert!(
        depth > obvhs::bvh2::DEFAULT_MAX_STACK_DEPTH,
        "the input no longer builds a tree deeper than obvhs's default stack ({depth} levels)"
    );
    assert!(bvh.max_depth > depth, "max_depth {} for a tree of depth {depth}", bvh.max_depth);
}
