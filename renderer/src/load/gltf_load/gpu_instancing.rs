//! `EXT_mesh_gpu_instancing`: a node that draws its mesh once per element of its TRANSLATION,
//! ROTATION and SCALE accessors, each copy's transform applied before the node's own
//! (the extension's rule: world = node's world x T x R x S).

use super::*;
use gltf::accessor::util::Iter;

const EXTENSION: &str = "EXT_mesh_gpu_instancing";

/// The accessor indices the extension names on `node`: (attribute, accessor).
fn attributes(node: &gltf::Node) -> Vec<(String, Option<usize>)> {
    let Some(ext) = node.extension_value(EXTENSION) else { return Vec::new() };
    let Some(attributes) = ext.get("attributes").and_then(|a| a.as_object()) else { return Vec::new() };
    attributes.iter().map(|(name, v)| (name.clone(), v.as_u64().map(|i| i as usize))).collect()
}

/// How many copies of its mesh `node` draws, from the accessors' declared counts (nothing
/// read): 1 without the extension.
pub(super) fn planned_count(doc: &gltf::Document, node: &gltf::Node) -> u64 {
    attributes(node)
        .iter()
        .filter_map(|(_, i)| doc.accessors().nth((*i)?))
        .map(|a| a.count() as u64)
        .max()
        .unwrap_or(1)
}

/// The world transforms `node` draws its mesh with: `world` alone, or one per instance of the
/// extension. Errors name the attribute: an accessor that does not exist, is empty, has
/// the wrong type or a count unlike the others', a value that is not finite, a transform
/// that is singular or not finite.
pub(super) fn placements(
    file: &FileContext,
    node: &gltf::Node,
    world: DMat4,
) -> Result<Vec<DMat4>, SceneError> {
    let attributes = attributes(node);
    if node.extension_value(EXTENSION).is_none() {
        return Ok(vec![world]);
    }
    let key = |name: &str| format!("nodes[{}].extensions.{EXTENSION}.attributes.{name}", node.index());
    let fail = |name: &str, msg: String| SceneError::new(file.path, key(name), msg);
    if attributes.is_empty() {
        return Err(SceneError::new(
            file.path,
            format!("nodes[{}].extensions.{EXTENSION}.attributes", node.index()),
            "names no TRANSLATION, ROTATION or SCALE accessor",
        ));
    }
    let (mut t, mut r, mut s) = (None, None, None);
    for (name, index) in &attributes {
        let accessor = index
            .and_then(|i| file.doc.accessors().nth(i))
            .ok_or_else(|| fail(name, format!("{index:?} is not an accessor of the file")))?;
        match name.as_str() {
            "TRANSLATION" => t = Some(vec3s(file, &accessor).map_err(|m| fail(name, m))?),
            "SCALE" => s = Some(vec3s(file, &accessor).map_err(|m| fail(name, m))?),
            "ROTATION" => r = Some(rotations(file, &accessor).map_err(|m| fail(name, m))?),
            _ => {} // custom attributes (the extension allows them): nothing to place
        }
    }
    let count = [t.as_ref().map(Vec::len), r.as_ref().map(Vec::len), s.as_ref().map(Vec::len)];
    let n = count.iter().flatten().copied().max().unwrap_or(0);
    for (name, c) in ["TRANSLATION", "ROTATION", "SCALE"].iter().zip(count) {
        if c.is_some_and(|c| c != n) {
            return Err(fail(name, format!("{} elements where another attribute has {n}", c.unwrap_or(0))));
        }
    }
    (0..n)
        .map(|k| {
            let tk = t.as_ref().map_or(DVec3::ZERO, |v| v[k]);
            let rk = r.as_ref().map_or(glam::DQuat::IDENTITY, |v| v[k]);
            let sk = s.as_ref().map_or(DVec3::ONE, |v| v[k]);
            let placed = world * DMat4::from_scale_rotation_translation(sk, rk, tk);
            if !placed.is_finite() || placed.determinant() == 0.0 {
                let name = if sk.x * sk.y * sk.z == 0.0 { "SCALE" } else { "TRANSLATION" };
                return Err(fail(name, format!("instance {k}'s transform is singular or not finite")));
            }
            Ok(placed)
        })
        .collect()
}

/// A float VEC3 accessor's elements, each finite.
fn vec3s(file: &FileContext, a: &gltf::Accessor) -> Result<Vec<DVec3>, String> {
    primitives::check_accessor(a, Dimensions::Vec3, &[DataType::F32])?;
    let values: Vec<[f32; 3]> = Iter::new(a.clone(), |b: gltf::Buffer| Some(&file.buffers[b.index()][..]))
        .ok_or_else(|| format!("accessors[{}] lies outside its buffer", a.index()))?
        .collect();
    finite(values.into_iter().map(|v| DVec3::from(v.map(f64::from))).collect(), |v| v.is_finite())
}

/// A VEC4 rotation accessor's unit quaternions: float, or normalized signed bytes or shorts
/// (the extension allows all three), renormalised in f64.
fn rotations(file: &FileContext, a: &gltf::Accessor) -> Result<Vec<glam::DQuat>, String> {
    primitives::check_accessor(a, Dimensions::Vec4, &[DataType::F32, DataType::I8, DataType::I16])?;
    let get = |b: gltf::Buffer| Some(&file.buffers[b.index()][..]);
    let outside = || format!("accessors[{}] lies outside its buffer", a.index());
    let raw: Vec<[f64; 4]> = match a.data_type() {
        DataType::I8 => Iter::<[i8; 4]>::new(a.clone(), get)
            .ok_or_else(outside)?
            .map(|q| q.map(|c| (c as f64 / 127.0).max(-1.0)))
            .collect(),
        DataType::I16 => Iter::<[i16; 4]>::new(a.clone(), get)
            .ok_or_else(outside)?
            .map(|q| q.map(|c| (c as f64 / 32767.0).max(-1.0)))
            .collect(),
        _ => Iter::<[f32; 4]>::new(a.clone(), get).ok_or_else(outside)?.map(|q| q.map(f64::from)).collect(),
    };
    let quats: Vec<glam::DQuat> = raw.into_iter().map(glam::DQuat::from_array).collect();
    let unit = finite(quats, |q| q.is_finite() && q.length() > 0.5)?;
    Ok(unit.into_iter().map(|q| q.normalize()).collect())
}

/// `values` if every one passes `ok`, else which does not.
fn finite<T: std::fmt::Debug>(values: Vec<T>, ok: impl Fn(&T) -> bool) -> Result<Vec<T>, String> {
    match values.iter().position(|v| !ok(v)) {
        None => Ok(values),
        Some(i) => Err(format!("element {i} is not finite (or not a rotation): {:?}", values[i])),
    }
}

#[cfg(test)]
mod tests {
    /// A node whose `EXT_mesh_gpu_instancing` accessor holds no copy places nothing: its
    /// mesh is neither counted nor planned as shared (its uses less one underflowed, found
    /// by review: a panic in debug builds, every mesh "shared" in release).
    #[test]
    fn an_empty_instancing_accessor_places_no_copy() {
        let json = r#"{
          "asset": {"version": "2.0"},
          "extensionsUsed": ["EXT_mesh_gpu_instancing"],
          "buffers": [{"byteLength": 36}],
          "bufferViews": [{"buffer": 0, "byteLength": 36}],
          "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
            {"bufferView": 0, "componentType": 5126, "count": 0, "type": "VEC3"}
          ],
          "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
          "nodes": [{"mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 1}}}}],
          "scenes": [{"nodes": [0]}],
          "scene": 0
        }"#;
        let raw = gltf::Gltf::from_slice_without_validation(json.as_bytes()).expect("parses");
        let doc = gltf::Document::from_json(raw.document.into_json()).expect("a valid document");
        let plan = super::super::plan(&doc);
        assert_eq!((plan.flattened, plan.placed, plan.shared_copies), (0, 0, 0));
        assert!(plan.shared.is_empty());
    }
}
