//! Strata in proportion to the irradiance: under a near or large light, `traced`'s samples are
//! spread so that each stratum carries about the same share of the point's irradiance.
//!
//! Uniform strata weighed by g = cos cos / r^2 ([`crate::methods::irradiance_share`]) are
//! unbiased, but where g peaks (a light close above the point) the few strata under the peak
//! carry most of the irradiance, and an edge crossing them is noisy: at 0.3 light widths the
//! error of N = 4096 reaches 0.004 (1 sigma) against 0.001 under a far light
//! (`tests/physical_visibility.rs`). So where g varies over the light by more than
//! [`PEAK_OVER_MEAN`] times its mean, the strata follow g: rows of equal mass of g's marginal in b, then in each
//! row, columns of equal mass of g's density across that row's band. Every stratum is still an
//! axis-aligned rectangle of the light, one jittered sample in it, weighed by g times its area
//! (so the estimate stays unbiased whatever the partition); the partition only sets the
//! variance. The density is a 16 x 16 table of g at cell centres with a tenth of the uniform
//! density mixed in (no stratum is ever more than ~10x the uniform one). Rejected: solid
//! angle or projected solid angle sampling, whose strata are curved in the light's
//! coordinates (`silhouette` bins samples by position, but `traced`'s shafts and the counting
//! cell by cell need rectangles), and measured no better on average
//! (`docs/notes/2026-11-28-visibility-estimators.md`).

use crate::geometry::light::RectLight;
use crate::geometry::point::ShadingPoint;
use glam::Vec3;

/// Table cells per axis.
const TAB: usize = 16;
/// The uniform density's share in the mixture.
const UNIFORM_SHARE: f32 = 0.1;
/// g's peak over its mean on the light above which the strata follow g: a point under the
/// middle of a square light nearer than about 0.65 light widths, or under its edge nearer than
/// about 0.9 (a floor 2.4 light widths below, as in the default scene, has 1.05 to 1.4, and
/// keeps the plain grid and `silhouette`'s counting cell by cell).
pub const PEAK_OVER_MEAN: f64 = 1.8;
/// Padding of [`IrradianceStrata::block_bounds`], in light coordinates: far above the f32
/// rounding of a stratum's bounds and its sample (a few ulps of 1).
const BOUNDS_PAD: f32 = 1e-5;

/// A point's strata in proportion to g (see the module doc).
#[derive(Debug, Clone)]
pub struct IrradianceStrata {
    /// The density per table cell, row r (b) major, each row normalised to sum 1.
    rows_cdf: [[f32; TAB + 1]; TAB],
    /// Each table row's mass, as a share of the whole.
    row_mass: [f32; TAB],
    /// The marginal CDF over table rows: `b_cdf[r]` is the mass of rows below r.
    b_cdf: [f32; TAB + 1],
}

/// g at light point `y` from `p` (normal `n`), up to a constant factor: (n . w) (n_L . w) / r^4,
/// with lengths in units of `unit` (so that f32 holds r^4 in a scene 1e-20 m or 1e20 m across).
fn g(p: Vec3, n: Vec3, light_n: Vec3, y: Vec3, inv_unit: f32) -> f32 {
    let w = (y - p) * inv_unit;
    let inv = 1.0 / w.length_squared();
    n.dot(w).max(0.0) * inv * (-light_n.dot(w)).max(0.0) * inv
}

/// The x in [0, 1] where the piecewise-linear CDF `cdf` (TAB + 1 knots at k / TAB, from 0 to
/// 1, non-decreasing) reaches `t`.
fn inverse(cdf: &[f32; TAB + 1], t: f32) -> f32 {
    if t <= 0.0 {
        return 0.0;
    }
    if t >= 1.0 {
        return 1.0;
    }
    // The last knot at or below t (knot 0 is 0 <= t).
    let k = cdf[1..TAB].iter().take_while(|&&c| c <= t).count();
    let span = cdf[k + 1] - cdf[k];
    let f = if span > 0.0 { ((t - cdf[k]) / span).clamp(0.0, 1.0) } else { 0.0 };
    ((k as f32 + f) / TAB as f32).min(1.0)
}

/// A column CDF over one band of rows: the mixture of the table rows it overlaps.
#[derive(Debug, Clone, Copy)]
pub struct Columns {
    cdf: [f32; TAB + 1],
}

impl Columns {
    /// The a where the band's column CDF reaches `s`.
    #[inline]
    pub fn at(&self, s: f32) -> f32 {
        inverse(&self.cdf, s)
    }
}

/// g from `point` as a function of the light point, in units of the point's distance to the
/// light's centre (so that f32 holds r^4 in a scene 1e-20 m or 1e20 m across).
fn g_from(light: &RectLight, point: &ShadingPoint) -> impl Fn(Vec3) -> f32 {
    let (p, n, ln) = (point.p, point.n_shading, light.normal);
    let unit = (light.center.as_dvec3() - p.as_dvec3()).length();
    let inv_unit = if unit > 0.0 && unit.is_finite() { (1.0 / unit) as f32 } else { 1.0 };
    move |y| g(p, n, ln, y, inv_unit)
}

impl IrradianceStrata {
    /// Whether g's peak over the light exceeds [`PEAK_OVER_MEAN`] times its mean, both
    /// estimated from ten values: the peak at the corners, edge midpoints, centre and the
    /// point's foot on the light (where a point facing it sees g peak), the mean by Simpson's
    /// rule on the 3 x 3 of them. A decision, not a measurement: any strata are unbiased, so
    /// it need only be cheap (ten evaluations, ~40 ns; the exact mean's four arc tangents
    /// cost `silhouette` 3% on the default scene) and the same for every method.
    pub fn varies(light: &RectLight, point: &ShadingPoint) -> bool {
        let g = g_from(light, point);
        let (mut peak, mut sum) = (0.0f32, 0.0f32);
        for (j, wj) in [(0.0, 1.0), (0.5, 4.0), (1.0, 1.0)] {
            for (i, wi) in [(0.0, 1.0), (0.5, 4.0), (1.0, 1.0)] {
                let v = g(light.point(i, j));
                peak = peak.max(v);
                sum += wi * wj * v;
            }
        }
        // In f64: a light 1e20 m across overflows f32's squared edge.
        let to_point = point.p.as_dvec3() - light.center.as_dvec3();
        let foot = |edge: Vec3| {
            let edge = edge.as_dvec3();
            (to_point.dot(edge) / edge.length_squared() + 0.5).clamp(0.0, 1.0) as f32
        };
        let peak = peak.max(g(light.point(foot(light.u), foot(light.v))));
        let mean = sum / 36.0;
        mean > 0.0 && peak.is_finite() && peak as f64 > PEAK_OVER_MEAN * mean as f64
    }

    /// The strata of `point` under `light` when g varies over the light by more than
    /// [`PEAK_OVER_MEAN`] times its mean and the whole light is above the point's horizon; `None` for the plain
    /// grid.
    pub fn new(light: &RectLight, point: &ShadingPoint) -> Option<Self> {
        if !Self::varies(light, point) {
            return None;
        }
        let g = g_from(light, point);
        let mut table = [[0.0f32; TAB]; TAB];
        let mut total = 0.0f64;
        for (r, row) in table.iter_mut().enumerate() {
            for (c, cell) in row.iter_mut().enumerate() {
                let (a, b) = ((c as f32 + 0.5) / TAB as f32, (r as f32 + 0.5) / TAB as f32);
                *cell = g(light.point(a, b));
                total += *cell as f64;
            }
        }
        if !(total.is_finite() && total > 0.0) {
            return None;
        }
        let uniform = UNIFORM_SHARE as f64 * total / (TAB * TAB) as f64;
        let scale = (1.0 - UNIFORM_SHARE) as f64;
        let mut rows_cdf = [[0.0f32; TAB + 1]; TAB];
        let mut row_mass = [0.0f32; TAB];
        let mut b_cdf = [0.0f32; TAB + 1];
        let mut below = 0.0f64;
        for (r, row) in table.iter().enumerate() {
            // The mixture's running sums over the row, then normalised.
            let mut sums = [0.0f64; TAB + 1];
            for (c, &cell) in row.iter().enumerate() {
                sums[c + 1] = sums[c] + scale * cell as f64 + uniform;
            }
            let sum = sums[TAB];
            rows_cdf[r] = sums.map(|x| (x / sum) as f32);
            rows_cdf[r][TAB] = 1.0;
            row_mass[r] = (sum / total) as f32;
            below += sum;
            b_cdf[r + 1] = (below / total) as f32;
        }
        b_cdf[TAB] = 1.0;
        Some(Self { rows_cdf, row_mass, b_cdf })
    }

    /// The band [b0, b1] of sample row `j` of `ny`.
    #[inline]
    pub fn row(&self, j: u32, ny: u32) -> [f32; 2] {
        [inverse(&self.b_cdf, j as f32 / ny as f32), inverse(&self.b_cdf, (j + 1) as f32 / ny as f32)]
    }

    /// The column CDF of the band [b0, b1]: the table rows it overlaps, each by its overlap
    /// times its mass.
    pub fn columns(&self, band: [f32; 2]) -> Columns {
        let mut cdf = [0.0f32; TAB + 1];
        let mut weight = 0.0f32;
        for r in table_rows(band) {
            let overlap =
                (band[1].min((r + 1) as f32 / TAB as f32) - band[0].max(r as f32 / TAB as f32)).max(0.0);
            let w = overlap * self.row_mass[r];
            for (c, x) in cdf.iter_mut().enumerate() {
                *x += w * self.rows_cdf[r][c];
            }
            weight += w;
        }
        if weight > 0.0 {
            for x in &mut cdf {
                *x /= weight;
            }
        } else {
            // A band of zero height (rounding): the uniform columns.
            cdf = std::array::from_fn(|c| c as f32 / TAB as f32);
        }
        cdf[TAB] = 1.0;
        Columns { cdf }
    }

    /// Light-coordinate bounds of the strata block whose plain coordinates are `a` x `b`
    /// ([i0 / nx, i1 / nx] x [j0 / ny, j1 / ny]), for the shafts: the rows' band, and the
    /// columns over it (each row's column CDF mixes the table rows its band overlaps, so its
    /// inverse lies between theirs), padded.
    pub fn block_bounds(&self, a: [f32; 2], b: [f32; 2]) -> ([f32; 2], [f32; 2]) {
        let band = [inverse(&self.b_cdf, b[0]), inverse(&self.b_cdf, b[1])];
        let (mut lo, mut hi) = (1.0f32, 0.0f32);
        for r in table_rows(band) {
            lo = lo.min(inverse(&self.rows_cdf[r], a[0]));
            hi = hi.max(inverse(&self.rows_cdf[r], a[1]));
        }
        if lo > hi {
            (lo, hi) = (0.0, 1.0);
        }
        ([lo - BOUNDS_PAD, hi + BOUNDS_PAD], [band[0] - BOUNDS_PAD, band[1] + BOUNDS_PAD])
    }
}

/// The table rows a band [b0, b1] overlaps.
fn table_rows(band: [f32; 2]) -> std::ops::Range<usize> {
    let first = ((band[0] * TAB as f32) as usize).min(TAB - 1);
    let last = ((band[1] * TAB as f32).ceil() as usize).clamp(first + 1, TAB);
    first..last
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point_under(h: f32) -> (RectLight, ShadingPoint) {
        let light = RectLight::new(Vec3::new(0.0, h, 0.0), Vec3::X, Vec3::Z, Vec3::ONE);
        let p = Vec3::new(0.1, 0.0, -0.2);
        let point = ShadingPoint {
            p,
            p_error: crate::geometry::ray_origin::point_error(p),
            n_geom: Vec3::Y,
            n_shading: Vec3::Y,
        };
        (light, point)
    }

    /// Shaft culling stays exact where the strata follow g (its leaves' bounds are
    /// [`IrradianceStrata::block_bounds`]): culled and plain `traced` give the same bits on
    /// points close under the light among random occluders, and culling still skips rays.
    #[test]
    fn culling_gives_the_plain_bits_where_the_strata_follow_g() {
        use crate::geometry::camera::Camera;
        use crate::geometry::scene::Scene;
        use crate::interface::shadowing::{LightShadowing, PrepareContext, ShadowQuery};
        use crate::load::gltf_load::Geometry;
        use crate::methods::traced::{Traced, TracedParams};
        use crate::util::random::Rng;
        use glam::DVec3;
        let mut rng = Rng::new(41);
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let mut g = Geometry::default();
        for _ in 0..30 {
            let c = DVec3::new(r(-1.0, 1.0) as f64, r(1.0, 1.9) as f64, r(-1.0, 1.0) as f64);
            g.add_quad(
                c,
                DVec3::new(r(0.02, 0.3) as f64, 0.0, 0.0),
                DVec3::new(0.0, 0.0, r(0.02, 0.3) as f64),
                [0.5; 3],
            );
        }
        let light = RectLight::new(Vec3::new(0.0, 2.0, 0.0), Vec3::X, Vec3::Z, Vec3::ONE);
        let camera = Camera::look_at(Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        let s = Scene::build(g, vec![light], camera, DVec3::ZERO, std::time::Duration::ZERO);
        let prepared = |mut t: Traced| {
            let ctx = PrepareContext::for_light(&s, 0);
            t.prepare(&ctx).unwrap();
            t
        };
        let (plain, culled) = (
            prepared(Traced::new(TracedParams::PLAIN, 1024)),
            prepared(Traced::new(TracedParams::CULLED, 1024)),
        );
        let (mut followed, mut partial) = (0, 0);
        for k in 0..400u64 {
            let p = Vec3::new(r(-1.2, 1.2), r(0.6, 1.2), r(-1.2, 1.2));
            let point = ShadingPoint {
                p,
                p_error: crate::geometry::ray_origin::point_error(p),
                n_geom: Vec3::Y,
                n_shading: Vec3::Y,
            };
            followed += IrradianceStrata::new(&s.lights[0], &point).is_some() as usize;
            let q = ShadowQuery { point, pixel: [0, 0], seed: k, irradiance: 0.0 };
            let (a, b) = (plain.visibility(&s, &q), culled.visibility(&s, &q));
            assert_eq!(a.to_bits(), b.to_bits(), "point {p}: plain {a} culled {b}");
            partial += usize::from(a > 0.0 && a < 1.0);
        }
        let rays = |t: &Traced| t.counters().into_iter().find(|c| c.0 == "shadow_rays").unwrap().1;
        assert!(followed > 300, "only {followed} points follow g");
        assert!(partial > 40, "{partial} in penumbra");
        assert!(rays(&culled) * 2 < rays(&plain), "culled {} plain {}", rays(&culled), rays(&plain));
    }

    /// The decision is the same at every scale a scene may have (a light 1e20 m across
    /// overflowed f32's squared edge at the point's foot).
    #[test]
    fn the_decision_does_not_depend_on_the_scene_scale() {
        for h in [0.05f32, 0.1, 0.15, 0.3, 1.0] {
            let at = |sc: f32| {
                let light =
                    RectLight::new(Vec3::new(0.0, 2.0, 0.0) * sc, Vec3::X * sc, Vec3::Z * sc, Vec3::ONE);
                let p = Vec3::new(-0.25, 2.0 - h, -0.25) * sc;
                let point = ShadingPoint {
                    p,
                    p_error: crate::geometry::ray_origin::point_error(p),
                    n_geom: Vec3::Y,
                    n_shading: Vec3::Y,
                };
                IrradianceStrata::varies(&light, &point)
            };
            let unit = at(1.0);
            for sc in [1e-20, 1e19, 1e20] {
                assert_eq!(at(sc), unit, "h {h} scale {sc}");
            }
        }
    }

    #[test]
    fn a_far_light_keeps_the_plain_grid_and_a_near_one_follows_g() {
        let (far, p) = point_under(3.0);
        assert!(IrradianceStrata::new(&far, &p).is_none());
        let (near, p) = point_under(0.3);
        assert!(IrradianceStrata::new(&near, &p).is_some());
    }

    /// The strata partition the light: rows tile [0, 1], each row's columns tile [0, 1], and
    /// each stratum's exact share of g (a fine midpoint sum) is within a factor of the
    /// uniform share 1 / N, where a uniform grid's ranges over 40x at 0.3 light widths.
    #[test]
    fn strata_tile_the_light_with_near_equal_shares_of_g() {
        let (light, point) = point_under(0.3);
        let s = IrradianceStrata::new(&light, &point).unwrap();
        let (nx, ny) = (16u32, 16u32);
        let fine = 24;
        let mut total = 0.0f64;
        let mut shares = Vec::new();
        let mut prev_b = 0.0;
        for j in 0..ny {
            let band = s.row(j, ny);
            assert_eq!(band[0], prev_b, "row {j}");
            prev_b = band[1];
            let cols = s.columns(band);
            let mut prev_a = 0.0;
            for i in 0..nx {
                let (a0, a1) = (cols.at(i as f32 / nx as f32), cols.at((i + 1) as f32 / nx as f32));
                assert_eq!(a0, prev_a, "row {j} column {i}");
                assert!(a1 > a0 && band[1] > band[0]);
                prev_a = a1;
                let mut sum = 0.0f64;
                for u in 0..fine {
                    for v in 0..fine {
                        let a = a0 + (a1 - a0) * (u as f32 + 0.5) / fine as f32;
                        let b = band[0] + (band[1] - band[0]) * (v as f32 + 0.5) / fine as f32;
                        sum += g(point.p, point.n_shading, light.normal, light.point(a, b), 1.0) as f64;
                    }
                }
                let share = sum * ((a1 - a0) * (band[1] - band[0])) as f64 / (fine * fine) as f64;
                total += share;
                shares.push(share);
            }
            assert_eq!(prev_a, 1.0);
        }
        assert_eq!(prev_b, 1.0);
        let (lo, hi) = shares.iter().fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
        let uniform = total / (nx * ny) as f64;
        assert!(lo > 0.3 * uniform && hi < 2.0 * uniform, "shares {lo} to {hi} of {uniform}");
    }
}
