//! Where each triangle came from: glTF meshes (all primitives of one mesh) with their
//! topology in the mesh's own space, the instances that place them (one per node that uses
//! a mesh), and per triangle its instance and its index among its mesh's triangles.
//!
//! The triangles themselves are still stored flattened in render space; this record lets a
//! method that needs connectivity (`silhouette`'s edges) work it out once per mesh instead
//! of once per copy: one transform maps equal positions to equal positions, so a mesh's
//! welded vertices are welded in every instance of it.

use crate::geometry::attributes::CornerExtras;
use glam::{DAffine3, DMat3, DMat4, DVec3, Vec2, Vec3, Vec4};
use std::sync::Arc;

/// A mesh's triangles as welded vertex ids in its own space: corners at bit-identical
/// positions (in the file, -0.0 as 0.0) share an id, across its primitives too.
#[derive(Debug, Clone, Default)]
pub struct MeshTopology {
    /// Vertex ids are `0..vertices`.
    pub vertices: u32,
    /// Per triangle of the mesh (every primitive's, in order, the file's winding): its
    /// corners' ids. Triangles dropped at load (zero area in render space) keep their index.
    pub corners: Vec<[u32; 3]>,
}

impl MeshTopology {
    /// Welds `positions` (bit-identical ones share an id, ids in order of first appearance
    /// of each position in the sorted order) and maps `corners` (indices into `positions`).
    pub fn weld(positions: &[Vec3], corners: &[[u32; 3]]) -> MeshTopology {
        let mut keys: Vec<u128> =
            positions.iter().enumerate().map(|(i, &v)| position_key(v, i as u32)).collect();
        keys.sort_unstable();
        let mut id = vec![0u32; positions.len()];
        let mut next = 0u32;
        for (n, &k) in keys.iter().enumerate() {
            if n > 0 && keys[n - 1] >> 32 != k >> 32 {
                next += 1;
            }
            id[k as u32 as usize] = next;
        }
        let vertices = if positions.is_empty() { 0 } else { next + 1 };
        MeshTopology { vertices, corners: corners.iter().map(|c| c.map(|i| id[i as usize])).collect() }
    }
}

/// A weld's sort key: the position's bits (-0.0 as 0.0) above a 32-bit tag, in one u128
/// (one integer comparison per step); equal positions are equal in `key >> 32`.
pub fn position_key(v: Vec3, tag: u32) -> u128 {
    let v = v + Vec3::ZERO; // -0.0 + 0.0 = 0.0
    let p = ((v.x.to_bits() as u128) << 64) | ((v.y.to_bits() as u128) << 32) | v.z.to_bits() as u128;
    (p << 32) | tag as u128
}

/// One placement of a mesh: a node using it (its transform is applied to the triangles).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Instance {
    /// Index into the scene's meshes.
    pub mesh: u32,
    /// A transform of negative determinant: the loader swapped each triangle's last two
    /// corners to keep its front face, so its corners are the mesh's in that order.
    pub mirrored: bool,
}

/// A triangle's instance and its index among its mesh's triangles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TriangleOrigin {
    pub instance: u32,
    pub local: u32,
}

impl TriangleOrigin {
    /// A triangle of no mesh (a soup built by hand): welded by position where needed.
    pub const LOOSE: TriangleOrigin = TriangleOrigin { instance: u32::MAX, local: u32::MAX };

    pub fn is_loose(self) -> bool {
        self.instance == u32::MAX
    }
}

/// A primitive's vertex data as the file holds it, shared by every placement of its mesh.
#[derive(Debug, Default)]
pub struct PrimitiveData {
    pub positions: Vec<[f32; 3]>,
    pub normals: Option<Vec<[f32; 3]>>,
    pub uvs: Option<Vec<[f32; 2]>>,
    /// The second texture-coordinate set
    /// ([`crate::geometry::material::Material::second_uv_set`]), where its material reads one.
    pub uv2: Option<Vec<[f32; 2]>>,
    /// COLOR_0, linear RGBA, where the file has it and it is not white everywhere.
    pub colors: Option<Vec<[f32; 4]>>,
    /// Tangents in the file's space (xyz, and w = +-1 the bitangent's sign), where the
    /// material has a normal texture: the file's TANGENT, or generated.
    pub tangents: Option<Vec<[f32; 4]>>,
    /// Per triangle: its corners (the file's winding) into the vertex arrays.
    pub corners: Vec<[u32; 3]>,
}

impl PrimitiveData {
    /// The extra attributes of the triangle with corners `c` (already in the placed order,
    /// [`Placing::corners`]) under `placing`: the flattened scene's and a kept instance's
    /// alike.
    pub fn extras(&self, placing: &Placing, c: [u32; 3]) -> CornerExtras {
        let uv2 = self.uv2.as_ref().map(|t| c.map(|i| Vec2::from(t[i as usize])));
        let color = self.colors.as_ref().map(|t| c.map(|i| Vec4::from(t[i as usize])));
        CornerExtras { uv2, color, tangent: placing.tangents(self.tangents.as_deref(), c) }
    }
}

/// A node's placement of a mesh kept unflattened (see `Geometry::keep_instances`): the
/// mesh's primitives, the world transform, a material per primitive and the instance.
#[derive(Debug, Clone)]
pub struct Placement {
    pub primitives: Arc<Vec<PrimitiveData>>,
    pub world: DMat4,
    pub materials: Arc<[u32]>,
    pub instance: u32,
}

/// The one arithmetic that places a mesh's corners and normals in world space. The loader's
/// flattening and the queries on kept instances both use it, so a triangle is the same bits
/// either way.
#[derive(Debug, Clone, Copy)]
pub struct Placing {
    /// The world transform as an affine map: the same products and sums in the same order as
    /// `DMat4::transform_point3` (so the same bits), without its fourth lane.
    affine: DAffine3,
    normal_from_file: DMat3,
    mirrored: bool,
}

impl Placing {
    pub fn new(world: DMat4) -> Placing {
        let normal_from_file = DMat3::from_mat4(world).inverse().transpose();
        let affine = DAffine3::from_mat4(world);
        Placing { affine, normal_from_file, mirrored: world.determinant() < 0.0 }
    }

    /// The transform's linear part.
    pub fn linear(&self) -> DMat3 {
        self.affine.matrix3
    }

    /// The transform's translation.
    pub fn translation(&self) -> DVec3 {
        self.affine.translation
    }

    /// A bound on the f64 rounding of a placed point (world space, and less a render
    /// offset `offset`) for mesh points within `reach` of the mesh's origin (in each
    /// coordinate): a few ulps of the terms summed. Render-space bounds alone miss it where
    /// world coordinates dwarf the camera-relative ones (geo-referenced scenes).
    pub fn rounding(&self, reach: f64, offset: DVec3) -> f64 {
        let linear = self.affine.matrix3;
        let stretch =
            [linear.x_axis, linear.y_axis, linear.z_axis].iter().map(|c| c.abs().element_sum()).sum::<f64>();
        8.0 * f64::EPSILON
            * (stretch * reach + self.affine.translation.abs().max_element() + offset.abs().max_element())
    }

    /// Whether the transform mirrors (its triangles' last two corners swapped).
    #[inline(always)]
    pub fn mirrored(&self) -> bool {
        self.mirrored
    }

    /// A triangle's corners in the order that keeps its front face: the last two swapped
    /// under a mirroring transform.
    #[inline(always)]
    pub fn corners(&self, mut c: [u32; 3]) -> [u32; 3] {
        if self.mirrored {
            c.swap(1, 2);
        }
        c
    }

    /// A file position in world space (f64).
    #[inline(always)]
    pub fn position(&self, p: [f32; 3]) -> DVec3 {
        self.point(DVec3::from(p.map(f64::from)))
    }

    /// [`Self::position`] of a file position already in f64.
    #[inline(always)]
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.affine.transform_point3(p)
    }

    /// The corners' normals in world space (unit, f32), or `None` where the file has none
    /// or one of them does not survive the transform (the face normal stands in).
    pub fn normals(&self, normals: Option<&[[f32; 3]]>, c: [u32; 3]) -> Option<[Vec3; 3]> {
        let ns = normals?;
        let n = c.map(|i| {
            (self.normal_from_file * DVec3::from(ns[i as usize].map(f64::from))).normalize_or_zero().as_vec3()
        });
        n.iter().all(|v| v.is_finite() && v.length_squared() > 0.5).then_some(n)
    }

    /// The corners' tangents in world space: xyz through the transform's linear part (a
    /// tangent is a direction along the surface, and stays orthogonal to the transformed
    /// normal), unit; w the bitangent's sign, flipped under a mirroring transform (the
    /// mirror turns the frame's handedness, so N x T turns against the surface's bitangent).
    /// `None` where the file has none or one does not survive the transform.
    pub fn tangents(&self, tangents: Option<&[[f32; 4]]>, c: [u32; 3]) -> Option<[Vec4; 3]> {
        let ts = tangents?;
        let flip = if self.mirrored { -1.0 } else { 1.0 };
        let t = c.map(|i| {
            let [x, y, z, w] = ts[i as usize];
            let v = (self.affine.matrix3 * DVec3::new(x as f64, y as f64, z as f64)).normalize_or_zero();
            v.as_vec3().extend(if w < 0.0 { -flip } else { flip })
        });
        t.iter().all(|v| v.is_finite() && v.truncate().length_squared() > 0.5).then_some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weld_joins_bit_identical_positions_only() {
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(-0.0, 0.0, 0.0), // the same point as the first
            Vec3::new(1.0, f32::EPSILON, 0.0),
        ];
        let t = MeshTopology::weld(&p, &[[0, 1, 3], [2, 3, 1]]);
        assert_eq!(t.vertices, 3);
        assert_eq!(t.corners[0][0], t.corners[1][0]);
        assert_ne!(t.corners[0][1], t.corners[0][2]);
        assert_eq!(t.corners[0][1], t.corners[1][2]);
    }
}
