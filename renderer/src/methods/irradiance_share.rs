//! The shadow term every method returns: the share of the light's irradiance that arrives,
//! estimated from a point's light samples and their verdicts (contract, "Conventions").
//!
//! Each sample y_i carries g_i = cos(theta_x) cos(theta_y) / r^2 (theta_x from the shading
//! normal, as the unshadowed irradiance E = L G takes it). The samples are uniform over the
//! part of the light above the horizon (the rectangle, or the horizon warp's part: both
//! measure-preserving), so each stands for `a = |part| / N` of it and `a sum g_i` over a set
//! estimates that set's share of G without bias. G itself is exact (Lambert's formula, the
//! same the shading multiplies by), so
//!
//! ```text
//! V = 1 - a sum_{blocked} g_i / G    when at most half the samples are blocked,
//! V = a sum_{visible} g_i / G        otherwise,
//! ```
//!
//! clamped to [0, 1]: a point with nothing blocked is exactly 1 and one with nothing visible
//! exactly 0, and only the smaller of the two sets is weighed (a method that knows each
//! sample's verdict, like `silhouette`, weighs no sample where a point is lit or in umbra).
//! The sums run in stratum order from 0, so every method that reaches the same verdicts
//! returns the same bits. Rejected: the ratio sum_{visible} g / sum_{all} g (needs every
//! sample's weight at every penumbra point, and is biased by O(1/N)); sampling in proportion
//! to g (solid angle or projected solid angle: the samples leave the light's row grid that
//! `silhouette` counts along). Measured against both: `docs/notes/2026-11-28-visibility-estimators.md`.

use crate::geometry::light::RectLight;
use crate::interface::shadowing::ShadowQuery;
use glam::Vec3;

/// One point's weights and the share they make: see the module doc.
#[derive(Debug, Clone, Copy)]
pub struct IrradianceShare {
    light: RectLight,
    p: Vec3,
    n: Vec3,
    /// 1 / the point's distance to the light's centre: lengths are measured in that unit, so
    /// that f32 holds r^4 for a scene 1e-20 m or 1e20 m across.
    inv_unit: f32,
    /// In that unit: the light's corner (a, b) = (0, 0) from the point, and its edges, so that
    /// the vector to light point (a, b) is `corner + a u + b v` ([`IrradianceShare::weight_at`]).
    corner: Vec3,
    u: Vec3,
    v: Vec3,
    /// The point's height over the light's plane, n_L . (p - c), in that unit: r cos(theta_y)
    /// for every light point (positive where the point faces the emitting side).
    height: f32,
    /// The area each sample stands for: |part above the horizon| / N, in that unit squared.
    sample_area: f64,
    /// G, where the query brings it ([`ShadowQuery::irradiance`]; 0: computed when needed).
    given: f32,
}

impl IrradianceShare {
    /// The weights of `q`'s samples of `light`: `samples` of them uniform over a part of the
    /// light of `part` times its area (1: the whole rectangle).
    pub fn new(light: &RectLight, q: &ShadowQuery, part: f64, samples: u32) -> Self {
        let point = &q.point;
        let area = light.u.as_dvec3().cross(light.v.as_dvec3()).length();
        let to_point = point.p.as_dvec3() - light.center.as_dvec3();
        let unit = match to_point.length() {
            d if d > 0.0 && d.is_finite() => d,
            _ => 1.0,
        };
        let corner =
            light.center.as_dvec3() - 0.5 * (light.u.as_dvec3() + light.v.as_dvec3()) - point.p.as_dvec3();
        Self {
            light: *light,
            p: point.p,
            n: point.n_shading,
            inv_unit: (1.0 / unit) as f32,
            corner: (corner / unit).as_vec3(),
            u: (light.u.as_dvec3() / unit).as_vec3(),
            v: (light.v.as_dvec3() / unit).as_vec3(),
            height: (light.normal.as_dvec3().dot(to_point).max(0.0) / unit) as f32,
            sample_area: area / (unit * unit) * part / samples.max(1) as f64,
            given: q.irradiance,
        }
    }

    /// g at the light point `target`: cos(theta_x) cos(theta_y) / r^2 = (n . w) h / r^4 with
    /// w = target - p and h the point's height over the light's plane (no square root), in
    /// the point's unit of length ([`IrradianceShare::sample_area`] is in the same). A sample
    /// under the horizon by rounding counts nothing. f32 on purpose: weighing is the only
    /// per-sample work `silhouette` adds in penumbra (measured: f64 and a full redraw of each
    /// sample cost it 37% on the default scene).
    #[inline(always)]
    pub fn weight(&self, target: Vec3) -> f64 {
        self.g((target - self.p) * self.inv_unit)
    }

    /// g at the light point of rectangle coordinates (a, b), from the point's own corner and
    /// edges (six multiply-adds, not [`RectLight::point`]'s and a subtraction): the weight of
    /// `traced`'s samples, which carry their (a, b), for every method that answers them.
    #[inline(always)]
    pub fn weight_at(&self, a: f32, b: f32) -> f64 {
        self.g(self.corner + a * self.u + b * self.v)
    }

    /// g for the vector `w` from the point to a light point, in the point's unit.
    #[inline(always)]
    fn g(&self, w: Vec3) -> f64 {
        let inv = 1.0 / w.length_squared();
        (self.n.dot(w).max(0.0) * inv * (self.height * inv)) as f64
    }

    /// Whether the blocked samples are the set to weigh: at most half of those counted.
    #[inline]
    fn weigh_blocked(counted: u32, blocked: u32) -> bool {
        2 * blocked as u64 <= counted as u64
    }

    /// V from `blocked` of `counted` samples, with `smaller` the sum of the weights of the
    /// set [`IrradianceShare::weigh_blocked`] names (in stratum order). Exactly 1 with none
    /// blocked and 0 with all; the area fraction where the weights cannot say (a light the
    /// point sees edge-on, where E is 0 and V multiplies nothing).
    pub fn visibility(&self, counted: u32, blocked: u32, smaller: f64) -> f32 {
        if blocked == 0 || counted == 0 {
            return 1.0;
        }
        if blocked >= counted {
            return 0.0;
        }
        // The shading's own G where the query brings it (four arc tangents saved per
        // penumbra point: 2% of `silhouette` on the default scene).
        let total = match self.given {
            g if g > 0.0 => g as f64,
            _ => self.light.irradiance_factor_f64(self.p, self.n),
        };
        let share = self.sample_area * smaller / total;
        let v = if Self::weigh_blocked(counted, blocked) { 1.0 - share } else { share };
        if total > 0.0 && v.is_finite() {
            v.clamp(0.0, 1.0) as f32
        } else {
            (counted - blocked) as f32 / counted as f32
        }
    }
}

impl IrradianceShare {
    /// V from bit words over a point's samples, `(counted, unblocked)` per word (bit k of
    /// word w: sample 64 w + k), the smaller set weighed by `weight(k)` in sample order: for
    /// methods that settle every sample before weighing any (`silhouette`, the exact
    /// `edge_table`, `pcss`).
    #[inline]
    pub fn visibility_from_bits(
        &self,
        words: impl Iterator<Item = (u64, u64)> + Clone,
        mut weight: impl FnMut(usize) -> f64,
    ) -> f32 {
        let (mut counted, mut visible) = (0u32, 0u32);
        for (c, open) in words.clone() {
            counted += c.count_ones();
            visible += (c & open).count_ones();
        }
        let blocked = counted - visible;
        let mut smaller = 0.0;
        if blocked != 0 && visible != 0 {
            let weigh_blocked = Self::weigh_blocked(counted, blocked);
            for (w, (c, open)) in words.enumerate() {
                let mut set = if weigh_blocked { c & !open } else { c & open };
                while set != 0 {
                    smaller += weight(64 * w + set.trailing_zeros() as usize);
                    set &= set - 1;
                }
            }
        }
        self.visibility(counted, blocked, smaller)
    }
}

/// Verdicts counted and weighed as they come, for a method that learns every sample's
/// verdict in stratum order (`traced`): both sets are summed, the smaller one is used.
#[derive(Debug, Default, Clone, Copy)]
pub struct ShareTally {
    pub counted: u32,
    pub blocked: u32,
    weight_blocked: f64,
    weight_visible: f64,
}

impl ShareTally {
    #[inline]
    pub fn add(&mut self, weight: f64, blocked: bool) {
        self.counted += 1;
        if blocked {
            self.blocked += 1;
            self.weight_blocked += weight;
        } else {
            self.weight_visible += weight;
        }
    }

    /// V (see [`IrradianceShare::visibility`]).
    pub fn visibility(&self, share: &IrradianceShare) -> f32 {
        let smaller = if IrradianceShare::weigh_blocked(self.counted, self.blocked) {
            self.weight_blocked
        } else {
            self.weight_visible
        };
        share.visibility(self.counted, self.blocked, smaller)
    }
}
