//! The runtime scene: triangles in BVH order with their shading attributes, materials,
//! textures, lights and camera; closest-hit and occlusion queries with the alpha test; and
//! the hit's own error bound that the one rule for ray origins uses ([`crate::geometry::ray_origin`]).

use crate::geometry::attributes::TriangleExtras;
use crate::geometry::camera::Camera;
use crate::geometry::coverage::CoveragePoint;
use crate::geometry::instanced::InstancedScene;
use crate::geometry::instances::{Instance, MeshTopology, TriangleOrigin};
use crate::geometry::light::RectLight;
use crate::geometry::material::{Material, Shading, Texture};
use crate::geometry::point::ShadingPoint;
use crate::geometry::ray_origin::{shadow_ray, shadow_ray_from};
use crate::geometry::surface::interpolate;
use crate::geometry::watertight::{HitPoint, ShearedRay, walkable};
use glam::{DVec3, Vec2, Vec3};
use obvhs::{BvhBuildParams, bvh2::Bvh2, ray::Ray, triangle::Triangle};
use std::time::Duration;

/// Per-triangle shading data, stored in BVH order next to `Scene::triangles`.
#[derive(Debug, Clone, Copy)]
pub struct TriangleShading {
    /// Vertex normals (world, unit); the face normal three times when the file has none.
    pub n: [Vec3; 3],
    pub uv: [Vec2; 3],
    pub material: u32,
}

/// A closest hit: where, with which normals. Both face the side the ray came from, each by
/// its own plane ([`ShadingPoint`]): the geometric normal for ray origins, the shading normal
/// for reflection, so a surface reflects only light arriving on the same side of its shading
/// plane as the ray that found it. Where smoothed normals tilt the shading plane past the
/// ray, the two point to different sides of the geometric plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    pub t: f32,
    /// The hit point (interpolated from the triangle's vertices, not `o + t d`), its error
    /// bound ([`ShearedRay::hit_point`]: f64 barycentrics) and its normals.
    pub point: ShadingPoint,
    pub uv: Vec2,
    pub material: u32,
    /// Index into the BVH-ordered triangle arrays; for a kept instance's triangle
    /// (`kept`), its slot in its mesh's tree.
    pub triangle: u32,
    /// The kept instance hit (an index into `Scene::instanced`'s `placed`), if any.
    pub kept: Option<u32>,
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

pub struct Scene {
    /// In BVH order: `bvh` leaves index these directly.
    pub triangles: Vec<Triangle>,
    pub shading: Vec<TriangleShading>,
    /// Per triangle (BVH order), only where a material reads them: the second texture
    /// coordinates, COLOR_0 and tangents ([`crate::geometry::attributes`]).
    pub extras: TriangleExtras,
    /// Per triangle (BVH order): its instance and index in its mesh.
    pub origins: Vec<TriangleOrigin>,
    /// The meshes the instances place, and the instances (see [`crate::geometry::instances`]).
    pub meshes: Vec<MeshTopology>,
    pub instances: Vec<Instance>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// `None` for a scene without triangles (every ray misses).
    pub bvh: Option<Bvh2>,
    /// Instances kept unflattened (a scene too big to flatten): traced through their own
    /// trees ([`crate::geometry::instanced`]), with the same answers.
    pub instanced: Option<InstancedScene>,
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
    /// How materials are shaded (`[materials] shading`): normal maps bend the hits' shading
    /// normals in [`Shading::Gltf`] only.
    pub shading_mode: Shading,
    /// Whether any hit's normal is bent: [`Shading::Gltf`] and some triangle with tangents
    /// (lets a hit skip the material lookup otherwise).
    pub normal_maps: bool,
    pub stats: LoadStats,
    /// One line each: what the load dropped or could not keep precise (see `LoadStats`).
    pub warnings: Vec<String>,
}

/// Whether a camera frame in render space makes a camera: a finite position, and a view
/// direction and up vector that give a right vector in f32 (as [`Camera::from_frame`]
/// computes it). The scene file checks its camera in f64; recentring on the models can put
/// position and look_at on one f32 value, or out of f32's range (found by fuzzing).
pub(crate) fn camera_frame_ok(position: Vec3, forward: Vec3, up: Vec3) -> bool {
    position.is_finite() && forward.try_normalize().and_then(|f| f.cross(up).try_normalize()).is_some()
}

/// Raises `bvh.max_depth` to the tree's depth. obvhs sizes its traversal stacks by it, and its
/// build can leave it below the real depth after reinsertion (found by fuzzing: 143 levels,
/// max_depth 127, caught by obvhs's debug validation); a push past a fixed stack is clamped
/// there, dropping a subtree: missed hits.
pub(crate) fn cover_depth(bvh: &mut Bvh2) {
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
/// pixel-ordered rays we trace (see docs/notes/2026-11-21-bvh-choice.md and `benches/traced_shadows.rs`).
pub fn bvh_params() -> BvhBuildParams {
    BvhBuildParams::medium_build()
}

impl Scene {
    /// Triangles of the distinct meshes, each counted once however many instances place it
    /// (those its first instance kept), and those of no mesh: what the scene would hold with
    /// every mesh stored once.
    pub fn unique_triangles(&self) -> u64 {
        let mut first = vec![u32::MAX; self.meshes.len()];
        for (i, inst) in self.instances.iter().enumerate() {
            let f = &mut first[inst.mesh as usize];
            *f = (*f).min(i as u32);
        }
        let counted = |o: &TriangleOrigin| {
            o.is_loose() || first[self.instances[o.instance as usize].mesh as usize] == o.instance
        };
        let flat = self.origins.iter().filter(|o| counted(o)).count() as u64;
        // Kept instances: the triangles its mesh's first instance keeps (none if that one
        // keeps none, as flattened).
        let kept = self.instanced.as_ref().map_or(0, |inst| {
            let mut placed_of = vec![None; self.instances.len()];
            for p in &inst.placed {
                placed_of[p.instance as usize] = Some(p.mesh);
            }
            first
                .iter()
                .filter(|&&i| i != u32::MAX)
                .filter_map(|&i| placed_of[i as usize])
                .map(|m| inst.meshes[m as usize].slots.len() as u64)
                .sum::<u64>()
        });
        flat + kept
    }

    /// How many instances are kept unflattened ([`crate::geometry::instanced`]).
    pub fn kept_instances(&self) -> u64 {
        self.instanced.as_ref().map_or(0, |i| i.placed.len() as u64)
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

    /// The shading normal `n` (zero: none, the geometric one stands in) on the side of the
    /// ray that arrived along `d`: the two-sided Lambertian reflects on the side of the
    /// shading plane the incoming direction lies on, as pbrt-v4 (`SameHemisphere`) and
    /// Mitsuba 3's two-sided diffuse do. Flipping it onto `n_geom`'s side instead reflected
    /// light arriving below the shading plane above it: 4.6% more light than Mitsuba in a
    /// closed box with corner-averaged normals, 20% in its corners (issue 26). A ray in the
    /// shading plane (`n . d` exactly 0) takes `n_geom`'s side, so where the normals agree
    /// nothing changes.
    #[inline]
    fn facing_ray(n: Vec3, n_geom: Vec3, d: Vec3) -> Vec3 {
        if n == Vec3::ZERO {
            return n_geom;
        }
        let cos = n.dot(d);
        if cos > 0.0 || (cos == 0.0 && n.dot(n_geom) < 0.0) { -n } else { n }
    }

    /// Where barycentrics (b1, b2) of triangle `slot` lie, as BLEND's coverage reads it: its
    /// instance and index in its mesh (not its slot, so a kept copy reads the same pattern;
    /// the slot for a triangle of no mesh), and its COLOR_0 alpha there.
    #[inline]
    fn coverage_point(&self, slot: usize, b1: f32, b2: f32) -> CoveragePoint {
        let triangle = match self.origins.get(slot) {
            Some(o) if !o.is_loose() => *o,
            _ => TriangleOrigin { instance: u32::MAX, local: slot as u32 },
        };
        let color_alpha = self.extras.color.get(slot).map_or(1.0, |c| interpolate(c.map(|c| c.w), b1, b2));
        CoveragePoint { triangle, b1, b2, color_alpha }
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
    fn hit_distance(&self, ray: &ShearedRay, tmax: f32, slot: usize) -> f32 {
        match ray.intersect(&self.triangles[slot], tmax) {
            None => f32::INFINITY,
            Some((t, b1, b2)) => {
                if self.any_alpha_test {
                    let m = &self.materials[self.shading[slot].material as usize];
                    let point = || self.coverage_point(slot, b1, b2);
                    if m.is_cutout(self.uv_at(slot, b1, b2), &self.textures, point) {
                        return f32::INFINITY;
                    }
                }
                t
            }
        }
    }

    /// A kept instance's triangle's hit distance (alpha test honoured): [`Self::hit_distance`]
    /// for the triangle the flattened scene would hold.
    #[inline(always)]
    fn kept_hit_distance(
        &self,
        inst: &InstancedScene,
        placed: usize,
        slot: usize,
        ray: &ShearedRay,
        tmax: f32,
    ) -> f32 {
        let p = &inst.placed[placed];
        match ray.intersect(&inst.render_triangle(p, slot), tmax) {
            None => f32::INFINITY,
            Some((d, b1, b2)) => {
                if self.any_alpha_test {
                    let t = inst.triangle(p, slot);
                    let m = &self.materials[p.materials[t.primitive as usize] as usize];
                    let point = || inst.coverage_point(p, &t, slot, b1, b2);
                    if m.is_cutout(inst.uv_at(p, &t, b1, b2), &self.textures, point) {
                        return f32::INFINITY;
                    }
                }
                d
            }
        }
    }

    /// Whether a kept instance's triangle lies on `ray` (with its sheared form) within its range.
    #[inline]
    fn kept_occluded(&self, ray: &Ray, sheared: &ShearedRay) -> bool {
        self.instanced.as_ref().is_some_and(|inst| {
            inst.traverse(ray, true, |p, slot, tmax| self.kept_hit_distance(inst, p, slot, sheared, tmax))
                .is_some()
        })
    }

    /// The render-space triangle a hit lies on.
    pub fn hit_triangle(&self, hit: &SurfaceHit) -> Triangle {
        match (hit.kept, &self.instanced) {
            (Some(p), Some(inst)) => inst.render_triangle(&inst.placed[p as usize], hit.triangle as usize),
            _ => self.triangles[hit.triangle as usize],
        }
    }

    /// Closest hit along `ray` (alpha test honoured).
    pub fn intersect(&self, ray: Ray) -> Option<SurfaceHit> {
        let ray = walkable(ray);
        let mut hit = obvhs::ray::RayHit::none();
        let sheared = ShearedRay::new(&ray);
        let flat = self.bvh.as_ref().is_some_and(|bvh| {
            bvh.ray_traverse(ray, &mut hit, |r, slot| self.hit_distance(&sheared, r.tmax, slot))
        });
        if let Some(inst) = &self.instanced {
            let nearer = Ray { tmax: if flat { hit.t } else { ray.tmax }, ..ray };
            let found = inst.traverse(&nearer, false, |p, slot, tmax| {
                self.kept_hit_distance(inst, p, slot, &sheared, tmax)
            });
            if let Some((t, p, slot)) = found {
                return self.kept_hit(inst, (p, slot), t, &sheared, &ray);
            }
        }
        if !flat {
            return None;
        }
        let slot = hit.primitive_id as usize;
        let tri = &self.triangles[slot];
        // The hit point from the vertices, not from o + t d (its error is then bounded
        // whatever the ray's length), in f64 (whatever the triangle's size).
        let HitPoint { p, p_error, b1, b2 } = sheared.hit_point(tri)?;
        let d = Vec3::from(ray.direction);
        let mut n_geom = Self::face_normal(tri);
        let front_face = n_geom.dot(d) < 0.0;
        if !front_face {
            n_geom = -n_geom;
        }
        let sh = &self.shading[slot];
        let n_shading = ((1.0 - b1 - b2) * sh.n[0] + b1 * sh.n[1] + b2 * sh.n[2]).normalize_or_zero();
        let uv = self.uv_at(slot, b1, b2);
        let n_shading = if self.normal_maps {
            self.mapped_normal(sh.material, n_shading, (uv, b1, b2), || self.extras.get(slot))
        } else {
            n_shading
        };
        let n_shading = Self::facing_ray(n_shading, n_geom, d);
        Some(SurfaceHit {
            t: hit.t,
            point: ShadingPoint { p, p_error, n_geom, n_shading },
            uv,
            material: sh.material,
            triangle: slot as u32,
            kept: None,
            front_face,
        })
    }

    /// [`Self::intersect`]'s hit on a kept instance's triangle: the same arithmetic on the
    /// triangle, normals and texture coordinates the flattened scene would store.
    fn kept_hit(
        &self,
        inst: &InstancedScene,
        (placed, slot): (usize, usize),
        t: f32,
        sheared: &ShearedRay,
        ray: &Ray,
    ) -> Option<SurfaceHit> {
        let p = &inst.placed[placed];
        let pt = inst.triangle(p, slot);
        let tri = &pt.tri;
        let HitPoint { p: at, p_error, b1, b2 } = sheared.hit_point(tri)?;
        let d = Vec3::from(ray.direction);
        let mut n_geom = Self::face_normal(tri);
        let front_face = n_geom.dot(d) < 0.0;
        if !front_face {
            n_geom = -n_geom;
        }
        let n = inst.normals(p, &pt).unwrap_or_else(|| {
            let q = [tri.v0, tri.v1, tri.v2].map(|v| Vec3::from(v).as_dvec3());
            [crate::geometry::precision::render_face(q).as_vec3(); 3]
        });
        let n_shading = ((1.0 - b1 - b2) * n[0] + b1 * n[1] + b2 * n[2]).normalize_or_zero();
        let uv = inst.uv_at(p, &pt, b1, b2);
        let material = p.materials[pt.primitive as usize];
        let n_shading = if self.normal_maps {
            self.mapped_normal(material, n_shading, (uv, b1, b2), || inst.extras(p, &pt))
        } else {
            n_shading
        };
        let n_shading = Self::facing_ray(n_shading, n_geom, d);
        Some(SurfaceHit {
            t,
            point: ShadingPoint { p: at, p_error, n_geom, n_shading },
            uv,
            material,
            triangle: slot as u32,
            kept: Some(placed as u32),
            front_face,
        })
    }

    /// Whether anything (alpha test honoured) lies on `ray` within [tmin, tmax]: an any-hit
    /// query that stops at the first hit.
    #[inline]
    pub fn occluded(&self, ray: Ray) -> bool {
        crate::util::pixel_cost::count_ray();
        let ray = walkable(ray);
        let sheared = ShearedRay::new(&ray);
        let flat = self.bvh.as_ref().is_some_and(|bvh| {
            !bvh.ray_traverse_miss(ray, |r, slot| self.hit_distance(&sheared, r.tmax, slot))
        });
        flat || self.kept_occluded(&ray, &sheared)
    }

    /// Whether the segment from surface point `point` to `target` (error bound
    /// `target_error`, on a surface of normal `target_normal`) is blocked, with the one rule
    /// at both ends ([`crate::geometry::ray_origin::shadow_ray`]).
    #[inline]
    pub fn segment_occluded(
        &self,
        point: &ShadingPoint,
        target: Vec3,
        target_error: Vec3,
        target_normal: Vec3,
    ) -> bool {
        match shadow_ray(point, target, target_error, target_normal) {
            Some(ray) => self.occluded(ray),
            None => false,
        }
    }

    /// [`Self::segment_occluded`] from an origin already offset
    /// ([`crate::geometry::ray_origin::shadow_ray_from`]).
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

    /// [`Self::segment_occluded_from`] through every triangle but those `skip` holds: for a
    /// method that answers for those triangles by other means (the same ray and tests).
    pub fn segment_occluded_from_except(
        &self,
        origin: Vec3,
        target: Vec3,
        (target_error, target_normal): (Vec3, Vec3),
        skip: impl Fn(usize) -> bool,
    ) -> bool {
        let Some(ray) = shadow_ray_from(origin, target, target_error, target_normal) else { return false };
        let ray = walkable(ray);
        crate::util::pixel_cost::count_ray();
        let sheared = ShearedRay::new(&ray);
        let flat = self.bvh.as_ref().is_some_and(|bvh| {
            !bvh.ray_traverse_miss(ray, |r, slot| {
                if skip(slot) { f32::INFINITY } else { self.hit_distance(&sheared, r.tmax, slot) }
            })
        });
        flat || self.kept_occluded(&ray, &sheared)
    }

    /// Whether the alpha test cuts out the point of triangle `slot` at barycentrics (b1, b2)
    /// (weights of its second and third corners): the test a ray's hit gets, for a method
    /// that finds the point on the triangle without a ray (BLEND's coverage at that point:
    /// the pattern a ray meeting it there reads).
    pub fn cut_out_at(&self, slot: usize, b1: f32, b2: f32) -> bool {
        self.any_alpha_test
            && self.materials[self.shading[slot].material as usize].is_cutout(
                self.uv_at(slot, b1, b2),
                &self.textures,
                || self.coverage_point(slot, b1, b2),
            )
    }

    /// Whether the shadow ray [`Scene::segment_occluded_from`] builds meets any of the
    /// triangles `slots` (alpha test honoured), tried in order until one is met: the same ray
    /// and the same test its traversal applies to each, for a method that knows which few
    /// triangles can block it. The ray is built once for them all.
    pub fn segment_meets_any(
        &self,
        origin: Vec3,
        target: Vec3,
        (target_error, target_normal): (Vec3, Vec3),
        slots: impl IntoIterator<Item = usize>,
    ) -> bool {
        let Some(ray) = shadow_ray_from(origin, target, target_error, target_normal) else { return false };
        let sheared = ShearedRay::new(&ray);
        slots.into_iter().any(|slot| self.hit_distance(&sheared, ray.tmax, slot) < ray.tmax)
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
