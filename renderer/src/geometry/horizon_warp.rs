//! Sampling only the part of a rectangular light above a shading point's tangent plane.
//!
//! A light point is affine in its rectangle coordinates (a, b) in [0, 1]^2
//! ([`RectLight::point`]), so the part above the plane `n . (x - p) > 0` is the unit square
//! cut by a half-plane: a convex polygon R in (a, b). [`HorizonWarp`] maps the unit square
//! onto R, measure-preserving (constant Jacobian |R|) and monotone in each coordinate: the
//! coordinate whose coefficient in the plane equation is smaller ("outer", x) is drawn from
//! its marginal by inverting the area function A(x) = int_0^x L, where L(x), the length of
//! R's slice at x, is piecewise linear (so A is piecewise quadratic); the other ("inner", y)
//! is uniform within the slice. Slicing along the larger coefficient keeps the slope of the
//! cut line in (x, y) within [-1, 1], so nearly parallel cuts are harmless. Stratified cells
//! of the square map to pieces of R of equal area, so stratification carries over.
//!
//! Everything is computed in f64, like [`RectLight::irradiance_factor`]'s clip.

use crate::geometry::light::RectLight;
use crate::geometry::point::ShadingPoint;

/// Below this area (as a fraction of the light's) the part above the horizon is too thin to
/// sample in f32 light coordinates: the caller keeps its unclipped fallback.
pub const MIN_CLIPPED_AREA: f64 = 1e-9;

/// Padding of [`HorizonWarp::bounds`], in (a, b) units: far above the warp's f64 rounding
/// (~1e-8 at worst, where the area function is inverted through a square root) and above the
/// f32 rounding of a sample's coordinates (6e-8), far below a light's size.
pub const BOUNDS_PAD: f64 = 1e-6;

/// The part of a light above a tangent plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HorizonPart {
    /// Every corner above the plane: sample the whole rectangle.
    Whole,
    /// The rectangle is cut: sample R through the warp.
    Clipped(HorizonWarp),
    /// No corner above, or R of area below [`MIN_CLIPPED_AREA`].
    Degenerate,
}

impl HorizonPart {
    /// The part of `light` strictly above `point`'s horizon: the plane through `point.p` with
    /// normal `point.n_shading`.
    pub fn new(light: &RectLight, point: &ShadingPoint) -> Self {
        let (p, n) = (point.p, point.n_shading.as_dvec3());
        let (c, u, v) = (light.center.as_dvec3(), light.u.as_dvec3(), light.v.as_dvec3());
        // f(a, b) = n . (point(a, b) - p) = f0 + fa a + fb b.
        let (fa, fb) = (n.dot(u), n.dot(v));
        let f0 = n.dot(c - p.as_dvec3()) - 0.5 * fa - 0.5 * fb;
        Self::from_plane(f0, fa, fb)
    }

    /// The part of the unit square where `f0 + fa a + fb b > 0`.
    pub fn from_plane(f0: f64, fa: f64, fb: f64) -> Self {
        let corners = [f0, f0 + fa, f0 + fb, f0 + fa + fb];
        if corners.iter().all(|&f| f > 0.0) {
            return HorizonPart::Whole;
        }
        if !corners.iter().any(|&f| f > 0.0) || !corners.iter().all(|f| f.is_finite()) {
            return HorizonPart::Degenerate;
        }
        // Mixed signs: fa or fb is non-zero.
        let outer_is_a = fb.abs() >= fa.abs();
        let (co, ci) = if outer_is_a { (fa, fb) } else { (fb, fa) };
        let warp = HorizonWarp::new(outer_is_a, ci > 0.0, 1.0 + (f0 + ci.min(0.0)) / ci.abs(), co / ci.abs());
        if warp.area >= MIN_CLIPPED_AREA { HorizonPart::Clipped(warp) } else { HorizonPart::Degenerate }
    }
}

/// One piece of the slice-length function: on [xa, xb], L(x) = la + slope (x - xa).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Piece {
    xa: f64,
    xb: f64,
    la: f64,
    slope: f64,
    area: f64,
}

impl Piece {
    /// The x in [xa, xb] where the area from xa reaches `da`.
    #[inline]
    fn solve(&self, da: f64) -> f64 {
        let da = da.clamp(0.0, self.area);
        // la d + slope d^2 / 2 = da, in the form without cancellation.
        let den = self.la + (self.la * self.la + 2.0 * self.slope * da).max(0.0).sqrt();
        let d = if den > 0.0 { 2.0 * da / den } else { 0.0 };
        (self.xa + d).min(self.xb)
    }
}

/// A measure-preserving map from the unit square onto the part R of a light's (a, b) square
/// above a tangent plane (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HorizonWarp {
    /// Whether a is the outer (marginal) coordinate, drawn from the square's first.
    outer_is_a: bool,
    /// R's slices are [1 - L, 1] (the plane's inner coefficient is positive) or [0, L].
    inner_positive: bool,
    /// L(x) = clamp(m0 + k x, 0, 1), |k| <= 1.
    m0: f64,
    k: f64,
    pieces: [Piece; 3],
    count: usize,
    /// |R|, as a fraction of the square.
    area: f64,
}

impl HorizonWarp {
    fn new(outer_is_a: bool, inner_positive: bool, m0: f64, k: f64) -> Self {
        // Breakpoints of the clamp: L = 0 at x = -m0 / k, L = 1 at x = (1 - m0) / k.
        let mut xs = [0.0, 1.0, 1.0, 1.0];
        let mut nx = 1;
        if k != 0.0 {
            for x in [-m0 / k, (1.0 - m0) / k] {
                if x > 0.0 && x < 1.0 {
                    xs[nx] = x;
                    nx += 1;
                }
            }
        }
        xs[nx] = 1.0;
        xs[..=nx].sort_by(f64::total_cmp);
        let mut pieces = [Piece::default(); 3];
        let mut area = 0.0;
        for (i, piece) in pieces.iter_mut().enumerate().take(nx) {
            let (xa, xb) = (xs[i], xs[i + 1]);
            let mid = m0 + k * 0.5 * (xa + xb);
            let (la, slope) = if mid <= 0.0 {
                (0.0, 0.0)
            } else if mid >= 1.0 {
                (1.0, 0.0)
            } else {
                ((m0 + k * xa).clamp(0.0, 1.0), k)
            };
            let d = xb - xa;
            *piece = Piece { xa, xb, la, slope, area: (la * d + 0.5 * slope * d * d).max(0.0) };
            area += piece.area;
        }
        Self { outer_is_a, inner_positive, m0, k, pieces, count: nx, area }
    }

    /// |R| as a fraction of the light's area.
    pub fn area(&self) -> f64 {
        self.area
    }

    /// The slice length at outer coordinate x.
    #[inline]
    fn slice(&self, x: f64) -> f64 {
        (self.m0 + self.k * x).clamp(0.0, 1.0)
    }

    /// The outer coordinate below which a fraction `s` of R lies: A^-1(s |R|).
    #[inline]
    fn outer(&self, s: f64) -> f64 {
        let target = s * self.area;
        let mut below = 0.0;
        let mut last = 0.0;
        for piece in &self.pieces[..self.count] {
            if piece.area <= 0.0 {
                continue;
            }
            if target <= below + piece.area {
                return piece.solve(target - below);
            }
            below += piece.area;
            last = piece.xb;
        }
        last // s a rounding above 1
    }

    /// The inner coordinate at fraction `t` of the slice of length `l`.
    #[inline]
    fn inner(&self, t: f64, l: f64) -> f64 {
        if self.inner_positive { 1.0 - (1.0 - t) * l } else { t * l }
    }

    /// The point (a, b) of R for the point (s, t) of the unit square: s is drawn along a, t
    /// along b (whichever is the outer coordinate), both increasing.
    #[inline]
    pub fn map(&self, s: f64, t: f64) -> (f64, f64) {
        let (so, si) = if self.outer_is_a { (s, t) } else { (t, s) };
        let x = self.outer(so);
        let y = self.inner(si, self.slice(x));
        if self.outer_is_a { (x, y) } else { (y, x) }
    }

    /// A rectangle `(a range, b range)` holding the image of `[s0, s1] x [t0, t1]`, padded by
    /// [`BOUNDS_PAD`] for rounding and clamped to the unit square.
    pub fn bounds(&self, s: [f64; 2], t: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        let (so, si) = if self.outer_is_a { (s, t) } else { (t, s) };
        let (x0, x1) = (self.outer(so[0]), self.outer(so[1]));
        // L is monotone (a clamped linear function), so its range over [x0, x1] is at the ends;
        // the inner coordinate is monotone in t and in L.
        let (l0, l1) = (self.slice(x0), self.slice(x1));
        let (lmin, lmax) = (l0.min(l1), l0.max(l1));
        let (y0, y1) = if self.inner_positive {
            (self.inner(si[0], lmax), self.inner(si[1], lmin))
        } else {
            (self.inner(si[0], lmin), self.inner(si[1], lmax))
        };
        let pad = |lo: f64, hi: f64| [(lo - BOUNDS_PAD).max(0.0), (hi + BOUNDS_PAD).min(1.0)];
        let (xr, yr) = (pad(x0, x1), pad(y0, y1));
        if self.outer_is_a { (xr, yr) } else { (yr, xr) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::random::Rng;

    /// Cut lines of every kind: through two opposite sides, adjacent sides (corner slivers
    /// large and tiny, on every corner), nearly parallel to either axis, and through corners.
    fn planes() -> Vec<(f64, f64, f64)> {
        let mut v = vec![
            (-0.3, 1.0, 0.0),        // a > 0.3
            (0.3, -1.0, 0.0),        // a < 0.3
            (-0.6, 0.0, 1.0),        // b > 0.6
            (0.6, 0.0, -1.0),        // b < 0.6
            (-1.9, 1.0, 1.0),        // corner sliver at (1, 1), area 0.005
            (-1.0 + 1e-3, 0.5, 0.5), // the diagonal, just above
            (0.02, -1.0, -1.0),      // sliver at (0, 0)
            (-0.97, 1.0, -0.5),      // sliver at (1, 0)
            (0.4, 1e-12, -1.0),      // nearly parallel to a
            (-0.55, 1.0, 3e-13),     // nearly parallel to b
            (-0.5, 1.0, 1.0),        // through the corners (0.5, 0) and (0, 0.5)
            (-1.0, 1.0, 1.0),        // through two corners exactly
            (-1.0 + 2e-4, 0.5, 0.5), // tiny sliver: area 1.6e-7... of the corner (1, 1)
            (-0.01, 0.02, 1.0),      // steep
        ];
        let mut rng = Rng::new(11);
        for _ in 0..40 {
            let mut r = || 2.0 * rng.next_f32() as f64 - 1.0;
            v.push((r(), r(), r()));
        }
        v
    }

    fn warps() -> Vec<(HorizonWarp, (f64, f64, f64))> {
        planes()
            .into_iter()
            .filter_map(|pl| match HorizonPart::from_plane(pl.0, pl.1, pl.2) {
                HorizonPart::Clipped(w) => Some((w, pl)),
                _ => None,
            })
            .collect()
    }

    /// The exact area of R within the rectangle [a0, a1] x [b0, b1]: the rectangle clipped by
    /// the half-plane (Sutherland-Hodgman), then the shoelace formula.
    pub(super) fn clipped_area(pl: (f64, f64, f64), a: [f64; 2], b: [f64; 2]) -> f64 {
        let f = |p: [f64; 2]| pl.0 + pl.1 * p[0] + pl.2 * p[1];
        let rect = [[a[0], b[0]], [a[1], b[0]], [a[1], b[1]], [a[0], b[1]]];
        let mut poly = Vec::new();
        for i in 0..4 {
            let (p, q) = (rect[i], rect[(i + 1) % 4]);
            let (fp, fq) = (f(p), f(q));
            if fp > 0.0 {
                poly.push(p);
            }
            if (fp > 0.0) != (fq > 0.0) {
                let t = fp / (fp - fq);
                poly.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
            }
        }
        shoelace(&poly)
    }

    fn shoelace(poly: &[[f64; 2]]) -> f64 {
        let n = poly.len();
        (0..n)
            .map(|i| poly[i][0] * poly[(i + 1) % n][1] - poly[(i + 1) % n][0] * poly[i][1])
            .sum::<f64>()
            .abs()
            * 0.5
    }

    #[test]
    fn whole_empty_and_tiny_parts_are_not_warped() {
        assert_eq!(HorizonPart::from_plane(0.1, 1.0, 1.0), HorizonPart::Whole);
        assert_eq!(HorizonPart::from_plane(0.0, 0.0, 0.0), HorizonPart::Degenerate);
        assert_eq!(HorizonPart::from_plane(-0.1, -1.0, 0.05), HorizonPart::Degenerate);
        // A corner sliver of area 5e-11.
        assert_eq!(HorizonPart::from_plane(-2.0 + 1e-5, 1.0, 1.0), HorizonPart::Degenerate);
        assert_eq!(HorizonPart::from_plane(f64::NAN, 1.0, 1.0), HorizonPart::Degenerate);
    }

    #[test]
    fn the_warps_area_is_the_clipped_polygons() {
        let ws = warps();
        assert!(ws.len() > 30, "{} clipped cases", ws.len());
        for (w, pl) in ws {
            let exact = clipped_area(pl, [0.0, 1.0], [0.0, 1.0]);
            assert!((w.area() - exact).abs() <= 1e-12 + 1e-9 * exact, "{pl:?}: {} vs {exact}", w.area());
        }
    }

    #[test]
    fn samples_land_inside_the_part_above_the_plane() {
        let mut rng = Rng::new(5);
        for (w, pl) in warps() {
            // The corners of the square, and random points.
            let st = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)];
            let random = (0..2000).map(|_| (rng.next_f32() as f64, rng.next_f32() as f64));
            for (s, t) in st.into_iter().chain(random) {
                let (a, b) = w.map(s, t);
                assert!(
                    (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b),
                    "{pl:?}: ({s}, {t}) -> ({a}, {b})"
                );
                // Above the plane, up to rounding of the cut (relative to the coefficients).
                let scale = pl.0.abs() + pl.1.abs() + pl.2.abs();
                let f = pl.0 + pl.1 * a + pl.2 * b;
                assert!(f >= -1e-12 * scale, "{pl:?}: ({s}, {t}) -> ({a}, {b}) at {f}");
            }
        }
    }

    /// Each stratum of a 16 x 16 grid maps to a piece of R of area |R| / 256, measured on the
    /// image of its boundary (shoelace over 64 points per side).
    #[test]
    fn every_stratum_maps_to_an_equal_share_of_the_area() {
        let n = 16;
        let steps = 64;
        for (w, pl) in warps() {
            for (i, j) in [(0, 0), (15, 15), (3, 12), (12, 3), (7, 8), (0, 15), (15, 0)] {
                let (s0, t0) = (i as f64 / n as f64, j as f64 / n as f64);
                let h = 1.0 / n as f64;
                let mut poly = Vec::new();
                let along = |k: usize| k as f64 / steps as f64 * h;
                for k in 0..steps {
                    poly.push(w.map(s0 + along(k), t0));
                }
                for k in 0..steps {
                    poly.push(w.map(s0 + h, t0 + along(k)));
                }
                for k in 0..steps {
                    poly.push(w.map(s0 + h - along(k), t0 + h));
                }
                for k in 0..steps {
                    poly.push(w.map(s0, t0 + h - along(k)));
                }
                let poly: Vec<[f64; 2]> = poly.into_iter().map(|(a, b)| [a, b]).collect();
                let area = shoelace(&poly);
                let expected = w.area() / (n * n) as f64;
                // The image's curved sides (a function of s through a square root) are
                // approximated by chords: 1e-3 relative, measured ~1e-5.
                assert!(
                    (area - expected).abs() <= 1e-3 * expected + 1e-15,
                    "{pl:?} stratum ({i}, {j}): {area} vs {expected}"
                );
            }
        }
    }

    /// A fixed rectangle receives its share |Q n R| / |R| of uniformly drawn points, within
    /// 5 binomial standard deviations (plus 1e-4 for the clip's own rounding).
    #[test]
    fn samples_are_uniform_over_the_part() {
        let mut rng = Rng::new(9);
        let draws = 20_000;
        let q = ([0.3, 0.8], [0.55, 0.95]);
        for (w, pl) in warps() {
            let share = clipped_area(pl, q.0, q.1) / w.area();
            let inside = (0..draws)
                .filter(|_| {
                    let (a, b) = w.map(rng.next_f32() as f64, rng.next_f32() as f64);
                    (q.0[0]..q.0[1]).contains(&a) && (q.1[0]..q.1[1]).contains(&b)
                })
                .count();
            let sd = (share * (1.0 - share) / draws as f64).sqrt();
            let got = inside as f64 / draws as f64;
            assert!((got - share).abs() <= 5.0 * sd + 1e-4, "{pl:?}: {got} vs {share} (sd {sd})");
        }
    }

    /// `bounds` holds the image of a block of strata (checked on a fine grid of its points)
    /// and is not much larger than the block's image needs.
    #[test]
    fn bounds_hold_the_image_of_a_block() {
        for (w, pl) in warps() {
            for (s, t) in [([0.0, 1.0], [0.0, 1.0]), ([0.25, 0.5], [0.75, 1.0]), ([0.5, 0.75], [0.0, 0.25])] {
                let (ar, br) = w.bounds(s, t);
                let steps = 40;
                for i in 0..=steps {
                    for j in 0..=steps {
                        let si = s[0] + (s[1] - s[0]) * i as f64 / steps as f64;
                        let tj = t[0] + (t[1] - t[0]) * j as f64 / steps as f64;
                        let (a, b) = w.map(si, tj);
                        assert!(
                            ar[0] <= a && a <= ar[1] && br[0] <= b && b <= br[1],
                            "{pl:?} block {s:?} x {t:?}: ({a}, {b}) outside {ar:?} x {br:?}"
                        );
                    }
                }
            }
        }
    }
}

/// `traced` through the warp: horizon slivers, an analytic fraction, and exact culling.
#[cfg(test)]
mod traced_tests {
    use crate::geometry::camera::Camera;
    use crate::geometry::horizon_warp::HorizonPart;
    use crate::geometry::light::RectLight;
    use crate::geometry::point::ShadingPoint;
    use crate::geometry::scene::Scene;
    use crate::interface::shadowing::{LightShadowing, PrepareContext, ShadowQuery};
    use crate::load::gltf_load::Geometry;
    use crate::methods::traced::{Traced, TracedParams};
    use crate::util::random::Rng;
    use glam::{DVec3, Vec3};
    use std::time::Duration;

    type Quad = ([f64; 3], [f64; 3], [f64; 3]);

    /// 1 x 1 light at height 2 facing down: point(a, b) = (a - 0.5, 2, b - 0.5).
    fn light() -> RectLight {
        RectLight::new(Vec3::new(0.0, 2.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE)
    }

    fn scene(quads: &[Quad]) -> Scene {
        let mut g = Geometry::default();
        for (c, u, v) in quads {
            g.add_quad(DVec3::from(*c), DVec3::from(*u), DVec3::from(*v), [0.5; 3]);
        }
        let camera = Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        Scene::build(g, vec![light()], camera, DVec3::ZERO, Duration::ZERO)
    }

    fn traced(s: &Scene, mut t: Traced) -> Traced {
        let ctx = PrepareContext::for_light(s, 0);
        t.prepare(&ctx).unwrap();
        t
    }

    fn query(p: Vec3, n: Vec3, seed: u64) -> ShadowQuery {
        ShadowQuery {
            point: ShadingPoint {
                p,
                p_error: crate::geometry::ray_origin::point_error(p),
                n_geom: n,
                n_shading: n,
            },
            pixel: [0, 0],
            seed,
            irradiance: 0.0,
        }
    }

    /// The occluder: x in [edge / 2, edge / 2 + 4], z in [-2, 2] at y = 1. From the origin it
    /// hides the light's points with x > edge.
    fn half_plane(edge: f64) -> Quad {
        ([0.5 * edge + 2.0, 1.0, 0.0], [4.0, 0.0, 0.0], [0.0, 0.0, 4.0])
    }

    /// The exact V at the origin (normal `n`) behind [`half_plane`]`(edge)`: the irradiance of
    /// the light's unblocked part (x <= edge), horizon-clipped, over the whole light's
    /// (Lambert's formula on each: the share of irradiance, contract "Conventions").
    fn exact_share(edge: f32, n: Vec3) -> f64 {
        let whole = light();
        let width = edge + 0.5;
        let open =
            RectLight::new(Vec3::new(edge - 0.5 * width, 2.0, 0.0), width * Vec3::X, Vec3::Z, Vec3::ONE);
        open.irradiance_factor_f64(Vec3::ZERO, n) / whole.irradiance_factor_f64(Vec3::ZERO, n)
    }

    /// The case: a point whose horizon leaves it a corner sliver of 0.5% of the light
    /// (x, z in [0.4, 0.5], x + z > 0.9), a quarter of its area unblocked (a share of its
    /// irradiance of 0.127: the unblocked quarter lies along the horizon). Unwarped, 64 samples
    /// put 0.3 in the sliver (V = 1 by the fallback, or 0 or 1 from one sample).
    #[test]
    fn a_horizon_sliver_at_64_samples_is_within_a_tenth_of_16384() {
        let s = scene(&[half_plane(0.45)]);
        let n = Vec3::new(0.2, -0.09, 0.2).normalize();
        let exact = exact_share(0.45, n) as f32;
        let (few, many) = (
            traced(&s, Traced::new(TracedParams::CULLED, 64)),
            traced(&s, Traced::new(TracedParams::CULLED, 16384)),
        );
        for seed in 0..20 {
            let q = query(Vec3::ZERO, n, seed);
            let (v64, v16k) = (few.visibility(&s, &q), many.visibility(&s, &q));
            assert!((v16k - exact).abs() <= 0.01, "seed {seed}: V_16384 {v16k}, exact {exact}");
            assert!((v64 - v16k).abs() <= 0.1, "seed {seed}: V_64 {v64} vs V_16384 {v16k}");
        }
    }

    /// Under an oblique horizon cut (a + b / 2 > 1.15: a triangle, 12% of the light) and an
    /// occluder edge across it, the estimates are unbiased (the mean of 200 within 4 standard
    /// errors of the exact share of irradiance, plus 1e-6: shadow rays start the point's own error bound
    /// along the tilted normal, ~1e-38 at the origin), each within 0.03 of it at N = 1024,
    /// and converge.
    #[test]
    fn a_clipped_half_occluded_light_gives_the_exact_fraction() {
        let n = Vec3::new(1.0, -0.2, 0.5).normalize();
        // The cut in light coordinates: n . (point(a, b) - 0) = (a + b / 2 - 1.15) |n|^-1 .
        let cut = (-1.15, 1.0, 0.5);
        let whole = super::tests::clipped_area(cut, [0.0, 1.0], [0.0, 1.0]);
        assert!((whole - 0.1225).abs() < 1e-12);
        let seeds = 200u64;
        for edge in [0.3, 0.42] {
            let exact = exact_share(edge as f32, n);
            let area = super::tests::clipped_area(cut, [0.0, edge + 0.5], [0.0, 1.0]) / whole;
            assert!((exact - area).abs() > 0.05, "edge {edge}: the test tells V from the area fraction");
            let s = scene(&[half_plane(edge)]);
            let mut rmse_by_n = Vec::new();
            for samples in [16u32, 64, 256, 1024] {
                let t = traced(&s, Traced::new(TracedParams::CULLED, samples));
                let v: Vec<f64> =
                    (0..seeds).map(|k| t.visibility(&s, &query(Vec3::ZERO, n, k)) as f64).collect();
                let mean = v.iter().sum::<f64>() / seeds as f64;
                let var = v.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (seeds - 1) as f64;
                let se = (var / seeds as f64).sqrt();
                // Origins move by the point's own error bound only (~1e-38 at the origin). 4
                // standard errors: 8 means are tested (3 gave a 2% chance of a false alarm, and
                // one came: 3.03 at N = 256, and -0.19 with 4000 seeds).
                let tol = 4.0 * se + 1e-6;
                assert!((mean - exact).abs() <= tol, "edge {edge} N {samples}: {mean} vs {exact} ({tol})");
                let worst = v.iter().map(|e| (e - exact).abs()).fold(0.0, f64::max);
                if samples == 1024 {
                    assert!(worst <= 0.03, "edge {edge}: worst {worst}");
                }
                rmse_by_n.push((v.iter().map(|e| (e - exact).powi(2)).sum::<f64>() / seeds as f64).sqrt());
            }
            // Stratified sampling of a straight edge: ~N^-3/4, 16x from N = 16 to 1024.
            assert!(rmse_by_n[3] * 4.0 < rmse_by_n[0], "edge {edge}: {rmse_by_n:?}");
        }
    }

    /// Shaft culling stays exact where the horizon cuts the light: culled and plain traced give
    /// the same bits on points whose shading normal tilts the horizon through the light, among
    /// random occluders, and culling still skips rays there.
    #[test]
    fn culling_gives_the_plain_bits_under_a_clipped_light() {
        let mut rng = Rng::new(23);
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let floor: Quad = ([0.0, 0.0, 0.0], [20.0, 0.0, 0.0], [0.0, 0.0, -20.0]);
        let mut quads = vec![floor];
        for _ in 0..30 {
            let c = [r(-2.0, 2.0) as f64, r(0.05, 1.8) as f64, r(-2.0, 2.0) as f64];
            let u = [r(0.02, 0.4) as f64, r(-0.2, 0.2) as f64, r(-0.1, 0.1) as f64];
            let v = [r(-0.1, 0.1) as f64, r(-0.2, 0.2) as f64, r(0.02, 0.4) as f64];
            quads.push((c, u, v));
        }
        let s = scene(&quads);
        let (plain, culled) = (
            traced(&s, Traced::new(TracedParams::PLAIN, 1024)),
            traced(&s, Traced::new(TracedParams::CULLED, 1024)),
        );
        let (mut clipped, mut partial) = (0, 0);
        for k in 0..600u64 {
            let p = Vec3::new(r(-2.0, 2.0), 0.0, r(-2.0, 2.0));
            // A shading normal whose horizon passes near the light's centre: tilted away from
            // it by about the elevation's complement, give or take 0.4 rad.
            let to_light = (Vec3::new(0.0, 2.0, 0.0) - p).normalize();
            let away = Vec3::new(-to_light.x, 0.0, -to_light.z).normalize_or(Vec3::X);
            let tilt = std::f32::consts::FRAC_PI_2 - to_light.y.asin() + r(-0.4, 0.4);
            let n = (Vec3::Y * tilt.cos() + away * tilt.sin()).normalize();
            let q = ShadowQuery {
                point: ShadingPoint {
                    p,
                    p_error: crate::geometry::ray_origin::point_error(p),
                    n_geom: Vec3::Y,
                    n_shading: n,
                },
                pixel: [0, 0],
                seed: k,
                irradiance: 0.0,
            };
            if !matches!(HorizonPart::new(&s.lights[0], &q.point), HorizonPart::Clipped(_)) {
                continue;
            }
            if s.lights[0].irradiance_factor(p, n) <= 0.0 {
                continue;
            }
            clipped += 1;
            let (a, b) = (plain.visibility(&s, &q), culled.visibility(&s, &q));
            assert_eq!(a.to_bits(), b.to_bits(), "point {p} normal {n}: plain {a} culled {b}");
            partial += usize::from(a > 0.0 && a < 1.0);
        }
        let rays = |t: &Traced| t.counters().into_iter().find(|c| c.0 == "shadow_rays").unwrap().1;
        assert!(clipped > 120, "{clipped} clipped points");
        assert!(partial > clipped / 10, "{partial} of {clipped} in penumbra");
        assert!(rays(&culled) * 2 < rays(&plain), "culled {} plain {}", rays(&culled), rays(&plain));
    }
}
