//! Meshes placed by many glTF nodes: the counts a user reads (flattened triangles, unique
//! triangles, instances), and a scene too big for the memory refused before its buffers are
//! read. Files generated at run time; expected values from the numbers written into them.

use crate::common;

use common::gltf_writer::{GltfBuilder, TRIANGLES, TempDir, primitive};
use renderer::{KeepInstances, LoadOptions, Scene, SceneError, SceneFile};
use serde_json::json;

const CAMERA_AND_LIGHT: &str = r#"
[camera]
position = [0.0, 30.0, 60.0]
look_at = [0.0, 0.0, 0.0]

[[light]]
center = [0.0, 40.0, 0.0]
u = [2.0, 0.0, 0.0]
v = [0.0, 0.0, 2.0]
radiance = [1.0, 1.0, 1.0]
"#;

/// A strip of `2 * cells` triangles (a 1 x `cells` grid of unit squares) placed by `nodes`
/// nodes side by side; writes `<dir>/field.gltf` + `field.bin`.
fn write_field(dir: &TempDir, cells: usize, nodes: usize) {
    let mut b = GltfBuilder::new();
    let mut p = Vec::new();
    for i in 0..=cells {
        p.push([i as f32, 0.0, 0.0]);
        p.push([i as f32, 0.0, 1.0]);
    }
    let mut idx = Vec::new();
    for i in 0..cells as u32 {
        let (a, c) = (2 * i, 2 * i + 2);
        idx.extend([a, a + 1, c, c, a + 1, c + 1]);
    }
    let pos = b.positions(&p);
    let ind = b.indices_u32(&idx);
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], Some(ind), TRIANGLES, None)]);
    let placed: Vec<usize> = (0..nodes)
        .map(|k| b.node(json!({"mesh": mesh, "translation": [0.0, 0.0, 2.0 * k as f64]})))
        .collect();
    let s = b.scene(&placed);
    b.set_default_scene(s);
    b.write(&dir.path, "field");
}

fn load(dir: &TempDir, limit: Option<u64>) -> Result<Scene, SceneError> {
    let toml = format!("[[model]]\npath = \"field.gltf\"\n{CAMERA_AND_LIGHT}");
    let path = dir.join("scene.toml");
    std::fs::write(&path, &toml).expect("write the scene file");
    Scene::load_with(
        &SceneFile::parse(&toml, &path)?,
        &path,
        LoadOptions { memory_limit: limit, keep: KeepInstances::Never },
    )
}

/// 200 nodes placing one 1,000-triangle mesh: 200,000 triangles flattened, 1,000 unique, 200
/// instances; with room for them it loads, and the counts are the file's.
#[test]
fn a_mesh_placed_by_many_nodes_is_counted_once_as_unique_and_once_per_node_flattened() {
    let dir = TempDir::new("instances-counts");
    write_field(&dir, 500, 200);
    let scene = load(&dir, Some(1 << 30)).expect("200,000 triangles fit in 1 GiB");
    assert_eq!(scene.stats.triangles, 200_000);
    assert_eq!(scene.unique_triangles(), 1_000);
    assert_eq!(scene.instances.len(), 200);
    assert_eq!(scene.meshes.len(), 1);
}

/// The same file under a 50 MB limit: about 200,000 x 450 bytes = 90 MB are needed, so the
/// load is refused in one line that names the file and the key and says how much. The
/// buffer is removed first: the refusal comes before any buffer is read.
#[test]
fn a_scene_beyond_the_memory_is_refused_before_its_buffers_are_read() {
    let dir = TempDir::new("instances-refused");
    write_field(&dir, 500, 200);
    std::fs::remove_file(dir.join("field.bin")).expect("remove the buffer");
    let err = match load(&dir, Some(50_000_000)) {
        Ok(_) => panic!("200,000 triangles at ~450 bytes each do not fit in 50 MB"),
        Err(e) => e,
    };
    assert_eq!(err.file, dir.join("field.gltf"));
    assert_eq!(err.key, "nodes");
    let message = err.to_string();
    assert!(!message.contains('\n'), "one line: {message}");
    let need = 200_000.0 * 450.0 / (1u64 << 30) as f64;
    for part in [format!("about {need:.1} GiB"), "200000 triangles".into(), "1000 distinct triangles".into()]
    {
        assert!(message.contains(&part), "{part:?} in {message}");
    }
    // Without a limit the missing buffer is what fails: the refusal above came first.
    let err = load(&dir, None).err().expect("the buffer is gone");
    assert_eq!(err.key, "buffers[0].uri", "{err}");
}

/// One triangle drawn by a node (translated, rotated 90 degrees about y) through
/// EXT_mesh_gpu_instancing with three copies: each copy's TRS applied first, then the node's
/// (world = node x T x R x S), the third mirrored by a negative scale. Expected positions
/// from the numbers written, in f64; render space is world less the camera's position;
/// tolerance 1e-5 m (f32 rounding of coordinates under 60 m: spacing 4e-6).
#[test]
fn gpu_instancing_draws_the_mesh_once_per_copy_under_the_node() {
    use glam::{DMat4, DQuat, DVec3};
    let dir = TempDir::new("gpu-instancing");
    let mut b = GltfBuilder::new();
    let tri = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let pos = b.positions(&tri);
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], None, TRIANGLES, None)]);
    let t = [[0.0f32, 0.0, 0.0], [5.0, 0.0, 0.0], [0.0, 0.0, 7.0]];
    let half = std::f32::consts::FRAC_1_SQRT_2;
    let r = [[0.0f32, 0.0, 0.0, 1.0], [0.0, 0.0, half, half], [half, 0.0, 0.0, half]];
    let s = [[1.0f32, 1.0, 1.0], [2.0, 2.0, 2.0], [1.0, -1.0, 1.0]];
    let (ta, ra, sa) = (b.vec3(&t), b.vec4(&r), b.vec3(&s));
    let node_t = [1.0, 2.0, 3.0];
    let node_r = [0.0, half as f64, 0.0, half as f64];
    let node = b.node(json!({
        "mesh": mesh, "translation": node_t, "rotation": node_r,
        "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": ta, "ROTATION": ra, "SCALE": sa}}}
    }));
    let sc = b.scene(&[node]);
    b.set_default_scene(sc);
    b.require_extension("EXT_mesh_gpu_instancing");
    b.write(&dir.path, "field");
    let scene = load(&dir, None).expect("a file requiring the extension loads");
    assert_eq!((scene.stats.triangles, scene.instances.len(), scene.meshes.len()), (3, 3, 1));
    assert_eq!(scene.instances.iter().map(|i| i.mirrored).collect::<Vec<_>>(), [false, false, true]);

    let node_m = DMat4::from_rotation_translation(DQuat::from_array(node_r).normalize(), DVec3::from(node_t));
    let camera = DVec3::new(0.0, 30.0, 60.0);
    let f = |v: [f32; 3]| DVec3::from(v.map(f64::from));
    let mut loaded: Vec<[DVec3; 3]> =
        scene.triangles.iter().map(|t| [t.v0, t.v1, t.v2].map(|v| glam::Vec3::from(v).as_dvec3())).collect();
    for k in 0..3 {
        let q = DQuat::from_array(r[k].map(f64::from)).normalize();
        let m = node_m * DMat4::from_scale_rotation_translation(f(s[k]), q, f(t[k]));
        let want = tri.map(|v| m.transform_point3(f(v)) - camera);
        let near = |a: &[DVec3; 3]| want.iter().all(|w| a.iter().any(|v| (*v - *w).length() < 1e-5));
        let i = loaded
            .iter()
            .position(near)
            .unwrap_or_else(|| panic!("copy {k} ({want:?}) not among {loaded:?}"));
        loaded.remove(i);
    }
}

/// The extension's errors: attribute counts that differ, a zero scale, an accessor that does
/// not exist: one line each naming the attribute; and the refusal counts every copy.
#[test]
fn gpu_instancing_errors_name_the_attribute_and_the_refusal_counts_copies() {
    type Case = (&'static str, Vec<[f32; 3]>, Vec<[f32; 3]>, &'static str);
    let cases: [Case; 2] = [
        ("counts", vec![[0.0; 3], [1.0, 0.0, 0.0]], vec![[1.0; 3]], "elements where another attribute has 2"),
        ("zero-scale", vec![[0.0; 3]], vec![[0.0, 1.0, 1.0]], "singular"),
    ];
    for (name, t, s, says) in cases {
        let dir = TempDir::new(&format!("gpu-instancing-{name}"));
        let mut b = GltfBuilder::new();
        let pos = b.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], None, TRIANGLES, None)]);
        let (ta, sa) = (b.vec3(&t), b.vec3(&s));
        let attributes = json!({"TRANSLATION": ta, "SCALE": sa});
        let node = b.node(
            json!({"mesh": mesh, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attributes}}}),
        );
        let sc = b.scene(&[node]);
        b.set_default_scene(sc);
        b.write(&dir.path, "field");
        let err = load(&dir, None).err().unwrap_or_else(|| panic!("{name}: loads"));
        let message = err.to_string();
        assert!(
            err.key.starts_with("nodes[0].extensions.EXT_mesh_gpu_instancing.attributes."),
            "{name}: {message}"
        );
        assert!(message.contains(says) && !message.contains('\n'), "{name}: {message}");
    }

    // 1,000 copies of a 1,000-triangle mesh by one node: 10^6 triangles, 450 MB, refused
    // under 100 MB before the buffers are read.
    let dir = TempDir::new("gpu-instancing-refused");
    let mut b = GltfBuilder::new();
    let mut p = Vec::new();
    for i in 0..=500 {
        p.extend([[i as f32, 0.0, 0.0], [i as f32, 0.0, 1.0]]);
    }
    let pos = b.positions(&p);
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], None, 5, None)]); // a strip: 1,000 triangles
    let ta = b.vec3(&(0..1000).map(|k| [0.0, 0.0, 2.0 * k as f32]).collect::<Vec<_>>());
    let node = b.node(
        json!({"mesh": mesh, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": ta}}}}),
    );
    let sc = b.scene(&[node]);
    b.set_default_scene(sc);
    b.write(&dir.path, "field");
    let err = load(&dir, Some(100_000_000)).err().expect("10^6 triangles do not fit in 100 MB");
    assert_eq!(err.key, "nodes", "{err}");
    assert!(
        err.to_string().contains("1000 instance(s)") && err.to_string().contains("1000000 triangles"),
        "{err}"
    );
    let scene = load(&dir, None).expect("loads without a limit");
    assert_eq!((scene.stats.triangles, scene.instances.len()), (1_000_000, 1000));
}

/// Loads `toml` (written as `<dir>/scene.toml`) with instances flattened and kept.
fn load_both(dir: &std::path::Path, toml: &str) -> (Scene, Scene) {
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).expect("write the scene file");
    load_file_both(&SceneFile::parse(toml, &path).expect("a valid scene file"), &path)
}

/// `file` loaded with instances flattened and kept. The kept scene holds the placed corners
/// of about half its instances (a memory limit whose budget for them is half the flattened
/// triangles' corners), so that both ways of reading a triangle are tested.
fn load_file_both(file: &SceneFile, path: &std::path::Path) -> (Scene, Scene) {
    let load =
        |limit, keep| Scene::load_with(file, path, LoadOptions { memory_limit: limit, keep }).expect("loads");
    let flat = load(None, KeepInstances::Never);
    // The budget is an eighth of the limit; a triangle's corners take 36 bytes.
    let kept = load(Some(8 * 36 * flat.stats.triangles / 2), KeepInstances::Always);
    let placed = &kept.instanced.as_ref().expect("instances kept").placed;
    let held = placed.iter().filter(|p| p.corners_at.is_some()).count();
    let both = held > 0 && held < placed.len();
    assert!(both || placed.len() < 2, "{held} of {} instances hold their corners", placed.len());
    (flat, kept)
}

/// Casts `rays` random rays from around the camera's view and shadow rays between hits, in
/// both scenes: every closest hit (its t, point, error bound, normals, uv, material, side)
/// and every occlusion answer is the same bit for bit. Returns the hits met.
fn same_answers(flat: &Scene, kept: &Scene, rays: usize, reach: f32) -> usize {
    use glam::Vec3A;
    use obvhs::ray::Ray;
    assert!(kept.instanced.is_some() && flat.instanced.is_none());
    assert_eq!(flat.stats.triangles, kept.stats.triangles, "the kept scene counts the flattened triangles");
    assert_eq!(flat.warnings, kept.warnings, "the same drops, counted alike");
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let (lo, hi) = (flat.bounds_min, flat.bounds_max);
    let mut hits = 0;
    let mut previous: Option<glam::Vec3> = None;
    let mut clear = 0;
    for _ in 0..rays {
        let o = glam::Vec3::new(uniform(), uniform(), uniform()) * reach - reach / 2.0;
        let target = lo + (hi - lo) * glam::Vec3::new(uniform(), uniform(), uniform());
        let ray = Ray::new_inf(Vec3A::from(o), Vec3A::from((target - o).normalize()));
        let (a, b) = (flat.intersect(ray), kept.intersect(ray));
        match (&a, &b) {
            (Some(a), Some(b)) => {
                let key = |h: &renderer::SurfaceHit| (h.t, h.point, h.uv, h.material, h.front_face);
                assert_eq!(key(a), key(b), "ray from {o} to {target}");
                hits += 1;
                // A shadow segment between this hit and the last, each end lifted off its
                // surface as the renderer's origins are (not along a face's plane).
                let lifted = a.point.p + 1e-3 * reach * a.point.n_geom;
                if let Some(p) = previous {
                    let shadow = Ray::new(Vec3A::from(lifted), Vec3A::from(p - lifted), 0.0, 1.0);
                    assert_eq!(flat.occluded(shadow), kept.occluded(shadow), "shadow ray {lifted} -> {p}");
                }
                previous = Some(lifted);
                clear += shafts_sound(flat, kept, &a.point, &mut uniform) as usize;
            }
            (None, None) => {}
            _ => panic!("ray from {o} to {target}: {a:?} against {b:?}"),
        }
        assert_eq!(flat.occluded(ray), kept.occluded(ray), "ray from {o} to {target}");
    }
    assert!(clear > hits / 20, "{clear} of {hits} shafts proven clear: the check must meet some");
    hits
}

/// A shaft from `point` (facing the whole light) the kept scene proves clear holds no blocked
/// ray of the flattened scene (16 rays to random light points, by the renderer's own rule
/// for shadow rays). Returns whether it was proven clear.
fn shafts_sound(
    flat: &Scene,
    kept: &Scene,
    point: &renderer::ShadingPoint,
    uniform: &mut impl FnMut() -> f32,
) -> bool {
    let light = &flat.lights[0];
    // Points the whole light is above (a shaft holds the rays of a lit side only).
    if light.corners().iter().any(|&c| (c - point.p).dot(point.n_geom) <= 0.0) {
        return false;
    }
    let Some(shaft) = renderer::Shaft::new(light, point) else { return false };
    if !kept.shaft_clear(&shaft) {
        return false;
    }
    for _ in 0..16 {
        let target = light.center + (uniform() - 0.5) * light.u + (uniform() - 0.5) * light.v;
        let zero = glam::Vec3::ZERO;
        assert!(
            !flat.segment_occluded(point, target, zero, light.normal),
            "a shaft the kept scene proved clear holds a blocked ray from {} to {target}",
            point.p
        );
    }
    true
}

/// A mesh (a closed box) placed by five nodes: plain, turned, scaled unevenly, mirrored, and
/// one sharing a face with the first (a seam between instances); a quad under them. Kept or
/// flattened, every hit and shadow answer is the same bit for bit.
#[test]
fn kept_instances_answer_every_ray_as_the_flattened_scene() {
    let dir = TempDir::new("instances-kept");
    let mut b = GltfBuilder::new();
    let c = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    let faces: [[u32; 4]; 6] =
        [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [3, 7, 6, 2], [0, 4, 7, 3], [1, 2, 6, 5]];
    let idx: Vec<u32> = faces.iter().flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]]).collect();
    let pos = b.positions(&c);
    let normals = b.normals(&c.map(|p| [p[0] - 0.5, p[1] - 0.5, p[2] - 0.5]));
    let ind = b.indices_u32(&idx);
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos), ("NORMAL", normals)], Some(ind), TRIANGLES, None)]);
    let nodes = [
        json!({"mesh": mesh, "translation": [0.0, 0.0, 0.0]}),
        json!({"mesh": mesh, "translation": [1.0, 0.0, 0.0]}),
        json!({"mesh": mesh, "translation": [-3.0, 0.3, 1.0], "rotation": [0.2, 0.3, 0.1, 0.927]}),
        json!({"mesh": mesh, "translation": [2.5, 0.0, -2.0], "scale": [0.5, 2.0, 1.5]}),
        json!({"mesh": mesh, "translation": [0.0, 0.0, 3.0], "scale": [-1.0, 1.0, 1.0]}),
    ]
    .map(|n| b.node(n));
    let sc = b.scene(&nodes);
    b.set_default_scene(sc);
    b.write(&dir.path, "field");
    let quad = "[[quad]]\ncenter = [0.0, -0.01, 0.0]\nu = [12.0, 0.0, 0.0]\nv = [0.0, 0.0, -12.0]\n";
    let toml = format!("[[model]]\npath = \"field.gltf\"\n{quad}{CAMERA_AND_LIGHT}");
    let (flat, kept) = load_both(&dir.path, &toml);
    assert_eq!(kept.instanced.as_ref().map(|i| i.placed.len()), Some(5));
    let hits = same_answers(&flat, &kept, 20_000, 16.0);
    assert!(hits > 5_000, "{hits} hits: the rays must meet the scene");
}

/// metal-rough-spheres (one sphere placed by 98 nodes, two pole triangles dropped in each):
/// the same answers kept or flattened.
#[test]
fn metal_rough_spheres_kept_answers_as_flattened() {
    if !common::shared::scenes_present("instances::metal_rough_spheres_kept_answers_as_flattened") {
        return;
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("scenes/gltf/metal-rough-spheres.toml");
    let text = std::fs::read_to_string(&path).expect("the scene file");
    let file = SceneFile::parse(&text, &path).expect("a valid scene file");
    let (flat, kept) = load_file_both(&file, &path);
    let hits = same_answers(&flat, &kept, 20_000, 0.05);
    assert!(hits > 2_000, "{hits} hits");
}

/// A node whose transform flattens its mesh (a zero scale) is an error naming the node.
#[test]
fn a_singular_node_transform_is_an_error_naming_the_node() {
    let dir = TempDir::new("instances-singular");
    let mut b = GltfBuilder::new();
    let pos = b.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], None, TRIANGLES, None)]);
    let ok = b.node(json!({"mesh": mesh}));
    let flat = b.node(json!({"mesh": mesh, "scale": [1.0, 0.0, 1.0]}));
    let sc = b.scene(&[ok, flat]);
    b.set_default_scene(sc);
    b.write(&dir.path, "field");
    let err = load(&dir, None).err().expect("a zero scale is refused");
    assert_eq!((err.file.clone(), err.key.as_str()), (dir.join("field.gltf"), "nodes[1]"), "{err}");
    assert!(err.to_string().contains("singular"), "{err}");
}

// ---------------------------------------------------------------------------------------
// Kept instances at the edges (cases a review found)
// ---------------------------------------------------------------------------------------

/// A 2 x 2 quad at y = 0 in its mesh's space.
fn quad_mesh(b: &mut GltfBuilder) -> (usize, usize) {
    let pos = b.positions(&[[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]]);
    (pos, b.indices_u32(&[0, 2, 1, 0, 3, 2]))
}

fn write_nodes(dir: &TempDir, mut b: GltfBuilder, nodes: Vec<serde_json::Value>) -> (Scene, Scene) {
    let placed: Vec<usize> = nodes.into_iter().map(|n| b.node(n)).collect();
    let sc = b.scene(&placed);
    b.set_default_scene(sc);
    b.write(&dir.path, "field");
    load_both(&dir.path, &format!("[[model]]\npath = \"field.gltf\"\n{CAMERA_AND_LIGHT}"))
}

fn down_from(o: glam::Vec3) -> obvhs::ray::Ray {
    let d = glam::Vec3::new(0.05, -1.0, 0.03).normalize();
    obvhs::ray::Ray::new_inf(o.into(), d.into())
}

/// A segment ending exactly at a hit: no hit, as flattened (obvhs counts t < tmax only).
#[test]
fn a_hit_at_exactly_the_segment_end_is_none_kept_or_flattened() {
    let dir = TempDir::new("instances-tmax");
    let mut b = GltfBuilder::new();
    let (pos, ind) = quad_mesh(&mut b);
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], Some(ind), TRIANGLES, None)]);
    let (flat, kept) = write_nodes(
        &dir,
        b,
        vec![json!({"mesh": mesh}), json!({"mesh": mesh, "translation": [5.0, 0.0, 0.0]})],
    );
    let ray = down_from(glam::Vec3::new(0.0, -25.0, -60.0));
    let t = flat.intersect(ray).expect("the ray meets the quad").t;
    let capped = obvhs::ray::Ray { tmax: t, ..ray };
    assert_eq!(flat.intersect(capped).map(|h| h.t), kept.intersect(capped).map(|h| h.t));
    assert_eq!(flat.occluded(capped), kept.occluded(capped));
    assert!(!kept.occluded(capped) && kept.intersect(ray).map(|h| h.t) == Some(t));
}

/// Two meshes sharing POSITION and indices but not NORMAL: each keeps its own normals.
#[test]
fn meshes_sharing_positions_keep_their_own_normals() {
    let dir = TempDir::new("instances-normals");
    let mut b = GltfBuilder::new();
    let (pos, ind) = quad_mesh(&mut b);
    let up = b.normals(&[[0.0, 1.0, 0.0]; 4]);
    let tilt = b.normals(&[[0.6, 0.8, 0.0]; 4]);
    let m1 = b.mesh(vec![primitive(&[("POSITION", pos), ("NORMAL", up)], Some(ind), TRIANGLES, None)]);
    let m2 = b.mesh(vec![primitive(&[("POSITION", pos), ("NORMAL", tilt)], Some(ind), TRIANGLES, None)]);
    let nodes = vec![json!({"mesh": m1, "translation": [-5.0, 0.0, 0.0]}), json!({"mesh": m2})];
    let (flat, kept) = write_nodes(&dir, b, nodes);
    let ray = down_from(glam::Vec3::new(0.0, -25.0, -60.0));
    let (a, k) = (flat.intersect(ray).expect("a hit"), kept.intersect(ray).expect("a hit"));
    assert_eq!(a.point, k.point);
    assert!((a.point.n_shading.x.abs() - 0.6).abs() < 1e-6, "the tilted normal: {}", a.point.n_shading);
}

/// A mesh whose first instance keeps no triangle (lost to f32): unique triangles counted
/// from that instance, as flattened (none), and the same warnings.
#[test]
fn unique_triangles_count_the_first_instance_kept_or_flattened() {
    let dir = TempDir::new("instances-unique");
    let mut b = GltfBuilder::new();
    let (pos, ind) = quad_mesh(&mut b);
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], Some(ind), TRIANGLES, None)]);
    let nodes = vec![json!({"mesh": mesh, "scale": [1e-12, 1e-12, 1e-12]}), json!({"mesh": mesh})];
    let (flat, kept) = write_nodes(&dir, b, nodes);
    assert_eq!((flat.unique_triangles(), flat.stats.triangles), (0, 2));
    assert_eq!(kept.unique_triangles(), flat.unique_triangles());
    assert_eq!(kept.warnings, flat.warnings);
}

/// Rays along an axis (direction components 0 or 1e-6) just beside the edges of a 100x
/// instance's leaf boxes: obvhs's `Ray::new` clamps a direction component under f32's
/// epsilon, which ended a ray's stay in a slab early (the flattened walk missed 35 of 18,000
/// such rays, the kept one more: its direction was shrunk 100x). Both walk with
/// `watertight::walkable`'s inverse now: every ray meets the floor at the same t either way.
#[test]
fn rays_along_an_axis_meet_a_scaled_instance_kept_as_flattened() {
    let dir = TempDir::new("instances-axis");
    let mut b = GltfBuilder::new();
    let cells = 16u32;
    let (mut p, mut idx) = (Vec::new(), Vec::new());
    for i in 0..=cells {
        for j in 0..=cells {
            p.push([i as f32 / cells as f32, 0.0, j as f32 / cells as f32]);
        }
    }
    let at = |i: u32, j: u32| i * (cells + 1) + j;
    for i in 0..cells {
        for j in 0..cells {
            idx.extend([at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    let base = p.len() as u32; // a post at the corner: the bounds reach y = 1
    p.extend([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    idx.extend([base, base + 1, base + 2]);
    let (pos, ind) = (b.positions(&p), b.indices_u32(&idx));
    let mesh = b.mesh(vec![primitive(&[("POSITION", pos)], Some(ind), TRIANGLES, None)]);
    let (flat, kept) = write_nodes(&dir, b, vec![json!({"mesh": mesh, "scale": [100.0, 100.0, 100.0]})]);
    let (mut total, mut both) = (0, 0);
    for dx in [0.0f32, 1e-6, -1e-6] {
        let d = glam::Vec3::new(dx, -1.0, 0.0).normalize();
        for k in 1..cells {
            let edge = k as f32 * 100.0 / cells as f32;
            for m in 1..=100 {
                for x in [edge - m as f32 * 1e-5, edge + m as f32 * 1e-5] {
                    let o = glam::Vec3::new(x, 200.0, -60.0 + 31.3);
                    let ray = obvhs::ray::Ray::new_inf(o.into(), d.into());
                    let (a, k) = (flat.intersect(ray).map(|h| h.t), kept.intersect(ray).map(|h| h.t));
                    total += 1;
                    match (a, k) {
                        (Some(a), Some(k)) => {
                            assert_eq!(a, k, "x {x}, d.x {dx:e}");
                            both += 1;
                        }
                        (Some(a), None) => panic!("kept missed the hit at {a}: x {x}, d.x {dx:e}"),
                        (None, Some(k)) => {
                            panic!("the flattened scene missed the hit at {k}: x {x}, d.x {dx:e}")
                        }
                        (None, None) => {}
                    }
                }
            }
        }
    }

    assert!(both > total * 9 / 10, "the rays must meet the floor: {both} of {total}");
}

/// Lights made from emissive rectangles (no `[[light]]`): a double-sided emissive quad placed
/// by two nodes faces the scene's centre, which boxes placed far to one side move. Kept or
/// flattened, the scene's bounds and so its lights are the same.
#[test]
fn lights_from_kept_emissive_instances_face_the_same_centre() {
    let dir = TempDir::new("instances-emitters");
    let mut b = GltfBuilder::new();
    let glow = b.material(json!({"emissiveFactor": [1.0, 1.0, 1.0], "doubleSided": true}));
    let (pos, ind) = quad_mesh(&mut b);
    let lamp = b.mesh(vec![primitive(&[("POSITION", pos)], Some(ind), TRIANGLES, Some(glow))]);
    let (pos, ind) = quad_mesh(&mut b);
    let slab = b.mesh(vec![primitive(&[("POSITION", pos)], Some(ind), TRIANGLES, None)]);
    let mut nodes = vec![
        json!({"mesh": lamp, "translation": [0.0, 4.0, 0.0]}),
        json!({"mesh": lamp, "translation": [3.0, 4.0, 0.0]}),
    ];
    nodes.extend((0..3).map(|k| json!({"mesh": slab, "translation": [40.0 + k as f64, -3.0, 5.0]})));
    let placed: Vec<usize> = nodes.into_iter().map(|n| b.node(n)).collect();
    let sc = b.scene(&placed);
    b.set_default_scene(sc);
    b.write(&dir.path, "field");
    let toml = "[[model]]\npath = \"field.gltf\"\n[camera]\nposition = [0.0, 2.0, 12.0]\nlook_at = [0.0, 0.0, 0.0]\n";
    let (flat, kept) = load_both(&dir.path, toml);
    assert_eq!(flat.lights.len(), 2, "the two placed lamps");
    let key = |s: &Scene| s.lights.iter().map(|l| (l.center, l.u, l.v, l.normal)).collect::<Vec<_>>();
    assert_eq!(key(&flat), key(&kept));
    assert_eq!((flat.bounds_min, flat.bounds_max), (kept.bounds_min, kept.bounds_max));
}

/// Every method on the bench's field of 400 instanced boulders, kept and flattened: `traced`,
/// `silhouette`, `pcss` and `none` render the same image and visibility bytes either way
/// (their answers are the flattened scene's, bit for bit: no tolerance), and `edge_table`,
/// which needs the triangles flattened, refuses the kept scene in one line naming itself.
#[test]
fn every_method_renders_kept_instances_as_flattened() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = root.join("scenes/stress/boulder-field-400.toml");
    let dir = TempDir::new("instances-methods");
    let render = |method: &str, keep| {
        let out = dir.join(&format!("{method}-{keep:?}.png"));
        let args = penumbra::RenderArgs {
            scene: Some(scene.clone()),
            keys: penumbra::request::Overrides {
                shadows: Some(method.to_string()),
                samples: Some(16),
                width: Some(48),
                height: Some(36),
                ..Default::default()
            },
            out: Some(out.clone()),
            aov: true,
            quiet: true,
            keep_instances: Some(keep),
            ..Default::default()
        };
        penumbra::run_render(&args).map(|o| {
            let read = |ext: &str| std::fs::read(out.with_extension(ext)).expect("an output");
            (read("exr"), read("visibility.0.exr"), o.report.kept_instances)
        })
    };
    for method in ["traced", "silhouette", "pcss", "none"] {
        let kept = render(method, KeepInstances::Always).expect("renders kept");
        let flat = render(method, KeepInstances::Never).expect("renders flattened");
        assert_eq!((kept.2, flat.2), (400, 0), "{method}: the instances kept");
        assert_eq!(kept.0, flat.0, "{method}: the image");
        assert_eq!(kept.1, flat.1, "{method}: the visibility");
    }
    let err = render("edge_table", KeepInstances::Always).expect_err("edge_table needs them flattened");
    assert!(err.to_string().contains("edge_table"), "{err}");
}
