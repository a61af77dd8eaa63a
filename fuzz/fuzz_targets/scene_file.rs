//! Scene files: any bytes, as TOML, must parse or be refused with an error; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let outcome = penumbra_fuzz::scene_file(data);
    if penumbra_fuzz::verbose() {
        eprintln!("{outcome:?}");
    }
});
