//! The files a scene is made of, for the keys that must change when any of them does (the
//! bench's truth cache, a tile's fingerprint).

use std::path::{Path, PathBuf};

/// The files a model is made of: the file itself and, for a `.gltf`, the buffers and images
/// its JSON names by (relative, percent-encoded) URI. Embedded `data:` URIs are in the file.
pub fn model_files(model: &Path) -> Vec<PathBuf> {
    let mut files = vec![model.to_path_buf()];
    let is_gltf = model.extension().is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
    let json: Option<serde_json::Value> =
        if is_gltf { std::fs::read(model).ok().and_then(|b| serde_json::from_slice(&b).ok()) } else { None };
    let folder = model.parent().unwrap_or(Path::new(""));
    if let Some(json) = json {
        for list in ["buffers", "images"] {
            for item in json[list].as_array().into_iter().flatten() {
                if let Some(uri) = item["uri"].as_str().filter(|u| !u.starts_with("data:")) {
                    // glTF URIs are percent-encoded; the gltf crate decodes them with `urlencoding`.
                    let path = urlencoding::decode(uri).map_or_else(|_| uri.to_string(), |p| p.into_owned());
                    files.push(folder.join(path));
                }
            }
        }
    }
    files
}
