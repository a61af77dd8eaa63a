//! Building a [`Scene`] from a scene file: models and quads composed in f64, render space
//! centred on the camera, lights and camera placed in it, triangles f32 cannot hold dropped
//! and warned about, then the BVH.

use crate::geometry::attributes::TriangleExtras;
use crate::geometry::camera::Camera;
use crate::geometry::instances::{Instance, MeshTopology, TriangleOrigin};
use crate::geometry::light::RectLight;
use crate::geometry::material::{Material, Shading};
use crate::geometry::precision::f32_spacing;
use crate::geometry::scene::{LoadStats, Scene, TriangleShading, camera_frame_ok, cover_depth};
use crate::load::gltf_load::{Geometry, GltfCamera, SourceTriangle, UnlitEmitters, load_gltf};
use crate::load::precision_tally::PrecisionTally;
use crate::load::scene_file::{LightDesc, SceneFile};
use crate::util::error::SceneError;
use glam::{DMat4, DQuat, DVec3, Vec2, Vec3};
use obvhs::triangle::Triangle;
use rayon::prelude::*;
use std::path::Path;
use std::time::{Duration, Instant};

/// How a scene is loaded: the memory it may take and whether it may keep instances.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Bytes the load may use at its peak (`None`: no limit).
    pub memory_limit: Option<u64>,
    pub keep: KeepInstances,
}

/// Whether glTF placements of meshes may stay unflattened ([`crate::geometry::instanced`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum KeepInstances {
    /// Flatten every placement (what every shadow method but `traced` and `none` needs).
    #[default]
    Never,
    /// Keep the placements of a mesh whose copies beyond the first would hold at least
    /// `gltf_load::SHARED_TRIANGLES` flattened (flatten the rest), and every placement where
    /// the flattened scene would not fit in the memory limit.
    Shared,
    /// Keep them always (tests: the kept scene against the flattened one).
    Always,
}

/// Bytes of placed corners held for kept instances ([`crate::geometry::instanced::InstancedScene::corners`]): a
/// test then reads 36 bytes instead of placing three corners. metal-rough-spheres kept,
/// `traced` at N = 1024, 320x240: render 1.19x the flattened scene's (2.29 / 1.91 s),
/// where placing every corner took 1.5-1.6x (docs/notes/2026-11-28-instances.md). At most
/// an eighth of the memory limit and 1 GiB: a kept scene stays a small part of the machine
/// (10,000 boulders would hold 29 GB).
fn corner_budget(memory_limit: Option<u64>) -> u64 {
    memory_limit.map_or(1 << 30, |m| m / 8).min(1 << 30)
}

impl Scene {
    /// Loads a scene file: models, quads, camera, lights; builds the BVH.
    pub fn load(file: &SceneFile, scene_path: &Path) -> Result<Scene, SceneError> {
        Self::load_with(file, scene_path, LoadOptions::default())
    }

    /// [`Scene::load`] under `options`: a model whose flattened triangles would take the
    /// scene past the memory limit keeps its instances unflattened where the options allow
    /// it and they fit, else is refused (an error naming the file and how much it needs,
    /// before its buffers are read; see `gltf_load::BYTES_PER_TRIANGLE`).
    pub fn load_with(file: &SceneFile, scene_path: &Path, options: LoadOptions) -> Result<Scene, SceneError> {
        let t0 = Instant::now();
        let load_span = tracing::info_span!("load").entered();
        let mut geometry = Geometry {
            memory_limit: options.memory_limit,
            keep_instances: options.keep == KeepInstances::Always,
            keep_shared: options.keep == KeepInstances::Shared,
            may_keep_instances: options.keep != KeepInstances::Never,
            shading: file.materials.shading,
            gather_emitters: file.light.is_empty(),
            // Diffuse shading shows no emission: nothing to warn of.
            unlit: match file.materials.shading {
                Shading::Gltf => UnlitEmitters::new(&file.light),
                Shading::Diffuse => UnlitEmitters::default(),
            },
            ..Geometry::default()
        };
        let gltf_camera = load_models(file, scene_path, &mut geometry)?;
        for q in &file.quad {
            geometry.add_quad(DVec3::from(q.center), DVec3::from(q.u), DVec3::from(q.v), q.color);
        }

        // Render space is centred on the camera (world, f64): f32 is most precise where the
        // camera looks, and geometry far away cannot cost the visible part its precision.
        let world_offset = camera_world_position(file, gltf_camera.as_ref()).unwrap_or(DVec3::ZERO);
        // Kept instances' passes now: their world bounds place the lights as the flattened
        // scene's would, and the build reuses them.
        let passes = super::kept_instances::passes(&geometry.placements, world_offset);
        let (mut lo, mut hi) = world_bounds(&geometry.triangles);
        for p in &passes {
            (lo, hi) = (lo.min(p.world.0), hi.max(p.world.1));
        }
        let mut warnings = std::mem::take(&mut geometry.warnings);
        let extent = if lo.x <= hi.x { (hi - lo).length() } else { 0.0 };
        let lights = scene_lights(
            file,
            &geometry,
            (0.5 * (lo + hi), extent),
            world_offset,
            scene_path,
            &mut warnings,
        )?;
        warnings.extend(geometry.unlit.warnings());
        let camera = scene_camera(file, gltf_camera, world_offset, scene_path)?;
        let load = t0.elapsed();
        drop(load_span);

        let mut scene = Self::build_with(geometry, passes, lights, camera, world_offset, load);
        warnings.append(&mut scene.warnings);
        scene.warnings = warnings;
        Ok(scene)
    }

    /// Builds the BVH and the BVH-ordered arrays from loaded geometry (positions in world
    /// space, f64) and lights/camera already in render space (world minus `world_offset`,
    /// the camera's world position for `Scene::load`). Triangles that f32 cannot hold in
    /// render space are dropped, counted and named in `warnings`.
    pub fn build(
        geometry: Geometry,
        lights: Vec<RectLight>,
        camera: Camera,
        world_offset: DVec3,
        load: Duration,
    ) -> Scene {
        let passes = super::kept_instances::passes(&geometry.placements, world_offset);
        Self::build_with(geometry, passes, lights, camera, world_offset, load)
    }

    /// [`Scene::build`] with the kept instances' passes already made.
    fn build_with(
        geometry: Geometry,
        passes: Vec<super::kept_instances::Pass>,
        lights: Vec<RectLight>,
        camera: Camera,
        world_offset: DVec3,
        load: Duration,
    ) -> Scene {
        let Geometry {
            triangles: source,
            materials,
            textures,
            degenerate,
            overflowed,
            meshes,
            instances,
            placements,
            memory_limit,
            extras: source_extras,
            shading: shading_mode,
            ..
        } = geometry;
        let mut precision = PrecisionTally::default();
        precision.zero_area = degenerate;
        precision.overflowed = overflowed;
        // Kept instances first: the loader placed them before any quad or soup.
        let (instanced, kept_triangles) = super::kept_instances::build(
            placements,
            passes,
            (world_offset, corner_budget(memory_limit)),
            &mut precision,
        );
        let Flat { mut tris, mut shading, mut origins, mut extras } =
            flat_triangles(&source, source_extras, world_offset, &mut precision);
        let warnings = precision.warnings();
        let (lo, hi) = scene_bounds(&tris, instanced.as_ref());
        let t_bvh = Instant::now();
        let bvh_span = tracing::info_span!("bvh", triangles = tris.len()).entered();
        let bvh = crate::geometry::scene_bvh::build(&tris, &origins, &instances, &meshes).map(|mut bvh| {
            cover_depth(&mut bvh);
            // Reorder once so that leaves index our arrays directly; in parallel, order kept
            // (8.2 M triangles' arrays took ~1 s on one thread).
            let order = &bvh.primitive_indices;
            tris = order.par_iter().map(|&i| tris[i as usize]).collect();
            shading = order.par_iter().map(|&i| shading[i as usize]).collect();
            origins = order.par_iter().map(|&i| origins[i as usize]).collect();
            extras.reorder(order);
            bvh
        });
        drop(bvh_span);
        let bvh_time = t_bvh.elapsed();
        let any_alpha_test =
            materials.iter().any(|m| !matches!(m.alpha, crate::geometry::material::AlphaMode::Opaque));
        let stats = load_stats(load, bvh_time, tris.len() as u64 + kept_triangles, &precision);
        let normal_maps = shading_mode == Shading::Gltf
            && (!extras.tangent.is_empty() || instanced.as_ref().is_some_and(|i| i.any_tangents()));
        Scene {
            triangles: tris,
            shading,
            extras,
            origins,
            meshes,
            instances,
            materials,
            textures,
            bvh,
            instanced,
            bounds_min: lo,
            bounds_max: hi,
            lights,
            camera,
            world_offset,
            any_alpha_test,
            shading_mode,
            normal_maps,
            stats,
            warnings,
        }
    }
}

/// The flattened triangles in render space, in the loader's order, with their shading data,
/// origins and extra attributes.
struct Flat {
    tris: Vec<Triangle>,
    shading: Vec<TriangleShading>,
    origins: Vec<TriangleOrigin>,
    extras: TriangleExtras,
}

/// `source` (world, f64) in render space (less `world_offset`), those f32 cannot hold
/// dropped and counted in `precision`, with the extra attributes of those kept
/// (`source_extras`, by index in `source`: its values moved, not copied).
fn flat_triangles(
    source: &[SourceTriangle],
    mut source_extras: TriangleExtras,
    world_offset: DVec3,
    precision: &mut PrecisionTally,
) -> Flat {
    let mut flat = Flat {
        tris: Vec::with_capacity(source.len()),
        shading: Vec::with_capacity(source.len()),
        origins: Vec::with_capacity(source.len()),
        extras: TriangleExtras::default(),
    };
    // The source index of each triangle kept, where any has extra attributes.
    let mut kept = Vec::new();
    let any_extras = source_extras.bytes() > 0;
    for (i, s) in source.iter().enumerate() {
        let Some(face) = precision.keep(s.p, world_offset) else { continue };
        let p = s.p.map(|p| (p - world_offset).as_vec3());
        flat.tris.push(Triangle { v0: p[0].into(), v1: p[1].into(), v2: p[2].into() });
        flat.shading.push(TriangleShading { n: s.n.unwrap_or([face; 3]), uv: s.uv, material: s.material });
        flat.origins.push(s.origin);
        if any_extras {
            kept.push(i as u32);
        }
    }
    if any_extras {
        source_extras.finish(source.len());
        source_extras.reorder(&kept);
        flat.extras = source_extras;
    }
    flat
}

/// What loading cost and what it dropped or found imprecise.
fn load_stats(load: Duration, bvh: Duration, triangles: u64, precision: &PrecisionTally) -> LoadStats {
    LoadStats {
        load,
        bvh,
        triangles,
        degenerate_triangles: precision.zero_area
            + precision.collapsed
            + precision.out_of_range
            + precision.overflowed,
        zero_area: precision.zero_area,
        collapsed_in_f32: precision.collapsed,
        beyond_f32_range: precision.out_of_range + precision.overflowed,
        imprecise_triangles: precision.imprecise,
    }
}

/// The render-space box around the flattened triangles and the kept instances' placements
/// (zero for an empty scene).
fn scene_bounds(
    tris: &[Triangle],
    instanced: Option<&crate::geometry::instanced::InstancedScene>,
) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in tris {
        for v in [t.v0, t.v1, t.v2] {
            lo = lo.min(v.into());
            hi = hi.max(v.into());
        }
    }
    for p in instanced.iter().flat_map(|i| &i.placed) {
        lo = lo.min(p.bounds.min.into());
        hi = hi.max(p.bounds.max.into());
    }
    if tris.is_empty() && instanced.is_none() {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    (lo, hi)
}

impl Geometry {
    /// Adds a rectangle (two triangles, corners `center +- u/2 +- v/2`, front face along
    /// u x v) with its own diffuse material.
    pub fn add_quad(&mut self, center: DVec3, u: DVec3, v: DVec3, color: [f32; 3]) {
        self.materials.push(Material::diffuse(color));
        let material = self.materials.len() as u32 - 1;
        // A mesh of its own: corners 0 1 2 3 as p00 p10 p11 p01.
        let instance = self.instances.len() as u32;
        self.instances.push(Instance { mesh: self.meshes.len() as u32, mirrored: false });
        self.meshes.push(MeshTopology { vertices: 4, corners: vec![[0, 1, 2], [0, 2, 3]] });
        let corner = |a: f64, b: f64| center + a * u + b * v;
        let (p00, p10, p11, p01) =
            (corner(-0.5, -0.5), corner(0.5, -0.5), corner(0.5, 0.5), corner(-0.5, 0.5));
        for (local, p, uv) in [
            (0, [p00, p10, p11], [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)]),
            (1, [p00, p11, p01], [Vec2::new(0.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]),
        ] {
            let origin = TriangleOrigin { instance, local };
            self.triangles.push(SourceTriangle { p, n: None, uv, material, origin });
        }
    }
}

/// The camera's world position: the render-space origin. `None` when the scene file asks for
/// a glTF camera the model lacks (`scene_camera` reports that).
fn camera_world_position(file: &SceneFile, gltf_camera: Option<&GltfCamera>) -> Option<DVec3> {
    if file.camera.from_gltf {
        gltf_camera.map(|c| c.world.transform_point3(DVec3::ZERO))
    } else {
        file.camera.position.map(DVec3::from)
    }
}

/// Loads every `[[model]]` into `geometry`, each scaled, turned about y and moved as its
/// table says. Returns the first model's glTF camera, if it has one.
fn load_models(
    file: &SceneFile,
    scene_path: &Path,
    geometry: &mut Geometry,
) -> Result<Option<GltfCamera>, SceneError> {
    let mut gltf_camera = None;
    for (i, m) in file.model.iter().enumerate() {
        let path = SceneFile::resolve(scene_path, &m.path);
        if let Some(problem) = not_a_model_file(&path) {
            return Err(SceneError::new(scene_path, format!("model[{i}].path"), problem));
        }
        let model_from_file = DMat4::from_scale_rotation_translation(
            DVec3::splat(m.scale),
            DQuat::from_rotation_y(m.rotate_y_deg.to_radians()),
            DVec3::from(m.translate),
        );
        let cam = load_gltf(&path, model_from_file, geometry)?;
        if i == 0 {
            gltf_camera = cam;
        }
    }
    Ok(gltf_camera)
}

/// Why `path` cannot be a model file, or `None` when it is a file. A folder gets its own
/// message (it was reported as "no such file", which sent users looking for a typo), naming
/// the glTF files inside it when there are any.
fn not_a_model_file(path: &Path) -> Option<String> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => None,
        Ok(m) if m.is_dir() => {
            let mut inside: Vec<String> = std::fs::read_dir(path)
                .into_iter()
                .flatten()
                .flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".gltf") || n.ends_with(".glb"))
                .collect();
            inside.sort();
            let hint =
                if inside.is_empty() { String::new() } else { format!(" (it holds {})", inside.join(", ")) };
            Some(format!("{} is a directory, not a .gltf or .glb file{hint}", path.display()))
        }
        Ok(_) => Some(format!("{} is not a regular file", path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            Some(format!("no such file: {}", path.display()))
        }
        Err(e) => Some(format!("cannot read {}: {e}", path.display())),
    }
}

/// The (min, max) corners of the triangles' world positions; (+inf, -inf) without any.
fn world_bounds(triangles: &[SourceTriangle]) -> (DVec3, DVec3) {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for t in triangles {
        for p in t.p {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (lo, hi)
}

/// Why a light cannot be placed in render space: the message, whether the camera's distance
/// is to blame (the light would be fine near the camera), and the edge that is too short
/// (`"u"` or `"v"`).
pub struct LightPlacement {
    pub message: String,
    pub camera_too_far: bool,
    pub edge: &'static str,
}

/// The light `l` in render space (world minus `world_offset`), or why f32 cannot hold it
/// there. Its centre and edges are kept, and what it sends is measured from each point in
/// f64 ([`RectLight::corners_from`]), so its size and power survive at any distance; but its
/// centre, like every position there, is an f32 position spaced s = [`f32_spacing`] of its
/// distance d from the camera, and so are the shading points around it: an edge shorter than
/// s is finer than a position there resolves (the light would move by more than its size), so
/// each edge must be at least s (2.4e-7 m at 2.6 m; a 1e-30 m light is refused anywhere but
/// at the camera). Where the light would be fine near the camera and the camera is over 10x
/// the scene's extent `scene_extent` (world, m) away from it (a 0.5 m light 10^7 m from the
/// camera, where s is 1 m), the camera's distance is the culprit, and the message says so.
pub fn light_in_render_space(
    l: &LightDesc,
    world_offset: DVec3,
    scene_extent: f64,
) -> Result<RectLight, LightPlacement> {
    let centre = DVec3::from(l.center) - world_offset;
    let (u, v) = (DVec3::from(l.u), DVec3::from(l.v));
    let light = RectLight::new(centre.as_vec3(), u.as_vec3(), v.as_vec3(), Vec3::from(l.radiance));
    let (d, lu, lv) = (centre.length(), u.length(), v.length());
    let spacing = f32_spacing(d);
    if lu.min(lv) >= spacing && light.normal.is_finite() {
        return Ok(light);
    }
    let edge = if lu <= lv { "u" } else { "v" };
    let fine_nearby = light.normal.is_finite();
    let camera_too_far = fine_nearby && d > 10.0 * (scene_extent + lu + lv);
    let message = if camera_too_far {
        format!(
            "the camera is {d:.3e} m from the light ({lu:.3e} x {lv:.3e} m), where f32 positions are spaced \
             {spacing:.3e} m: render space is centred on the camera, so the light's edges must be at least \
             that long there; move the camera nearer the scene",
        )
    } else {
        format!(
            "the light ({lu:.3e} x {lv:.3e} m) is too small for f32 at its distance from the camera \
             ({d:.3e} m, where f32 positions are spaced {spacing:.3e} m): a position there cannot resolve \
             it, so each edge must be at least {spacing:.3e} m",
        )
    };
    Err(LightPlacement { message, camera_too_far, edge })
}

/// The lights in render space (world minus `world_offset`): the scene file's, or else the
/// emissive rectangles of the models ([`super::emitter_lights`]; `scene_centre` in world
/// space, `scene_extent` the geometry's diagonal).
fn scene_lights(
    file: &SceneFile,
    geometry: &Geometry,
    (scene_centre, scene_extent): (DVec3, f64),
    world_offset: DVec3,
    scene_path: &Path,
    warnings: &mut Vec<String>,
) -> Result<Vec<RectLight>, SceneError> {
    if !file.light.is_empty() {
        return file
            .light
            .iter()
            .enumerate()
            .map(|(k, l)| {
                light_in_render_space(l, world_offset, scene_extent).map_err(|e| {
                    let key = match (e.camera_too_far, file.camera.from_gltf) {
                        (false, _) => format!("light[{k}].{}", e.edge),
                        (true, false) => "camera.position".to_string(),
                        (true, true) => "camera.from_gltf".to_string(),
                    };
                    SceneError::new(scene_path, key, e.message)
                })
            })
            .collect();
    }
    super::emitter_lights::emitter_lights(
        geometry,
        (scene_centre, scene_extent),
        world_offset,
        scene_path,
        warnings,
    )
}

/// The camera in render space (world minus `world_offset`): the first model's glTF camera
/// when `camera.from_gltf`, else the scene file's.
fn scene_camera(
    file: &SceneFile,
    gltf_camera: Option<GltfCamera>,
    world_offset: DVec3,
    scene_path: &Path,
) -> Result<Camera, SceneError> {
    let to_render = |p: DVec3| (p - world_offset).as_vec3();
    if file.camera.from_gltf {
        let Some(cam) = gltf_camera else {
            return Err(SceneError::new(
                scene_path,
                "camera.from_gltf",
                format!("{} has no perspective camera", file.model[0].path.display()),
            ));
        };
        let position = to_render(cam.world.transform_point3(DVec3::ZERO));
        let forward = cam.world.transform_vector3(DVec3::NEG_Z).as_vec3();
        let up = cam.world.transform_vector3(DVec3::Y).as_vec3();
        if !camera_frame_ok(position, forward, up) {
            return Err(SceneError::new(
                scene_path,
                "camera.from_gltf",
                "the glTF camera's transform is degenerate, or out of f32's range",
            ));
        }
        Ok(Camera::from_frame(position, forward, up, cam.yfov as f32))
    } else {
        let c = &file.camera;
        let (Some(pos), Some(at)) = (c.position, c.look_at) else {
            unreachable!("checked by SceneFile::validate")
        };
        // The view direction in f64: at 1e-20 m its f32 length would underflow.
        let forward = (DVec3::from(at) - DVec3::from(pos)).normalize().as_vec3();
        Ok(Camera::from_frame(
            to_render(DVec3::from(pos)),
            forward,
            DVec3::from(c.up).normalize().as_vec3(),
            (c.yfov_deg as f32).to_radians(),
        ))
    }
}
