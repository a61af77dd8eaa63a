//! The fitted table against brute force: LTC × norm over rectangles against f64 quadrature of
//! D·V·cos over the same rectangles.

use crate::shading::ltc::{LtcLobe, ltc_lobe};
use crate::shading::quadrature::{Side, for_each_reflected, smith_visibility_f64, specular_moments};
use crate::util::random::Rng;
use glam::DVec3;

/// A rectangle seen from the shading point: centre and half-axis vectors.
#[derive(Debug, Clone, Copy)]
pub(super) struct Rect {
    pub center: DVec3,
    pub ex: DVec3,
    pub ey: DVec3,
}

impl Rect {
    /// Facing the origin at `dir` (unit) and `distance`, half sizes `hx`, `hy`, turned by
    /// `spin` about its normal and tilted by `tilt` about its first axis.
    pub fn facing(dir: DVec3, distance: f64, hx: f64, hy: f64, spin: f64, tilt: f64) -> Self {
        let up = if dir.z.abs() < 0.9 { DVec3::Z } else { DVec3::X };
        let a = dir.cross(up).normalize();
        let b = dir.cross(a);
        let (a, b) = (a * spin.cos() + b * spin.sin(), b * spin.cos() - a * spin.sin());
        let b = b * tilt.cos() + dir * tilt.sin();
        Rect { center: dir * distance, ex: a * hx, ey: b * hy }
    }

    pub fn corners(&self) -> [DVec3; 4] {
        let (c, x, y) = (self.center, self.ex, self.ey);
        [c - x - y, c + x - y, c + x + y, c - x + y]
    }

    /// Whether the ray from the origin along `w` meets the rectangle.
    pub fn hit(&self, w: DVec3) -> bool {
        let n = self.ex.cross(self.ey);
        let denom = w.dot(n);
        if denom == 0.0 {
            return false;
        }
        let t = self.center.dot(n) / denom;
        if t <= 0.0 {
            return false;
        }
        let q = w * t - self.center;
        q.dot(self.ex).abs() <= self.ex.length_squared() && q.dot(self.ey).abs() <= self.ey.length_squared()
    }
}

/// `∫ D·V·cos dω` over each rectangle (above the surface), by the half-vector rule with
/// `n × n` nodes.
pub(super) fn brute_force(alpha: f64, cos_v: f64, rects: &[Rect], n: usize) -> Vec<f64> {
    let mut sums = vec![0.0; rects.len()];
    for_each_reflected(alpha, cos_v, n, n, Side::Above, |wi, _, w| {
        let value = w * wi.z * smith_visibility_f64(alpha, wi.z, cos_v);
        for (s, r) in sums.iter_mut().zip(rects) {
            if r.hit(wi) {
                *s += value;
            }
        }
    });
    sums
}

/// The test's rectangles at one roughness and view: around the mirror direction at three
/// sizes of the lobe's scale and off it, one over the whole hemisphere, walls crossing the
/// surface's horizon on four sides, one straddling the LTC horizon, and random ones.
pub(super) fn rectangles(alpha: f64, cos_v: f64, lobe: &LtcLobe, rng: &mut Rng) -> Vec<(&'static str, Rect)> {
    let sin_v = (1.0 - cos_v * cos_v).sqrt();
    let mirror = DVec3::new(-sin_v, 0.0, cos_v);
    let width = (2.0 * alpha).max(0.01);
    let mut rects = vec![
        ("mirror, half-width w/2", Rect::facing(mirror, 1.0, 0.5 * width, 0.5 * width, 0.0, 0.0)),
        ("mirror, 2w", Rect::facing(mirror, 1.0, 2.0 * width, 2.0 * width, 0.3, 0.0)),
        ("mirror, 8w, tilted", Rect::facing(mirror, 3.0, 24.0 * width, 12.0 * width, 0.7, 0.6)),
        ("whole hemisphere", Rect { center: DVec3::Z, ex: DVec3::X * 1e4, ey: DVec3::Y * 1e4 }),
    ];
    for (k, name) in [(1.0, "off mirror by w"), (3.0, "off mirror by 3w")] {
        let off = (mirror + DVec3::new(0.0, k * width, 0.0)).normalize();
        rects.push((name, Rect::facing(off, 1.0, width, width, 0.0, 0.0)));
        let toward = (mirror + DVec3::new(k * width * cos_v, 0.0, k * width * sin_v)).normalize();
        rects.push((name, Rect::facing(toward, 2.0, 2.0 * width, width, 0.0, 0.0)));
    }
    for (dir, name) in [
        (DVec3::NEG_X, "wall across the horizon, -x"),
        (DVec3::X, "wall across the horizon, +x"),
        (DVec3::Y, "wall across the horizon, +y"),
    ] {
        let wall =
            Rect { center: dir * 2.0 + DVec3::new(0.0, 0.0, 0.3), ex: dir.cross(DVec3::Z), ey: DVec3::Z };
        rects.push((name, wall));
    }
    let m = lobe.horizon_normal();
    let on_ltc_horizon = DVec3::Z - m * m.z;
    if on_ltc_horizon.length() > 1e-3 && m.dot(DVec3::Z) < 0.999 {
        let d = on_ltc_horizon.normalize();
        rects.push(("straddling the LTC horizon", Rect::facing(d, 1.0, 0.3, 0.3, 0.2, 0.0)));
    }
    for _ in 0..6 {
        let z = rng.next_f32() as f64;
        let phi = std::f64::consts::TAU * rng.next_f32() as f64;
        let r = (1.0 - z * z).sqrt();
        let dir = DVec3::new(r * phi.cos(), r * phi.sin(), z);
        let size = 0.05 * 40f64.powf(rng.next_f32() as f64);
        let (spin, tilt) = (rng.next_f32() as f64 * 3.0, rng.next_f32() as f64 - 0.5);
        rects.push(("random", Rect::facing(dir, 1.0, size, size * 0.6, spin, tilt)));
    }
    rects
}

/// View angles of the accuracy test, degrees.
const VIEWS: [f64; 6] = [0.0, 20.0, 40.0, 60.0, 75.0, 85.0];

/// Limits on |LTC·norm − brute force| / peak, peak the largest brute-force integral among the
/// rectangles at that roughness and view (about `norm`: the whole-hemisphere rectangle is one
/// of them). 1% wherever the fit holds it; elsewhere the error measured with the committed
/// table + 20%, rounded up to 0.5%: these are the fit's limits, not the test's slack. The
/// shading's unshadowed S does not carry them: it integrates the true lobe with nodes placed
/// by the fit (the next test, 1%).
/// Worst measured: 7.7% (r 0.05, 85°), 5.4% (r 0.3, 85°), 2.2% (r 0.5, 60°), 1.5% (r 0.5, 0°).
const LIMITS: [(f64, [f64; 6]); 8] = [
    (0.05, [0.01, 0.01, 0.01, 0.01, 0.025, 0.095]),
    (0.10, [0.01, 0.01, 0.01, 0.01, 0.01, 0.035]),
    (0.20, [0.01, 0.01, 0.01, 0.01, 0.015, 0.055]),
    (0.30, [0.01, 0.01, 0.01, 0.015, 0.04, 0.07]),
    (0.50, [0.02, 0.015, 0.015, 0.03, 0.035, 0.065]),
    (0.70, [0.015, 0.01, 0.015, 0.03, 0.035, 0.055]),
    (0.90, [0.01, 0.01, 0.01, 0.01, 0.02, 0.04]),
    (1.00, [0.01, 0.01, 0.01, 0.015, 0.025, 0.035]),
];

#[test]
fn ltc_matches_brute_force_over_rectangles() {
    // Brute force: 768 × 768 nodes of the half-vector rule with the rectangle as an indicator;
    // its own error, measured against 1024², is below 3e-4 of the peak.
    let mut rng = Rng::new(7);
    let mut failures = Vec::new();
    for (r, limits) in LIMITS {
        let alpha = r * r;
        let mut line = format!("r {r:.2}:");
        for (deg, limit) in VIEWS.into_iter().zip(limits) {
            let cos_v = deg.to_radians().cos();
            let lobe = ltc_lobe(r as f32, cos_v as f32);
            let named = rectangles(alpha, cos_v, &lobe, &mut rng);
            let rects: Vec<Rect> = named.iter().map(|p| p.1).collect();
            let brute = brute_force(alpha, cos_v, &rects, 768);
            let (norm, _) = specular_moments(alpha, cos_v, 384);
            assert!(
                (brute[3] - norm).abs() < 1e-4 * norm,
                "brute force over the hemisphere {} vs {norm}",
                brute[3]
            );
            let peak = brute.iter().cloned().fold(0.0, f64::max);
            let mut worst = (0.0, "");
            for ((name, rect), b) in named.iter().zip(&brute) {
                let error = (lobe.polygon_integral(&rect.corners()) * lobe.norm - b).abs() / peak;
                if error > worst.0 {
                    worst = (error, name);
                }
            }
            line += &format!(" {deg}°: {:.4}", worst.0);
            if worst.0 > limit {
                failures.push(format!("r {r}, {deg}°: {:.4} > {limit} ({})", worst.0, worst.1));
            }
        }
        eprintln!("{line}");
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The lobe's own integral by quadrature in the cosine space
/// ([`polygon_lobe_moments`](crate::shading::lobe_integral::polygon_lobe_moments)) against the
/// same brute force, over the same rectangles, roughness 0.05-1 and views 0-85°: within 1% of
/// the peak everywhere (the bound), and the Schlick moment too.
#[test]
fn lobe_quadrature_matches_brute_force_over_rectangles() {
    use crate::shading::lobe_integral::polygon_lobe_moments;
    let mut rng = Rng::new(7);
    let mut worst_all: f64 = 0.0;
    let mut failures = Vec::new();
    for (r, _) in LIMITS {
        let alpha = r * r;
        let mut line = format!("r {r:.2}:");
        for deg in VIEWS {
            let cos_v = deg.to_radians().cos();
            let lobe = ltc_lobe(r as f32, cos_v as f32);
            let named = rectangles(alpha, cos_v, &lobe, &mut rng);
            let rects: Vec<Rect> = named.iter().map(|p| p.1).collect();
            let brute = brute_force(alpha, cos_v, &rects, 768);
            let peak = brute.iter().cloned().fold(0.0, f64::max);
            // The Schlick moment over the whole hemisphere against the table's quadrature.
            let (norm, fresnel) = specular_moments(alpha, cos_v, 384);
            let (_, f) = polygon_lobe_moments(&lobe, alpha, cos_v, &rects[3].corners());
            assert!((f - fresnel).abs() < 1e-3 * norm, "r {r}, {deg}°: fresnel {f} vs {fresnel}");
            let mut worst = (0.0, "");
            for ((name, rect), b) in named.iter().zip(&brute) {
                let (s, _) = polygon_lobe_moments(&lobe, alpha, cos_v, &rect.corners());
                let error = (s - b).abs() / peak;
                if error > worst.0 {
                    worst = (error, name);
                }
            }
            worst_all = worst_all.max(worst.0);
            line += &format!(" {deg}°: {:.5}", worst.0);
            if worst.0 > 0.01 {
                failures.push(format!("r {r}, {deg}°: {:.4} ({})", worst.0, worst.1));
            }
        }
        eprintln!("{line}");
    }
    eprintln!("worst {worst_all:.5}");
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Edge cases of the quadrature: a rectangle under the surface gives 0, either winding the
/// same (to rounding), and a tiny one the lobe's value times its solid angle (to 1e-6 relative).
#[test]
fn lobe_quadrature_edge_cases() {
    use crate::shading::lobe_integral::polygon_lobe_moments;
    let (r, cos_v): (f64, f64) = (0.3, 0.6);
    let alpha = r * r;
    let lobe = ltc_lobe(r as f32, cos_v as f32);
    let below = Rect::facing(DVec3::new(0.3, 0.2, -0.9).normalize(), 1.0, 0.2, 0.2, 0.0, 0.0);
    assert_eq!(polygon_lobe_moments(&lobe, alpha, cos_v, &below.corners()), (0.0, 0.0));
    let sin_v = (1.0 - cos_v * cos_v).sqrt();
    let mirror = DVec3::new(-sin_v, 0.0, cos_v);
    let tiny = Rect::facing(mirror, 1.0, 1e-4, 1e-4, 0.0, 0.0);
    let mut corners = tiny.corners();
    let (s, _) = polygon_lobe_moments(&lobe, alpha, cos_v, &corners);
    corners.reverse();
    let reversed = polygon_lobe_moments(&lobe, alpha, cos_v, &corners).0;
    assert!((reversed - s).abs() <= 1e-12 * s, "{reversed} vs {s}");
    // Solid angle of a 2e-4 square at distance 1, head-on: 4e-8 (1 − O(1e-8)).
    let value = crate::shading::quadrature::ggx_d_f64(alpha, 1.0)
        * crate::shading::quadrature::smith_visibility_f64(alpha, cos_v, cos_v)
        * cos_v;
    assert!((s / (value * 4e-8) - 1.0).abs() < 1e-6, "{s} vs {}", value * 4e-8);
}
