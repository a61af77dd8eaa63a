//! What a glossy surface weighs the light's points by, for the shadow methods: the GGX
//! specular lobe of the glTF BRDF at one shading point ([`crate::shading::brdf`]), with
//! Fresnel left out (F = 1: its colour multiplies the unshadowed integral, not the share),
//! and its Linearly Transformed Cosine fit ([`crate::shading::ltc`]) for the methods that
//! integrate it in closed form.
//!
//! A query for a glossy surface asks two shares of one light from one set of verdicts
//! ([`crate::LightShadowing::visibility_glossy`]): V, the share of irradiance (the diffuse
//! part), and the lobe's share,
//!
//! ```text
//! V_glossy = integral over the visible light of g f_s / integral over the light of g f_s,
//! ```
//!
//! with g = cos(theta_x) cos(theta_y) / r^2 and f_s = D(h) Vis(wi, wo). A method with samples
//! takes the plain ratio of its weighted sums (Heitz, Hill, Neubelt 2018): an umbra is
//! exactly 0 and a lit point exactly 1 whatever the lobe. `analytic` integrates the LTC fit
//! of g f_s over its exact visible region: exact visibility, the fit's error in the lobe's
//! shape only (the contract, "Conventions").

use crate::shading::brdf::{ggx_d, smith_visibility};
use crate::shading::ltc::{LtcLobe, ltc_lobe};
use glam::{DMat3, DVec3, Vec3};

/// The glossy lobe of one shading point. `Copy`, a few words: built once per point and
/// passed by reference to every light's query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlossyLobe {
    /// World to the lobe's frame, by rows: x in the plane of `wo` and the normal (toward
    /// `wo`), y, z the shading normal (the LTC tables' convention).
    pub frame: [Vec3; 3],
    /// The direction toward the viewer, in that frame: (sin theta, 0, cos theta).
    pub wo: Vec3,
    /// GGX alpha (perceptual roughness squared).
    pub alpha: f32,
    /// The LTC fit of D Vis cos in that frame.
    pub ltc: LtcLobe,
}

impl GlossyLobe {
    /// The lobe of a surface of perceptual roughness `roughness` with shading normal `n`,
    /// seen from `wo` (unit, world, on `n`'s side). None where `wo` lies in the shading
    /// plane or under it (the lobe is empty there).
    pub fn new(n: Vec3, wo: Vec3, roughness: f32) -> Option<Self> {
        let frame = lobe_frame(n, wo)?;
        let local_wo = Vec3::new(frame[0].dot(wo).max(0.0), 0.0, n.dot(wo).min(1.0));
        let alpha = crate::shading::brdf::alpha_of(roughness);
        Some(Self { frame, wo: local_wo, alpha, ltc: ltc_lobe(roughness, local_wo.z) })
    }

    /// `w` (world) in the lobe's frame.
    #[inline(always)]
    pub fn to_local(&self, w: Vec3) -> Vec3 {
        Vec3::new(self.frame[0].dot(w), self.frame[1].dot(w), self.frame[2].dot(w))
    }

    /// [`GlossyLobe::to_local`] in f64: for vectors to a light's corners, whose differences
    /// (the light's size) f32 could round away beside their length.
    pub fn to_local_f64(&self, w: DVec3) -> DVec3 {
        let f = self.frame.map(|a| a.as_dvec3());
        DVec3::new(f[0].dot(w), f[1].dot(w), f[2].dot(w))
    }

    /// The factor the lobe puts on g at the light point `w` away from the shading point
    /// (world, any length): D(h) Vis(wi, wo), 0 under the shading horizon.
    #[inline]
    pub fn factor(&self, w: Vec3) -> f32 {
        let l = self.to_local(w).normalize_or_zero();
        if l.z <= 0.0 {
            return 0.0;
        }
        let h = (l + self.wo).normalize_or_zero();
        ggx_d(self.alpha, h.z) * smith_visibility(self.alpha, l.z, self.wo.z)
    }

    /// The matrix taking world vectors to the LTC's clamped-cosine space: M^-1 times the
    /// frame. Lambert's formula on a region's corners so mapped integrates the fit over it.
    pub fn world_to_cosine(&self) -> DMat3 {
        let [x, y, z] = self.frame.map(|r| r.as_dvec3());
        // Rows x, y, z: the columns of the transpose.
        self.ltc.minv * DMat3::from_cols(x, y, z).transpose()
    }
}

/// The frame of a lobe about the unit normal `n` seen from `wo` (unit, world), by rows: x in
/// the plane of `wo` and `n` (toward `wo`), y = n x x, z = n (the LTC tables' convention).
/// None where `wo` lies in the plane of `n` or under it.
pub fn lobe_frame(n: Vec3, wo: Vec3) -> Option<[Vec3; 3]> {
    let cos = n.dot(wo);
    if cos.is_nan() || cos <= 0.0 {
        return None;
    }
    // Seen along the normal the lobe is round: any x will do.
    let x = (wo - cos * n).try_normalize().unwrap_or_else(|| n.any_orthonormal_vector());
    Some([x, n.cross(x), n])
}

/// A glossy query's two answers ([`crate::LightShadowing::visibility_glossy`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LobeVisibility {
    /// V, the share of irradiance (what [`crate::LightShadowing::visibility`] answers).
    pub diffuse: f32,
    /// The lobe's share ([`GlossyLobe`]).
    pub glossy: f32,
}

impl LobeVisibility {
    /// Both shares `v`: a point wholly lit or wholly in umbra, or a method that weighs no lobe.
    pub fn both(v: f32) -> Self {
        Self { diffuse: v, glossy: v }
    }
}

/// A lobe's weighted sums over one point's light samples: all of them, and the visible ones.
/// Their ratio is the lobe's share (plain, so that an umbra is 0 and a lit point 1).
#[derive(Debug, Clone, Copy, Default)]
pub struct LobeTally {
    all: f64,
    visible: f64,
}

impl LobeTally {
    #[inline]
    pub fn add(&mut self, weight: f64, visible: bool) {
        self.all += weight;
        if visible {
            self.visible += weight;
        }
    }

    /// The lobe's share; `fallback` (the diffuse share) where no sample has weight (a lobe
    /// that misses the light: it multiplies nothing).
    pub fn share(&self, fallback: f32) -> f32 {
        if self.all > 0.0 && self.all.is_finite() {
            (self.visible / self.all).clamp(0.0, 1.0) as f32
        } else {
            fallback
        }
    }
}
