//! The registry: every shadow method by name. This is the one place that knows every
//! plugin, one line each. Everything else about a method lives in its own folder: its
//! parameters, defaults, checks and constructor ([`renderer::MethodParams`]), and its help
//! line and key reference section ([`renderer::MethodEntry`]), its bench sweep and plot colour
//! ([`bench_entry::BenchEntry`]). The
//! scene file's `[shadows]`, `--shadows`, the bench and the key reference loop over
//! [`METHODS`] (or a registry given in its place, in tests). A retired method leaves
//! [`METHODS`] for [`RETIRED`]: its code stays a library, and a scene file that still names
//! it gets an error saying what to use instead.

use bench_entry::{BenchEntry, SweepSetting};
use renderer::interface::method::{default_table, parse_boxed};
use renderer::{MethodEntry, SceneError, ShadowMethod, TracedParams, Unshadowed};
use shadow_plugin::{AnalyticParams, EdgeTableParams, PcssParams, SilhouetteParams};
use std::path::Path;

/// Parses a method's `[shadows.<name>]` table (`prefix` names it in errors).
pub type ParseFn = fn(&toml::Table, &Path, &str) -> Result<Box<dyn ShadowMethod>, SceneError>;

/// One method: what the rest of the program needs to know of it, read off its
/// [`MethodEntry`] and [`BenchEntry`] implementations.
#[derive(Clone, Copy)]
pub struct Registered {
    pub name: &'static str,
    /// A line of help.
    pub about: &'static str,
    pub parse: ParseFn,
    /// The keys its table takes, with their defaults (choice keys such as `preset` aside).
    pub keys: fn() -> toml::Table,
    /// Keys that pick a starting point (a preset) rather than set a field.
    pub choice_keys: &'static [&'static str],
    /// The keys its section of the key reference documents, with their defaults.
    pub documented_keys: fn() -> toml::Table,
    /// Its section of the key reference (Markdown, without the heading).
    pub keys_doc: &'static str,
    /// The settings the bench sweeps (`--quick` or not), in order.
    pub sweep: fn(bool) -> Vec<SweepSetting>,
    /// Where its settings go in the bench's sweep: lowest first, ties in registry order.
    pub bench_rank: u32,
    /// Its plot colour (sRGB) and whether its points are joined into a line.
    pub colour: [u8; 3],
    pub plot_line: bool,
    /// Whether it renders scenes whose instances stay unflattened (`traced`, `none`).
    pub traces_kept_instances: bool,
}

impl Registered {
    /// The entry of method `M`.
    pub const fn of<M: MethodEntry + BenchEntry>() -> Self {
        Self {
            name: M::NAME,
            about: M::ABOUT,
            parse: parse_boxed::<M>,
            keys: default_table::<M>,
            choice_keys: M::CHOICE_KEYS,
            documented_keys: M::documented_keys,
            keys_doc: M::KEYS_DOC,
            sweep: M::sweep,
            bench_rank: M::BENCH_RANK,
            colour: M::COLOUR,
            plot_line: M::PLOT_LINE,
            traces_kept_instances: M::TRACES_KEPT_INSTANCES,
        }
    }
}

/// Every method, the default first.
pub const METHODS: &[Registered] = &[
    Registered::of::<TracedParams>(),
    Registered::of::<Unshadowed>(),
    Registered::of::<EdgeTableParams>(),
    Registered::of::<PcssParams>(),
    Registered::of::<SilhouetteParams>(),
    Registered::of::<AnalyticParams>(),
];

/// Methods no longer registered, each with what to use instead: a scene file that names one
/// (`method` or its table) gets "`<file>: <key>: "<name>" was retired; <advice>`". Their code
/// stays in its crate; only the registry forgets them.
pub const RETIRED: &[(&str, &str)] = &[(
    "depth_march",
    "use method = \"edge_table\" (exact by default: lower error for less time on every bench \
     scene; reading = \"published\" takes depth_march's keys); see \
     docs/notes/2026-11-26-retired-depth-march.md",
)];

/// The registered method called `name`.
pub fn registered(name: &str) -> Option<&'static Registered> {
    METHODS.iter().find(|m| m.name == name)
}

/// What to use instead of `name`, if it is a retired method.
pub fn retired(name: &str) -> Option<&'static str> {
    RETIRED.iter().find(|(n, _)| *n == name).map(|&(_, advice)| advice)
}

/// The error for a scene file naming the retired method `name` at `key`.
pub fn retired_error(name: &str, file: &Path, key: &str) -> Option<SceneError> {
    retired(name).map(|advice| SceneError::new(file, key, format!("\"{name}\" was retired; {advice}")))
}

/// The method of `methods` called `name`.
pub fn find_in<'a>(methods: &'a [Registered], name: &str) -> Option<&'a Registered> {
    methods.iter().find(|m| m.name == name)
}

/// The method called `name`.
pub fn find(name: &str) -> Option<&'static Registered> {
    find_in(METHODS, name)
}

/// The names of `methods`, for messages: `"traced", "none", ...`.
pub fn names_of<'a>(methods: impl IntoIterator<Item = &'a str>) -> String {
    methods.into_iter().map(|m| format!("\"{m}\"")).collect::<Vec<_>>().join(", ")
}

/// The registered names, for messages: `"traced", "none", ...`.
pub fn names() -> String {
    names_of(METHODS.iter().map(|m| m.name))
}

/// A `--shadows` parser: the names of `methods`, each with its help line.
pub fn value_parser_of(methods: &[Registered]) -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(
        methods.iter().map(|m| clap::builder::PossibleValue::new(m.name).help(m.about)),
    )
}

/// `--shadows`'s parser: the registered names, each with its help line.
pub fn value_parser() -> clap::builder::PossibleValuesParser {
    value_parser_of(METHODS)
}
