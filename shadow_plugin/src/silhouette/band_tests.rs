//! The band around a projected edge, tested where it matters: light samples placed a
//! fraction of a band to a few bands from the edge's line, their rays traced with the
//! renderer's own shadow ray and watertight test against one of the edge's triangles. The
//! counting settles a sample outside the band by the sign of its side alone; the triangle
//! must then be met exactly when the sample is on its third vertex's side. Random scenes
//! from millimetres to kilometres across, far from the origin or near it.

use crate::silhouette_edges::projection::{Frame, exact_orient_sign, push};
use glam::{DVec2, DVec3, Vec3};
use renderer::RectLight;
use renderer::geometry::ray_origin::shadow_ray_from;
use renderer::geometry::watertight::ShearedRay;

/// Offsets from the edge's line, in bands: inside (traced, not checked) and outside.
const OFFSETS: [f64; 14] = [1e-4, 3e-4, 1e-3, 3e-3, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 1.01, 1.5, 3.0];

thread_local! {
    /// Samples outside the band checked beside edges seen nearly end-on.
    static END_ON: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    /// Disagreements per offset (index 2k) and near-origin edge (2k + 1).
    static DISAGREEMENTS: std::cell::RefCell<[u32; 2 * OFFSETS.len()]> =
        const { std::cell::RefCell::new([0; 2 * OFFSETS.len()]) };
}

/// (samples checked outside the band, disagreements there, the largest |side| / band of a
/// disagreement anywhere) over `trials` random edges.
fn run(trials: usize, seed: u64) -> (u64, u64, f64) {
    let mut next = crate::silhouette_edges::uniform(seed);
    let (mut checked, mut wrong, mut worst) = (0u64, 0u64, 0.0f64);
    for trial in 0..trials {
        // A third of the edges near the origin, a third seen nearly end-on (their ends on
        // two rays from o 3e-4 to 3e-2 of the light apart: a smooth mesh's contour; closer
        // ones leave no sample clearly inside the triangle's other sides).
        let near_origin = trial % 3 == 1;
        let end_on = trial % 3 == 2;
        let scale = 10f64.powf(6.0 * next() - 3.0);
        let shift = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * scale * 1e3 * next();
        let unit = |next: &mut dyn FnMut() -> f64| DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
        let u = (unit(&mut next) * scale).as_vec3();
        let v = (unit(&mut next) * scale).as_vec3();
        let light = RectLight::new((shift + unit(&mut next) * scale).as_vec3(), u, v, Vec3::ONE);
        let normal = light.normal.as_dvec3();
        let o = light.center.as_dvec3() + normal * scale * (0.5 + 4.0 * next()) + unit(&mut next) * scale;
        let o = o.as_vec3();
        let Some(frame) = Frame::new(&light, o) else { continue };
        // The edge between o and two light points; the third vertex beside it.
        let between = |next: &mut dyn FnMut() -> f64| {
            let s = light.point(next() as f32, next() as f32).as_dvec3();
            // Half the edges near the origin (a point's own neighbours: micrometres away).
            let lambda = if near_origin { 10f64.powf(-4.0 + 3.0 * next()) } else { 0.1 + 0.8 * next() };
            (o.as_dvec3() + lambda * (s - o.as_dvec3())).as_vec3().as_dvec3()
        };
        let (e0, e1) = if end_on {
            let (a, b) = (next() as f32, next() as f32);
            let apart = 10f64.powf(-3.5 + 2.0 * next()) as f32;
            let (s0, s1) = (light.point(a, b).as_dvec3(), light.point(a + apart, b + apart).as_dvec3());
            let (l0, l1) = (0.1 + 0.4 * next(), 0.5 + 0.4 * next());
            let at = |s: DVec3, l: f64| (o.as_dvec3() + l * (s - o.as_dvec3())).as_vec3().as_dvec3();
            (at(s0, l0), at(s1, l1))
        } else {
            (between(&mut next), between(&mut next))
        };
        let c = between(&mut next);
        let c = (c + unit(&mut next) * 0.1 * (c - o.as_dvec3()).length()).as_vec3().as_dvec3();
        let n = (e0 - frame.o).cross(e1 - frame.o);
        let mut active = Vec::new();
        push(&mut active, &frame, e0, e1, n, 1);
        // The other two sides, as the counting would see them: a sample is informative only
        // where it lies clearly inside both (then the ray meets the triangle iff it passes
        // the first edge on the third vertex's side).
        push(&mut active, &frame, e1, c, (e1 - frame.o).cross(c - frame.o), 1);
        push(&mut active, &frame, c, e0, (c - frame.o).cross(e0 - frame.o), 1);
        if active.len() != 3 {
            continue;
        }
        let (e, others) = (&active[0], [active[1], active[2]]);
        let inside_others = |a: f32, b: f32| {
            let towards = [exact_orient_sign(frame.o, e1, c, e0), exact_orient_sign(frame.o, c, e0, e1)];
            others.iter().zip(towards).all(|(x, t)| {
                let v = x.side_at(a, b);
                v.abs() >= 4.0 * x.band && (v > 0.0) == (t > 0)
            })
        };
        let c_side = exact_orient_sign(frame.o, e0, e1, c);
        if c_side == 0 {
            continue;
        }
        let tri = obvhs::triangle::Triangle {
            v0: e0.as_vec3().into(),
            v1: e1.as_vec3().into(),
            v2: c.as_vec3().into(),
        };
        // Samples across the line at the middle of the projected edge.
        let mid = 0.5 * (e.p0 + e.p1);
        let g = DVec2::new(e.side[1] as f64, e.side[2] as f64);
        let at_mid = e.side[0] as f64 + g.dot(mid);
        for k in OFFSETS {
            for sign in [-1.0, 1.0] {
                let target_side = sign * k * e.band as f64;
                let p = mid + g * (target_side - at_mid) / g.length_squared();
                let (a, b) = (p.x as f32, p.y as f32);
                if !((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)) {
                    continue;
                }
                if !inside_others(a, b) {
                    continue;
                }
                let side = e.side_at(a, b);
                let target = light.point(a, b);
                let Some(ray) = shadow_ray_from(o, target, light.point_error(a, b), light.normal) else {
                    continue;
                };
                let met = ShearedRay::new(&ray).intersect(&tri, ray.tmax).is_some();
                let expected = (side > 0.0) == (c_side > 0);
                if met != expected {
                    let slot = 2 * OFFSETS.iter().position(|&x| x == k).unwrap() + near_origin as usize;
                    DISAGREEMENTS.with(|d| d.borrow_mut()[slot] += 1);
                }
                if met != expected {
                    worst = worst.max((side / e.band).abs() as f64);
                }
                if side.abs() >= e.band {
                    END_ON.with(|c| c.set(c.get() + end_on as u64));
                    checked += 1;
                    wrong += (met != expected) as u64;
                }
            }
        }
    }
    (checked, wrong, worst)
}

/// Outside the band, the side's sign always says whether the ray meets the triangle, and
/// the band keeps a margin: every disagreement lies within a quarter of it. (Measured: up
/// to 0.1 of it, none at 0.2, for edges far from the origin, near it and seen end-on
/// alike. With the edge's shift in f32 ulps, as the f32 test this one replaced needed,
/// edges near the origin disagreed only within 1e-3 of their band.)
#[test]
fn outside_the_band_the_side_decides_the_ray() {
    let (checked, wrong, worst) = run(100_000, 0x5eed_ba4d_0001_2345);
    let by_offset = DISAGREEMENTS.with(|d| *d.borrow());
    eprintln!("disagreements per offset {OFFSETS:?}, (far, near the origin): {by_offset:?}");
    eprintln!("{checked} samples outside the band, {wrong} wrong; worst disagreement at {worst:.3} bands");
    let end_on = END_ON.with(|c| c.get());
    assert!(checked > 100_000, "only {checked} samples checked");
    assert!(end_on > 1000, "only {end_on} samples checked beside edges seen end-on");
    assert!(by_offset[0] > 1000, "the test no longer reaches the rounding zone");
    assert_eq!(wrong, 0, "samples outside the band whose ray the side misjudges");
    assert!(worst < 0.25, "a disagreement at {worst} of the band: too little margin");
}
