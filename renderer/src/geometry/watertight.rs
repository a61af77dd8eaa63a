//! The ray-triangle test: watertight (Woop, Benthin and Wald 2013; pbrt-v4's
//! `IntersectTriangle`). A ray through an edge two triangles share meets at least one of
//! them, whatever the rounding: no shadow leaks through the seams of a closed mesh.
//!
//! The vertices are moved into the ray's frame (translated to its origin, permuted so that
//! the ray runs along +z, sheared onto that axis) by one f64 function of the vertex and the
//! ray alone, so a shared vertex lands on the same bits in both triangles; each edge's
//! function `a.x b.y - a.y b.x` is antisymmetric bit for bit, so the two triangles across an
//! edge see it with opposite signs, never both outside. A hit whose t lies within its own
//! rounding of 0 is none (pbrt-v4's bound): a ray leaving a surface does not meet it.
//!
//! Why f64: in f32 the frame's rounding made t uncertain by ~1e-7 of the distances, more than
//! the origin offset of a point on a long wall far from the scene's origin (sauerbraten-zdm2's
//! walls shadowed themselves), and pbrt's bound then dropped grazing hits, which leaked at
//! seams. Möller-Trumbore (the test before this one) rounds each triangle's barycentrics on
//! its own: a ray through a seam could miss both sides (one sample in 23 M on
//! glass-vase-flowers, found by `silhouette`'s differential test).

use glam::{DVec3, Vec3, Vec3A};
use obvhs::{ray::Ray, triangle::Triangle};

/// `ray` with its inverse direction as the box tests need it: obvhs's `Ray::new` clamps a
/// component under f32's epsilon to 1/epsilon, so a ray along an axis that starts within
/// microns of a box's face left that slab after (face - origin) x 8e6 and missed what lay
/// beyond (found comparing kept instances with the flattened scene). Here only components
/// under 1e-30 are clamped (to 1e30, never an infinity that could make 0 x inf a NaN).
#[inline(always)]
pub fn walkable(mut ray: Ray) -> Ray {
    let inv = |c: f32| if c.abs() < 1e-30 { 1e30f32.copysign(c) } else { 1.0 / c };
    let d = ray.direction;
    ray.inv_direction = glam::Vec3A::new(inv(d.x), inv(d.y), inv(d.z));
    ray
}

/// A ray in the test's frame: the axis it runs along (`kz`), the other two, and the shear.
/// Built once per ray; the test per triangle is then translations, six products and the
/// three edge functions, in f64 (scalar f64 costs what scalar f32 does here).
#[derive(Debug, Clone, Copy)]
pub struct ShearedRay {
    origin: DVec3,
    k: [usize; 3],
    shear: [f64; 3],
    tmin: f32,
}

impl ShearedRay {
    #[inline(always)]
    pub fn new(ray: &Ray) -> ShearedRay {
        let a = ray.direction.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        let d = Vec3::from(ray.direction).as_dvec3().to_array();
        let shear = [-d[kx] / d[kz], -d[ky] / d[kz], 1.0 / d[kz]];
        ShearedRay { origin: Vec3::from(ray.origin).as_dvec3(), k: [kx, ky, kz], shear, tmin: ray.tmin }
    }

    /// The same ray starting its range at `tmin`.
    pub fn with_tmin(self, tmin: f32) -> ShearedRay {
        ShearedRay { tmin, ..self }
    }

    /// A vertex in the ray's frame: (x, y) sheared, z along the ray (unscaled).
    #[inline(always)]
    fn vertex(&self, v: Vec3A) -> [f64; 3] {
        let p = (Vec3::from(v).as_dvec3() - self.origin).to_array();
        let [kx, ky, kz] = self.k;
        [p[kx] + self.shear[0] * p[kz], p[ky] + self.shear[1] * p[kz], p[kz]]
    }

    /// (t, b1, b2) of a hit with `tmin < t <= tmax` (`tmax` given per test: a closest-hit
    /// traversal shrinks it; strict at `tmin`: a ray leaving a plane
    /// exactly, where the offset is zero, computes t = 0 on it); b1, b2 weigh `v1`, `v2`.
    /// Degenerate triangles (all three edge functions zero) are never hit.
    #[inline(always)]
    pub fn intersect(&self, tri: &Triangle, tmax: f32) -> Option<(f32, f32, f32)> {
        let (p0, p1, p2) = (self.vertex(tri.v0), self.vertex(tri.v1), self.vertex(tri.v2));
        let (e0, e1, e2) = (edge(p1, p2), edge(p2, p0), edge(p0, p1));
        // A ray on an edge (0) is inside for both triangles.
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 {
            return None;
        }
        let z = DVec3::new(p0[2], p1[2], p2[2]) * self.shear[2];
        let t = (e0 * z.x + e1 * z.y + e2 * z.z) / det;
        // A t within its own rounding of 0 is no hit: the ray's origin lies on the triangle's
        // plane up to that rounding (its own surface, left by the origin offset). pbrt-v4's
        // conservative bound, from the f32 frame's rounding (the edge functions add none).
        if t <= t_rounding([p0, p1, p2], z, [e0, e1, e2], det) {
            return None;
        }
        let t = t as f32;
        (t > self.tmin && t <= tmax).then(|| (t, (e1 / det) as f32, (e2 / det) as f32))
    }
}

impl ShearedRay {
    /// The point where the ray meets `tri`, from the test's own f64 barycentrics, with a
    /// per-component bound on its error; `None` where the test would find no hit at any t.
    ///
    /// Why not f32 barycentrics (`b0 v0 + b1 v1 + b2 v2`, pbrt's way): their relative
    /// rounding (6e-8) times the triangle's size moved a 10^8 m floor's hit points by metres,
    /// and the error bound, as large, pushed shadow rays off by as much. Here the point is
    /// `v0 + b1 (v1 - v0) + b2 (v2 - v0)` in f64: the edge vectors of an axis-aligned floor
    /// have exact zeros across it, so its height stays exact whatever the floor's size, and
    /// elsewhere the f64 error is ~1e-16 of the triangle's size. The bound is that error
    /// (the edge functions' rounding carried through the division, then the interpolation's)
    /// plus the exact distance of the f64 point to its f32 rounding.
    pub fn hit_point(&self, tri: &Triangle) -> Option<HitPoint> {
        let (p0, p1, p2) = (self.vertex(tri.v0), self.vertex(tri.v1), self.vertex(tri.v2));
        let e = [edge(p1, p2), edge(p2, p0), edge(p0, p1)];
        let det = e[0] + e[1] + e[2];
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let (b1, b2) = (e[1] / det, e[2] / det);
        // The edge functions' rounding (t_rounding's delta_e), the sum's, then the quotient's:
        // |d b_i| <= (de + |b_i| d det) / |det| + u |b_i|, doubled for the second-order terms.
        let max = |k: usize| [p0, p1, p2].iter().fold(0.0f64, |m, v| m.max(v[k].abs()));
        let (max_x, max_y, max_z) = (max(0), max(1), max(2));
        let (delta_x, delta_y) = (gamma64(5) * (max_x + max_z), gamma64(5) * (max_y + max_z));
        let delta_e = 2.0 * (gamma64(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
        let delta_det = 3.0 * delta_e + gamma64(2) * (e[0].abs() + e[1].abs() + e[2].abs());
        let db = |b: f64| 2.0 * ((delta_e + b.abs() * delta_det) / det.abs() + gamma64(1) * b.abs());
        let v0 = Vec3::from(tri.v0).as_dvec3();
        let (d1, d2) = (Vec3::from(tri.v1).as_dvec3() - v0, Vec3::from(tri.v2).as_dvec3() - v0);
        let p = v0 + b1 * d1 + b2 * d2;
        // The differences (one rounding each), the products and the two sums: gamma(4).
        let interpolation = gamma64(4) * (v0.abs() + (b1 * d1).abs() + (b2 * d2).abs());
        let error = interpolation + db(b1) * d1.abs() + db(b2) * d2.abs();
        let p32 = p.as_vec3();
        let rounding = (p32.as_dvec3() - p).abs();
        // Rounded up to f32 (one ulp over), plus the smallest normal f32 so that an exact
        // point of a plane through 0 still leaves it.
        let p_error = ((error + rounding) * (1.0 + 2.0 * f32::EPSILON as f64)).as_vec3()
            + Vec3::splat(f32::MIN_POSITIVE);
        Some(HitPoint { p: p32, p_error, b1: b1 as f32, b2: b2 as f32 })
    }
}

/// A hit's point in f32 with its error bound and barycentrics ([`ShearedRay::hit_point`]).
#[derive(Debug, Clone, Copy)]
pub struct HitPoint {
    pub p: Vec3,
    pub p_error: Vec3,
    /// The weights of `v1` and `v2` (for attributes: normals, uvs).
    pub b1: f32,
    pub b2: f32,
}

/// `gamma(n)` in f64's unit roundoff.
#[inline(always)]
fn gamma64(n: u32) -> f64 {
    let nu = n as f64 * f64::EPSILON * 0.5;
    nu / (1.0 - nu)
}

/// A bound on the rounding of a hit's t (pbrt-v4's `deltaT`, Pharr et al. 2023, 6.8.7), in
/// f64's unit roundoff: from the frame's coordinates' (translation and shear: gamma(5) of x
/// or y plus z, gamma(3) of the scaled z) through the edge functions and their weighted sum.
#[inline(always)]
fn t_rounding(p: [[f64; 3]; 3], z: DVec3, e: [f64; 3], det: f64) -> f64 {
    let g = |n: u32| {
        let nu = n as f64 * f64::EPSILON * 0.5;
        nu / (1.0 - nu)
    };
    let max = |k: usize| p.iter().fold(0.0f64, |m, v| m.max(v[k].abs()));
    let (max_x, max_y, max_z) = (max(0), max(1), z.abs().max_element());
    let (delta_x, delta_y, delta_z) = (g(5) * (max_x + max_z), g(5) * (max_y + max_z), g(3) * max_z);
    let delta_e = 2.0 * (g(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    let max_e = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    3.0 * (g(3) * max_e * max_z + delta_e * max_z + delta_z * max_e) / det.abs()
}

/// The edge function of (a, b) seen along the ray: antisymmetric bit for bit (the products
/// commute, the difference negates exactly), so the triangles on either side of a shared
/// edge agree on it.
#[inline(always)]
fn edge(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A uniform [0, 1) f32 stream (xorshift64, 24 bits).
    fn uniform(mut state: u64) -> impl FnMut() -> f32 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    fn tri(v: [Vec3; 3]) -> Triangle {
        Triangle { v0: v[0].into(), v1: v[1].into(), v2: v[2].into() }
    }

    /// Rays aimed exactly at points of a shared edge, from random origins, between two
    /// random triangles sharing it (both windings): every ray meets at least one of the two,
    /// where Möller-Trumbore left gaps (10,543 of 77,564 seams met by neither side, measured
    /// when this test replaced it).
    #[test]
    fn a_ray_through_a_shared_edge_meets_a_side() {
        let mut next = uniform(0x2545_f491_4f6c_dd1d);
        let (mut met, mut both) = (0, 0);
        for k in 0..200_000 {
            let mut point = |s: f32| Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * s;
            let (a, b) = (point(2.0), point(2.0));
            let (c, d) = (point(2.0), point(2.0));
            let origin = point(20.0);
            let t = next();
            // A point of the edge, rounded: the ray passes within rounding of it.
            let on_edge = a + t * (b - a);
            let direction = on_edge - origin;
            let ray = Ray::new(origin.into(), direction.into(), 0.0, f32::INFINITY);
            let s = ShearedRay::new(&ray);
            // The two sides of edge ab: c and d on opposite sides of the ray's plane through
            // the edge, so that the pair covers the edge as seen from the origin.
            let n = (a - origin).cross(b - origin);
            if n.dot(c - origin).signum() == n.dot(d - origin).signum() {
                continue;
            }
            let (t1, t2) =
                if k % 2 == 0 { (tri([a, b, c]), tri([b, a, d])) } else { (tri([c, a, b]), tri([d, b, a])) };
            let (h1, h2) =
                (s.intersect(&t1, f32::INFINITY).is_some(), s.intersect(&t2, f32::INFINITY).is_some());
            // Both behind the origin (t < 0) can happen only if the edge point is: it is not.
            assert!(h1 || h2, "ray {ray:?} through the edge of {t1:?} and {t2:?} meets neither");
            met += 1;
            both += (h1 && h2) as u32;
        }
        assert!(met > 50_000, "only {met} seams tested");
        eprintln!("{met} seams, {both} rays met both sides");
    }

    /// A ray leaving a point of a triangle (interpolated as hits are, its origin offset by
    /// the one rule) never meets that triangle: the t within its own rounding of 0 is no hit.
    /// Long thin triangles far from the origin, as a map's walls (the f32 frame let 2 of 100,000
    /// such rays meet their own triangle; sauerbraten-zdm2's walls shadowed themselves).
    #[test]
    fn a_ray_leaving_a_triangle_does_not_meet_it() {
        use crate::geometry::point::ShadingPoint;
        use crate::geometry::ray_origin::{interpolation_error, offset_origin, shadow_ray_from};
        let mut next = uniform(0x9e37_79b9_7f4a_7c15);
        let mut met = 0;
        for _ in 0..300_000 {
            let centre = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 20.0;
            let mut corner = || centre + Vec3::new(next() - 0.5, 4.0 * (next() - 0.5), 0.01 * (next() - 0.5));
            let v = [corner(), corner(), corner()];
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            if n == Vec3::ZERO {
                continue;
            }
            let (b1, b2) = (next(), next());
            if b1 + b2 > 1.0 {
                continue;
            }
            let b = [1.0 - b1 - b2, b1, b2];
            let p = b[0] * v[0] + b[1] * v[1] + b[2] * v[2];
            let point = ShadingPoint { p, p_error: interpolation_error(b, v), n_geom: n, n_shading: n };
            // Toward a target above the plane, some nearly grazing.
            let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            let target = p + 5.0 * (d - d.dot(n) * n) + (0.001 + 3.0 * next()) * n;
            let origin = offset_origin(&point, target - p);
            let Some(ray) = shadow_ray_from(origin, target, Vec3::ZERO, -n) else { continue };
            met += ShearedRay::new(&ray).intersect(&tri(v), ray.tmax).is_some() as u32;
        }
        assert_eq!(met, 0, "rays met the triangle they leave");
    }

    /// The hit's t and barycentrics against the exact answer, and a miss outside.
    #[test]
    fn a_hit_reports_t_and_barycentrics() {
        let t = tri([Vec3::new(0.0, 0.0, 2.0), Vec3::new(1.0, 0.0, 2.0), Vec3::new(0.0, 1.0, 2.0)]);
        let ray = |x: f32, y: f32| Ray::new(Vec3A::new(x, y, 0.0), Vec3A::Z, 0.0, f32::INFINITY);
        let (hit_t, b1, b2) = ShearedRay::new(&ray(0.25, 0.5)).intersect(&t, f32::INFINITY).unwrap();
        assert_eq!((hit_t, b1, b2), (2.0, 0.25, 0.5));
        assert!(ShearedRay::new(&ray(0.75, 0.5)).intersect(&t, f32::INFINITY).is_none());
        // tmax below the hit, tmin at it (strict): misses.
        assert!(ShearedRay::new(&ray(0.25, 0.25)).intersect(&t, 1.5).is_none());
        let mut start = ray(0.25, 0.25);
        start.tmin = 2.0;
        assert!(ShearedRay::new(&start).intersect(&t, f32::INFINITY).is_none());
    }
}
