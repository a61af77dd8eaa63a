//! A primitive's attributes beyond POSITION, NORMAL, its base colour's TEXCOORD and the
//! indices: the second texture-coordinate set, COLOR_0 and TANGENT (generated where a
//! normal-mapped primitive has none), each read only where its material reads it
//! ([`Needs`]), each accessor checked as the others are before gltf's reader trusts it.

use super::primitives::Vertices;
use super::*;

/// What a primitive's material reads beside its positions and normals, which decides the
/// attributes read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) struct Needs {
    /// The base colour texture's set (0 without one): a triangle's first coordinates.
    pub(super) base_set: u32,
    /// [`Material::second_uv_set`].
    pub(super) second_set: Option<u32>,
    /// The normal texture's set, where tangents are wanted (a normal texture, shaded as
    /// glTF).
    pub(super) tangent_set: Option<u32>,
    /// COLOR_0 (read where present): shaded as glTF only.
    pub(super) colors: bool,
}

impl Needs {
    pub(super) fn of(material: &Material, shading: Shading) -> Needs {
        let gltf = shading == Shading::Gltf;
        Needs {
            base_set: material.base_uv_set(),
            second_set: material.second_uv_set(),
            tangent_set: material.normal_texture.filter(|_| gltf).map(|n| n.texture.tex_coord),
            colors: gltf,
        }
    }
}

/// The attributes [`Needs`] asks for, read (or generated).
#[derive(Default)]
pub(super) struct Extras {
    pub(super) uv2: Option<Vec<[f32; 2]>>,
    pub(super) colors: Option<Vec<[f32; 4]>>,
    pub(super) tangents: Option<Vec<[f32; 4]>>,
}

/// Reads what `needs` asks of `prim` beyond `v` (its vertices, read and checked): the
/// second set, COLOR_0 (dropped where it is white everywhere: it would multiply by one) and
/// TANGENT, else tangents generated from `v` and `corners` (the triangles' vertex indices)
/// where the normal texture's coordinates exist. `fail` makes an error under the
/// primitive's key.
pub(super) fn read_extras(
    prim: &gltf::Primitive,
    needs: &Needs,
    (v, corners): (&Vertices, &[[u32; 3]]),
    buffers: &[gltf::buffer::Data],
    fail: &impl Fn(&str, String) -> SceneError,
) -> Result<Extras, SceneError> {
    let reader = prim.reader(|b| Some(&buffers[b.index()]));
    let count = v.positions.len();
    let uv2 = match needs.second_set {
        None => None,
        Some(set) => {
            let key = format!(".attributes.TEXCOORD_{set}");
            let spec: Spec = (&[Dimensions::Vec2], &[DataType::F32, DataType::U8, DataType::U16]);
            check(prim.get(&Semantic::TexCoords(set)), &key, spec, fail)?
                .map(|a| {
                    read(reader.read_tex_coords(set).map(|t| t.into_f32().collect()), &a, (&key, count), fail)
                })
                .transpose()?
        }
    };
    let colors = if needs.colors { read_colors(prim, &reader, count, fail)? } else { None };
    let tangents = match needs.tangent_set {
        None => None,
        Some(set) => match read_tangents(prim, &reader, count, fail)? {
            Some(t) => Some(t),
            None => {
                let uvs = if set == needs.base_set { v.uvs.as_deref() } else { uv2.as_deref() };
                uvs.map(|uv| generate_tangents(&v.positions, v.normals.as_deref(), uv, corners))
            }
        },
    };
    Ok(Extras { uv2, colors, tangents })
}

/// The element shapes and component types an attribute's accessor may have.
type Spec = (&'static [Dimensions], &'static [DataType]);

/// `accessor` (of the attribute `key` names) checked as [`check_accessor`] does, for one of
/// the shapes `spec` allows.
fn check<'a>(
    accessor: Option<gltf::Accessor<'a>>,
    key: &str,
    (shapes, types): Spec,
    fail: &impl Fn(&str, String) -> SceneError,
) -> Result<Option<gltf::Accessor<'a>>, SceneError> {
    let Some(a) = accessor else { return Ok(None) };
    // The accessor's own shape where it is one allowed, so a wrong one names the first.
    let shape = if shapes.contains(&a.dimensions()) { a.dimensions() } else { shapes[0] };
    check_accessor(&a, shape, types).map_err(|msg| fail(key, msg))?;
    Ok(Some(a))
}

/// What gltf's reader gave for the checked accessor `a` (`None`: its data lies outside its
/// buffer), with one element per vertex (`count`); errors under `key`.
fn read<T>(
    values: Option<Vec<T>>,
    a: &gltf::Accessor,
    (key, count): (&str, usize),
    fail: &impl Fn(&str, String) -> SceneError,
) -> Result<Vec<T>, SceneError> {
    let Some(values) = values else {
        return Err(fail(
            key,
            format!("accessors[{}] lies outside its buffer view, or the view outside its buffer", a.index()),
        ));
    };
    if values.len() != count {
        return Err(fail(key, format!("{} elements for {count} vertices (POSITION)", values.len())));
    }
    Ok(values)
}

/// COLOR_0 as linear RGBA (VEC3 read with alpha 1; normalized bytes and shorts over their
/// maximum), or `None` where it is absent or white everywhere.
fn read_colors<'a, 's, F>(
    prim: &gltf::Primitive<'a>,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    count: usize,
    fail: &impl Fn(&str, String) -> SceneError,
) -> Result<Option<Vec<[f32; 4]>>, SceneError>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let key = ".attributes.COLOR_0";
    let spec: Spec = (&[Dimensions::Vec4, Dimensions::Vec3], &[DataType::F32, DataType::U8, DataType::U16]);
    let Some(a) = check(prim.get(&Semantic::Colors(0)), key, spec, fail)? else { return Ok(None) };
    let colors = read(reader.read_colors(0).map(|c| c.into_rgba_f32().collect()), &a, (key, count), fail)?;
    if let Some(i) = colors.iter().position(|c: &[f32; 4]| !c.iter().all(|x| x.is_finite() && *x >= 0.0)) {
        return Err(fail(key, format!("vertex {i} is not finite and >= 0: {:?}", colors[i])));
    }
    Ok(colors.iter().any(|c| *c != [1.0; 4]).then_some(colors))
}

/// TANGENT (VEC4 f32: xyz and the bitangent's sign in w), or `None` where absent.
fn read_tangents<'a, 's, F>(
    prim: &gltf::Primitive<'a>,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    count: usize,
    fail: &impl Fn(&str, String) -> SceneError,
) -> Result<Option<Vec<[f32; 4]>>, SceneError>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let key = ".attributes.TANGENT";
    let spec: Spec = (&[Dimensions::Vec4], &[DataType::F32]);
    let Some(a) = check(prim.get(&Semantic::Tangents), key, spec, fail)? else { return Ok(None) };
    read(reader.read_tangents().map(|t| t.collect()), &a, (key, count), fail).map(Some)
}
