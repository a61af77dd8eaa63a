//! How a shadow method is configured. Each method's parameters are one struct in the
//! plugin's own file, with its scene-file table ([`MethodParams::Table`], the keys of
//! `[shadows.<name>]` as serde reads them) beside it; defaults and presets are the plugin's.
//! The parameters check themselves ([`MethodParams::validate`]) and build the plugin
//! ([`ShadowMethod::build`]). The composition root (the CLI) only keeps a registry of names
//! to [`parse_method`].
//!
//! Code-only switches (ablations the bench measures, such as `traced`'s shaft culling) are
//! in the parameters, not in the table: the scene file cannot set them (they are unknown
//! keys there), a table laid over a preset keeps the preset's, tests and the bench set them.

use crate::interface::shadowing::LightShadowing;
use crate::util::error::SceneError;
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fmt;
use std::path::Path;

/// A configured shadow method: what the renderer needs to make one plugin per light.
pub trait ShadowMethod: fmt::Debug + Send + Sync {
    /// The method's name: `[shadows].method`, `--shadows` and the run report spell it so.
    fn name(&self) -> &'static str;
    /// Most light samples per shading point the method takes.
    fn max_samples(&self) -> u32;
    /// A fresh, unprepared plugin for one light, with `samples` light samples.
    fn build(&self, samples: u32) -> Box<dyn LightShadowing>;
}

/// A bad value in a method's table: the key relative to the table (`grid`), and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyError {
    pub key: &'static str,
    pub message: String,
}

impl KeyError {
    pub fn new(key: &'static str, message: impl Into<String>) -> Self {
        Self { key, message: message.into() }
    }
}

/// The table of a method that takes no keys (`[shadows.traced]`, `[shadows.none]`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct NoKeys {}

/// A method's parameters as the scene file reads them: [`MethodParams::Table`] is the
/// `[shadows.<name>]` table, the rest of `Self` the code-only switches.
pub trait MethodParams: ShadowMethod + Default + Clone + 'static {
    /// The method's name (see [`ShadowMethod::name`]).
    const NAME: &'static str;

    /// Keys that choose [`MethodParams::base`] (a preset) rather than set a field.
    const CHOICE_KEYS: &'static [&'static str] = &[];

    /// The method's `[shadows.<name>]` table, one field per key: flat (no `serde(flatten)`,
    /// so that every bad value's error names its key) and without `deny_unknown_fields`
    /// ([`parse_method`] names unknown keys itself). Serialised, it holds the keys one
    /// configuration reads: a key it leaves out has no effect there.
    type Table: Serialize + DeserializeOwned;

    /// The values the table's keys override: the default, or the preset the table names.
    fn base(table: &toml::Table) -> Result<Self, KeyError> {
        let _ = table;
        Ok(Self::default())
    }

    /// The keys this configuration reads, with their values.
    fn table(&self) -> Self::Table;

    /// This configuration with `table`'s values in place of its own; the code-only switches
    /// stay `self`'s.
    fn with_table(&self, table: Self::Table) -> Self;

    /// Why `key`, given in the table, has no effect with the other choices made (it is an
    /// error), or `None` when it does. A key [`MethodParams::table`] leaves out is always an
    /// error; this gives its reason.
    fn inapplicable(&self, key: &str) -> Option<String> {
        let _ = key;
        None
    }

    /// Checks what the types cannot (ranges, limits across keys).
    fn validate(&self) -> Result<(), KeyError>;
}

/// `table` (the method's `[shadows.<name>]`, `prefix` naming it in errors) typed as `M`: its
/// keys laid over [`MethodParams::base`], then checked. Every error names `file` and the key:
/// a bad value (serde's message, at the key its path gives), then an unknown key, a key that
/// has no effect, a value out of range.
pub fn parse_method<M: MethodParams>(
    table: &toml::Table,
    file: &Path,
    prefix: &str,
) -> Result<M, SceneError> {
    let key_error = |key: &str, message: String| SceneError::new(file, format!("{prefix}.{key}"), message);
    let base = M::base(table).map_err(|e| key_error(e.key, e.message))?;
    let mut fields = table.clone();
    fields.retain(|k, _| !M::CHOICE_KEYS.contains(&k));
    let values: M::Table = settings_over(&base.table(), &fields, file, prefix)?;
    let known = crate::util::keys::struct_fields::<M::Table>();
    if let Some(key) = fields.keys().find(|k| !known.contains(&k.as_str())) {
        return Err(key_error(key, unknown_key_message(key, &base)));
    }
    let params = base.with_table(values);
    let read = table_of(&params);
    let why_not = |k: &str| {
        params
            .inapplicable(k)
            .or_else(|| (!read.contains_key(k)).then(|| "has no effect with the table's other keys".into()))
    };
    if let Some((key, why)) = fields.keys().find_map(|k| Some((k, why_not(k)?))) {
        return Err(key_error(key, why));
    }
    params.validate().map_err(|e| key_error(e.key, e.message))?;
    Ok(params)
}

/// serde's words for an unknown field, with the keys `base` reads (and the choice keys) as
/// the ones expected.
fn unknown_key_message<M: MethodParams>(key: &str, base: &M) -> String {
    let mut keys: Vec<String> = table_of(base).into_iter().map(|(k, _)| k).collect();
    keys.retain(|k| base.inapplicable(k).is_none());
    keys.extend(M::CHOICE_KEYS.iter().map(|k| k.to_string()));
    keys.sort();
    if keys.is_empty() {
        return format!("unknown field `{key}`, there are no fields");
    }
    let keys: Vec<String> = keys.iter().map(|k| format!("`{k}`")).collect();
    format!("unknown field `{key}`, expected one of {}", keys.join(", "))
}

/// [`parse_method`], boxed: the registry's constructor.
pub fn parse_boxed<M: MethodParams>(
    table: &toml::Table,
    file: &Path,
    prefix: &str,
) -> Result<Box<dyn ShadowMethod>, SceneError> {
    Ok(Box::new(parse_method::<M>(table, file, prefix)?))
}

/// The keys `M`'s table takes at its defaults, with their default values (the choice keys
/// aside): what the key reference (docs/scene-keys.md) lists.
pub fn default_table<M: MethodParams>() -> toml::Table {
    let params = M::default();
    let mut table = table_of(&params);
    table.retain(|k, _| params.inapplicable(k).is_none());
    table
}

/// Whether `params` reads `key`: its table ([`MethodParams::table`]) has it.
pub fn reads<M: MethodParams>(params: &M, key: &str) -> bool {
    table_of(params).contains_key(key)
}

/// `T` from `base`'s values with `table`'s keys in their place. Bad values are errors naming
/// `prefix.key` (the path serde reports: `T` must be flat, see [`MethodParams::Table`]).
pub fn settings_over<T: Serialize + DeserializeOwned>(
    base: &T,
    table: &toml::Table,
    file: &Path,
    prefix: &str,
) -> Result<T, SceneError> {
    let mut merged = as_table(base);
    merged.extend(table.iter().map(|(k, v)| (k.clone(), v.clone())));
    crate::util::keys::deserialize_value::<T>(toml::Value::Table(merged), file, prefix)
}

/// `params`' table as TOML: the keys it reads, with their values.
fn table_of<M: MethodParams>(params: &M) -> toml::Table {
    as_table(&params.table())
}

fn as_table<T: Serialize>(value: &T) -> toml::Table {
    match toml::Value::try_from(value).expect("method tables serialise") {
        toml::Value::Table(t) => t,
        _ => panic!("method tables serialise to a table"),
    }
}
