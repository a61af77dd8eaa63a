//! Accuracy and cost of the depth-map shadow methods against the traced truth, side by side
//! in one run: the table in the README and in the edge-table issue's closing note.
//!
//! ```sh
//! cargo run --release --example shadow_accuracy -- [--width W] [--height H] [--samples N] \
//!     [--map-sizes 256,512] SCENE.toml...
//! ```
//!
//! `--map-sizes` lists the depth-map sizes of the nearest/trilinear x two-grid rows (the
//! default's own map stays 256^2): what a finer map buys on a scene and what it costs.
//!
//! Per scene: `traced` (the truth) and every configuration at the same sample count, 1 spp,
//! pixel centres. Errors are over pixels that see the light (unshadowed irradiance > 0):
//! visibility RMSE, RMSE over penumbra pixels (truth strictly between 0.02 and 0.98), 99th
//! percentile absolute error, leak rate (truth < 0.02, ours > 0.1, over pixels with truth <
//! 0.02) and false-shadow rate (truth > 0.98, ours < 0.9, over pixels with truth > 0.98).
//! Shadow cost = shadow_prepare + (render time - render time of `none`).

use renderer::{LightShadowing, RenderSettings, Scene, SceneFile, Traced, TracedParams, Unshadowed, render};
use shadow_plugin::{Blend, DepthMarch, EdgeTable, EdgeTableParams, Heightfield, PublishedParams, Reading};
use std::path::PathBuf;
use std::time::Duration;

struct Row {
    name: String,
    cost: Duration,
    errors: Errors,
    fallbacks: u64,
    mask_mb: f64,
}

#[derive(Default, Clone, Copy)]
struct Errors {
    rmse: f64,
    penumbra_rmse: f64,
    p99: f64,
    leak: f64,
    false_shadow: f64,
}

fn errors(truth: &[f32], ours: &[f32], lit: &[f32]) -> Errors {
    let (mut se, mut n, mut pse, mut pn) = (0.0, 0usize, 0.0, 0usize);
    let (mut dark, mut leaks, mut bright, mut false_shadows) = (0usize, 0usize, 0usize, 0usize);
    let mut abs = Vec::new();
    for ((&t, &o), &l) in truth.iter().zip(ours).zip(lit) {
        if l <= 0.0 || t < 0.0 {
            continue; // sees no light (or no surface)
        }
        let d = (o - t) as f64;
        se += d * d;
        n += 1;
        abs.push(d.abs());
        if t > 0.02 && t < 0.98 {
            pse += d * d;
            pn += 1;
        }
        if t < 0.02 {
            dark += 1;
            leaks += (o > 0.1) as usize;
        }
        if t > 0.98 {
            bright += 1;
            false_shadows += (o < 0.9) as usize;
        }
    }
    abs.sort_by(f64::total_cmp);
    Errors {
        rmse: (se / n.max(1) as f64).sqrt(),
        penumbra_rmse: (pse / pn.max(1) as f64).sqrt(),
        p99: abs.get((abs.len() as f64 * 0.99) as usize).copied().unwrap_or(0.0),
        leak: leaks as f64 / dark.max(1) as f64,
        false_shadow: false_shadows as f64 / bright.max(1) as f64,
    }
}

fn run(
    scene: &Scene,
    make: &dyn Fn() -> Box<dyn LightShadowing>,
    settings: &RenderSettings,
) -> renderer::Frame {
    let mut methods: Vec<_> = scene.lights.iter().map(|_| make()).collect();
    render(scene, &mut methods, settings, &|_| {}).expect("prepare succeeds")
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut width, mut height, mut samples) = (320u32, 240u32, 1024u32);
    let mut map_sizes = vec![256u32, 512];
    let mut scenes = Vec::new();
    while let Some(a) = args.next() {
        let mut num = |name: &str| -> u32 {
            args.next().and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("{name} takes a number"))
        };
        match a.as_str() {
            "--width" => width = num("--width"),
            "--height" => height = num("--height"),
            "--samples" => samples = num("--samples"),
            "--map-sizes" => {
                map_sizes = args
                    .next()
                    .and_then(|v| v.split(',').map(|n| n.trim().parse().ok().filter(|&n| n >= 4)).collect())
                    .unwrap_or_else(|| panic!("--map-sizes takes sizes >= 4, comma-separated"));
            }
            _ => scenes.push(PathBuf::from(a)),
        }
    }
    if scenes.is_empty() {
        scenes.push(PathBuf::from("scenes/default.toml"));
    }
    let memory_budget_bytes = penumbra::memory::memory_budget_bytes().unwrap_or_else(|e| panic!("{e}"));
    let settings =
        RenderSettings { width, height, spp: 1, seed: 0, memory_budget_bytes, profile: false, max_depth: 2 };
    let published =
        |p: PublishedParams| EdgeTableParams { reading: Reading::Published(p), ..EdgeTableParams::default() };
    let et = |res: u32, grid: [u32; 3], blend: Blend, heightfield: Heightfield| EdgeTableParams {
        resolution: res,
        grid,
        ..published(PublishedParams { blend, heightfield, ..PublishedParams::DEFAULT })
    };
    // The exact reading (the default), then the published reading's settings around its
    // previous default (what the rows below vary).
    let exact = EdgeTableParams::default();
    let dp = PublishedParams::DEFAULT;
    let d = published(dp);
    let mut configs: Vec<(String, EdgeTableParams)> =
        vec![("edge_table default (exact)".to_string(), exact), ("edge_table published".to_string(), d)];
    for &res in &map_sizes {
        for grid in [[4, 4, 4], [8, 8, 4]] {
            for blend in [Blend::Nearest, Blend::Trilinear] {
                configs.push((
                    format!("edge_table {res} {}x{}x{} {blend:?}", grid[0], grid[1], grid[2]).to_lowercase(),
                    et(res, grid, blend, dp.heightfield),
                ));
            }
        }
    }
    // The depth-spacing decision: the grid before 4 x 4 x 4 (two depth levels), and the
    // default's grid again at 256^2 (its twin row measures the run's timing noise).
    for grid in [[4, 4, 2], [2, 2, 8]] {
        configs.push((
            format!("edge_table 256 {}x{}x{} nearest", grid[0], grid[1], grid[2]),
            et(256, grid, Blend::Nearest, dp.heightfield),
        ));
    }
    for h in [Heightfield::Solid, Heightfield::Shells, Heightfield::Plates] {
        if h != dp.heightfield {
            configs.push((
                format!("edge_table default {h:?}").to_lowercase(),
                published(PublishedParams { heightfield: h, ..dp }),
            ));
        }
    }
    for slab in [0.0, 4.0] {
        configs.push((
            format!("edge_table default slab {slab}"),
            published(PublishedParams { slab_thickness: slab, ..dp }),
        ));
    }
    let mut open = d;
    open.switches.map.closed_volumes = false;
    configs.push(("edge_table default, closed_volumes off".to_string(), open));
    let offset = published(PublishedParams { normal_offset: 1.0, ..dp });
    configs.push(("edge_table default, normal_offset 1.0".to_string(), offset));
    let mut one_layer = d;
    one_layer.switches.map.hidden_layer = false;
    configs.push(("edge_table default, hidden_layer off".to_string(), one_layer));
    let no_grazing = published(PublishedParams { grazing_cos: 0.0, ..dp });
    configs.push(("edge_table default, grazing_cos 0 (off)".to_string(), no_grazing));
    let less_grazing = published(PublishedParams { grazing_cos: 0.2, ..dp });
    configs.push(("edge_table default, grazing_cos 0.2".to_string(), less_grazing));
    let mut all_lit = d;
    all_lit.switches.map.fit_shadowed = false;
    configs.push(("edge_table default, fit_shadowed off".to_string(), all_lit));
    let mut unmirrored = d;
    unmirrored.switches.mirrored = false;
    configs.push(("edge_table default, mirrored off".to_string(), unmirrored));

    for path in &scenes {
        let file = SceneFile::load(path).unwrap_or_else(|e| panic!("{e}"));
        let scene = Scene::load(&file, path).unwrap_or_else(|e| panic!("{e}"));
        let none = run(&scene, &|| Box::new(Unshadowed {}), &settings);
        let base = none.render;
        let lit = &none.visibility[0];
        // The truth: every ray traced. `traced` as it ships culls shafts: the same bits
        // (its error row must read 0), at its own cost; "vs traced" is against that one.
        let truth = run(&scene, &|| Box::new(Traced::new(TracedParams::PLAIN, samples)), &settings);
        let culled = run(&scene, &|| Box::new(Traced::new(TracedParams::CULLED, samples)), &settings);
        let cost = |f: &renderer::Frame| f.shadow_prepare + f.render.saturating_sub(base);
        let mut rows = vec![
            Row {
                name: format!("traced {samples}"),
                cost: cost(&culled),
                errors: errors(&truth.visibility[0], &culled.visibility[0], lit),
                fallbacks: 0,
                mask_mb: 0.0,
            },
            Row {
                name: format!("traced {samples} plain (the truth)"),
                cost: cost(&truth),
                errors: Errors::default(),
                fallbacks: 0,
                mask_mb: 0.0,
            },
        ];
        let march =
            run(&scene, &|| Box::new(DepthMarch::new(d.depth_map(), dp.heightfield, samples)), &settings);
        rows.push(Row {
            name: format!("depth_march {} {:?}", d.resolution, dp.heightfield).to_lowercase(),
            cost: cost(&march),
            errors: errors(&truth.visibility[0], &march.visibility[0], lit),
            fallbacks: march.counters.get("fallbacks").copied().unwrap_or(0),
            mask_mb: 0.0,
        });
        for (name, params) in &configs {
            let f = run(&scene, &|| Box::new(EdgeTable::new(*params, samples)), &settings);
            rows.push(Row {
                name: name.clone(),
                cost: cost(&f),
                errors: errors(&truth.visibility[0], &f.visibility[0], lit),
                fallbacks: f.counters.get("fallbacks").copied().unwrap_or(0),
                mask_mb: f.counters.get("mask_bytes").copied().unwrap_or(0) as f64 / 1048576.0,
            });
        }
        let points = truth.counters.get("shadow_queries").copied().unwrap_or(0);
        println!(
            "\n### {} ({}x{}, {} samples, {} shading points lit, {} triangles)\n",
            path.display(),
            width,
            height,
            samples,
            points,
            scene.stats.triangles
        );
        println!(
            "| method | shadow cost (s) | vs traced | vs plain | RMSE | penumbra RMSE | p99 | leak | false shadow | fallbacks | masks (MiB) |"
        );
        println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
        let traced_cost = rows[0].cost.as_secs_f64();
        let plain_cost = rows[1].cost.as_secs_f64();
        for r in &rows {
            let e = r.errors;
            println!(
                "| {} | {:.3} | {:.1}x | {:.1}x | {:.4} | {:.4} | {:.3} | {:.2}% | {:.3}% | {} | {:.1} |",
                r.name,
                r.cost.as_secs_f64(),
                traced_cost / r.cost.as_secs_f64().max(1e-9),
                plain_cost / r.cost.as_secs_f64().max(1e-9),
                e.rmse,
                e.penumbra_rmse,
                e.p99,
                100.0 * e.leak,
                100.0 * e.false_shadow,
                r.fallbacks,
                r.mask_mb
            );
        }
    }
}
