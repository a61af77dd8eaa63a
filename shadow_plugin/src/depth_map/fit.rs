//! Fitting a depth map's frustum: a box over the images of the receivers the light reaches
//! (those something may shadow, with [`super::MapSwitches::fit_shadowed`]), trimmed by
//! irradiance, grown by how far a shadow ray travels before it is above the nearest caster.

use super::{DepthMapParams, LightFrame, MAX_TAN, RECEIVER_TRIM, grazing};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use renderer::{RectLight, Scene, ShadingPoint, Shaft};

/// Where a map's pixels lie.
pub(super) struct Frustum {
    /// Image-plane coordinates (x/z, y/z) of the map's lower corner, and the pixel pitch.
    pub origin: Vec2,
    pub pitch: f32,
    /// See [`super::DepthMap::caster_z_near`].
    pub caster_z_near: f32,
}

/// Fits the frustum of a `res` x `res` map to the receivers in `visible`.
pub(super) fn fit(
    scene: &Scene,
    light: &RectLight,
    frame: &LightFrame,
    visible: &[ShadingPoint],
    params: &DepthMapParams,
    res: u32,
) -> Frustum {
    let _span = tracing::info_span!("fit").entered();
    let (lo, hi, z_recv_min) = receiver_box(scene, light, frame, visible, params);
    let caster_z_near = caster_z_near(scene, frame, lo, hi, z_recv_min);
    // The margin: how far a shadow ray travels in the image before it is above the
    // nearest caster.
    let margin = frame.half_size * (1.0 / caster_z_near - 1.0 / (z_recv_min.max(caster_z_near)));
    let lo = (lo - margin).max(Vec2::splat(-MAX_TAN));
    let hi = (hi + margin).min(Vec2::splat(MAX_TAN));
    let side = (hi - lo).max_element().max(1e-6);
    let centre = 0.5 * (lo + hi);
    // One pixel of padding on each side so the border pixels are inside the fit.
    let pitch = side / (res as f32 - 2.0).max(1.0);
    let origin = centre - Vec2::splat(0.5 * pitch * res as f32);
    Frustum { origin, pitch, caster_z_near }
}

/// The box (lower and upper image-plane corners) of the receivers, and their nearest depth.
fn receiver_box(
    scene: &Scene,
    light: &RectLight,
    frame: &LightFrame,
    visible: &[ShadingPoint],
    params: &DepthMapParams,
) -> (Vec2, Vec2, f32) {
    // Receivers: visible points the light reaches, weighted by their irradiance. The
    // frustum leaves out RECEIVER_TRIM of the total irradiance on each side of each axis:
    // surfaces reaching up to the light's plane (a wall beside a ceiling light) would
    // otherwise stretch the map over a huge field of view for points that the light
    // only grazes; those fall back to traced rays.
    // In parallel, with the sorts in `trimmed_range`: on the default scene at 640x480 (307k
    // points) the serial fit took 67 of prepare's 160 ms.
    // With `fit_shadowed`, the box is fitted to the receivers whose shaft is not clear
    // (the third member), while the depth range (and so the margin below) still spans
    // every receiver: the margin fitted to the shadowed ones alone grew with their depth
    // and coarsened the map (tests/hard_cases.rs, light larger than the scene: RMSE 0.025
    // -> 0.038).
    let receivers: Vec<(Vec3, f32, bool)> = visible
        .par_iter()
        .filter_map(|v| {
            let p = frame.light_from_world(v.p);
            if p.z <= frame.depth_tolerance(v.p, v.p_error) || grazing(frame, params.grazing_cos, v) {
                return None;
            }
            let e = light.irradiance_factor(v.p, v.n_shading);
            if e <= 0.0 {
                return None;
            }
            let fitted = !params.switches.fit_shadowed
                || Shaft::new(light, v).is_none_or(|shaft| !scene.shaft_clear(&shaft));
            Some((p, e, fitted))
        })
        .collect();
    // Nothing in view that anything may shadow: fit to every receiver, as without the
    // option (not to a default box the points would read masks through for nothing).
    let any_fitted = receivers.iter().any(|r| r.2);
    let fitted = receivers.iter().filter(|r| r.2 || !any_fitted);
    let mut xs: Vec<(f32, f32)> = fitted.clone().map(|(p, e, _)| (p.x / p.z, *e)).collect();
    let mut ys: Vec<(f32, f32)> = fitted.map(|(p, e, _)| (p.y / p.z, *e)).collect();
    let mut z_recv_min = receivers.iter().map(|(p, _, _)| p.z).fold(f32::INFINITY, f32::min);
    let (mut lo, mut hi) = if xs.is_empty() {
        // No receiver at all (some are always fitted when there are any).
        z_recv_min = 1.0;
        (Vec2::splat(-1.0), Vec2::splat(1.0))
    } else {
        let (x0, x1) = trimmed_range(&mut xs);
        let (y0, y1) = trimmed_range(&mut ys);
        (Vec2::new(x0, y0), Vec2::new(x1, y1))
    };
    lo = lo.clamp(Vec2::splat(-MAX_TAN), Vec2::splat(MAX_TAN));
    hi = hi.clamp(lo, Vec2::splat(MAX_TAN));
    (lo, hi, z_recv_min)
}

/// The casters' nearest depth: that of the nearest vertex in front of the light whose image
/// could reach a receiver's filter region (conservatively, within the receivers' box `lo..hi`
/// grown by the light's half size / z); the receivers' nearest depth `z_recv_min` when no
/// vertex is nearer. Kept instances' vertices are placed as the flattened scene holds them;
/// an instance whose bounds lie wholly deeper than the nearest found so far is skipped (a
/// minimum: the same value in any order).
fn caster_z_near(scene: &Scene, frame: &LightFrame, lo: Vec2, hi: Vec2, z_recv_min: f32) -> f32 {
    let mut caster_z_near = z_recv_min;
    let consider = |v: Vec3, caster_z_near: &mut f32| {
        let p = frame.light_from_world(v);
        if p.z > frame.depth_tolerance(v, Vec3::ZERO) && p.z < *caster_z_near {
            let img = Vec2::new(p.x, p.y) / p.z;
            let reach = frame.half_size / p.z;
            if img.cmpge(lo - reach).all() && img.cmple(hi + reach).all() {
                *caster_z_near = p.z;
            }
        }
    };
    for t in &scene.triangles {
        for v in [t.v0, t.v1, t.v2] {
            consider(Vec3::from(v), &mut caster_z_near);
        }
    }
    let Some(inst) = &scene.instanced else { return caster_z_near };
    for p in &inst.placed {
        // The box's least depth (f64; the f32 depths of its vertices round by far less than
        // the margin).
        let (bmin, bmax) = (Vec3::from(p.bounds.min).as_dvec3(), Vec3::from(p.bounds.max).as_dvec3());
        let (o, z) = (frame.origin.as_dvec3(), frame.z.as_dvec3());
        let nearest = (0..8)
            .map(|k| {
                let c = glam::DVec3::new(
                    if k & 1 == 0 { bmin.x } else { bmax.x },
                    if k & 2 == 0 { bmin.y } else { bmax.y },
                    if k & 4 == 0 { bmin.z } else { bmax.z },
                );
                (c - o).dot(z) - 1e-5 * (c - o).abs().element_sum()
            })
            .fold(f64::INFINITY, f64::min);
        if nearest > caster_z_near as f64 {
            continue;
        }
        for slot in 0..inst.meshes[p.mesh as usize].slots.len() {
            let t = inst.render_triangle(p, slot);
            for v in [t.v0, t.v1, t.v2] {
                consider(Vec3::from(v), &mut caster_z_near);
            }
        }
    }
    caster_z_near
}

/// The range of `(coordinate, weight)` pairs that leaves out `RECEIVER_TRIM` of the total
/// weight at each end.
fn trimmed_range(values: &mut [(f32, f32)]) -> (f32, f32) {
    // A total order on both members: the order, and so the sums below, are the same bits
    // whatever the parallel sort's split (thread count).
    values.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let total: f64 = values.iter().map(|v| v.1 as f64).sum();
    let cut = total * RECEIVER_TRIM;
    let position = |iter: &mut dyn Iterator<Item = &(f32, f32)>| {
        let mut acc = 0.0;
        for v in iter {
            acc += v.1 as f64;
            if acc > cut {
                return v.0;
            }
        }
        values[0].0
    };
    let lo = position(&mut values.iter());
    let hi = position(&mut values.iter().rev());
    (lo.min(hi), hi.max(lo))
}
