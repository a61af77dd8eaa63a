//! The glTF file and what it points to: opening it with the holes gltf leaves closed
//! ([`open_gltf`]), its buffers one by one (errors name the buffer and the file), and the
//! buffer and image URIs that lead out of the model's folder.

use crate::util::error::SceneError;
use std::path::Path;

/// A .glb shorter than its header says ("the file is truncated: N of M bytes"), or `None`.
pub(super) fn truncated_glb(path: &Path) -> Option<String> {
    use std::io::Read;
    let mut header = [0u8; 12];
    let mut f = std::fs::File::open(path).ok()?;
    let actual = f.metadata().ok()?.len();
    f.read_exact(&mut header).ok()?;
    let declared = u32::from_le_bytes(header[8..12].try_into().ok()?) as u64;
    (&header[0..4] == b"glTF" && actual < declared)
        .then(|| format!("the .glb is truncated: {actual} bytes, its header declares {declared}"))
}

/// Where a buffer or image URI points on disk (relative to `base`, percent-decoded), or
/// `None` for a `data:` URI.
pub(super) fn uri_path(base: &Path, uri: &str) -> Option<std::path::PathBuf> {
    if uri.starts_with("data:") {
        return None;
    }
    let decoded = urlencoding::decode(uri).map_or_else(|_| uri.to_string(), |d| d.into_owned());
    let local = decoded.strip_prefix("file://").or_else(|| decoded.strip_prefix("file:"));
    Some(match local {
        Some(p) => std::path::PathBuf::from(p),
        None => base.join(decoded),
    })
}

/// Where a buffer or image URI leads out of the model's folder: "an absolute path", "an
/// absolute file: URI" or "a relative path out of the model's folder" (lexically, by its
/// `..`s); `None` for a `data:` URI or a path inside the folder.
pub(super) fn out_of_folder(uri: &str) -> Option<&'static str> {
    if uri.starts_with("data:") {
        return None;
    }
    let decoded = urlencoding::decode(uri).map_or_else(|_| uri.to_string(), |d| d.into_owned());
    if decoded.starts_with("file:") {
        return Some("an absolute file: URI");
    }
    let rel = Path::new(&decoded);
    if rel.has_root() || decoded.starts_with('\\') || decoded.get(1..2) == Some(":") {
        return Some("an absolute path");
    }
    let mut depth = 0i32;
    for c in rel.components() {
        match c {
            std::path::Component::ParentDir => depth -= 1,
            std::path::Component::Normal(_) => depth += 1,
            _ => {}
        }
        if depth < 0 {
            return Some("a relative path out of the model's folder");
        }
    }
    None
}

/// A warning per buffer and image URI that leads out of the model's folder. They load (a
/// production scene may share textures between models, and refusing would break files other
/// tools open), but glTF's norm is a URI relative to the file and inside its folder: an
/// absolute path breaks when the model is moved or shared, and a scene from elsewhere can
/// make the renderer read any file the user can, so the user hears which file it reads.
pub(super) fn uris_out_of_folder(path: &Path, base: &Path, doc: &gltf::Document) -> Vec<String> {
    let buffers = doc.buffers().filter_map(|b| match b.source() {
        gltf::buffer::Source::Uri(uri) => Some((format!("buffers[{}].uri", b.index()), uri)),
        gltf::buffer::Source::Bin => None,
    });
    // From the JSON, not `Image::source`: that unwraps the mime type of an image in a buffer
    // view and panics where it is missing (a kept fuzz input); `image_source_problem` names it.
    let images = doc
        .as_json()
        .images
        .iter()
        .enumerate()
        .filter_map(|(i, image)| image.uri.as_deref().map(|uri| (format!("images[{i}].uri"), uri)));
    buffers
        .chain(images)
        .filter_map(|(key, uri)| {
            let what = out_of_folder(uri)?;
            let file = uri_path(base, uri).map_or_else(|| uri.to_string(), |p| p.display().to_string());
            Some(format!(
                "{}: {key} {uri:?} is {what}: it reads {file}, outside the model's folder (glTF expects \
                 URIs relative to the file; the model breaks when moved or shared)",
                path.display()
            ))
        })
        .collect()
}

/// The document's buffers, each loaded on its own so that an error names the buffer and the
/// file that failed (gltf's `import_buffers` names neither).
pub(super) fn load_buffers(
    path: &Path,
    base: &Path,
    doc: &gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<gltf::buffer::Data>, SceneError> {
    let mut buffers = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        let (key, file) = match buffer.source() {
            gltf::buffer::Source::Uri(uri) => {
                (format!("buffers[{i}].uri"), uri_path(base, uri).map(|p| p.display().to_string()))
            }
            gltf::buffer::Source::Bin => (format!("buffers[{i}]"), None),
        };
        let what = file.clone().unwrap_or_else(|| "the embedded data".into());
        let data = gltf::buffer::Data::from_source_and_blob(buffer.source(), Some(base), &mut blob).map_err(
            |e| {
                let msg = match (&e, &file) {
                    (gltf::Error::MissingBlob, _) => "the .glb has no binary chunk".to_string(),
                    (gltf::Error::Io(io), Some(f)) => format!("cannot read {f}: {io}"),
                    _ => format!("cannot load {what}: {e}"),
                };
                SceneError::new(path, &key, msg)
            },
        )?;
        if data.len() < buffer.length() {
            return Err(SceneError::new(
                path,
                format!("buffers[{i}].byteLength"),
                format!(
                    "{what} has {} bytes, fewer than the {} declared (truncated?)",
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// Whether gltf's import can decode `uri`: it unwraps `urlencoding::decode` of a URI without
/// a scheme, which fails (a panic) when the %-escapes are not UTF-8, e.g. `%FF.bin`.
pub(super) fn decodable_uri(uri: &str) -> bool {
    uri.contains(':') || urlencoding::decode(uri).is_ok()
}

/// `gltf::Gltf::open` with three holes closed:
/// - `open` trusts a .glb header: it allocates the header's length (up to 4 GiB) before
///   reading the rest (found by fuzzing), and computes `length - 12`, which underflows for a
///   length below the header's own 12 bytes. Here the file is read first and the length
///   checked against it.
/// - gltf-json's validation indexes `accessors` by each primitive's POSITION before checking
///   that index (found by fuzzing), so a document is checked for that first.
/// - gltf's import panics on a buffer URI whose %-escapes are not UTF-8 ([`decodable_uri`]).
///
/// A file that requires EXT_mesh_gpu_instancing is accepted (gltf would refuse it).
///
/// The error is the key it concerns (empty where none applies, such as a syntax error) and
/// what is wrong.
pub(super) fn open_gltf(path: &Path) -> Result<gltf::Gltf, (String, String)> {
    use gltf::json::{mesh::Semantic, validation::Checked};
    let unkeyed = |message: String| (String::new(), message);
    let bytes = std::fs::read(path).map_err(|e| unkeyed(e.to_string()))?;
    if bytes.starts_with(b"glTF") && bytes.len() >= 12 {
        let length = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if length < 12 || length as usize > bytes.len() {
            return Err(unkeyed(format!(
                "GLB header length {length} does not fit the file's {} bytes",
                bytes.len()
            )));
        }
    }
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| json_error_key(&bytes).unwrap_or_else(|| unkeyed(e.to_string())))?;
    let json = gltf.document.as_json();
    for (i, buffer) in json.buffers.iter().enumerate() {
        if let Some(uri) = &buffer.uri
            && !decodable_uri(uri)
        {
            return Err(unkeyed(format!("buffers[{i}].uri: its %-escapes do not decode to UTF-8")));
        }
    }
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(i) = prim.attributes.get(&Checked::Valid(Semantic::Positions))
                && i.value() >= json.accessors.len()
            {
                return Err(unkeyed(format!(
                    "meshes[{m}].primitives[{p}].attributes.POSITION: no accessor {} ({} accessors)",
                    i.value(),
                    json.accessors.len()
                )));
            }
        }
    }
    // gltf validates `extensionsRequired` against the extensions it reads itself; this loader
    // reads EXT_mesh_gpu_instancing (`gpu_instancing.rs`), so a file may require it.
    let mut json = gltf.document.into_json();
    json.extensions_required.retain(|e| e != "EXT_mesh_gpu_instancing");
    let document = gltf::Document::from_json(json).map_err(|e| unkeyed(e.to_string()))?;
    Ok(gltf::Gltf { document, blob: gltf.blob })
}

/// Where the JSON of a glTF file (`bytes`: .gltf or .glb) fails to deserialise, as a key
/// path (`nodes[3].matrix[5]`) and what is wrong there; `None` where no key applies (a
/// syntax error, a .glb without a JSON chunk). serde_json names a line and column only, and
/// a number f32 cannot hold (1e39 in a matrix) reads as "number out of range" without
/// saying which number: its value is named here too.
fn json_error_key(bytes: &[u8]) -> Option<(String, String)> {
    let glb = bytes.starts_with(b"glTF").then(|| gltf::Glb::from_slice(bytes).ok()).flatten();
    let json: &[u8] = glb.as_ref().map_or(bytes, |g| &g.json);
    let mut de = serde_json::Deserializer::from_slice(json);
    let e = serde_path_to_error::deserialize::<_, gltf::json::Root>(&mut de).err()?;
    let key = e.path().to_string();
    if key.is_empty() || key == "." {
        return None;
    }
    // The value at the path, read as f64 (wider than the f32 gltf reads).
    let root: serde_json::Value = serde_json::from_slice(json).ok()?;
    let value = e.path().iter().try_fold(&root, |v, segment| match segment {
        serde_path_to_error::Segment::Seq { index } => v.get(index),
        serde_path_to_error::Segment::Map { key } => v.get(key),
        _ => None,
    });
    let message = match value.and_then(|v| v.as_f64()) {
        Some(x) if x.abs() > f32::MAX as f64 => {
            format!("{x:e} is out of f32's range (at most {:.1e} in magnitude)", f32::MAX)
        }
        _ => e.inner().to_string(),
    };
    Some((key, message))
}

#[cfg(test)]
mod tests {
    use super::*;

    const NODE_MATRIX_1E39: &str = r#"{"asset": {"version": "2.0"},
        "nodes": [{}, {"matrix": [1, 0, 0, 0, 0, 1e39, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}]}"#;

    #[test]
    fn a_number_f32_cannot_hold_is_named_by_its_key_path_in_gltf_and_glb() {
        let expected = (
            "nodes[1].matrix[5]".to_string(),
            "1e39 is out of f32's range (at most 3.4e38 in magnitude)".to_string(),
        );
        assert_eq!(json_error_key(NODE_MATRIX_1E39.as_bytes()), Some(expected.clone()));
        let mut json = NODE_MATRIX_1E39.as_bytes().to_vec();
        json.resize(json.len().next_multiple_of(4), b' ');
        let mut glb = b"glTF".to_vec();
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&(12 + 8 + json.len() as u32).to_le_bytes());
        glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"JSON");
        glb.extend_from_slice(&json);
        assert_eq!(json_error_key(&glb), Some(expected));
    }

    #[test]
    fn a_syntax_error_has_no_key_path() {
        assert_eq!(json_error_key(b"{\"asset\": "), None);
    }
}
