//! Edges and flagged triangles projected from the ray origin onto the light's plane.
//!
//! Light coordinates: a sample is (a, b) with `s = centre + (a - 1/2) u + (b - 1/2) v`. An
//! edge's projection from the origin `o` is computed in homogeneous coordinates (a w, b w, w),
//! affine in the 3D point, so the edge is clipped to the light's rectangle (grown by
//! `MARGIN`) before any division; each vertex projects by a function of itself and `o` alone,
//! so edges sharing a vertex share its projection bit for bit.

use glam::{DVec2, DVec3, Vec3};

/// Light-space margin (in units of the light's sides) an edge is kept to: samples lie in
/// [0, 1]^2 up to a rounding, and the reference point inside.
pub(super) const MARGIN: f64 = 0.02;

/// The band's ulps (of the light's coordinates for the ray's aim, taken 4 times over; of the
/// edge's in f64 for the watertight test's frame) within which a sample's shadow ray may pass
/// an edge and `traced`'s test may go either way: such samples are traced. Measured
/// (`silhouette/band_tests.rs`: samples placed across random edges' lines, near the point and seen
/// end-on too, traced with the renderer's ray and watertight test): every disagreement lies
/// within 0.1 of the band. (64 before that test: on metal-rough-spheres, 4x more samples
/// traced, and points with no reference point clear of every band.)
pub(super) const BAND_ULPS: f64 = 16.0;

/// An edge active for this point, as affine functions of a sample's light coordinates.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct ActiveEdge {
    /// `side(a, b) = s0 + sa a + sb b`: orient3d(o, e0, e1, s) scaled to O(1), the sign of the
    /// sample's side. In f32, like the samples: the band covers its rounding.
    pub(crate) side: [f32; 3],
    /// |side| under this at a sample: it is traced (`traced`'s own f32 ray test may go
    /// either way there, and this side's evaluation).
    pub(crate) band: f32,
    /// |side| under this at a point of a path (the reference, C_j, M): its sign is not
    /// sure. Only this side's own evaluation (f64 coefficients rounded to f32, an f32
    /// evaluation) matters there: no ray is aimed at a path's points, the count changes
    /// where the path crosses the exact projection.
    pub(crate) path_band: f32,
    /// The clipped projection's ends.
    pub(crate) p0: DVec2,
    pub(crate) p1: DVec2,
    /// The sum of the incident faces' orientations.
    pub(crate) weight: i32,
}

impl ActiveEdge {
    #[inline(always)]
    pub(crate) fn side_at(&self, a: f32, b: f32) -> f32 {
        self.side[0] + self.side[1] * a + self.side[2] * b
    }
}

/// A flagged triangle's projection over the light: a convex polygon in light coordinates
/// (the triangle clipped to the slab between o's plane and the light's, and to the grown
/// light), as edge lines `l0 + la a + lb b >= -margin` inside, normalised to distance.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Region {
    pub(crate) lines: [[f64; 3]; MAX_POLYGON],
    pub(crate) count: usize,
    pub(crate) margin: f64,
    /// A box holding the grown polygon (infinite where a corner is too sharp to bound): most
    /// samples are rejected by it alone (glass-vase-flowers: the per-sample region tests
    /// were ~45% of the method's time).
    pub(crate) lo: DVec2,
    pub(crate) hi: DVec2,
    /// The triangle, and whether alpha (holes) is its only flag: then a sample the opaque
    /// count leaves lit is tested against it alone, not traced.
    pub(crate) slot: u32,
    pub(crate) alpha_only: bool,
}

/// A triangle clipped by six planes has at most nine sides.
pub(crate) const MAX_POLYGON: usize = 9;

/// A triangle's projection over the light ([`Frame::clip_triangle`]): a convex polygon in
/// light coordinates.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Projected {
    /// The corners in order (the first `count`).
    pub(crate) corners: [DVec2; MAX_POLYGON],
    pub(crate) count: usize,
    /// The corners' smallest depth from o, as a fraction of o's height over the light (1 on
    /// the light's plane).
    pub(crate) lambda_min: f64,
}

/// A clipping constraint on a homogeneous point (o's height, a tiny height): inside >= 0.
type Constraint = fn(&[f64; 3], f64, f64) -> f64;

impl Region {
    pub(crate) fn new(frame: &Frame, v: [DVec3; 3]) -> Option<Region> {
        let Projected { corners: pts, count: n, lambda_min } = frame.clip_triangle(v)?;
        // A 3D displacement d at depth lambda moves the projection by d / lambda: the band of
        // the triangle's coordinates, in light units.
        let magnitude = v.iter().fold(frame.magnitude, |m, x| m.max(x.abs().max_element()));
        let delta = BAND_ULPS * f32::EPSILON as f64 * 0.5 * magnitude;
        let side = frame.u.length().min(frame.v.length());
        let margin = delta / (lambda_min * side) + 1e-9;
        // Orientation from the signed area; a degenerate polygon keeps its lines (the margin
        // still holds the samples near it).
        let area: f64 = (0..n).map(|k| pts[k].perp_dot(pts[(k + 1) % n])).sum();
        let (lo, hi) = (DVec2::NEG_INFINITY, DVec2::INFINITY);
        let mut region =
            Region { lines: [[0.0; 3]; MAX_POLYGON], count: 0, margin, lo, hi, slot: 0, alpha_only: false };
        for k in 0..n {
            let (a, b) = (pts[k], pts[(k + 1) % n]);
            let d = b - a;
            let len = d.length();
            if len == 0.0 {
                continue;
            }
            // Inside (left of a -> b for a counter-clockwise polygon): d x (x - a) >= 0.
            let sign = if area >= 0.0 { 1.0 } else { -1.0 };
            let (la, lb) = (-d.y * sign / len, d.x * sign / len);
            region.lines[region.count] = [-(la * a.x + lb * a.y), la, lb];
            region.count += 1;
        }
        region.bound();
        Some(region)
    }

    /// The box of the grown polygon: its corners are where consecutive lines, each moved out
    /// by the margin, meet (the lines go round a convex polygon in order). Nearly parallel
    /// neighbours (a sharp or degenerate corner) leave the box infinite.
    fn bound(&mut self) {
        let n = self.count;
        let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
        for k in 0..n {
            let (p, q) = (self.lines[k], self.lines[(k + 1) % n]);
            let det = p[1] * q[2] - p[2] * q[1];
            if n < 3 || det.abs() < 1e-6 {
                return;
            }
            // la x + lb y = -margin - l0 on both lines.
            let (rp, rq) = (-self.margin - p[0], -self.margin - q[0]);
            let x = DVec2::new((rp * q[2] - p[2] * rq) / det, (p[1] * rq - rp * q[1]) / det);
            (lo, hi) = (lo.min(x), hi.max(x));
        }
        // A rounding's worth beyond (the corners are computed, the tests evaluated).
        let grow = DVec2::splat(1e-9 + 1e-12 * (lo.abs().max_element() + hi.abs().max_element()));
        (self.lo, self.hi) = (lo - grow, hi + grow);
    }

    /// Whether the sample at `p` may see its ray meet the triangle.
    #[inline]
    pub(crate) fn holds(&self, p: DVec2) -> bool {
        p.cmpge(self.lo).all()
            && p.cmple(self.hi).all()
            && self.lines[..self.count].iter().all(|l| l[0] + l[1] * p.x + l[2] * p.y >= -self.margin)
    }
}

/// The light's frame in f64, seen from the origin `o`.
pub(crate) struct Frame {
    pub(crate) o: DVec3,
    pub(crate) centre: DVec3,
    pub(crate) u: DVec3,
    pub(crate) v: DVec3,
    /// u / |u|^2, v / |v|^2: light coordinates of a point in the plane.
    pub(crate) u_dual: DVec3,
    pub(crate) v_dual: DVec3,
    pub(crate) normal: DVec3,
    /// o's height over the light's plane (> 0).
    pub(crate) height: f64,
    /// The largest distance from o to a (grown) light corner.
    pub(crate) reach: f64,
    /// The largest coordinate magnitude of o and the light's corners.
    pub(crate) magnitude: f64,
}

impl Frame {
    pub(crate) fn new(light: &renderer::RectLight, origin: Vec3) -> Option<Frame> {
        let (centre, u, v) = (light.center.as_dvec3(), light.u.as_dvec3(), light.v.as_dvec3());
        let normal = u.cross(v).normalize();
        let o = origin.as_dvec3();
        let height = normal.dot(o - centre);
        if !(height > 0.0 && height.is_finite()) {
            return None;
        }
        let g = 0.5 + MARGIN;
        let corners =
            [centre - g * u - g * v, centre + g * u - g * v, centre + g * u + g * v, centre - g * u + g * v];
        let reach = corners.iter().map(|c| (*c - o).length()).fold(0.0, f64::max);
        let magnitude = corners.iter().fold(o.abs().max_element(), |m, c| m.max(c.abs().max_element()));
        Some(Frame {
            o,
            centre,
            u,
            v,
            u_dual: u / u.length_squared(),
            v_dual: v / v.length_squared(),
            normal,
            height,
            reach,
            magnitude,
        })
    }

    /// `x`'s projection from o in homogeneous light coordinates (a w, b w, w), w = o's
    /// height over the light less x's: affine in x.
    pub(crate) fn project(&self, x: DVec3) -> [f64; 3] {
        let w = self.height - self.normal.dot(x - self.centre);
        let h = (self.o - self.centre) * w + (x - self.o) * self.height;
        [h.dot(self.u_dual) + 0.5 * w, h.dot(self.v_dual) + 0.5 * w, w]
    }

    /// A triangle's projection from o over the light: the triangle clipped (homogeneous
    /// Sutherland-Hodgman) to the slab between o's plane and the light's and to the grown
    /// light, or `None` where nothing of it is left. A triangle wholly in the slab and away
    /// from o's plane is not clipped (the light's rectangle only trims what no sample
    /// reaches): its corners may lie beyond the grown light, and it is `None` only where it
    /// lies wholly beyond one side of it.
    pub(crate) fn clip_triangle(&self, v: [DVec3; 3]) -> Option<Projected> {
        // Against w > 0, w <= height (the light's plane) and the grown rectangle; all affine
        // in the 3D point.
        let mut poly = [[0.0f64; 3]; MAX_POLYGON];
        let mut n = 3;
        for (k, x) in v.iter().enumerate() {
            poly[k] = self.project(*x);
        }
        let h = self.height;
        let tiny = 1e-9 * h;
        // Wholly between o's plane and the light's, not near o's (leaves between a point and
        // its light): the triangle itself, unclipped. The light's rectangle only trims what
        // no sample reaches; `lambda_min` over the whole triangle is at most the trimmed
        // one's; and the projection is magnified at most 100 times, so the lines' constants
        // keep their precision far under the margin (which grows with the magnitudes).
        let inside_slab = poly[..3].iter().all(|p| p[2] >= 1e-2 * h && h - p[2] >= 0.0);
        let constraints: [Constraint; 6] = [
            |p, _, tiny| p[2] - tiny,
            |p, h, _| h - p[2],
            |p, _, _| p[0] + MARGIN * p[2],
            |p, _, _| (1.0 + MARGIN) * p[2] - p[0],
            |p, _, _| p[1] + MARGIN * p[2],
            |p, _, _| (1.0 + MARGIN) * p[2] - p[1],
        ];
        for g in constraints.into_iter().filter(|_| !inside_slab) {
            let mut out = [[0.0f64; 3]; MAX_POLYGON];
            let mut m = 0;
            for k in 0..n {
                let (a, b) = (poly[k], poly[(k + 1) % n]);
                let (ga, gb) = (g(&a, h, tiny), g(&b, h, tiny));
                if ga >= 0.0 {
                    out[m] = a;
                    m += 1;
                }
                if (ga >= 0.0) != (gb >= 0.0) && m < out.len() {
                    let t = ga / (ga - gb);
                    out[m] = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])];
                    m += 1;
                }
            }
            if m == 0 {
                return None;
            }
            (poly, n) = (out, m);
        }
        let mut pts = [DVec2::ZERO; MAX_POLYGON];
        for (pt, p) in pts.iter_mut().zip(&poly[..n]) {
            *pt = DVec2::new(p[0] / p[2], p[1] / p[2]);
        }
        // Unclipped: wholly beyond one side of the grown light, as the clipping would have
        // found (a region there held no sample, but cost the point its cheaper paths).
        if inside_slab {
            let (lo, hi) = (
                pts[..3].iter().fold(DVec2::INFINITY, |m, p| m.min(*p)),
                pts[..3].iter().fold(DVec2::NEG_INFINITY, |m, p| m.max(*p)),
            );
            if hi.x < -MARGIN || hi.y < -MARGIN || lo.x > 1.0 + MARGIN || lo.y > 1.0 + MARGIN {
                return None;
            }
        }
        let lambda_min = poly[..n].iter().map(|p| p[2] / h).fold(f64::INFINITY, f64::min);
        Some(Projected { corners: pts, count: n, lambda_min })
    }
}

/// Sign of orient3d(o, e0, e1, c) = ((e0 - o) x (e1 - o)) . (c - o), or `None` where the f64
/// rounding could flip it (Shewchuk's static bound on the permanent, doubled): then
/// [`exact_orient_sign`] decides.
pub(crate) fn orient_sign(n: DVec3, n_abs: DVec3, c: DVec3, o: DVec3) -> Option<i32> {
    let d = c - o;
    let det = n.dot(d);
    let bound = 2e-15 * n_abs.dot(d.abs());
    if det > bound {
        Some(1)
    } else if det < -bound {
        Some(-1)
    } else {
        None
    }
}

/// The exact sign of orient3d(o, e0, e1, c) (Shewchuk's adaptive predicate, exact for the f64
/// values of f32 coordinates): 0 where o lies in the face's plane, which no segment from o
/// then crosses. Rare (a filter miss), so its cost does not matter.
pub(crate) fn exact_orient_sign(o: DVec3, e0: DVec3, e1: DVec3, c: DVec3) -> i32 {
    let p = |v: DVec3| robust::Coord3D { x: v.x, y: v.y, z: v.z };
    // robust's orient3d(a, b, c, d) = det[a - d, b - d, c - d] = (c - o) . ((e0 - o) x (e1 - o)).
    let det = robust::orient3d(p(c), p(e0), p(e1), p(o));
    if det > 0.0 {
        1
    } else if det < 0.0 {
        -1
    } else {
        0
    }
}

/// The clipped projection of edge (e0, e1), or `None` where nothing of it lies over the grown
/// light between o's plane and the light's.
pub(crate) fn clip(frame: &Frame, e0: DVec3, e1: DVec3) -> Option<(DVec2, DVec2)> {
    let (h0, h1) = (frame.project(e0), frame.project(e1));
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    // Each constraint g >= 0, g affine along the edge.
    let g = |h: [f64; 3]| {
        let w = h[2];
        [w, h[0] + MARGIN * w, (1.0 + MARGIN) * w - h[0], h[1] + MARGIN * w, (1.0 + MARGIN) * w - h[1]]
    };
    let (g0, g1) = (g(h0), g(h1));
    for k in 0..5 {
        let (a, b) = (g0[k], g1[k]);
        if a < 0.0 && b < 0.0 {
            return None;
        }
        if a < 0.0 {
            t0 = t0.max(a / (a - b));
        } else if b < 0.0 {
            t1 = t1.min(a / (a - b));
        }
    }
    if t0 >= t1 {
        return None;
    }
    let at = |t: f64| -> Option<DVec2> {
        // Unclipped ends keep their own projection (shared bit for bit with their other edges).
        let h = if t == 0.0 {
            h0
        } else if t == 1.0 {
            h1
        } else {
            [h0[0] + t * (h1[0] - h0[0]), h0[1] + t * (h1[1] - h0[1]), h0[2] + t * (h1[2] - h0[2])]
        };
        (h[2] > 1e-12 * frame.height).then(|| DVec2::new(h[0] / h[2], h[1] / h[2]))
    };
    Some((at(t0)?, at(t1)?))
}

/// The side of light coordinates (a, b) of the plane through o and an edge (`n` its
/// normal): s0 + a sa + b sb.
fn side_coefficients(frame: &Frame, n: DVec3) -> (f64, f64, f64) {
    let sa = n.dot(frame.u);
    let sb = n.dot(frame.v);
    (n.dot(frame.centre - frame.o) - 0.5 * (sa + sb), sa, sb)
}

/// Whether the plane through o and an edge (`n` its normal) cuts the light's plane in a line
/// ([`push`] drops the edges whose plane does not).
pub(crate) fn has_side(frame: &Frame, n: DVec3) -> bool {
    let (s0, sa, sb) = side_coefficients(frame, n);
    let scale = s0.abs().max(sa.abs()).max(sb.abs());
    scale > 0.0 && scale.is_finite()
}

/// Adds edge (e0, e1) (`n` = (e0 - o) x (e1 - o)) to `active` if its projection meets the
/// grown light.
pub(crate) fn push(active: &mut Vec<ActiveEdge>, frame: &Frame, e0: DVec3, e1: DVec3, n: DVec3, weight: i32) {
    {
        let Some((p0, p1)) = clip(frame, e0, e1) else { return };
        let (s0, sa, sb) = side_coefficients(frame, n);
        // side(s) = n . (s - o). `traced` aims its ray at s with the rounding of s and of
        // the f32 unit direction (ulps of the light's coordinates, or of the ray's length):
        // the side moves by |n| times that, taken 4 times over. Its test then moves the
        // vertices into the ray's frame in f64 (`watertight`): the edge shifts relative to o
        // by f64 ulps of their coordinates, the side by |shift x (e1 - e0)| |s - o|. (With
        // f32 ulps there, as for the f32 test this one replaced, an edge a few millimetres
        // from the point got a band of cells: a sample in ten traced on boulder-field, 0.1
        // of them with metal-rough-spheres; band_tests measured that bound 1000x loose.)
        let m_edge = frame.o.abs().max_element().max(e0.abs().max_element()).max(e1.abs().max_element());
        let m_light = frame.magnitude.max(frame.reach);
        let ulps = BAND_ULPS * f32::EPSILON as f64 * 0.5;
        let ulps64 = BAND_ULPS * f64::EPSILON * 0.5;
        let band = ulps64 * (e1 - e0).length() * frame.reach * m_edge + 4.0 * ulps * n.length() * m_light;
        // Scaled to O(1) for f32 (tiny and huge scenes alike); the band grows by the f32
        // evaluation's rounding (three products and sums of coefficients rounded once).
        let scale = s0.abs().max(sa.abs()).max(sb.abs());
        if !(scale > 0.0 && scale.is_finite()) {
            return;
        }
        // One division: any positive scale will do (the band is scaled alike).
        let inv = 1.0 / scale;
        let side = [(s0 * inv) as f32, (sa * inv) as f32, (sb * inv) as f32];
        let rounding = 8.0 * f32::EPSILON as f64 * (side[0].abs() + side[1].abs() + side[2].abs()) as f64;
        let band = (band * inv).max(rounding) as f32 * 1.001;
        // The f64 coefficients' own error (a few ulps of their terms) under the f32 one.
        let exact =
            1e-14 * n.length() * (frame.u.length() + frame.v.length() + (frame.centre - frame.o).length());
        let path_band = (rounding + exact * inv) as f32 * 1.001;
        // A sample's band holds a path point's (so a sample is never surer than a point).
        let band = band.max(path_band);
        active.push(ActiveEdge { side, band, path_band, p0, p1, weight });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filtered(o: DVec3, e0: DVec3, e1: DVec3, c: DVec3) -> Option<i32> {
        let (d0, d1) = (e0 - o, e1 - o);
        let n_abs = DVec3::new(
            (d0.y * d1.z).abs() + (d0.z * d1.y).abs(),
            (d0.z * d1.x).abs() + (d0.x * d1.z).abs(),
            (d0.x * d1.y).abs() + (d0.y * d1.x).abs(),
        );
        orient_sign(d0.cross(d1), n_abs, c, o)
    }

    /// The box of a grown region holds every point its lines accept (random triangles, some
    /// thin, with margins up to 0.05).
    #[test]
    fn a_region_box_holds_every_point_its_lines_accept() {
        let mut next = crate::silhouette_edges::uniform(0x0bad_5eed_dead_beef);
        let mut bounded = 0;
        for _ in 0..2000 {
            let pts = [0, 1, 2].map(|_| DVec2::new(next(), next()));
            let area = (pts[1] - pts[0]).perp_dot(pts[2] - pts[0]);
            let sign = if area >= 0.0 { 1.0 } else { -1.0 };
            let (lo, hi) = (DVec2::NEG_INFINITY, DVec2::INFINITY);
            let (lines, margin) = ([[0.0; 3]; MAX_POLYGON], 0.05 * next());
            let mut region = Region { lines, count: 0, margin, lo, hi, slot: 0, alpha_only: false };
            for k in 0..3 {
                let (a, b) = (pts[k], pts[(k + 1) % 3]);
                let d = b - a;
                let (la, lb) = (-d.y * sign / d.length(), d.x * sign / d.length());
                region.lines[k] = [-(la * a.x + lb * a.y), la, lb];
            }
            region.count = 3;
            region.bound();
            bounded += region.hi.x.is_finite() as u32;
            for _ in 0..200 {
                let p = DVec2::new(4.0 * next() - 1.5, 4.0 * next() - 1.5);
                let by_lines =
                    region.lines[..3].iter().all(|l| l[0] + l[1] * p.x + l[2] * p.y >= -region.margin);
                assert!(!by_lines || region.holds(p), "{p} accepted by the lines, not the box");
            }
        }
        assert!(bounded > 1900, "only {bounded} boxes finite");
    }

    /// A triangle across o's plane and the light's is clipped to the slab and the grown
    /// light; one wholly in the slab keeps its own corners, in order.
    #[test]
    fn a_clipped_triangle_lies_over_the_grown_light() {
        let light = renderer::RectLight::new(Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE);
        let frame = Frame::new(&light, Vec3::new(0.1, 0.2, 1.0)).expect("o above the light");
        let across = [DVec3::new(-3.0, 0.0, 2.0), DVec3::new(3.0, 0.5, -1.0), DVec3::new(0.0, 3.0, 0.5)];
        let p = frame.clip_triangle(across).expect("over the light");
        assert!(p.count > 3 && p.lambda_min > 0.0);
        for c in &p.corners[..p.count] {
            assert!(
                c.cmpge(DVec2::splat(-MARGIN - 1e-9)).all()
                    && c.cmple(DVec2::splat(1.0 + MARGIN + 1e-9)).all()
            );
        }
        let inside = [DVec3::new(0.0, 0.0, 0.5), DVec3::new(0.2, 0.0, 0.5), DVec3::new(0.0, 0.2, 0.5)];
        let p = frame.clip_triangle(inside).expect("over the light");
        assert_eq!(p.count, 3);
        for (c, x) in p.corners.iter().zip(inside) {
            let h = frame.project(x);
            assert_eq!(*c, DVec2::new(h[0] / h[2], h[1] / h[2]));
        }
        let beyond = inside.map(|x| x + DVec3::new(5.0, 0.0, 0.0));
        assert!(frame.clip_triangle(beyond).is_none());
    }

    /// The exact predicate agrees with the filter wherever the filter answers, and decides
    /// where it does not: a point exactly in the plane (0), and one 2^-45 off it.
    #[test]
    fn exact_orientation_decides_what_the_filter_cannot() {
        let mut uniform = crate::silhouette_edges::uniform(0x9e37_79b9_7f4a_7c15);
        let mut next = || uniform() * 20.0 - 10.0;
        let mut point = || DVec3::new(next(), next(), next());
        for _ in 0..10_000 {
            let (o, e0, e1, c) = (point(), point(), point(), point());
            let exact = exact_orient_sign(o, e0, e1, c);
            assert_eq!(filtered(o, e0, e1, c).unwrap_or(exact), exact);
        }
        let (o, e0, e1) = (DVec3::ZERO, DVec3::new(3.0, 1.0, 7.0), DVec3::new(1.0, 5.0, 2.0));
        // (e0 x e1).z = 14 > 0: c above the plane along z is on the positive side.
        let on_plane = e0 + e1;
        assert_eq!(filtered(o, e0, e1, on_plane), None);
        assert_eq!(exact_orient_sign(o, e0, e1, on_plane), 0);
        let off = on_plane + DVec3::new(0.0, 0.0, 2f64.powi(-45));
        assert_eq!(filtered(o, e0, e1, off), None);
        assert_eq!(exact_orient_sign(o, e0, e1, off), 1);
        assert_eq!(exact_orient_sign(o, e0, e1, on_plane - DVec3::new(0.0, 0.0, 2f64.powi(-45))), -1);
    }
}
