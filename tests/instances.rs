//! Meshes placed by many glTF nodes: the counts a user reads (flattened triangles, unique
//! triangles, instances), and a scene too big for the memory refused before its buffers are
//! read. Files generated at run time; expected values from the numbers written into them.

mod common;

use common::gltf_writer::{GltfBuilder, TRIANGLES, TempDir, primitive};
use renderer::{Scene, SceneError, SceneFile};
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
    Scene::load_within(&SceneFile::parse(&toml, &path)?, &path, limit)
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
