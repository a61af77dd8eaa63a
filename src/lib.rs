//! The `penumbra` command line: the composition root, the one place that knows every shadow
//! method and maps the scene file's `[shadows]` table to plugins. Its commands: `render`
//! ([`render`]), `merge` ([`merge`]) and `bench` ([`bench`]).

pub mod bench;
pub mod cli_error;
pub mod flags;
pub mod fonts;
pub mod frame_files;
pub mod heat;
pub mod key_reference;
pub mod memory;
pub mod merge;
pub mod methods;
pub mod output;
pub mod profile;
pub mod progress;
pub mod render;
pub mod request;
pub mod run_report;
pub mod scene_files;
pub mod shadows_config;
pub mod threads;
pub mod tile;

pub use cli_error::{CliError, OutputError};
pub use output::exit_cleanly_on_signals;
pub use render::{RenderArgs, RenderOutcome, run_render};
pub use renderer::load::scene_file::MAX_PRIMARY_SAMPLES;
pub use request::{DEFAULT_SCENE, DEFAULT_SCENE_NAME};
pub use threads::thread_pool;
