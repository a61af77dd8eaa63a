//! Tangents for a normal-mapped primitive that has none, as glTF asks (MikkTSpace, from the
//! positions, normals and the normal texture's coordinates), written here after the
//! algorithm's description (Mikkelsen 2008, "Simulation of wrinkled surfaces revisited"):
//!
//! - each triangle's tangent and bitangent from its texture-coordinate derivatives (the
//!   directions in which u and v grow), with the sign of its UV area (its orientation);
//! - at each corner both are projected onto the vertex normal's plane, made unit and weighed
//!   by the corner's angle in that plane, then summed over the corners that share position,
//!   normal, texture coordinates and orientation (a vertex of an unwelded mesh and its copies
//!   get one tangent; mirrored UV islands meeting at a seam do not cancel);
//! - the sum is made orthogonal to the normal and unit, and w = +-1 says whether the summed
//!   bitangent lies along N x T or against it.
//!
//! v is taken growing up the image (glTF's v grows down): normal textures are authored with
//! +y up (OpenGL's convention, which glTF names), so the bitangent is the direction of
//! decreasing glTF v. Left out of the full algorithm: splitting a vertex's corners into
//! groups by how far their tangents diverge, and degenerate triangles' borrowing of their
//! neighbours' tangents (a vertex with no usable triangle gets any tangent orthogonal to its
//! normal). Measured against flight-helmet's own tangents: `tests/materials.rs`.

use glam::{DVec2, DVec3};
use std::collections::HashMap;

/// Per vertex: a unit tangent orthogonal to the vertex normal (xyz) and the bitangent's sign
/// (w = +-1), for a primitive's `positions`, `normals` (`None`: each triangle's face normal),
/// texture coordinates `uvs` (the normal texture's set) and triangles `corners` (vertex
/// indices, in range). A vertex in no triangle gets any tangent orthogonal to its normal.
pub fn generate_tangents(
    positions: &[[f32; 3]],
    normals: Option<&[[f32; 3]]>,
    uvs: &[[f32; 2]],
    corners: &[[u32; 3]],
) -> Vec<[f32; 4]> {
    let at = |i: u32| DVec3::from(positions[i as usize].map(f64::from));
    let uv_at = |i: u32| {
        let [u, v] = uvs[i as usize].map(f64::from);
        DVec2::new(u, -v)
    };
    let mut groups = Groups::default();
    // Per vertex: the group of its first corner in a triangle with a UV frame.
    let mut first = vec![u32::MAX; positions.len()];
    // Per vertex in no such triangle: the face normal of one it is in.
    let mut lone = HashMap::new();
    for c in corners {
        let p = c.map(at);
        let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        let Some((t, b, orientation)) = face_frame(p, c.map(uv_at)) else {
            c.iter().for_each(|&i| _ = lone.entry(i).or_insert(face));
            continue;
        };
        for k in 0..3 {
            let i = c[k];
            let n = vertex_normal(normals, i, face);
            let g = groups.id(positions[i as usize], n, uvs[i as usize], orientation);
            if first[i as usize] == u32::MAX {
                first[i as usize] = g;
            }
            let angle = corner_angle(n, p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
            let sum = &mut groups.sums[g as usize];
            sum.0 += angle * on_plane(n, t);
            sum.1 += angle * on_plane(n, b);
        }
    }
    first
        .iter()
        .enumerate()
        .map(|(i, &g)| match groups.sums.get(g as usize) {
            Some(&(t, b, n)) => finish(n, t, b),
            None => {
                let face = lone.get(&(i as u32)).copied().unwrap_or(DVec3::Z);
                finish(vertex_normal(normals, i as u32, face), DVec3::ZERO, DVec3::ZERO)
            }
        })
        .collect()
}

/// Corners that share one tangent: by position, normal, coordinates (bits) and orientation.
#[derive(Default)]
struct Groups {
    ids: HashMap<[u32; 9], u32>,
    /// Per group: the angle-weighted tangent and bitangent sums, and its normal.
    sums: Vec<(DVec3, DVec3, DVec3)>,
}

impl Groups {
    fn id(&mut self, p: [f32; 3], n: DVec3, uv: [f32; 2], orientation: bool) -> u32 {
        let nf = n.as_vec3();
        let key = [
            p[0].to_bits(),
            p[1].to_bits(),
            p[2].to_bits(),
            nf.x.to_bits(),
            nf.y.to_bits(),
            nf.z.to_bits(),
            uv[0].to_bits(),
            uv[1].to_bits(),
            orientation as u32,
        ];
        let next = self.sums.len() as u32;
        let id = *self.ids.entry(key).or_insert(next);
        if id == next {
            self.sums.push((DVec3::ZERO, DVec3::ZERO, n));
        }
        id
    }
}

/// A triangle's unit tangent and bitangent (the directions of growing u and growing v, in
/// space) and whether its UV image keeps its winding; `None` where its UV image has no
/// area or its positions none.
fn face_frame(p: [DVec3; 3], uv: [DVec2; 3]) -> Option<(DVec3, DVec3, bool)> {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let (d1, d2) = (uv[1] - uv[0], uv[2] - uv[0]);
    let area = d1.x * d2.y - d2.x * d1.y;
    if area == 0.0 || !area.is_finite() {
        return None;
    }
    // Solving e1 = d1.x T + d1.y B, e2 = d2.x T + d2.y B for T and B; the sign of the area
    // is kept in neither, only their directions.
    let t = ((e1 * d2.y - e2 * d1.y) * area.signum()).try_normalize()?;
    let b = ((e2 * d1.x - e1 * d2.x) * area.signum()).try_normalize()?;
    Some((t, b, area > 0.0))
}

/// Vertex `i`'s unit normal, or `face` where the primitive has none (or it is zero).
fn vertex_normal(normals: Option<&[[f32; 3]]>, i: u32, face: DVec3) -> DVec3 {
    normals.and_then(|n| DVec3::from(n[i as usize].map(f64::from)).try_normalize()).unwrap_or(face)
}

/// `v` projected onto the plane of unit normal `n`, unit (zero where it lies along `n`).
fn on_plane(n: DVec3, v: DVec3) -> DVec3 {
    (v - n * n.dot(v)).normalize_or_zero()
}

/// The angle at corner `p` between its edges to `q` and `r`, measured in the plane of `n`.
fn corner_angle(n: DVec3, p: DVec3, q: DVec3, r: DVec3) -> f64 {
    let (a, b) = (on_plane(n, q - p), on_plane(n, r - p));
    a.dot(b).clamp(-1.0, 1.0).acos()
}

/// The vertex's tangent from its group's sums: orthogonal to `n`, unit (any orthogonal
/// direction where the sums vanish), w the sign of the bitangent against N x T.
fn finish(n: DVec3, t: DVec3, b: DVec3) -> [f32; 4] {
    let n = if n == DVec3::ZERO { DVec3::Z } else { n };
    let t = on_plane(n, t);
    let t = if t == DVec3::ZERO { n.any_orthonormal_vector() } else { t };
    let w = if n.cross(t).dot(b) < 0.0 { -1.0 } else { 1.0 };
    let t = t.as_vec3();
    [t.x, t.y, t.z, w]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit quad in the xy plane, normal +z, u along +x and glTF v down the image along -y:
    /// the tangent is +x and the bitangent (v up the image) +y = N x T, so w = +1. Mirrored
    /// in u (u along -x) the tangent turns to -x and w to -1.
    #[test]
    fn a_quad_gets_its_uv_directions() {
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let n = [[0.0, 0.0, 1.0]; 4];
        let uv = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
        let corners = [[0, 1, 2], [0, 2, 3]];
        for t in generate_tangents(&p, Some(&n), &uv, &corners) {
            assert_eq!(t, [1.0, 0.0, 0.0, 1.0]);
        }
        let mirrored = uv.map(|[u, v]| [1.0 - u, v]);
        for t in generate_tangents(&p, None, &mirrored, &corners) {
            assert_eq!(t, [-1.0, 0.0, 0.0, -1.0]);
        }
    }

    /// A vertex shared by two triangles at a fold averages their tangents by the corners'
    /// angles, in the plane of its normal; the result is orthogonal to it and unit.
    #[test]
    fn shared_vertices_average_and_stay_orthogonal() {
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.3], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.3]];
        let n = [[0.0, 0.0, 1.0], [0.2, 0.0, 1.0], [0.0, 0.1, 1.0], [-0.2, 0.0, 1.0]];
        let uv = [[0.5, 1.0], [1.0, 1.0], [0.5, 0.0], [0.0, 1.0]];
        let t = generate_tangents(&p, Some(&n), &uv, &[[0, 1, 2], [0, 2, 3]]);
        for (t, n) in t.iter().zip(n) {
            let (t, n) = (glam::Vec3::new(t[0], t[1], t[2]), glam::Vec3::from(n).normalize());
            assert!(t.dot(n).abs() < 1e-6 && (t.length() - 1.0).abs() < 1e-6, "{t} against {n}");
            assert!(t.x > 0.9, "u grows along +x: {t}");
        }
    }

    #[test]
    fn degenerate_uvs_and_lone_vertices_still_get_a_frame() {
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 5.0]];
        let uv = [[0.3, 0.3]; 4];
        let t = generate_tangents(&p, None, &uv, &[[0, 1, 2]]);
        for t in &t[..3] {
            assert!(t[2].abs() < 1e-6 && (t[0] * t[0] + t[1] * t[1] - 1.0).abs() < 1e-6, "{t:?}");
        }
        assert!(t[3].iter().all(|c| c.is_finite()));
    }
}
