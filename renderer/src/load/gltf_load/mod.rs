//! glTF 2.0 (.gltf + .bin + images, or .glb) into world-space triangles, materials and
//! textures. Node transforms are composed in f64; every node of the default scene is
//! expanded, nested TRS and matrices alike. Skins and morph targets are ignored (bind pose).

use crate::geometry::attributes::TriangleExtras;
use crate::geometry::instances::{Instance, MeshTopology, Placement, Placing, PrimitiveData, TriangleOrigin};
use crate::geometry::material::{AlphaMode, Filter, Material, Shading, Texture, TextureRef, Wrap};
use crate::util::error::SceneError;
use glam::{Affine2, DMat4, DVec3, Mat2, Vec2, Vec3, Vec4};
use gltf::Semantic;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use std::collections::HashMap;
use std::path::Path;

mod attributes;
mod files;
mod gpu_instancing;
mod images;
mod materials;
mod overflow;
mod primitives;
mod tangents;
mod unlit_emitters;
use attributes::{Needs, read_extras};
use files::{load_buffers, open_gltf, truncated_glb, uris_out_of_folder};
use materials::*;
pub use overflow::Overflow;
use primitives::*;
pub use tangents::generate_tangents;
pub use unlit_emitters::UnlitEmitters;

/// A triangle as loaded: world positions in f64 (before the scene is recentred), optional
/// world-space vertex normals, texture coordinates and a material index (into the scene's
/// material list).
#[derive(Debug, Clone, Copy)]
pub struct SourceTriangle {
    pub p: [DVec3; 3],
    pub n: Option<[Vec3; 3]>,
    pub uv: [Vec2; 3],
    pub material: u32,
    /// Its instance and index in its mesh ([`TriangleOrigin::LOOSE`] for a hand-made soup).
    pub origin: TriangleOrigin,
}

/// Triangles of one emissive primitive instance: a candidate rectangular light.
#[derive(Debug, Clone)]
pub struct EmitterCandidate {
    pub triangles: Vec<[DVec3; 3]>,
    /// emissiveFactor x emissive strength (without the texture, where there is one).
    pub radiance: Vec3,
    pub double_sided: bool,
    /// `FILE: materials[i].emissiveTexture` where its material has an emissive texture: its
    /// radiance varies over it, which a light's single radiance cannot hold, so it is never
    /// made a light (the scene says so, naming this).
    pub emissive_texture: Option<String>,
}

/// A camera found in a glTF file: its node's world transform and vertical fov (radians).
#[derive(Debug, Clone, Copy)]
pub struct GltfCamera {
    pub world: DMat4,
    pub yfov: f64,
}

/// Everything the loader appends to.
#[derive(Debug, Default)]
pub struct Geometry {
    pub triangles: Vec<SourceTriangle>,
    /// The extra attributes of the `triangles` whose material reads a second
    /// texture-coordinate set, COLOR_0 or tangents, by index there (pushed in order; the
    /// scene build keeps those of the triangles it keeps).
    pub extras: TriangleExtras,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// Emissive primitives, gathered only when `gather_emitters`.
    pub emitters: Vec<EmitterCandidate>,
    /// Whether emissive primitives are gathered as candidate lights (the scene file gives no
    /// `[[light]]`): else they would be copied for nothing (toy-car's body, 89k triangles, is
    /// emissive through a texture).
    pub gather_emitters: bool,
    /// The scene file's `[[light]]`s and the emissive materials met off them (a warning each).
    pub unlit: UnlitEmitters,
    /// Meshes and the instances that place them, which `SourceTriangle::origin` names.
    pub meshes: Vec<MeshTopology>,
    pub instances: Vec<Instance>,
    /// Triangles dropped because they have zero area.
    pub degenerate: u64,
    /// The current node's triangles dropped because its transform takes them out of f32's
    /// range: warned of per node ([`Overflow::warning`]), then reset.
    pub overflow: Overflow,
    /// Every node's such triangles, for the load's counts.
    pub overflowed: u64,
    /// One line each: what a user should hear of the files loaded (URIs out of a model's
    /// folder).
    pub warnings: Vec<String>,
    /// glTF placements kept unflattened (when `keep_instances`): each mesh stored once, the
    /// scene traces it through a second level ([`crate::geometry::instanced`]).
    pub placements: Vec<Placement>,
    /// Whether the loader keeps placements of meshes as [`Placement`]s instead of flattening
    /// them: set where the flattened scene would not fit in `memory_limit` and
    /// `may_keep_instances` allows it (or by a caller).
    pub keep_instances: bool,
    pub may_keep_instances: bool,
    /// Whether to keep the placements of the current file's meshes in `shared` (those whose
    /// copies beyond the first hold at least [`SHARED_TRIANGLES`]).
    pub keep_shared: bool,
    pub shared: std::collections::HashSet<MeshKey>,
    /// How the scene's materials are shaded: tangents are read (or generated) for
    /// normal-mapped primitives in [`Shading::Gltf`] only.
    pub shading: Shading,
    /// Bytes the load may use at its peak: a file whose triangles, once every instance is
    /// flattened, would need more ([`BYTES_PER_TRIANGLE`] each) is refused before its
    /// buffers are read. `None`: no limit.
    pub memory_limit: Option<u64>,
}

/// Peak bytes per flattened triangle from the load through the BVH build: the f64 source
/// triangle, the render-space one and its shading data, the BVH and its build's scratch.
/// Measured with `/usr/bin/time -f %M` (`--shadows traced`, 160x120, 64 samples): 486 on a
/// field of 100 boulders (8.2 M triangles), 492 on metal-rough-spheres (1.0 M), more on small
/// textured scenes. Taken low, so that a scene that fits is never refused.
pub const BYTES_PER_TRIANGLE: u64 = 450;

/// Bytes per kept instance (`geometry::instanced::Placed`, its pass and the top tree's share),
/// rounded up.
pub const BYTES_PER_INSTANCE: u64 = 512;

/// What every primitive of one file reads beside itself: the file (its errors name it), its
/// buffers, and where its materials start in the scene's list.
#[derive(Clone, Copy)]
struct FileContext<'a> {
    path: &'a Path,
    doc: &'a gltf::Document,
    buffers: &'a [gltf::buffer::Data],
    /// The scene's index of the file's material 0.
    material_base: u32,
    /// The scene's index of the glTF default material, for primitives without one.
    default_material: u32,
}

/// Loads `path` into `geometry`, transformed by `model_from_file` after the file's own node
/// transforms. Returns the file's first camera, if any.
pub fn load_gltf(
    path: &Path,
    model_from_file: DMat4,
    geometry: &mut Geometry,
) -> Result<Option<GltfCamera>, SceneError> {
    let fail = |key: &str, msg: String| SceneError::new(path, key, msg);
    let gltf = open_gltf(path).map_err(|(key, e)| match truncated_glb(path) {
        Some(msg) => fail("", msg),
        None if key.is_empty() => fail("", format!("cannot load glTF: {e}")),
        None => fail(&key, e),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    plan_instances(path, &gltf.document, geometry)?;
    let out_of_folder = uris_out_of_folder(path, base, &gltf.document);
    geometry.warnings.extend(out_of_folder.iter().cloned());
    // A URI out of the model's folder that reads the wrong file (say /etc/passwd) fails the
    // load further on ("index 28525 out of range"), and the warning that names the file read
    // would never be printed: the error names it instead.
    load_file(path, base, &gltf, model_from_file, geometry).map_err(|mut e| {
        if let Some(first) = out_of_folder.first() {
            e.message.push_str(&format!(" (note: {first})"));
        }
        e
    })
}

/// [`load_gltf`] once the file is open: its buffers, materials and nodes.
fn load_file(
    path: &Path,
    base: &Path,
    gltf: &gltf::Gltf,
    model_from_file: DMat4,
    geometry: &mut Geometry,
) -> Result<Option<GltfCamera>, SceneError> {
    let fail = |key: &str, msg: String| SceneError::new(path, key, msg);
    let buffers = load_buffers(path, base, &gltf.document, gltf.blob.clone())?;
    let doc = &gltf.document;

    let material_base = geometry.materials.len() as u32;
    load_materials(materials::Source { path, base, doc, buffers: &buffers }, geometry)?;
    // The glTF default material (white, opaque) for primitives without one.
    geometry.materials.push(Material::gltf_default());
    let default_material = geometry.materials.len() as u32 - 1;
    // Diffuse shading honours no material extension by choice: nothing to warn of.
    let unhonoured = unhonoured_extensions(doc);
    if !unhonoured.is_empty() && geometry.shading == Shading::Gltf {
        geometry.warnings.push(format!(
            "{}: material extensions not honoured (shaded as metallic-roughness): {}",
            path.display(),
            unhonoured.join(", ")
        ));
    }

    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| fail("scenes", "the file has no scene".into()))?;
    let file = FileContext { path, doc, buffers: &buffers, material_base, default_material };
    load_nodes(&file, &scene, model_from_file, geometry)
}

/// A mesh placed by several nodes is kept unflattened (where the method traces kept
/// instances) when its copies beyond the first would hold at least this many triangles
/// flattened (about 120 MB). metal-rough-spheres (97 copies of a 10.6k-triangle sphere, 1.0 M):
/// load + BVH 0.46 -> 0.04 s, peak memory 375 -> 54 MB, `traced`'s render 1.19x
/// (docs/notes/2026-11-28-instances.md). Below it the copies cost the flattened scene under
/// about 0.1 s and 120 MB, less than a render's share of the kept walk's extra cost
/// (glass-vase-flowers: one 7k-triangle mesh placed twice stays flattened).
pub const SHARED_TRIANGLES: u64 = 1 << 18;

/// What identifies a mesh's geometry: its triangle primitives' position and index accessors
/// and modes. Files repeat one geometry in meshes that differ only in material
/// (metal-rough-spheres: 98 meshes, one sphere).
pub type MeshKey = Vec<(usize, Option<usize>, u32)>;

/// [`MeshKey`] of `mesh`.
fn mesh_key(mesh: &gltf::Mesh) -> MeshKey {
    mesh.primitives()
        .filter_map(|p| {
            Some((
                p.get(&Semantic::Positions)?.index(),
                p.indices().map(|i| i.index()),
                p.mode().as_gl_enum(),
            ))
        })
        .collect()
}

/// The triangles a primitive holds, from its accessors' declared counts (nothing read).
fn primitive_triangles(prim: &gltf::Primitive) -> u64 {
    let n = prim.indices().or_else(|| prim.get(&Semantic::Positions)).map_or(0, |a| a.count() as u64);
    match prim.mode() {
        Mode::Triangles => n / 3,
        Mode::TriangleStrip | Mode::TriangleFan => n.saturating_sub(2),
        _ => 0, // points and lines: not loaded
    }
}

/// What the default scene of `doc` places, from the node tree and the accessors' declared
/// counts, before any buffer is read. A node reached twice is counted once (the load refuses
/// it).
#[derive(Default)]
struct Plan {
    /// Triangles once every instance is flattened.
    flattened: u64,
    /// Instances: nodes with a mesh and their `EXT_mesh_gpu_instancing` copies.
    placed: u64,
    /// Triangles of the distinct meshes ([`MeshKey`]).
    unique: u64,
    /// The meshes whose copies beyond the first hold at least [`SHARED_TRIANGLES`], the
    /// triangles of those copies, and their instances.
    shared: std::collections::HashSet<MeshKey>,
    shared_copies: u64,
    shared_placed: u64,
}

fn plan(doc: &gltf::Document) -> Plan {
    let mut plan = Plan::default();
    let Some(scene) = doc.default_scene().or_else(|| doc.scenes().next()) else { return plan };
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    let mut visited = std::collections::HashSet::new();
    // Per mesh: its triangles and its instances.
    let mut meshes: HashMap<MeshKey, (u64, u64)> = HashMap::new();
    while let Some(node) = stack.pop() {
        if !visited.insert(node.index()) {
            continue;
        }
        if let Some(mesh) = node.mesh() {
            let n: u64 = mesh.primitives().map(|p| primitive_triangles(&p)).sum();
            let copies = gpu_instancing::planned_count(doc, &node);
            plan.flattened = plan.flattened.saturating_add(n.saturating_mul(copies));
            plan.placed += copies;
            let uses = meshes.entry(mesh_key(&mesh)).or_insert((n, 0));
            uses.1 += copies;
        }
        stack.extend(node.children());
    }
    for (key, (n, uses)) in meshes {
        plan.unique = plan.unique.saturating_add(n);
        // A node may place no copy (an `EXT_mesh_gpu_instancing` accessor of count 0).
        let copies = n.saturating_mul(uses.saturating_sub(1));
        if copies >= SHARED_TRIANGLES {
            plan.shared.insert(key);
            plan.shared_copies = plan.shared_copies.saturating_add(copies);
            plan.shared_placed += uses;
        }
    }
    plan
}

/// Chooses which of `doc`'s placements to keep unflattened ([`Geometry::shared`], or every
/// one where the flattened scene would not fit), and refuses `path` when even kept they
/// would take the scene past `geometry.memory_limit` ([`BYTES_PER_TRIANGLE`] a triangle,
/// [`BYTES_PER_INSTANCE`] an instance): one line that says how much, before the memory is
/// spent (10,000 copies of an 82k-triangle mesh in a 3.5 MB file were killed by the OOM
/// killer after 82 s at 23.7 GB).
fn plan_instances(path: &Path, doc: &gltf::Document, geometry: &mut Geometry) -> Result<(), SceneError> {
    let plan = plan(doc);
    let (shared_copies, shared_placed) =
        if geometry.keep_shared { (plan.shared_copies, plan.shared_placed) } else { (0, 0) };
    geometry.shared = if geometry.keep_shared { plan.shared } else { Default::default() };
    let Some(limit) = geometry.memory_limit else { return Ok(()) };
    let Plan { flattened, placed, unique, .. } = plan;
    let loaded = geometry.triangles.len() as u64;
    let need = loaded
        .saturating_add(flattened.saturating_sub(shared_copies))
        .saturating_mul(BYTES_PER_TRIANGLE)
        .saturating_add(shared_placed * BYTES_PER_INSTANCE);
    if geometry.keep_instances || need <= limit {
        return Ok(());
    }
    // Kept: each mesh's triangles once, and every instance's transform and bounds.
    let kept =
        (loaded + unique).saturating_mul(BYTES_PER_TRIANGLE).saturating_add(placed * BYTES_PER_INSTANCE);
    if geometry.may_keep_instances && kept <= limit {
        geometry.keep_instances = true;
        return Ok(());
    }
    let total = loaded.saturating_add(flattened);
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    let size = |b: u64| {
        if b < 1 << 30 { format!("{} MiB", b.div_ceil(1 << 20)) } else { format!("{:.1} GiB", gib(b)) }
    };
    let kept_note = if geometry.may_keep_instances {
        format!(" (with each mesh stored once, {})", size(kept))
    } else {
        format!(
            "; with each mesh stored once it would need {}, but the chosen method needs every copy \
             flattened",
            size(kept)
        )
    };
    let need = total.saturating_mul(BYTES_PER_TRIANGLE);
    Err(SceneError::new(
        path,
        "nodes",
        format!(
            "the scene needs about {:.1} GiB to load and {:.1} GiB is available: {placed} instance(s) \
             (nodes and EXT_mesh_gpu_instancing copies) of meshes of {unique} distinct triangles, \
             {total} triangles once every instance is flattened, about {BYTES_PER_TRIANGLE} bytes \
             each{kept_note}",
            gib(need),
            gib(limit)
        ),
    ))
}

/// What a mesh's read primitives depend on: its [`MeshKey`], and per primitive what its
/// material reads and the accessors read for it.
type ReadKey = (MeshKey, Vec<AttributeKey>);

/// Loads the meshes of every node of `scene`, each under its world transform (the file's
/// node transforms after `model_from_file`). Returns the first perspective camera met.
fn load_nodes(
    file: &FileContext,
    scene: &gltf::Scene,
    model_from_file: DMat4,
    geometry: &mut Geometry,
) -> Result<Option<GltfCamera>, SceneError> {
    let mut camera = None;
    // Depth-first over the node tree; an explicit stack so deep hierarchies cannot overflow.
    let mut stack: Vec<(gltf::Node, DMat4, usize)> = scene.nodes().map(|n| (n, model_from_file, 0)).collect();
    stack.reverse();
    // The spec's nodes form disjoint trees: a node reached twice is shared or in a cycle, and
    // a chain of nodes each listing the next twice is 2^n visits (a hang, not an error).
    let mut visited = std::collections::HashSet::new();
    let mut met = MeshesMet::default();
    while let Some((node, parent, depth)) = stack.pop() {
        if !visited.insert(node.index()) {
            return Err(SceneError::new(
                file.path,
                format!("nodes[{}]", node.index()),
                "reached twice: a node may have one parent and appear in a scene once",
            ));
        }
        let world = node_world(file, &node, parent, depth)?;
        if camera.is_none()
            && let Some(cam) = node.camera()
            && let gltf::camera::Projection::Perspective(p) = cam.projection()
        {
            camera = Some(GltfCamera { world, yfov: p.yfov() as f64 });
        }
        if let Some(mesh) = node.mesh() {
            load_mesh_node(file, (&node, &mesh, world), &mut met, geometry)?;
        }
        continue_children(&node, world, depth, &mut stack);
    }
    Ok(camera)
}

/// `node`'s world transform under `parent`, at `depth` in the tree: an error for a
/// hierarchy deeper than 256, a transform that is not finite, or a singular one under a mesh.
fn node_world(
    file: &FileContext,
    node: &gltf::Node,
    parent: DMat4,
    depth: usize,
) -> Result<DMat4, SceneError> {
    let fail = |msg: &str| Err(SceneError::new(file.path, format!("nodes[{}]", node.index()), msg));
    if depth > 256 {
        return fail("node hierarchy deeper than 256 (a cycle?)");
    }
    let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
    let world = parent * local;
    if !world.is_finite() {
        return fail("transform is not finite");
    }
    // A mesh under a singular transform would lose all its area (every triangle dropped,
    // or a placement with no inverse for the ray's move into its space).
    if node.mesh().is_some() && world.determinant() == 0.0 {
        return fail("transform is singular (a zero scale): its mesh would have no area");
    }
    Ok(world)
}

/// The meshes met so far in a file's node walk.
#[derive(Default)]
struct MeshesMet {
    /// A mesh's accessors ([`MeshKey`]) -> the scene's mesh id.
    ids: HashMap<MeshKey, u32>,
    /// A mesh's primitives as read ([`ReadKey`]), for placements kept unflattened.
    kept: HashMap<ReadKey, KeptMesh>,
}

/// A mesh's primitives as read, shared by its kept placements, and their file-space bounds
/// (what [`Overflow::count_kept`] tests first).
type KeptMesh = (std::sync::Arc<Vec<PrimitiveData>>, (Vec3, Vec3));

/// [`place_mesh_node`], then a warning naming the node if its transform took triangles out
/// of f32's range (they are dropped).
fn load_mesh_node(
    file: &FileContext,
    placed: (&gltf::Node, &gltf::Mesh, DMat4),
    met: &mut MeshesMet,
    geometry: &mut Geometry,
) -> Result<(), SceneError> {
    place_mesh_node(file, placed, met, geometry)?;
    let overflow = std::mem::take(&mut geometry.overflow);
    geometry.overflowed += overflow.triangles;
    geometry.warnings.extend(overflow.warning(file.path, placed.0.index()));
    Ok(())
}

/// One node's mesh under `world`: its topology welded at its first use (later uses only add
/// an instance), then each placement (one, or `EXT_mesh_gpu_instancing`'s) either kept
/// unflattened or flattened into `geometry`'s triangles.
fn place_mesh_node(
    file: &FileContext,
    (node, mesh, world): (&gltf::Node, &gltf::Mesh, DMat4),
    met: &mut MeshesMet,
    geometry: &mut Geometry,
) -> Result<(), SceneError> {
    // Keyed by the accessors its triangles are read from, not by the mesh: files repeat one
    // geometry in meshes that differ only in material (metal-rough-spheres: 98 meshes, one
    // sphere).
    let key = mesh_key(mesh);
    let keep = geometry.keep_instances || geometry.shared.contains(&key);
    let known = met.ids.get(&key).copied();
    let mut topology = known.is_none().then(TopologyBuilder::default);
    let mesh_id = known.unwrap_or(geometry.meshes.len() as u32);
    // Kept instances read a mesh's primitives once (10,000 boulders' nodes would read 82k
    // triangles each). Their normals and texture coordinates too: meshes sharing positions
    // may differ there.
    let needs =
        |p: &gltf::Primitive| Needs::of(&geometry.materials[material_id(file, p) as usize], geometry.shading);
    let read_key: ReadKey = (key.clone(), mesh.primitives().map(|p| attribute_key(&p, needs(&p))).collect());
    let cached = if keep { met.kept.get(&read_key).cloned() } else { None };
    let mut read = Vec::new();
    if cached.is_none() {
        for prim in mesh.primitives() {
            read.extend(read_primitive(file, (mesh, &prim), &needs(&prim), topology.as_mut())?);
        }
    }
    if let Some(t) = topology {
        met.ids.insert(key, mesh_id);
        geometry.meshes.push(t.finish());
    }
    let placements = gpu_instancing::placements(file, node, world)?;
    if keep {
        let prims: Vec<gltf::Primitive> = mesh.primitives().filter(has_triangles).collect();
        let materials: std::sync::Arc<[u32]> = prims.iter().map(|p| material_id(file, p)).collect();
        let (data, bounds) = match cached {
            Some(d) => d,
            None => {
                let d = std::sync::Arc::new(read.into_iter().map(|r| r.data).collect::<Vec<_>>());
                let bounds = overflow::mesh_bounds(&d);
                met.kept.insert(read_key, (d.clone(), bounds));
                (d, bounds)
            }
        };
        for placed in placements {
            // The pass over kept instances drops these without counting them again.
            geometry.overflow.count_kept(&data, bounds, placed);
            let instance = geometry.instances.len() as u32;
            geometry.instances.push(Instance { mesh: mesh_id, mirrored: placed.determinant() < 0.0 });
            for (d, p) in data.iter().zip(&prims) {
                if geometry.gather_emitters {
                    geometry.emitters.extend(emitter_of(d, &p.material(), placed, file.path));
                }
                geometry.unlit.check_kept(d, &p.material(), placed, file.path);
            }
            let (primitives, materials) = (data.clone(), materials.clone());
            geometry.placements.push(Placement { primitives, world: placed, materials, instance });
        }
        return Ok(());
    }
    for placed in placements {
        let instance = geometry.instances.len() as u32;
        geometry.instances.push(Instance { mesh: mesh_id, mirrored: placed.determinant() < 0.0 });
        let mut origin = TriangleOrigin { instance, local: 0 };
        for prim in &read {
            place_primitive(prim, (placed, file.path), origin, geometry);
            origin.local += prim.triangles();
        }
    }
    Ok(())
}

/// Pushes `node`'s children (first child on top) for the depth-first walk.
fn continue_children<'a>(
    node: &gltf::Node<'a>,
    world: DMat4,
    depth: usize,
    stack: &mut Vec<(gltf::Node<'a>, DMat4, usize)>,
) {
    let children: Vec<_> = node.children().collect();
    for child in children.into_iter().rev() {
        stack.push((child, world, depth + 1));
    }
}

/// An accessor a primitive is read through: the key its errors name (after the primitive's),
/// the accessor if the primitive has it, and the element shape and component types gltf's
/// reader for it expects.
type AccessorSpec<'a> = (String, Option<gltf::Accessor<'a>>, Dimensions, &'static [DataType]);
