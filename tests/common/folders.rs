//! A fresh scratch folder per test, and the `penumbra` binary run in one. Included with
//! `#[path]` by the test files that use it.

#![allow(dead_code)] // each test file uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh, empty folder `penumbra-<test file>-<pid>-<name>` under the system temp dir, left
/// in place for inspection (a test removes it when it passes).
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "penumbra-{}-{}-{name}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `penumbra ARGS`, run in `cwd`.
pub fn penumbra(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_penumbra")).args(args).current_dir(cwd).output().expect("penumbra runs")
}
