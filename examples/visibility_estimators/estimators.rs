//! The four estimators of V at one point. 1-3 (`area`, `ratio`, `norm`) share traced's samples,
//! uniform over the light's area; 4 (`solid`) maps strata of the unit square by the spherical
//! rectangle (`crate::spherical_rect`).

use crate::rng::{Rng, strata};
use crate::scene::Point;
use crate::spherical_rect::{SphericalRect, SphericalRectF32};
use glam::{DVec3, Vec3};

/// Counts and weights of one point's uniform samples.
#[derive(Default, Clone, Copy)]
pub struct Tally {
    visible: u32,
    blocked: u32,
    g_visible: f64,
    g_blocked: f64,
}

/// g at `target` as the renderer weighs it: n . w (n_L . -w) / r^4, in f64, no square root.
#[inline]
fn weight(p: DVec3, n: DVec3, light_n: DVec3, target: Vec3) -> f64 {
    let w = target.as_dvec3() - p;
    let r2 = w.length_squared();
    n.dot(w).max(0.0) * (-light_n.dot(w)).max(0.0) / (r2 * r2)
}

/// `n` stratified jittered samples over the light, drawn as `traced` draws them (f32 rectangle
/// coordinates, row by row); `blocked(i, target)` gives sample i's verdict. With `WEIGH`
/// false only the samples are counted (estimator 1's work).
#[inline(always)]
pub fn uniform_tally<const WEIGH: bool>(
    pt: &Point,
    n: u32,
    rng: &mut Rng,
    mut blocked: impl FnMut(usize, Vec3) -> bool,
) -> Tally {
    let (nx, ny) = strata(n);
    let (inv_x, inv_y) = (1.0 / nx as f32, 1.0 / ny as f32);
    let mut t = Tally::default();
    let mut i = 0;
    for cy in 0..ny {
        for cx in 0..nx {
            let a = (cx as f32 + rng.next_f32()) * inv_x;
            let b = (cy as f32 + rng.next_f32()) * inv_y;
            let target = pt.light.point(a, b);
            let g = if WEIGH { weight(pt.p, pt.n, pt.light.normal, target) } else { 0.0 };
            if blocked(i, target) {
                t.blocked += 1;
                t.g_blocked += g;
            } else {
                t.visible += 1;
                t.g_visible += g;
            }
            i += 1;
        }
    }
    t
}

pub fn area_fraction(t: &Tally) -> f64 {
    t.visible as f64 / (t.visible + t.blocked) as f64
}

pub fn ratio(t: &Tally) -> f64 {
    let all = t.g_visible + t.g_blocked;
    if all > 0.0 { t.g_visible / all } else { area_fraction(t) }
}

/// Estimator 3: the smaller set against the exact G; `area_per_sample` = A / N.
pub fn normalised(t: &Tally, area_per_sample: f64, g_total: f64) -> f64 {
    let v = if t.blocked <= t.visible {
        1.0 - area_per_sample * t.g_blocked / g_total
    } else {
        area_per_sample * t.g_visible / g_total
    };
    v.clamp(0.0, 1.0)
}

/// Estimator 4's loop with the f32 map (cos_x in f32): its cost only.
#[inline(always)]
pub fn solid_angle_tally_f32(
    pt: &Point,
    rect: &SphericalRectF32,
    n: u32,
    rng: &mut Rng,
    mut blocked: impl FnMut(usize, Vec3) -> bool,
) -> (f64, f64) {
    let (nx, ny) = strata(n);
    let (inv_x, inv_y) = (1.0 / nx as f32, 1.0 / ny as f32);
    let (p, normal) = (pt.p.as_vec3(), pt.n.as_vec3());
    let (mut visible, mut all) = (0.0, 0.0);
    let mut i = 0;
    for cy in 0..ny {
        for cx in 0..nx {
            let u = (cx as f32 + rng.next_f32()) * inv_x;
            let v = (cy as f32 + rng.next_f32()) * inv_y;
            let y = rect.sample(u, v);
            let w = y - p;
            let cos_x = (normal.dot(w).max(0.0) / w.length()) as f64;
            all += cos_x;
            if !blocked(i, y) {
                visible += cos_x;
            }
            i += 1;
        }
    }
    (visible, all)
}

/// `n` stratified jittered samples of the unit square mapped by `rect`; returns
/// (sum over visible of cos_x, sum of cos_x).
#[inline(always)]
pub fn solid_angle_tally(
    pt: &Point,
    rect: &SphericalRect,
    n: u32,
    rng: &mut Rng,
    mut blocked: impl FnMut(usize, Vec3) -> bool,
) -> (f64, f64) {
    let (nx, ny) = strata(n);
    let (inv_x, inv_y) = (1.0 / nx as f64, 1.0 / ny as f64);
    let (mut visible, mut all) = (0.0, 0.0);
    let mut i = 0;
    for cy in 0..ny {
        for cx in 0..nx {
            let u = (cx as f64 + rng.next_f64()) * inv_x;
            let v = (cy as f64 + rng.next_f64()) * inv_y;
            let y = rect.sample(u, v);
            let w = y - pt.p;
            let cos_x = pt.n.dot(w).max(0.0) / w.length();
            all += cos_x;
            if !blocked(i, y.as_vec3()) {
                visible += cos_x;
            }
            i += 1;
        }
    }
    (visible, all)
}
