//! What `Scene::build` learns about each triangle's precision in render space (zero area,
//! lost to f32, imprecise, too large for the intersector), for flattened triangles and kept
//! instances alike, and the warnings it makes of it.

use crate::geometry::precision::{SHAPE_PRECISION, f32_spacing, is_degenerate};
use glam::{DVec3, Vec3};

/// What `Scene::build` learns about each triangle's precision in render space, and the
/// warnings it makes of it.
#[derive(Debug, Default)]
pub(crate) struct PrecisionTally {
    pub(crate) zero_area: u64,
    pub(crate) collapsed: u64,
    /// The nearest collapsed triangle's distance from the camera.
    collapsed_nearest: f64,
    pub(crate) out_of_range: u64,
    /// Dropped by the loader because a glTF node's transform takes them out of f32's range
    /// (counted in the stats; the loader's warning names each node).
    pub(crate) overflowed: u64,
    pub(crate) imprecise: u64,
    /// The farthest imprecise triangle's distance from the camera and its f32 spacing.
    imprecise_farthest: (f64, f64),
    oversized: u64,
    /// The oversized triangle whose rounding reaches farthest: that reach (m), a corner
    /// (world space) and its plane's distance from the camera.
    oversized_worst: (f64, DVec3, f64),
}

/// The intersector's rounding of a hit's distance, as a fraction of its triangle's reach from
/// the ray's origin (`watertight::t_rounding` is ~150 f64 units for a well-shaped triangle;
/// more for slivers): hits nearer than that are not found.
pub(super) const INTERSECTOR_ROUNDING: f64 = 200.0 * f64::EPSILON * 0.5;

impl PrecisionTally {
    /// The unit face normal (render space) of the world-space triangle `p` if f32 can hold
    /// it relative to `origin`; else `None`, with the reason counted.
    pub(crate) fn keep(&mut self, p: [DVec3; 3], origin: DVec3) -> Option<Vec3> {
        if is_degenerate(p) {
            self.zero_area += 1; // the loaders test this too; a caller of `build` may not
            return None;
        }
        let rel = p.map(|p| p - origin);
        let distance = rel.iter().map(|r| r.length()).fold(0.0, f64::max);
        let p32 = rel.map(|r| r.as_vec3());
        if !p32.iter().all(|v| v.is_finite()) {
            self.out_of_range += 1;
            return None;
        }
        let q = p32.map(|v| v.as_dvec3());
        if is_degenerate(q) {
            if self.collapsed == 0 || distance < self.collapsed_nearest {
                self.collapsed_nearest = distance;
            }
            self.collapsed += 1;
            return None;
        }
        let size = [q[1] - q[0], q[2] - q[1], q[0] - q[2]].iter().map(|e| e.length()).fold(0.0, f64::max);
        let spacing = f32_spacing(distance);
        if spacing > size / SHAPE_PRECISION {
            if distance > self.imprecise_farthest.0 {
                self.imprecise_farthest = (distance, spacing);
            }
            self.imprecise += 1;
        }
        let face = crate::geometry::precision::render_face(q);
        self.check_size(q, face, origin);
        Some(face.as_vec3())
    }

    /// Whether nothing is counted.
    pub(crate) fn is_clean(&self) -> bool {
        self.zero_area == 0
            && self.collapsed == 0
            && self.out_of_range == 0
            && self.imprecise == 0
            && self.oversized == 0
    }

    /// Adds `other`'s counts, as if its triangles had been kept after this one's (the first
    /// extreme wins a tie, as in one pass).
    pub(crate) fn merge(&mut self, other: &PrecisionTally) {
        if other.collapsed > 0 && (self.collapsed == 0 || other.collapsed_nearest < self.collapsed_nearest) {
            self.collapsed_nearest = other.collapsed_nearest;
        }
        if other.imprecise_farthest.0 > self.imprecise_farthest.0 {
            self.imprecise_farthest = other.imprecise_farthest;
        }
        if other.oversized_worst.0 > self.oversized_worst.0 {
            self.oversized_worst = other.oversized_worst;
        }
        self.zero_area += other.zero_area;
        self.collapsed += other.collapsed;
        self.out_of_range += other.out_of_range;
        self.overflowed += other.overflowed;
        self.imprecise += other.imprecise;
        self.oversized += other.oversized;
    }

    /// Counts the triangle (render space `q`, unit normal `face`) if it is so large against
    /// its plane's distance from the camera that the intersector cannot place the hits
    /// camera rays make on it: its rounding over 1% of that distance (a floor 10^14 m
    /// wide seen from 2 m). Finer than the hit rounding, hits are exact (10^12 m is).
    fn check_size(&mut self, q: [DVec3; 3], face: DVec3, origin: DVec3) {
        let reach = q.iter().map(|v| v.length()).fold(0.0, f64::max);
        let rounding = INTERSECTOR_ROUNDING * reach;
        let plane = face.dot(q[0]).abs();
        if plane > 0.0 && rounding > 0.01 * plane {
            if rounding > self.oversized_worst.0 {
                self.oversized_worst = (rounding, q[0] + origin, plane);
            }
            self.oversized += 1;
        }
    }

    pub(crate) fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.zero_area > 0 {
            w.push(format!(
                "{} triangle(s) dropped: zero area (repeated or collinear vertices)",
                self.zero_area
            ));
        }
        if self.collapsed > 0 {
            let d = self.collapsed_nearest;
            w.push(format!(
                "{} triangle(s) dropped: too small for f32 at their distance from the camera (the nearest \
                 {d:.3e} m away, where f32 positions are spaced {:.3e} m)",
                self.collapsed,
                f32_spacing(d)
            ));
        }
        if self.out_of_range > 0 {
            w.push(format!(
                "{} triangle(s) dropped: farther from the camera than f32 can hold ({:.1e} m)",
                self.out_of_range,
                f32::MAX
            ));
        }
        if self.imprecise > 0 {
            let (d, s) = self.imprecise_farthest;
            w.push(format!(
                "{} triangle(s) too far from the camera for f32 to keep their shape: the farthest \
                 {d:.3e} m away, where f32 positions are spaced {s:.3e} m (over 1/{SHAPE_PRECISION} of \
                 its size); render space is centred on the camera, so nearer geometry keeps its own \
                 precision",
                self.imprecise
            ));
        }
        if self.oversized > 0 {
            let (r, c, d) = self.oversized_worst;
            w.push(format!(
                "{} triangle(s) too large for the intersector at their distance from the camera: hits on \
                 them nearer than ~{r:.1e} m are missed; the worst has a corner at [{:.3e}, {:.3e}, {:.3e}] \
                 and its plane passes {d:.3e} m from the camera (hits are exact on triangles reaching \
                 less than ~{:.0e} m from it: split those near the camera)",
                self.oversized,
                c.x,
                c.y,
                c.z,
                0.01 * d / INTERSECTOR_ROUNDING
            ));
        }
        w
    }
}
