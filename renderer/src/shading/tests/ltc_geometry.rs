//! Lambert's formula, the clipping and the LTC density, each against an independent
//! computation; the table's nodes against the quadrature that made them.

use super::ltc_accuracy::{Rect, rectangles};
use crate::shading::brdf::ROUGHNESS_MIN;
use crate::shading::ltc::{
    LTC_SIZE, LtcLobe, lambert_edge, ltc_grid_cos_theta, ltc_grid_roughness, ltc_lobe,
};
use crate::shading::quadrature::specular_moments;
use crate::util::random::Rng;
use glam::{DMat3, DVec3};
use std::f64::consts::{PI, TAU};

fn square(e: f64, z: f64) -> [DVec3; 4] {
    [DVec3::new(-e, -e, z), DVec3::new(e, -e, z), DVec3::new(e, e, z), DVec3::new(-e, e, z)]
}

fn loop_sum(v: &[DVec3]) -> f64 {
    (0..v.len()).map(|k| lambert_edge(v[k], v[(k + 1) % v.len()])).sum()
}

#[test]
fn lambert_edges_give_the_square_form_factor() {
    // The form factor of a square of half side e at height 1 centred above the point, from the
    // corner-rectangle closed form: (4/π)·x·atan(x) with x = e/√(1 + e²). 1e-6 is where acos
    // would have kept 5 digits; atan2 keeps them all.
    for e in [1e-6f64, 1e-3, 0.5, 1.0, 30.0, 1e4] {
        let x = e / (1.0 + e * e).sqrt();
        let exact = 4.0 / PI * x * x.atan();
        let v = square(e, 1.0);
        let sum = loop_sum(&v);
        assert!((sum - exact).abs() <= 1e-12 * exact, "e {e}: {sum} vs {exact}");
        let reversed: Vec<DVec3> = v.iter().rev().copied().collect();
        assert!((loop_sum(&reversed) + exact).abs() <= 1e-12 * exact, "clockwise is negative");
        // Scale-free: the same directions at other distances.
        let scaled: Vec<DVec3> = v.iter().map(|p| *p * 1e3).collect();
        assert!((LtcLobe::cosine().polygon_integral(&scaled) - exact).abs() <= 1e-12 * exact);
    }
    assert_eq!(lambert_edge(DVec3::X, DVec3::X), 0.0);
    assert_eq!(lambert_edge(DVec3::ZERO, DVec3::X), 0.0);
}

#[test]
fn clipping_to_the_surface() {
    let cosine = LtcLobe::cosine();
    // The whole upper hemisphere (1 − 1e-12 from the closed form above), and nothing below.
    assert!((cosine.polygon_integral(&square(1e6, 1.0)) - 1.0).abs() < 1e-9);
    assert_eq!(cosine.polygon_integral(&square(3.0, -1.0)), 0.0);
    // A wall from z = −1 to 1 equals its upper half, clipped by hand.
    let wall = |z0: f64| {
        [
            DVec3::new(2.0, -1.0, z0),
            DVec3::new(2.0, 1.0, z0),
            DVec3::new(2.0, 1.0, 1.0),
            DVec3::new(2.0, -1.0, 1.0),
        ]
    };
    let (clipped, by_hand) = (cosine.polygon_integral(&wall(-1.0)), cosine.polygon_integral(&wall(0.0)));
    assert!(by_hand > 0.01 && (clipped - by_hand).abs() < 1e-15, "{clipped} vs {by_hand}");
    // A non-convex L across the horizon equals its two rectangles, in either winding.
    let l_shape = [
        DVec3::new(-1.0, -1.0, -0.5),
        DVec3::new(1.0, -1.0, -0.5),
        DVec3::new(1.0, 0.0, 0.2),
        DVec3::new(0.0, 0.0, 0.2),
        DVec3::new(0.0, 1.0, 0.9),
        DVec3::new(-1.0, 1.0, 0.9),
    ];
    let part_a = [l_shape[0], l_shape[1], l_shape[2], DVec3::new(-1.0, 0.0, 0.2)];
    let part_b = [DVec3::new(-1.0, 0.0, 0.2), l_shape[3], l_shape[4], l_shape[5]];
    let lobe = ltc_lobe(0.4, 0.6);
    for lobe in [cosine, lobe] {
        let whole = lobe.polygon_integral(&l_shape);
        let parts = lobe.polygon_integral(&part_a) + lobe.polygon_integral(&part_b);
        let reversed: Vec<DVec3> = l_shape.iter().rev().copied().collect();
        assert!(whole > 1e-3 && (whole - parts).abs() < 1e-14, "{whole} vs {parts}");
        assert!((lobe.polygon_integral(&reversed) - whole).abs() < 1e-15);
    }
}

#[test]
fn edge_terms_sum_to_the_polygon_integral() {
    // A quad above the surface and the LTC horizon: its edges, summed by the caller.
    let lobe = ltc_lobe(0.3, 0.5);
    let quad = [
        DVec3::new(-1.0, -0.2, 1.0),
        DVec3::new(-0.5, -0.2, 1.0),
        DVec3::new(-0.5, 0.3, 1.0),
        DVec3::new(-1.0, 0.3, 1.0),
    ];
    let m = lobe.horizon_normal();
    assert!(quad.iter().all(|p| p.z > 0.0 && m.dot(*p) > 0.0));
    let edges: f64 = (0..4).map(|k| lobe.edge_term(quad[k], quad[(k + 1) % 4])).sum();
    let whole = lobe.polygon_integral(&quad);
    assert!(edges > 0.0 && (edges - whole).abs() < 1e-15, "counterclockwise is positive: {edges} vs {whole}");
}

#[test]
fn horizon_normal_splits_the_ltc_support() {
    let mut rng = Rng::new(9);
    for (r, c) in [(0.05, 0.9), (0.3, 0.5), (0.6, 0.1), (1.0, 0.02)] {
        let lobe = ltc_lobe(r, c);
        let m = lobe.horizon_normal();
        assert!((m.length() - 1.0).abs() < 1e-12);
        for _ in 0..1000 {
            let d = DVec3::new(
                rng.next_f32() as f64 - 0.5,
                rng.next_f32() as f64 - 0.5,
                rng.next_f32() as f64 - 0.5,
            );
            let (side, z) = (m.dot(d), (lobe.minv * d).z);
            assert!(side * z >= 0.0 || side.abs() < 1e-12, "m·d {side} but (minv d).z {z}");
        }
    }
}

/// Integrals of the LTC density over the sphere, over z >= 0 and over each rectangle (in the
/// surface's hemisphere), on a polar grid about the lobe's axis M·ẑ graded as θ = π s² so that
/// the narrowest lobes get hundreds of nodes.
fn density_quadrature(lobe: &LtcLobe, rects: &[Rect]) -> (f64, f64, Vec<f64>) {
    let axis = (lobe.minv.inverse() * DVec3::Z).normalize();
    let e1 = axis.any_orthonormal_vector();
    let e2 = axis.cross(e1);
    let (n_s, n_phi) = (3000, 1200);
    let (mut sphere, mut upper, mut in_rects) = (0.0, 0.0, vec![0.0; rects.len()]);
    for i in 0..n_s {
        let s = (i as f64 + 0.5) / n_s as f64;
        let theta = PI * s * s;
        let ring = theta.sin() * 2.0 * PI * s / n_s as f64 * TAU / n_phi as f64;
        for k in 0..n_phi {
            let phi = TAU * (k as f64 + 0.5) / n_phi as f64;
            let w = axis * theta.cos() + (e1 * phi.cos() + e2 * phi.sin()) * theta.sin();
            let value = lobe.density(w) * ring;
            sphere += value;
            if w.z >= 0.0 {
                upper += value;
                for (acc, r) in in_rects.iter_mut().zip(rects) {
                    if r.hit(w) {
                        *acc += value;
                    }
                }
            }
        }
    }
    (sphere, upper, in_rects)
}

#[test]
fn ltc_density_integrates_to_one_and_to_the_polygon_integrals() {
    // The sphere's integrand is smooth: 1e-6. The surface's horizon and the rectangles' edges
    // cut through lobes, where the grid's indicator errs (measured by doubling the grid: 1e-6
    // at the horizon, up to 1.6e-4 at rectangle edges through a lobe's peak): 1e-5 and 4e-4.
    let mut rng = Rng::new(4);
    let mut worst: f64 = 0.0;
    for (r, deg) in [(0.05f64, 30.0f64), (0.2, 70.0), (0.5, 0.0), (0.8, 85.0)] {
        let cos_v = deg.to_radians().cos();
        let lobe = ltc_lobe(r as f32, cos_v as f32);
        let named = rectangles(r * r, cos_v, &lobe, &mut rng);
        let rects: Vec<Rect> = named.iter().map(|p| p.1).collect();
        let (sphere, upper, in_rects) = density_quadrature(&lobe, &rects);
        let hemisphere = lobe.polygon_integral(&square(1e6, 1.0));
        assert!((sphere - 1.0).abs() < 1e-6, "r {r}, {deg} deg: the density integrates to {sphere}");
        assert!((upper - hemisphere).abs() < 1e-5, "r {r}, {deg} deg: {upper} vs {hemisphere}");
        for ((name, rect), q) in named.iter().zip(in_rects) {
            let analytic = lobe.polygon_integral(&rect.corners());
            worst = worst.max((analytic - q).abs());
            assert!((analytic - q).abs() < 4e-4, "r {r}, {deg} deg, {name}: {analytic} vs {q}");
        }
    }
    eprintln!("polygon integrals against the density's quadrature: worst difference {worst:.2e}");
}

#[test]
fn samples_land_in_polygons_as_often_as_the_integral_says() {
    let mut rng = Rng::new(6);
    let n = 100_000;
    for (r, deg) in [(0.1f64, 20.0f64), (0.5, 60.0), (1.0, 80.0)] {
        let cos_v = deg.to_radians().cos();
        let lobe = ltc_lobe(r as f32, cos_v as f32);
        let named = rectangles(r * r, cos_v, &lobe, &mut rng);
        let mut hits = vec![0usize; named.len()];
        for _ in 0..n {
            let w = lobe.sample([rng.next_f32() as f64, rng.next_f32() as f64]);
            for (h, (_, rect)) in hits.iter_mut().zip(&named) {
                if w.z >= 0.0 && rect.hit(w) {
                    *h += 1;
                }
            }
        }
        for ((name, rect), h) in named.iter().zip(hits) {
            let p = lobe.polygon_integral(&rect.corners());
            let observed = h as f64 / n as f64;
            let sigma = (p * (1.0 - p) / n as f64).sqrt();
            assert!(
                (observed - p).abs() <= 5.0 * sigma + 1e-5,
                "r {r}, {deg} deg, {name}: {observed} vs {p}"
            );
        }
    }
}

#[test]
fn table_nodes_are_well_formed_and_hold_the_quadrature() {
    for i in (0..LTC_SIZE).step_by(7).chain([LTC_SIZE - 1]) {
        for j in (0..LTC_SIZE).step_by(5).chain([LTC_SIZE - 1]) {
            let (r, c) = (ltc_grid_roughness(i), ltc_grid_cos_theta(j));
            let lobe = ltc_lobe(r as f32, c as f32);
            let m: DMat3 = lobe.minv;
            assert!(m.to_cols_array().iter().all(|v| v.is_finite()));
            assert!(m.determinant() > 0.0, "node ({i}, {j}) turns the orientation");
            let (norm, fresnel) = specular_moments(r * r, c, 384);
            // At the node up to the f32 rounding of (r, c) and the stored values.
            assert!((lobe.norm - norm).abs() < 2e-5 * norm, "node ({i}, {j}): norm {} vs {norm}", lobe.norm);
            assert!(
                (lobe.fresnel - fresnel).abs() < 2e-5 * norm,
                "node ({i}, {j}): fresnel {} vs {fresnel}",
                lobe.fresnel
            );
            assert!(lobe.norm > 0.0 && lobe.norm <= 1.0 && lobe.fresnel >= 0.0 && lobe.fresnel <= lobe.norm);
        }
    }
    assert_eq!(ltc_grid_roughness(0), ROUGHNESS_MIN as f64);
    assert_eq!(ltc_grid_roughness(LTC_SIZE - 1), 1.0);
}
