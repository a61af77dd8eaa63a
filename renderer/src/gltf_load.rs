//! glTF 2.0 (.gltf + .bin + images, or .glb) into world-space triangles, materials and
//! textures. Node transforms are composed in f64; every node of the default scene is
//! expanded, nested TRS and matrices alike. Skins and morph targets are ignored (bind pose).

use crate::error::SceneError;
use crate::material::{AlphaMode, Material, Texture, TextureRef, Wrap};
use glam::{Affine2, DMat3, DMat4, DVec3, Mat2, Vec2, Vec3, Vec4};
use gltf::Semantic;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use std::collections::HashMap;
use std::path::Path;

/// A triangle as loaded: world positions in f64 (before the scene is recentred), optional
/// world-space vertex normals, texture coordinates and a material index (into the scene's
/// material list).
#[derive(Debug, Clone, Copy)]
pub struct SourceTriangle {
    pub p: [DVec3; 3],
    pub n: Option<[Vec3; 3]>,
    pub uv: [Vec2; 3],
    pub material: u32,
}

/// Triangles of one emissive primitive instance: a candidate rectangular light.
#[derive(Debug, Clone)]
pub struct EmitterCandidate {
    pub triangles: Vec<[DVec3; 3]>,
    pub radiance: Vec3,
    pub double_sided: bool,
}

/// A camera found in a glTF file: its node's world transform and vertical fov (radians).
#[derive(Debug, Clone, Copy)]
pub struct GltfCamera {
    pub world: DMat4,
    pub yfov: f64,
}

/// Everything the loader appends to.
#[derive(Debug, Default)]
pub struct Geometry {
    pub triangles: Vec<SourceTriangle>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub emitters: Vec<EmitterCandidate>,
    /// Triangles dropped because they have zero area.
    pub degenerate: u64,
}

/// Loads `path` into `geometry`, transformed by `model_from_file` after the file's own node
/// transforms. Returns the file's first camera, if any.
pub fn load_gltf(
    path: &Path,
    model_from_file: DMat4,
    geometry: &mut Geometry,
) -> Result<Option<GltfCamera>, SceneError> {
    let fail = |key: &str, msg: String| SceneError::new(path, key, msg);
    let gltf = open_gltf(path).map_err(|e| match truncated_glb(path) {
        Some(msg) => fail("", msg),
        None => fail("", format!("cannot load glTF: {e}")),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(path, base, &gltf.document, gltf.blob.clone())?;
    let doc = &gltf.document;

    let material_base = geometry.materials.len() as u32;
    load_materials(path, base, doc, &buffers, geometry)?;
    // The glTF default material (white, opaque) for primitives without one.
    geometry.materials.push(Material::diffuse([1.0, 1.0, 1.0]));
    let default_material = geometry.materials.len() as u32 - 1;

    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| fail("scenes", "the file has no scene".into()))?;
    load_nodes(path, &scene, model_from_file, material_base, default_material, &buffers, geometry)
}

/// A .glb shorter than its header says ("the file is truncated: N of M bytes"), or `None`.
fn truncated_glb(path: &Path) -> Option<String> {
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
fn uri_path(base: &Path, uri: &str) -> Option<std::path::PathBuf> {
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

/// The document's buffers, each loaded on its own so that an error names the buffer and the
/// file that failed (gltf's `import_buffers` names neither).
fn load_buffers(
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

/// Appends the file's materials to `geometry` (only what shading and the alpha test need),
/// with their base colour textures decoded once each. `base` is the folder of `path`, which
/// relative image URIs start from.
fn load_materials(
    path: &Path,
    base: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    geometry: &mut Geometry,
) -> Result<(), SceneError> {
    let fail = |key: &str, msg: String| SceneError::new(path, key, msg);
    // glTF image index -> slot in `geometry.textures`.
    let mut image_slots: HashMap<usize, u32> = HashMap::new();
    for m in doc.materials() {
        let key = format!("materials[{}]", m.index().unwrap_or(0));
        let pbr = m.pbr_metallic_roughness();
        let base_color = Vec4::from(pbr.base_color_factor());
        if !base_color.to_array().iter().all(|c| (0.0..=1.0).contains(c)) {
            return Err(fail(
                &format!("{key}.pbrMetallicRoughness.baseColorFactor"),
                format!("each channel must be in [0, 1] (an albedo), got {:?}", base_color.to_array()),
            ));
        }
        let base_color_texture = match pbr.base_color_texture() {
            None => None,
            Some(info) => Some(texture_ref(path, base, doc, &info, buffers, &mut image_slots, geometry)?),
        };
        let alpha = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask { cutoff: m.alpha_cutoff().unwrap_or(0.5) },
            gltf::material::AlphaMode::Blend => AlphaMode::Mask { cutoff: 0.5 },
        };
        geometry.materials.push(Material { base_color, base_color_texture, alpha });
    }
    Ok(())
}

/// A material's base colour texture: its image decoded into `geometry.textures` the first
/// time any material uses it (`image_slots` remembers where), with the sampler's wrap modes
/// and the KHR_texture_transform, if any.
fn texture_ref(
    path: &Path,
    base: &Path,
    doc: &gltf::Document,
    info: &gltf::texture::Info,
    buffers: &[gltf::buffer::Data],
    image_slots: &mut HashMap<usize, u32>,
    geometry: &mut Geometry,
) -> Result<TextureRef, SceneError> {
    let fail = |key: &str, msg: String| SceneError::new(path, key, msg);
    let texture = info.texture();
    let image = texture.source();
    let slot = match image_slots.get(&image.index()) {
        Some(&s) => s,
        None => {
            if let Some(msg) = image_source_problem(doc, image.index(), buffers) {
                return Err(fail(&format!("images[{}]", image.index()), msg));
            }
            let data = gltf::image::Data::from_source(image.source(), Some(base), buffers).map_err(|e| {
                let (key, what) = match image.source() {
                    gltf::image::Source::Uri { uri, .. } => match uri_path(base, uri) {
                        Some(p) => (format!("images[{}].uri", image.index()), p.display().to_string()),
                        None => (format!("images[{}].uri", image.index()), "the data URI".into()),
                    },
                    gltf::image::Source::View { view, .. } => (
                        format!("images[{}].bufferView", image.index()),
                        format!("bufferViews[{}]", view.index()),
                    ),
                };
                fail(&key, format!("cannot read or decode {what}: {e}"))
            })?;
            let tex = to_rgba8(&data).ok_or_else(|| {
                fail(
                    &format!("images[{}]", image.index()),
                    format!("unsupported pixel format {:?}", data.format),
                )
            })?;
            geometry.textures.push(tex);
            let s = geometry.textures.len() as u32 - 1;
            image_slots.insert(image.index(), s);
            s
        }
    };
    let sampler = texture.sampler();
    let transform = info.texture_transform().map_or(Affine2::IDENTITY, |t| {
        let (s, c) = t.rotation().sin_cos();
        let rotation = Mat2::from_cols(Vec2::new(c, s), Vec2::new(-s, c));
        let scale = Mat2::from_diagonal(Vec2::from(t.scale()));
        Affine2::from_mat2_translation(rotation * scale, Vec2::from(t.offset()))
    });
    Ok(TextureRef {
        texture: slot,
        wrap_s: wrap(sampler.wrap_s()),
        wrap_t: wrap(sampler.wrap_t()),
        transform,
    })
}

/// Loads the meshes of every node of `scene`, each under its world transform (the file's
/// node transforms after `model_from_file`). Returns the first perspective camera met.
fn load_nodes(
    path: &Path,
    scene: &gltf::Scene,
    model_from_file: DMat4,
    material_base: u32,
    default_material: u32,
    buffers: &[gltf::buffer::Data],
    geometry: &mut Geometry,
) -> Result<Option<GltfCamera>, SceneError> {
    let fail = |key: &str, msg: String| SceneError::new(path, key, msg);
    let mut camera = None;
    // Depth-first over the node tree; an explicit stack so deep hierarchies cannot overflow.
    let mut stack: Vec<(gltf::Node, DMat4, usize)> = scene.nodes().map(|n| (n, model_from_file, 0)).collect();
    stack.reverse();
    // The spec's nodes form disjoint trees: a node reached twice is shared or in a cycle, and
    // a chain of nodes each listing the next twice is 2^n visits (a hang, not an error).
    let mut visited = std::collections::HashSet::new();
    while let Some((node, parent, depth)) = stack.pop() {
        if !visited.insert(node.index()) {
            return Err(fail(
                &format!("nodes[{}]", node.index()),
                "reached twice: a node may have one parent and appear in a scene once".into(),
            ));
        }
        if depth > 256 {
            return Err(fail(
                &format!("nodes[{}]", node.index()),
                "node hierarchy deeper than 256 (a cycle?)".into(),
            ));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if !world.is_finite() {
            return Err(fail(&format!("nodes[{}]", node.index()), "transform is not finite".into()));
        }
        if camera.is_none()
            && let Some(cam) = node.camera()
            && let gltf::camera::Projection::Perspective(p) = cam.projection()
        {
            camera = Some(GltfCamera { world, yfov: p.yfov() as f64 });
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                load_primitive(
                    path,
                    &mesh,
                    &prim,
                    world,
                    material_base,
                    default_material,
                    buffers,
                    geometry,
                )?;
            }
        }
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world, depth + 1));
        }
    }
    Ok(camera)
}

/// Whether gltf's import can decode `uri`: it unwraps `urlencoding::decode` of a URI without
/// a scheme, which fails (a panic) when the %-escapes are not UTF-8, e.g. `%FF.bin`.
fn decodable_uri(uri: &str) -> bool {
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
fn open_gltf(path: &Path) -> Result<gltf::Gltf, String> {
    use gltf::json::{mesh::Semantic, validation::Checked};
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    if bytes.starts_with(b"glTF") && bytes.len() >= 12 {
        let length = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if length < 12 || length as usize > bytes.len() {
            return Err(format!("GLB header length {length} does not fit the file's {} bytes", bytes.len()));
        }
    }
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| e.to_string())?;
    let json = gltf.document.as_json();
    for (i, buffer) in json.buffers.iter().enumerate() {
        if let Some(uri) = &buffer.uri
            && !decodable_uri(uri)
        {
            return Err(format!("buffers[{i}].uri: its %-escapes do not decode to UTF-8"));
        }
    }
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(i) = prim.attributes.get(&Checked::Valid(Semantic::Positions))
                && i.value() >= json.accessors.len()
            {
                return Err(format!(
                    "meshes[{m}].primitives[{p}].attributes.POSITION: no accessor {} ({} accessors)",
                    i.value(),
                    json.accessors.len()
                ));
            }
        }
    }
    let document = gltf::Document::from_json(gltf.document.into_json()).map_err(|e| e.to_string())?;
    Ok(gltf::Gltf { document, blob: gltf.blob })
}

/// What gltf's `Image::source` and `image::Data::from_source` panic on and its validation
/// lets through: a bufferView without a mimeType and a bufferView outside its buffer (both
/// found by fuzzing), neither a uri nor a bufferView (the unwrap beside the first), and a
/// uri that gltf cannot decode ([`decodable_uri`]).
fn image_source_problem(
    doc: &gltf::Document,
    index: usize,
    buffers: &[gltf::buffer::Data],
) -> Option<String> {
    let json = &doc.as_json().images[index];
    match (&json.buffer_view, &json.mime_type, &json.uri) {
        (Some(_), None, _) => Some("has a bufferView but no mimeType".into()),
        (None, _, None) => Some("has neither a uri nor a bufferView".into()),
        (None, _, Some(uri)) if !decodable_uri(uri) => {
            Some("uri: its %-escapes do not decode to UTF-8".into())
        }
        (Some(v), Some(_), _) => {
            let view = doc.views().nth(v.value())?; // the index is validated
            let len = buffers[view.buffer().index()].len();
            match view.offset().checked_add(view.length()) {
                Some(end) if end <= len => None,
                _ => Some(format!(
                    "bufferViews[{}] (offset {}, length {}) lies outside its buffer ({len} bytes)",
                    v.value(),
                    view.offset(),
                    view.length()
                )),
            }
        }
        (None, _, Some(_)) => None,
    }
}

#[allow(clippy::too_many_arguments)]
fn load_primitive(
    path: &Path,
    mesh: &gltf::Mesh,
    prim: &gltf::Primitive,
    world: DMat4,
    material_base: u32,
    default_material: u32,
    buffers: &[gltf::buffer::Data],
    geometry: &mut Geometry,
) -> Result<(), SceneError> {
    let key = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
    let fail = |k: &str, msg: String| SceneError::new(path, format!("{key}{k}"), msg);
    let mode = prim.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        return Ok(()); // points and lines have no area: nothing to render or shadow
    }
    let material = prim.material();
    let mat_id = match material.index() {
        Some(i) => material_base + i as u32,
        None => default_material,
    };
    let uv_set = material
        .pbr_metallic_roughness()
        .base_color_texture()
        .map(|info| info.texture_transform().and_then(|t| t.tex_coord()).unwrap_or(info.tex_coord()))
        .unwrap_or(0);

    let vertices = read_vertices(prim, uv_set, buffers, &fail)?;
    let corners = triangle_corners(mode, &vertices.indices);
    push_triangles(world, &vertices, corners, &material, mat_id, geometry);
    Ok(())
}

/// An accessor a primitive is read through: the key its errors name (after the primitive's),
/// the accessor if the primitive has it, and the element shape and component types gltf's
/// reader for it expects.
type AccessorSpec<'a> = (String, Option<gltf::Accessor<'a>>, Dimensions, &'static [DataType]);

/// POSITION, NORMAL, TEXCOORD_`uv_set` and the indices of `prim`, each checked (when
/// present) by `check_accessor`. `fail` makes an error under the primitive's key.
fn checked_accessors<'a>(
    prim: &gltf::Primitive<'a>,
    uv_set: u32,
    fail: &impl Fn(&str, String) -> SceneError,
) -> Result<[AccessorSpec<'a>; 4], SceneError> {
    // gltf's readers trust the accessors, and nothing validates these properties before
    // here: an empty accessor overflows `count - 1` (a panic in debug builds), an index
    // component type other than u8/u16/u32 hits `unreachable!`, a wrong element type is
    // read as garbage, and data outside its buffer view reads as "no attribute" (which
    // `read_vertices` reports).
    let accessors: [AccessorSpec<'a>; 4] = [
        (".attributes.POSITION".into(), prim.get(&Semantic::Positions), Dimensions::Vec3, &[DataType::F32]),
        (".attributes.NORMAL".into(), prim.get(&Semantic::Normals), Dimensions::Vec3, &[DataType::F32]),
        (
            format!(".attributes.TEXCOORD_{uv_set}"),
            prim.get(&Semantic::TexCoords(uv_set)),
            Dimensions::Vec2,
            &[DataType::F32, DataType::U8, DataType::U16],
        ),
        (
            ".indices".into(),
            prim.indices(),
            Dimensions::Scalar,
            &[DataType::U8, DataType::U16, DataType::U32],
        ),
    ];
    for (k, accessor, dimensions, types) in &accessors {
        if let Some(a) = accessor {
            check_accessor(a, *dimensions, types).map_err(|msg| fail(k, msg))?;
        }
    }
    Ok(accessors)
}

/// A primitive's vertex data, read and checked: positions finite, every other attribute
/// with one element per vertex, every index naming a vertex.
struct Vertices {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    uvs: Option<Vec<[f32; 2]>>,
    /// The file's indices, or 0..positions.len() for a primitive without them.
    indices: Vec<u32>,
}

/// Reads `prim`'s positions, normals, texture coordinates (set `uv_set`) and indices.
/// `fail` makes an error under the primitive's key.
fn read_vertices(
    prim: &gltf::Primitive,
    uv_set: u32,
    buffers: &[gltf::buffer::Data],
    fail: &impl Fn(&str, String) -> SceneError,
) -> Result<Vertices, SceneError> {
    let accessors = checked_accessors(prim, uv_set, fail)?;
    let unreadable = |k: &str, a: &Option<gltf::Accessor>| match a {
        Some(a) => fail(
            k,
            format!("accessors[{}] lies outside its buffer view, or the view outside its buffer", a.index()),
        ),
        None => fail(k, "missing".into()),
    };
    let [(pos_key, pos_acc, ..), (n_key, n_acc, ..), (uv_key, uv_acc, ..), (i_key, i_acc, ..)] = &accessors;

    let reader = prim.reader(|b| Some(&buffers[b.index()]));
    let positions: Vec<[f32; 3]> = match reader.read_positions() {
        Some(p) => p.collect(),
        None => return Err(unreadable(pos_key, pos_acc)),
    };
    if let Some(i) = positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(fail(".attributes.POSITION", format!("vertex {i} is not finite: {:?}", positions[i])));
    }
    // Every attribute must have one element per vertex (the spec requires equal counts;
    // nothing validates it before here), or indexing them by vertex would panic.
    let same_count = |k: &str, len: usize| {
        if len == positions.len() {
            Ok(())
        } else {
            Err(fail(k, format!("{len} elements for {} vertices (POSITION)", positions.len())))
        }
    };
    let normals: Option<Vec<[f32; 3]>> = match (reader.read_normals(), n_acc) {
        (Some(n), _) => Some(n.collect()),
        (None, Some(_)) => return Err(unreadable(n_key, n_acc)),
        (None, None) => None,
    };
    if let Some(n) = &normals {
        same_count(n_key, n.len())?;
    }
    let uvs: Option<Vec<[f32; 2]>> = match (reader.read_tex_coords(uv_set), uv_acc) {
        (Some(t), _) => Some(t.into_f32().collect()),
        (None, Some(_)) => return Err(unreadable(uv_key, uv_acc)),
        (None, None) => None,
    };
    if let Some(t) = &uvs {
        same_count(uv_key, t.len())?;
    }
    let indices: Vec<u32> = match (reader.read_indices(), i_acc) {
        (Some(i), _) => i.into_u32().collect(),
        (None, Some(_)) => return Err(unreadable(i_key, i_acc)),
        (None, None) => (0..positions.len() as u32).collect(),
    };
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
        return Err(fail(".indices", format!("index {bad} out of range ({} vertices)", positions.len())));
    }
    Ok(Vertices { positions, normals, uvs, indices })
}

/// The corners of each triangle of a triangle list, strip or fan (`mode`), as indices in
/// the file's winding.
fn triangle_corners(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [indices[i], indices[i + 1], indices[i + 2]]
                } else {
                    [indices[i + 1], indices[i], indices[i + 2]]
                }
            })
            .collect(),
        _ => (1..indices.len().saturating_sub(1)).map(|i| [indices[0], indices[i], indices[i + 1]]).collect(),
    }
}

/// Appends a primitive's triangles (`corners` into `vertices`) to `geometry` in world space,
/// counting and dropping those of zero area. Those of an emissive material (without an
/// emissive texture) also become one emitter candidate.
fn push_triangles(
    world: DMat4,
    vertices: &Vertices,
    corners: Vec<[u32; 3]>,
    material: &gltf::Material,
    mat_id: u32,
    geometry: &mut Geometry,
) {
    let Vertices { positions, normals, uvs, .. } = vertices;
    let normal_from_file = DMat3::from_mat4(world).inverse().transpose();
    let mirrored = world.determinant() < 0.0;
    let emissive = Vec3::from(material.emissive_factor()) * material.emissive_strength().unwrap_or(1.0);
    let is_emitter =
        emissive.max_element() > 0.0 && material.emissive_texture().is_none() && emissive.is_finite();
    let mut emitter_tris = Vec::new();
    for c in corners {
        let mut c = c;
        if mirrored {
            c.swap(1, 2); // keep the winding (and so the front face) under a mirroring transform
        }
        let p = c.map(|i| world.transform_point3(DVec3::from(positions[i as usize].map(f64::from))));
        if crate::precision::is_degenerate(p) {
            geometry.degenerate += 1;
            continue;
        }
        let n = normals.as_ref().and_then(|ns| {
            let n = c.map(|i| {
                (normal_from_file * DVec3::from(ns[i as usize].map(f64::from))).normalize_or_zero().as_vec3()
            });
            n.iter().all(|v| v.is_finite() && v.length_squared() > 0.5).then_some(n)
        });
        let uv = match uvs {
            Some(t) => c.map(|i| Vec2::from(t[i as usize])),
            None => [Vec2::ZERO; 3],
        };
        geometry.triangles.push(SourceTriangle { p, n, uv, material: mat_id });
        if is_emitter {
            emitter_tris.push(p);
        }
    }
    if !emitter_tris.is_empty() {
        geometry.emitters.push(EmitterCandidate {
            triangles: emitter_tris,
            radiance: emissive,
            double_sided: material.double_sided(),
        });
    }
}

/// Checks what gltf's accessor readers assume: at least one element (also in a sparse
/// substitution) and the element type the reader expects.
fn check_accessor(a: &gltf::Accessor, dimensions: Dimensions, types: &[DataType]) -> Result<(), String> {
    if a.count() == 0 || a.sparse().is_some_and(|s| s.count() == 0) {
        return Err(format!("accessors[{}] is empty (count must be >= 1)", a.index()));
    }
    if a.dimensions() != dimensions || !types.contains(&a.data_type()) {
        return Err(format!(
            "accessors[{}] is {:?} of {:?}; expected {:?} of one of {:?}",
            a.index(),
            a.dimensions(),
            a.data_type(),
            dimensions,
            types
        ));
    }
    Ok(())
}

fn wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

fn to_rgba8(data: &gltf::image::Data) -> Option<Texture> {
    use gltf::image::Format;
    let px = &data.pixels;
    let (channels, bytes) = match data.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        _ => return None,
    };
    let stride = channels * bytes;
    let count = (data.width * data.height) as usize;
    if px.len() < count * stride {
        return None;
    }
    // 16-bit channels are little-endian in gltf's decoded data: keep the high byte.
    let get = |i: usize, ch: usize| px[i * stride + ch * bytes + bytes - 1];
    let rgba8 = (0..count)
        .map(|i| match channels {
            1 => {
                let g = get(i, 0);
                [g, g, g, 255]
            }
            2 => {
                let g = get(i, 0);
                [g, g, g, get(i, 1)]
            }
            3 => [get(i, 0), get(i, 1), get(i, 2), 255],
            _ => [get(i, 0), get(i, 1), get(i, 2), get(i, 3)],
        })
        .collect();
    Some(Texture { width: data.width, height: data.height, rgba8 })
}
