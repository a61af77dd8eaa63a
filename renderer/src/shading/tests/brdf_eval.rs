//! The f32 BRDF against the specification written once more in f64 (`quadrature`), and its
//! symmetries; the white furnace's expectation against closed forms.

use crate::shading::brdf::{GltfBrdf, ggx_d, schlick_weight, smith_visibility};
use crate::shading::quadrature::{brdf_parts_f64, directional_albedo, ggx_d_f64, smith_visibility_f64};
use crate::util::random::Rng;
use glam::{DVec3, Vec3};

/// A unit direction above the surface, about uniform in solid angle, sometimes near grazing.
pub(super) fn random_direction(rng: &mut Rng) -> Vec3 {
    let z = if rng.next_f32() < 0.2 { 0.02 * rng.next_f32() + 1e-4 } else { rng.next_f32().max(1e-4) };
    let phi = std::f32::consts::TAU * rng.next_f32();
    let r = (1.0 - z * z).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub(super) fn materials() -> Vec<GltfBrdf> {
    let mut out = Vec::new();
    for base_color in [Vec3::new(0.9, 0.6, 0.3), Vec3::ONE, Vec3::new(0.0, 0.2, 1.0)] {
        for metallic in [0.0, 0.3, 1.0] {
            for roughness in [0.0, 0.02, 0.05, 0.3, 0.7, 1.0] {
                out.push(GltfBrdf { base_color, metallic, roughness });
            }
        }
    }
    out
}

fn close(a: Vec3, b: DVec3, rel: f64) -> bool {
    (a.as_dvec3() - b).abs().max_element() <= rel * b.abs().max_element() + 1e-9
}

#[test]
fn eval_matches_the_specifications_mix() {
    // f32 folded Schlick form against the f64 mix(dielectric, metal, metallic): relative 1e-4
    // covers f32 rounding, D's peak of up to 2e6 included.
    let mut rng = Rng::new(1);
    for brdf in materials() {
        for _ in 0..2000 {
            let (wo, wi) = (random_direction(&mut rng), random_direction(&mut rng));
            let f = brdf.eval(wo, wi);
            // The reference at the unit vectors nearest the f32 inputs: for nearly opposite
            // grazing pairs 1 + wo·wi is tiny, and the inputs' own rounding off unit length
            // (6e-8) would move it by 3e-4 relative.
            let (wo64, wi64) = (wo.as_dvec3().normalize(), wi.as_dvec3().normalize());
            let (diffuse, spec_over_d, d) = brdf_parts_f64(&brdf, wo64, wi64);
            assert!(close(f.diffuse, diffuse, 1e-4), "{brdf:?} {wo} {wi}: {} vs {diffuse}", f.diffuse);
            assert!(
                close(f.specular, spec_over_d * d, 1e-4),
                "{brdf:?} {wo} {wi}: {} vs {}",
                f.specular,
                spec_over_d * d
            );
        }
    }
}

#[test]
fn terms_match_their_f64_forms() {
    // V from Smith's Λ (G2 = 1/(1 + Λl + Λv)) against the closed form the f32 code uses.
    let mut rng = Rng::new(2);
    for _ in 0..20000 {
        let alpha = (0.02 + 0.98 * rng.next_f32()).powi(2);
        let (c1, c2) = (rng.next_f32().max(1e-3), rng.next_f32().max(1e-3));
        let d = ggx_d(alpha, c1) as f64;
        let d64 = ggx_d_f64(alpha as f64, c1 as f64);
        assert!((d - d64).abs() <= 1e-4 * d64, "D({alpha}, {c1}) = {d} vs {d64}");
        let v = smith_visibility(alpha, c1, c2) as f64;
        let v64 = smith_visibility_f64(alpha as f64, c1 as f64, c2 as f64);
        assert!((v - v64).abs() <= 1e-4 * v64, "V({alpha}, {c1}, {c2}) = {v} vs {v64}");
    }
    assert_eq!(ggx_d(0.5, 0.0), 0.0);
    assert_eq!(smith_visibility(0.5, 0.0, 0.5), 0.0);
    assert_eq!(schlick_weight(1.0), 0.0);
    assert_eq!(schlick_weight(0.0), 1.0);
    assert!((schlick_weight(0.5) - 0.03125).abs() < 1e-9);
}

#[test]
fn eval_is_reciprocal_non_negative_and_zero_below_the_surface() {
    let mut rng = Rng::new(3);
    for brdf in materials() {
        for _ in 0..2000 {
            let (wo, wi) = (random_direction(&mut rng), random_direction(&mut rng));
            let (a, b) = (brdf.eval(wo, wi), brdf.eval(wi, wo));
            // Equal up to the rounding of wo·h against wi·h (the same value in exact arithmetic).
            assert!(close(a.diffuse, b.diffuse.as_dvec3(), 1e-5), "{brdf:?} {wo} {wi}");
            assert!(close(a.specular, b.specular.as_dvec3(), 1e-5), "{brdf:?} {wo} {wi}");
            assert!(a.diffuse.min_element() >= 0.0 && a.specular.min_element() >= 0.0);
            let below = wi * Vec3::new(1.0, 1.0, -1.0);
            assert_eq!(brdf.eval(wo, below).total(), Vec3::ZERO);
            assert_eq!(brdf.eval(below, wo).total(), Vec3::ZERO);
            assert_eq!(brdf.pdf(wo, below), 0.0);
            assert!(brdf.sample(below, [0.5, 0.5, 0.5]).is_none());
        }
    }
}

#[test]
fn specular_tint_folds_the_mix_into_one_schlick_term() {
    // f0·(1 − s) + f90·s against the two Fresnel terms weighted as in Appendix B, for s in [0, 1].
    for brdf in materials() {
        let (f0, f90) = brdf.specular_tint();
        let m = brdf.metallic;
        for s in [0.0f32, 0.1, 0.5, 1.0] {
            let mixed = (1.0 - m) * Vec3::splat(0.04 + 0.96 * s)
                + m * (brdf.base_color + (1.0 - brdf.base_color) * s);
            let folded = f0 + (f90 - f0) * s;
            assert!((mixed - folded).abs().max_element() < 1e-6, "{brdf:?} s {s}: {mixed} vs {folded}");
        }
    }
}

/// 1D Simpson's rule with `n` (even) intervals.
fn simpson(a: f64, b: f64, n: usize, f: impl Fn(f64) -> f64) -> f64 {
    let h = (b - a) / n as f64;
    let inner: f64 = (1..n).map(|k| f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 }).sum();
    (f(a) + f(b) + inner) * h / 3.0
}

#[test]
fn furnace_expectation_matches_closed_forms() {
    let white = |metallic, roughness| GltfBrdf { base_color: Vec3::ONE, metallic, roughness };
    // Roughness 1 (α = 1), seen head-on: D = 1/π, V = 0.5/(1 + n·l), so a white metal reflects
    // ∫0^1 c/(1 + c) dc = 1 − ln 2 (single scattering keeps 31% of the light).
    let metal = directional_albedo(&white(1.0, 1.0), 1.0).as_dvec3();
    assert!((metal - DVec3::splat(1.0 - 2f64.ln())).abs().max_element() < 1e-5, "{metal}");
    // The dielectric at α = 1, head-on: |wo·h| = cos(θ/2) = √((1 + c)/2), s = (1 − that)^5;
    // albedo = ∫0^1 [(0.04 + 0.96 s)·c/(1 + c) + 1.92 (1 − s) c] dc (specular + diffuse).
    let s = |c: f64| (1.0 - ((1.0 + c) / 2.0).sqrt()).powi(5);
    let exact = simpson(0.0, 1.0, 2000, |c| (0.04 + 0.96 * s(c)) * c / (1.0 + c) + 1.92 * (1.0 - s(c)) * c);
    let dielectric = directional_albedo(&white(0.0, 1.0), 1.0).as_dvec3();
    assert!((dielectric - DVec3::splat(exact)).abs().max_element() < 1e-5, "{dielectric} vs {exact}");
    // Smooth and white, the metal loses almost nothing.
    let smooth = directional_albedo(&white(1.0, 0.0), 1.0);
    assert!(smooth.min_element() > 0.9999 && smooth.max_element() < 1.0 + 1e-5, "{smooth}");
}

#[test]
fn furnace_expectation_of_a_white_metal_stays_below_one_and_falls_with_roughness() {
    for cos_v in [1.0, 0.7, 0.2, 0.05] {
        let mut previous = f32::INFINITY;
        for roughness in [0.05, 0.2, 0.4, 0.6, 0.8, 1.0] {
            let a = directional_albedo(&GltfBrdf { base_color: Vec3::ONE, metallic: 1.0, roughness }, cos_v);
            assert!(a.max_element() <= 1.0 + 1e-5 && a.min_element() > 0.0, "cos {cos_v}, {roughness}: {a}");
            if cos_v >= 0.2 {
                assert!(a.x < previous, "cos {cos_v}: {a} after {previous} at roughness {roughness}");
            }
            previous = a.x;
        }
    }
}

#[test]
fn furnace_expectation_of_a_white_dielectric_exceeds_one_at_grazing_views() {
    // Appendix B weights the diffuse part by 1 − F(wo·h): for most wi, h is far from grazing
    // and the weight stays near 0.96 even when the specular part reflects 60% of a grazing
    // view. A furnace must expect this gain, measured here (see `directional_albedo`).
    let white = |roughness, cos_v| {
        directional_albedo(&GltfBrdf { base_color: Vec3::ONE, metallic: 0.0, roughness }, cos_v).x
    };
    assert!((white(0.02, 1.0) - 1.0).abs() < 1e-3);
    assert!(white(0.02, 0.5) > 1.02 && white(0.02, 0.5) < 1.03);
    assert!(white(0.02, 0.1) > 1.5 && white(1.0, 0.1) < 1.0);
}
