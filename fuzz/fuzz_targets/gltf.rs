//! glTF models (.glb, or .gltf JSON + NUL + its external buffer): any bytes must load or be
//! refused with an error; never a panic, a hang or an unbounded allocation.
#![no_main]

use libfuzzer_sys::fuzz_target;
use penumbra_fuzz::GltfHarness;
use std::sync::OnceLock;

/// One folder per process under the temp dir, reused by every input.
fn harness() -> &'static GltfHarness {
    static HARNESS: OnceLock<GltfHarness> = OnceLock::new();
    HARNESS.get_or_init(|| {
        GltfHarness::new(std::env::temp_dir().join(format!("penumbra-fuzz-gltf-{}", std::process::id())))
    })
}

fuzz_target!(|data: &[u8]| {
    let outcome = harness().run(data);
    if penumbra_fuzz::verbose() {
        eprintln!("{outcome:?}");
    }
});
