//! The frame: a primary pass (closest hits for every pixel sample), `prepare` per light, then
//! a shading pass (irradiance times visibility). Rayon over rows of pixels; every random
//! number is keyed by (seed, pixel, sample, light), so the bytes do not depend on the number
//! of threads.

use crate::geometry::material::Shading;
use crate::geometry::point::ShadingPoint;
use crate::geometry::scene::{Scene, SurfaceHit};
use crate::integrator::gltf_path;
use crate::integrator::path::{PathContext, PathId, VertexQueries, merge_vertex_queries};
use crate::integrator::tally::FrameTally;
use crate::interface::shadowing::{LightShadowing, PrepareContext, ShadowError};
use crate::util::pixel_cost::{PixelCost, Work};
use crate::util::random::{Rng, strata, stream_seed};
use glam::{Vec3, Vec3A};
use obvhs::ray::Ray;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::ops::Range;
use std::time::{Duration, Instant};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// 1 = one ray through each pixel centre; more = jittered stratified samples, box filter.
    pub spp: u32,
    pub seed: u64,
    /// Handed to every method's `prepare` ([`PrepareContext::memory_budget_bytes`]): the
    /// most bytes one light's method may hold. The command line reads it from the machine.
    pub memory_budget_bytes: u64,
    /// Measure each pixel's shading time and work ([`Frame::costs`]).
    pub profile: bool,
    /// Longest path, counted as Mitsuba 3 counts it ([`crate::integrator::path`]): 2 = direct light
    /// only, 5 = three indirect bounces.
    pub max_depth: u32,
}

/// What [`render`] reports as it goes, for a progress display.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// A phase begins: its name, and the rows it will report (0: none, show a spinner).
    Phase { name: &'static str, rows: u64 },
    /// `n` more rows of the current phase are done.
    Rows(u64),
}

/// Rows of pixels shaded as one unit of work (one span of the trace, one progress step):
/// small enough that two threads share even a 120-row image evenly.
pub const ROW_BAND: usize = 8;

/// What a frame produces: the whole frame, or the band of rows a tile asked for
/// ([`render_rows`]).
#[derive(Debug, Clone)]
pub struct Frame {
    /// The whole frame's size.
    pub width: u32,
    pub height: u32,
    /// The rows rendered (all of them unless a tile's band was asked for): the per-pixel
    /// buffers below hold `width x rows.len()` pixels, top row first.
    pub rows: Range<u32>,
    /// Linear radiance, row-major, top row first.
    pub radiance: Vec<Vec3>,
    /// Per light k: visibility at each pixel's primary hit in [0, 1] (the mean over the
    /// pixel's samples that hit; 0 where the light is below the horizon or faces away), or
    /// -1 where no primary ray hits anything.
    pub visibility: Vec<Vec<f32>>,
    /// Gathering the primary hits into the visible points the methods' `prepare` reads (0
    /// when none reads them: [`LightShadowing::reads_visible_points`]).
    pub visible_points: Duration,
    /// Every light's `prepare`.
    pub shadow_prepare: Duration,
    /// Wall time of the pixel loop: primary rays, shading and shadow queries (and the
    /// frame's assembly: visibility layers, warnings).
    pub render: Duration,
    /// Per pixel, with [`RenderSettings::profile`]: its shading time and shadow work.
    pub costs: Option<Vec<PixelCost>>,
    /// Shadow queries per path vertex (index 0 = the primary hit).
    pub vertex_queries: Vec<VertexQueries>,
    pub counters: BTreeMap<String, u64>,
    /// The counters as they stood when every `prepare` had run (the visible points, masks
    /// built, bytes held): the same in every tile of a frame, so tiles merge by summing
    /// `counters - prepare_counters` and adding these once.
    pub prepare_counters: BTreeMap<String, u64>,
    /// What the frame's warnings are made of, over the rows rendered.
    pub tally: FrameTally,
    /// Each method's warnings from its `prepare` ("light k: ..."): the same in every tile.
    pub method_warnings: Vec<String>,
    /// One line each: what makes this image suspect (nothing hit, no light reaching what the
    /// camera sees, visible geometry f32 cannot keep precise: [`FrameTally::warnings`]),
    /// then `method_warnings`. For a band of rows, the band's alone: a tile's are merged
    /// from the tallies.
    pub warnings: Vec<String>,
}

/// Stream tag of the primary samples' jitter (the others: [`crate::integrator::path`]).
const TAG_PRIMARY: u64 = 1;

/// Renders `scene` with one shadow method per light (`methods[k]` shadows `scene.lights[k]`).
/// `progress` is told each phase as it begins and the rows finished, from any thread.
/// Each phase is a `tracing` span (`primary_pass`, `visible_points`, `prepare` per light,
/// `shading` with a `rows` span per band).
///
/// # Errors
/// The first error a method's `prepare` reports.
pub fn render(
    scene: &Scene,
    methods: &mut [Box<dyn LightShadowing>],
    settings: &RenderSettings,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<Frame, ShadowError> {
    render_rows(scene, methods, settings, 0..settings.height, progress)
}

/// [`render`] for the band `rows` of the frame only (a tile): every method still prepares
/// with the whole frame's visible points (a depth map fitted to what the camera sees is the
/// same in every tile), so each pixel gets exactly the whole render's bytes.
///
/// # Errors
/// The first error a method's `prepare` reports.
pub fn render_rows(
    scene: &Scene,
    methods: &mut [Box<dyn LightShadowing>],
    settings: &RenderSettings,
    rows: Range<u32>,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<Frame, ShadowError> {
    assert_eq!(methods.len(), scene.lights.len(), "one shadow method per light");
    assert!(rows.start < rows.end && rows.end <= settings.height, "rows within the frame");
    let RenderSettings { width, height, spp, .. } = *settings;
    // Only for methods whose `prepare` reads them: `none`, `traced` and `silhouette` do not.
    // Those that do need the whole frame's primary hits, whatever the rows.
    let gather = methods.iter().any(|m| m.reads_visible_points());
    let hit_rows = if gather { 0..height } else { rows.clone() };

    let t_primary = Instant::now();
    progress(Progress::Phase { name: "primary rays", rows: hit_rows.len() as u64 });
    let hits =
        tracing::info_span!("primary_pass").in_scope(|| primary_hits(scene, settings, &hit_rows, progress));
    let primary_time = t_primary.elapsed();

    let t_gather = Instant::now();
    let visible = if gather { gather_visible(scene, &hits, settings, progress) } else { Vec::new() };
    let visible_points = t_gather.elapsed();

    let t_prepare = Instant::now();
    progress(Progress::Phase { name: "preparing the shadow method", rows: 0 });
    prepare_lights(scene, methods, &visible, settings)?;
    let mut prepare_counters = BTreeMap::from([("visible_points".to_string(), visible.len() as u64)]);
    add_method_counters(methods, &mut prepare_counters);
    drop(visible);
    let shadow_prepare = t_prepare.elapsed();

    let t_shade = Instant::now();
    progress(Progress::Phase { name: "shading", rows: rows.len() as u64 });
    let per_row = width as usize * spp as usize;
    let band =
        (rows.start - hit_rows.start) as usize * per_row..(rows.end - hit_rows.start) as usize * per_row;
    let band_hits = &hits[band];
    let shaded = tracing::info_span!("shading")
        .in_scope(|| shade(scene, methods, band_hits, rows.start as usize, settings, progress));

    let counters = frame_counters(methods, &shaded, prepare_counters["visible_points"], settings);
    let (pixels, lights) = (width as usize * rows.len(), scene.lights.len());
    let visibility =
        (0..lights).map(|k| (0..pixels).map(|i| shaded.visibility[i * lights + k]).collect()).collect();
    let mut tally = FrameTally::of_hits(scene, band_hits);
    tally.facing = shaded.facing;
    tally.lit = shaded.lit;
    let method_warnings: Vec<String> = methods
        .iter()
        .enumerate()
        .flat_map(|(k, m)| m.warnings().into_iter().map(move |w| format!("light {k}: {w}")))
        .collect();
    let warnings = tally.warnings().into_iter().chain(method_warnings.iter().cloned()).collect();
    let render = primary_time + t_shade.elapsed();
    Ok(Frame {
        width,
        height,
        rows,
        radiance: shaded.radiance,
        visibility,
        visible_points,
        shadow_prepare,
        render,
        costs: shaded.costs,
        vertex_queries: shaded.vertex_queries,
        counters,
        prepare_counters,
        tally,
        method_warnings,
        warnings,
    })
}

/// The visible points every method's `prepare` reads, from the whole frame's `hits`.
fn gather_visible(
    scene: &Scene,
    hits: &[Option<SurfaceHit>],
    settings: &RenderSettings,
    progress: &(dyn Fn(Progress) + Sync),
) -> Vec<ShadingPoint> {
    progress(Progress::Phase { name: "gathering visible points", rows: 0 });
    tracing::info_span!("visible_points").in_scope(|| {
        let mut v = visible_points(hits);
        // Paths query points the camera does not see: the first bounce of each pixel's
        // first sample (exactly the vertex its path will query), so depth maps cover them
        // too.
        if settings.max_depth > 2 {
            v.extend(first_bounces(scene, hits, settings));
        }
        v
    })
}

/// The frame's counters: the shading pass's, the points gathered, every method's, and with
/// paths the queries per vertex.
fn frame_counters(
    methods: &[Box<dyn LightShadowing>],
    shaded: &Shaded,
    gathered: u64,
    settings: &RenderSettings,
) -> BTreeMap<String, u64> {
    let mut counters = BTreeMap::from([
        ("shading_points".to_string(), shaded.shading_points),
        ("shadow_queries".to_string(), shaded.shadow_queries),
        ("visible_points".to_string(), gathered),
    ]);
    add_method_counters(methods, &mut counters);
    if settings.max_depth > 2 {
        for (i, v) in shaded.vertex_queries.iter().enumerate() {
            counters.insert(format!("shadow_queries_vertex_{}", i + 1), v.queries);
            counters.insert(format!("shadow_rays_vertex_{}", i + 1), v.rays);
            counters.insert(format!("shadow_queries_without_rays_vertex_{}", i + 1), v.without_rays);
            counters.insert(format!("shadow_fallbacks_vertex_{}", i + 1), v.fallbacks);
        }
    }
    counters
}

/// Adds every light's method counters into `counters`, summed over lights.
fn add_method_counters(methods: &[Box<dyn LightShadowing>], counters: &mut BTreeMap<String, u64>) {
    for m in methods {
        for (name, value) in m.counters() {
            *counters.entry(name.to_string()).or_insert(0) += value;
        }
    }
}

/// The primary pass over `rows`: the closest hit (or none) of every sample of every pixel,
/// at `((y - rows.start) * width + x) * spp + s`.
pub(crate) fn primary_hits(
    scene: &Scene,
    settings: &RenderSettings,
    rows: &Range<u32>,
    progress: &(dyn Fn(Progress) + Sync),
) -> Vec<Option<SurfaceHit>> {
    let RenderSettings { width, height, spp, seed, .. } = *settings;
    let (w, spp_us) = (width as usize, spp as usize);
    let mut hits: Vec<Option<SurfaceHit>> = vec![None; w * rows.len() * spp_us];
    let (sx, sy) = strata(spp);
    hits.par_chunks_mut(w * spp_us).enumerate().for_each(|(i, row)| {
        let y = rows.start as usize + i;
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
        progress(Progress::Rows(1));
    });
    hits
}

/// The first vertex after the primary hit of each pixel's first sample, as
/// [`crate::integrator::path::indirect`] will find it (the same random stream).
/// `hits` are the whole frame's.
fn first_bounces(scene: &Scene, hits: &[Option<SurfaceHit>], settings: &RenderSettings) -> Vec<ShadingPoint> {
    let RenderSettings { width, spp, seed, .. } = *settings;
    let (w, spp) = (width as usize, spp as usize);
    let rows: Vec<Vec<ShadingPoint>> = hits
        .par_chunks(w * spp)
        .enumerate()
        .map(|(y, row)| {
            (0..w)
                .filter_map(|x| {
                    let hit = row[x * spp].as_ref()?;
                    let pixel_index = (y * w + x) as u64;
                    let id = PathId { pixel: [x as u32, y as u32], pixel_index, sample: 0, seed };
                    let next = crate::integrator::path::bounce(scene, &hit.point, &mut id.bounce_rng())?;
                    Some(next.point)
                })
                .collect()
        })
        .collect();
    rows.concat()
}

/// Every primary hit as the point `prepare` reads.
fn visible_points(hits: &[Option<SurfaceHit>]) -> Vec<ShadingPoint> {
    // Counted first, so the vector is allocated once: grown by doubling, 33 M hits cost
    // 4.8 s here (copies and page faults of GBs), a parallel flattened collect 25 s.
    let count = hits.par_iter().filter(|h| h.is_some()).count();
    let mut out = Vec::with_capacity(count);
    out.extend(hits.iter().flatten().map(|hit| hit.point));
    out
}

/// Prepares every light's method with what the camera sees (every primary hit).
fn prepare_lights(
    scene: &Scene,
    methods: &mut [Box<dyn LightShadowing>],
    visible: &[ShadingPoint],
    settings: &RenderSettings,
) -> Result<(), ShadowError> {
    let RenderSettings { seed, memory_budget_bytes, .. } = *settings;
    // The budget was read before the frame began: what the primary hits and the lights
    // prepared so far hold is no longer free.
    let mut held = std::mem::size_of_val(visible) as u64;
    for (k, method) in methods.iter_mut().enumerate() {
        let ctx = PrepareContext {
            scene,
            light: &scene.lights[k],
            light_index: k,
            visible,
            seed,
            memory_budget_bytes: memory_budget_bytes.saturating_sub(held),
        };
        tracing::info_span!("prepare", light = k, method = method.name())
            .in_scope(|| method.prepare(&ctx))?;
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
    costs: Option<Vec<PixelCost>>,
    vertex_queries: Vec<VertexQueries>,
    shading_points: u64,
    shadow_queries: u64,
    /// Per light: shading points with non-zero irradiance from it.
    facing: Vec<u64>,
    /// Per light: shading points with non-zero irradiance and visibility.
    lit: Vec<u64>,
}

/// A band's tallies: shading points, per light the points facing it and those it reaches,
/// and the shadow queries per path vertex.
struct Tally {
    points: u64,
    facing: Vec<u64>,
    lit: Vec<u64>,
    vertices: Vec<VertexQueries>,
}

/// The shading pass: irradiance times visibility at every primary hit (`hits`: those of the
/// rows from `first_row` on), from every light, averaged over each pixel's samples. Bands of
/// `ROW_BAND` rows, each a `rows` span; `progress` hears of every band's rows.
fn shade(
    scene: &Scene,
    methods: &[Box<dyn LightShadowing>],
    hits: &[Option<SurfaceHit>],
    first_row: usize,
    settings: &RenderSettings,
    progress: &(dyn Fn(Progress) + Sync),
) -> Shaded {
    let RenderSettings { width, spp, profile, .. } = *settings;
    let (w, spp) = (width as usize, spp as usize);
    let h = hits.len() / (w * spp);
    let lights = scene.lights.len();
    let mut radiance = vec![Vec3::ZERO; w * h];
    let mut visibility = vec![0.0f32; w * h * lights];
    let mut costs = vec![PixelCost::default(); if profile { w * h } else { 0 }];
    // Without profiling the costs' chunks are empty: one per band all the same.
    let cost_chunk = if profile { w * ROW_BAND } else { 1 };
    let mut cost_chunks: Vec<&mut [PixelCost]> = costs.chunks_mut(cost_chunk).collect();
    cost_chunks.resize_with(h.div_ceil(ROW_BAND), Default::default);
    let tallies: Vec<Tally> = radiance
        .par_chunks_mut(w * ROW_BAND)
        .zip(visibility.par_chunks_mut(w * lights.max(1) * ROW_BAND))
        .zip(cost_chunks.into_par_iter())
        .enumerate()
        .map(|(band, ((rad, vis), cost))| {
            let y0 = first_row + band * ROW_BAND;
            let rows = rad.len() / w;
            let _span = tracing::info_span!("rows", y0, y1 = y0 + rows).entered();
            let mut tally = Tally {
                points: 0,
                facing: vec![0; lights],
                lit: vec![0; lights],
                vertices: vec![VertexQueries::default(); settings.max_depth.max(2) as usize - 1],
            };
            for i in 0..rad.len() {
                let (x, y) = (i % w, y0 + i / w);
                let vis_px = &mut vis[i * lights..(i + 1) * lights];
                let (t0, w0) =
                    if profile { (Some(Instant::now()), Work::now()) } else { (None, Work::default()) };
                let pixel = (y - first_row) * w + x;
                let pixel_hits = &hits[pixel * spp..(pixel + 1) * spp];
                rad[i] = shade_pixel(scene, methods, pixel_hits, settings, [x, y], vis_px, &mut tally);
                if let Some(t0) = t0 {
                    cost[i] = PixelCost { time_s: t0.elapsed().as_secs_f32(), work: Work::now().since(w0) };
                }
            }
            progress(Progress::Rows(rows as u64));
            tally
        })
        .collect();
    let sum = |f: &dyn Fn(&Tally) -> u64| tallies.iter().map(f).sum::<u64>();
    let mut vertex_queries = Vec::new();
    for t in &tallies {
        merge_vertex_queries(&mut vertex_queries, &t.vertices);
    }
    let shadow_queries = vertex_queries.iter().map(|v| v.queries).sum();
    Shaded {
        vertex_queries,
        radiance,
        visibility,
        costs: profile.then_some(costs),
        shading_points: sum(&|t| t.points),
        shadow_queries,
        facing: (0..lights).map(|k| sum(&|t| t.facing[k])).collect(),
        lit: (0..lights).map(|k| sum(&|t| t.lit[k])).collect(),
    }
}

/// One pixel's radiance (the mean over its samples' `hits`), its per-light visibility into
/// `vis_px` (-1 where no sample hits), its points and queries added to `tally`.
fn shade_pixel(
    scene: &Scene,
    methods: &[Box<dyn LightShadowing>],
    hits: &[Option<SurfaceHit>],
    settings: &RenderSettings,
    [x, y]: [usize; 2],
    vis_px: &mut [f32],
    tally: &mut Tally,
) -> Vec3 {
    let RenderSettings { width, spp, seed, profile, max_depth, .. } = *settings;
    let pixel_index = (y * width as usize + x) as u64;
    let ctx = PathContext { scene, methods, max_depth, profile };
    // The primary hits' direct light, summed as the direct-light renderer sums it (so
    // max_depth = 2 gives its bytes), and the paths' indirect light beside it.
    let (mut sum, mut indirect, mut gltf) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
    let mut hit_count = 0u32;
    vis_px.fill(0.0);
    for (s, hit) in hits.iter().enumerate() {
        let Some(hit) = hit else { continue };
        hit_count += 1;
        tally.points += 1;
        let id = PathId { pixel: [x as u32, y as u32], pixel_index, sample: s as u64, seed };
        if scene.shading_mode == Shading::Gltf {
            let (facing, lit) = (&mut tally.facing, &mut tally.lit);
            gltf += gltf_path::radiance(&ctx, hit, &id, &mut tally.vertices, |k, v| {
                facing[k] += 1;
                lit[k] += u64::from(v > 0.0);
                vis_px[k] += v;
            });
            continue;
        }
        let albedo = scene.albedo(hit);
        for (k, light) in scene.lights.iter().enumerate() {
            let e = light.irradiance_factor(hit.point.p, hit.point.n_shading);
            if e <= 0.0 {
                continue; // no light reaches: skip the shadow query
            }
            let v = crate::integrator::path::shadow_query(
                &ctx,
                &hit.point,
                (&id, k, 1),
                e,
                None,
                &mut tally.vertices,
            )
            .diffuse;
            tally.facing[k] += 1;
            tally.lit[k] += u64::from(v > 0.0);
            vis_px[k] += v;
            sum += albedo * light.radiance * (e * v);
        }
        if max_depth > 2 {
            indirect += crate::integrator::path::indirect(&ctx, &hit.point, albedo, &id, &mut tally.vertices);
        }
    }
    for v in vis_px.iter_mut() {
        *v = if hit_count == 0 { -1.0 } else { *v / hit_count as f32 };
    }
    if scene.shading_mode == Shading::Gltf {
        return gltf / spp as f32;
    }
    let direct = sum * (std::f32::consts::FRAC_1_PI / spp as f32);
    if max_depth > 2 { direct + indirect / spp as f32 } else { direct }
}
