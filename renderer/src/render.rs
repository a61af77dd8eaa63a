//! The frame: a primary pass (closest hits for every pixel sample), `prepare` per light, then
//! a shading pass (irradiance times visibility). Rayon over rows of pixels; every random
//! number is keyed by (seed, pixel, sample, light), so the bytes do not depend on the number
//! of threads.

use crate::sampling::{Rng, strata, stream_seed};
use crate::scene::{Scene, SurfaceHit};
use crate::shadowing::{LightShadowing, PrepareContext, ShadowError, ShadowQuery, VisiblePoint};
use glam::{Vec3, Vec3A};
use obvhs::ray::Ray;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// 1 = one ray through each pixel centre; more = jittered stratified samples, box filter.
    pub spp: u32,
    pub seed: u64,
    /// Handed to every method's `prepare` ([`PrepareContext::mask_budget_bytes`]): the most
    /// bytes of masks one light may hold. The command line reads it from the machine.
    pub mask_budget_bytes: u64,
}

/// What a frame produces.
#[derive(Debug, Clone)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Linear radiance, row-major, top row first.
    pub radiance: Vec<Vec3>,
    /// Per light k: visibility at each pixel's primary hit in [0, 1] (the mean over the
    /// pixel's samples that hit; 0 where the light is below the horizon or faces away), or
    /// -1 where no primary ray hits anything.
    pub visibility: Vec<Vec<f32>>,
    pub shadow_prepare: Duration,
    /// Wall time of the pixel loop: primary rays, shading and shadow queries.
    pub render: Duration,
    pub counters: BTreeMap<String, u64>,
    /// One line each: what makes this image suspect (nothing hit, no light reaching what the
    /// camera sees, visible geometry f32 cannot keep precise). See [`frame_warnings`].
    pub warnings: Vec<String>,
}

/// Stream tags, so different uses of one pixel's seed never share random numbers.
const TAG_PRIMARY: u64 = 1;
const TAG_SHADOW: u64 = 2;

/// Renders `scene` with one shadow method per light (`methods[k]` shadows `scene.lights[k]`).
/// `progress` is called with the number of rows finished, from any thread.
///
/// # Errors
/// The first error a method's `prepare` reports.
pub fn render(
    scene: &Scene,
    methods: &mut [Box<dyn LightShadowing>],
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Frame, ShadowError> {
    assert_eq!(methods.len(), scene.lights.len(), "one shadow method per light");
    let RenderSettings { width, height, .. } = *settings;

    let t_primary = Instant::now();
    let hits = primary_hits(scene, settings);
    let primary_time = t_primary.elapsed();

    let t_prepare = Instant::now();
    prepare_lights(scene, methods, &hits, settings)?;
    let shadow_prepare = t_prepare.elapsed();

    let t_shade = Instant::now();
    let shaded = shade(scene, methods, &hits, settings, progress);
    let render = primary_time + t_shade.elapsed();

    let mut counters = BTreeMap::new();
    counters.insert("shading_points".to_string(), shaded.shading_points);
    counters.insert("shadow_queries".to_string(), shaded.shadow_queries);
    for m in methods.iter() {
        for (name, value) in m.counters() {
            *counters.entry(name.to_string()).or_insert(0) += value;
        }
    }
    let (w, h, lights) = (width as usize, height as usize, scene.lights.len());
    let visibility =
        (0..lights).map(|k| (0..w * h).map(|i| shaded.visibility[i * lights + k]).collect()).collect();
    let warnings = frame_warnings(scene, &hits, &shaded.facing, &shaded.lit);
    Ok(Frame {
        width,
        height,
        radiance: shaded.radiance,
        visibility,
        shadow_prepare,
        render,
        counters,
        warnings,
    })
}

/// The warnings of a frame, one line each: no primary ray hits anything; light k reaches no
/// visible point (facing: per light, the shading points with non-zero irradiance; lit: those
/// also with non-zero visibility); no light reaches any; and, when the scene holds triangles
/// f32 cannot keep precise, how precise the visible part is.
pub fn frame_warnings(
    scene: &Scene,
    hits: &[Option<SurfaceHit>],
    facing: &[u64],
    lit: &[u64],
) -> Vec<String> {
    use crate::precision::{SHAPE_PRECISION, f32_spacing};
    let mut warnings = Vec::new();
    let visible = hits.iter().flatten().count();
    if visible == 0 {
        warnings
            .push("the camera sees nothing: no primary ray hits any geometry (the image is black)".into());
        return warnings;
    }
    for (k, (&f, &l)) in facing.iter().zip(lit).enumerate() {
        if f == 0 {
            warnings.push(format!(
                "light {k} reaches no visible point: every point the camera sees is behind its emitting \
                 side or below the light's horizon"
            ));
        } else if l == 0 {
            warnings.push(format!(
                "light {k} reaches no visible point: {f} visible point(s) face it, all fully shadowed"
            ));
        }
    }
    if !lit.is_empty() && lit.iter().all(|&l| l == 0) {
        warnings.push(format!(
            "the camera sees nothing lit: none of {visible} visible point(s) receives light (the image is black)"
        ));
    }
    if scene.stats.imprecise_triangles > 0 {
        // The camera is the render-space origin: |p| is the distance from it.
        let (mut far, mut imprecise) = (0.0f64, 0u64);
        for hit in hits.iter().flatten() {
            let d = hit.p.as_dvec3().length();
            far = far.max(d);
            let t = &scene.triangles[hit.triangle as usize];
            let size = [t.v1 - t.v0, t.v2 - t.v1, t.v0 - t.v2].iter().map(|e| e.length()).fold(0.0, f32::max);
            imprecise += u64::from(f32_spacing(d) > size as f64 / SHAPE_PRECISION);
        }
        warnings.push(format!(
            "the visible part lies within {far:.3e} m of the camera, where f32 positions are spaced {:.3e} m; \
             {imprecise} of {visible} visible point(s) lie on triangles f32 cannot keep precise",
            f32_spacing(far)
        ));
    }
    warnings
}

/// The primary pass: the closest hit (or none) of every sample of every pixel, at
/// `(y * width + x) * spp + s`.
fn primary_hits(scene: &Scene, settings: &RenderSettings) -> Vec<Option<SurfaceHit>> {
    let RenderSettings { width, height, spp, seed, .. } = *settings;
    let (w, h, spp_us) = (width as usize, height as usize, spp as usize);
    let mut hits: Vec<Option<SurfaceHit>> = vec![None; w * h * spp_us];
    let (sx, sy) = strata(spp);
    hits.par_chunks_mut(w * spp_us).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            let pixel_index = (y * w + x) as u64;
            let mut rng = Rng::new(stream_seed(&[seed, pixel_index, TAG_PRIMARY]));
            for s in 0..spp_us {
                let (fx, fy) = if spp == 1 {
                    (0.5, 0.5)
                } else {
                    let (i, j) = ((s as u32 % sx) as f32, (s as u32 / sx) as f32);
                    ((i + rng.next_f32()) / sx as f32, (j + rng.next_f32()) / sy as f32)
                };
                let d = scene.camera.ray_direction(x as f32 + fx, y as f32 + fy, width, height).normalize();
                let ray = Ray::new(Vec3A::from(scene.camera.position), Vec3A::from(d), 0.0, f32::INFINITY);
                row[x * spp_us + s] = scene.intersect(ray);
            }
        }
    });
    hits
}

/// Prepares every light's method with what the camera sees (every primary hit).
fn prepare_lights(
    scene: &Scene,
    methods: &mut [Box<dyn LightShadowing>],
    hits: &[Option<SurfaceHit>],
    settings: &RenderSettings,
) -> Result<(), ShadowError> {
    let RenderSettings { seed, mask_budget_bytes, .. } = *settings;
    let visible: Vec<VisiblePoint> = hits
        .iter()
        .flatten()
        .map(|hit| VisiblePoint {
            p: hit.p,
            p_error: hit.p_error,
            n_geom: hit.n_geom,
            n_shading: hit.n_shading,
        })
        .collect();
    // The budget was read before the frame began: what the primary hits and the lights
    // prepared so far hold is no longer free.
    let mut held = std::mem::size_of_val(visible.as_slice()) as u64;
    for (k, method) in methods.iter_mut().enumerate() {
        let ctx = PrepareContext {
            scene,
            light: &scene.lights[k],
            light_index: k,
            visible: &visible,
            seed,
            mask_budget_bytes: mask_budget_bytes.saturating_sub(held),
        };
        method.prepare(&ctx)?;
        held += method.memory_bytes();
    }
    Ok(())
}

/// What the shading pass produces.
struct Shaded {
    /// Linear radiance per pixel, row-major.
    radiance: Vec<Vec3>,
    /// Per pixel, then per light: as `Frame::visibility`, interleaved.
    visibility: Vec<f32>,
    shading_points: u64,
    shadow_queries: u64,
    /// Per light: shading points with non-zero irradiance from it.
    facing: Vec<u64>,
    /// Per light: shading points with non-zero irradiance and visibility.
    lit: Vec<u64>,
}

/// The shading pass: irradiance times visibility at every primary hit, from every light,
/// averaged over each pixel's samples. Calls `progress(1)` per row.
fn shade(
    scene: &Scene,
    methods: &[Box<dyn LightShadowing>],
    hits: &[Option<SurfaceHit>],
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Shaded {
    let RenderSettings { width, height, spp, seed, .. } = *settings;
    let (w, h, spp_us) = (width as usize, height as usize, spp as usize);
    let lights = scene.lights.len();
    let mut radiance = vec![Vec3::ZERO; w * h];
    let mut visibility = vec![0.0f32; w * h * lights];
    let shading_points = AtomicU64::new(0);
    let shadow_queries = AtomicU64::new(0);
    let facing: Vec<AtomicU64> = (0..lights).map(|_| AtomicU64::new(0)).collect();
    let lit: Vec<AtomicU64> = (0..lights).map(|_| AtomicU64::new(0)).collect();
    radiance.par_chunks_mut(w).zip(visibility.par_chunks_mut(w * lights.max(1))).enumerate().for_each(
        |(y, (rad_row, vis_row))| {
            let (mut points, mut queries) = (0u64, 0u64);
            let (mut row_facing, mut row_lit) = (vec![0u64; lights], vec![0u64; lights]);
            for x in 0..w {
                let pixel_index = (y * w + x) as u64;
                let mut sum = Vec3::ZERO;
                let mut hit_count = 0u32;
                let vis_px = &mut vis_row[x * lights..(x + 1) * lights];
                vis_px.fill(0.0);
                for s in 0..spp_us {
                    let Some(hit) = &hits[(y * w + x) * spp_us + s] else { continue };
                    hit_count += 1;
                    points += 1;
                    let albedo = scene.albedo(hit);
                    for (k, light) in scene.lights.iter().enumerate() {
                        let e = light.irradiance_factor(hit.p, hit.n_shading);
                        if e <= 0.0 {
                            continue; // no light reaches: skip the shadow query
                        }
                        let q = ShadowQuery {
                            p: hit.p,
                            p_error: hit.p_error,
                            n_geom: hit.n_geom,
                            n_shading: hit.n_shading,
                            pixel: [x as u32, y as u32],
                            seed: stream_seed(&[seed, pixel_index, s as u64, k as u64, TAG_SHADOW]),
                        };
                        let v = methods[k].visibility(scene, &q);
                        debug_assert!((0.0..=1.0).contains(&v), "{} returned {v}", methods[k].name());
                        queries += 1;
                        row_facing[k] += 1;
                        row_lit[k] += u64::from(v > 0.0);
                        vis_px[k] += v;
                        sum += albedo * light.radiance * (e * v);
                    }
                }
                rad_row[x] = sum * (std::f32::consts::FRAC_1_PI / spp as f32);
                for v in vis_px.iter_mut() {
                    *v = if hit_count == 0 { -1.0 } else { *v / hit_count as f32 };
                }
            }
            shading_points.fetch_add(points, Ordering::Relaxed);
            shadow_queries.fetch_add(queries, Ordering::Relaxed);
            for k in 0..lights {
                facing[k].fetch_add(row_facing[k], Ordering::Relaxed);
                lit[k].fetch_add(row_lit[k], Ordering::Relaxed);
            }
            progress(1);
        },
    );
    Shaded {
        radiance,
        visibility,
        shading_points: shading_points.into_inner(),
        shadow_queries: shadow_queries.into_inner(),
        facing: facing.into_iter().map(AtomicU64::into_inner).collect(),
        lit: lit.into_iter().map(AtomicU64::into_inner).collect(),
    }
}
