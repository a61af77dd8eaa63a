//! The runtime scene: triangles in BVH order with their shading attributes, materials,
//! textures, lights and camera; closest-hit and occlusion queries with the alpha test; and
//! the hit's own error bound that the one rule for ray origins uses ([`crate::ray_origin`]).

use crate::camera::Camera;
use crate::config::{LightDesc, SceneFile, validate_light};
use crate::error::SceneError;
use crate::gltf_load::{EmitterCandidate, Geometry, GltfCamera, SourceTriangle, load_gltf};
use crate::light::RectLight;
use crate::material::{Material, Texture};
use crate::ray_origin::{interpolation_error, shadow_ray, shadow_ray_from};
use glam::{DMat4, DQuat, DVec3, Vec2, Vec3};
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
    /// The hit point, interpolated from the triangle's vertices (not `o + t d`).
    pub p: Vec3,
    /// A bound on `p`'s own rounding, per component ([`interpolation_error`]): the one rule
    /// for ray origins offsets by it ([`crate::ray_origin::offset_origin`]).
    pub p_error: Vec3,
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

/// Timings and counts of a scene load.
#[derive(Debug, Clone, Copy, Default)]
pub struct LoadStats {
    pub load: Duration,
    pub bvh: Duration,
    pub triangles: u64,
    /// Every triangle dropped at load: `zero_area + collapsed_in_f32 + beyond_f32_range`.
    pub degenerate_triangles: u64,
    /// Zero area relative to the triangle's own size (repeated or collinear vertices).
    pub zero_area: u64,
    /// A real triangle whose f32 render-space vertices coincide or fall on a line: too small
    /// for f32 at its distance from the camera.
    pub collapsed_in_f32: u64,
    /// A vertex farther from the camera than f32 can hold (3.4e38).
    pub beyond_f32_range: u64,
    /// Kept triangles whose f32 spacing at their distance from the camera exceeds
    /// 1/`SHAPE_PRECISION` of their size.
    pub imprecise_triangles: u64,
}

/// A triangle is zero-area when the sine of the angle between two of its edges is at most
/// this: relative to its own size, so a 1e-20 m and a 1e20 m triangle are both real.
pub const DEGENERATE_SINE: f64 = 1e-12;

/// A kept triangle is flagged imprecise when f32's spacing at its distance from the camera
/// is more than 1/`SHAPE_PRECISION` of its longest edge: its corners then move by more than
/// 0.2% of its size, a visible step once it spans a few hundred pixels.
pub const SHAPE_PRECISION: f64 = 256.0;

/// Whether the triangle `p` has zero area relative to its own size:
/// `|e1 x e2| <= DEGENERATE_SINE |e1| |e2|`, on edges scaled to unit size first so that
/// neither tiny nor huge triangles under- or overflow. Non-finite corners count as degenerate.
pub fn is_degenerate(p: [DVec3; 3]) -> bool {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let m = e1.abs().max_element().max(e2.abs().max_element());
    if !(m > 0.0 && m.is_finite()) {
        return true;
    }
    let (e1, e2) = (e1 / m, e2 / m);
    // Edges are finite here, so neither side is NaN.
    e1.cross(e2).length() <= DEGENERATE_SINE * e1.length() * e2.length()
}

/// The distance between neighbouring f32 values at distance `d` from the render-space origin
/// (the camera): how precisely a position there is stored. Infinite beyond f32's range.
pub fn f32_spacing(d: f64) -> f64 {
    let x = (d.abs() as f32).max(f32::MIN_POSITIVE);
    if !x.is_finite() || x == f32::MAX {
        return f64::INFINITY;
    }
    (f32::from_bits(x.to_bits() + 1) - x) as f64
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
    /// World position of the render-space origin, the camera: world = render + world_offset.
    /// Positions are composed in f64 and stored relative to the camera, so f32 is most precise
    /// where the camera looks, whatever else the scene holds far away.
    pub world_offset: DVec3,
    /// Whether any material has an alpha test (lets occlusion skip the material lookup).
    pub any_alpha_test: bool,
    pub stats: LoadStats,
    /// One line each: what the load dropped or could not keep precise (see `LoadStats`).
    pub warnings: Vec<String>,
}

/// The BVH build preset. Bvh2 (not CwBvh): CwBvh clamps t to >= 1e-4 in world units, which
/// misses contact occluders in millimetre-scale scenes, and it is not faster for the
/// pixel-ordered rays we trace (see docs/notes/2026-11-21-bvh-choice.md and `benches/traced_shadows.rs`).
pub fn bvh_params() -> BvhBuildParams {
    BvhBuildParams::medium_build()
}

impl Scene {
    /// Loads a scene file: models, quads, camera, lights; builds the BVH.
    pub fn load(file: &SceneFile, scene_path: &Path) -> Result<Scene, SceneError> {
        let t0 = Instant::now();
        let mut geometry = Geometry::default();
        let gltf_camera = load_models(file, scene_path, &mut geometry)?;
        for q in &file.quad {
            geometry.add_quad(DVec3::from(q.center), DVec3::from(q.u), DVec3::from(q.v), q.color);
        }

        // Render space is centred on the camera (world, f64): f32 is most precise where the
        // camera looks, and geometry far away cannot cost the visible part its precision.
        let world_offset = camera_world_position(file, gltf_camera.as_ref()).unwrap_or(DVec3::ZERO);
        let (lo, hi) = world_bounds(&geometry.triangles);
        let mut warnings = Vec::new();
        let lights = scene_lights(file, &geometry, 0.5 * (lo + hi), world_offset, scene_path, &mut warnings)?;
        let camera = scene_camera(file, gltf_camera, world_offset, scene_path)?;
        let load = t0.elapsed();

        let mut scene = Self::build(geometry, lights, camera, world_offset, load);
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
        let Geometry { triangles: source, materials, textures, degenerate, .. } = geometry;
        let mut tris = Vec::with_capacity(source.len());
        let mut shading = Vec::with_capacity(source.len());
        let mut precision = PrecisionTally { zero_area: degenerate, ..Default::default() };
        for s in &source {
            let Some(face) = precision.keep(s.p, world_offset) else { continue };
            let p = s.p.map(|p| (p - world_offset).as_vec3());
            tris.push(Triangle { v0: p[0].into(), v1: p[1].into(), v2: p[2].into() });
            shading.push(TriangleShading { n: s.n.unwrap_or([face; 3]), uv: s.uv, material: s.material });
        }
        let warnings = precision.warnings();
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
        let t_bvh = Instant::now();
        let bvh = if tris.is_empty() {
            None
        } else {
            let bvh =
                obvhs::bvh2::builder::build_bvh2_from_tris(&tris, bvh_params(), &mut Duration::default());
            // Reorder once so that leaves index our arrays directly.
            tris = bvh.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
            shading = bvh.primitive_indices.iter().map(|&i| shading[i as usize]).collect();
            Some(bvh)
        };
        let bvh_time = t_bvh.elapsed();
        let any_alpha_test = materials.iter().any(|m| !matches!(m.alpha, crate::material::AlphaMode::Opaque));
        let stats = LoadStats {
            load,
            bvh: bvh_time,
            triangles: tris.len() as u64,
            degenerate_triangles: precision.zero_area + precision.collapsed + precision.out_of_range,
            zero_area: precision.zero_area,
            collapsed_in_f32: precision.collapsed,
            beyond_f32_range: precision.out_of_range,
            imprecise_triangles: precision.imprecise,
        };
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
            world_offset,
            any_alpha_test,
            stats,
            warnings,
        }
    }

    /// Möller-Trumbore with barycentrics (obvhs's `compute_barycentric` is mis-scaled, see
    /// deps.md): returns (t, b1, b2) for a hit with `tmin < t <= tmax` (strict at `tmin`: a
    /// ray leaving a plane exactly, where the offset is zero, computes t = 0 on it).
    ///
    /// In f32; where the determinant is zero, subnormal or not finite (a triangle ~1e-20 or
    /// ~1e20 across) or `t` overflows, the whole test is redone in f64 ([`Self::intersect_f64`]),
    /// so tiny and huge triangles are hit like any other. The common path costs one more
    /// comparison than before.
    #[inline(always)]
    fn intersect_triangle(tri: &Triangle, ray: &Ray) -> Option<(f32, f32, f32)> {
        let e1 = tri.v1 - tri.v0;
        let e2 = tri.v2 - tri.v0;
        let pvec = ray.direction.cross(e2);
        let det = e1.dot(pvec);
        if !(f32::MIN_POSITIVE..=f32::MAX).contains(&det.abs()) {
            return Self::intersect_f64(tri, ray);
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
        if !t.is_finite() {
            return Self::intersect_f64(tri, ray);
        }
        (t > ray.tmin && t <= ray.tmax).then_some((t, b1, b2))
    }

    /// The rare path of [`Self::intersect_triangle`]: the same test on the same f32 inputs in
    /// f64 (products of f32 values neither overflow nor underflow there).
    #[cold]
    #[inline(never)]
    fn intersect_f64(tri: &Triangle, ray: &Ray) -> Option<(f32, f32, f32)> {
        let v0 = Vec3::from(tri.v0).as_dvec3();
        let e1 = Vec3::from(tri.v1).as_dvec3() - v0;
        let e2 = Vec3::from(tri.v2).as_dvec3() - v0;
        let d = Vec3::from(ray.direction).as_dvec3();
        let pvec = d.cross(e2);
        let det = e1.dot(pvec);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let tvec = Vec3::from(ray.origin).as_dvec3() - v0;
        let b1 = tvec.dot(pvec) / det;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let qvec = tvec.cross(e1);
        let b2 = d.dot(qvec) / det;
        if b2 < 0.0 || b1 + b2 > 1.0 {
            return None;
        }
        let t = e2.dot(qvec) / det;
        (t > ray.tmin as f64 && t <= ray.tmax as f64).then_some((t as f32, b1 as f32, b2 as f32))
    }

    /// The unit geometric normal of a triangle (its winding's side): from the f32 cross
    /// product, or in f64 where that underflows or overflows (tiny and huge triangles).
    #[inline]
    fn face_normal(tri: &Triangle) -> Vec3 {
        let n = Vec3::from((tri.v1 - tri.v0).cross(tri.v2 - tri.v0));
        let len2 = n.length_squared();
        if len2 >= f32::MIN_POSITIVE && len2.is_finite() {
            return n / len2.sqrt();
        }
        let (v0, v1, v2) =
            (Vec3::from(tri.v0).as_dvec3(), Vec3::from(tri.v1).as_dvec3(), Vec3::from(tri.v2).as_dvec3());
        let n = (v1 - v0).cross(v2 - v0);
        // Scaled first: |n| may itself underflow f64 for triangles below ~1e-150.
        let n = n / n.abs().max_element();
        n.normalize_or_zero().as_vec3()
    }

    #[inline]
    fn uv_at(&self, slot: usize, b1: f32, b2: f32) -> Vec2 {
        let uv = &self.shading[slot].uv;
        (1.0 - b1 - b2) * uv[0] + b1 * uv[1] + b2 * uv[2]
    }

    /// The primitive test shared by closest-hit and occlusion: a hit that the alpha test
    /// does not cut out.
    /// Always inlined: it runs once per triangle a ray meets, inside the BVH traversal (as a
    /// call it cost ~20% of `traced` on monobloc-chair, measured).
    #[inline(always)]
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
        // The hit point from the vertices, not from o + t d: its error is then bounded by
        // the vertices' magnitudes alone, whatever the ray's length.
        let v = [Vec3::from(tri.v0), Vec3::from(tri.v1), Vec3::from(tri.v2)];
        let b = [1.0 - b1 - b2, b1, b2];
        let p = b[0] * v[0] + b[1] * v[1] + b[2] * v[2];
        let p_error = interpolation_error(b, v);
        let d = Vec3::from(ray.direction);
        let mut n_geom = Self::face_normal(tri);
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
            p_error,
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

    /// Whether the segment from surface point `p` (error bound `p_error`, geometric normal
    /// `n_geom`) to `target` (error bound `target_error`, on a surface of normal
    /// `target_normal`) is blocked, with the one rule at both ends
    /// ([`crate::ray_origin::shadow_ray`]).
    #[inline]
    pub fn segment_occluded(
        &self,
        p: Vec3,
        p_error: Vec3,
        n_geom: Vec3,
        target: Vec3,
        target_error: Vec3,
        target_normal: Vec3,
    ) -> bool {
        match shadow_ray(p, p_error, n_geom, target, target_error, target_normal) {
            Some(ray) => self.occluded(ray),
            None => false,
        }
    }

    /// [`Self::segment_occluded`] from an origin already offset
    /// ([`crate::ray_origin::shadow_ray_from`]).
    #[inline]
    pub fn segment_occluded_from(
        &self,
        origin: Vec3,
        target: Vec3,
        target_error: Vec3,
        target_normal: Vec3,
    ) -> bool {
        match shadow_ray_from(origin, target, target_error, target_normal) {
            Some(ray) => self.occluded(ray),
            None => false,
        }
    }

    /// A bound on the magnitude of every coordinate in the scene (triangles and lights), for
    /// rounding margins of tests that may meet any triangle ([`crate::Shaft`]).
    pub fn coordinate_bound(&self) -> f32 {
        let mut m = self.bounds_min.abs().max(self.bounds_max.abs()).max_element();
        for l in &self.lights {
            for c in l.corners() {
                m = m.max(c.abs().max_element());
            }
        }
        m
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

/// What `Scene::build` learns about each triangle's precision in render space, and the
/// warnings it makes of it.
#[derive(Debug, Default)]
struct PrecisionTally {
    zero_area: u64,
    collapsed: u64,
    /// The nearest collapsed triangle's distance from the camera.
    collapsed_nearest: f64,
    out_of_range: u64,
    imprecise: u64,
    /// The farthest imprecise triangle's distance from the camera and its f32 spacing.
    imprecise_farthest: (f64, f64),
}

impl PrecisionTally {
    /// The unit face normal (render space) of the world-space triangle `p` if f32 can hold
    /// it relative to `origin`; else `None`, with the reason counted.
    fn keep(&mut self, p: [DVec3; 3], origin: DVec3) -> Option<Vec3> {
        if is_degenerate(p) {
            self.zero_area += 1; // the loaders test this too; a caller of `build` may not
            return None;
        }
        let rel = p.map(|p| p - origin);
        let distance = rel.iter().map(|r| r.length()).fold(0.0, f64::max);
        let p32 = rel.map(|r| r.as_vec3());
        if !p32.iter().all(|v| v.is_finite()) {
            self.out_of_range += 1;
            return None;
        }
        let q = p32.map(|v| v.as_dvec3());
        if is_degenerate(q) {
            if self.collapsed == 0 || distance < self.collapsed_nearest {
                self.collapsed_nearest = distance;
            }
            self.collapsed += 1;
            return None;
        }
        let size = [q[1] - q[0], q[2] - q[1], q[0] - q[2]].iter().map(|e| e.length()).fold(0.0, f64::max);
        let spacing = f32_spacing(distance);
        if spacing > size / SHAPE_PRECISION {
            if distance > self.imprecise_farthest.0 {
                self.imprecise_farthest = (distance, spacing);
            }
            self.imprecise += 1;
        }
        let m = (q[1] - q[0]).abs().max_element();
        Some(((q[1] - q[0]) / m).cross((q[2] - q[0]) / m).normalize().as_vec3())
    }

    fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.zero_area > 0 {
            w.push(format!(
                "{} triangle(s) dropped: zero area (repeated or collinear vertices)",
                self.zero_area
            ));
        }
        if self.collapsed > 0 {
            let d = self.collapsed_nearest;
            w.push(format!(
                "{} triangle(s) dropped: too small for f32 at their distance from the camera (the nearest \
                 {d:.3e} m away, where f32 positions are spaced {:.3e} m)",
                self.collapsed,
                f32_spacing(d)
            ));
        }
        if self.out_of_range > 0 {
            w.push(format!(
                "{} triangle(s) dropped: farther from the camera than f32 can hold ({:.1e} m)",
                self.out_of_range,
                f32::MAX
            ));
        }
        if self.imprecise > 0 {
            let (d, s) = self.imprecise_farthest;
            w.push(format!(
                "{} triangle(s) too far from the camera for f32 to keep their shape: the farthest \
                 {d:.3e} m away, where f32 positions are spaced {s:.3e} m (over 1/{SHAPE_PRECISION} of \
                 its size); render space is centred on the camera, so nearer geometry keeps its own \
                 precision",
                self.imprecise
            ));
        }
        w
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
        let cam = load_gltf(&path, model_from_file, geometry)?;
        if i == 0 {
            gltf_camera = cam;
        }
    }
    Ok(gltf_camera)
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

/// The light `l` in render space (world minus `world_offset`), or why f32 cannot hold it
/// there: its corners must stay a real rectangle in f32 at its distance from the camera, or
/// its irradiance could not be computed (a 1e-30 m light 2 m away is one point in f32).
pub fn light_in_render_space(l: &LightDesc, world_offset: DVec3) -> Result<RectLight, String> {
    let centre = DVec3::from(l.center) - world_offset;
    let light = RectLight::new(
        centre.as_vec3(),
        DVec3::from(l.u).as_vec3(),
        DVec3::from(l.v).as_vec3(),
        Vec3::from(l.radiance),
    );
    let c = light.corners().map(|c| c.as_dvec3());
    if is_degenerate([c[0], c[1], c[2]]) || is_degenerate([c[0], c[2], c[3]]) || !light.normal.is_finite() {
        let d = centre.length();
        return Err(format!(
            "the light ({:.3e} x {:.3e} m) is too small for f32 at its distance from the camera \
             ({d:.3e} m, where f32 positions are spaced {:.3e} m): its area and irradiance cannot be computed",
            DVec3::from(l.u).length(),
            DVec3::from(l.v).length(),
            f32_spacing(d),
        ));
    }
    Ok(light)
}

/// The lights in render space (world minus `world_offset`): the scene file's, or else the
/// emissive rectangles of the models (double-sided ones facing `scene_centre`, world space).
/// An emissive rectangle f32 cannot hold is skipped with a line in `warnings`.
fn scene_lights(
    file: &SceneFile,
    geometry: &Geometry,
    scene_centre: DVec3,
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
                light_in_render_space(l, world_offset)
                    .map_err(|msg| SceneError::new(scene_path, format!("light[{k}].u"), msg))
            })
            .collect();
    }
    let mut found = Vec::new();
    for e in &geometry.emitters {
        if let Some(desc) = rectangle_light(e, scene_centre)
            && validate_light(&desc, "emitter", scene_path).is_ok()
        {
            match light_in_render_space(&desc, world_offset) {
                Ok(light) => found.push(light),
                Err(msg) => warnings.push(format!("an emissive rectangle is not a light: {msg}")),
            }
        }
    }
    if found.is_empty() {
        return Err(SceneError::new(
            scene_path,
            "light",
            "no [[light]] given and the models have no emissive rectangles",
        ));
    }
    Ok(found)
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
        if !(forward.length_squared() > 0.0 && forward.cross(up).length_squared() > 0.0) {
            return Err(SceneError::new(
                scene_path,
                "camera.from_gltf",
                "the glTF camera's transform is degenerate",
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
