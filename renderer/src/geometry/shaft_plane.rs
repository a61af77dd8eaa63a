//! A shaft's separating axis along a triangle's normal (`Shaft::triangle_outside`): the hull's
//! vertices all on one side of the triangle's plane, each projection with its rounding; in
//! f32 where the products stay finite and normal, in f64 otherwise (a triangle over ~4e9 m
//! wide overflowed |n|^2 and disabled every shaft beside it).

use crate::geometry::ray_origin::gamma;
use glam::{Vec3, Vec3A};

/// `x > 0` (false for NaN).
#[inline]
fn is_positive(x: f32) -> bool {
    x > 0.0
}

/// [`crate::geometry::shaft::Shaft::triangle_outside`]'s plane axis in f32; `None` where a product overflows or
/// underflows (the f64 test decides).
#[inline]
pub(crate) fn separates(hull: &[Vec3A; 5], slack: f32, [v0, v1, v2]: [Vec3A; 3]) -> Option<bool> {
    let (e1, e2) = (v1 - v0, v2 - v0);
    let n = e1.cross(e2);
    let len = n.length();
    if !is_positive(len) || !len.is_finite() || len < 1e-18 {
        return None;
    }
    let na = n.abs();
    let proj = |w: Vec3A| (n.dot(w), gamma(5) * na.dot(w.abs()));
    let (mut tri_lo, mut tri_hi) = (0.0f32, 0.0f32);
    for w in [e1, e2] {
        let (s, r) = proj(w);
        tri_lo = tri_lo.min(s - r);
        tri_hi = tri_hi.max(s + r);
    }
    let margin = slack * len;
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for &v in hull {
        let (s, r) = proj(v - v0);
        lo = lo.min(s - r);
        hi = hi.max(s + r);
    }
    let all = [tri_lo, tri_hi, margin, lo, hi];
    all.iter().all(|x| x.is_finite()).then_some(lo > tri_hi + margin || hi < tri_lo - margin)
}

/// The plane axis in f64 (the f32 coordinates are exact there; every product of them
/// is finite): the same test with f64's rounding bound. `false` for a triangle of no
/// area.
#[cold]
pub(crate) fn separates_f64(hull: &[Vec3A; 5], slack: f32, [v0, v1, v2]: [Vec3A; 3]) -> bool {
    let [v0, v1, v2] = [v0, v1, v2].map(|v| Vec3::from(v).as_dvec3());
    let (e1, e2) = (v1 - v0, v2 - v0);
    let n = e1.cross(e2);
    let len = n.length();
    if !(len > 0.0 && len.is_finite()) {
        return false;
    }
    // gamma(6) in f64: the subtraction, three products and two sums.
    let g = 6.0 * f64::EPSILON / (2.0 - 6.0 * f64::EPSILON);
    let na = n.abs();
    let proj = |w: glam::DVec3| (n.dot(w), g * na.dot(w.abs()));
    let (mut tri_lo, mut tri_hi) = (0.0f64, 0.0f64);
    for w in [e1, e2] {
        let (s, r) = proj(w);
        tri_lo = tri_lo.min(s - r);
        tri_hi = tri_hi.max(s + r);
    }
    let margin = slack as f64 * len;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in hull {
        let (s, r) = proj(Vec3::from(v).as_dvec3() - v0);
        lo = lo.min(s - r);
        hi = hi.max(s + r);
    }
    lo > tri_hi + margin || hi < tri_lo - margin
}
