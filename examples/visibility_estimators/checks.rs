//! Self-checks: the exact V against quadrature, the spherical rectangle sampler (f64 and f32)
//! against its solid angle, and the design note's example.

use crate::HEIGHTS;
use crate::estimators::{solid_angle_tally, solid_angle_tally_f32};
use crate::rng::Rng;
use crate::scene::{Card, Light, Point};
use crate::spherical_rect::{SphericalRect, SphericalRectF32};
use glam::{DVec2, DVec3};

/// int over the light of v g dA and of g dA by the midpoint rule on an m x m grid.
fn quadrature(pt: &Point, m: usize) -> (f64, f64) {
    let (mut vis, mut all) = (0.0, 0.0);
    let h = pt.light.height();
    for j in 0..m {
        for i in 0..m {
            let y = DVec3::new((i as f64 + 0.5) / m as f64 - 0.5, h, (j as f64 + 0.5) / m as f64 - 0.5);
            let w = y - pt.p;
            let r2 = w.length_squared();
            let g = pt.n.dot(w) * (-pt.light.normal.dot(w)) / (r2 * r2);
            all += g;
            if !pt.card.blocks(pt.p, y) {
                vis += g;
            }
        }
    }
    let da = 1.0 / (m * m) as f64;
    (vis * da, all * da)
}

pub fn self_checks(cards: &[Card]) {
    println!("## Self-checks\n");
    // The exact V against a 2000 x 2000 midpoint rule (its error is the card edges' pixels).
    let mut worst_g: f64 = 0.0;
    let mut worst_v: f64 = 0.0;
    for &h in &[0.3, 1.0, 5.0] {
        for card in cards {
            let card = Card { height: h / 3.0, ..*card };
            for p in [DVec2::new(0.05, 0.1), DVec2::new(0.45, -0.2), DVec2::new(-0.2, 0.35)] {
                let pt = Point::new(DVec3::new(p.x, 0.0, p.y), Light::at(h), card);
                let (vis, all) = quadrature(&pt, 2000);
                worst_g = worst_g.max((all / pt.g_total - 1.0).abs());
                worst_v = worst_v.max((vis / all - pt.v_exact).abs());
            }
        }
    }
    println!("- Lambert's G against a 2000^2 midpoint rule: largest relative difference {worst_g:.1e}");
    println!("- exact V against the midpoint rule of v g: largest difference {worst_v:.1e}");
    assert!(worst_g < 1e-5 && worst_v < 2e-3, "the exact V disagrees with quadrature");
    // The sampler: its solid angle against Lambert-free quadrature of |z0| / r^3 dA, S times the
    // mean cos_x against G, and the share of samples left of x = 0 against the left half's own
    // solid angle (a uniform density in solid angle).
    let (mut worst_s, mut worst_e, mut worst_u): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let (mut worst_32, mut worst_e32): (f64, f64) = (0.0, 0.0);
    for &h in &HEIGHTS {
        for p in [DVec2::new(0.0, 0.0), DVec2::new(0.3, -0.45), DVec2::new(1.1, 0.7)] {
            let pt =
                Point::new(DVec3::new(p.x, 0.0, p.y), Light::at(h), Card { height: h / 3.0, ..cards[0] });
            let rect = SphericalRect::of(&pt);
            let m = 1000;
            let mut omega = 0.0;
            for j in 0..m {
                for i in 0..m {
                    let y =
                        DVec3::new((i as f64 + 0.5) / m as f64 - 0.5, h, (j as f64 + 0.5) / m as f64 - 0.5);
                    omega += h / (y - pt.p).length().powi(3);
                }
            }
            omega /= (m * m) as f64;
            worst_s = worst_s.max((rect.s / omega - 1.0).abs());
            let n = 1 << 18;
            let (_, sum_cos) = solid_angle_tally(&pt, &rect, n, &mut Rng::new(7), |_, _| false);
            worst_e = worst_e.max((rect.s * sum_cos / n as f64 / pt.g_total - 1.0).abs());
            let mut rng = Rng::new(9);
            let m2 = 1 << 16;
            let left = (0..m2).filter(|_| rect.sample(rng.next_f64(), rng.next_f64()).x < 0.0).count();
            let c = pt.light.corner.as_dvec3();
            let half = SphericalRect::new(pt.p, c, DVec3::new(0.5, 0.0, 0.0), DVec3::Z);
            let want = half.s / rect.s;
            let sigma = (want * (1.0 - want) / m2 as f64).sqrt();
            worst_u = worst_u.max(((left as f64 / m2 as f64) - want).abs() / sigma);
            let r32 = SphericalRectF32::of(&rect);
            for j in 0..=64 {
                for i in 0..=64 {
                    let (u, v) = (i as f64 / 64.0, j as f64 / 64.0);
                    let d = (r32.sample(u as f32, v as f32).as_dvec3() - rect.sample(u, v)).length();
                    worst_32 = worst_32.max(d);
                }
            }
            let (_, sum_cos) = solid_angle_tally_f32(&pt, &r32, n, &mut Rng::new(7), |_, _| false);
            worst_e32 = worst_e32.max((rect.s * sum_cos / n as f64 / pt.g_total - 1.0).abs());
        }
    }
    println!(
        "- solid angle S of the spherical rectangle against quadrature: largest relative difference {worst_s:.1e}"
    );
    println!(
        "- S * mean(cos_x) over 2^18 stratified samples against G: largest relative difference {worst_e:.1e}"
    );
    println!("- share of samples in the left half against its solid angle share: largest {worst_u:.1} sigma");
    println!(
        "- the f32 map against the f64 map on a 65 x 65 grid of (u, v): largest distance {worst_32:.1e} m; \
         S * mean(cos_x) against G: {worst_e32:.1e}"
    );
    assert!(worst_s < 1e-5 && worst_e < 1e-4 && worst_u < 5.0, "the spherical rectangle sampler is off");
    assert!(worst_32 < 1e-4 && worst_e32 < 1e-3, "the f32 map is off");
    // The design note's example: a floor point under the light's centre, the outer quarter
    // blocked (the note: area fraction 0.75 against V = 0.88 at 0.6 m, 0.78 at 1 m, 0.753 at 3 m).
    let strip = Card::new(DVec2::new(0.375 / 3.0, 0.0), DVec2::new(0.125 / 3.0, 10.0), 0.0, 0.0);
    let vs: Vec<String> = [0.6, 1.0, 3.0]
        .iter()
        .map(|&h| {
            let pt = Point::new(DVec3::ZERO, Light::at(h), Card { height: h / 3.0, ..strip });
            format!("{h} m: area {:.3}, V {:.3}", pt.area_exact, pt.v_exact)
        })
        .collect();
    println!("- point under the centre, outer quarter blocked: {}\n", vs.join("; "));
}
