//! `sample()` against `pdf()` and the quadrature: where the directions land, the density's
//! mass, and the mean weight against the directional albedo.

use super::quadrature_rules::visible_normal_mass;
use crate::shading::brdf::GltfBrdf;
use crate::shading::quadrature::{Side, directional_albedo, for_each_reflected, ggx_d_f64, smith_lambda_f64};
use crate::util::random::Rng;
use glam::{DVec3, Vec3};
use std::f64::consts::{FRAC_1_PI, PI};

const VIEWS_DEG: [f32; 3] = [0.0, 45.0, 80.0];

fn wo_at(deg: f32) -> Vec3 {
    let t = deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

fn material(metallic: f32, roughness: f32) -> GltfBrdf {
    GltfBrdf { base_color: Vec3::new(0.9, 0.6, 0.3), metallic, roughness }
}

/// G1(wo)/(4 wo.z): the specular density is this × D(h).
fn g1_over_4cos(alpha: f64, cos_v: f64) -> f64 {
    1.0 / (1.0 + smith_lambda_f64(alpha, cos_v)) / (4.0 * cos_v)
}

/// A 16 × 16 histogram bin of a half vector in the rule's coordinates (t uniform, so a lobe of
/// any width spreads over the bins): t² = α²cos²/(sin² + α²cos²), φ_h.
fn half_vector_bin(alpha: f64, h: DVec3) -> usize {
    let (c2, s2) = (h.z * h.z, h.x * h.x + h.y * h.y);
    let t = (alpha * alpha * c2 / (s2 + alpha * alpha * c2)).sqrt();
    let phi = (h.y.atan2(h.x) + PI) / (2.0 * PI);
    ((t * 16.0) as usize).min(15) * 16 + ((phi * 16.0) as usize).min(15)
}

/// A 16 × 16 bin of a direction in (sin²θ, φ), where the cosine lobe is uniform.
fn direction_bin(w: DVec3) -> usize {
    let u = 1.0 - w.z * w.z;
    let phi = (w.y.atan2(w.x) + PI) / (2.0 * PI);
    ((u * 16.0) as usize).min(15) * 16 + ((phi * 16.0) as usize).min(15)
}

/// Draws `n` samples and compares the histogram (and the share of `None`) with `expected`
/// (per bin, then `None` last): each within 5 standard deviations of a binomial count plus
/// `slack` for the quadrature of the expectation.
fn check_histogram(brdf: &GltfBrdf, wo: Vec3, bin: impl Fn(Vec3) -> usize, expected: &[f64], n: usize) {
    let mut rng = Rng::new(11);
    let mut counts = vec![0usize; expected.len()];
    for _ in 0..n {
        let u = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
        match brdf.sample(wo, u) {
            Some(s) => {
                assert_eq!(s.pdf, brdf.pdf(wo, s.wi), "the sample reports pdf(wo, wi)");
                counts[bin(s.wi)] += 1;
            }
            None => *counts.last_mut().unwrap() += 1,
        }
    }
    let slack = 1e-4;
    for (k, (&c, &p)) in counts.iter().zip(expected).enumerate() {
        let observed = c as f64 / n as f64;
        let sigma = (p * (1.0 - p) / n as f64).sqrt();
        assert!(
            (observed - p).abs() <= 5.0 * sigma + slack,
            "{brdf:?} wo {wo}: bin {k} observed {observed}, expected {p}"
        );
    }
    assert!(
        (expected.iter().sum::<f64>() - 1.0).abs() < 1e-4,
        "expected bins sum to {}",
        expected.iter().sum::<f64>()
    );
}

#[test]
fn metal_samples_follow_the_visible_normals() {
    // A metal samples the specular lobe only: histogram of h against ∫_bin D_v(h)/(4 wo·h) dω
    // by the half-vector rule, and None as often as visible normals reflect wo downwards.
    for roughness in [0.05f32, 0.3, 1.0] {
        for deg in VIEWS_DEG {
            let brdf = material(1.0, roughness);
            let (alpha, wo) = (brdf.alpha() as f64, wo_at(deg));
            let cos_v = wo.z as f64;
            let mut expected = vec![0.0; 257];
            let scale = g1_over_4cos(alpha, cos_v);
            for_each_reflected(alpha, cos_v, 1024, 1024, Side::Above, |_, h, w| {
                expected[half_vector_bin(alpha, h)] += w * scale;
            });
            expected[256] = visible_normal_mass(alpha, cos_v, Side::Below, 1024);
            let bin = |wi: Vec3| half_vector_bin(alpha, (wo + wi).as_dvec3().normalize());
            check_histogram(&brdf, wo, bin, &expected, 200_000);
        }
    }
}

#[test]
fn dielectric_samples_follow_the_mixture() {
    // Histogram of wi against (1 − P_s)·(cosine lobe, uniform over these bins) + P_s·(specular
    // lobe by the rule), None with probability P_s·(visible normals reflected downwards).
    for roughness in [0.05f32, 0.3, 1.0] {
        for deg in VIEWS_DEG {
            let brdf = material(0.0, roughness);
            let (alpha, wo) = (brdf.alpha() as f64, wo_at(deg));
            let cos_v = wo.z as f64;
            let p_spec = brdf.specular_probability(wo) as f64;
            let mut expected = vec![(1.0 - p_spec) / 256.0; 257];
            let scale = p_spec * g1_over_4cos(alpha, cos_v);
            for_each_reflected(alpha, cos_v, 1024, 1024, Side::Above, |wi, _, w| {
                expected[direction_bin(wi)] += w * scale;
            });
            expected[256] = p_spec * visible_normal_mass(alpha, cos_v, Side::Below, 1024);
            check_histogram(&brdf, wo, |wi| direction_bin(wi.as_dvec3()), &expected, 200_000);
        }
    }
}

#[test]
fn pdf_integrates_to_one_less_the_mass_reflected_below() {
    // ∫ pdf over the hemisphere: its diffuse share (1 − P_s) is exact, the rest is integrated
    // by the half-vector rule from pdf() itself (f32), then compared with 1 − P_s·P_below.
    for metallic in [0.0f32, 1.0] {
        for roughness in [0.05f32, 0.3, 0.7, 1.0] {
            for deg in VIEWS_DEG {
                let brdf = material(metallic, roughness);
                let (alpha, wo) = (brdf.alpha() as f64, wo_at(deg));
                let cos_v = wo.z as f64;
                let p_spec = brdf.specular_probability(wo) as f64;
                let mut specular = 0.0;
                for_each_reflected(alpha, cos_v, 1024, 512, Side::Above, |wi, h, w| {
                    let pdf = brdf.pdf(wo, wi.as_vec3()) as f64 - (1.0 - p_spec) * wi.z * FRAC_1_PI;
                    specular += w * pdf / ggx_d_f64(alpha, h.z);
                });
                let total = specular + (1.0 - p_spec);
                let expected = 1.0 - p_spec * visible_normal_mass(alpha, cos_v, Side::Below, 1024);
                assert!((total - expected).abs() < 2e-4, "{brdf:?} at {deg} deg: {total} vs {expected}");
            }
        }
    }
}

#[test]
fn mean_weight_is_the_directional_albedo() {
    // E[weight] over 2^18 samples (None counting 0) against the f64 quadrature: within 5
    // standard errors of the mean, plus 1e-4 relative for the quadrature and f32 sums.
    let n = 1 << 18;
    let mut worst: f64 = 0.0;
    for metallic in [0.0f32, 1.0] {
        for roughness in [0.05f32, 0.3, 0.7, 1.0] {
            for deg in VIEWS_DEG {
                let brdf = material(metallic, roughness);
                let wo = wo_at(deg);
                let truth = directional_albedo(&brdf, wo.z).as_dvec3();
                let mut rng = Rng::new(5);
                let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
                for _ in 0..n {
                    let u = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
                    let w = brdf.sample(wo, u).map_or(DVec3::ZERO, |s| s.weight.as_dvec3());
                    sum += w;
                    sum2 += w * w;
                }
                let mean = sum / n as f64;
                let std_err = ((sum2 / n as f64 - mean * mean).max(DVec3::ZERO) / n as f64).powf(0.5);
                let err = (mean - truth).abs();
                let limit = 5.0 * std_err + 1e-4 * truth;
                assert!(
                    err.cmple(limit).all(),
                    "{brdf:?} at {deg} deg: mean {mean}, albedo {truth}, limit {limit}"
                );
                worst = worst.max((err / limit).max_element());
            }
        }
    }
    eprintln!("mean weight against the albedo: worst |error| / limit = {worst:.2}");
}
