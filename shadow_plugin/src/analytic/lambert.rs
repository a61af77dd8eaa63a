//! Lambert's edge terms on the light's plane, seen from a shading point: the domain the
//! point can see (the light's rectangle above its shading horizon) in light coordinates,
//! and the term of any straight piece of it. Summed round a region (counter-clockwise in
//! light coordinates), the terms give twice its cosine-weighted solid angle, up to one sign
//! shared by every region of the point: V is a ratio of two such sums.
//!
//! In f64, relative to the point (lengths in the point's own distance to the light, so that
//! a scene 1e-3 m or 1e5 m across keeps its digits); the angle by atan2(|a x b|, a . b),
//! which keeps tiny pieces accurate where acos would not.

use super::arrangement::MAX_DOMAIN;
use glam::{DMat3, DVec2, DVec3};
use renderer::RectLight;

/// The light's plane seen from one point.
#[derive(Debug, Clone, Copy)]
pub struct LightPlane {
    /// Light point (0, 0) relative to the point, and the light's edges, in the point's unit.
    corner: DVec3,
    u: DVec3,
    v: DVec3,
    /// The shading normal.
    n: DVec3,
    /// The light's normal (emitting side), and twice the light's area in the point's unit
    /// squared: an area element da db of light coordinates weighs that times g.
    n_light: DVec3,
    area2: f64,
}

impl LightPlane {
    pub fn new(light: &RectLight, p: DVec3, n: DVec3) -> LightPlane {
        let (c, u, v) = (light.center.as_dvec3(), light.u.as_dvec3(), light.v.as_dvec3());
        let corner = c - 0.5 * (u + v) - p;
        let unit = match (c - p).length() {
            d if d > 0.0 && d.is_finite() => d,
            _ => 1.0,
        };
        let (u, v) = (u / unit, v / unit);
        let n_light = light.normal.as_dvec3();
        LightPlane { corner: corner / unit, u, v, n, n_light, area2: 2.0 * u.cross(v).length() }
    }

    /// The same plane in a linearly transformed space, `m` taking the point's vectors there
    /// (a glossy lobe's clamped-cosine space, [`renderer::interface::lobe::GlossyLobe`]): its
    /// terms, weights and row integrals are those of the cosine about z in that space, which
    /// is the lobe's fit here. Light coordinates are kept (a linear map keeps the plane's
    /// affine coordinates), and the point keeps its side of the plane.
    pub fn transformed(&self, m: DMat3) -> LightPlane {
        let (corner, u, v) = (m * self.corner, m * self.u, m * self.v);
        let mut n_light = u.cross(v).normalize_or_zero();
        if (n_light.dot(corner) > 0.0) != (self.n_light.dot(self.corner) > 0.0) {
            n_light = -n_light;
        }
        LightPlane { corner, u, v, n: DVec3::Z, n_light, area2: 2.0 * u.cross(v).length() }
    }

    /// The vector from the point to light point `q` (light coordinates).
    #[inline]
    pub fn at(&self, q: DVec2) -> DVec3 {
        self.corner + q.x * self.u + q.y * self.v
    }

    /// The weight of light point `q` in the units of [`LightPlane::edge_term`]'s sums:
    /// 2 g |u x v|, g = cos(theta_x) cos(theta_y) / r^2 (0 under the horizon), so that
    /// integrated over da db it gives a region's sum.
    #[inline]
    pub fn weight(&self, q: DVec2) -> f64 {
        let w = self.at(q);
        let r2 = w.length_squared();
        let cos_x = self.n.dot(w).max(0.0);
        let cos_y = (-self.n_light.dot(w)).max(0.0);
        self.area2 * cos_x * cos_y / (r2 * r2)
    }

    /// Lambert's term of the straight piece a -> b: angle(A, B) n . unit(A x B).
    #[inline]
    pub fn edge_term(&self, a: DVec2, b: DVec2) -> f64 {
        let (va, vb) = (self.at(a), self.at(b));
        let c = va.cross(vb);
        let len = c.length();
        if len > 0.0 { len.atan2(va.dot(vb)) * self.n.dot(c) / len } else { 0.0 }
    }

    /// [`LightPlane::weight`] integrated along the row at `y` from x0 to x1 (light
    /// coordinates), in closed form: above the horizon (where the rows lie) the weight is
    /// h (c0 + c1 x) / |u|^4 ((x + b)^2 + k^2)^2, with h the point's height over the
    /// light's plane and k the row's distance from the point's foot, in u's lengths.
    pub fn row_integral(&self, y: f64, x0: f64, x1: f64) -> f64 {
        let a = self.corner + y * self.v;
        let uu = self.u.length_squared();
        let h = -self.n_light.dot(a);
        let b = a.dot(self.u) / uu;
        let k = (a - b * self.u).length() / uu.sqrt();
        let (c0, c1) = (self.n.dot(a), self.n.dot(self.u));
        // c0 + c1 x = gamma + c1 t, t = x + b.
        let gamma = c0 - c1 * b;
        let k2 = k * k;
        let i1 = |t: f64| t / (2.0 * k2 * (t * t + k2)) + (t / k).atan() / (2.0 * k2 * k);
        let i2 = |t: f64| -1.0 / (2.0 * (t * t + k2));
        let (t0, t1) = (x0 + b, x1 + b);
        self.area2 * h / (uu * uu) * (gamma * (i1(t1) - i1(t0)) + c1 * (i2(t1) - i2(t0)))
    }

    /// The part of the light's rectangle above the shading horizon (n . (y - p) >= 0), in
    /// light coordinates, counter-clockwise, without repeated corners: its corners in
    /// `out`, their count returned (under 3: nothing of the light is above).
    pub fn domain(&self, out: &mut [DVec2; MAX_DOMAIN]) -> usize {
        let square = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0)];
        clip_polygon(&square, |q| self.height(self.n, q), out)
    }

    /// `normal . (y - p)` at light point `q`, in the point's unit.
    #[inline]
    pub fn height(&self, normal: DVec3, q: DVec2) -> f64 {
        normal.dot(self.at(q))
    }

    /// The sum of the terms round a polygon (light coordinates, in order).
    pub fn polygon_sum(&self, corners: &[DVec2]) -> f64 {
        let n = corners.len();
        (0..n).map(|k| self.edge_term(corners[k], corners[(k + 1) % n])).sum()
    }
}

/// The convex polygon `corners` clipped to g >= 0 (g affine), into `out` without repeated
/// corners; the count returned.
pub fn clip_polygon(corners: &[DVec2], g: impl Fn(DVec2) -> f64, out: &mut [DVec2; MAX_DOMAIN]) -> usize {
    let mut m = 0;
    let mut push = |q: DVec2, out: &mut [DVec2; MAX_DOMAIN]| {
        if (m == 0 || out[m - 1] != q) && m < MAX_DOMAIN {
            out[m] = q;
            m += 1;
        }
    };
    let n = corners.len();
    for k in 0..n {
        let (a, b) = (corners[k], corners[(k + 1) % n]);
        let (ga, gb) = (g(a), g(b));
        if ga >= 0.0 {
            push(a, out);
        }
        if (ga >= 0.0) != (gb >= 0.0) {
            let t = ga / (ga - gb);
            let q = if t <= 0.0 {
                a
            } else if t >= 1.0 {
                b
            } else {
                a + t * (b - a)
            };
            push(q, out);
        }
    }
    if m > 1 && out[m - 1] == out[0] {
        m -= 1;
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Over the domain, the sum is twice the light's irradiance factor (computed by the
    /// renderer's own clipping in 3D), at points whose horizon cuts the light and not.
    #[test]
    fn the_domain_sum_is_the_unshadowed_irradiance() {
        let light = RectLight::new(
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.6),
            Vec3::ONE,
        );
        let cases = [
            (Vec3::new(0.0, 0.0, 0.0), Vec3::Y),
            (Vec3::new(0.3, 1.0, -0.2), Vec3::new(0.8, 0.6, 0.0)),
            (Vec3::new(-1.5, 1.9, 0.1), Vec3::new(0.99, 0.1, 0.1).normalize()),
            (Vec3::new(0.2, 1.99, 0.0), Vec3::new(0.0, 0.7, 0.7).normalize()),
        ];
        for (p, n) in cases {
            let plane = LightPlane::new(&light, p.as_dvec3(), n.as_dvec3());
            let mut corners = [DVec2::ZERO; MAX_DOMAIN];
            let m = plane.domain(&mut corners);
            let sum = plane.polygon_sum(&corners[..m]);
            let expected = light.irradiance_factor_f64(p, n);
            assert!(
                (0.5 * sum.abs() - expected).abs() <= 1e-12 * expected.max(1e-300),
                "{p} {n}: {sum} {expected}"
            );
        }
    }

    /// The weights integrated over the light (a fine midpoint grid) give the domain's sum.
    #[test]
    fn weights_integrate_to_the_domain_sum() {
        let light = RectLight::new(
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.6),
            Vec3::ONE,
        );
        let (p, n) = (Vec3::new(0.3, 1.0, -0.2), Vec3::new(0.8, 0.6, 0.0));
        let plane = LightPlane::new(&light, p.as_dvec3(), n.as_dvec3());
        let mut corners = [DVec2::ZERO; MAX_DOMAIN];
        let m = plane.domain(&mut corners);
        let sum = plane.polygon_sum(&corners[..m]).abs();
        let g = 2000;
        let step = 1.0 / g as f64;
        let mut total = 0.0;
        for i in 0..g {
            for j in 0..g {
                total +=
                    plane.weight(DVec2::new((i as f64 + 0.5) * step, (j as f64 + 0.5) * step)) * step * step;
            }
        }
        assert!((total - sum).abs() < 1e-4 * sum, "{total} against {sum}");
    }

    /// A sub-rectangle's sum equals the irradiance factor of a light that is that
    /// sub-rectangle, from 1e-3 to 1e5 m.
    #[test]
    fn a_part_of_the_light_is_the_light_it_would_be() {
        for scale in [1e-3f32, 1.0, 1e5] {
            let light =
                RectLight::new(Vec3::new(0.0, 2.0, 0.0) * scale, Vec3::X * scale, Vec3::Z * scale, Vec3::ONE);
            let (p, n) = (Vec3::new(0.1, 0.0, 0.2) * scale, Vec3::Y);
            let plane = LightPlane::new(&light, p.as_dvec3(), n.as_dvec3());
            // The part [0.25, 0.75] x [0, 0.5]: centre (0, 2, -0.25), half the sides.
            let part =
                [DVec2::new(0.25, 0.0), DVec2::new(0.75, 0.0), DVec2::new(0.75, 0.5), DVec2::new(0.25, 0.5)];
            let sub = RectLight::new(
                Vec3::new(0.0, 2.0, -0.25) * scale,
                0.5 * Vec3::X * scale,
                0.5 * Vec3::Z * scale,
                Vec3::ONE,
            );
            let expected = sub.irradiance_factor_f64(p, n);
            let got = 0.5 * plane.polygon_sum(&part).abs();
            assert!((got - expected).abs() <= 1e-6 * expected, "scale {scale}: {got} {expected}");
        }
    }

    /// A row's closed form against a fine midpoint rule of the weight along it, on rows of
    /// a light the point sees from near and far, and past a tilted normal.
    #[test]
    fn row_integral_is_the_weight_along_the_row() {
        let light = RectLight::new(
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.6),
            Vec3::ONE,
        );
        for (p, n) in [
            (Vec3::new(0.3, 1.0, -0.2), Vec3::new(0.3, 0.9, 0.1).normalize()),
            (Vec3::new(0.1, 1.97, 0.05), Vec3::Y),
            (Vec3::new(-3.0, 0.0, 1.0), Vec3::Y),
        ] {
            let plane = LightPlane::new(&light, p.as_dvec3(), n.as_dvec3());
            for (y, x0, x1) in [(0.1, 0.0, 1.0), (0.55, 0.2, 0.3), (0.97, 0.6, 0.99)] {
                let g = 20000;
                let step = (x1 - x0) / g as f64;
                let sum: f64 =
                    (0..g).map(|i| plane.weight(DVec2::new(x0 + (i as f64 + 0.5) * step, y)) * step).sum();
                let got = plane.row_integral(y, x0, x1);
                assert!((got - sum).abs() <= 1e-7 * sum, "{p} row {y} [{x0}, {x1}]: {got} against {sum}");
            }
        }
    }
}
