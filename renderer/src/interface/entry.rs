//! What the program around the renderer knows of a method besides its table: a line of
//! help, its section of the key reference (docs/scene-keys.md), the settings the bench
//! sweeps and its colour in the bench's plots. A method says all of it in its own folder
//! ([`MethodEntry`]), so that the CLI's registry is one line per method and neither the
//! bench nor the key reference names any method.

use crate::interface::method::{MethodParams, ShadowMethod, default_table};
use std::sync::Arc;

/// One setting of the bench's sweep: a method with its parameters (code-only switches
/// included), a sample count, and how the bench treats it.
#[derive(Debug, Clone)]
pub struct SweepSetting {
    /// The row's label (`results.csv`'s `setting`): unique over the whole sweep.
    pub label: String,
    pub method: Arc<dyn ShadowMethod>,
    /// Light samples per shading point.
    pub samples: u32,
    /// Where the setting stands in its method's cost order, parameter by parameter, each
    /// only making a run costlier as it grows; `None`: never skipped. Once a setting's first
    /// run takes longer than `--max-run-seconds`, the later settings of the same method that
    /// are at least as costly in every parameter ([`no_costlier`]) are skipped.
    pub cost: Option<Vec<u32>>,
    /// The row the equal-error speedup is computed for (at most one in a sweep; the CSV's
    /// `headline` column).
    pub headline: bool,
    /// One of the runs the headline is compared with: the speedup is the cost of the
    /// cheapest reference run at or below the headline's error over the headline's cost.
    pub reference: bool,
}

impl SweepSetting {
    /// `method` with `samples`, labelled `label`: never skipped, neither headline nor reference.
    pub fn new(label: String, method: impl ShadowMethod + 'static, samples: u32) -> Self {
        Self { label, method: Arc::new(method), samples, cost: None, headline: false, reference: false }
    }
}

/// Whether cost order `a` is at most `b` in every parameter (orders of different lengths
/// are not comparable: never).
pub fn no_costlier(a: &[u32], b: &[u32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x <= y)
}

/// The sample count the bench compares methods at: 1024, 64 in its quick sweep.
pub const fn top_samples(quick: bool) -> u32 {
    if quick { 64 } else { 1024 }
}

/// A method as the registry lists it: its parameters ([`MethodParams`]) and what the help,
/// the key reference and the bench need to know of it.
pub trait MethodEntry: MethodParams {
    /// One line of help (`--shadows`'s possible values).
    const ABOUT: &'static str;

    /// Its section of the key reference, under the generated heading
    /// ``## `[shadows.<name>]` ``: Markdown, ending with a line break. Each table row whose
    /// key cell is code (`` `key` ``) documents a key and its default, checked against
    /// [`MethodEntry::documented_keys`] and [`MethodParams::CHOICE_KEYS`].
    const KEYS_DOC: &'static str;

    /// Its colour in the bench's plots (sRGB), the same on every scene.
    const COLOUR: [u8; 3];

    /// Whether the plot joins its points into a line: for a family of one parameter (a
    /// sample count); settings that differ in several ways at once are points.
    const PLOT_LINE: bool = false;

    /// Where its settings go in the bench's sweep, and so in `results.csv`: lowest first,
    /// ties in the registry's order.
    const BENCH_RANK: u32 = u32::MAX;

    /// Whether it renders a scene whose instances are kept unflattened
    /// ([`crate::geometry::instanced`]): only through the scene's ray queries, never its
    /// triangle arrays. A scene too big to flatten is refused for the others, before loading.
    const TRACES_KEPT_INSTANCES: bool = false;

    /// The settings the bench sweeps (`quick`: the short sweep of `--quick`), in order.
    fn sweep(quick: bool) -> Vec<SweepSetting>;

    /// The keys its [`MethodEntry::KEYS_DOC`] documents, with the defaults it gives (the
    /// choice keys aside): the keys its table takes at its defaults, unless the method
    /// documents more (keys that apply only to another choice, with that choice's values).
    fn documented_keys() -> toml::Table {
        default_table::<Self>()
    }
}
