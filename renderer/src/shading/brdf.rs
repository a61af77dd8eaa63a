//! The glTF 2.0 metallic-roughness BRDF (the specification's Appendix B), evaluated and sampled
//! in f32 in the local shading frame: +z is the shading normal, every direction a unit vector
//! pointing away from the surface (`wo` towards the viewer, `wi` towards the light).
//!
//! Appendix B, term by term (α = roughness², h = normalize(wo + wi)):
//! - `D = α² / (π ((n·h)² (α² − 1) + 1)²)`, the GGX (Trowbridge-Reitz) distribution;
//! - `V = G2 / (4 n·l n·v)` with the height-correlated Smith G2, written out in
//!   [`smith_visibility`];
//! - dielectric = mix(baseColor/π, D·V, F) with `F = 0.04 + 0.96 (1 − |wo·h|)^5`;
//! - metal = D·V·(baseColor + (1 − baseColor)(1 − |wo·h|)^5);
//! - material = mix(dielectric, metal, metallic).
//!
//! [`BrdfValue`] keeps the two physical parts apart: `diffuse = (1 − metallic)(1 − F)·baseColor/π`
//! and `specular = (1 − metallic)·F·D·V + metallic·D·V·F_metal`. Schlick's form is linear in its
//! reflectance at normal incidence, so the specular part folds into one Schlick term with a
//! coloured `f0` ([`GltfBrdf::specular_tint`]), which is what [`GltfBrdf::eval`] computes.
//!
//! Sampling is a two-lobe mixture: cosine-weighted directions for the diffuse part, the GGX
//! distribution of visible normals for the specular part (drawn with Dupuy & Benyoub's spherical
//! caps, "Sampling Visible GGX Normals with Spherical Caps", HPG 2023, which draw the same density
//! as Heitz's 2018 JCGT method). [`GltfBrdf::pdf`] is that mixture's density, and
//! [`GltfBrdf::sample`] reports the weight against it, so MIS with light sampling can use either.

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, TAU};

/// The floor on the perceptual roughness before squaring it into α.
///
/// 0.02 gives α ≥ 4e-4 and α² ≥ 1.6e-7: the peak of D, 1/(π α²) ≈ 2e6, and D·V·cos/pdf in
/// [`GltfBrdf::sample`] stay finite and far from f32 overflow, while the lobe is already far
/// narrower than any light a scene holds (a half-angle of about α radians, 0.02°). Below it
/// the BRDF is a mirror in all but name, and f32 directions (about 6e-8 apart near the pole)
/// would start to quantise the lobe itself.
pub const ROUGHNESS_MIN: f32 = 0.02;

/// Reflectance at normal incidence of glTF's dielectric, IOR 1.5: ((1.5 − 1) / (1.5 + 1))².
pub const DIELECTRIC_F0: f32 = 0.04;

/// A glTF metallic-roughness material at one shading point (textures already applied).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GltfBrdf {
    /// Linear RGB base colour, each channel in [0, 1].
    pub base_color: Vec3,
    /// 0 dielectric, 1 metal; values outside [0, 1] are clamped.
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] (α = roughness², floored at [`ROUGHNESS_MIN`]).
    pub roughness: f32,
}

/// The BRDF value f (not multiplied by the cosine), split into its two physical parts.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BrdfValue {
    /// `(1 − metallic)(1 − F(wo·h))·baseColor/π`.
    pub diffuse: Vec3,
    /// `D·V·(f0 + (1 − f0)(1 − wo·h)^5)`, f0 from [`GltfBrdf::specular_tint`].
    pub specular: Vec3,
}

impl BrdfValue {
    /// `diffuse + specular`.
    pub fn total(&self) -> Vec3 {
        self.diffuse + self.specular
    }
}

/// One direction drawn by [`GltfBrdf::sample`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrdfSample {
    /// The sampled direction, unit, `wi.z > 0`.
    pub wi: Vec3,
    /// `(diffuse + specular)(wi)·wi.z / pdf`, the whole BRDF against the mixture density.
    pub weight: Vec3,
    /// [`GltfBrdf::pdf`] at `wi` (solid angle).
    pub pdf: f32,
    /// Whether the specular lobe drew it (the weight still covers both lobes).
    pub from_specular: bool,
}

impl GltfBrdf {
    /// α = max(roughness, [`ROUGHNESS_MIN`])², roughness clamped to at most 1.
    pub fn alpha(&self) -> f32 {
        alpha_of(self.roughness)
    }

    fn metallic01(&self) -> f32 {
        self.metallic.clamp(0.0, 1.0)
    }

    /// The specular lobe's Schlick colours `(f0, f90)`: `f0 = mix(0.04, baseColor, metallic)`,
    /// `f90 = 1`.
    ///
    /// Why one Schlick term holds both: with s = (1 − wo·h)^5, the specular part is
    /// `D·V·[(1 − m)(0.04 + 0.96 s) + m (c + (1 − c) s)]`. Collecting terms, the factor without s
    /// is `(1 − m) 0.04 + m c = f0`, and the factor of s is `(1 − m) 0.96 + m (1 − c) = 1 − f0`,
    /// so it is `D·V·(f0 + (f90 − f0) s)` with f90 = 1. Integrated against any region this
    /// gives `f0·∫D·V·cos + (f90 − f0)·∫s·D·V·cos`, the split [`crate::shading::ltc`] tabulates.
    pub fn specular_tint(&self) -> (Vec3, Vec3) {
        let f0 = Vec3::splat(DIELECTRIC_F0).lerp(self.base_color, self.metallic01());
        (f0, Vec3::ONE)
    }

    /// The BRDF f(wo, wi), both parts zero unless `wo.z > 0` and `wi.z > 0`.
    ///
    /// Preconditions: `wo`, `wi` unit vectors in the shading frame. Symmetric in its arguments.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> BrdfValue {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return BrdfValue::default();
        }
        // Unnormalised half vector: its z > 0, and D is computed from its components without
        // the cancellation 1 − cos² would suffer near the lobe's peak. For unit wo, wi,
        // wo·h = (1 + wo·wi)/|wo + wi| = |wo + wi|/2: symmetric in wo and wi (reciprocity to
        // the last bit) and free of the cancellation in 1 + wo·wi when they nearly oppose.
        let half = wo + wi;
        let v_dot_h = (0.5 * half.length()).min(1.0);
        let s = schlick_weight(v_dot_h);
        let alpha = self.alpha();
        let dv = ggx_d_half(alpha, half) * smith_visibility(alpha, wi.z, wo.z);
        let (f0, f90) = self.specular_tint();
        let specular = (f0 + (f90 - f0) * s) * dv;
        let dielectric_f = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * s;
        let diffuse = self.base_color * ((1.0 - self.metallic01()) * (1.0 - dielectric_f) * FRAC_1_PI);
        BrdfValue { diffuse, specular }
    }

    /// The probability with which [`GltfBrdf::sample`] picks the specular lobe at `wo`.
    ///
    /// The two lobes' reflectances, estimated cheaply from `wo` alone and averaged over RGB:
    /// specular ≈ Schlick's F at `wo.z` with the coloured f0 (the Fresnel that sets how much
    /// the specular lobe reflects), diffuse ≈ `(1 − metallic)·0.96·baseColor` (its Fresnel
    /// factor is taken at h, mostly far from grazing, so `wo`'s own Fresnel would starve the
    /// diffuse lobe at grazing views). The probability is their ratio. It is 1 when the diffuse
    /// part is zero (a metal, a black dielectric) and never 0, since f90 = 1 makes the specular
    /// part nonzero wherever the diffuse one is; so each lobe is sampled wherever it is nonzero.
    pub fn specular_probability(&self, wo: Vec3) -> f32 {
        let (f0, f90) = self.specular_tint();
        let fresnel = f0 + (f90 - f0) * schlick_weight(wo.z.clamp(0.0, 1.0));
        let specular = fresnel.element_sum() / 3.0;
        let diffuse =
            (1.0 - self.metallic01()) * (1.0 - DIELECTRIC_F0) * self.base_color.max(Vec3::ZERO).element_sum()
                / 3.0;
        if diffuse <= 0.0 { 1.0 } else { specular / (specular + diffuse) }
    }

    /// The solid-angle density of the directions [`GltfBrdf::sample`] draws, over `wi.z > 0`:
    /// `P_s·D_v(h)/(4 wo·h) + (1 − P_s)·wi.z/π` with `P_s` from
    /// [`GltfBrdf::specular_probability`] and `D_v(h) = G1(wo)·(wo·h)·D(h)/wo.z` the visible
    /// normals. Zero unless `wo.z > 0` and `wi.z > 0`.
    ///
    /// It integrates to less than 1 over the upper hemisphere: the visible normal can reflect
    /// `wo` below the surface, and [`GltfBrdf::sample`] then returns `None`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p_spec = self.specular_probability(wo);
        let alpha = self.alpha();
        // D_v/(4 wo·h) = G1(wo)·D/(4 wo.z); G1/(4 wo.z) written so that wo.z cancels.
        let lambda_term = (wo.z * wo.z * (1.0 - alpha * alpha) + alpha * alpha).sqrt();
        let specular = ggx_d_half(alpha, wo + wi) * 0.5 / (wo.z + lambda_term);
        p_spec * specular + (1.0 - p_spec) * wi.z * FRAC_1_PI
    }

    /// Draws `wi` from the mixture of [`GltfBrdf::pdf`]: `u[0]` picks the lobe (specular when
    /// below [`GltfBrdf::specular_probability`]), `u[1]`, `u[2]` the direction. `None` when
    /// `wo.z <= 0` or the drawn direction is not above the surface (the visible normal
    /// reflected `wo` downwards: the sample carries no energy, counted as weight 0).
    ///
    /// Preconditions: `wo` unit, each `u` in [0, 1).
    pub fn sample(&self, wo: Vec3, u: [f32; 3]) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let from_specular = u[0] < self.specular_probability(wo);
        let wi = if from_specular {
            let h = sample_visible_normal(self.alpha(), wo, u[1], u[2])?;
            2.0 * wo.dot(h) * h - wo
        } else {
            cosine_direction(u[1], u[2])
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        let weight = self.eval(wo, wi).total() * (wi.z / pdf);
        Some(BrdfSample { wi, weight, pdf, from_specular })
    }
}

/// GGX alpha of perceptual `roughness`: max(roughness, [`ROUGHNESS_MIN`])^2, roughness
/// clamped to at most 1.
pub fn alpha_of(roughness: f32) -> f32 {
    let r = roughness.clamp(ROUGHNESS_MIN, 1.0);
    r * r
}

/// The GGX normal distribution `D = α² / (π (cos²θ_h (α² − 1) + 1)²)` for `cos_h = n·h > 0`,
/// zero otherwise.
pub fn ggx_d(alpha: f32, cos_h: f32) -> f32 {
    if cos_h <= 0.0 {
        return 0.0;
    }
    let cos2 = (cos_h * cos_h).min(1.0);
    // (1 − c)(1 + c) rather than 1 − c²: same value, one rounding less near the peak.
    let sin2 = ((1.0 - cos_h) * (1.0 + cos_h)).max(0.0);
    d_from_components(alpha, sin2, cos2)
}

/// D from an unnormalised half vector `half` (z > 0): with cos² = z²/|half|² and
/// sin² = (x² + y²)/|half|², D = α²|half|⁴ / (π (x² + y² + α² z²)²).
fn ggx_d_half(alpha: f32, half: Vec3) -> f32 {
    if half.z <= 0.0 {
        return 0.0;
    }
    let len2 = half.length_squared();
    d_from_components(alpha, (half.x * half.x + half.y * half.y) / len2, half.z * half.z / len2)
}

fn d_from_components(alpha: f32, sin2: f32, cos2: f32) -> f32 {
    let a2 = alpha * alpha;
    let denom = sin2 + a2 * cos2;
    a2 * FRAC_1_PI / (denom * denom)
}

/// The height-correlated Smith visibility `V = G2 / (4 n·l n·v)`:
/// `0.5 / (n·l √((n·v)²(1 − α²) + α²) + n·v √((n·l)²(1 − α²) + α²))`, zero when either cosine is
/// not positive.
pub fn smith_visibility(alpha: f32, n_dot_l: f32, n_dot_v: f32) -> f32 {
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let gv = n_dot_l * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt();
    let gl = n_dot_v * (n_dot_l * n_dot_l * (1.0 - a2) + a2).sqrt();
    0.5 / (gv + gl)
}

/// Schlick's Fresnel weight `(1 − cos)^5`, cos clamped to [0, 1].
pub fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// A visible GGX normal for `wo` (Dupuy & Benyoub 2023): stretch `wo` into the configuration
/// where the microsurface is a unit hemisphere, where the visible normals are
/// `normalize(v + c)` with `c` uniform on the spherical cap `c.z ≥ −v.z`, then unstretch the
/// normal. `None` only when the sum `v + c` vanishes (u2 → 1 at one φ).
fn sample_visible_normal(alpha: f32, wo: Vec3, u1: f32, u2: f32) -> Option<Vec3> {
    let v = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let phi = TAU * u1;
    let z = (1.0 - u2) * (1.0 + v.z) - v.z;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let h = Vec3::new(r * phi.cos(), r * phi.sin(), z) + v;
    let h = Vec3::new(alpha * h.x, alpha * h.y, h.z.max(0.0)).normalize_or_zero();
    (h.z > 0.0).then_some(h)
}

/// A cosine-distributed direction about +z (density wi.z/π), `u` in [0, 1).
fn cosine_direction(u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = TAU * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt())
}
