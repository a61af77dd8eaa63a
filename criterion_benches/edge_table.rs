//! The edge-table method (`shadow_plugin::edge_table`): its two kernels alone, on hand-made
//! inputs, and its full per-point path on the default scene. One thread (criterion's).
//!
//! - `mask_build/{small,large}/{256,1024}`: one `Mask::build`, i.e. one mask for one sub-pixel
//!   offset (0.375, 0.625), depth (a floor 2.2 below a 0.9 x 0.9 light, as in the default
//!   scene), set of stratified light samples (`mask_samples::stratified`), pitch and stop height.
//!   `small`: a 256^2 map over a +-1.5 field (pitch 0.0118) and an occluder 0.5 above the
//!   floor: rays cross 5.1 pixels on average, at most 10. `large`: a 512^2 map (the `fine`
//!   preset, pitch 0.0059) and an occluder 1.0 above the floor: 29 on average, at most 56-58.
//!   The samples are cloned, and the mask dropped, outside the timed part.
//! - `mask_query/{small,large}/{case}/{256,1024}`: one `Mask::query` of such a mask, against a
//!   hand-made map (`DepthMap::from_depths`, slabs 2 pixels thick) read as
//!   `Heightfield::Plates`, at the point the mask was built for; its stop height comes from
//!   `DepthMap::stop_depth`, as `EdgeTable::visibility` gets it, outside the timed loop.
//!   `flat`: a lit floor (an occluder in the map's corner only sets its nearest depth): region
//!   shrinking stops the rays below the floor (stop height < 0), the early-out path.
//!   `flat_unshrunk`: the same floor at the mask's full height (what a lit point pays when
//!   region shrinking cannot help): every pixel of the region is visited and skipped, no
//!   lookup. `plate`: a floating plate at the occluder's depth over a corner of the filter
//!   region (35-37% of the rays blocked), the penumbra path. `plate_depth_march`: the baseline,
//!   the same rays marched one by one (`depth_march::march_bits`); the bench asserts that it
//!   gives the query's bits.
//! - `visibility/{all,lit,penumbra,umbra,fallback}/{256,1024}`: `EdgeTable::visibility` with
//!   the default parameters (`balanced`: 256^2 map, 2 x 2 x 8 masks, nearest, plates),
//!   prepared on the default scene (`scenes/default.toml`, quads only) from the primary hits
//!   of a 160 x 120 frame at pixel centres, over those 19,200 hits: all, and split by how
//!   they are answered (fallback: by traced rays, all on the back wall; else by visibility
//!   1, (0, 1), 0). Throughput = points.
//!
//! Run: `cargo bench -p criterion_benches --bench edge_table` (about 1.5 minutes after the build). One group:
//! `cargo bench -p criterion_benches --bench edge_table -- mask_query` (the argument is a regex on the ids, e.g.
//! `-- mask_query/large/plate`). The setup prints each case's crossings, bytes, visible
//! rays and lookups on stderr.
//!
//! Measured on the shared 2-core VM, medians of one run (other builds were running: expect
//! 10-50% run-to-run noise, up to 2x on single cases); in brackets, the same ratio in two
//! other runs.
//!
//! | mask | samples | crossings | bytes | build | per crossing |
//! |---|---:|---:|---:|---:|---:|
//! | small | 256 | 1,314 | 32,820 | 170 us | 129 ns |
//! | small | 1024 | 5,223 | 187,296 | 940 us | 180 ns |
//! | large | 256 | 7,417 | 283,156 | 1.53 ms | 207 ns |
//! | large | 1024 | 29,686 | 803,900 | 5.0 ms | 168 ns |
//!
//! Queries, one later run (same VM), each with hierarchical block culling (the default) and,
//! in brackets, without it (`Mask::without_block_culling`, the `_unculled` ids), side by
//! side; the same bits either way (asserted):
//!
//! | query | 256 samples | 1024 samples |
//! |---|---:|---:|
//! | small / flat | 32 ns | 35 ns |
//! | small / flat_unshrunk | 118 ns (730 ns: 6.2x) | 128 ns (767 ns: 6.0x) |
//! | small / plate | 2.18 us (2.41 us) | 3.39 us (3.86 us) |
//! | small / plate_depth_march | 7.2 us (3.3x the query) | 31.6 us (9.3x) |
//! | large / flat | 36 ns | 36 ns |
//! | large / flat_unshrunk | 1.83 us (14.8 us: 8.1x) | 1.82 us (18.7 us: 10.2x) |
//! | large / plate | 45.3 us (53.8 us) | 90.3 us (103.9 us) |
//! | large / plate_depth_march | 34.2 us (0.76x the query) | 181 us (2.0x) |
//!
//! Per-pixel in- and out-tables (one search each instead of one per side; ARCHITECTURE.md),
//! measured a few minutes after the per-side version on the same VM, so compared through
//! `plate_depth_march`, whose code did not change: the plate query went from 0.31x / 0.11x
//! of the march (small, 256 / 1024 samples) to 0.22x / 0.08x, and from 0.46x / 0.28x (large)
//! to 0.41x / 0.21x; mask bytes 33,400 / 187,892 / 294,268 / 818,040 to 54,328 / 428,376 /
//! 364,048 / 1,409,256 (small / large, 256 / 1024 samples; each crossing is in two tables),
//! build 215 us / 1.34 ms / 2.19 ms / 6.65 ms to 370 us / 2.12 ms / 2.26 ms / 9.30 ms. The
//! tables above are older runs, with per-side tables.
//!
//! The first run's queries (before block culling): small / flat_unshrunk 279 / 277 ns, small
//! / plate (118 / 130 lookups) 1.74 / 2.83 us, large / flat_unshrunk 4.9 / 6.5 us, large /
//! plate (2,446 / 3,836 lookups) 34.5 / 80 us; plate_depth_march 3.4x / 15x the query in
//! the small region, 0.84x / 1.76x in the large one.
//!
//! | visibility, per point | 256 samples | 1024 samples |
//! |---|---:|---:|
//! | all (19,200) | 612 ns | 1.41 us |
//! | lit (17,390 / 17,369) | 288 ns | 310 ns |
//! | penumbra (1,427 / 1,451) | 1.23 us | 1.66 us |
//! | umbra (97 / 94) | 1.25 us | 2.08 us |
//! | fallback (286) | 16 us | 72 us (63, 68 in other runs) |
//!
//! What they show: in a small region the query beats marching by 3.2-3.4x (256 samples) and
//! 8-15x (1024); in a large one it does not (0.68-0.84x at 256 samples, 1.7-2.0x at 1024):
//! the plate path does 2,446 / 3,836 lookups (for 7,417 / 29,686 crossings) at 14-21 ns
//! each. Block culling (8 x 8 pixel blocks skipped by a min-pyramid lookup when the highest
//! floor over them is below every crossing into them) makes a region of lit floor 6-10x
//! cheaper and the plate case 10-16% cheaper; on sauerbraten-zdm2 at 320x240 the whole
//! shadow cost fell from 14.0 s to 4.25 s (same image; 4 x 4 blocks 5.7 s, 16 x 16 5.6 s).
//! A lit point costs ~10x the flat query inside `visibility` (the rest of the per-point path
//! outside the kernel), and the 1.5% of points answered by traced rays take 40% (256) to
//! 55-75% (1024) of the frame's visibility time. `prepare` took 29 ms (256) and 57 ms
//! (1024) on 2 threads (32 masks, 1.2 MB and 6.5 MB; the `visibility` rows were measured
//! with the then default 4 x 4 x 2 grid, every mask built, before mirrored masks and four
//! depth levels). The default scene's own map is
//! coarser than `small` (pitch 0.027: the back wall widens the frustum), so its regions are
//! smaller still.

use criterion::{BatchSize, BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::ray::Ray;
use renderer::util::random::{Rng, stream_seed};
use renderer::{LightShadowing, PrepareContext, Scene, SceneFile, ShadingPoint, ShadowQuery};
use shadow_plugin::depth_map::MapPoint;
use shadow_plugin::depth_map::bits::{MAX_WORDS, count, words};
use shadow_plugin::depth_map::march::{for_each_crossing, stop_height};
use shadow_plugin::depth_map::mask_samples;
use shadow_plugin::depth_march::march_bits;
use shadow_plugin::{DepthMap, EdgeTable, EdgeTableParams, Heightfield, LightFrame, Mask};
use std::collections::HashSet;
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

/// The default scene's light: 0.9 m square.
const HALF: Vec2 = Vec2::splat(0.45);
/// The receiver (a floor facing the light) 2.2 m below it, as in the default scene.
const FLOOR_Z: f32 = 2.2;
/// The floor's depth bias in the map: what the former scene-scaled ray epsilon gave a scene
/// with an 18 m diagonal (a floor facing the light squarely has no slope term); kept so that
/// the bench's timings stay comparable (it times mask queries, not the bias).
const FLOOR_BIAS: f32 = 1.8e-4;
/// A 4 x 4 grid's mask offset (cell centre (1.5 / 4, 2.5 / 4)).
const OFFSET: Vec2 = Vec2::new(0.375, 0.625);
const SAMPLE_COUNTS: [usize; 2] = [256, 1024];
/// Slab thickness of the `plates` reading, in pixel footprints (the default).
const SLAB: f32 = 2.0;

/// A filter region: the map's pixel pitch (image-plane units), the depth the mask marches
/// up to (the nearest occluder's), and the size of the hand-made map the query reads.
struct Region {
    name: &'static str,
    pitch: f32,
    z_stop: f32,
    res: u32,
}

const REGIONS: [Region; 2] = [
    // 256^2 map over a +-1.5 field, occluder at the box top (0.5 m above the floor).
    Region { name: "small", pitch: 3.0 / 254.0, z_stop: 1.7, res: 64 },
    // 512^2 map (the `fine` preset) over the same field, occluder 1 m above the floor.
    Region { name: "large", pitch: 3.0 / 510.0, z_stop: 1.2, res: 128 },
];

fn light_samples(n: usize) -> Vec<Vec2> {
    let mut s = vec![Vec2::ZERO; n];
    mask_samples::stratified(&mut s, HALF, &mut Rng::new(stream_seed(&[7, 0, n as u64, 3])));
    s
}

fn h_stop(region: &Region) -> f32 {
    stop_height(region.z_stop, FLOOR_Z)
}

/// Crossings per ray (mean, max) and distinct pixels entered, counted with the mask
/// builder's own walk.
fn ray_stats(region: &Region, samples: &[Vec2]) -> (f64, usize, usize) {
    let (mut total, mut max) = (0usize, 0usize);
    let mut pixels = HashSet::new();
    for s in samples {
        let mut k = 0;
        for_each_crossing(OFFSET, *s, FLOOR_Z * region.pitch, h_stop(region), |c, _, _| {
            k += 1;
            pixels.insert(c);
            true
        });
        total += k;
        max = max.max(k);
    }
    (total as f64 / samples.len() as f64, max, pixels.len())
}

fn bench_build(c: &mut Criterion) {
    let mut group = c.benchmark_group("mask_build");
    group.sample_size(20).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(2));
    for region in &REGIONS {
        for n in SAMPLE_COUNTS {
            let samples = light_samples(n);
            let mask = Mask::build_for(
                Heightfield::Plates,
                OFFSET,
                FLOOR_Z,
                samples.clone(),
                region.pitch,
                h_stop(region),
            );
            let (mean, max, pixels) = ray_stats(region, &samples);
            eprintln!(
                "mask {}/{n}: pitch {:.5}, h_stop {:.4}: {} crossings ({mean:.1} per ray, max {max}), \
                 {pixels} pixels entered, {} bytes",
                region.name,
                region.pitch,
                h_stop(region),
                mask.crossings(),
                mask.bytes()
            );
            group.bench_function(BenchmarkId::new(region.name, n), |b| {
                b.iter_batched(
                    || samples.clone(),
                    |s| {
                        Mask::build_for(
                            Heightfield::Plates,
                            black_box(OFFSET),
                            black_box(FLOOR_Z),
                            s,
                            black_box(region.pitch),
                            black_box(h_stop(region)),
                        )
                    },
                    BatchSize::SmallInput,
                )
            });
        }
    }
    group.finish();
}

/// A hand-made map for `region`: a floor at `FLOOR_Z` (biased), slabs `SLAB` pixels thick,
/// an occluder at `z_stop` in the map's corner (far outside the query's region: it only sets
/// the map's nearest depth, as in a scene with occluders elsewhere) and, if `plate`, a
/// floating plate at `z_stop` over the columns right of the query pixel and the rows from
/// half the region's reach below it: a corner of the plate inside the filter region.
fn map(region: &Region, plate: bool) -> (DepthMap, [i32; 2]) {
    let res = region.res as usize;
    let pixel = [res as i32 / 2, res as i32 / 2];
    let frame = LightFrame { origin: Vec3::ZERO, x: Vec3::X, y: Vec3::Y, z: Vec3::Z, half_size: HALF };
    let origin = Vec2::splat(-0.5 * res as f32 * region.pitch);
    let mut depth = vec![FLOOR_Z + FLOOR_BIAS; res * res];
    for y in 0..4 {
        for x in 0..4 {
            depth[y * res + x] = region.z_stop;
        }
    }
    if plate {
        let reach = (HALF.y * (1.0 / region.z_stop - 1.0 / FLOOR_Z) / region.pitch) as usize;
        for y in pixel[1] as usize - reach / 2..res {
            for x in pixel[0] as usize + 1..res {
                depth[y * res + x] = region.z_stop;
            }
        }
    }
    let bottom = depth.iter().map(|d| d * (1.0 + SLAB * region.pitch)).collect();
    let map = DepthMap::from_depths(frame, origin, region.pitch, region.res, depth).with_bottoms(bottom);
    (map, pixel)
}

fn bench_query(c: &mut Criterion) {
    let mut group = c.benchmark_group("mask_query");
    group
        .sample_size(30)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_millis(1500));
    let hf = Heightfield::Plates;
    for region in &REGIONS {
        for n in SAMPLE_COUNTS {
            let mask = Mask::build_for(hf, OFFSET, FLOOR_Z, light_samples(n), region.pitch, h_stop(region));
            let w = words(n);
            // (case, map, the stop height the query is asked for)
            let mut cases = Vec::new();
            let (flat, pixel) = map(region, false);
            // As the renderer asks it on a lit floor: region shrinking finds only the floor
            // below the point, so the stop height is <= 0 and no side is looked at.
            let (z_stop, _) = flat.stop_depth(pixel, FLOOR_Z);
            cases.push(("flat", flat.clone(), stop_height(z_stop, FLOOR_Z)));
            // The same floor with the mask's full height (no region shrinking, e.g. an
            // occluder's pyramid block overlapping the region): every pixel is visited and
            // skipped by its lowest crossing.
            cases.push(("flat_unshrunk", flat, mask.h_max));
            let (plate, _) = map(region, true);
            let (z_stop, _) = plate.stop_depth(pixel, FLOOR_Z);
            cases.push(("plate", plate, stop_height(z_stop, FLOOR_Z)));
            let plate_z_stop = z_stop;
            for (case, map, hs) in &cases {
                assert!(*hs <= mask.h_max);
                let mut out = [0u64; MAX_WORDS];
                let stats = mask.query(map, pixel, FLOOR_Z, *hs, hf, &mut out);
                let visible = count(&out[..w]);
                eprintln!(
                    "query {}/{case}/{n}: h_stop {hs:.4}, {visible} of {n} rays visible, {} lookups, \
                     early out {}",
                    region.name, stats.lookups, stats.early_out
                );
                match *case {
                    "plate" => assert!(visible > n as u32 / 10 && visible < n as u32 * 9 / 10),
                    _ => assert_eq!(visible, n as u32),
                }
                // With and without hierarchical culling of blocks, side by side (same bits).
                let unculled = mask.clone().without_block_culling();
                let mut out_unculled = [0u64; MAX_WORDS];
                unculled.query(map, pixel, FLOOR_Z, *hs, hf, &mut out_unculled);
                assert_eq!(out[..w], out_unculled[..w]);
                for (variant, m) in [("", &mask), ("_unculled", &unculled)] {
                    group.bench_function(
                        BenchmarkId::new(format!("{}/{case}{variant}", region.name), n),
                        |b| {
                            b.iter(|| {
                                m.query(
                                    black_box(map),
                                    black_box(pixel),
                                    black_box(FLOOR_Z),
                                    black_box(*hs),
                                    black_box(hf),
                                    black_box(&mut out),
                                )
                            })
                        },
                    );
                }
                if *case == "plate" {
                    // The baseline: the same rays marched one by one (`depth_march`), which
                    // must give the same bits.
                    let mp = MapPoint { pixel, offset: OFFSET, z: FLOOR_Z };
                    let mut marched = [0u64; MAX_WORDS];
                    march_bits(map, &mp, &mask.samples, plate_z_stop, hf, &mut marched[..w]);
                    assert_eq!(marched[..w], out[..w]);
                    let id = BenchmarkId::new(format!("{}/plate_depth_march", region.name), n);
                    group.bench_function(id, |b| {
                        b.iter(|| {
                            march_bits(
                                black_box(map),
                                black_box(&mp),
                                black_box(&mask.samples),
                                black_box(plate_z_stop),
                                black_box(hf),
                                black_box(&mut marched[..w]),
                            )
                        })
                    });
                }
            }
        }
    }
    group.finish();
}

/// The default scene (quads only, embedded in the repository) and the visibility queries of
/// a 160 x 120 frame at pixel centres, as the renderer makes them.
fn default_scene() -> (Scene, Vec<ShadingPoint>, Vec<ShadowQuery>) {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/default.toml"));
    let file = SceneFile::load(path).unwrap_or_else(|e| panic!("{e}"));
    let scene = Scene::load(&file, path).unwrap_or_else(|e| panic!("{e}"));
    let (w, h) = (160u32, 120u32);
    let light = scene.lights[0];
    let (mut visible, mut queries) = (Vec::new(), Vec::new());
    for y in 0..h {
        for x in 0..w {
            let d = scene.camera.ray_direction(x as f32 + 0.5, y as f32 + 0.5, w, h).normalize();
            let ray = Ray::new(Vec3A::from(scene.camera.position), Vec3A::from(d), 0.0, f32::INFINITY);
            let Some(hit) = scene.intersect(ray) else { continue };
            visible.push(hit.point);
            if light.irradiance_factor(hit.point.p, hit.point.n_shading) > 0.0 {
                queries.push(ShadowQuery {
                    point: hit.point,
                    pixel: [x, y],
                    seed: stream_seed(&[0, (y * w + x) as u64, 0, 0, 2]),
                    irradiance: 0.0,
                });
            }
        }
    }
    (scene, visible, queries)
}

fn bench_visibility(c: &mut Criterion) {
    let (scene, visible, queries) = default_scene();
    let mut group = c.benchmark_group("visibility");
    group.sample_size(10).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(2));
    for n in SAMPLE_COUNTS {
        let mut method = EdgeTable::new(EdgeTableParams::default(), n as u32);
        let ctx = PrepareContext {
            scene: &scene,
            light: &scene.lights[0],
            light_index: 0,
            visible: &visible,
            seed: 0,
            memory_budget_bytes: penumbra::memory::memory_budget_bytes().unwrap_or_else(|e| panic!("{e}")),
        };
        let t = Instant::now();
        method.prepare(&ctx).unwrap_or_else(|e| panic!("{e}"));
        let prepare = t.elapsed();
        // Each query's class: answered by traced rays (outside the map or needing a taller
        // mask), else lit, penumbra or umbra by its visibility.
        let fallbacks = |m: &EdgeTable| m.counters().iter().find(|c| c.0 == "fallbacks").map_or(0, |c| c.1);
        let mut classes: [(&str, Vec<ShadowQuery>); 4] =
            [("lit", vec![]), ("penumbra", vec![]), ("umbra", vec![]), ("fallback", vec![])];
        for q in &queries {
            let before = fallbacks(&method);
            let v = method.visibility(&scene, q);
            let k = if fallbacks(&method) > before {
                3
            } else if v >= 1.0 {
                0
            } else if v <= 0.0 {
                2
            } else {
                1
            };
            classes[k].1.push(*q);
        }
        let counters = method.counters();
        let counter = |k: &str| counters.iter().find(|c| c.0 == k).map_or(0, |c| c.1);
        eprintln!(
            "visibility/{n}: prepare {:.1} ms ({} threads), {} masks, {} mask bytes; {} queries: {}; \
             early outs {}, edge lookups {}",
            prepare.as_secs_f64() * 1e3,
            rayon::current_num_threads(),
            counter("masks_built"),
            counter("mask_bytes"),
            queries.len(),
            classes.iter().map(|(c, qs)| format!("{} {c}", qs.len())).collect::<Vec<_>>().join(", "),
            counter("early_outs"),
            counter("edge_lookups"),
        );
        let all = ("all", queries.clone());
        for (subset, qs) in std::iter::once(&all).chain(&classes) {
            group.throughput(Throughput::Elements(qs.len() as u64));
            group.bench_function(BenchmarkId::new(*subset, n), |b| {
                b.iter(|| qs.iter().map(|q| method.visibility(&scene, black_box(q))).sum::<f32>())
            });
        }
    }
    group.finish();
}

criterion_group! {
    name = benches;
    // Fewer bootstrap resamples than the default 100,000: the analysis otherwise takes
    // about a second per benchmark on this machine.
    config = Criterion::default().nresamples(10_000);
    targets = bench_build, bench_query, bench_visibility
}
criterion_main!(benches);
