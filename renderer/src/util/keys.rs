//! Typed TOML with key paths: every deserialisation error names the file and the dotted key
//! (from `serde_path_to_error`), or the byte, line and column where no key applies.

use crate::util::error::SceneError;
use std::path::Path;

/// Deserialises TOML text into `T`, turning serde's error into a [`SceneError`] that names
/// the key path (`prefix` is prepended, e.g. `shadows`) or, for syntax errors, the byte
/// offset with line and column.
pub fn deserialize_toml<T: serde::de::DeserializeOwned>(
    text: &str,
    path: &Path,
    prefix: &str,
) -> Result<T, SceneError> {
    let de = toml::Deserializer::new(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = join_key(prefix, &e.path().to_string());
        let inner = e.inner();
        let message = inner.message().to_string();
        let key = with_unknown_field(&key, &message);
        let key = if key.is_empty() || key == "." {
            match inner.span() {
                Some(span) => location(text, span.start),
                None => String::new(),
            }
        } else {
            key
        };
        SceneError::new(path, key, message)
    })
}

/// Deserialises an already-parsed TOML value (a sub-table) into `T`, with key paths under
/// `prefix`.
pub fn deserialize_value<T: serde::de::DeserializeOwned>(
    value: toml::Value,
    path: &Path,
    prefix: &str,
) -> Result<T, SceneError> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let key = join_key(prefix, &e.path().to_string());
        let message = e.inner().message().to_string();
        SceneError::new(path, with_unknown_field(&key, &message), message)
    })
}

fn join_key(prefix: &str, path: &str) -> String {
    let path = if path == "." { "" } else { path };
    match (prefix.is_empty(), path.is_empty()) {
        (true, _) => path.to_string(),
        (false, true) => prefix.to_string(),
        (false, false) => format!("{prefix}.{path}"),
    }
}

/// serde reports an unknown field at the table that holds it; name the field itself.
fn with_unknown_field(key: &str, message: &str) -> String {
    // serde_path_to_error already ends the path with the field for tables; values typed
    // later (deserialize_value) may not.
    if let Some(rest) = message.strip_prefix("unknown field `")
        && let Some(name) = rest.split('`').next()
        && !(key == name || key.ends_with(&format!(".{name}")))
    {
        return join_key(key, name);
    }
    key.to_string()
}

fn location(text: &str, byte: usize) -> String {
    let byte = byte.min(text.len());
    let before = &text[..byte];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!("byte {byte} (line {line}, column {column})")
}
