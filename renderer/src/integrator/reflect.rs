//! Light the rectangles send toward `wo` off a surface shaded by the glTF BRDF
//! (`[materials] shading = "gltf"`, [`crate::shading::brdf`]), at any path vertex.
//!
//! Per light, two parts, each with its own shadow term from one query of the light's method
//! ([`crate::LightShadowing::visibility_glossy`]):
//!
//! ```text
//! L ( k_d E V + S V_glossy ),    S = f0 I + (f90 - f0) I_F
//! ```
//!
//! - The diffuse part: `k_d = (1 - metallic) base / pi (1 - F)`, E the exact irradiance and V
//!   the share of it that arrives. Appendix B's `1 - F` depends on the half vector; it is
//!   taken at the light's centre (it stays within 0.96-0.90 but at grazing angles).
//! - The specular part: S, the unshadowed integral of D Vis F cos over the light, Schlick's
//!   Fresnel split into the lobe's two moments over the light (`I` of D Vis cos, `I_F` of
//!   (1 - wo.h)^5 D Vis cos), each by quadrature of the true lobe with nodes placed by its LTC
//!   fit ([`crate::shading::lobe_integral`]: within 0.2% of brute force where the fit alone
//!   is off by up to 7.7%), times the lobe's share ([`crate::interface::lobe`]). The fit
//!   still gives the share's shape for `analytic` (a ratio: the fit's error largely cancels).
//!
//! A lobe sharper than [`LTC_ROUGHNESS_MIN`] is not fitted well (the fit's tests start
//! there); its light comes from BSDF samples that hit the light instead (the path's
//! [`crate::integrator::path`]): the two strategies split the lobes, not the directions, a
//! valid multiple importance sampling (weights of 1 and 0 per lobe: they sum to 1 for every
//! direction).

use crate::geometry::light::RectLight;
use crate::geometry::point::ShadingPoint;
use crate::geometry::surface::Surface;
use crate::integrator::path::{PathContext, PathId, VertexQueries, shadow_query};
use crate::interface::lobe::GlossyLobe;
use crate::shading::brdf::{DIELECTRIC_F0, GltfBrdf, schlick_weight};
use crate::shading::lobe_integral::polygon_lobe_moments;
use glam::{DVec3, Vec3};

/// The roughness under which a specular lobe's direct light comes from BSDF samples, not
/// the LTC fit (see the module doc).
pub const LTC_ROUGHNESS_MIN: f32 = 0.05;

/// A surface's BRDF at one vertex, with what every light's term reads of it.
#[derive(Debug, Clone, Copy)]
pub struct Reflector {
    pub brdf: GltfBrdf,
    /// Toward where the path came from (unit, world, on the shading normal's side).
    pub wo: Vec3,
    pub n: Vec3,
    /// The specular lobe's fit, for a lobe at least [`LTC_ROUGHNESS_MIN`] rough.
    pub lobe: Option<GlossyLobe>,
}

impl Reflector {
    pub fn new(surface: &Surface, n: Vec3, wo: Vec3) -> Self {
        let brdf = GltfBrdf {
            base_color: surface.base_color,
            metallic: surface.metallic,
            roughness: surface.roughness,
        };
        let lobe = if surface.roughness >= LTC_ROUGHNESS_MIN {
            GlossyLobe::new(n, wo, surface.roughness)
        } else {
            None
        };
        Self { brdf, wo, n, lobe }
    }

    /// Whether the specular lobe's light comes from BSDF samples that hit lights (a lobe too
    /// sharp for the fit).
    pub fn sharp(&self) -> bool {
        self.brdf.roughness < LTC_ROUGHNESS_MIN
    }

    /// `k_d` for `light` (see the module doc): the diffuse BRDF with its Fresnel loss toward
    /// the light's mean direction.
    fn diffuse_weight(&self, p: Vec3, light: &RectLight) -> Vec3 {
        let brdf = &self.brdf;
        let l = light.irradiance_direction(p, self.n);
        let h = (l + self.wo).normalize_or_zero();
        let f = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * schlick_weight(h.dot(self.wo).abs());
        (1.0 - brdf.metallic) * (1.0 - f) * std::f32::consts::FRAC_1_PI * brdf.base_color
    }

    /// S for `light` (see the module doc): the lobe's two moments over the light's corners
    /// in the lobe's frame, mixed by the Fresnel split's colours.
    fn specular_integral(&self, lobe: &GlossyLobe, p: Vec3, light: &RectLight) -> Vec3 {
        // Relative to p in f64: corners rounded to f32 about the camera can change a tiny
        // light's size.
        let corners: [DVec3; 4] = light.corners_from(p).map(|c| lobe.to_local_f64(c));
        let (moment, fresnel) =
            polygon_lobe_moments(&lobe.ltc, lobe.alpha as f64, lobe.wo.z as f64, &corners);
        let (f0, f90) = self.brdf.specular_tint();
        f0 * moment as f32 + (f90 - f0) * fresnel as f32
    }
}

/// The light every rectangle reflects off `point` toward `r.wo`, each light's part shadowed
/// by its method, at vertex `vertex` of path `id`; `seen(k, V)` hears each light's V.
pub fn direct(
    ctx: &PathContext,
    point: &ShadingPoint,
    r: &Reflector,
    (id, vertex): (&PathId, u32),
    stats: &mut [VertexQueries],
    mut seen: impl FnMut(usize, f32),
) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for (k, light) in ctx.scene.lights.iter().enumerate() {
        let e = light.irradiance_factor(point.p, r.n);
        if e <= 0.0 {
            continue;
        }
        let kd = r.diffuse_weight(point.p, light);
        match &r.lobe {
            Some(lobe) => {
                let s = r.specular_integral(lobe, point.p, light);
                let v = shadow_query(ctx, point, (id, k, vertex), e, Some(lobe), stats);
                seen(k, v.diffuse);
                sum += light.radiance * (kd * (e * v.diffuse) + s * v.glossy);
            }
            None => {
                let v = shadow_query(ctx, point, (id, k, vertex), e, None, stats);
                seen(k, v.diffuse);
                sum += light.radiance * kd * (e * v.diffuse);
            }
        }
    }
    sum
}
