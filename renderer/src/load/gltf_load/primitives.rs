//! glTF primitives into triangles: accessors checked against their declared types and the
//! buffers before any read, strips and fans unrolled, degenerate corners kept for the
//! scene builder to count.

use super::*;

/// A mesh's topology as its primitives are read (at its first use): positions in the file's
/// space and corners into them, welded at the end.
#[derive(Default)]
pub(super) struct TopologyBuilder {
    positions: Vec<Vec3>,
    corners: Vec<[u32; 3]>,
}

impl TopologyBuilder {
    pub(super) fn finish(self) -> MeshTopology {
        MeshTopology::weld(&self.positions, &self.corners)
    }
}

/// A primitive read once per node, placed by each of the node's transforms (one, or one
/// per instance of `EXT_mesh_gpu_instancing`).
pub(super) struct ReadPrimitive<'a> {
    pub(super) data: PrimitiveData,
    pub(super) material: gltf::Material<'a>,
    pub(super) mat_id: u32,
}

impl ReadPrimitive<'_> {
    /// Its triangles (degenerate ones included): the next primitive's first index in the
    /// mesh is this one's plus this.
    pub(super) fn triangles(&self) -> u32 {
        self.data.corners.len() as u32
    }
}

/// Reads primitive `prim` of `mesh` (of the file `file` describes), and adds its triangles to
/// `topology` at the mesh's first use. `None` for points and lines (no area: nothing to
/// render or shadow).
/// Whether `prim` holds triangles (points and lines have no area: nothing to render or
/// shadow).
pub(super) fn has_triangles(prim: &gltf::Primitive) -> bool {
    matches!(prim.mode(), Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)
}

/// What a primitive's read data depends on beyond its positions, indices and mode: what its
/// material reads ([`Needs`]) and the accessors read for it.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(super) struct AttributeKey {
    needs: Needs,
    /// NORMAL, the base set's TEXCOORD, the second set's, COLOR_0 and TANGENT, where read.
    accessors: [Option<usize>; 5],
}

/// [`AttributeKey`] of `prim` whose material reads `needs`.
pub(super) fn attribute_key(prim: &gltf::Primitive, needs: Needs) -> AttributeKey {
    let index = |s: Semantic| prim.get(&s).map(|a| a.index());
    let accessors = [
        index(Semantic::Normals),
        index(Semantic::TexCoords(needs.base_set)),
        needs.second_set.and_then(|s| index(Semantic::TexCoords(s))),
        if needs.colors { index(Semantic::Colors(0)) } else { None },
        needs.tangent_set.and_then(|_| index(Semantic::Tangents)),
    ];
    AttributeKey { needs, accessors }
}

/// The scene's index of `prim`'s material.
pub(super) fn material_id(file: &FileContext, prim: &gltf::Primitive) -> u32 {
    match prim.material().index() {
        Some(i) => file.material_base + i as u32,
        None => file.default_material,
    }
}

pub(super) fn read_primitive<'a>(
    file: &FileContext,
    (mesh, prim): (&gltf::Mesh, &gltf::Primitive<'a>),
    needs: &Needs,
    topology: Option<&mut TopologyBuilder>,
) -> Result<Option<ReadPrimitive<'a>>, SceneError> {
    let FileContext { path, buffers, .. } = *file;
    let key = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
    let fail = |k: &str, msg: String| SceneError::new(path, format!("{key}{k}"), msg);
    let mode = prim.mode();
    if !has_triangles(prim) {
        return Ok(None);
    }
    let material = prim.material();
    let mat_id = material_id(file, prim);

    let vertices = read_vertices(prim, needs.base_set, buffers, &fail)?;
    let corners = triangle_corners(mode, &vertices.indices);
    if let Some(t) = topology {
        let base = t.positions.len() as u32;
        t.positions.extend(vertices.positions.iter().map(|&p| Vec3::from(p)));
        t.corners.extend(corners.iter().map(|c| c.map(|i| base + i)));
    }
    let extras = read_extras(prim, needs, (&vertices, &corners), buffers, &fail)?;
    let Vertices { positions, normals, uvs, .. } = vertices;
    let super::attributes::Extras { uv2, colors, tangents } = extras;
    let data = PrimitiveData { positions, normals, uvs, uv2, colors, tangents, corners };
    Ok(Some(ReadPrimitive { data, material, mat_id }))
}

/// Appends `prim`'s triangles under the world transform `world` to `geometry`, the first as
/// triangle `origin.local` of its mesh (`path`: the file it is read from).
pub(super) fn place_primitive(
    prim: &ReadPrimitive,
    (world, path): (DMat4, &Path),
    origin: TriangleOrigin,
    geometry: &mut Geometry,
) {
    push_triangles((world, path), &prim.data, &prim.material, (prim.mat_id, origin), geometry);
}

/// POSITION, NORMAL, TEXCOORD_`uv_set` and the indices of `prim`, each checked (when
/// present) by `check_accessor`. `fail` makes an error under the primitive's key.
pub(super) fn checked_accessors<'a>(
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
pub(super) struct Vertices {
    pub(super) positions: Vec<[f32; 3]>,
    pub(super) normals: Option<Vec<[f32; 3]>>,
    pub(super) uvs: Option<Vec<[f32; 2]>>,
    /// The file's indices, or 0..positions.len() for a primitive without them.
    pub(super) indices: Vec<u32>,
}

/// Reads `prim`'s positions, normals, texture coordinates (set `uv_set`) and indices.
/// `fail` makes an error under the primitive's key.
pub(super) fn read_vertices(
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
pub(super) fn triangle_corners(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
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
/// counting and dropping those of zero area and those out of f32's range
/// ([`Geometry::overflow`]). Those of an emissive material also become one
/// emitter candidate (`path`, the file, names its emissive texture where it has one).
pub(super) fn push_triangles(
    (world, path): (DMat4, &Path),
    data: &PrimitiveData,
    material: &gltf::Material,
    (mat_id, origin): (u32, TriangleOrigin),
    geometry: &mut Geometry,
) {
    let PrimitiveData { positions, normals, uvs, corners, .. } = data;
    let has_extras = data.uv2.is_some() || data.colors.is_some() || data.tangents.is_some();
    let placing = Placing::new(world);
    let emissive = emission(material, path).filter(|_| geometry.gather_emitters);
    let mut emitter_tris = Vec::new();
    let mut unlit = geometry.unlit.pending(material, path);
    for (local, &c) in (origin.local..).zip(corners) {
        let origin = TriangleOrigin { local, ..origin };
        // The winding (and so the front face) kept under a mirroring transform.
        let c = placing.corners(c);
        let p = c.map(|i| placing.position(positions[i as usize]));
        // Named with its node by the caller: f32 cannot hold it in any render space.
        if geometry.overflow.count(p) {
            continue;
        }
        if crate::geometry::precision::is_degenerate(p) {
            geometry.degenerate += 1;
            continue;
        }
        let n = placing.normals(normals.as_deref(), c);
        let uv = match uvs {
            Some(t) => c.map(|i| Vec2::from(t[i as usize])),
            None => [Vec2::ZERO; 3],
        };
        if has_extras {
            geometry.extras.push(geometry.triangles.len(), data.extras(&placing, c));
        }
        geometry.triangles.push(SourceTriangle { p, n, uv, material: mat_id, origin });
        if emissive.is_some() {
            emitter_tris.push(p);
        }
        if unlit.as_ref().is_some_and(|key| geometry.unlit.check(key, &p)) {
            unlit = None;
        }
    }
    if let Some((radiance, emissive_texture)) = emissive.filter(|_| !emitter_tris.is_empty()) {
        geometry.emitters.push(EmitterCandidate {
            triangles: emitter_tris,
            radiance,
            double_sided: material.double_sided(),
            emissive_texture,
        });
    }
}

/// A material's emission where it is positive and finite: emissiveFactor x emissive strength,
/// and `FILE: materials[i].emissiveTexture` (`path` the file) where a texture varies it.
fn emission(material: &gltf::Material, path: &Path) -> Option<(Vec3, Option<String>)> {
    let emissive = Vec3::from(material.emissive_factor()) * material.emissive_strength().unwrap_or(1.0);
    let texture = material
        .emissive_texture()
        .map(|_| format!("{}: materials[{}].emissiveTexture", path.display(), material.index().unwrap_or(0)));
    (emissive.max_element() > 0.0 && emissive.is_finite()).then_some((emissive, texture))
}

/// The emitter candidate of `prim` placed by `world` (its non-degenerate triangles in world
/// space, as [`push_triangles`] collects them), for a placement kept unflattened; `path` is
/// the file.
pub(super) fn emitter_of(
    data: &PrimitiveData,
    material: &gltf::Material,
    world: DMat4,
    path: &Path,
) -> Option<EmitterCandidate> {
    let (radiance, emissive_texture) = emission(material, path)?;
    let placing = Placing::new(world);
    let triangles: Vec<[DVec3; 3]> = data
        .corners
        .iter()
        .map(|&c| placing.corners(c).map(|i| placing.position(data.positions[i as usize])))
        .filter(|p| crate::geometry::precision::fits_f32(p) && !crate::geometry::precision::is_degenerate(*p))
        .collect();
    (!triangles.is_empty()).then(|| EmitterCandidate {
        triangles,
        radiance,
        double_sided: material.double_sided(),
        emissive_texture,
    })
}

/// Checks what gltf's accessor readers assume: at least one element (also in a sparse
/// substitution) and the element type the reader expects.
pub(super) fn check_accessor(
    a: &gltf::Accessor,
    dimensions: Dimensions,
    types: &[DataType],
) -> Result<(), String> {
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
    // gltf's reader slices each element at the view's stride: a stride under the element's
    // size leaves the last element short (an assertion in gltf, found by fuzzing).
    if let Some(stride) = a.view().and_then(|v| v.stride()).filter(|&s| s < a.size()) {
        return Err(format!(
            "accessors[{}]'s bufferView has byteStride {stride}, under its element's {} bytes",
            a.index(),
            a.size()
        ));
    }
    Ok(())
}
