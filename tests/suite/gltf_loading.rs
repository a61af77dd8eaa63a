//! glTF loading, end to end through `SceneFile::parse` + `Scene::load`, on files generated
//! here at run time (no third-party assets): node hierarchies (TRS, matrices, mirroring),
//! primitive modes, the alpha test in traced shadows, errors, glTF cameras and emissive
//! rectangles as lights.
//!
//! Expected values are computed independently in f64 from the numbers written into the
//! files; the loader's own code is never called for them.

use crate::common;

use common::gltf_writer::{
    GltfBuilder, TRIANGLE_FAN, TRIANGLE_STRIP, TRIANGLES, TempDir, primitive, write_json, write_png_rgba,
};
use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};
use renderer::{
    LightShadowing, PrepareContext, Scene, SceneError, SceneFile, ShadingPoint, ShadowQuery, Traced,
    TracedParams,
};
use serde_json::json;
use std::path::Path;

// ---------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------

/// Parses `toml` as `<dir>/scene.toml` (also written there, for debugging) and loads it.
fn load_scene(dir: &TempDir, toml: &str) -> Result<Scene, SceneError> {
    let scene_path = dir.join("scene.toml");
    std::fs::write(&scene_path, toml).expect("write the scene file");
    let file = SceneFile::parse(toml, &scene_path)?;
    Scene::load(&file, &scene_path)
}

/// A unit quaternion from an axis (any length) and an angle in degrees.
fn quat(axis: [f64; 3], deg: f64) -> DQuat {
    DQuat::from_axis_angle(DVec3::from(axis).normalize(), deg.to_radians())
}

/// A quaternion as glTF writes it: [x, y, z, w].
fn quat_json(q: DQuat) -> [f64; 4] {
    [q.x, q.y, q.z, q.w]
}

/// glTF TRS: T * R * S.
fn trs(t: [f64; 3], r: DQuat, s: [f64; 3]) -> DMat4 {
    DMat4::from_translation(DVec3::from(t)) * DMat4::from_quat(r) * DMat4::from_scale(DVec3::from(s))
}

/// The scene file's model transform: p' = translate + R_y(rotate_y_deg) * (scale * p).
fn model_matrix(translate: [f64; 3], scale: f64, rotate_y_deg: f64) -> DMat4 {
    DMat4::from_translation(DVec3::from(translate))
        * DMat4::from_rotation_y(rotate_y_deg.to_radians())
        * DMat4::from_scale(DVec3::splat(scale))
}

/// A normal transformed by `m`, computed from two tangents (n' ~ M t1 x M t2, which is
/// cofactor(M) n = det(M) M^-T n), so that it does not share the loader's formula.
fn transform_normal(m: &DMat4, n: DVec3) -> DVec3 {
    let n = n.normalize();
    let t1 = n.any_orthonormal_vector();
    let t2 = n.cross(t1); // t1 x t2 = n
    let m3 = DMat3::from_mat4(*m);
    ((m3 * t1).cross(m3 * t2) * m3.determinant().signum()).normalize()
}

/// The loaded triangles in world space (render space + world_offset), in BVH order.
fn world_triangles(scene: &Scene) -> Vec<[DVec3; 3]> {
    scene.triangles.iter().map(|t| [t.v0, t.v1, t.v2].map(|v| v.as_dvec3() + scene.world_offset)).collect()
}

fn face_normal(p: &[DVec3; 3]) -> DVec3 {
    (p[1] - p[0]).cross(p[2] - p[0]).normalize()
}

/// Diagonal of the bounding box of some points.
fn diagonal<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> f64 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for p in points {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (hi - lo).length()
}

/// For each expected triangle (a vertex set), the loaded triangle with the same vertices
/// within `tol` and, per loaded corner k, the expected corner it matches. Each loaded
/// triangle is used once. Panics with a description of the first mismatch.
fn match_triangles(loaded: &[[DVec3; 3]], expected: &[[DVec3; 3]], tol: f64) -> Vec<(usize, [usize; 3])> {
    assert_eq!(loaded.len(), expected.len(), "triangle count");
    let mut used = vec![false; loaded.len()];
    let mut out = Vec::new();
    for (e_i, e) in expected.iter().enumerate() {
        let found = loaded.iter().enumerate().find_map(|(i, l)| {
            if used[i] {
                return None;
            }
            let mut perm = [usize::MAX; 3];
            for k in 0..3 {
                let j = (0..3).find(|&j| !perm.contains(&j) && (l[k] - e[j]).length() <= tol)?;
                perm[k] = j;
            }
            Some((i, perm))
        });
        let Some((i, perm)) = found else {
            let nearest = loaded
                .iter()
                .map(|l| (0..3).map(|k| (l[k] - e[k]).length()).fold(0.0, f64::max))
                .fold(f64::INFINITY, f64::min);
            panic!("expected triangle {e_i} {e:?} not loaded (tol {tol:e}; nearest corner-wise {nearest:e})");
        };
        used[i] = true;
        out.push((i, perm));
    }
    out
}

fn vec3_toml(v: [f64; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])
}

/// Runs `f`, turning a panic into a test failure that names `case`.
fn no_panic<T>(case: &str, f: impl FnOnce() -> T) -> T {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(v) => v,
        Err(e) => {
            let msg = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            panic!("{case}: the loader panicked instead of returning an error: {msg}");
        }
    }
}

/// Asserts that `err` is a one-line message naming `gltf` (and, when given, containing `key`).
fn assert_gltf_error(case: &str, err: &SceneError, gltf: &Path, key: Option<&str>) {
    let text = err.to_string();
    assert_eq!(text.lines().count(), 1, "{case}: not one line: {text:?}");
    assert!(!text.contains('\r'), "{case}: not one line: {text:?}");
    assert!(text.contains(&gltf.display().to_string()), "{case}: does not name {}: {text}", gltf.display());
    assert_eq!(err.file, gltf, "{case}: {text}");
    if let Some(key) = key {
        assert!(text.contains(key), "{case}: does not contain {key:?}: {text}");
    }
}

const CAMERA_AND_LIGHT: &str = r#"
[camera]
position = [20.0, 6.0, 18.0]
look_at = [0.0, 0.0, 0.0]

[[light]]
center = [0.0, 15.0, 0.0]
u = [1.0, 0.0, 0.0]
v = [0.0, 0.0, 1.0]
radiance = [1.0, 1.0, 1.0]
"#;

/// Triangle-list mesh data as written into a file.
struct MeshData {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    /// Triangle list; written as u16, u32 or not at all (see `IndexKind`).
    indices: Vec<u32>,
    index_kind: IndexKind,
}

#[derive(Clone, Copy)]
enum IndexKind {
    None,
    U16,
    U32,
}

impl MeshData {
    fn add_to(&self, b: &mut GltfBuilder) -> usize {
        let pos = b.positions(&self.positions);
        let mut attrs = vec![("POSITION", pos)];
        if let Some(n) = &self.normals {
            attrs.push(("NORMAL", b.normals(n)));
        }
        let indices = match self.index_kind {
            IndexKind::None => {
                assert_eq!(self.indices, (0..self.positions.len() as u32).collect::<Vec<_>>());
                None
            }
            IndexKind::U16 => {
                Some(b.indices_u16(&self.indices.iter().map(|&i| i as u16).collect::<Vec<_>>()))
            }
            IndexKind::U32 => Some(b.indices_u32(&self.indices)),
        };
        b.mesh(vec![primitive(&attrs, indices, TRIANGLES, None)])
    }

    /// Expected world triangles (corners, per-corner shading normals, front-face normal)
    /// under the world transform `w`.
    fn expected(&self, w: &DMat4) -> Vec<([DVec3; 3], [DVec3; 3], DVec3)> {
        let det = DMat3::from_mat4(*w).determinant();
        self.indices
            .chunks_exact(3)
            .map(|c| {
                let local = [0, 1, 2].map(|k| DVec3::from(self.positions[c[k] as usize].map(f64::from)));
                let p = local.map(|q| w.transform_point3(q));
                // glTF: a negative determinant makes the transformed triangle clockwise
                // when seen from its front.
                let front = (p[1] - p[0]).cross(p[2] - p[0]).normalize() * det.signum();
                let n = match &self.normals {
                    Some(ns) => {
                        [0, 1, 2].map(|k| transform_normal(w, DVec3::from(ns[c[k] as usize].map(f64::from))))
                    }
                    None => [front; 3],
                };
                (p, n, front)
            })
            .collect()
    }
}

// ---------------------------------------------------------------------------------------
// 1. Node hierarchy
// ---------------------------------------------------------------------------------------

#[test]
fn node_hierarchy_transforms_positions_and_normals() {
    let dir = TempDir::new("node_hierarchy");

    // Mesh 0: one triangle, no indices, tilted vertex normals (front = +Z).
    let tri = MeshData {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        normals: Some(vec![[0.3, 0.2, 1.0], [-0.2, 0.1, 1.0], [0.1, -0.3, 1.0]]),
        indices: vec![0, 1, 2],
        index_kind: IndexKind::None,
    };
    // Mesh 1: a quad in the XZ plane facing +Y, u16 indices, tilted vertex normals.
    let quad = MeshData {
        positions: vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
        normals: Some(vec![[0.2, 1.0, 0.1], [-0.1, 1.0, 0.3], [0.0, 1.0, -0.2], [0.25, 1.0, 0.0]]),
        indices: vec![0, 1, 2, 0, 2, 3],
        index_kind: IndexKind::U16,
    };
    // Mesh 2: a triangle with u32 indices and no normals (the face normal is used).
    let bare = MeshData {
        positions: vec![[0.5, 0.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, -1.0], [0.0, 0.0, -1.0]],
        normals: None,
        indices: vec![1, 0, 3],
        index_kind: IndexKind::U32,
    };

    let mut b = GltfBuilder::new();
    let m_tri = tri.add_to(&mut b);
    let m_quad = quad.add_to(&mut b);
    let m_bare = bare.add_to(&mut b);

    // Root: TRS with a non-uniform scale.
    let (root_t, root_r, root_s) = ([1.0, 2.0, 3.0], quat([1.0, 1.0, 0.0], 40.0), [1.5, 0.5, 2.0]);
    // Child: a column-major matrix = translate(0.25, -1, 2) * rot_z(90 deg) * scale(2, 0.5, 1.5),
    // written out by hand (columns: R*(2,0,0), R*(0,0.5,0), (0,0,1.5), translation).
    let child_matrix: [f64; 16] =
        [0.0, 2.0, 0.0, 0.0, -0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 1.5, 0.0, 0.25, -1.0, 2.0, 1.0];
    // Grandchild: TRS again.
    let (gc_t, gc_r, gc_s) = ([-1.0, 0.0, 0.5], quat([0.2, 1.0, 0.3], 70.0), [0.7, 1.3, 0.9]);
    // A second root, mirrored (negative x scale), with a child that inherits the mirror.
    let (mir_t, mir_r, mir_s) = ([0.0, 0.0, -2.0], quat([0.0, 0.0, 1.0], 15.0), [-1.0, 1.0, 1.2]);
    let (mc_t, mc_r, mc_s) = ([0.5, 1.0, 0.0], quat([0.0, 1.0, 0.0], -30.0), [1.0, 2.0, 1.0]);

    let grandchild = b.node(json!({
        "translation": gc_t, "rotation": quat_json(gc_r), "scale": gc_s, "mesh": m_bare,
    }));
    let child = b.node(json!({"matrix": child_matrix, "mesh": m_quad, "children": [grandchild]}));
    let root = b.node(json!({
        "translation": root_t, "rotation": quat_json(root_r), "scale": root_s,
        "mesh": m_tri, "children": [child],
    }));
    let mirror_child = b.node(json!({
        "translation": mc_t, "rotation": quat_json(mc_r), "scale": mc_s, "mesh": m_quad,
    }));
    let mirror = b.node(json!({
        "translation": mir_t, "rotation": quat_json(mir_r), "scale": mir_s,
        "mesh": m_tri, "children": [mirror_child],
    }));
    // A node only in a second, non-default scene: must not be loaded.
    let elsewhere = b.node(json!({"translation": [50.0, 0.0, 0.0], "mesh": m_quad}));
    let default_scene = b.scene(&[root, mirror]);
    b.scene(&[elsewhere]);
    b.set_default_scene(default_scene);
    b.write(&dir.path, "hierarchy");

    let (translate, scale, rotate_y_deg) = ([10.0, -3.0, 5.0], 1.7, 33.0);
    let toml = format!(
        "[[model]]\npath = \"hierarchy.gltf\"\ntranslate = {}\nscale = {scale:?}\nrotate_y_deg = {rotate_y_deg:?}\n{CAMERA_AND_LIGHT}",
        vec3_toml(translate)
    );
    let scene = load_scene(&dir, &toml).unwrap_or_else(|e| panic!("{e}"));

    // Expected world transforms: model * root * child * ... (f64, glam, from the file's numbers).
    let model = model_matrix(translate, scale, rotate_y_deg);
    let w_root = model * trs(root_t, root_r, root_s);
    let w_child = w_root * DMat4::from_cols_array(&child_matrix);
    let w_gc = w_child * trs(gc_t, gc_r, gc_s);
    let w_mirror = model * trs(mir_t, mir_r, mir_s);
    let w_mirror_child = w_mirror * trs(mc_t, mc_r, mc_s);
    assert!(
        DMat3::from_mat4(w_mirror).determinant() < 0.0
            && DMat3::from_mat4(w_mirror_child).determinant() < 0.0
    );

    let mut expected = Vec::new();
    for (mesh, w) in
        [(&tri, w_root), (&quad, w_child), (&bare, w_gc), (&tri, w_mirror), (&quad, w_mirror_child)]
    {
        expected.extend(mesh.expected(&w));
    }
    assert_eq!(expected.len(), 1 + 2 + 1 + 1 + 2);
    let expected_p: Vec<[DVec3; 3]> = expected.iter().map(|e| e.0).collect();
    let size = diagonal(expected_p.iter().flatten());
    let tol = 1e-5 * size;

    let loaded = world_triangles(&scene);
    let matches = match_triangles(&loaded, &expected_p, tol);
    for (e_i, (i, perm)) in matches.iter().enumerate() {
        let (_, n_expected, front) = &expected[e_i];
        // Front face kept (also under mirroring): within 1e-4 (a unit vector from f32 corners).
        let face = face_normal(&loaded[*i]);
        assert!(
            (face - *front).length() < 1e-4,
            "triangle {e_i}: loaded face normal {face} vs expected front {front}"
        );
        // Vertex normals: the inverse-transpose transformed, normalised file normals (1e-5).
        for k in 0..3 {
            let n = scene.shading[*i].n[k].as_dvec3();
            let want = n_expected[perm[k]];
            assert!((n - want).length() < 1e-5, "triangle {e_i} corner {k}: normal {n} vs expected {want}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// 2. Primitive modes
// ---------------------------------------------------------------------------------------

#[test]
fn triangle_strips_and_fans_indexed_and_not() {
    let dir = TempDir::new("primitive_modes");

    // A zigzag strip in the XZ plane whose first triangle is CCW seen from +Y.
    let strip: Vec<[f32; 3]> = vec![
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [2.0, 0.0, 0.0],
        [2.0, 0.0, 1.0],
    ];
    // A fan around the origin, CCW seen from +Y.
    let fan: Vec<[f32; 3]> = vec![
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, -1.0],
        [0.0, 0.0, -1.0],
    ];
    let shift =
        |v: &[[f32; 3]], dz: f32| -> Vec<[f32; 3]> { v.iter().map(|p| [p[0], p[1], p[2] + dz]).collect() };
    // Indexed variants: the same vertex sequence through a shuffled vertex array (with one
    // unreferenced vertex) and an index list.
    let order = [3usize, 0, 5, 1, 4, 2];
    let shuffled = |v: &[[f32; 3]]| -> (Vec<[f32; 3]>, Vec<u32>) {
        let mut verts: Vec<[f32; 3]> = order.iter().map(|&i| v[i]).collect();
        verts.push([9.0, 9.0, 9.0]); // unused
        let idx = (0..v.len()).map(|i| order.iter().position(|&o| o == i).unwrap() as u32).collect();
        (verts, idx)
    };

    let mut b = GltfBuilder::new();
    let mut prims = Vec::new();
    // (vertex sequence as drawn, mode) for each primitive, for the expectations.
    let mut drawn: Vec<(Vec<[f32; 3]>, u32)> = Vec::new();

    let s0 = shift(&strip, 0.0);
    prims.push(primitive(&[("POSITION", b.positions(&s0))], None, TRIANGLE_STRIP, None));
    drawn.push((s0, TRIANGLE_STRIP));

    let s1 = shift(&strip, 3.0);
    let (v, idx) = shuffled(&s1);
    let (pos, ind) = (b.positions(&v), b.indices_u16(&idx.iter().map(|&i| i as u16).collect::<Vec<_>>()));
    prims.push(primitive(&[("POSITION", pos)], Some(ind), TRIANGLE_STRIP, None));
    drawn.push((s1, TRIANGLE_STRIP));

    let f0 = shift(&fan, 7.0);
    prims.push(primitive(&[("POSITION", b.positions(&f0))], None, TRIANGLE_FAN, None));
    drawn.push((f0, TRIANGLE_FAN));

    let f1 = shift(&fan, 11.0);
    let (v, idx) = shuffled(&f1);
    let (pos, ind) = (b.positions(&v), b.indices_u32(&idx));
    prims.push(primitive(&[("POSITION", pos)], Some(ind), TRIANGLE_FAN, None));
    drawn.push((f1, TRIANGLE_FAN));

    // A LINES primitive (mode 1): no area, no triangles.
    let lines = shift(&strip, 20.0);
    prims.push(primitive(&[("POSITION", b.positions(&lines))], None, 1, None));

    let mesh = b.mesh(prims);
    let node = b.node(json!({"mesh": mesh}));
    let s = b.scene(&[node]);
    b.set_default_scene(s);
    b.write(&dir.path, "modes");

    let scene = load_scene(&dir, &format!("[[model]]\npath = \"modes.gltf\"\n{CAMERA_AND_LIGHT}"))
        .unwrap_or_else(|e| panic!("{e}"));

    // Expected per the glTF 2.0 spec (primitive topologies): strip p_i = {v_i, v_(i+1+i%2), v_(i+2-i%2)};
    // fan p_i = {v_(i+1), v_(i+2), v_0}.
    let mut expected = Vec::new();
    for (v, mode) in &drawn {
        let v: Vec<DVec3> = v.iter().map(|p| DVec3::from(p.map(f64::from))).collect();
        for i in 0..v.len() - 2 {
            expected.push(if *mode == TRIANGLE_STRIP {
                [v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]]
            } else {
                [v[i + 1], v[i + 2], v[0]]
            });
        }
    }
    assert_eq!(expected.len(), 4 * 4);
    for e in &expected {
        assert!(face_normal(e).y > 0.999, "fixture: every expected triangle faces +Y");
    }
    let loaded = world_triangles(&scene);
    assert_eq!(loaded.len(), 16, "4 primitives x 4 triangles (the LINES primitive adds none)");
    let tol = 1e-5 * diagonal(expected.iter().flatten());
    match_triangles(&loaded, &expected, tol);
    // Winding: every loaded triangle keeps the front face (+Y), odd strip triangles included.
    for (i, t) in loaded.iter().enumerate() {
        let n = face_normal(t);
        assert!((n - DVec3::Y).length() < 1e-5, "loaded triangle {i} faces {n}, not +Y");
    }
}

// ---------------------------------------------------------------------------------------
// 3. Alpha mask in traced shadows
// ---------------------------------------------------------------------------------------

/// Writes the card glTF (a 2x2 quad at height `h`, UVs u = (x+1)/2, v = (z+1)/2) with the
/// given alpha mode and a texture transparent for u < 0.5.
fn write_card(dir: &TempDir, stem: &str, alpha_mode: &str, h: f32) {
    write_png_rgba(
        &dir.join("half_alpha.png"),
        64,
        64,
        |x, _| if x < 32 { [255, 255, 255, 0] } else { [255; 4] },
    );
    let mut b = GltfBuilder::new();
    let pos = b.positions(&[[-1.0, h, -1.0], [1.0, h, -1.0], [1.0, h, 1.0], [-1.0, h, 1.0]]);
    let uv = b.texcoords(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    let ind = b.indices_u16(&[0, 2, 1, 0, 3, 2]);
    let tex = b.texture_png("half_alpha.png");
    let mut material = json!({
        "pbrMetallicRoughness": {"baseColorTexture": {"index": tex}},
        "alphaMode": alpha_mode,
        "doubleSided": true,
    });
    if alpha_mode == "MASK" {
        material["alphaCutoff"] = json!(0.5);
    }
    let mat = b.material(material);
    let mesh =
        b.mesh(vec![primitive(&[("POSITION", pos), ("TEXCOORD_0", uv)], Some(ind), TRIANGLES, Some(mat))]);
    let node = b.node(json!({"mesh": mesh}));
    let s = b.scene(&[node]);
    b.set_default_scene(s);
    b.write(&dir.path, stem);
}

/// The user's report: textures were always filtered bilinearly, so a sampler asking for
/// `NEAREST` (pixel art, masks, lookup textures) was not honoured, in colours or alpha tests.
/// A 4 x 1 texture of alpha 255, 0, 0, 0 under an alpha cutoff of 0.2: at u = 0.3 (texel 1,
/// 0.2 of a texel past the centre of texel 0's edge) the nearest texel is clear, a bilinear
/// lookup reads 255 x 0.3 = 76.5 >= 51: opaque. `magFilter` decides; without it, a nearest
/// `minFilter`; without either, linear.
#[test]
fn a_nearest_sampler_is_honoured_by_the_alpha_test() {
    let dir = TempDir::new("nearest_sampler");
    write_png_rgba(&dir.join("stripe.png"), 4, 1, |x, _| if x == 0 { [255; 4] } else { [255, 255, 255, 0] });
    let cases = [
        (json!({"magFilter": 9728}), true),
        (json!({"magFilter": 9729, "minFilter": 9728}), false),
        (json!({"minFilter": 9986}), true),
        (json!({}), false),
    ];
    for (i, (sampler, nearest)) in cases.into_iter().enumerate() {
        let mut b = GltfBuilder::new();
        let pos = b.positions(&[[-1.0, 1.0, -1.0], [1.0, 1.0, -1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0]]);
        let uv = b.texcoords(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        let ind = b.indices_u16(&[0, 2, 1, 0, 3, 2]);
        let tex = b.texture_png_sampled("stripe.png", sampler.clone());
        let mat = b.material(json!({
            "pbrMetallicRoughness": {"baseColorTexture": {"index": tex}},
            "alphaMode": "MASK",
            "alphaCutoff": 0.2,
        }));
        let mesh = b.mesh(vec![primitive(
            &[("POSITION", pos), ("TEXCOORD_0", uv)],
            Some(ind),
            TRIANGLES,
            Some(mat),
        )]);
        let node = b.node(json!({"mesh": mesh}));
        let s = b.scene(&[node]);
        b.set_default_scene(s);
        let stem = format!("card{i}");
        b.write(&dir.path, &stem);
        let toml = format!(
            "[[model]]\npath = \"{stem}.gltf\"\n[camera]\nposition = [0.0, 5.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n\
             [[light]]\ncenter = [0.0, 3.0, 0.0]\nu = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 0.5]\nradiance = [1.0, 1.0, 1.0]\n"
        );
        let scene = load_scene(&dir, &toml).expect("loads");
        let m = scene.materials.iter().find(|m| m.base_color_texture.is_some()).expect("the card's material");
        let cut = |u: f32| m.is_cutout(glam::Vec2::new(u, 0.5), &scene.textures, || unreachable!("MASK"));
        assert_eq!(cut(0.3), nearest, "sampler {sampler}: u = 0.3");
        // Inside texel 0 and deep in texel 2 both filters agree.
        assert!(!cut(0.1) && cut(0.6), "sampler {sampler}");
    }
}

/// Traced visibility (64 samples) of the scene's first light at floor points (world, y = 0,
/// normal +Y).
fn floor_visibility(scene: &Scene, points: &[DVec3]) -> Vec<f32> {
    let mut traced = Traced::new(TracedParams::PLAIN, 64);
    traced.prepare(&PrepareContext::for_light(scene, 0)).expect("prepare");
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let p = (*p - scene.world_offset).as_vec3();
            let q = ShadowQuery {
                point: ShadingPoint {
                    p,
                    p_error: renderer::geometry::ray_origin::point_error(p),
                    n_geom: Vec3::Y,
                    n_shading: Vec3::Y,
                },
                pixel: [0, 0],
                seed: 0x9e37_79b9 + i as u64,
                irradiance: 0.0,
            };
            traced.visibility(scene, &q)
        })
        .collect()
}

#[test]
fn alpha_mask_cuts_holes_in_traced_shadows() {
    let dir = TempDir::new("alpha_mask");
    let h = 1.0f64; // card height
    let big_h = 20.0f64; // light height
    let light_half = 0.025f64; // the light is 0.05 x 0.05
    write_card(&dir, "card_mask", "MASK", h as f32);
    write_card(&dir, "card_opaque", "OPAQUE", h as f32);
    let toml = |stem: &str| {
        format!(
            r#"
[[model]]
path = "{stem}.gltf"

[[quad]]
center = [0.0, 0.0, 0.0]
u = [8.0, 0.0, 0.0]
v = [0.0, 0.0, -8.0]

[camera]
position = [0.0, 6.0, 8.0]
look_at = [0.0, 0.0, 0.0]

[[light]]
center = [0.0, {big_h:?}, 0.0]
u = [{w:?}, 0.0, 0.0]
v = [0.0, 0.0, {w:?}]
radiance = [1.0, 1.0, 1.0]
"#,
            w = 2.0 * light_half
        )
    };

    // A card edge at x_e (height h) casts its shadow edge on the floor around
    // x_e * H / (H - h), blurred over +-light_half * h / (H - h) by the light's extent. The
    // alpha edge (u = 0.5, x = 0) is additionally blurred by bilinear filtering over one
    // texel each side: |x| <= 1/64 on the card.
    let project = |x: f64| x * big_h / (big_h - h);
    let penumbra = light_half * h / (big_h - h);
    let texel_blur = project(1.0 / 64.0);
    let edges = [project(-1.0), project(0.0), project(1.0)]; // x of the shadow edges (and z = +-project(1))
    let opaque_side = [DVec3::new(project(0.5), 0.0, 0.0), DVec3::new(project(0.4), 0.0, project(0.5))];
    let clear_side = [DVec3::new(project(-0.5), 0.0, 0.0), DVec3::new(project(-0.6), 0.0, project(-0.4))];
    let outside = [DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -2.5)];
    for p in opaque_side.iter().chain(&clear_side) {
        let margin = edges
            .iter()
            .map(|e| (p.x - e).abs())
            .chain([(p.z - project(1.0)).abs(), (p.z + project(1.0)).abs()])
            .fold(f64::INFINITY, f64::min);
        assert!(
            margin > 10.0 * (penumbra + texel_blur),
            "test point {p} is {margin} from a shadow edge; penumbra {penumbra}, texel blur {texel_blur}"
        );
    }
    for p in &outside {
        assert!(p.x.abs() > project(1.0) + 10.0 * penumbra || p.z.abs() > project(1.0) + 10.0 * penumbra);
    }

    let mask = load_scene(&dir, &toml("card_mask")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(mask.triangles.len(), 4);
    let all: Vec<DVec3> = opaque_side.iter().chain(&clear_side).chain(&outside).copied().collect();
    let v = floor_visibility(&mask, &all);
    let (v_opaque, rest) = v.split_at(opaque_side.len());
    let (v_clear, v_out) = rest.split_at(clear_side.len());
    for (p, v) in opaque_side.iter().zip(v_opaque) {
        assert!(*v < 0.05, "MASK: below the opaque half at {p}: V = {v}, want < 0.05");
    }
    for (p, v) in clear_side.iter().zip(v_clear) {
        assert!(*v > 0.95, "MASK: below the transparent half at {p}: V = {v}, want > 0.95");
    }
    for (p, v) in outside.iter().zip(v_out) {
        assert!(*v > 0.95, "MASK: outside the card's shadow at {p}: V = {v}, want > 0.95");
    }

    // Control: the same card, OPAQUE, shadows both halves.
    let opaque = load_scene(&dir, &toml("card_opaque")).unwrap_or_else(|e| panic!("{e}"));
    let v = floor_visibility(&opaque, &all);
    for (p, v) in opaque_side.iter().chain(&clear_side).zip(&v) {
        assert!(*v < 0.05, "OPAQUE: below the card at {p}: V = {v}, want < 0.05");
    }
    for (p, v) in outside.iter().zip(&v[opaque_side.len() + clear_side.len()..]) {
        assert!(*v > 0.95, "OPAQUE: outside the card's shadow at {p}: V = {v}, want > 0.95");
    }
}

// ---------------------------------------------------------------------------------------
// 4. and 5. Errors
// ---------------------------------------------------------------------------------------

/// A file with one triangle-list primitive (optionally u16-indexed); returns the .gltf path.
fn single_triangle(
    dir: &TempDir,
    stem: &str,
    positions: &[[f32; 3]],
    indices: Option<&[u16]>,
) -> std::path::PathBuf {
    let mut b = GltfBuilder::new();
    let pos = b.positions(positions);
    let ind = indices.map(|i| b.indices_u16(i));
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], ind, TRIANGLES, None)]);
    let node = b.node(json!({"mesh": mesh}));
    let s = b.scene(&[node]);
    b.set_default_scene(s);
    b.write(&dir.path, stem)
}

fn model_toml(stem: &str) -> String {
    format!("[[model]]\npath = \"{stem}.gltf\"\n{CAMERA_AND_LIGHT}")
}

#[test]
fn nan_position_is_an_error_naming_the_accessor() {
    let dir = TempDir::new("nan_position");
    let gltf = single_triangle(&dir, "nan", &[[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]], None);
    let err = no_panic("NaN position", || load_scene(&dir, &model_toml("nan")))
        .err()
        .expect("a NaN vertex must be rejected");
    assert_gltf_error("NaN position", &err, &gltf, Some("attributes.POSITION"));
}

#[test]
fn broken_files_are_errors_not_panics() {
    let dir = TempDir::new("broken_files");
    let good = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    // Truncated JSON.
    let gltf = single_triangle(&dir, "truncated", &good, None);
    let text = std::fs::read_to_string(&gltf).unwrap();
    std::fs::write(&gltf, &text[..text.len() / 2]).unwrap();
    let err = no_panic("truncated JSON", || load_scene(&dir, &model_toml("truncated")))
        .err()
        .expect("truncated JSON must be rejected");
    assert_gltf_error("truncated JSON", &err, &gltf, None);

    // An index past the last vertex.
    let gltf = single_triangle(&dir, "bad_index", &good, Some(&[0, 1, 7]));
    let err = no_panic("index out of range", || load_scene(&dir, &model_toml("bad_index")))
        .err()
        .expect("an out-of-range index must be rejected");
    assert_gltf_error("index out of range", &err, &gltf, Some("indices"));

    // Attribute accessors shorter than POSITION (the spec requires equal counts): NORMAL
    // and TEXCOORD_0 with 2 elements for 3 vertices.
    for (case, semantic) in [("short NORMAL", "NORMAL"), ("short TEXCOORD_0", "TEXCOORD_0")] {
        let stem = format!("short_{semantic}");
        let mut b = GltfBuilder::new();
        let pos = b.positions(&good);
        let attr = if semantic == "NORMAL" {
            b.normals(&[[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
        } else {
            b.texcoords(&[[0.0, 0.0], [1.0, 0.0]])
        };
        let mut mat = json!({});
        if semantic == "TEXCOORD_0" {
            write_png_rgba(&dir.join("white.png"), 2, 2, |_, _| [255; 4]);
            let tex = b.texture_png("white.png");
            mat = json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": tex}}});
        }
        let mat = b.material(mat);
        let mesh =
            b.mesh(vec![primitive(&[("POSITION", pos), (semantic, attr)], None, TRIANGLES, Some(mat))]);
        let node = b.node(json!({"mesh": mesh}));
        let s = b.scene(&[node]);
        b.set_default_scene(s);
        let gltf = b.write(&dir.path, &stem);
        let err = no_panic(case, || load_scene(&dir, &model_toml(&stem))).err().unwrap_or_else(|| {
            panic!("{case}: an attribute with fewer elements than POSITION must be rejected")
        });
        assert_gltf_error(case, &err, &gltf, Some(semantic));
    }

    // A buffer file that does not exist.
    let gltf = single_triangle(&dir, "no_bin", &good, None);
    std::fs::remove_file(dir.join("no_bin.bin")).unwrap();
    let err = no_panic("missing .bin", || load_scene(&dir, &model_toml("no_bin")))
        .err()
        .expect("a missing buffer must be rejected");
    assert_gltf_error("missing .bin", &err, &gltf, None);

    // Edits of an otherwise valid, indexed file (accessor 0 = POSITION, 1 = indices), each
    // with the key its error must name.
    type Edit = fn(&mut serde_json::Value);
    let edits: [(&str, Edit, &str); 12] = [
        (
            "POSITION without a bufferView",
            |d| {
                d["accessors"][0].as_object_mut().unwrap().remove("bufferView");
            },
            "accessors[0].bufferView",
        ),
        ("POSITION past its buffer view", |d| d["accessors"][0]["count"] = json!(30), "attributes.POSITION"),
        ("empty POSITION accessor", |d| d["accessors"][0]["count"] = json!(0), "attributes.POSITION"),
        ("empty index accessor", |d| d["accessors"][1]["count"] = json!(0), "indices"),
        ("float indices", |d| d["accessors"][1]["componentType"] = json!(5126), "indices"),
        ("VEC2 indices", |d| d["accessors"][1]["type"] = json!("VEC2"), "indices"),
        ("u16 POSITION", |d| d["accessors"][0]["componentType"] = json!(5123), "attributes.POSITION"),
        ("VEC2 POSITION", |d| d["accessors"][0]["type"] = json!("VEC2"), "attributes.POSITION"),
        (
            "sparse POSITION with count 0",
            |d| {
                d["accessors"][0]["sparse"] = json!({
                    "count": 0,
                    "indices": {"bufferView": 1, "componentType": 5123},
                    "values": {"bufferView": 0},
                })
            },
            "attributes.POSITION",
        ),
        (
            "buffer view past the buffer",
            |d| d["bufferViews"][0]["byteLength"] = json!(4000),
            "attributes.POSITION",
        ),
        ("buffer longer than its file", |d| d["buffers"][0]["byteLength"] = json!(4000), "buffers"),
        ("node index out of range", |d| d["scenes"][0]["nodes"] = json!([5]), "scenes[0].nodes[0]"),
    ];
    for (i, (case, edit, key)) in edits.iter().enumerate() {
        let stem = format!("edit{i}");
        let gltf = single_triangle(&dir, &stem, &good, Some(&[0, 1, 2]));
        let mut doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&gltf).unwrap()).unwrap();
        edit(&mut doc);
        write_json(&gltf, &doc);
        let err = no_panic(case, || load_scene(&dir, &model_toml(&stem)))
            .err()
            .unwrap_or_else(|| panic!("{case}: must be rejected"));
        assert_gltf_error(case, &err, &gltf, Some(key));
    }
}

// ---------------------------------------------------------------------------------------
// 6. glTF camera
// ---------------------------------------------------------------------------------------

#[test]
fn camera_from_gltf_follows_the_node_transform() {
    let dir = TempDir::new("gltf_camera");
    let yfov = 0.8f64;
    let mut b = GltfBuilder::new();
    let pos = b.positions(&[[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 0.0, 1.0]]);
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], None, TRIANGLES, None)]);
    let cam = b.camera(
        json!({"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.1, "aspectRatio": 1.5}}),
    );
    let other = b.camera(json!({"type": "perspective", "perspective": {"yfov": 1.2, "znear": 0.1}}));

    let (parent_t, parent_r, parent_s) = ([0.5, 1.0, -2.0], quat([0.0, 1.0, 0.0], 30.0), [1.5, 1.5, 1.5]);
    let (cam_t, cam_r) = ([0.0, 0.5, 4.0], quat([1.0, 0.3, 0.0], -20.0));
    let cam_node = b.node(json!({"translation": cam_t, "rotation": quat_json(cam_r), "camera": cam}));
    let parent = b.node(json!({
        "translation": parent_t, "rotation": quat_json(parent_r), "scale": parent_s,
        "mesh": mesh, "children": [cam_node],
    }));
    // A later camera (depth-first after the first): not the one used.
    let later = b.node(json!({"translation": [9.0, 9.0, 9.0], "camera": other}));
    let s = b.scene(&[parent, later]);
    b.set_default_scene(s);
    b.write(&dir.path, "camera");

    let (translate, scale, rotate_y_deg) = ([3.0, 0.5, -7.0], 2.0, -50.0);
    let toml = format!(
        r#"
[[model]]
path = "camera.gltf"
translate = {}
scale = {scale:?}
rotate_y_deg = {rotate_y_deg:?}

[camera]
from_gltf = true

[[light]]
center = [0.0, 10.0, 0.0]
u = [1.0, 0.0, 0.0]
v = [0.0, 0.0, 1.0]
radiance = [1.0, 1.0, 1.0]
"#,
        vec3_toml(translate)
    );
    let scene = load_scene(&dir, &toml).unwrap_or_else(|e| panic!("{e}"));

    let w = model_matrix(translate, scale, rotate_y_deg)
        * trs(parent_t, parent_r, parent_s)
        * trs(cam_t, cam_r, [1.0, 1.0, 1.0]);
    let position = w.transform_point3(DVec3::ZERO);
    let forward = w.transform_vector3(DVec3::NEG_Z).normalize();
    let up = w.transform_vector3(DVec3::Y).normalize();

    let cam = &scene.camera;
    let got_position = cam.position.as_dvec3() + scene.world_offset;
    let size = diagonal(&[position, scene.bounds_min.as_dvec3(), scene.bounds_max.as_dvec3()]);
    assert!(
        (got_position - position).length() < 1e-5 * size,
        "camera position {got_position} vs {position} (tol {:e})",
        1e-5 * size
    );
    assert!((cam.forward.as_dvec3() - forward).length() < 1e-5, "forward {} vs {forward}", cam.forward);
    assert!((cam.up.as_dvec3() - up).length() < 1e-5, "up {} vs {up}", cam.up);
    let tan_half = (0.5 * yfov).tan();
    assert!(
        ((cam.tan_half_fov as f64) - tan_half).abs() < 1e-6 * tan_half,
        "tan(yfov/2) {} vs {tan_half}",
        cam.tan_half_fov
    );
}

// ---------------------------------------------------------------------------------------
// 7. Emissive rectangles as lights
// ---------------------------------------------------------------------------------------

#[test]
fn emissive_rectangle_becomes_the_light() {
    let dir = TempDir::new("emissive_light");
    let mut b = GltfBuilder::new();
    b.use_extension("KHR_materials_emissive_strength");
    let emissive = b.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]},
        "emissiveFactor": [1.0, 1.0, 1.0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5.0}},
    }));
    // A 2 x 0.5 rectangle in the local XY plane, counter-clockwise seen from +Z.
    let corners = [[-1.0f32, -0.25, 0.0], [1.0, -0.25, 0.0], [1.0, 0.25, 0.0], [-1.0, 0.25, 0.0]];
    let pos = b.positions(&corners);
    let ind = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let rect = b.mesh(vec![primitive(&[("POSITION", pos)], Some(ind), TRIANGLES, Some(emissive))]);
    // A lone emissive triangle: not a rectangle, so not a light.
    let pos = b.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]);
    let tri = b.mesh(vec![primitive(&[("POSITION", pos)], None, TRIANGLES, Some(emissive))]);
    // Some non-emissive geometry (the default material).
    let pos = b.positions(&[[-3.0, 0.0, -3.0], [-3.0, 0.0, 3.0], [3.0, 0.0, 0.0]]);
    let floor = b.mesh(vec![primitive(&[("POSITION", pos)], None, TRIANGLES, None)]);

    // Scale along the rectangle's own axes keeps it a rectangle: 3 x 0.4.
    let (rect_t, rect_r, rect_s) = ([0.3, 2.0, -1.0], quat([1.0, 0.5, 0.2], 110.0), [1.5, 0.8, 2.0]);
    let rect_node = b.node(json!({
        "translation": rect_t, "rotation": quat_json(rect_r), "scale": rect_s, "mesh": rect,
    }));
    let tri_node = b.node(json!({"translation": [-2.0, 1.5, 0.5], "mesh": tri}));
    let floor_node = b.node(json!({"mesh": floor}));
    let s = b.scene(&[rect_node, tri_node, floor_node]);
    b.set_default_scene(s);
    b.write(&dir.path, "emissive");

    let (translate, scale, rotate_y_deg) = ([1.0, 0.0, 2.0], 1.3, 25.0);
    let toml = format!(
        r#"
[[model]]
path = "emissive.gltf"
translate = {}
scale = {scale:?}
rotate_y_deg = {rotate_y_deg:?}

[camera]
position = [0.0, 4.0, 9.0]
look_at = [0.0, 0.0, 0.0]
"#,
        vec3_toml(translate)
    );
    let scene = load_scene(&dir, &toml).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.lights.len(), 1, "exactly one emissive rectangle");
    let light = &scene.lights[0];

    let w = model_matrix(translate, scale, rotate_y_deg) * trs(rect_t, rect_r, rect_s);
    let world: Vec<DVec3> =
        corners.iter().map(|c| w.transform_point3(DVec3::from(c.map(f64::from)))).collect();
    let centre = world.iter().copied().sum::<DVec3>() / 4.0;
    let edge_u = world[1] - world[0];
    let edge_v = world[3] - world[0];
    assert!(edge_u.dot(edge_v).abs() < 1e-12, "fixture: still a rectangle");
    let area = edge_u.length() * edge_v.length();
    assert!((area - 1.2 * scale * scale).abs() < 1e-9, "fixture: area {area}");
    let front = edge_u.cross(edge_v).normalize(); // CCW corners: the front face

    let size = diagonal(&[scene.bounds_min.as_dvec3(), scene.bounds_max.as_dvec3()]);
    let got_centre = light.center.as_dvec3() + scene.world_offset;
    assert!(
        (got_centre - centre).length() < 1e-5 * size,
        "light centre {got_centre} vs {centre} (tol {:e})",
        1e-5 * size
    );
    let got_area = light.area() as f64;
    assert!((got_area - area).abs() < 1e-4 * area, "light area {got_area} vs {area}");
    let mut sides = [light.u.length() as f64, light.v.length() as f64];
    sides.sort_by(f64::total_cmp);
    let mut want_sides = [edge_u.length(), edge_v.length()];
    want_sides.sort_by(f64::total_cmp);
    for (g, e) in sides.iter().zip(&want_sides) {
        assert!((g - e).abs() < 1e-4 * e, "light sides {sides:?} vs {want_sides:?}");
    }
    assert!((light.u.dot(light.v) as f64).abs() < 1e-5 * area, "u and v perpendicular");
    assert!(
        (light.normal.as_dvec3() - front).length() < 1e-5,
        "light normal {} vs the front face {front}",
        light.normal
    );
    assert!((light.u.cross(light.v).normalize().as_dvec3() - front).length() < 1e-5);
    for c in 0..3 {
        assert!(
            (light.radiance[c] - 5.0).abs() < 1e-6,
            "radiance {} (emissiveFactor 1 x strength 5)",
            light.radiance
        );
    }
}

/// Meshes and instances as loaded: two glTF meshes reading the same accessors (differing
/// in material only) are one mesh; a mesh of its own accessors is another; every node
/// using one is an instance (mirrored where its transform flips). Through the mesh's welded
/// ids, every triangle's corners land where the flattened triangle's do: equal ids, equal
/// render-space positions (what `silhouette`'s connectivity per mesh relies on), and the
/// quad of the scene file is a mesh of its own.
#[test]
fn meshes_sharing_accessors_are_one_mesh_placed_by_each_node() {
    let dir = TempDir::new("instances");
    let mut b = GltfBuilder::new();
    // A square of two triangles, its four corners repeated (a seam: six vertices, four
    // positions), and a lone triangle.
    let square = b.positions(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
    ]);
    let lone = b.positions(&[[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5]]);
    let red = b.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.0, 0.0, 1.0]}}));
    let blue = b.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 1.0, 1.0]}}));
    let m0 = b.mesh(vec![primitive(&[("POSITION", square)], None, TRIANGLES, Some(red))]);
    let m1 = b.mesh(vec![primitive(&[("POSITION", square)], None, TRIANGLES, Some(blue))]);
    let m2 = b.mesh(vec![primitive(&[("POSITION", lone)], None, TRIANGLES, None)]);
    let nodes = [
        b.node(json!({"mesh": m0, "translation": [0.0, 0.0, -3.0]})),
        b.node(json!({"mesh": m1, "translation": [2.0, 0.1, -3.0], "scale": [1.0, 1.0, -1.0]})),
        b.node(json!({"mesh": m0, "translation": [-2.0, 0.2, -3.0], "rotation": [0.0, 0.3826834, 0.0, 0.9238795]})),
        b.node(json!({"mesh": m2, "translation": [0.0, 1.0, -3.0]})),
    ];
    let s = b.scene(&nodes);
    b.set_default_scene(s);
    b.write(&dir.path, "instances");
    let quad = "[[quad]]\ncenter = [0.0, -1.0, 0.0]\nu = [4.0, 0.0, 0.0]\nv = [0.0, 0.0, -4.0]\n";
    let scene = load_scene(&dir, &format!("{}{quad}", model_toml("instances"))).expect("loads");
    assert_eq!(scene.meshes.len(), 3, "the square, the lone triangle, the quad");
    assert_eq!(scene.instances.len(), 5);
    assert_eq!(scene.meshes[0].vertices, 4, "the square's six vertices welded to four");
    assert_eq!(scene.instances.iter().filter(|i| i.mirrored).count(), 1);
    assert_eq!(scene.instances[0].mesh, scene.instances[1].mesh);
    assert_eq!(scene.instances[0].mesh, scene.instances[2].mesh);
    // Per instance and mesh id, the render-space position every corner with that id has.
    let mut seen = std::collections::HashMap::new();
    for (slot, (tri, o)) in scene.triangles.iter().zip(&scene.origins).enumerate() {
        assert!(!o.is_loose(), "slot {slot}");
        let inst = scene.instances[o.instance as usize];
        let mut c = scene.meshes[inst.mesh as usize].corners[o.local as usize];
        if inst.mirrored {
            c.swap(1, 2);
        }
        for (k, v) in [tri.v0, tri.v1, tri.v2].into_iter().enumerate() {
            let at = *seen.entry((o.instance, c[k])).or_insert(v);
            assert_eq!(at, v, "slot {slot} corner {k}: id {} at two positions", c[k]);
        }
    }
    assert_eq!(seen.len(), 4 + 4 + 4 + 3 + 4, "every corner of every instance met");
}
