//! Meshes kept as instances: each stored once in its own space under a tree of its own, and a
//! top tree over the instances' bounds. A scene whose flattened triangles would not fit in
//! memory keeps its glTF placements this way (`Geometry::keep_instances`).
//!
//! The answers are the flattened scene's, bit for bit. The trees only choose which triangles
//! to test. Each test places the triangle's corners in render space with the loader's own
//! arithmetic ([`Placing`], then the render offset, rounded to f32), so it tests the
//! triangle the flattened scene would hold, with the same watertight test and the same ray.
//! Seams between instances stay closed. The mesh's tree is walked with the ray moved into
//! the mesh's space. Its boxes are grown by a bound on two roundings: that move's, and the
//! f32 rounding of the placed corners. So no triangle a ray meets is culled.
//!
//! Cost (measured on flight-helmet, metal-rough-spheres and toy-car, every triangle placed on
//! the fly): `traced` renders 14-31% slower than from stored triangles.

use crate::geometry::attributes::CornerExtras;
use crate::geometry::coverage::CoveragePoint;
use crate::geometry::instances::{Placing, PrimitiveData, TriangleOrigin};
use crate::geometry::surface::interpolate;
use glam::{DMat3, DMat4, DVec3, Vec2, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use std::sync::Arc;

/// One mesh as its instances share it: its primitives, and its tree over the triangles they
/// keep (boxes grown for every instance that uses it).
pub struct StoredMesh {
    pub primitives: Arc<Vec<PrimitiveData>>,
    /// Per leaf slot (tree order): the primitive and the triangle's index in it.
    pub slots: Vec<[u32; 2]>,
    /// Per leaf slot: the triangle's corners in the file's winding, f64 (read by every test:
    /// one load instead of three dependent ones, no conversion).
    pub points: Vec<[DVec3; 3]>,
    pub bvh: Bvh2,
    /// Per primitive: the index in the mesh of its first triangle (as the flattened scene's
    /// [`TriangleOrigin::local`] counts them), which keys BLEND's coverage.
    pub first_local: Vec<u32>,
}

/// One instance: its mesh, transform and materials.
#[derive(Debug)]
pub struct Placed {
    pub mesh: u32,
    pub placing: Placing,
    /// Render space to the mesh's space.
    pub to_mesh: DMat4,
    /// A material per primitive.
    pub materials: Arc<[u32]>,
    pub instance: u32,
    /// Render-space bounds of its triangles.
    pub bounds: Aabb,
    /// Its transform has no usable inverse (nearly singular): its triangles are all tested,
    /// without its mesh's tree.
    pub brute: bool,
    /// Where its placed corners start in [`InstancedScene::corners`], if they are held.
    pub corners_at: Option<usize>,
    /// A bound on the f64 rounding of a placed corner before its f32 rounding
    /// ([`Placing::rounding`]).
    pub world_rounding: f64,
}

/// The kept instances of a scene (see the module doc).
pub struct InstancedScene {
    pub meshes: Vec<StoredMesh>,
    pub placed: Vec<Placed>,
    /// Over `placed`'s bounds; leaves index `placed` through `primitive_indices`.
    pub tlas: Bvh2,
    /// World position of the render-space origin.
    pub offset: DVec3,
    /// Placed corners held for some instances (in their mesh's slot order), so that a test
    /// reads them instead of placing them: the same bits, within a memory budget.
    pub corners: Vec<[Vec3; 3]>,
}

/// A triangle of a kept instance, placed: its render-space corners, primitive and corners'
/// indices.
#[derive(Debug, Clone, Copy)]
pub struct PlacedTriangle {
    pub tri: Triangle,
    pub primitive: u32,
    pub corners: [u32; 3],
}

impl InstancedScene {
    /// The triangle at `slot` of `p`'s mesh tree, in render space: the flattened scene's
    /// bits ([`Placing::position`]'s arithmetic on the same f64 corners, less the offset).
    #[inline(always)]
    pub fn render_triangle(&self, p: &Placed, slot: usize) -> Triangle {
        let v = match p.corners_at {
            Some(at) => self.corners[at + slot],
            None => place_corners(&self.meshes[p.mesh as usize], p, self.offset, slot),
        };
        Triangle { v0: v[0].into(), v1: v[1].into(), v2: v[2].into() }
    }

    /// A box in render space holding the placed corners (f32, as [`Self::render_triangle`]
    /// rounds them) of every mesh point in `aabb` (the mesh's space): its centre and half
    /// extent carried in f64 (`linear_abs`: the placing's linear part, entries made
    /// positive), grown by 2^-20 of its reach for the f32 rounding and by the f64 one.
    #[inline]
    pub fn render_box(&self, p: &Placed, linear_abs: &DMat3, aabb: &Aabb) -> (Vec3A, Vec3A) {
        let (lo, hi) = (Vec3::from(aabb.min).as_dvec3(), Vec3::from(aabb.max).as_dvec3());
        let c = p.placing.point(0.5 * (lo + hi)) - self.offset;
        let e = *linear_abs * (0.5 * (hi - lo));
        let grow = e + (c.abs() + e) * (1.0 / (1u64 << 20) as f64) + DVec3::splat(p.world_rounding);
        (Vec3A::from((c - grow).as_vec3()), Vec3A::from((c + grow).as_vec3()))
    }

    /// [`Self::render_triangle`] with the primitive and the corners' indices (for shading).
    pub fn triangle(&self, p: &Placed, slot: usize) -> PlacedTriangle {
        let mesh = &self.meshes[p.mesh as usize];
        let [prim, k] = mesh.slots[slot];
        let corners = p.placing.corners(mesh.primitives[prim as usize].corners[k as usize]);
        PlacedTriangle { tri: self.render_triangle(p, slot), primitive: prim, corners }
    }

    /// The texture coordinates at barycentrics (b1, b2) of a placed triangle.
    pub fn uv_at(&self, p: &Placed, t: &PlacedTriangle, b1: f32, b2: f32) -> Vec2 {
        let data = &self.meshes[p.mesh as usize].primitives[t.primitive as usize];
        match &data.uvs {
            Some(uv) => {
                let uv = t.corners.map(|i| Vec2::from(uv[i as usize]));
                (1.0 - b1 - b2) * uv[0] + b1 * uv[1] + b2 * uv[2]
            }
            None => Vec2::ZERO,
        }
    }

    /// Where on the placed triangle at `slot` of `p`'s mesh tree barycentrics (b1, b2) lie,
    /// as BLEND's coverage reads it: the point of the triangle the flattened scene holds
    /// (its instance and index in its mesh; its COLOR_0 alpha there).
    pub fn coverage_point(
        &self,
        p: &Placed,
        t: &PlacedTriangle,
        slot: usize,
        b1: f32,
        b2: f32,
    ) -> CoveragePoint {
        let mesh = &self.meshes[p.mesh as usize];
        let local = mesh.first_local[t.primitive as usize] + mesh.slots[slot][1];
        let colors = mesh.primitives[t.primitive as usize].colors.as_ref();
        let color_alpha = colors.map_or(1.0, |c| interpolate(t.corners.map(|i| c[i as usize][3]), b1, b2));
        CoveragePoint { triangle: TriangleOrigin { instance: p.instance, local }, b1, b2, color_alpha }
    }

    /// The corners' world normals of a placed triangle (`None`: the face normal stands in).
    pub fn normals(&self, p: &Placed, t: &PlacedTriangle) -> Option<[Vec3; 3]> {
        let data = &self.meshes[p.mesh as usize].primitives[t.primitive as usize];
        p.placing.normals(data.normals.as_deref(), t.corners)
    }

    /// The extra attributes of a placed triangle (second coordinates, COLOR_0, tangents), as
    /// the flattened scene stores them ([`PrimitiveData::extras`]).
    pub fn extras(&self, p: &Placed, t: &PlacedTriangle) -> CornerExtras {
        self.meshes[p.mesh as usize].primitives[t.primitive as usize].extras(&p.placing, t.corners)
    }

    /// Whether any stored mesh has tangents (a normal-mapped kept instance).
    pub fn any_tangents(&self) -> bool {
        self.meshes.iter().any(|m| m.primitives.iter().any(|d| d.tangents.is_some()))
    }

    /// The triangles `ray` may meet, per instance whose bounds it meets: `test(placed, slot,
    /// tmax)` gives the hit's t (render space, the ray's own parameter) or infinity. With
    /// `any`, stops at the first hit. Returns the closest (t, placed, slot) found.
    pub fn traverse(
        &self,
        ray: &Ray,
        any: bool,
        mut test: impl FnMut(usize, usize, f32) -> f32,
    ) -> Option<(f32, usize, usize)> {
        let mut best: Option<(f32, usize, usize)> = None;
        // The ray in f64, once (each instance it reaches reads it).
        let (o, d) = (Vec3::from(ray.origin).as_dvec3(), Vec3::from(ray.direction).as_dvec3());
        let inv = d.recip();
        let mut top = |r: &Ray, leaf: usize| -> f32 {
            let pi = self.tlas.primitive_indices[leaf] as usize;
            let p = &self.placed[pi];
            let Some(start) = entry(&p.bounds, (o, d, inv), r) else { return f32::INFINITY };
            let mut found = f32::INFINITY;
            let world_tmax = r.tmax;
            // The test takes the world ray's own range, not the moved ray's (its f32 rounding
            // could let a hit just past the end of a segment through), and a hit counts only
            // strictly inside it, as in obvhs's walk of the flattened scene.
            let mut consider = |slot: usize| -> f32 {
                let limit = found.min(world_tmax);
                let t = test(pi, slot, limit);
                if t < limit {
                    found = t;
                    best = Some((t, pi, slot));
                    t
                } else {
                    f32::INFINITY
                }
            };
            if p.brute {
                for slot in 0..self.meshes[p.mesh as usize].slots.len() {
                    if consider(slot).is_finite() && any {
                        break;
                    }
                }
                return found;
            }
            // The ray moved into the mesh's space from where it enters the instance's bounds
            // (the move's rounding is then bounded by the mesh's size, not the ray's length),
            // with a unit direction there: obvhs clamps a direction component under f32's
            // epsilon, which a direction shrunk by a large scale reaches long before a world
            // one (rays along an axis missed a 100x instance's floor).
            let o_mesh = p.to_mesh.transform_point3(o + start * d);
            let d_mesh = p.to_mesh.transform_vector3(d);
            let len = d_mesh.length();
            let (lo, hi) = ((r.tmin as f64 - start).max(0.0) * len, (r.tmax as f64 - start) * len);
            let direction = (d_mesh * len.recip()).as_vec3().into();
            // `walkable` gives the inverse direction (obvhs's `Ray::new` would compute one too).
            let local = crate::geometry::watertight::walkable(Ray {
                origin: o_mesh.as_vec3().into(),
                direction,
                inv_direction: direction,
                tmin: lo as f32,
                tmax: hi as f32,
            });
            let mut inner = |_: &Ray, slot: usize| -> f32 {
                let t = consider(slot);
                if t.is_finite() { ((t as f64 - start) * len) as f32 } else { f32::INFINITY }
            };
            let bvh = &self.meshes[p.mesh as usize].bvh;
            if any {
                if !bvh.ray_traverse_miss(local, &mut inner) {
                    return found;
                }
            } else {
                let mut hit = RayHit::none();
                bvh.ray_traverse(local, &mut hit, &mut inner);
            }
            found
        };
        if any {
            self.tlas.ray_traverse_miss(*ray, &mut top);
        } else {
            let mut hit = RayHit::none();
            self.tlas.ray_traverse(*ray, &mut hit, &mut top);
        }
        best
    }
}

/// The render-space corners of the triangle at `slot` of `p`'s mesh tree: the flattened
/// scene's bits ([`Placing::position`]'s arithmetic on the same f64 corners, less the
/// render offset, rounded to f32; the last two swapped under a mirroring transform).
#[inline(always)]
pub fn place_corners(mesh: &StoredMesh, p: &Placed, offset: DVec3, slot: usize) -> [Vec3; 3] {
    let mut c = mesh.points[slot];
    if p.placing.mirrored() {
        c.swap(1, 2);
    }
    c.map(|x| (p.placing.point(x) - offset).as_vec3())
}

/// Where the ray enters `b` (its own parameter, f64, at least its tmin), or `None` if it
/// misses it within its range. Grown by a relative 1e-9 of the distances (f64 rounds them
/// at 1e-16): the caller only starts the mesh's walk there.
fn entry(b: &Aabb, (o, d, inv): (DVec3, DVec3, DVec3), r: &Ray) -> Option<f64> {
    let (lo, hi) = (Vec3::from(b.min).as_dvec3(), Vec3::from(b.max).as_dvec3());
    let (mut t0, mut t1) = (r.tmin as f64, r.tmax as f64);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < lo[k] || o[k] > hi[k] {
                return None;
            }
            continue;
        }
        let (a, b) = ((lo[k] - o[k]) * inv[k], (hi[k] - o[k]) * inv[k]);
        let (a, b) = if a < b { (a, b) } else { (b, a) };
        let slack = 1e-9 * (a.abs() + b.abs());
        t0 = t0.max(a - slack);
        t1 = t1.min(b + slack);
    }
    (t0 <= t1).then_some(t0)
}
