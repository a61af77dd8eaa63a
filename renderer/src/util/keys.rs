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
        // An unknown field's path ends with the field itself (serde_path_to_error records the
        // key before serde refuses it).
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
        SceneError::new(path, join_key(prefix, &e.path().to_string()), e.inner().message().to_string())
    })
}

/// The field names of struct `T` (the keys its table takes), as its `Deserialize` names them
/// to the deserializer: asked of the derived impl itself, so they cannot drift from it.
/// Empty for a type that is not a struct.
pub fn struct_fields<T: serde::de::DeserializeOwned>() -> &'static [&'static str] {
    use serde::de::{Error, Visitor, value};
    /// A deserializer that only records the fields a struct asks for.
    struct Fields<'a>(&'a mut &'static [&'static str]);
    impl<'de> serde::Deserializer<'de> for Fields<'_> {
        type Error = value::Error;
        fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, value::Error> {
            Err(value::Error::custom("not a struct"))
        }
        fn deserialize_struct<V: Visitor<'de>>(
            self,
            _: &'static str,
            fields: &'static [&'static str],
            _: V,
        ) -> Result<V::Value, value::Error> {
            *self.0 = fields;
            Err(value::Error::custom("fields read"))
        }
        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
            option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
            ignored_any
        }
    }
    let mut fields: &'static [&'static str] = &[];
    let _ = T::deserialize(Fields(&mut fields));
    fields
}

fn join_key(prefix: &str, path: &str) -> String {
    let path = if path == "." { "" } else { path };
    match (prefix.is_empty(), path.is_empty()) {
        (true, _) => path.to_string(),
        (false, true) => prefix.to_string(),
        (false, false) => format!("{prefix}.{path}"),
    }
}

fn location(text: &str, byte: usize) -> String {
    let byte = byte.min(text.len());
    let before = &text[..byte];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!("byte {byte} (line {line}, column {column})")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize)]
    #[allow(dead_code)]
    struct Two {
        a: u32,
        #[serde(rename = "b_key")]
        b: Option<f32>,
    }

    #[test]
    fn a_structs_fields_are_its_keys() {
        assert_eq!(struct_fields::<Two>(), ["a", "b_key"]);
        assert!(struct_fields::<crate::interface::method::NoKeys>().is_empty());
        assert!(struct_fields::<u32>().is_empty(), "not a struct");
    }

    #[test]
    fn a_bad_value_is_named_by_its_path() {
        let value: toml::Value = toml::from_str("a = 1\nb_key = \"x\"").unwrap();
        let e = deserialize_value::<Two>(value, Path::new("s.toml"), "t").err().unwrap();
        assert_eq!(e.key, "t.b_key");
    }
}
