//! The analytic scene (the light, a card, a floor point) and its exact answer: Lambert's
//! formula on the light and on the blocked polygon.

use glam::{DVec2, DVec3, Vec3};

/// The light: the unit square x, z in [-0.5, 0.5] at height `h`, emitting down (-Y); its
/// rectangle coordinates (a, b) in [0, 1]^2 run along +X and +Z.
#[derive(Clone, Copy)]
pub struct Light {
    pub corner: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub normal: DVec3,
}

impl Light {
    pub fn at(h: f64) -> Self {
        Self { corner: Vec3::new(-0.5, h as f32, -0.5), u: Vec3::X, v: Vec3::Z, normal: DVec3::NEG_Y }
    }

    #[inline]
    pub fn point(&self, a: f32, b: f32) -> Vec3 {
        self.corner + a * self.u + b * self.v
    }

    pub fn height(&self) -> f64 {
        self.corner.y as f64
    }

    /// The light's corners in order around it, in f64.
    pub fn corners(&self) -> [DVec3; 4] {
        let (c, u, v) = (self.corner.as_dvec3(), self.u.as_dvec3(), self.v.as_dvec3());
        [c, c + u, c + u + v, c + v]
    }
}

/// An opaque rectangle parallel to the floor at `height`: centre (x, z), half sizes along its
/// own axes, its first axis `axis` (turned `angle_deg` from +X in the x-z plane).
#[derive(Clone, Copy)]
pub struct Card {
    pub centre: DVec2,
    pub half: DVec2,
    pub axis: DVec2,
    pub height: f64,
}

impl Card {
    pub fn new(centre: DVec2, half: DVec2, angle_deg: f64, height: f64) -> Self {
        let t = angle_deg.to_radians();
        Self { centre, half, axis: DVec2::new(t.cos(), t.sin()), height }
    }

    /// Whether the segment from `p` (below the card) to `y` (above it) crosses the card.
    #[inline]
    pub fn blocks(&self, p: DVec3, y: DVec3) -> bool {
        let t = (self.height - p.y) / (y.y - p.y);
        let q = DVec2::new(p.x + t * (y.x - p.x), p.z + t * (y.z - p.z)) - self.centre;
        let (s, w) = (q.dot(self.axis), q.perp_dot(self.axis));
        s.abs() < self.half.x && w.abs() < self.half.y
    }

    /// The corners (x, z), in order around the card.
    fn corners(&self) -> [DVec2; 4] {
        let (e1, e2) = (self.axis * self.half.x, self.axis.perp() * self.half.y);
        let c = self.centre;
        [c - e1 - e2, c + e1 - e2, c + e1 + e2, c - e1 + e2]
    }
}

/// One floor point of the penumbra and its exact answer.
pub struct Point {
    pub p: DVec3,
    pub n: DVec3,
    pub light: Light,
    pub card: Card,
    /// int g dA over the whole light (Lambert).
    pub g_total: f64,
    pub v_exact: f64,
    /// The unoccluded area fraction (what estimator 1 converges to).
    pub area_exact: f64,
}

/// int over the polygon `poly` (convex, every vertex above the tangent plane) of
/// cos_x cos_y / r^2 dA, by Lambert's formula: (1/2) |sum over edges of
/// angle(a, b) n . normalize(a x b)|.
pub fn lambert(poly: &[DVec3], p: DVec3, n: DVec3) -> f64 {
    let mut sum = 0.0;
    for (j, &vj) in poly.iter().enumerate() {
        let (a, b) = (vj - p, poly[(j + 1) % poly.len()] - p);
        let c = a.cross(b);
        let len = c.length();
        if len > 0.0 {
            sum += len.atan2(a.dot(b)) * n.dot(c) / len;
        }
    }
    0.5 * sum.abs()
}

/// Clips a convex polygon in the plane to the square [-0.5, 0.5]^2 (Sutherland-Hodgman).
fn clip_to_square(mut poly: Vec<DVec2>) -> Vec<DVec2> {
    // Each half-plane as (axis, sign): sign * coordinate <= 0.5.
    for (axis, sign) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)] {
        if poly.is_empty() {
            break;
        }
        let inside = |q: DVec2| sign * q[axis] <= 0.5;
        let mut out = Vec::with_capacity(poly.len() + 1);
        for j in 0..poly.len() {
            let (a, b) = (poly[j], poly[(j + 1) % poly.len()]);
            if inside(a) {
                out.push(a);
            }
            if inside(a) != inside(b) {
                let t = (sign * 0.5 - a[axis]) / (b[axis] - a[axis]);
                out.push(a + t * (b - a));
            }
        }
        poly = out;
    }
    poly
}

impl Point {
    pub fn new(p: DVec3, light: Light, card: Card) -> Self {
        let n = DVec3::Y;
        let h = light.height();
        let g_total = lambert(&light.corners(), p, n);
        // The card's central projection from p onto the light's plane (a convex quadrilateral),
        // clipped to the light: the blocked part.
        let scale = (h - p.y) / (card.height - p.y);
        let projected = card
            .corners()
            .iter()
            .map(|c| DVec2::new(p.x, p.z) + scale * (*c - DVec2::new(p.x, p.z)))
            .collect();
        let blocked = clip_to_square(projected);
        let (g_blocked, area_blocked) = if blocked.len() >= 3 {
            let poly: Vec<DVec3> = blocked.iter().map(|q| DVec3::new(q.x, h, q.y)).collect();
            let area = 0.5
                * (0..blocked.len())
                    .map(|j| blocked[j].perp_dot(blocked[(j + 1) % blocked.len()]))
                    .sum::<f64>()
                    .abs();
            (lambert(&poly, p, n), area)
        } else {
            (0.0, 0.0)
        };
        Self {
            p,
            n,
            light,
            card,
            g_total,
            v_exact: 1.0 - g_blocked / g_total,
            area_exact: 1.0 - area_blocked,
        }
    }
}
