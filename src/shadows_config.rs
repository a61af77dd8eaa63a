//! The `[shadows]` table, typed through the registry ([`crate::methods`]): the chosen
//! method, the sample count, and each method's own table, parsed by the method's parameter
//! struct. Every table the file gives is checked, whichever method runs, so a typo under
//! `[shadows.pcss]` is an error even while `traced` renders.

use crate::methods::{self, METHODS, Registered};
use renderer::{LightShadowing, SceneError, ShadowMethod};
use std::path::Path;
use std::sync::Arc;

/// Light samples per shading point when the scene file does not say.
pub const DEFAULT_SAMPLES: u32 = 256;

/// `[shadows]`, typed.
#[derive(Debug, Clone)]
pub struct ShadowsConfig {
    /// Index into `settings` of the chosen method.
    chosen: usize,
    /// Light samples per shading point (per mask for `edge_table`).
    pub samples: u32,
    /// Every registered method's settings, in registry order: the file's table or defaults.
    /// Each one's [`ShadowMethod::name`] is its registered name.
    settings: Vec<Arc<dyn ShadowMethod>>,
}

impl Default for ShadowsConfig {
    fn default() -> Self {
        Self::from_table(&toml::Table::new(), Path::new("")).expect("the defaults are valid")
    }
}

impl ShadowsConfig {
    /// Types the raw `[shadows]` table of `file`.
    pub fn from_table(table: &toml::Table, file: &Path) -> Result<Self, SceneError> {
        Self::from_table_in(table, file, METHODS, None)
    }

    /// Types the raw `[shadows]` table of `file` with the methods of `methods` (the first
    /// one the default); `method`, when given, in place of the chosen method's settings
    /// (code-only fields included: studies and tests) before the sample count is checked.
    pub fn from_table_in(
        table: &toml::Table,
        file: &Path,
        methods: &[Registered],
        method: Option<Arc<dyn ShadowMethod>>,
    ) -> Result<Self, SceneError> {
        let names: Vec<&'static str> = methods.iter().map(|m| m.name).collect();
        let mut config = Self { chosen: 0, samples: DEFAULT_SAMPLES, settings: Vec::new() };
        // Checked once the method is known: its own limit, in the words `validate` uses.
        let mut samples = i64::from(DEFAULT_SAMPLES);
        for (key, value) in table {
            let key_path = format!("shadows.{key}");
            match (key.as_str(), value) {
                ("method", toml::Value::String(name)) => {
                    config.chosen = index(&names, name, file, &key_path)?
                }
                ("samples", toml::Value::Integer(n)) => samples = *n,
                ("method", _) => return Err(SceneError::new(file, key_path, "must be a string")),
                ("samples", _) => return Err(SceneError::new(file, key_path, "must be an integer")),
                (name, value) if names.contains(&name) && !value.is_table() => {
                    return Err(SceneError::new(file, key_path, "must be a table"));
                }
                (name, _) if !names.contains(&name) => {
                    if let Some(e) = methods::retired_error(name, file, &key_path) {
                        return Err(e);
                    }
                    let known = format!(
                        "\"method\", \"samples\" or a method's table ({})",
                        methods::names_of(names.iter().copied())
                    );
                    return Err(SceneError::new(file, key_path, format!("unknown key; expected {known}")));
                }
                _ => {}
            }
        }
        let empty = toml::Table::new();
        for m in methods {
            let own = table.get(m.name).and_then(toml::Value::as_table).unwrap_or(&empty);
            let setting: Arc<dyn ShadowMethod> =
                Arc::from((m.parse)(own, file, &format!("shadows.{}", m.name))?);
            // `name()` and `set_method` find a method by the name its settings give.
            assert_eq!(setting.name(), m.name, "a method's settings are named as it is registered");
            config.settings.push(setting);
        }
        if let Some(m) = method {
            config.set_method(m);
        }
        let max = config.method().max_samples();
        config.samples = u32::try_from(samples).ok().filter(|n| (1..=max).contains(n)).ok_or_else(|| {
            SceneError::new(
                file,
                "shadows.samples",
                format!("must be in 1..={max} for {}, got {samples}", config.name()),
            )
        })?;
        Ok(config)
    }

    /// Chooses `method` with these settings (code-only fields included).
    fn set_method(&mut self, method: Arc<dyn ShadowMethod>) {
        self.chosen = self.names().iter().position(|&m| m == method.name()).expect("a registered method");
        self.settings[self.chosen] = method;
    }

    /// The chosen method's settings.
    pub fn method(&self) -> &Arc<dyn ShadowMethod> {
        &self.settings[self.chosen]
    }

    /// The chosen method's name.
    pub fn name(&self) -> &'static str {
        self.method().name()
    }

    /// The registered methods' names, in registry order.
    fn names(&self) -> Vec<&'static str> {
        self.settings.iter().map(|m| m.name()).collect()
    }

    /// A fresh, unprepared plugin for one light.
    pub fn build(&self) -> Box<dyn LightShadowing> {
        self.method().build(self.samples)
    }
}

/// The index of `name` in `names`, or an error naming `key` (saying what to use instead of a
/// retired method).
fn index(names: &[&'static str], name: &str, file: &Path, key: &str) -> Result<usize, SceneError> {
    names.iter().position(|&m| m == name).ok_or_else(|| {
        if let Some(e) = methods::retired_error(name, file, key) {
            return e;
        }
        let expected = methods::names_of(names.iter().copied());
        SceneError::new(file, key, format!("unknown method \"{name}\"; expected one of {expected}"))
    })
}
