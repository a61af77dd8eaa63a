//! Which edges of the opaque triangles end a cover: boundaries, silhouettes and folds seen
//! from the light's centre (see the parent module).

use glam::Vec3;
use rayon::prelude::*;
use renderer::geometry::ray_origin::gamma;

/// Bit pattern of an edge's endpoints, smaller first: shared edges of a mesh have identical
/// f32 vertices.
type EdgeKey = [u32; 6];

fn edge_key(a: Vec3, b: Vec3) -> EdgeKey {
    let (ka, kb) = (a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits));
    let (x, y) = if ka <= kb { (ka, kb) } else { (kb, ka) };
    [x[0], x[1], x[2], y[0], y[1], y[2]]
}

/// The open edges of the opaque triangles (light-frame vertices): see the module doc.
/// A 64-bit hash of an edge's key (FNV-1a with a shift): edges are sorted by it, 16 bytes
/// each instead of 32.
fn edge_hash(k: EdgeKey) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for x in k {
        h = (h ^ u64::from(x)).wrapping_mul(0x0000_0100_0000_01b3);
        h ^= h >> 29;
    }
    h
}

pub(super) fn open_edges(tris: &[[Vec3; 3]]) -> Vec<(Vec3, Vec3)> {
    let key = |t: u32, e: u8| {
        let v = &tris[t as usize];
        edge_key(v[e as usize], v[(e as usize + 1) % 3])
    };
    let mut edges: Vec<(u64, u32, u8)> = (0..tris.len() as u32)
        .into_par_iter()
        .flat_map_iter(|t| (0..3u8).map(move |e| (edge_hash(key(t, e)), t, e)))
        .collect();
    edges.par_sort_unstable();
    let mut open = Vec::new();
    let mut k = 0;
    while k < edges.len() {
        let mut end = k + 1;
        while end < edges.len() && edges[end].0 == edges[k].0 {
            end += 1;
        }
        let (t, e) = (edges[k].1 as usize, edges[k].2 as usize);
        let (a, b) = (tris[t][e], tris[t][(e + 1) % 3]);
        // A group whose members' keys differ (a hash collision) is open: conservative.
        let same = edges[k + 1..end].iter().all(|x| key(x.1, x.2) == key(edges[k].1, edges[k].2));
        if !same {
            for x in &edges[k..end] {
                let v = &tris[x.1 as usize];
                open.push((v[x.2 as usize], v[(x.2 as usize + 1) % 3]));
            }
            k = end;
            continue;
        }
        let interior = end - k == 2 && {
            // The two third vertices on opposite sides of the plane through the edge and
            // the light's centre (the frame's origin), each by more than its rounding.
            let n = a.cross(b);
            let third = |i: usize| {
                let (t, e) = (edges[i].1 as usize, edges[i].2 as usize);
                tris[t][(e + 2) % 3]
            };
            let (c1, c2) = (third(k), third(k + 1));
            let tol = |c: Vec3| gamma(8) * a.length() * b.length() * c.length();
            let (s1, s2) = (n.dot(c1), n.dot(c2));
            s1.abs() > tol(c1) && s2.abs() > tol(c2) && (s1 > 0.0) != (s2 > 0.0)
        };
        if !interior {
            open.push((a, b));
        }
        k = end;
    }
    open
}
