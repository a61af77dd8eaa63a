//! Rectangular area lights and their exact unshadowed irradiance.

use glam::{DVec3, Vec3};

/// A one-sided rectangular emitter. Corners are `center +- u/2 +- v/2`; it emits radiance
/// `radiance` toward `normal = normalize(cross(u, v))` only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RectLight {
    pub center: Vec3,
    /// Full edge vectors (perpendicular).
    pub u: Vec3,
    pub v: Vec3,
    pub normal: Vec3,
    pub radiance: Vec3,
}

impl RectLight {
    /// The normal is computed in f64, so that a light too small for f32's products (edges
    /// of 1e-20 m) still has one; see `scene_load::light_in_render_space` for what is refused.
    pub fn new(center: Vec3, u: Vec3, v: Vec3, radiance: Vec3) -> Self {
        let normal = u.as_dvec3().cross(v.as_dvec3()).normalize().as_vec3();
        Self { center, u, v, normal, radiance }
    }

    pub fn area(&self) -> f32 {
        self.u.cross(self.v).length()
    }

    /// The point at rectangle coordinates (a, b) in [0, 1]^2.
    #[inline]
    pub fn point(&self, a: f32, b: f32) -> Vec3 {
        self.center + (a - 0.5) * self.u + (b - 0.5) * self.v
    }

    /// A bound (per component) on the f32 rounding of [`RectLight::point`]`(a, b)`: the
    /// subtractions, two products and two sums, gamma(4) of the terms' magnitudes.
    #[inline]
    pub fn point_error(&self, a: f32, b: f32) -> Vec3 {
        crate::geometry::ray_origin::gamma(4)
            * (self.center.abs() + ((a - 0.5) * self.u).abs() + ((b - 0.5) * self.v).abs())
    }

    /// A bound on [`RectLight::point_error`] over the whole light.
    pub fn max_point_error(&self) -> Vec3 {
        self.point_error(0.0, 0.0).max(self.point_error(1.0, 1.0))
    }

    /// Corners in counter-clockwise order seen from the emitting side, in render space (f32):
    /// where a light is small beside its distance from the camera they are rounded by as much
    /// as its size, so they only bound where samples land ([`RectLight::point`]); what the
    /// light sends is measured from [`RectLight::corners_from`].
    pub fn corners(&self) -> [Vec3; 4] {
        let (hu, hv) = (0.5 * self.u, 0.5 * self.v);
        [self.center - hu - hv, self.center + hu - hv, self.center + hu + hv, self.center - hu + hv]
    }

    /// The corners ([`RectLight::corners`]' order) relative to `p`, in f64: the centre from
    /// `p` plus the half edges, so that no rounding about the camera changes the light's size
    /// (its corners rounded to f32 2.6 m from the camera made a 3e-7 m light 1.9x its power).
    pub fn corners_from(&self, p: Vec3) -> [DVec3; 4] {
        let d = self.center.as_dvec3() - p.as_dvec3();
        self.offsets().map(|o| d + o)
    }

    /// The corners relative to the centre, in f64 (exact: halves of the f32 edges).
    fn offsets(&self) -> [DVec3; 4] {
        let (hu, hv) = (0.5 * self.u.as_dvec3(), 0.5 * self.v.as_dvec3());
        [-hu - hv, hu - hv, hu + hv, -hu + hv]
    }

    /// Whether `p` is strictly on the emitting side of the light's plane.
    #[inline]
    pub fn faces(&self, p: Vec3) -> bool {
        (p.as_dvec3() - self.center.as_dvec3()).dot(self.normal.as_dvec3()) > 0.0
    }

    /// Where the ray from `o` along unit `d` meets the light from its emitting side: the
    /// distance, in f64 (a bounce that finds a light it reflects, [`crate::integrator::gltf_path`]).
    pub fn crossing(&self, o: Vec3, d: Vec3) -> Option<f32> {
        let (n, d64) = (self.normal.as_dvec3(), d.as_dvec3());
        let facing = -n.dot(d64);
        if facing.is_nan() || facing <= 0.0 {
            return None;
        }
        let t = n.dot(o.as_dvec3() - self.center.as_dvec3()) / facing;
        if t.is_nan() || t <= 0.0 {
            return None;
        }
        let q = o.as_dvec3() + t * d64 - self.center.as_dvec3();
        let (u, v) = (self.u.as_dvec3(), self.v.as_dvec3());
        let (a, b) = (q.dot(u) / u.length_squared(), q.dot(v) / v.length_squared());
        (a.abs() <= 0.5 && b.abs() <= 0.5).then_some(t as f32)
    }

    /// Whether `p` lies on the light's rectangle, to a ten-thousandth of its size (a hit on
    /// the triangles of an emissive rectangle made a light).
    pub fn holds(&self, p: Vec3) -> bool {
        let q = p.as_dvec3() - self.center.as_dvec3();
        let (u, v) = (self.u.as_dvec3(), self.v.as_dvec3());
        let size = u.length() + v.length();
        let slack = 1e-4;
        q.dot(self.normal.as_dvec3()).abs() <= slack * size
            && (q.dot(u) / u.length_squared()).abs() <= 0.5 + slack
            && (q.dot(v) / v.length_squared()).abs() <= 0.5 + slack
    }

    /// Irradiance factor at `p` on a surface with unit normal `n`: E / L, the cosine-weighted
    /// solid angle of the light (the polygon form factor times pi), with the light clipped to
    /// the upper hemisphere of `n` and zero behind the emitting side. Multiply by
    /// `radiance` for E. Exact up to floating point (computed in f64).
    pub fn irradiance_factor(&self, p: Vec3, n: Vec3) -> f32 {
        self.irradiance_factor_f64(p, n) as f32
    }

    /// [`RectLight::irradiance_factor`] before its rounding to f32: the integral of
    /// g = cos cos / r^2 over the part of the light above the horizon of `n`, in m^0 (a
    /// cosine-weighted solid angle), the denominator of the visibility's share of irradiance
    /// ([`crate::methods::irradiance_share`]).
    pub fn irradiance_factor_f64(&self, p: Vec3, n: Vec3) -> f64 {
        if !self.faces(p) {
            return 0.0;
        }
        let seen = self.above_horizon(p, n.as_dvec3());
        if seen.count < 3 {
            return 0.0;
        }
        // Lambert's formula: E/L = 1/2 sum_i angle(r_i, r_i+1) n . unit(r_i x r_i+1).
        let n = n.as_dvec3();
        let mut sum = 0.0;
        for i in 0..seen.count {
            let (c, angle) = seen.edge(i);
            let c_len = c.length();
            if c_len > 0.0 {
                sum += angle * n.dot(c) / c_len;
            }
        }
        // The clipped polygon is convex and lies in one hemisphere, so every term has the
        // sign of the winding seen from p; the magnitude is the answer.
        0.5 * sum.abs()
    }

    /// The part of the rectangle above the horizon of `n` seen from `p` (Sutherland-Hodgman
    /// against n . r >= 0), its vertices kept as the centre from `p` and offsets from it.
    fn above_horizon(&self, p: Vec3, n: DVec3) -> Seen {
        let d = self.center.as_dvec3() - p.as_dvec3();
        let mut seen = Seen { d, o: [DVec3::ZERO; 8], count: 0 };
        let (height, offsets) = (n.dot(d), self.offsets());
        for i in 0..4 {
            let (a, b) = (offsets[i], offsets[(i + 1) % 4]);
            let (da, db) = (height + n.dot(a), height + n.dot(b));
            if da >= 0.0 {
                seen.o[seen.count] = a;
                seen.count += 1;
            }
            if (da >= 0.0) != (db >= 0.0) {
                let t = da / (da - db);
                seen.o[seen.count] = a + t * (b - a);
                seen.count += 1;
            }
        }
        seen
    }

    /// The mean direction of the light's irradiance at `p` (normal `n`): Lambert's vector
    /// form factor of its part above the horizon, normalised (toward the light); zero where
    /// none of it is above. Where a term depends on the light's direction, it is read there
    /// (the diffuse part's Fresnel, [`crate::integrator::reflect`]).
    pub fn irradiance_direction(&self, p: Vec3, n: Vec3) -> Vec3 {
        if !self.faces(p) {
            return Vec3::ZERO;
        }
        let seen = self.above_horizon(p, n.as_dvec3());
        let mut sum = DVec3::ZERO;
        for i in 0..seen.count {
            let (c, angle) = seen.edge(i);
            let c_len = c.length();
            if c_len > 0.0 {
                sum += c * (angle / c_len);
            }
        }
        // The winding decides the sign: the direction is the one toward the light.
        if sum.dot(seen.d) < 0.0 {
            sum = -sum;
        }
        sum.normalize_or_zero().as_vec3()
    }

    /// Unshadowed irradiance E (per colour channel) at `p` with unit normal `n`.
    pub fn irradiance(&self, p: Vec3, n: Vec3) -> Vec3 {
        self.radiance * self.irradiance_factor(p, n)
    }
}

/// A polygon seen from a point: vertex i is `d + o[i]`, `d` the light's centre from the
/// point and `o[i]` the vertex from the centre. Kept apart because Lambert's terms for a light
/// far smaller than its distance are differences: r_i x r_i+1 from the corner vectors
/// themselves rounds by ~1e-16 r^2, which is 0.1% of E for a 3e-7 m light 1 m away (the
/// terms, ~size/r each, cancel down to E/L ~ (size/r)^2).
struct Seen {
    d: DVec3,
    o: [DVec3; 8],
    count: usize,
}

impl Seen {
    /// Edge i's r_i x r_i+1 and the angle between r_i and r_i+1, from the expansions
    /// (d + a) x (d + b) = d x (b - a) + a x b and (d + a) . (d + b) = d.d + d.(a + b) + a.b,
    /// whose terms carry the light's size instead of cancelling to it. atan2(|c|, dot) keeps
    /// small angles accurate where acos would not.
    fn edge(&self, i: usize) -> (DVec3, f64) {
        let (a, b) = (self.o[i], self.o[(i + 1) % self.count]);
        let c = self.d.cross(b - a) + a.cross(b);
        let dot = self.d.length_squared() + self.d.dot(a + b) + a.dot(b);
        (c, c.length().atan2(dot))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent answer: midpoint-rule integration over the light's area of
    /// cos(theta_p)^+ cos(theta_l) / r^2, in f64.
    fn integrate(light: &RectLight, p: Vec3, n: Vec3, steps: usize) -> f64 {
        let (p, n) = (p.as_dvec3(), n.as_dvec3());
        let (c, u, v) = (light.center.as_dvec3(), light.u.as_dvec3(), light.v.as_dvec3());
        let ln = u.cross(v).normalize();
        let da = u.cross(v).length() / (steps * steps) as f64;
        let mut sum = 0.0;
        for i in 0..steps {
            for j in 0..steps {
                let a = (i as f64 + 0.5) / steps as f64 - 0.5;
                let b = (j as f64 + 0.5) / steps as f64 - 0.5;
                let x = c + a * u + b * v;
                let d = x - p;
                let r2 = d.length_squared();
                let w = d / r2.sqrt();
                let cos_p = n.dot(w).max(0.0);
                let cos_l = (-w).dot(ln).max(0.0);
                sum += cos_p * cos_l / r2 * da;
            }
        }
        sum
    }

    fn lcg(state: &mut u64) -> f32 {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*state >> 40) as f32) / (1u64 << 24) as f32
    }

    #[test]
    fn irradiance_matches_numerical_integration() {
        // Lights of several shapes and orientations; points at many positions and normals,
        // including lights partly below the horizon and points behind the emitting side.
        let mut s = 7u64;
        let mut partly_clipped = 0;
        let mut behind = 0;
        for case in 0..60 {
            let u_dir = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5).normalize();
            let helper = if u_dir.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
            let v_dir = u_dir.cross(helper).normalize();
            let light = RectLight::new(
                Vec3::new(0.3, 2.0, -0.2),
                u_dir * (0.3 + lcg(&mut s)),
                v_dir * (0.3 + 0.5 * lcg(&mut s)),
                Vec3::ONE,
            );
            let offset = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5) * 3.0;
            let p = light.center + offset + light.normal * if case % 5 == 0 { -0.5 } else { 1.2 };
            let n = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5).normalize();
            let exact = light.irradiance_factor(p, n) as f64;
            let reference = if light.faces(p) { integrate(&light, p, n, 1500) } else { 0.0 };
            if !light.faces(p) {
                behind += 1;
                assert_eq!(exact, 0.0);
                continue;
            }
            let signs: Vec<bool> = light.corners().iter().map(|c| n.dot(*c - p) > 0.0).collect();
            if signs.iter().any(|&b| b) && signs.iter().any(|&b| !b) {
                partly_clipped += 1;
            }
            let tol = 1e-4 * reference.max(1e-3);
            assert!((exact - reference).abs() <= tol, "case {case}: exact {exact} vs integrated {reference}");
        }
        assert!(partly_clipped >= 5, "only {partly_clipped} cases cross the horizon");
        assert!(behind >= 5, "only {behind} cases behind the light");
    }

    #[test]
    fn irradiance_of_small_light_is_inverse_square_law() {
        // A tiny light straight above, facing down: E/L -> A cos cos / r^2.
        let light = RectLight::new(Vec3::new(0.0, 10.0, 0.0), Vec3::X * 0.01, Vec3::Z * 0.01, Vec3::ONE);
        assert!(light.normal.y < 0.0);
        let e = light.irradiance_factor(Vec3::ZERO, Vec3::Y) as f64;
        let expected = 1e-4 / 100.0;
        assert!((e - expected).abs() < 1e-5 * expected, "{e} vs {expected}");
    }
}
