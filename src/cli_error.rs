//! What the command line reports when it stops: one type per kind of failure, each printed
//! as one line before exit status 2. Bad input (a scene file, a glTF file, a flag, a tile's
//! report) is the renderer's [`SceneError`], naming the file and the key; an output that
//! could not be written is an [`OutputError`], naming the path and the flag that chose it.
//! Either way nothing is left half-written (`output::StagedFiles`).

use renderer::SceneError;
use std::fmt;
use std::path::{Path, PathBuf};

/// A file or folder the command could not write: its path, the flag that chose it (`--out`,
/// `--cache`), and what went wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputError {
    pub path: PathBuf,
    pub flag: &'static str,
    pub message: String,
}

impl OutputError {
    pub fn new(path: impl AsRef<Path>, flag: &'static str, message: impl Into<String>) -> Self {
        Self { path: path.as_ref().to_path_buf(), flag, message: message.into() }
    }
}

impl fmt::Display for OutputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let message = self.message.replace(['\n', '\r'], " ");
        write!(f, "{}: {}: {message}", self.path.display(), self.flag)
    }
}

impl std::error::Error for OutputError {}

/// Why a command stopped.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CliError {
    /// Bad input: `FILE: KEY: what is wrong`.
    #[error(transparent)]
    Input(#[from] SceneError),
    /// An output not written: `PATH: FLAG: what went wrong`.
    #[error(transparent)]
    Output(#[from] OutputError),
}
