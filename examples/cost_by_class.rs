//! Where a render's shading time goes, per pixel class: lit (V = 1), penumbra, umbra (V = 0)
//! by the first light's visibility AOV, background (no hit). Reads the outputs of
//! `penumbra render --aov --profile --out PREFIX.png` and prints, per class, the pixels and
//! the sum (with its share) of each cost layer: time, rays, shafts and lookups (the method's
//! own unit of work: `silhouette`'s active edges, the edge tables' mask reads).
//!
//! ```sh
//! penumbra render scenes/bench/sauerbraten-zdm2.toml --shadows silhouette --samples 1024 \
//!     --width 320 --height 240 --max-depth 2 --aov --profile --out out/z.png
//! cargo run --release --example cost_by_class -- out/z
//! ```
//!
//! Time is the profile's (inflated by its own clock reads): read its shares, not its seconds.

use std::path::PathBuf;

const CLASSES: [&str; 4] = ["lit", "penumbra", "umbra", "background"];

fn class(v: f32) -> usize {
    if v < 0.0 {
        3
    } else if v == 0.0 {
        2
    } else if v == 1.0 {
        0
    } else {
        1
    }
}

fn main() {
    let Some(prefix) = std::env::args().nth(1).map(PathBuf::from) else {
        eprintln!("usage: cost_by_class PREFIX  (reads PREFIX.cost.exr and PREFIX.visibility.0.exr)");
        std::process::exit(2);
    };
    let path = |ext: &str| PathBuf::from(format!("{}.{ext}", prefix.display()));
    let vis =
        image::open(path("visibility.0.exr")).expect("the visibility AOV (render with --aov)").into_rgb32f();
    let cost =
        exr::prelude::read_all_flat_layers_from_file(path("cost.exr")).expect("the cost EXR (--profile)");
    let layer = &cost.layer_data[0];
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    let values: Vec<Vec<f32>> =
        layer.channel_data.list.iter().map(|c| c.sample_data.values_as_f32().collect()).collect();
    let classes: Vec<usize> = vis.pixels().map(|p| class(p.0[0])).collect();
    assert_eq!(classes.len(), values[0].len(), "the AOV and the cost EXR differ in size");
    let mut pixels = [0usize; 4];
    let mut sums = vec![[0f64; 4]; names.len()];
    for (k, &c) in classes.iter().enumerate() {
        pixels[c] += 1;
        for (sum, layer) in sums.iter_mut().zip(&values) {
            sum[c] += layer[k] as f64;
        }
    }
    println!("{}", prefix.display());
    for (c, name) in CLASSES.iter().enumerate() {
        let mut line = format!("{name:>10} {:>7} px", pixels[c]);
        for (sum, layer) in sums.iter().zip(&names) {
            let total: f64 = sum.iter().sum();
            let share = if total > 0.0 { 100.0 * sum[c] / total } else { 0.0 };
            let per_pixel = if pixels[c] > 0 { sum[c] / pixels[c] as f64 } else { 0.0 };
            line += &format!(" | {layer} {:.4e} ({share:.0}%, {per_pixel:.3e}/px)", sum[c]);
        }
        println!("{line}");
    }
}
