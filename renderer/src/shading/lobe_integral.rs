//! The specular lobe's own integral over a polygon, by quadrature in the LTC's cosine space:
//! the unshadowed `S` of a glossy surface under a rectangle, without the fit's shape error.
//!
//! [`LtcLobe::polygon_integral`](super::ltc::LtcLobe::polygon_integral) integrates the *fit*:
//! exact for the fit, off the true lobe by the fit's shape (up to 7.7% of the lobe's albedo at
//! 85° views, see [`super::ltc`]). Here the fit only chooses where the nodes go. The change of
//! variables `w = M·w'/|M·w'|` (M = minv⁻¹), a bijection of the sphere, carries the lobe into the
//! cosine space, where it is nearly `norm·cos/π`: smooth and broad for any roughness. There the
//! polygon (clipped to the surface, then mapped) is cut into spherical triangles of at most
//! [`MAX_EDGE`] radians a side, and each is integrated by Radon's 7-point degree-5 rule on the
//! flat triangle through its corners, projected (gnomonic: `dω = det(a, b, c) / (2 |y|³) dA` in
//! barycentric measure). Mapped back by M, the triangle's corners `A = M a` keep the form:
//!
//! ```text
//! ∫ over the triangle of f(w) dω  ≈  Σ_k  weight_k · f(y_k / |y_k|) · det(A, B, C) / (2 |y_k|³),
//! y_k = λ_k A + μ_k B + ν_k C
//! ```
//!
//! so every node costs one GGX evaluation and a square root. The true lobe is evaluated, so
//! the fit's error only moves nodes; the mass beyond the fit's horizon is integrated too
//! (nothing is clipped in the cosine space). Measured against brute force in
//! `tests/ltc_accuracy.rs`.

use super::ltc::{HalfSpaceClip, LtcLobe};
use super::quadrature::{ggx_d_f64, smith_lambda_f64};
use glam::DVec3;

/// The longest side of a quadrature triangle in the cosine space, radians. Chosen by
/// `tests/ltc_accuracy.rs`: see the limits there.
pub const MAX_EDGE: f64 = 0.6;

/// Subdivision depth cap: a side of π halves to under [`MAX_EDGE`] in 3 levels; 5 is slack.
const MAX_DEPTH: u32 = 8;

/// Radon's 7-point rule of degree 5 on a triangle: barycentric nodes and weights summing to 1.
const RULE: [([f64; 3], f64); 7] = {
    // a = (6 − √15)/21, b = (6 + √15)/21; weights (155 ∓ √15)/1200 and 9/40.
    const A: f64 = 0.101_286_507_323_456_34;
    const B: f64 = 0.470_142_064_105_115_1;
    const WA: f64 = 0.125_939_180_544_827_15;
    const WB: f64 = 0.132_394_152_788_506_2;
    [
        ([1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0], 0.225),
        ([A, A, 1.0 - 2.0 * A], WA),
        ([A, 1.0 - 2.0 * A, A], WA),
        ([1.0 - 2.0 * A, A, A], WA),
        ([B, B, 1.0 - 2.0 * B], WB),
        ([B, 1.0 - 2.0 * B, B], WB),
        ([1.0 - 2.0 * B, B, B], WB),
    ]
};

/// `∫ D·Vis·cos dω` and `∫ (1 − wo·h)^5·D·Vis·cos dω` of the GGX lobe (`alpha`, view
/// `wo = (sinθ_v, 0, cosθ_v)`, the frame of [`super::ltc`]) over the polygon `v` (directions
/// from the shading point, in order, at most 7, any winding), clipped to `z >= 0`. `ltc` is
/// the lobe's fit, used only to place the nodes. No allocation.
pub fn polygon_lobe_moments(ltc: &LtcLobe, alpha: f64, cos_v: f64, v: &[DVec3]) -> (f64, f64) {
    assert!(v.len() <= 7, "a polygon of at most 7 vertices");
    let mut cosine_space = [DVec3::ZERO; 8];
    let mut count = 0;
    {
        let mut keep = |p: DVec3| {
            let q = ltc.minv * p;
            let len = q.length();
            if len > 0.0 {
                cosine_space[count] = q / len;
                count += 1;
            }
        };
        let mut clip = HalfSpaceClip::new(DVec3::Z);
        for &p in v {
            clip.push(p, &mut keep);
        }
        clip.finish(&mut keep);
    }
    if count < 3 || cos_v <= 0.0 {
        return (0.0, 0.0);
    }
    let corners = &cosine_space[..count];
    let lobe = Lobe {
        m: ltc.minv.inverse(),
        alpha,
        wo: DVec3::new((1.0 - cos_v * cos_v).max(0.0).sqrt(), 0.0, cos_v),
        lambda_v: smith_lambda_f64(alpha, cos_v),
    };
    let mut sums = (0.0, 0.0);
    let cos_max = MAX_EDGE.cos();
    if corners.iter().all(|c| c.dot(corners[0]) >= cos_max) {
        // Small: a fan from a corner, count − 2 triangles that need no subdivision in the
        // cosine space (half the nodes of the centroid's fan; most lights are this).
        for k in 1..count - 1 {
            lobe.triangle(corners[0], corners[k], corners[k + 1], &mut sums);
        }
    } else {
        let Some(center) = spherical_centroid(corners) else {
            return (0.0, 0.0);
        };
        for k in 0..count {
            lobe.triangle(center, corners[k], corners[(k + 1) % count], &mut sums);
        }
    }
    // One winding throughout: the sign of the sum is the polygon's orientation.
    if sums.0 < 0.0 { (-sums.0, -sums.1) } else { sums }
}

/// The direction of `∫ w dω` over the convex spherical polygon `corners` (unit, in order):
/// Stokes turns it into `½ Σ θ_k n_k` over the edges (θ the edge's angle, n its great circle's
/// unit normal). A positive combination of the polygon's own directions, so inside it and well
/// away from its rim; fan triangles from it stay fat and shrink under subdivision. (The mean of
/// the corners is not: a near-hemisphere whose corners lie around its rim puts it on the rim,
/// and the fan's middle triangles then never shrink.) None for a degenerate polygon.
fn spherical_centroid(corners: &[DVec3]) -> Option<DVec3> {
    let mut sum = DVec3::ZERO;
    for (k, &a) in corners.iter().enumerate() {
        let b = corners[(k + 1) % corners.len()];
        let c = a.cross(b);
        let s = c.length();
        if s > 0.0 {
            sum += c * (s.atan2(a.dot(b)) / s);
        }
    }
    // Clockwise polygons give the antipode: turn it to the corners' side.
    let side: f64 = corners.iter().map(|&a| a.dot(sum)).sum();
    let center = (sum * side.signum()).normalize_or_zero();
    (center != DVec3::ZERO && side != 0.0).then_some(center)
}

/// The lobe and the map back from the cosine space.
struct Lobe {
    m: glam::DMat3,
    alpha: f64,
    wo: DVec3,
    /// Smith's Λ of the view, the same for every node.
    lambda_v: f64,
}

impl Lobe {
    /// Adds the triangle `(a, b, c)` (unit, cosine space) to `sums`, subdivided at side
    /// midpoints until every side is under [`MAX_EDGE`].
    fn triangle(&self, a: DVec3, b: DVec3, c: DVec3, sums: &mut (f64, f64)) {
        let cos_max = MAX_EDGE.cos();
        let mut stack = [([DVec3::ZERO; 3], 0u32); 3 * MAX_DEPTH as usize + 2];
        stack[0] = ([a, b, c], 0);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let ([a, b, c], depth) = stack[top];
            let world = [self.m * a, self.m * b, self.m * c];
            let [wa, wb, wc] = world.map(|p| p.normalize());
            // Short in both spaces: the cosine space places nodes where the lobe is, the
            // world's angles where the map stretches (the fit's thin tail near the horizon).
            let long =
                |p: DVec3, q: DVec3, r: DVec3| p.dot(q) < cos_max || q.dot(r) < cos_max || r.dot(p) < cos_max;
            if (long(a, b, c) || long(wa, wb, wc)) && depth < MAX_DEPTH {
                let mid = |p: DVec3, q: DVec3| (p + q).normalize_or_zero();
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                for t in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
                    stack[top] = (t, depth + 1);
                    top += 1;
                }
            } else {
                self.leaf(world, sums);
            }
        }
    }

    /// Radon's rule on the flat triangle `(a, b, c)` (local frame, any lengths), projected.
    fn leaf(&self, [a, b, c]: [DVec3; 3], sums: &mut (f64, f64)) {
        // det(a, b, c) as det(a - c, b - c, c): the same value, but for a triangle far
        // smaller than its distance (a tiny light) the differences carry its size, where
        // a . (b x c) would cancel terms ~1e16 times larger than it.
        let det = c.dot((a - c).cross(b - c));
        for ([l, m, n], weight) in RULE {
            let y = a * l + b * m + c * n;
            let len2 = y.length_squared();
            let len = len2.sqrt();
            let w = y / len;
            if w.z <= 0.0 {
                continue;
            }
            let h = (w + self.wo).normalize();
            // D·Vis·cos with Vis = G2/(4 cosθ_l cosθ_v): cosθ_l cancels.
            let g2 = 1.0 / (1.0 + smith_lambda_f64(self.alpha, w.z) + self.lambda_v);
            let value = ggx_d_f64(self.alpha, h.z) * g2 / (4.0 * self.wo.z);
            let jacobian = weight * det / (2.0 * len2 * len);
            sums.0 += value * jacobian;
            sums.1 += value * jacobian * (1.0 - w.dot(h).clamp(0.0, 1.0)).powi(5);
        }
    }
}
