//! What the program around the renderer knows of a method besides its table: a line of
//! help, its section of the key reference (docs/scene-keys.md), whether it renders kept
//! instances. A method says it in its own folder ([`MethodEntry`]), so that the CLI's
//! registry is one line per method and the key reference names none. (What the bench knows
//! of it is the `bench_entry` crate's.)

use crate::interface::method::{MethodParams, default_table};

/// A method as the registry lists it: its parameters ([`MethodParams`]) and what the help and
/// the key reference need to know of it.
pub trait MethodEntry: MethodParams {
    /// One line of help (`--shadows`'s possible values).
    const ABOUT: &'static str;

    /// Its section of the key reference, under the generated heading
    /// ``## `[shadows.<name>]` ``: Markdown, ending with a line break. Each table row whose
    /// key cell is code (`` `key` ``) documents a key and its default, checked against
    /// [`MethodEntry::documented_keys`] and [`MethodParams::CHOICE_KEYS`].
    const KEYS_DOC: &'static str;

    /// Whether it renders a scene whose instances are kept unflattened
    /// ([`crate::geometry::instanced`]): only through the scene's ray queries, never its
    /// triangle arrays. A scene too big to flatten is refused for the others, before loading.
    const TRACES_KEPT_INSTANCES: bool = false;

    /// The keys its [`MethodEntry::KEYS_DOC`] documents, with the defaults it gives (the
    /// choice keys aside): the keys its table takes at its defaults, unless the method
    /// documents more (keys that apply only to another choice, with that choice's values).
    fn documented_keys() -> toml::Table {
        default_table::<Self>()
    }
}
