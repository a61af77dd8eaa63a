//! The `[shadows]` table, typed. This is the composition root's half of the scene file: the
//! renderer keeps `[shadows]` raw because only this crate knows every method.

use renderer::SceneError;
use renderer::config::deserialize_value;
use serde::Deserialize;
use std::path::Path;

/// Shadow methods, as the scene file and `--shadows` spell them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum MethodName {
    /// Shadow rays through the BVH to `samples` stratified points on the light: the truth.
    #[default]
    Traced,
    /// No shadows (V = 1): the cost floor.
    None,
}

impl MethodName {
    pub fn as_str(self) -> &'static str {
        match self {
            MethodName::Traced => "traced",
            MethodName::None => "none",
        }
    }
}

/// Light samples per shading point when the scene file does not say.
pub const DEFAULT_SAMPLES: u32 = 256;
/// Largest sample count accepted (64 x 1024 bits per mask is the edge-table ceiling too).
pub const MAX_SAMPLES: u32 = 65536;

/// `[shadows]`.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShadowsConfig {
    #[serde(default)]
    pub method: MethodName,
    /// Light samples per shading point.
    #[serde(default = "default_samples")]
    pub samples: u32,
}

fn default_samples() -> u32 {
    DEFAULT_SAMPLES
}

impl Default for ShadowsConfig {
    fn default() -> Self {
        Self { method: MethodName::default(), samples: DEFAULT_SAMPLES }
    }
}

impl ShadowsConfig {
    /// Types the raw `[shadows]` table of `scene_path`.
    pub fn from_table(table: &toml::Table, scene_path: &Path) -> Result<Self, SceneError> {
        let config: ShadowsConfig =
            deserialize_value(toml::Value::Table(table.clone()), scene_path, "shadows")?;
        config.validate(scene_path, "shadows.samples")?;
        Ok(config)
    }

    /// Checks the sample count; `key` names where it came from (scene key or CLI flag).
    pub fn validate(&self, file: &Path, key: &str) -> Result<(), SceneError> {
        if self.samples == 0 || self.samples > MAX_SAMPLES {
            return Err(SceneError::new(
                file,
                key,
                format!("must be in 1..={MAX_SAMPLES}, got {}", self.samples),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        text.parse().unwrap()
    }

    #[test]
    fn methods_and_samples_parse() {
        let p = Path::new("s.toml");
        let c = ShadowsConfig::from_table(&table("method = \"none\"\nsamples = 64"), p).unwrap();
        assert_eq!(c, ShadowsConfig { method: MethodName::None, samples: 64 });
        assert_eq!(ShadowsConfig::from_table(&table(""), p).unwrap(), ShadowsConfig::default());
    }

    #[test]
    fn bad_shadow_keys_are_named() {
        let p = Path::new("s.toml");
        let e = ShadowsConfig::from_table(&table("method = \"magic\""), p).unwrap_err();
        assert_eq!(e.key, "shadows.method", "{e}");
        let e = ShadowsConfig::from_table(&table("sample = 3"), p).unwrap_err();
        assert_eq!(e.key, "shadows.sample", "{e}");
        let e = ShadowsConfig::from_table(&table("samples = 0"), p).unwrap_err();
        assert_eq!(e.key, "shadows.samples", "{e}");
    }
}
