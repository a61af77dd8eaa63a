//! How a shadow method is configured. Each method's parameters are one struct in the
//! plugin's own file: it *is* the scene file's `[shadows.<name>]` table (serde, unknown keys
//! rejected, defaults and presets in the plugin), it checks itself ([`MethodParams::validate`])
//! and it builds the plugin ([`ShadowMethod::build`]). The composition root (the CLI) only
//! keeps a registry of names to [`parse_method`].
//!
//! Code-only switches (ablations the bench measures, such as `traced`'s shaft culling) are
//! fields serde skips: the scene file cannot set them, tests and the bench can.

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

/// A method's parameter struct as the scene file reads it.
pub trait MethodParams: ShadowMethod + Serialize + DeserializeOwned + Default + Clone + 'static {
    /// The method's name (see [`ShadowMethod::name`]).
    const NAME: &'static str;

    /// Keys that choose [`MethodParams::base`] (a preset) rather than set a field.
    const CHOICE_KEYS: &'static [&'static str] = &[];

    /// The values the table's keys override: the default, or the preset the table names.
    fn base(table: &toml::Table) -> Result<Self, KeyError> {
        let _ = table;
        Ok(Self::default())
    }

    /// Why `key`, given in the table, has no effect with the other choices made (it is an
    /// error), or `None` when it does.
    fn inapplicable(&self, key: &str) -> Option<String> {
        let _ = key;
        None
    }

    /// Copies the fields the scene file cannot set (serde skips them) from `base`. Required:
    /// a skipped field left out here would silently take its type's default, not the preset's.
    fn keep_code_only(&mut self, base: &Self);

    /// Checks what the types cannot (ranges, limits across keys).
    fn validate(&self) -> Result<(), KeyError>;
}

/// `table` (the method's `[shadows.<name>]`, `prefix` naming it in errors) typed as `M`: its
/// keys laid over [`MethodParams::base`], then checked. Every error names `file` and the key.
pub fn parse_method<M: MethodParams>(
    table: &toml::Table,
    file: &Path,
    prefix: &str,
) -> Result<M, SceneError> {
    let key_error = |e: KeyError| SceneError::new(file, format!("{prefix}.{}", e.key), e.message);
    let base = M::base(table).map_err(key_error)?;
    let mut fields = table.clone();
    fields.retain(|k, _| !M::CHOICE_KEYS.contains(&k));
    let mut params: M = settings_over(&base, &fields, file, prefix).map_err(|e| {
        if !e.message.starts_with("unknown field")
            || e.message.contains("expected")
            || e.message.contains("no fields")
        {
            return e;
        }
        // Flattened structs do not list what they expect: the base's keys are the table's.
        let mut keys: Vec<String> = base_table(&base)
            .into_iter()
            .map(|(k, _)| k)
            .filter(|k| base.inapplicable(k).is_none())
            .collect();
        keys.extend(M::CHOICE_KEYS.iter().map(|k| k.to_string()));
        keys.sort();
        let keys: Vec<String> = keys.iter().map(|k| format!("`{k}`")).collect();
        SceneError { message: format!("{}, expected one of {}", e.message, keys.join(", ")), ..e }
    })?;
    params.keep_code_only(&base);
    if let Some((key, why)) = fields.keys().find_map(|k| Some((k, params.inapplicable(k)?))) {
        return Err(SceneError::new(file, format!("{prefix}.{key}"), why));
    }
    params.validate().map_err(key_error)?;
    Ok(params)
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
    let mut table = base_table(&params);
    table.retain(|k, _| params.inapplicable(k).is_none());
    table
}

/// `T` from `base`'s values with `table`'s keys in their place. Unknown keys and bad values
/// are errors naming `prefix.key`.
pub fn settings_over<T: Serialize + DeserializeOwned>(
    base: &T,
    table: &toml::Table,
    file: &Path,
    prefix: &str,
) -> Result<T, SceneError> {
    let mut merged = base_table(base);
    merged.extend(table.iter().map(|(k, v)| (k.clone(), v.clone())));
    let e = match crate::util::keys::deserialize_value::<T>(toml::Value::Table(merged), file, prefix) {
        Ok(params) => return Ok(params),
        Err(e) => e,
    };
    if e.key != prefix {
        return Err(e);
    }
    // A flattened struct's type errors carry no path: find the key by laying the table's
    // keys over the base one at a time (only on this error path).
    for (k, v) in table {
        let mut one = base_table(base);
        one.insert(k.clone(), v.clone());
        if let Err(mut e) = crate::util::keys::deserialize_value::<T>(toml::Value::Table(one), file, prefix) {
            if e.key == prefix {
                e.key = format!("{prefix}.{k}");
            }
            return Err(e);
        }
    }
    Err(e)
}

fn base_table<T: Serialize>(base: &T) -> toml::Table {
    match toml::Value::try_from(base).expect("method parameters serialise") {
        toml::Value::Table(t) => t,
        _ => panic!("method parameters serialise to a table"),
    }
}
