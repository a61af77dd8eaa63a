//! Writes small glTF 2.0 files (.gltf JSON + one .bin buffer, optionally PNG textures) for
//! tests, so that no third-party asset is needed. Everything is generated at run time.

#![allow(dead_code)] // each test binary uses a different subset

use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// glTF component types.
const FLOAT: u32 = 5126;
const UNSIGNED_BYTE: u32 = 5121;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
/// bufferView targets.
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// glTF primitive modes.
pub const TRIANGLES: u32 = 4;
pub const TRIANGLE_STRIP: u32 = 5;
pub const TRIANGLE_FAN: u32 = 6;

/// A unique scratch folder under the system temp dir, removed when dropped.
pub struct TempDir {
    pub path: PathBuf,
}

impl TempDir {
    /// `penumbra-<pid>-<test name>` under `std::env::temp_dir()`, emptied first.
    pub fn new(test_name: &str) -> Self {
        let path = std::env::temp_dir().join(format!("penumbra-{}-{test_name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).expect("create the temporary directory");
        Self { path }
    }

    pub fn join(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// Builds the JSON document and the binary buffer together.
#[derive(Default)]
pub struct GltfBuilder {
    bin: Vec<u8>,
    buffer_views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
    materials: Vec<Value>,
    textures: Vec<Value>,
    images: Vec<Value>,
    samplers: Vec<Value>,
    cameras: Vec<Value>,
    scenes: Vec<Value>,
    default_scene: Option<usize>,
    extensions_used: Vec<String>,
    extensions_required: Vec<String>,
}

fn push(list: &mut Vec<Value>, v: Value) -> usize {
    list.push(v);
    list.len() - 1
}

impl GltfBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends `bytes` as a new bufferView (4-byte aligned) and returns its index.
    fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        push(
            &mut self.buffer_views,
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}),
        )
    }

    fn float_accessor(&mut self, data: &[f32], kind: &str, extra: Value) -> usize {
        let components = match kind {
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => panic!("unsupported accessor type {kind}"),
        };
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, ARRAY_BUFFER);
        let mut a = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": data.len() / components,
            "type": kind,
        });
        if let (Value::Object(a), Value::Object(extra)) = (&mut a, extra) {
            a.extend(extra);
        }
        push(&mut self.accessors, a)
    }

    /// A POSITION accessor (VEC3 f32) with the min/max the spec requires, computed over the
    /// finite components (so that a deliberately non-finite vertex still serialises).
    pub fn positions(&mut self, p: &[[f32; 3]]) -> usize {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for v in p {
            for k in 0..3 {
                if v[k].is_finite() {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
        }
        let flat: Vec<f32> = p.iter().flatten().copied().collect();
        self.float_accessor(&flat, "VEC3", json!({"min": lo, "max": hi}))
    }

    /// A NORMAL accessor (VEC3 f32), normalised here as the spec requires.
    pub fn normals(&mut self, n: &[[f32; 3]]) -> usize {
        let flat: Vec<f32> = n
            .iter()
            .flat_map(|v| {
                let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                [v[0] / l, v[1] / l, v[2] / l]
            })
            .collect();
        self.float_accessor(&flat, "VEC3", json!({}))
    }

    /// A raw VEC3 f32 accessor (no normalisation, no min/max).
    pub fn vec3(&mut self, v: &[[f32; 3]]) -> usize {
        let flat: Vec<f32> = v.iter().flatten().copied().collect();
        self.float_accessor(&flat, "VEC3", json!({}))
    }

    /// A raw VEC4 f32 accessor (EXT_mesh_gpu_instancing's ROTATION).
    pub fn vec4(&mut self, v: &[[f32; 4]]) -> usize {
        let flat: Vec<f32> = v.iter().flatten().copied().collect();
        self.float_accessor(&flat, "VEC4", json!({}))
    }

    /// A TEXCOORD_n accessor (VEC2 f32).
    pub fn texcoords(&mut self, uv: &[[f32; 2]]) -> usize {
        let flat: Vec<f32> = uv.iter().flatten().copied().collect();
        self.float_accessor(&flat, "VEC2", json!({}))
    }

    /// A normalized unsigned-byte VEC4 accessor (COLOR_0 as 8-bit RGBA).
    pub fn colors_u8(&mut self, c: &[[u8; 4]]) -> usize {
        let bytes: Vec<u8> = c.iter().flatten().copied().collect();
        let view = self.view(&bytes, ARRAY_BUFFER);
        push(
            &mut self.accessors,
            json!({"bufferView": view, "componentType": UNSIGNED_BYTE, "normalized": true,
                   "count": c.len(), "type": "VEC4"}),
        )
    }

    pub fn indices_u16(&mut self, i: &[u16]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, ELEMENT_ARRAY_BUFFER);
        push(
            &mut self.accessors,
            json!({"bufferView": view, "componentType": UNSIGNED_SHORT, "count": i.len(), "type": "SCALAR"}),
        )
    }

    pub fn indices_u32(&mut self, i: &[u32]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, ELEMENT_ARRAY_BUFFER);
        push(
            &mut self.accessors,
            json!({"bufferView": view, "componentType": UNSIGNED_INT, "count": i.len(), "type": "SCALAR"}),
        )
    }

    /// A mesh from primitive objects (see [`primitive`]).
    pub fn mesh(&mut self, primitives: Vec<Value>) -> usize {
        push(&mut self.meshes, json!({ "primitives": primitives }))
    }

    /// A node object as given (`mesh`, `children`, `translation`, `matrix`, ...).
    pub fn node(&mut self, node: Value) -> usize {
        push(&mut self.nodes, node)
    }

    pub fn material(&mut self, material: Value) -> usize {
        push(&mut self.materials, material)
    }

    /// A texture whose image is the PNG file `uri` (relative to the .gltf), sampled with the
    /// default filtering and clamp-to-edge wrapping.
    pub fn texture_png(&mut self, uri: &str) -> usize {
        self.texture_png_wrapped(uri, 33071, 33071)
    }

    /// [`Self::texture_png`] with the sampler's wrap modes (glTF codes: 10497 repeat, 33648
    /// mirrored repeat, 33071 clamp to edge).
    pub fn texture_png_wrapped(&mut self, uri: &str, wrap_s: u32, wrap_t: u32) -> usize {
        self.texture_png_sampled(uri, json!({"wrapS": wrap_s, "wrapT": wrap_t}))
    }

    /// [`Self::texture_png`] with the sampler `sampler` (glTF JSON: wrap modes, filters).
    pub fn texture_png_sampled(&mut self, uri: &str, sampler: Value) -> usize {
        let image = push(&mut self.images, json!({"uri": uri, "mimeType": "image/png"}));
        let sampler = push(&mut self.samplers, sampler);
        push(&mut self.textures, json!({"source": image, "sampler": sampler}))
    }

    pub fn camera(&mut self, camera: Value) -> usize {
        push(&mut self.cameras, camera)
    }

    pub fn scene(&mut self, nodes: &[usize]) -> usize {
        push(&mut self.scenes, json!({ "nodes": nodes }))
    }

    pub fn set_default_scene(&mut self, scene: usize) {
        self.default_scene = Some(scene);
    }

    pub fn use_extension(&mut self, name: &str) {
        self.extensions_used.push(name.to_string());
    }

    /// Lists `name` in extensionsUsed and extensionsRequired.
    pub fn require_extension(&mut self, name: &str) {
        self.use_extension(name);
        self.extensions_required.push(name.to_string());
    }

    /// The JSON document, its buffer pointing at `bin_uri`.
    pub fn json(&self, bin_uri: &str) -> Value {
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "penumbra tests"},
            "buffers": [{"uri": bin_uri, "byteLength": self.bin.len()}],
            "bufferViews": self.buffer_views,
            "accessors": self.accessors,
            "meshes": self.meshes,
            "nodes": self.nodes,
            "scenes": self.scenes,
        });
        let obj = doc.as_object_mut().expect("an object");
        for (key, list) in [
            ("materials", &self.materials),
            ("textures", &self.textures),
            ("images", &self.images),
            ("samplers", &self.samplers),
            ("cameras", &self.cameras),
        ] {
            if !list.is_empty() {
                obj.insert(key.into(), Value::from(list.clone()));
            }
        }
        if let Some(s) = self.default_scene {
            obj.insert("scene".into(), json!(s));
        }
        if !self.extensions_used.is_empty() {
            obj.insert("extensionsUsed".into(), json!(self.extensions_used));
        }
        if !self.extensions_required.is_empty() {
            obj.insert("extensionsRequired".into(), json!(self.extensions_required));
        }
        doc
    }

    /// Writes `<dir>/<stem>.gltf` and `<dir>/<stem>.bin`; returns the .gltf path.
    pub fn write(&self, dir: &Path, stem: &str) -> PathBuf {
        let bin_name = format!("{stem}.bin");
        std::fs::write(dir.join(&bin_name), &self.bin).expect("write the .bin");
        let path = dir.join(format!("{stem}.gltf"));
        write_json(&path, &self.json(&bin_name));
        path
    }
}

impl GltfBuilder {
    /// Writes `<dir>/<stem>.glb` (a JSON chunk and a BIN chunk holding the buffer); returns
    /// its path.
    pub fn write_glb(&self, dir: &Path, stem: &str) -> PathBuf {
        let mut doc = self.json("");
        doc["buffers"][0].as_object_mut().expect("a buffer").remove("uri");
        let mut json = serde_json::to_vec(&doc).expect("the document serialises");
        json.resize(json.len().next_multiple_of(4), b' ');
        let mut bin = self.bin.clone();
        bin.resize(bin.len().next_multiple_of(4), 0);
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        let path = dir.join(format!("{stem}.glb"));
        std::fs::write(&path, out).expect("write the .glb");
        path
    }
}

/// A primitive object: `attributes` as (semantic, accessor) pairs.
pub fn primitive(
    attributes: &[(&str, usize)],
    indices: Option<usize>,
    mode: u32,
    material: Option<usize>,
) -> Value {
    let attrs: serde_json::Map<String, Value> =
        attributes.iter().map(|(k, v)| (k.to_string(), json!(v))).collect();
    let mut p = json!({ "attributes": attrs, "mode": mode });
    let obj = p.as_object_mut().expect("an object");
    if let Some(i) = indices {
        obj.insert("indices".into(), json!(i));
    }
    if let Some(m) = material {
        obj.insert("material".into(), json!(m));
    }
    p
}

pub fn write_json(path: &Path, doc: &Value) {
    let text = serde_json::to_string_pretty(doc).expect("the document serialises");
    std::fs::write(path, text).expect("write the .gltf");
}

/// Writes an RGBA8 PNG whose pixel (x, y) (y = 0 the top row) is `f(x, y)`.
pub fn write_png_rgba(path: &Path, width: u32, height: u32, f: impl Fn(u32, u32) -> [u8; 4]) {
    let img = image::RgbaImage::from_fn(width, height, |x, y| image::Rgba(f(x, y)));
    img.save_with_format(path, image::ImageFormat::Png).expect("write the PNG");
}

/// Writes a PNG whose header declares `width` x `height` RGBA8 pixels but whose one IDAT
/// chunk holds a single byte: a decoder learns the size without the data, so a test can
/// claim a texture of gigabytes in a file of 60 bytes.
pub fn write_png_header_only(path: &Path, width: u32, height: u32) {
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]); // 8 bits, RGBA, deflate, adaptive filter, no interlace
    // zlib (no compression preset) of the one byte 0: a valid stream far shorter than the rows.
    let idat = [0x78, 0x01, 0x63, 0x00, 0x00, 0x00, 0x01, 0x00, 0x01];
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    for (kind, data) in [(b"IHDR", &ihdr[..]), (b"IDAT", &idat[..]), (b"IEND", &[][..])] {
        png.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let start = png.len();
        png.extend_from_slice(kind);
        png.extend_from_slice(data);
        let crc = crc32(&png[start..]);
        png.extend_from_slice(&crc.to_be_bytes());
    }
    std::fs::write(path, png).expect("write the PNG");
}

/// CRC-32 (IEEE, reflected), as PNG chunks carry it over their type and data.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}
