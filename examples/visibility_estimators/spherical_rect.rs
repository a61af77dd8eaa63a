//! Solid angle sampling of the spherical rectangle (estimator 4).
//!
//! Derivation (Urena, Fajardo and King 2013). In a frame at the shading point o with x, y
//! along the light's edges and z normal to it, oriented so the rectangle lies at z = z0 < 0:
//! the rectangle is [x0, x1] x [y0, y1] at z0. The planes through o and its edges have unit
//! normals (cross products of the corner vectors, in order around the rectangle)
//!   n0 ~ (0, z0, -y0) (edge y = y0),  n1 ~ (-z0, 0, x1) (x = x1),
//!   n2 ~ (0, -z0, y1) (y = y1),       n3 ~ (z0, 0, -x0) (x = x0),
//! and the spherical rectangle's interior angles are g_k = acos(-n_k . n_k+1), its solid angle
//! S = g0 + g1 + g2 + g3 - 2 pi (Girard). Its part left of x = t, [x0, t] x [y0, y1], keeps
//! the angles g2, g3 at x0 and has, at x = t, with n(t) ~ (-z0, 0, t) and s = t / sqrt(t^2 +
//! z0^2), the angles acos(-b0 s) and acos(-b1 s), where b0 = n0.z and b1 = n2.z. Its solid
//! angle is therefore acos(-b0 s) + acos(-b1 s) - k, k = 2 pi - g2 - g3. Setting it to u S
//! (the marginal CDF in x) and writing phi = acos(-b0 s), so that
//!   -b1 s = cos(a_u - phi) = cos(a_u) (-b0 s) + sin(a_u) sqrt(1 - b0^2 s^2),  a_u = u S + k,
//! gives s f_u = sqrt(1 - b0^2 s^2) with f_u = (b0 cos a_u - b1) / sin a_u: s = sign(f_u) /
//! sqrt(f_u^2 + b0^2), and t = -s z0 / sqrt(1 - s^2). Given x = t, the column is a segment
//! parallel to y at distance d = sqrt(t^2 + z0^2) from o; its solid angle density along y is
//! |z0| / (d^2 + y^2)^(3/2), proportional to the derivative of h(y) = y / sqrt(d^2 + y^2), so
//! y = h d / sqrt(1 - h^2) with h = h(y0) + v (h(y1) - h(y0)). The map (u, v) -> point has
//! constant density 1/S in solid angle: each sample stands for the same solid angle, so
//! cos_x is the only weight left for the projected solid angle (= int g dA).

use crate::scene::Point;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

/// The spherical rectangle of the light seen from one point.
pub struct SphericalRect {
    o: DVec3,
    x: DVec3,
    y: DVec3,
    z: DVec3,
    z0: f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    b0: f64,
    b1: f64,
    k: f64,
    /// The solid angle.
    pub s: f64,
}

impl SphericalRect {
    pub fn new(o: DVec3, corner: DVec3, ex: DVec3, ey: DVec3) -> Self {
        let (lx, ly) = (ex.length(), ey.length());
        let (x, y) = (ex / lx, ey / ly);
        let mut z = x.cross(y);
        let d = corner - o;
        let mut z0 = d.dot(z);
        if z0 > 0.0 {
            z = -z;
            z0 = -z0;
        }
        let (x0, y0) = (d.dot(x), d.dot(y));
        let (x1, y1) = (x0 + lx, y0 + ly);
        let n0 = DVec3::new(0.0, z0, -y0).normalize();
        let n1 = DVec3::new(-z0, 0.0, x1).normalize();
        let n2 = DVec3::new(0.0, -z0, y1).normalize();
        let n3 = DVec3::new(z0, 0.0, -x0).normalize();
        let angle = |a: DVec3, b: DVec3| (-a.dot(b)).clamp(-1.0, 1.0).acos();
        let (g0, g1, g2, g3) = (angle(n0, n1), angle(n1, n2), angle(n2, n3), angle(n3, n0));
        let k = 2.0 * PI - g2 - g3;
        Self { o, x, y, z, z0, x0, x1, y0, y1, b0: n0.z, b1: n2.z, k, s: g0 + g1 - k }
    }

    pub fn of(pt: &Point) -> Self {
        let l = &pt.light;
        Self::new(pt.p, l.corner.as_dvec3(), l.u.as_dvec3(), l.v.as_dvec3())
    }

    /// The point of the rectangle at (u, v) in [0, 1]^2.
    #[inline]
    pub fn sample(&self, u: f64, v: f64) -> DVec3 {
        let au = u * self.s + self.k;
        let (sin_au, cos_au) = au.sin_cos();
        let fu = (cos_au * self.b0 - self.b1) / sin_au;
        let cu = (1.0 / (fu * fu + self.b0 * self.b0).sqrt()).copysign(fu).clamp(-1.0, 1.0);
        let xu = (-(cu * self.z0) / (1.0 - cu * cu).max(1e-300).sqrt()).clamp(self.x0, self.x1);
        let d2 = xu * xu + self.z0 * self.z0;
        let h0 = self.y0 / (d2 + self.y0 * self.y0).sqrt();
        let h1 = self.y1 / (d2 + self.y1 * self.y1).sqrt();
        let hv = h0 + v * (h1 - h0);
        let hv2 = hv * hv;
        let yv = if hv2 < 1.0 - 1e-12 {
            (hv * d2.sqrt() / (1.0 - hv2).sqrt()).clamp(self.y0, self.y1)
        } else {
            self.y1
        };
        self.o + xu * self.x + yv * self.y + self.z0 * self.z
    }
}

/// The same map in f32 (as the renderer would run it), built from the f64 set-up: for its
/// cost, and checked against the f64 map.
pub struct SphericalRectF32 {
    o: Vec3,
    x: Vec3,
    y: Vec3,
    z: Vec3,
    z0: f32,
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    b0: f32,
    b1: f32,
    k: f32,
    s: f32,
}

impl SphericalRectF32 {
    pub fn of(r: &SphericalRect) -> Self {
        Self {
            o: r.o.as_vec3(),
            x: r.x.as_vec3(),
            y: r.y.as_vec3(),
            z: r.z.as_vec3(),
            z0: r.z0 as f32,
            x0: r.x0 as f32,
            x1: r.x1 as f32,
            y0: r.y0 as f32,
            y1: r.y1 as f32,
            b0: r.b0 as f32,
            b1: r.b1 as f32,
            k: r.k as f32,
            s: r.s as f32,
        }
    }

    #[inline]
    pub fn sample(&self, u: f32, v: f32) -> Vec3 {
        let au = u * self.s + self.k;
        let (sin_au, cos_au) = au.sin_cos();
        let fu = (cos_au * self.b0 - self.b1) / sin_au;
        let cu = (1.0 / (fu * fu + self.b0 * self.b0).sqrt()).copysign(fu).clamp(-1.0, 1.0);
        let xu = (-(cu * self.z0) / (1.0 - cu * cu).max(1e-30).sqrt()).clamp(self.x0, self.x1);
        let d2 = xu * xu + self.z0 * self.z0;
        let h0 = self.y0 / (d2 + self.y0 * self.y0).sqrt();
        let h1 = self.y1 / (d2 + self.y1 * self.y1).sqrt();
        let hv = h0 + v * (h1 - h0);
        let hv2 = hv * hv;
        let yv = if hv2 < 1.0 - 1e-6 {
            (hv * d2.sqrt() / (1.0 - hv2).sqrt()).clamp(self.y0, self.y1)
        } else {
            self.y1
        };
        self.o + xu * self.x + yv * self.y + self.z0 * self.z
    }
}
