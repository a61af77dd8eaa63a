//! The quadrature rules themselves: against an unadapted grid where the lobe is broad, against
//! their own refinement, and the visible normals' total mass.

use crate::shading::quadrature::{
    Side, for_each_reflected, ggx_d_f64, smith_lambda_f64, smith_visibility_f64, specular_moments,
};
use glam::DVec3;
use std::f64::consts::{PI, TAU};

/// `∫ D·V·cos dω` on a plain midpoint grid in (θ, φ) of wi: fine for lobes wide against the
/// grid step, useless for narrow ones (which is why the half-vector rule exists).
fn plain_grid_norm(alpha: f64, cos_v: f64, n: usize) -> f64 {
    let wo = DVec3::new((1.0 - cos_v * cos_v).sqrt(), 0.0, cos_v);
    let (dt, dp) = (0.5 * PI / n as f64, TAU / (2 * n) as f64);
    let mut sum = 0.0;
    for i in 0..n {
        let theta = (i as f64 + 0.5) * dt;
        for k in 0..2 * n {
            let phi = (k as f64 + 0.5) * dp;
            let wi = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let h = (wo + wi).normalize();
            sum += ggx_d_f64(alpha, h.z) * smith_visibility_f64(alpha, wi.z, cos_v) * wi.z * theta.sin();
        }
    }
    sum * dt * dp
}

#[test]
fn half_vector_rule_matches_a_plain_grid_on_broad_lobes() {
    // Broad lobes only (α >= 0.25): there the plain grid's own error, measured by halving its
    // step, is below 1e-6.
    for r in [0.5, 0.8, 1.0] {
        for cos_v in [1.0, 0.7, 0.3] {
            let rule = specular_moments(r * r, cos_v, 512).0;
            let grid = plain_grid_norm(r * r, cos_v, 1500);
            assert!((rule - grid).abs() <= 2e-5 * grid, "r {r} cos {cos_v}: rule {rule}, grid {grid}");
        }
    }
}

#[test]
fn moments_converge_under_refinement() {
    // The fitter's 384 rings against 1536: the table's norm and fresnel are this close to
    // their limit (relative to norm). At grazing views (cos <= 0.01) V·cos rises steeply at
    // the surface's edge and the rule converges slowly and unevenly: 3.5e-4 measured there.
    for r in [0.02, 0.05, 0.3, 0.6, 1.0] {
        for (cos_v, tol) in [(1.0, 2e-5), (0.5, 2e-5), (0.1, 2e-5), (0.01, 1e-3), (1e-3, 1e-3)] {
            let (n1, f1) = specular_moments(r * r, cos_v, 384);
            let (n2, f2) = specular_moments(r * r, cos_v, 1536);
            assert!((n1 - n2).abs() <= tol * n2, "norm r {r} cos {cos_v}: {n1} vs {n2}");
            assert!((f1 - f2).abs() <= tol * n2, "fresnel r {r} cos {cos_v}: {f1} vs {f2}");
        }
    }
}

/// `∫ D_v(h)/(4 wo·h) dω_i` over one side, D_v(h) = G1(wo)·(wo·h)·D(h)/wo.z the visible normals.
pub(super) fn visible_normal_mass(alpha: f64, cos_v: f64, side: Side, n: usize) -> f64 {
    let g1_over_4 = 1.0 / (1.0 + smith_lambda_f64(alpha, cos_v)) / (4.0 * cos_v);
    let mut mass = 0.0;
    for_each_reflected(alpha, cos_v, n, n, side, |_, _, w| mass += w * g1_over_4);
    mass
}

#[test]
fn visible_normals_have_unit_mass_over_both_sides() {
    // D_v integrates to 1 over the normals facing wo; the rule's two sides split that mass at
    // the surface. Checks the rule's Jacobian and φ limits against Smith's G1 (both f64).
    for r in [0.02, 0.05, 0.3, 0.7, 1.0] {
        for cos_v in [1.0, 0.7, 0.2, 0.02] {
            let above = visible_normal_mass(r * r, cos_v, Side::Above, 512);
            let below = visible_normal_mass(r * r, cos_v, Side::Below, 512);
            assert!((above + below - 1.0).abs() < 2e-5, "r {r} cos {cos_v}: {above} + {below}");
        }
    }
}
