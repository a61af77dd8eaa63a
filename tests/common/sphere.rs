//! A geodesic sphere for the tests that need a smooth closed surface.

#![allow(dead_code)] // each test binary uses a different subset

use glam::{DVec3, Vec2};
use renderer::geometry::material::Material;
use renderer::load::gltf_load::{Geometry, SourceTriangle};

/// A geodesic sphere (an icosahedron subdivided `levels` times, vertices on the sphere) of
/// radius `r` about the origin, albedo `rho`, faces wound outward (two-sided shading); with
/// the sphere's own normal at each corner where `smooth`, flat faces otherwise.
pub fn sphere(r: f64, levels: u32, rho: f32, smooth: bool) -> Geometry {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let v: Vec<DVec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| DVec3::from(*p).normalize())
    .collect();
    let faces = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut tris: Vec<[DVec3; 3]> = faces.iter().map(|f| [v[f[0]], v[f[1]], v[f[2]]]).collect();
    for _ in 0..levels {
        tris = tris
            .iter()
            .flat_map(|[a, b, c]| {
                let (ab, bc, ca) = ((*a + *b).normalize(), (*b + *c).normalize(), (*c + *a).normalize());
                [[*a, ab, ca], [ab, *b, bc], [ca, bc, *c], [ab, bc, ca]]
            })
            .collect();
    }
    let mut g = Geometry::default();
    g.materials.push(Material::diffuse([rho; 3]));
    for p in tris {
        g.triangles.push(SourceTriangle {
            p: p.map(|x| x * r),
            n: smooth.then(|| p.map(|x| x.normalize().as_vec3())),
            uv: [Vec2::ZERO; 3],
            material: 0,
            origin: renderer::geometry::instances::TriangleOrigin::LOOSE,
        });
    }
    g
}
