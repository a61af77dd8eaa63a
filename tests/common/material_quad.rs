//! A 2 x 2 quad as a glTF file, with what a material test puts on it (a material, texture
//! coordinates, TANGENT, COLOR_0, a node transform), its textures one-texel PNGs.

#![allow(dead_code)] // each test binary uses a different subset

use super::gltf_writer::{GltfBuilder, TRIANGLES, TempDir, primitive, write_png_rgba};
use serde_json::{Value, json};

/// The 2 x 2 quad's corners (y = 0, front face +y) and its first coordinates, u = (x + 1) / 2
/// and v = (z + 1) / 2: u grows along +x, glTF's v along +z (so the image's up is -z).
pub const CORNERS: [[f32; 3]; 4] = [[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]];
pub const UV0: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];

/// What the quad's primitive carries beside POSITION, NORMAL (+y) and TEXCOORD_0.
#[derive(Default)]
pub struct Quad {
    pub material: Value,
    /// TEXCOORD_0 (default [`UV0`]).
    pub uv0: Option<[[f32; 2]; 4]>,
    /// Extra attributes, each written where given.
    pub tangent: Option<[f32; 4]>,
    pub uv1: Option<[[f32; 2]; 4]>,
    pub color_u8: Option<[[u8; 4]; 4]>,
    pub color_f32: Option<[[f32; 3]; 4]>,
    /// The node's own properties (a transform), beside its mesh.
    pub node: Value,
    pub extensions_used: Vec<&'static str>,
}

/// Writes `<stem>.gltf` (and `.bin`) of `q` into `dir`, with a texture per PNG `textures`
/// names (texture k is `textures[k]`, each sampled NEAREST).
pub fn write_quad(dir: &TempDir, stem: &str, q: &Quad, textures: &[&str]) {
    let mut b = GltfBuilder::new();
    let pos = b.positions(&CORNERS);
    let n = b.normals(&[[0.0, 1.0, 0.0]; 4]);
    let uv = b.texcoords(&q.uv0.unwrap_or(UV0));
    let ind = b.indices_u16(&[0, 2, 1, 0, 3, 2]);
    let mut attributes = vec![("POSITION", pos), ("NORMAL", n), ("TEXCOORD_0", uv)];
    if let Some(t) = q.tangent {
        attributes.push(("TANGENT", b.vec4(&[t; 4])));
    }
    if let Some(uv1) = q.uv1 {
        attributes.push(("TEXCOORD_1", b.texcoords(&uv1)));
    }
    if let Some(c) = q.color_u8 {
        attributes.push(("COLOR_0", b.colors_u8(&c)));
    }
    if let Some(c) = q.color_f32 {
        attributes.push(("COLOR_0", b.vec3(&c)));
    }
    for t in textures {
        b.texture_png_sampled(t, json!({"magFilter": 9728, "minFilter": 9728}));
    }
    let mat = b.material(if q.material.is_null() { json!({}) } else { q.material.clone() });
    let mesh = b.mesh(vec![primitive(&attributes, Some(ind), TRIANGLES, Some(mat))]);
    let mut node = json!({"mesh": mesh});
    if let (Value::Object(n), Value::Object(extra)) = (&mut node, q.node.clone()) {
        n.extend(extra);
    }
    let node = b.node(node);
    let s = b.scene(&[node]);
    b.set_default_scene(s);
    q.extensions_used.iter().for_each(|e| b.use_extension(e));
    b.write(&dir.path, stem);
}

/// The scene file of model `<stem>.gltf` under `shading`.
pub fn scene_toml(stem: &str, shading: &str) -> String {
    format!(
        "[[model]]\npath = \"{stem}.gltf\"\n[camera]\nposition = [0.0, 5.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n\
         [[light]]\ncenter = [0.0, 3.0, 0.0]\nu = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 0.5]\nradiance = [1.0, 1.0, 1.0]\n\
         [materials]\nshading = \"{shading}\"\n"
    )
}

/// A texel's code for a tangent-space component c in [-1, 1], and what it decodes to.
pub fn code(c: f64) -> u8 {
    ((c + 1.0) * 0.5 * 255.0).round() as u8
}
pub fn decoded(code: u8) -> f64 {
    2.0 * code as f64 / 255.0 - 1.0
}

pub fn texel_png(dir: &TempDir, name: &str, bytes: [u8; 3]) {
    write_png_rgba(&dir.join(name), 1, 1, |_, _| [bytes[0], bytes[1], bytes[2], 255]);
}
