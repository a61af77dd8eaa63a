//! The key reference, docs/scene-keys.md, generated from the registry: the head below (the
//! `[materials]` and `[shadows]` tables, the list of methods filled in), then a section per registered method,
//! its heading generated and its text the method's own ([`renderer::MethodEntry::KEYS_DOC`],
//! in its folder). `tests/scene_keys.rs` fails when the file differs from [`page`]
//! (`PENUMBRA_BLESS=1` rewrites it) and when a method's section and its parameters disagree
//! ([`section_errors`]).

use crate::methods::{RETIRED, Registered};
use std::collections::BTreeMap;

/// The page up to the methods' sections; `{methods}` is replaced by the registered names,
/// `{retired}` by the retired ones ([`crate::methods::RETIRED`]).
const HEAD: &str = r#"# Scene file keys: `[materials]`, `[shadows]` and each method's table

Every key a scene file's `[materials]` and `[shadows]` tables and the method tables accept,
with its default.
This page is generated from the method registry (`src/methods.rs`): each method's section
is its own text, in its folder (`keys.md` beside a plugin's code), and `tests/scene_keys.rs`
holds each section against the method's parameter struct: a key missing there, a key there
the struct does not take, or a default that differs fails the tests. The tests also fail
when this file is stale; `PENUMBRA_BLESS=1 cargo test --test suite scene_keys::` rewrites it. Unknown
keys are errors naming the key's full path (`shadows.edge_table.gird`), and so is a key that
has no effect with the other choices made (`slab_thickness` with `heightfield = "shells"`).
Every method table the file gives is checked, whichever method renders.

The other tables (`[[model]]`, `[[quad]]`, `[camera]`, `[image]`, `[[light]]`) are in the
contract's example (docs/guide.md, "Scene files"), and so is `[integrator]`:

| key | type | default | meaning |
|---|---|---|---|
| `max_depth` (`[integrator]`) | int | `5` | longest light path, counted as Mitsuba 3 counts it: 2 = direct light only, 5 = three indirect bounces; 2 to 64; `--max-depth` overrides it |

## `[materials]`

How the glTF materials are shaded (`renderer::load::scene_file::MaterialsDesc`; held to its
struct by `tests/scene_keys.rs` as the method tables are).

| key | type | default | meaning |
|---|---|---|---|
| `shading` | string | `"gltf"` | `"gltf"`: as the files define them (the glTF BRDF, metallic-roughness GGX; normal textures bend the shading normal, which the light's irradiance and every shadow method's horizon use; emission seen by the camera and bounces); `"diffuse"`: every surface a two-sided Lambertian of its base colour with its interpolated normal, the renders of before materials were read, byte for byte; `--shading` overrides it |

## `[shadows]`

| key | type | default | meaning |
|---|---|---|---|
| `method` | string | `"traced"` | the shadow method: {methods}; `--shadows` overrides it{retired} |
| `samples` | int | `256` | light samples per shading point (rays per mask for `edge_table`, PCF taps for `pcss`): 1 to 65536 for `traced`, 1 to 4096 for the depth-map methods; `--samples` overrides it |
"#;

/// The key reference of `methods`: docs/scene-keys.md is `page(METHODS)`.
pub fn page(methods: &[Registered]) -> String {
    let names: Vec<String> = methods.iter().map(|m| format!("`\"{}\"`", m.name)).collect();
    let listed = match names.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    };
    let retired: Vec<String> = RETIRED.iter().map(|(name, _)| format!("`\"{name}\"`")).collect();
    let retired = if retired.is_empty() {
        String::new()
    } else {
        format!("; retired (an error saying what to use instead): {}", retired.join(", "))
    };
    let mut page = HEAD.replace("{methods}", &listed).replace("{retired}", &retired);
    for m in methods {
        page.push_str(&format!("\n## `[shadows.{}]`\n\n{}", m.name, m.keys_doc));
    }
    page
}

/// The keys a reference documents: per ``## `[SECTION]` `` heading, each table row whose key
/// cell is code, with its default cell (backticks stripped).
pub fn sections(markdown: &str) -> BTreeMap<String, BTreeMap<String, String>> {
    let mut out: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    let mut section = None;
    for line in markdown.lines() {
        if let Some(h) = line.strip_prefix("## `[").and_then(|h| h.strip_suffix("]`")) {
            section = Some(h.to_string());
            out.entry(h.to_string()).or_default();
            continue;
        }
        if let Some(s) = &section {
            out.get_mut(s).expect("opened above").extend(key_row(line));
        }
    }
    out
}

/// A table row's (key, default), if its key cell is code.
fn key_row(line: &str) -> Option<(String, String)> {
    let cells: Vec<&str> = line.split('|').map(str::trim).collect();
    match cells.as_slice() {
        [_, key, _, default, ..] if key.starts_with('`') => {
            let strip = |c: &str| c.trim_matches('`').to_string();
            Some((strip(key), strip(default)))
        }
        _ => None,
    }
}

/// The keys and defaults `m`'s section must document: its documented keys with their
/// defaults, and its choice keys with the defaults `documented` gives them (a choice key's
/// default is a name, not a field's value; a missing one is an error).
pub fn expected_keys(
    m: &Registered,
    documented: &BTreeMap<String, String>,
) -> Result<BTreeMap<String, String>, String> {
    let mut expected: BTreeMap<String, String> =
        (m.documented_keys)().into_iter().map(|(k, v)| (k, v.to_string())).collect();
    for k in m.choice_keys {
        let default = documented.get(*k).ok_or_else(|| format!("shadows.{}.{k} undocumented", m.name))?;
        expected.insert(k.to_string(), default.clone());
    }
    Ok(expected)
}

/// Where `m`'s own section ([`Registered::keys_doc`]) and its parameters disagree: a key
/// missing, a key too many or a default that differs, one line each.
pub fn section_errors(m: &Registered) -> Vec<String> {
    let documented: BTreeMap<String, String> = m.keys_doc.lines().filter_map(key_row).collect();
    let expected = match expected_keys(m, &documented) {
        Ok(e) => e,
        Err(e) => return vec![e],
    };
    let mut errors = Vec::new();
    for (k, v) in &expected {
        match documented.get(k) {
            None => errors.push(format!("shadows.{}.{k} undocumented (default {v})", m.name)),
            Some(d) if d != v => {
                errors.push(format!("shadows.{}.{k}: documented default {d}, the parameters' {v}", m.name));
            }
            Some(_) => {}
        }
    }
    for k in documented.keys().filter(|k| !expected.contains_key(*k)) {
        errors.push(format!("shadows.{}.{k} documented but not a key", m.name));
    }
    errors
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_method_row_lists_every_name() {
        let methods = &crate::methods::METHODS[..3];
        assert!(page(methods).contains("the shadow method: `\"traced\"`, `\"none\"` or `\"edge_table\"`;"));
        assert!(page(&methods[..1]).contains("the shadow method: `\"traced\"`;"));
    }
}
