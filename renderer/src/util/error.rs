//! The error for input a user got wrong: a scene file, a glTF file, a value a flag gave for
//! a scene-file key. Its `Display` is a single line `FILE: KEY: what is wrong`, which is what
//! the CLI prints before exiting with status 2. (An output the CLI cannot write is its own
//! kind, `penumbra::OutputError`.)

use std::fmt;
use std::path::{Path, PathBuf};

/// A user-facing error: the file it concerns, the key (a TOML key path such as
/// `light[0].u`, a glTF JSON path such as `meshes[3].primitives[0].attributes.POSITION`, or a
/// byte offset) and a message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneError {
    pub file: PathBuf,
    pub key: String,
    pub message: String,
}

impl SceneError {
    pub fn new(file: impl AsRef<Path>, key: impl Into<String>, message: impl Into<String>) -> Self {
        Self { file: file.as_ref().to_path_buf(), key: key.into(), message: message.into() }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // One line, always: collapse any newline a lower layer put in its message.
        let message = self.message.replace(['\n', '\r'], " ");
        if self.key.is_empty() {
            write!(f, "{}: {}", self.file.display(), message)
        } else {
            write!(f, "{}: {}: {}", self.file.display(), self.key, message)
        }
    }
}

impl std::error::Error for SceneError {}
