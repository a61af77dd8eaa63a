//! The truth the f32 shading code is measured against: the glTF BRDF written once more in f64,
//! from the specification's own mix (not [`super::brdf`]'s folded Schlick term), and
//! deterministic quadrature rules over the hemisphere that resolve GGX lobes down to
//! [`ROUGHNESS_MIN`](super::brdf::ROUGHNESS_MIN).
//!
//! Used by [`directional_albedo`], by the LTC fitter (`examples/fit_ltc.rs`: its `norm` and
//! `fresnel`) and by the tests. Nothing here is meant for per-pixel use.
//!
//! The specular rule ([`for_each_reflected`]) integrates in the half vector's domain, where a
//! lobe of any width is smooth: h is placed by the inverse of the GGX distribution's own CDF, so
//! nodes crowd where D is large, and the φ range of each ring is cut exactly at the surface
//! (`wi.z = 0`), so the integrand has no jump inside the rule. It converges more slowly at
//! grazing views (cosθ_v <= 0.01: about 1e-4 relative at 1024 rings), where V·cos rises steeply
//! from the surface's edge.

use super::brdf::{DIELECTRIC_F0, GltfBrdf};
use glam::{DVec3, Vec3};
use std::f64::consts::{FRAC_1_PI, PI, TAU};

/// GGX D in f64, `cos_h = n·h`; zero for `cos_h <= 0`.
pub fn ggx_d_f64(alpha: f64, cos_h: f64) -> f64 {
    if cos_h <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = cos_h * cos_h * (a2 - 1.0) + 1.0;
    a2 / (PI * t * t)
}

/// The height-correlated Smith visibility G2/(4 n·l n·v) in f64, from Λ:
/// `G2 = 1/(1 + Λ(l) + Λ(v))`, `Λ(w) = (√(1 + α² tan²θ) − 1)/2`.
pub fn smith_visibility_f64(alpha: f64, n_dot_l: f64, n_dot_v: f64) -> f64 {
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 {
        return 0.0;
    }
    let g2 = 1.0 / (1.0 + smith_lambda_f64(alpha, n_dot_l) + smith_lambda_f64(alpha, n_dot_v));
    g2 / (4.0 * n_dot_l * n_dot_v)
}

/// Smith's Λ for GGX at a direction with cosine `cos` > 0.
pub fn smith_lambda_f64(alpha: f64, cos: f64) -> f64 {
    let tan2 = (1.0 - cos * cos).max(0.0) / (cos * cos);
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// The BRDF, the specification's way: `mix(dielectric, metal, metallic)` with
/// dielectric = `(1 − F)·c/π + F·D·V`, `F = 0.04 + 0.96 s`, metal = `D·V·(c + (1 − c) s)`,
/// `s = (1 − |wo·h|)^5`. Returns `(diffuse, specular / D, D)`: the specular part without D, so
/// that [`for_each_reflected`], which carries D in its weights, can use it. Zero unless both
/// directions are above the surface.
pub fn brdf_parts_f64(brdf: &GltfBrdf, wo: DVec3, wi: DVec3) -> (DVec3, DVec3, f64) {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return (DVec3::ZERO, DVec3::ZERO, 0.0);
    }
    let r = (brdf.roughness as f64).clamp(super::brdf::ROUGHNESS_MIN as f64, 1.0);
    let alpha = r * r;
    let h = (wo + wi).normalize();
    let s = (1.0 - wo.dot(h).abs()).powi(5);
    let c = brdf.base_color.as_dvec3();
    let m = (brdf.metallic as f64).clamp(0.0, 1.0);
    let vis = smith_visibility_f64(alpha, wi.z, wo.z);
    let f_dielectric = DIELECTRIC_F0 as f64 + (1.0 - DIELECTRIC_F0 as f64) * s;
    let dielectric_diffuse = (1.0 - f_dielectric) * c * FRAC_1_PI;
    let dielectric_spec = DVec3::splat(f_dielectric * vis);
    let metal_spec = (c + (DVec3::ONE - c) * s) * vis;
    let diffuse = (1.0 - m) * dielectric_diffuse;
    let spec_over_d = (1.0 - m) * dielectric_spec + m * metal_spec;
    (diffuse, spec_over_d, ggx_d_f64(alpha, h.z))
}

/// Which reflected directions [`for_each_reflected`] covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// `wi.z > 0`: the BRDF's domain.
    Above,
    /// `wi.z <= 0` with `wo·h > 0`: where visible normals reflect `wo` below the surface.
    Below,
}

/// Nodes and weights for `∫ D(h) r(wi) dω_i`, h the half vector of `wo` and `wi`, over one
/// [`Side`]: calls `f(wi, h, weight)` with `Σ weight·r(wi) ≈ ∫ D(h) r(wi) dω_i`.
///
/// `wo = (√(1 − cos_v²), 0, cos_v)`. With dω_i = 4 (wo·h) dω_h and h drawn from D(h)·cosθ_h by
/// `tan²θ_h = α² u / (1 − u)`, the integral is `∫∫ r·4 (wo·h)/cosθ_h du dφ/2π`; substituting
/// `u = 1 − t²` removes the 1/cosθ_h singularity at the horizon, leaving the smooth factor
/// `2 √(t² + α²(1 − t²))`. Midpoint rule, `n_t` rings in t and `n_phi` nodes per ring over the
/// exact φ interval of the side.
pub fn for_each_reflected(
    alpha: f64,
    cos_v: f64,
    n_t: usize,
    n_phi: usize,
    side: Side,
    mut f: impl FnMut(DVec3, DVec3, f64),
) {
    let wo = DVec3::new((1.0 - cos_v * cos_v).max(0.0).sqrt(), 0.0, cos_v);
    let a2 = alpha * alpha;
    for it in 0..n_t {
        let t = (it as f64 + 0.5) / n_t as f64;
        let q = (t * t + a2 * (1.0 - t * t)).sqrt();
        let (cos_h, sin_h) = (t / q, alpha * (1.0 - t * t).sqrt() / q);
        // wo·h = a cosφ + b and wi.z = 2 cosθ_h (wo·h) − wo.z = 2 cosθ_h a cosφ + (2 cosθ_h b − wo.z).
        let (a, b) = (wo.x * sin_h, wo.z * cos_h);
        let phi_above = phi_limit(2.0 * cos_h * a, 2.0 * cos_h * b - wo.z);
        let (lo, hi) = match side {
            Side::Above => (0.0, phi_above),
            Side::Below => (phi_above, phi_limit(a, b)),
        };
        if hi <= lo {
            continue;
        }
        // Both halves ±[lo, hi] of the ring, n_phi nodes in all.
        let half_nodes = n_phi.div_ceil(2);
        let dphi = (hi - lo) / half_nodes as f64;
        let ring_weight = 8.0 * q / n_t as f64 * dphi / TAU;
        for ip in 0..half_nodes {
            let phi = lo + (ip as f64 + 0.5) * dphi;
            for phi in [phi, -phi] {
                let h = DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
                let wo_h = wo.dot(h);
                let wi = 2.0 * wo_h * h - wo;
                f(wi, h, ring_weight * wo_h);
            }
        }
    }
}

/// The φ in [0, π] below which `a cosφ + b > 0` (a ≥ 0): π if it holds everywhere, 0 if nowhere.
fn phi_limit(a: f64, b: f64) -> f64 {
    if a <= 1e-300 {
        return if b > 0.0 { PI } else { 0.0 };
    }
    (-b / a).clamp(-1.0, 1.0).acos()
}

/// `∫ g(wi)·wi.z dω_i` over the upper hemisphere for a smooth `g`, by the midpoint rule in
/// (sin²θ, φ), where the cosine-weighted measure is uniform: the integral is π × the mean.
pub fn cosine_integral(n: usize, mut g: impl FnMut(DVec3) -> DVec3) -> DVec3 {
    let mut sum = DVec3::ZERO;
    for iu in 0..n {
        let u = (iu as f64 + 0.5) / n as f64;
        let (sin_t, cos_t) = (u.sqrt(), (1.0 - u).sqrt());
        for ip in 0..n {
            let phi = TAU * (ip as f64 + 0.5) / n as f64;
            sum += g(DVec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t));
        }
    }
    sum * (PI / (n * n) as f64)
}

/// The directional albedo `∫ (diffuse + specular)(wo, wi)·wi.z dω_i` over the hemisphere, for
/// `wo` at `cos_theta_v` from the normal, by f64 quadrature (about 20 ms; not for per-pixel
/// use). Accurate to about 1e-5 relative, 1e-4 at grazing views (cosθ_v <= 0.01).
///
/// This is what a white furnace must return after one bounce: lit by a uniform environment of
/// radiance 1, a surface reflects exactly this radiance towards `wo`. It is not 1 for base
/// colour 1, either way:
/// - The glTF BRDF is single-scattering GGX: light the microsurface would reflect more than
///   once is lost, so a white metal reflects less than 1, the more so the rougher:
///   1 − ln 2 ≈ 0.307 at roughness 1 seen head-on (α = 1: D = 1/π, V = 0.5/(1 + n·l)).
/// - Appendix B weights the dielectric's diffuse part by 1 − F(wo·h), which stays near 0.96
///   for most `wi` even when the specular part reflects much of a grazing view: a white
///   dielectric reflects *more* than 1 there (1.0006 at cosθ_v = 0.7, 1.03 at 0.5, 1.55 at
///   0.1, roughness 0.02; 0.97 to 1.01 at roughness 1).
///
/// A path tracer's furnace test must compare against this, not 1.
pub fn directional_albedo(brdf: &GltfBrdf, cos_theta_v: f32) -> Vec3 {
    let cos_v = (cos_theta_v as f64).clamp(1e-6, 1.0);
    let wo = DVec3::new((1.0 - cos_v * cos_v).sqrt(), 0.0, cos_v);
    let alpha = brdf.alpha() as f64;
    let diffuse = cosine_integral(256, |wi| brdf_parts_f64(brdf, wo, wi).0);
    let mut specular = DVec3::ZERO;
    for_each_reflected(alpha, cos_v, 1024, 256, Side::Above, |wi, _, w| {
        specular += w * wi.z * brdf_parts_f64(brdf, wo, wi).1;
    });
    (diffuse + specular).as_vec3()
}

/// `(norm, fresnel)` of the specular lobe with F = 1 at `cos_v`: `∫ D·V·cos dω` and
/// `∫ (1 − wo·h)^5·D·V·cos dω` over the hemisphere, by [`for_each_reflected`] (`n` rings of `n`
/// nodes). The LTC table stores both.
pub fn specular_moments(alpha: f64, cos_v: f64, n: usize) -> (f64, f64) {
    let (mut norm, mut fresnel) = (0.0, 0.0);
    for_each_reflected(alpha, cos_v, n, n, Side::Above, |wi, h, w| {
        let term = w * wi.z * smith_visibility_f64(alpha, wi.z, cos_v);
        // wi·h = wo·h: h bisects them.
        let wo_h = wi.dot(h).clamp(0.0, 1.0);
        norm += term;
        fresnel += term * (1.0 - wo_h).powi(5);
    });
    (norm, fresnel)
}
