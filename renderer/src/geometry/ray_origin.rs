//! The one rule for ray origins and shadow-ray ends (after pbrt-v4's `OffsetRayOrigin` and
//! `SpawnRayTo`; see ARCHITECTURE.md, "Ray origins").
//!
//! Every hit carries a conservative bound on its own floating-point error (`p_error`, per
//! component, see [`interpolation_error`]). A ray leaving the hit starts at
//! [`offset_origin`]: the point pushed along the geometric normal just past that error box,
//! on the side the ray travels to, rounded away from the point. A shadow ray
//! ([`shadow_ray`]) ends short of its target by the target's own bound (pushed toward the
//! origin the same way) and then by [`SHADOW_EPSILON`] of its length, the intersector's
//! rounding of `t` near the far end. Nothing scales with the scene's size.

use crate::geometry::point::ShadingPoint;
use glam::{Vec3, Vec3A};
use obvhs::ray::Ray;

/// The unit roundoff of f32 (half an ulp of 1).
pub const UNIT_ROUNDOFF: f32 = f32::EPSILON * 0.5;

/// `gamma(n) = n u / (1 - n u)`: the relative error bound of `n` successive f32 roundings
/// (Higham; pbrt's `gamma`).
#[inline]
pub const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * UNIT_ROUNDOFF;
    nu / (1.0 - nu)
}

/// Fraction of a shadow ray's length it stops short of its (already offset) end: the
/// relative rounding of the ray-triangle test's `t` for geometry lying in the light's plane (an
/// emitter's own triangles, a ceiling flush with the light). pbrt-v4's `ShadowEpsilon`.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// The error bound of a point interpolated as `b0 v0 + b1 v1 + b2 v2` in f32, with
/// `b0 = 1 - b1 - b2` also in f32 (b1, b2 in [0, 1]). Against the point with the same b1, b2
/// and the exact `b0` (which lies exactly in the plane of `v0, v1, v2`): three products and
/// two sums, gamma(3) of `sum |b_i v_i|`, and b0's own absolute rounding (two operations on
/// magnitudes <= 1: <= 2u(1 + u)) times `|v0|`. pbrt's gamma(7) bound on the sum, with
/// the `|v0|` term for b0, so that a point next to a vertex far from the origin is covered.
/// Plus the smallest normal f32 (1.2e-38) in every component: an exact point of an
/// axis-aligned plane through 0 still leaves it, by a normal (not subnormal) number.
#[inline]
pub fn interpolation_error(b: [f32; 3], v: [Vec3; 3]) -> Vec3 {
    let sum = (b[0] * v[0]).abs() + (b[1] * v[1]).abs() + (b[2] * v[2]).abs();
    gamma(7) * (sum + v[0].abs()) + Vec3::splat(f32::MIN_POSITIVE)
}

/// The error bound to give a surface point known only by its f32 position (a query made by
/// hand, a point rounded once from an exact one): gamma(7) of its magnitude, plus the floor
/// of [`interpolation_error`]. A hit's own bound is its point's
/// [`crate::ShadingPoint::p_error`].
#[inline]
pub fn point_error(p: Vec3) -> Vec3 {
    gamma(7) * p.abs() + Vec3::splat(f32::MIN_POSITIVE)
}

/// The origin of a ray leaving `point` in direction `toward` (any vector on the side it
/// leaves to): `point.p` moved by `d = |n_geom| . p_error` along `n_geom` (past the error
/// box, so on the right side of the surface's plane), each component then rounded one float
/// further away from `p`.
#[inline]
pub fn offset_origin(point: &ShadingPoint, toward: Vec3) -> Vec3 {
    offset_past_error(point.p, point.p_error, point.n_geom, toward)
}

/// The rule of [`offset_origin`] for any surface point `p` (error bound `p_error`, unit
/// normal `n`): the shading point's origin, and a shadow ray's end on the light
/// ([`shadow_ray_from`]).
#[inline]
fn offset_past_error(p: Vec3, p_error: Vec3, n: Vec3, toward: Vec3) -> Vec3 {
    let d = n.abs().dot(p_error);
    let mut offset = d * n;
    if toward.dot(n) < 0.0 {
        offset = -offset;
    }
    let po = p + offset;
    let away = |x: f32, o: f32| {
        if o > 0.0 {
            x.next_up()
        } else if o < 0.0 {
            x.next_down()
        } else {
            x
        }
    };
    Vec3::new(away(po.x, offset.x), away(po.y, offset.y), away(po.z, offset.z))
}

/// A shadow ray from surface point `point` to `target`, a point on a surface of normal
/// `target_normal` with error `target_error` (a light point:
/// [`crate::RectLight::point_error`]). It starts at [`offset_origin`], aims at the target
/// moved by its own bound toward the origin's side of its plane (rounded away likewise), and
/// stops [`SHADOW_EPSILON`] of the way short of that. Unit direction, so `t` is a distance.
/// `None` if nothing is left of the segment.
#[inline]
pub fn shadow_ray(
    point: &ShadingPoint,
    target: Vec3,
    target_error: Vec3,
    target_normal: Vec3,
) -> Option<Ray> {
    shadow_ray_from(offset_origin(point, target - point.p), target, target_error, target_normal)
}

/// [`shadow_ray`] from an origin already offset (`offset_origin(point, target - point.p)`,
/// which takes one of two values per surface point: a caller tracing many rays from one
/// point computes it once per side).
#[inline]
pub fn shadow_ray_from(origin: Vec3, target: Vec3, target_error: Vec3, target_normal: Vec3) -> Option<Ray> {
    let end = offset_past_error(target, target_error, target_normal, origin - target);
    segment_ray(origin, end)
}

/// The ray from `origin` to `end` that stops [`SHADOW_EPSILON`] of the way short.
#[inline]
pub fn segment_ray(origin: Vec3, end: Vec3) -> Option<Ray> {
    let d = end - origin;
    let mut dist = d.length();
    if !(dist.is_finite() && dist > 1e-18) {
        // |d|^2 overflows (a 1e20 scene) or is subnormal (a 1e-20 one): scale it first. The
        // rare path; the common one is a single length.
        let m = d.abs().max_element();
        dist = m * (d / m).length();
    }
    let tmax = dist * (1.0 - SHADOW_EPSILON);
    if tmax.is_nan() || tmax <= 0.0 || !tmax.is_finite() {
        return None;
    }
    Some(Ray::new(Vec3A::from(origin), Vec3A::from(d / dist), 0.0, tmax))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_matches_its_definition() {
        assert_eq!(gamma(0), 0.0);
        let g = gamma(7) as f64;
        let u = (f32::EPSILON as f64) / 2.0;
        assert!((g - 7.0 * u / (1.0 - 7.0 * u)).abs() < 1e-6 * g);
    }

    #[test]
    fn the_origin_leaves_the_error_box_on_the_requested_side() {
        let p = Vec3::new(100.0, -3.0, 0.25);
        let e = Vec3::new(1e-5, 2e-6, 1e-7);
        let n = Vec3::new(0.6, 0.8, 0.0);
        let point = ShadingPoint { p, p_error: e, n_geom: n, n_shading: n };
        let up = offset_origin(&point, n);
        let down = offset_origin(&point, -n);
        let d = n.abs().dot(e);
        assert!((up - p).dot(n) >= d * 0.999 && (down - p).dot(n) <= -d * 0.999);
        // Rounded away: never onto p, even for a zero bound.
        let e = interpolation_error([1.0, 0.0, 0.0], [Vec3::new(1.0, 0.0, 2.0), Vec3::X, Vec3::Z]);
        let point =
            ShadingPoint { p: Vec3::new(1.0, 0.0, 2.0), p_error: e, n_geom: Vec3::Y, n_shading: Vec3::Y };
        let o = offset_origin(&point, Vec3::Y);
        assert!(o.y >= f32::MIN_POSITIVE && o.x == 1.0 && o.z == 2.0, "{o}");
    }
}
