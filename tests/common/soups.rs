//! Random triangle soups and terraced heightfields as glTF scene files, for the differential
//! tests of the exact methods against the BVH.

#![allow(dead_code)] // each test binary uses a different subset

use super::gltf_writer::{GltfBuilder, TRIANGLES, TempDir, primitive, write_png_rgba};
use renderer::util::random::Rng;
use serde_json::json;
use std::path::{Path, PathBuf};

/// Writes a glTF of `tris` (each three points) with one opaque material.
pub fn soup(dir: &TempDir, name: &str, tris: &[[[f32; 3]; 3]]) -> PathBuf {
    let mut g = GltfBuilder::default();
    let positions: Vec<[f32; 3]> = tris.iter().flatten().copied().collect();
    let pos = g.positions(&positions);
    let material = g.material(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0]}, "doubleSided": true}),
    );
    let mesh = g.mesh(vec![json!({"attributes": {"POSITION": pos}, "material": material})]);
    let node = g.node(json!({"mesh": mesh}));
    let scene = g.scene(&[node]);
    g.set_default_scene(scene);
    g.write(&dir.path, name)
}

/// A scene file around a model: a floor, a square light above, a camera looking down.
pub fn scene_file(dir: &TempDir, name: &str, model: &Path, light_size: f64) -> PathBuf {
    let text = format!(
        r#"[[model]]
path = "{}"
[[quad]]
center = [0.0, 0.0, 0.0]
u = [6.0, 0.0, 0.0]
v = [0.0, 0.0, -6.0]
color = [0.7, 0.7, 0.7]
[camera]
position = [0.3, 3.2, 2.4]
look_at = [0.0, 0.2, 0.0]
up = [0.0, 1.0, 0.0]
yfov_deg = 50.0
[[light]]
center = [0.2, 2.5, 0.1]
u = [{light_size}, 0.0, 0.0]
v = [0.0, 0.0, {light_size}]
radiance = [5.0, 5.0, 5.0]
"#,
        model.display().to_string().replace('\\', "/")
    );
    let path = dir.join(&format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

/// Six random soups (sizes from a millimetre to a metre, any orientation, a quarter of the
/// triangles with a neighbour sharing an edge: folds and flat pairs) and three terraced
/// heightfields (closed boxes: shared edges, covers, walls), each under a light of its own
/// size, from `seed`.
pub fn soups_and_terraces(dir: &TempDir, seed: u64) -> Vec<PathBuf> {
    let mut scenes = Vec::new();
    let mut rng = Rng::new(seed);
    let mut r = move || rng.next_f32();
    for k in 0..6 {
        let mut tris = Vec::new();
        let scale = [0.003f32, 0.05, 0.3, 1.0, 0.02, 0.2][k];
        for _ in 0..400 {
            let c = [r() * 2.0 - 1.0, 0.05 + r() * 1.5, r() * 2.0 - 1.0];
            let mut t = [[0.0f32; 3]; 3];
            for v in &mut t {
                *v = [c[0] + (r() - 0.5) * scale, c[1] + (r() - 0.5) * scale, c[2] + (r() - 0.5) * scale];
            }
            tris.push(t);
            // Every fourth triangle gets a neighbour sharing an edge (a fold or a flat pair).
            if r() < 0.25 {
                let d = [c[0] + (r() - 0.5) * scale, c[1] + (r() - 0.5) * scale, c[2] + (r() - 0.5) * scale];
                tris.push([t[1], t[0], d]);
            }
        }
        let model = soup(dir, &format!("soup{k}"), &tris);
        scenes.push(scene_file(dir, &format!("soup{k}"), &model, [0.2, 0.6, 1.2][k % 3]));
    }
    for k in 0..3 {
        // A terraced heightfield: an n x n grid of columns with random heights, each a closed
        // box (top and four sides), sharing edges with nothing: covers on the tops.
        let n = 8 + 4 * k;
        let cell = 1.6 / n as f32;
        let mut tris = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let h = 0.05 + r() * 0.6 * (k as f32 + 1.0) / 3.0;
                let (x0, z0) = (-0.8 + i as f32 * cell, -0.8 + j as f32 * cell);
                let (x1, z1) = (x0 + cell * 0.8, z0 + cell * 0.8);
                let top = [[x0, h, z0], [x1, h, z0], [x1, h, z1], [x0, h, z1]];
                tris.push([top[0], top[1], top[2]]);
                tris.push([top[0], top[2], top[3]]);
                for s in 0..4 {
                    let (a, b) = (top[s], top[(s + 1) % 4]);
                    let (a0, b0) = ([a[0], 0.0, a[2]], [b[0], 0.0, b[2]]);
                    tris.push([a, b, b0]);
                    tris.push([a, b0, a0]);
                }
            }
        }
        let model = soup(dir, &format!("terrace{k}"), &tris);
        scenes.push(scene_file(dir, &format!("terrace{k}"), &model, [0.3, 0.8, 1.5][k]));
    }
    scenes
}

/// Harder soups for the edge-counting methods, from `seed`: duplicated triangles (some with
/// the winding reversed), non-manifold fans (three or four triangles on one edge),
/// T-junctions (strips of small triangles whose corners lie on a larger triangle's edge) and
/// closed boxes crossing each other, each under a light of its own size.
pub fn stress_soups(dir: &TempDir, seed: u64) -> Vec<PathBuf> {
    let mut rng = Rng::new(seed);
    let mut r = move || rng.next_f32();
    let mut scenes = Vec::new();
    for k in 0..4 {
        let scale = [0.05f32, 0.3, 0.6, 0.15][k];
        let mut tris: Vec<[[f32; 3]; 3]> = Vec::new();
        for _ in 0..150 {
            let c = [r() * 1.6 - 0.8, 0.1 + r() * 1.2, r() * 1.6 - 0.8];
            let jitter = |r: &mut dyn FnMut() -> f32| {
                [c[0] + (r() - 0.5) * scale, c[1] + (r() - 0.5) * scale, c[2] + (r() - 0.5) * scale]
            };
            let (a, b) = (jitter(&mut r), jitter(&mut r));
            match k {
                // Duplicates: the same triangle twice, or once each way round.
                0 => {
                    let t = [a, b, jitter(&mut r)];
                    tris.push(t);
                    tris.push(if r() < 0.5 { t } else { [t[1], t[0], t[2]] });
                }
                // Non-manifold fans: three or four triangles on edge a b.
                1 => {
                    for _ in 0..3 + (r() < 0.5) as usize {
                        tris.push([a, b, jitter(&mut r)]);
                    }
                }
                // T-junctions: a triangle a b c, and a strip of triangles on its edge a b
                // whose corners split that edge (not welded to a or b's edge).
                2 => {
                    let c2 = jitter(&mut r);
                    tris.push([a, b, c2]);
                    let d = jitter(&mut r);
                    let splits = 2 + (r() * 3.0) as usize;
                    let at = |t: f32| {
                        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])]
                    };
                    for s in 0..splits {
                        let (t0, t1) = (s as f32 / splits as f32, (s + 1) as f32 / splits as f32);
                        tris.push([at(t1), at(t0), d]);
                    }
                }
                // Closed boxes, crossing each other.
                _ => {
                    let h = 0.5 * scale;
                    let v = |x: f32, y: f32, z: f32| [c[0] + x * h, c[1] + y * h, c[2] + z * h];
                    let corners = [
                        v(-1.0, -1.0, -1.0),
                        v(1.0, -1.0, -1.0),
                        v(1.0, 1.0, -1.0),
                        v(-1.0, 1.0, -1.0),
                        v(-1.0, -1.0, 1.0),
                        v(1.0, -1.0, 1.0),
                        v(1.0, 1.0, 1.0),
                        v(-1.0, 1.0, 1.0),
                    ];
                    for q in
                        [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [2, 3, 7, 6], [1, 2, 6, 5], [0, 4, 7, 3]]
                    {
                        let [p0, p1, p2, p3] = q.map(|i| corners[i]);
                        tris.push([p0, p1, p2]);
                        tris.push([p0, p2, p3]);
                    }
                }
            }
        }
        let name = ["duplicates", "fans", "t_junctions", "boxes"][k];
        let model = soup(dir, name, &tris);
        scenes.push(scene_file(dir, name, &model, [0.3, 0.8, 1.2, 0.5][k]));
    }
    scenes
}

/// Meshes with smoothed normals (shading normals tilted up to ~40 degrees off the faces), so
/// that lights lie partly under a point's geometric tangent plane and above its shading
/// horizon: coarse spheres with radial normals and a bumpy heightfield with normals from
/// random slopes, from `seed`.
pub fn smooth_soups(dir: &TempDir, seed: u64) -> Vec<PathBuf> {
    let mut rng = Rng::new(seed);
    let mut r = move || rng.next_f32();
    let mut tris: Vec<[[f32; 3]; 3]> = Vec::new();
    let mut normals: Vec<[[f32; 3]; 3]> = Vec::new();
    // Coarse latitude-longitude spheres (8 x 6): vertices shared bit for bit between faces.
    for _ in 0..6 {
        let (c, rad) = ([r() * 1.4 - 0.7, 0.3 + r() * 0.8, r() * 1.4 - 0.7], 0.1 + r() * 0.25);
        let dir = |i: usize, j: usize| {
            let (th, ph) = (std::f32::consts::PI * j as f32 / 6.0, std::f32::consts::TAU * i as f32 / 8.0);
            [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()]
        };
        let at = |d: [f32; 3]| [c[0] + rad * d[0], c[1] + rad * d[1], c[2] + rad * d[2]];
        for i in 0..8 {
            for j in 0..6 {
                let q = [dir(i, j), dir(i + 1, j), dir(i + 1, j + 1), dir(i, j + 1)];
                for [a, b, d] in [[0, 1, 2], [0, 2, 3]] {
                    if (j == 0 && b == 1) || (j == 5 && d == 3 && a == 0 && b == 2) {
                        continue; // the poles' collapsed sides
                    }
                    tris.push([at(q[a]), at(q[b]), at(q[d])]);
                    normals.push([q[a], q[b], q[d]]);
                }
            }
        }
    }
    // A bumpy heightfield (12 x 12 cells) whose vertex normals lean by random slopes.
    let n = 12;
    let height: Vec<f32> = (0..(n + 1) * (n + 1)).map(|_| 0.05 + 0.25 * r()).collect();
    let lean: Vec<[f32; 3]> =
        (0..(n + 1) * (n + 1)).map(|_| [r() * 1.6 - 0.8, 1.0, r() * 1.6 - 0.8]).collect();
    let vertex = |i: usize, j: usize| {
        let k = i * (n + 1) + j;
        ([-0.9 + 1.8 * i as f32 / n as f32, height[k], -0.9 + 1.8 * j as f32 / n as f32], lean[k])
    };
    for i in 0..n {
        for j in 0..n {
            let q = [vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1)];
            for [a, b, d] in [[0, 2, 1], [0, 3, 2]] {
                tris.push([q[a].0, q[b].0, q[d].0]);
                normals.push([q[a].1, q[b].1, q[d].1]);
            }
        }
    }
    let mut g = GltfBuilder::default();
    let pos = g.positions(&tris.iter().flatten().copied().collect::<Vec<_>>());
    let nrm = g.normals(&normals.iter().flatten().copied().collect::<Vec<_>>());
    let material = g.material(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0]}, "doubleSided": true}),
    );
    let mesh = g.mesh(vec![json!({"attributes": {"POSITION": pos, "NORMAL": nrm}, "material": material})]);
    let node = g.node(json!({"mesh": mesh}));
    let scene = g.scene(&[node]);
    g.set_default_scene(scene);
    let model = g.write(&dir.path, "smooth");
    [0.4, 1.5]
        .iter()
        .enumerate()
        .map(|(k, &size)| scene_file(dir, &format!("smooth{k}"), &model, size))
        .collect()
}

/// The materials of [`alpha_soups`]: opaque; the banded texture (repeat, cutoff 0.5); the
/// same texture rotated, scaled and offset by KHR_texture_transform (mirrored repeat, cutoff
/// 0.4); glass as BLEND of alpha 0.3 (coverage: mixed, a hole or not point by point); a
/// constant alpha over the cutoff.
fn alpha_materials(g: &mut GltfBuilder) -> Vec<usize> {
    let repeat = g.texture_png_wrapped("bands.png", 10497, 10497);
    let mirrored = g.texture_png_wrapped("bands.png", 33648, 10497);
    g.use_extension("KHR_texture_transform");
    let transform =
        json!({"KHR_texture_transform": {"offset": [0.2, -0.1], "rotation": 0.3, "scale": [1.5, 0.8]}});
    [
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0]}, "doubleSided": true}),
        json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": repeat}}, "alphaMode": "MASK",
            "alphaCutoff": 0.5, "doubleSided": true}),
        json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": mirrored, "extensions": transform}},
            "alphaMode": "MASK", "alphaCutoff": 0.4, "doubleSided": true}),
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.15, 0.15, 0.15, 0.3]}, "alphaMode": "BLEND"}),
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.7, 0.8]}, "alphaMode": "MASK"}),
    ]
    .into_iter()
    .map(|m| g.material(m))
    .collect()
}

/// Positions and texture coordinates, three per triangle.
#[derive(Default, Clone)]
struct TexturedTriangles {
    positions: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
}

/// Four random soups of alpha-masked triangles (with opaque ones, sharing edges with each
/// other: folds across materials), each under a light of its own size, from `seed`. The
/// texture `bands.png` is clear over its left third, opaque over its right third and noise
/// between; each triangle's UVs cover a small random patch of it (wrapped), or now and then
/// a large one, so that the alpha classes are all met: opaque, clear and mixed.
pub fn alpha_soups(dir: &TempDir, seed: u64) -> Vec<PathBuf> {
    let mut rng = Rng::new(seed);
    let mut r = move || rng.next_f32();
    let noise: Vec<u8> = (0..64 * 64).map(|_| [0, 100, 255][(r() * 3.0) as usize]).collect();
    write_png_rgba(&dir.join("bands.png"), 64, 64, |x, y| {
        let alpha = if x < 21 {
            0
        } else if x >= 43 {
            255
        } else {
            noise[(y * 64 + x) as usize]
        };
        [200, 180, 90, alpha]
    });
    let mut scenes = Vec::new();
    for k in 0..4 {
        let scale = [0.05f32, 0.3, 0.6, 0.15][k];
        let mut parts = vec![TexturedTriangles::default(); 5]; // per material
        for _ in 0..300 {
            let c = [r() * 1.6 - 0.8, 0.1 + r() * 1.2, r() * 1.6 - 0.8];
            let mut jitter =
                || [c[0] + (r() - 0.5) * scale, c[1] + (r() - 0.5) * scale, c[2] + (r() - 0.5) * scale];
            let t = [jitter(), jitter(), jitter()];
            let d = jitter();
            for tri in [Some(t), (r() < 0.3).then_some([t[1], t[0], d])].into_iter().flatten() {
                let material = [0, 1, 1, 1, 2, 2, 3, 4][(r() * 8.0) as usize];
                let uv0 = [r() * 3.0 - 1.0, r() * 3.0 - 1.0];
                let extent = if r() < 0.1 { 0.8 } else { 0.06 * r() };
                let part = &mut parts[material];
                part.positions.extend(tri);
                part.uvs.extend([uv0, [uv0[0] + extent * r(), uv0[1]], [uv0[0], uv0[1] + extent * r()]]);
            }
        }
        let mut g = GltfBuilder::default();
        let materials = alpha_materials(&mut g);
        let primitives = parts
            .iter()
            .zip(materials)
            .filter(|(part, _)| !part.positions.is_empty())
            .map(|(part, material)| {
                let attributes =
                    [("POSITION", g.positions(&part.positions)), ("TEXCOORD_0", g.texcoords(&part.uvs))];
                primitive(&attributes, None, TRIANGLES, Some(material))
            })
            .collect();
        let mesh = g.mesh(primitives);
        let node = g.node(json!({"mesh": mesh}));
        let scene = g.scene(&[node]);
        g.set_default_scene(scene);
        let name = format!("alpha_soup{k}");
        let model = g.write(&dir.path, &name);
        scenes.push(scene_file(dir, &name, &model, [0.3, 0.8, 1.2, 0.5][k]));
    }
    scenes
}

/// Meshes placed by several nodes each, from `seed`: a coarse indexed hemisphere with radial
/// normals, placed as is, mirrored across its rim (the two close into a sphere whose seam
/// is another instance's boundary), rotated and scaled unevenly, and under a nested
/// parent; and a bumpy patch in two primitives that share their middle row (a seam inside
/// one mesh), placed twice, once mirrored. Each under a light of its own size.
pub fn instanced_soups(dir: &TempDir, seed: u64) -> Vec<PathBuf> {
    let mut rng = Rng::new(seed);
    let mut r = move || rng.next_f32();
    let mut g = GltfBuilder::default();
    let material = g.material(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0]}, "doubleSided": true}),
    );
    // The hemisphere: 10 around, 4 rings down to the rim at y = 0, a pole vertex on top.
    let (around, rings) = (10u16, 4u16);
    let mut positions = vec![[0.0f32, 1.0, 0.0]];
    for j in 1..=rings {
        let th = std::f32::consts::FRAC_PI_2 * j as f32 / rings as f32;
        for i in 0..around {
            let ph = std::f32::consts::TAU * i as f32 / around as f32;
            let y = if j == rings { 0.0 } else { th.cos() };
            positions.push([th.sin() * ph.cos(), y, th.sin() * ph.sin()]);
        }
    }
    let at = |j: u16, i: u16| if j == 0 { 0 } else { 1 + (j - 1) * around + i % around };
    let mut indices = Vec::new();
    for i in 0..around {
        indices.extend([at(0, 0), at(1, i + 1), at(1, i)]);
        for j in 1..rings {
            let (a, b, c, d) = (at(j, i), at(j, i + 1), at(j + 1, i + 1), at(j + 1, i));
            indices.extend([a, b, c, a, c, d]);
        }
    }
    let pos = g.positions(&positions);
    let nrm = g.normals(&positions);
    let idx = g.indices_u16(&indices);
    let dome =
        g.mesh(vec![primitive(&[("POSITION", pos), ("NORMAL", nrm)], Some(idx), TRIANGLES, Some(material))]);
    // The bumpy patch: a 6 x 6 grid, its two halves of rows primitives of their own.
    let n = 6u16;
    let grid: Vec<[f32; 3]> = (0..=n)
        .flat_map(|i| (0..=n).map(move |j| (i, j)))
        .map(|(i, j)| [i as f32 / n as f32 - 0.5, 0.0, j as f32 / n as f32 - 0.5])
        .map(|[x, _, z]| [x, 0.15 * r(), z])
        .collect();
    let gp = g.positions(&grid);
    let vertex = |i: u16, j: u16| i * (n + 1) + j;
    let half = |rows: std::ops::Range<u16>| {
        let mut idx = Vec::new();
        for i in rows {
            for j in 0..n {
                let (a, b, c, d) = (vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1));
                idx.extend([a, c, b, a, d, c]);
            }
        }
        idx
    };
    let (lo, hi) = (half(0..n / 2), half(n / 2..n));
    let (lo, hi) = (g.indices_u16(&lo), g.indices_u16(&hi));
    let patch = g.mesh(vec![
        primitive(&[("POSITION", gp)], Some(lo), TRIANGLES, Some(material)),
        primitive(&[("POSITION", gp)], Some(hi), TRIANGLES, Some(material)),
    ]);
    let s = 0.25 + 0.1 * r();
    let mut nodes = vec![
        g.node(json!({"mesh": dome, "translation": [-0.4, 0.5, 0.1], "scale": [s, s, s]})),
        g.node(json!({"mesh": dome, "translation": [-0.4, 0.5, 0.1], "scale": [s, -s, s]})),
        g.node(json!({"mesh": dome, "translation": [0.5, 0.3, -0.3], "scale": [0.3, 0.15, 0.2],
            "rotation": [0.2, 0.3, 0.1, 0.927]})),
        g.node(
            json!({"mesh": patch, "translation": [0.1, 0.9, 0.4], "rotation": [0.0, 0.0, 0.1305, 0.9914]}),
        ),
        g.node(json!({"mesh": patch, "translation": [0.2, 1.2, -0.2], "scale": [-0.8, 1.0, 0.8]})),
    ];
    let child = g.node(json!({"mesh": dome, "translation": [0.0, 2.0, 0.0], "scale": [0.6, 0.6, 0.6]}));
    nodes.push(
        g.node(json!({"children": [child], "translation": [0.4, -1.6, 0.5], "scale": [0.5, 0.5, 0.5]})),
    );
    let scene = g.scene(&nodes);
    g.set_default_scene(scene);
    let model = g.write(&dir.path, "instanced");
    [0.3, 1.2]
        .iter()
        .enumerate()
        .map(|(k, &size)| scene_file(dir, &format!("instanced{k}"), &model, size))
        .collect()
}
