//! The registry: every shadow method by name. This is the one place that knows every
//! plugin; a method's parameters, defaults, checks and constructor live in its own file
//! ([`renderer::MethodParams`]), so adding a method is that file, one line here and its section in docs/scene-keys.md.

use renderer::interface::method::{default_table, parse_boxed};
use renderer::{MethodParams, SceneError, ShadowMethod, TracedParams, Unshadowed};
use shadow_plugin::{DepthMarchParams, EdgeTableParams, PcssParams};
use std::path::Path;

/// Parses a method's `[shadows.<name>]` table (`prefix` names it in errors).
pub type ParseFn = fn(&toml::Table, &Path, &str) -> Result<Box<dyn ShadowMethod>, SceneError>;

/// One method: its name, a line of help, its parser and its keys.
pub struct Registered {
    pub name: &'static str,
    pub about: &'static str,
    pub parse: ParseFn,
    /// The keys its table takes, with their defaults (choice keys such as `preset` aside).
    pub keys: fn() -> toml::Table,
    /// Keys that pick a starting point (a preset) rather than set a field.
    pub choice_keys: &'static [&'static str],
}

impl Registered {
    const fn of<M: MethodParams>(about: &'static str) -> Self {
        Self {
            name: M::NAME,
            about,
            parse: parse_boxed::<M>,
            keys: default_table::<M>,
            choice_keys: M::CHOICE_KEYS,
        }
    }
}

/// Every method, the default first.
pub const METHODS: &[Registered] = &[
    Registered::of::<TracedParams>(
        "Shadow rays through the BVH to `samples` stratified points on the light: the truth",
    ),
    Registered::of::<Unshadowed>("No shadows (V = 1): the cost floor"),
    Registered::of::<EdgeTableParams>(
        "Edge-table masks (Egan & Neulander 2004) classifying each ray against conservative depth bounds; the BVH traces only what they cannot settle: exact",
    ),
    Registered::of::<DepthMarchParams>(
        "Each shadow ray marched through the same depth map (walls and floors)",
    ),
    Registered::of::<PcssParams>("Percentage-closer soft shadows (Fernando 2005) on the same depth map"),
];

/// The method called `name`.
pub fn find(name: &str) -> Option<&'static Registered> {
    METHODS.iter().find(|m| m.name == name)
}

/// The registered names, for messages: `"traced", "none", ...`.
pub fn names() -> String {
    METHODS.iter().map(|m| format!("\"{}\"", m.name)).collect::<Vec<_>>().join(", ")
}

/// `--shadows`'s parser: the registered names, each with its help line.
pub fn value_parser() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(
        METHODS.iter().map(|m| clap::builder::PossibleValue::new(m.name).help(m.about)),
    )
}
