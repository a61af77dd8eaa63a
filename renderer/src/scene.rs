//! The runtime scene: triangles in BVH order with their shading attributes, materials,
//! textures, lights and camera; closest-hit and occlusion queries with the alpha test; and
//! the one rule for ray origins and shadow epsilons.

use crate::camera::Camera;
use crate::config::{LightDesc, SceneFile, validate_light};
use crate::error::SceneError;
use crate::gltf_load::{EmitterCandidate, Geometry, SourceTriangle, load_gltf};
use crate::light::RectLight;
use crate::material::{Material, Texture};
use glam::{DMat4, DQuat, DVec3, Vec2, Vec3, Vec3A};
use obvhs::{BvhBuildParams, bvh2::Bvh2, ray::Ray, triangle::Triangle};
use std::path::Path;
use std::time::{Duration, Instant};

/// Per-triangle shading data, stored in BVH order next to `Scene::triangles`.
#[derive(Debug, Clone, Copy)]
pub struct TriangleShading {
    /// Vertex normals (world, unit); the face normal three times when the file has none.
    pub n: [Vec3; 3],
    pub uv: [Vec2; 3],
    pub material: u32,
}

/// A closest hit: where, with which normals (both facing the side the ray came from).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    pub t: f32,
    pub p: Vec3,
    /// Unit geometric normal, on the side of the incoming ray.
    pub n_geom: Vec3,
    /// Unit interpolated normal, flipped to the same side as `n_geom`.
    pub n_shading: Vec3,
    pub uv: Vec2,
    pub material: u32,
    /// Index into the BVH-ordered triangle arrays.
    pub triangle: u32,
    /// Whether the ray met the triangle's front (the side its counter-clockwise winding
    /// faces, as glTF defines it). Closed meshes are entered through front faces and left
    /// through back faces, which is how a depth map tells their interiors.
    pub front_face: bool,
}

/// The scene-scaled epsilon rule for ray origins and shadow-ray ends, written once.
///
/// Every ray leaving a surface starts at `p + eps * n_geom` (on the side it travels to), and
/// every shadow ray stops `eps` short of its target. `eps` is `RELATIVE` times the diagonal of
/// the scene's bounding box: the scene is recentred at load time, so |p| never exceeds the
/// diagonal and f32 rounding of positions is at most 2^-24 of it, ~170x below `eps`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayEpsilon {
    pub eps: f32,
}

impl RayEpsilon {
    pub const RELATIVE: f32 = 1e-5;

    pub fn for_extent(diagonal: f32) -> Self {
        let diagonal = if diagonal.is_finite() && diagonal > 0.0 { diagonal } else { 1.0 };
        Self { eps: Self::RELATIVE * diagonal }
    }

    /// Origin for a ray from surface point `p` (geometric normal `n_geom`) toward `target`.
    #[inline]
    pub fn origin_toward(&self, p: Vec3, n_geom: Vec3, target: Vec3) -> Vec3 {
        let side = if n_geom.dot(target - p) >= 0.0 { 1.0 } else { -1.0 };
        p + (side * self.eps) * n_geom
    }

    /// A shadow ray from surface point `p` to `target`, stopping `eps` short of it.
    /// `direction` is unit length, so `t` is a distance.
    #[inline]
    pub fn shadow_ray(&self, p: Vec3, n_geom: Vec3, target: Vec3) -> Option<Ray> {
        let origin = self.origin_toward(p, n_geom, target);
        let d = target - origin;
        let dist = d.length();
        let tmax = dist - self.eps;
        if tmax.is_nan() || tmax <= 0.0 {
            return None;
        }
        Some(Ray::new(Vec3A::from(origin), Vec3A::from(d / dist), 0.0, tmax))
    }
}

/// Timings and counts of a scene load.
#[derive(Debug, Clone, Copy, Default)]
pub struct LoadStats {
    pub load: Duration,
    pub bvh: Duration,
    pub triangles: u64,
    pub degenerate_triangles: u64,
}

pub struct Scene {
    /// In BVH order: `bvh` leaves index these directly.
    pub triangles: Vec<Triangle>,
    pub shading: Vec<TriangleShading>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// `None` for a scene without triangles (every ray misses).
    pub bvh: Option<Bvh2>,
    /// Bounds of all triangles (render space).
    pub bounds_min: Vec3,
    pub bounds_max: Vec3,
    pub lights: Vec<RectLight>,
    pub camera: Camera,
    pub epsilon: RayEpsilon,
    /// World position of the render-space origin: world = render + world_offset. The scene is
    /// recentred so that f32 keeps its precision far from the world origin.
    pub world_offset: DVec3,
    /// Whether any material has an alpha test (lets occlusion skip the material lookup).
    pub any_alpha_test: bool,
    pub stats: LoadStats,
}

/// Whether a camera frame in render space makes a camera: a finite position, and a view
/// direction and up vector that give a right vector in f32 (as [`Camera::from_frame`]
/// computes it). The scene file checks its camera in f64; recentring on the models can put
/// position and look_at on one f32 value, or out of f32's range (found by fuzzing).
fn camera_frame_ok(position: Vec3, forward: Vec3, up: Vec3) -> bool {
    position.is_finite() && forward.try_normalize().and_then(|f| f.cross(up).try_normalize()).is_some()
}

/// Raises `bvh.max_depth` to the tree's depth. obvhs sizes its traversal stacks by it, and its
/// build can leave it below the real depth after reinsertion (found by fuzzing: 143 levels,
/// max_depth 127, caught by obvhs's debug validation); a push past a fixed stack is clamped
/// there, dropping a subtree: missed hits.
fn cover_depth(bvh: &mut Bvh2) {
    let mut depth = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        depth = depth.max(d);
        let node = &bvh.nodes[i];
        if node.prim_count == 0 {
            let first = node.first_index as usize;
            stack.extend([(first, d + 1), (first + 1, d + 1)]);
        }
    }
    bvh.max_depth = bvh.max_depth.max(depth + 1);
}

/// The BVH build preset. Bvh2 (not CwBvh): CwBvh clamps t to >= 1e-4 in world units, which
/// misses contact occluders in millimetre-scale scenes, and it is not faster for the
/// pixel-ordered rays we trace (see ARCHITECTURE.md and `benches/traced_shadows.rs`).
pub fn bvh_params() -> BvhBuildParams {
    BvhBuildParams::medium_build()
}

impl Scene {
    /// Loads a scene file: models, quads, camera, lights; builds the BVH.
    pub fn load(file: &SceneFile, scene_path: &Path) -> Result<Scene, SceneError> {
        let t0 = Instant::now();
        let mut geometry = Geometry::default();
        let mut gltf_camera = None;
        for (i, m) in file.model.iter().enumerate() {
            let path = SceneFile::resolve(scene_path, &m.path);
            if !path.is_file() {
                return Err(SceneError::new(
                    scene_path,
                    format!("model[{i}].path"),
                    format!("no such file: {}", path.display()),
                ));
            }
            let model_from_file = DMat4::from_scale_rotation_translation(
                DVec3::splat(m.scale),
                DQuat::from_rotation_y(m.rotate_y_deg.to_radians()),
                DVec3::from(m.translate),
            );
            let cam = load_gltf(&path, model_from_file, &mut geometry)?;
            if i == 0 {
                gltf_camera = cam;
            }
        }
        for q in &file.quad {
            geometry.add_quad(DVec3::from(q.center), DVec3::from(q.u), DVec3::from(q.v), q.color);
        }

        // Bounds in f64 world space; the render space is centred on them.
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for t in &geometry.triangles {
            for p in t.p {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        let world_offset = if geometry.triangles.is_empty() { DVec3::ZERO } else { 0.5 * (lo + hi) };
        let to_render = |p: DVec3| (p - world_offset).as_vec3();

        // Lights: the scene file's, or else the emissive rectangles of the models.
        let lights: Vec<RectLight> = if !file.light.is_empty() {
            file.light
                .iter()
                .map(|l| {
                    RectLight::new(
                        to_render(DVec3::from(l.center)),
                        DVec3::from(l.u).as_vec3(),
                        DVec3::from(l.v).as_vec3(),
                        Vec3::from(l.radiance),
                    )
                })
                .collect()
        } else {
            let centre = 0.5 * (lo + hi);
            let mut found = Vec::new();
            for e in &geometry.emitters {
                if let Some(desc) = rectangle_light(e, centre)
                    && validate_light(&desc, "emitter", scene_path).is_ok()
                {
                    found.push(RectLight::new(
                        to_render(DVec3::from(desc.center)),
                        DVec3::from(desc.u).as_vec3(),
                        DVec3::from(desc.v).as_vec3(),
                        Vec3::from(desc.radiance),
                    ));
                }
            }
            if found.is_empty() {
                return Err(SceneError::new(
                    scene_path,
                    "light",
                    "no [[light]] given and the models have no emissive rectangles",
                ));
            }
            found
        };

        let camera = if file.camera.from_gltf {
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
                    "the glTF camera's transform is degenerate, or out of f32's range once the scene is centred on the models",
                ));
            }
            Camera::from_frame(position, forward, up, cam.yfov as f32)
        } else {
            let c = &file.camera;
            let (Some(pos), Some(at)) = (c.position, c.look_at) else {
                unreachable!("checked by SceneFile::validate")
            };
            let (position, look_at, up) =
                (to_render(DVec3::from(pos)), to_render(DVec3::from(at)), DVec3::from(c.up).as_vec3());
            if !camera_frame_ok(position, look_at - position, up) {
                return Err(SceneError::new(
                    scene_path,
                    "camera",
                    format!(
                        "position, look_at and up give no view in f32 once the scene is centred on \
                         the models (at {:.3e}, {:.3e}, {:.3e}): the camera is too far from them, or \
                         their coordinates too large",
                        world_offset.x, world_offset.y, world_offset.z
                    ),
                ));
            }
            Camera::look_at(position, look_at, up, c.yfov_deg as f32)
        };
        let load = t0.elapsed();

        let scene = Self::build(geometry, lights, camera, world_offset, load);
        Ok(scene)
    }

    /// Builds the BVH and the BVH-ordered arrays from loaded geometry (positions in world
    /// space, f64) and lights/camera already in render space.
    pub fn build(
        geometry: Geometry,
        lights: Vec<RectLight>,
        camera: Camera,
        world_offset: DVec3,
        load: Duration,
    ) -> Scene {
        let Geometry { triangles: source, materials, textures, degenerate, .. } = geometry;
        let mut tris = Vec::with_capacity(source.len());
        let mut shading = Vec::with_capacity(source.len());
        let mut degenerate = degenerate;
        for s in &source {
            let p = s.p.map(|p| (p - world_offset).as_vec3());
            let face = (p[1] - p[0]).cross(p[2] - p[0]);
            if face.length_squared() == 0.0 || !face.is_finite() {
                degenerate += 1; // non-degenerate in f64 but collapsed in f32
                continue;
            }
            let face = face.normalize();
            tris.push(Triangle { v0: p[0].into(), v1: p[1].into(), v2: p[2].into() });
            shading.push(TriangleShading { n: s.n.unwrap_or([face; 3]), uv: s.uv, material: s.material });
        }
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for t in &tris {
            for v in [t.v0, t.v1, t.v2] {
                lo = lo.min(v.into());
                hi = hi.max(v.into());
            }
        }
        if tris.is_empty() {
            (lo, hi) = (Vec3::ZERO, Vec3::ZERO);
        }
        // Lights and the camera count toward the extent that scales epsilons.
        let (mut elo, mut ehi) = (lo, hi);
        for l in &lights {
            for c in l.corners() {
                elo = elo.min(c);
                ehi = ehi.max(c);
            }
        }
        let epsilon = RayEpsilon::for_extent((ehi - elo).length());

        let t_bvh = Instant::now();
        let bvh = if tris.is_empty() {
            None
        } else {
            let mut bvh =
                obvhs::bvh2::builder::build_bvh2_from_tris(&tris, bvh_params(), &mut Duration::default());
            cover_depth(&mut bvh);
            // Reorder once so that leaves index our arrays directly.
            tris = bvh.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
            shading = bvh.primitive_indices.iter().map(|&i| shading[i as usize]).collect();
            Some(bvh)
        };
        let bvh_time = t_bvh.elapsed();
        let any_alpha_test = materials.iter().any(|m| !matches!(m.alpha, crate::material::AlphaMode::Opaque));
        let stats =
            LoadStats { load, bvh: bvh_time, triangles: tris.len() as u64, degenerate_triangles: degenerate };
        Scene {
            triangles: tris,
            shading,
            materials,
            textures,
            bvh,
            bounds_min: lo,
            bounds_max: hi,
            lights,
            camera,
            epsilon,
            world_offset,
            any_alpha_test,
            stats,
        }
    }

    /// Möller-Trumbore with barycentrics (obvhs's `compute_barycentric` is mis-scaled, see
    /// deps.md): returns (t, b1, b2) for a hit within [tmin, tmax].
    #[inline]
    fn intersect_triangle(tri: &Triangle, ray: &Ray) -> Option<(f32, f32, f32)> {
        let e1 = tri.v1 - tri.v0;
        let e2 = tri.v2 - tri.v0;
        let pvec = ray.direction.cross(e2);
        let det = e1.dot(pvec);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let tvec = ray.origin - tri.v0;
        let b1 = tvec.dot(pvec) * inv;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let qvec = tvec.cross(e1);
        let b2 = ray.direction.dot(qvec) * inv;
        if b2 < 0.0 || b1 + b2 > 1.0 {
            return None;
        }
        let t = e2.dot(qvec) * inv;
        (t >= ray.tmin && t <= ray.tmax).then_some((t, b1, b2))
    }

    #[inline]
    fn uv_at(&self, slot: usize, b1: f32, b2: f32) -> Vec2 {
        let uv = &self.shading[slot].uv;
        (1.0 - b1 - b2) * uv[0] + b1 * uv[1] + b2 * uv[2]
    }

    /// The primitive test shared by closest-hit and occlusion: a hit that the alpha test
    /// does not cut out.
    #[inline]
    fn hit_distance(&self, ray: &Ray, slot: usize) -> f32 {
        match Self::intersect_triangle(&self.triangles[slot], ray) {
            None => f32::INFINITY,
            Some((t, b1, b2)) => {
                if self.any_alpha_test {
                    let m = &self.materials[self.shading[slot].material as usize];
                    if m.is_cutout(self.uv_at(slot, b1, b2), &self.textures) {
                        return f32::INFINITY;
                    }
                }
                t
            }
        }
    }

    /// Closest hit along `ray` (alpha test honoured).
    pub fn intersect(&self, ray: Ray) -> Option<SurfaceHit> {
        let bvh = self.bvh.as_ref()?;
        let mut hit = obvhs::ray::RayHit::none();
        if !bvh.ray_traverse(ray, &mut hit, |r, slot| self.hit_distance(r, slot)) {
            return None;
        }
        let slot = hit.primitive_id as usize;
        let tri = &self.triangles[slot];
        let (_, b1, b2) =
            Self::intersect_triangle(tri, &Ray { tmin: f32::NEG_INFINITY, tmax: f32::INFINITY, ..ray })?;
        let p = Vec3::from(ray.origin + hit.t * ray.direction);
        let d = Vec3::from(ray.direction);
        let mut n_geom = Vec3::from((tri.v1 - tri.v0).cross(tri.v2 - tri.v0)).normalize();
        let front_face = n_geom.dot(d) < 0.0;
        if !front_face {
            n_geom = -n_geom;
        }
        let sh = &self.shading[slot];
        let mut n_shading = ((1.0 - b1 - b2) * sh.n[0] + b1 * sh.n[1] + b2 * sh.n[2]).normalize_or_zero();
        if n_shading == Vec3::ZERO {
            n_shading = n_geom;
        }
        if n_shading.dot(n_geom) < 0.0 {
            n_shading = -n_shading;
        }
        Some(SurfaceHit {
            t: hit.t,
            p,
            n_geom,
            n_shading,
            uv: self.uv_at(slot, b1, b2),
            material: sh.material,
            triangle: slot as u32,
            front_face,
        })
    }

    /// Whether anything (alpha test honoured) lies on `ray` within [tmin, tmax]: an any-hit
    /// query that stops at the first hit.
    #[inline]
    pub fn occluded(&self, ray: Ray) -> bool {
        match &self.bvh {
            None => false,
            Some(bvh) => !bvh.ray_traverse_miss(ray, |r, slot| self.hit_distance(r, slot)),
        }
    }

    /// Whether the segment from surface point `p` (geometric normal `n_geom`) to `target` is
    /// blocked, with the scene's epsilon rule at both ends.
    #[inline]
    pub fn segment_occluded(&self, p: Vec3, n_geom: Vec3, target: Vec3) -> bool {
        match self.epsilon.shadow_ray(p, n_geom, target) {
            Some(ray) => self.occluded(ray),
            None => false,
        }
    }

    /// The albedo (linear RGB) at a hit.
    pub fn albedo(&self, hit: &SurfaceHit) -> Vec3 {
        self.materials[hit.material as usize].base_color_at(hit.uv, &self.textures).truncate()
    }
}

impl Geometry {
    /// Adds a rectangle (two triangles, corners `center +- u/2 +- v/2`, front face along
    /// u x v) with its own diffuse material.
    pub fn add_quad(&mut self, center: DVec3, u: DVec3, v: DVec3, color: [f32; 3]) {
        self.materials.push(Material::diffuse(color));
        let material = self.materials.len() as u32 - 1;
        let corner = |a: f64, b: f64| center + a * u + b * v;
        let (p00, p10, p11, p01) =
            (corner(-0.5, -0.5), corner(0.5, -0.5), corner(0.5, 0.5), corner(-0.5, 0.5));
        for (p, uv) in [
            ([p00, p10, p11], [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)]),
            ([p00, p11, p01], [Vec2::new(0.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]),
        ] {
            self.triangles.push(SourceTriangle { p, n: None, uv, material });
        }
    }
}

/// Fits a rectangle to an emissive primitive: the smallest-area rectangle aligned with one
/// of its triangle edges that contains every vertex, accepted when the triangles are
/// coplanar and their total area equals the rectangle's (to 0.1%).
fn rectangle_light(e: &EmitterCandidate, scene_centre: DVec3) -> Option<LightDesc> {
    let mut normal = DVec3::ZERO;
    let mut area = 0.0;
    for t in &e.triangles {
        let c = (t[1] - t[0]).cross(t[2] - t[0]);
        normal += c;
        area += 0.5 * c.length();
    }
    let normal = normal.try_normalize()?;
    let origin = e.triangles[0][0];
    let scale = e.triangles.iter().flatten().map(|p| (*p - origin).length()).fold(0.0, f64::max);
    if e.triangles.iter().flatten().any(|p| (*p - origin).dot(normal).abs() > 1e-4 * scale) {
        return None; // not planar
    }
    let mut best: Option<(f64, DVec3, DVec3, DVec3)> = None;
    for t in e.triangles.iter().take(16) {
        for k in 0..3 {
            let Some(a) = (t[(k + 1) % 3] - t[k]).reject_from(normal).try_normalize() else { continue };
            let b = normal.cross(a);
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in e.triangles.iter().flatten() {
                let d = *p - origin;
                let (x, y) = (d.dot(a), d.dot(b));
                lo = [lo[0].min(x), lo[1].min(y)];
                hi = [hi[0].max(x), hi[1].max(y)];
            }
            let rect_area = (hi[0] - lo[0]) * (hi[1] - lo[1]);
            if best.is_none_or(|(best_area, ..)| rect_area < best_area) {
                let centre = origin + a * 0.5 * (lo[0] + hi[0]) + b * 0.5 * (lo[1] + hi[1]);
                best = Some((rect_area, centre, a * (hi[0] - lo[0]), b * (hi[1] - lo[1])));
            }
        }
    }
    let (rect_area, center, mut u, v) = best?;
    if rect_area.is_nan() || rect_area <= 0.0 || (rect_area - area).abs() > 1e-3 * rect_area {
        return None;
    }
    // Emit toward the front face; a double-sided emitter faces the scene's centre.
    let mut facing = normal;
    if e.double_sided && (scene_centre - center).dot(facing) < 0.0 {
        facing = -facing;
    }
    if u.cross(v).dot(facing) < 0.0 {
        u = -u;
    }
    Some(LightDesc {
        center: center.to_array(),
        u: u.to_array(),
        v: v.to_array(),
        radiance: e.radiance.to_array(),
    })
}
