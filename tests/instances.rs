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
