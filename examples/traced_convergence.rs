//! How fast `traced` converges with its sample count, per scene: renders each scene with
//! `traced` at N = 64, 256 and 1024 and at 16384 (another seed: the reference), and prints
//! the largest |V_1024 - V_16384| over lit pixels, the visibility RMSE of each N against the
//! reference, and the slope of log RMSE against log N (least squares over the three N).
//!
//! ```sh
//! cargo run --release --example traced_convergence -- [--width W] [--height H] SCENE.toml...
//! ```
//!
//! Defaults: 160 x 120, 1 spp, pixel centres; `scenes/default.toml` and every
//! `scenes/gltf/*.toml` when no scene is named. Lit pixels: those whose unshadowed
//! irradiance from the light is non-zero (`none` returns V = 1 there), every light pooled.

use renderer::{LightShadowing, RenderSettings, Scene, SceneFile, Traced, TracedParams, Unshadowed, render};
use std::path::PathBuf;
use std::time::Instant;

const SAMPLES: [u32; 3] = [64, 256, 1024];
const REFERENCE: u32 = 16384;

fn run(scene: &Scene, make: &dyn Fn() -> Box<dyn LightShadowing>, settings: &RenderSettings) -> Vec<f32> {
    let mut methods: Vec<_> = scene.lights.iter().map(|_| make()).collect();
    let frame = render(scene, &mut methods, settings, &|_| {}).expect("prepare succeeds");
    frame.visibility.concat()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut width, mut height) = (160u32, 120u32);
    let mut scenes = Vec::new();
    while let Some(a) = args.next() {
        let mut num = |name: &str| -> u32 {
            args.next().and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("{name} takes a number"))
        };
        match a.as_str() {
            "--width" => width = num("--width"),
            "--height" => height = num("--height"),
            _ => scenes.push(PathBuf::from(a)),
        }
    }
    if scenes.is_empty() {
        scenes.push(PathBuf::from("scenes/default.toml"));
        let mut gltf: Vec<_> = std::fs::read_dir("scenes/gltf")
            .expect("scenes/gltf")
            .map(|e| e.expect("a directory entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        gltf.sort();
        scenes.extend(gltf);
    }
    let settings = |seed| RenderSettings {
        width,
        height,
        spp: 1,
        seed,
        memory_budget_bytes: u64::MAX,
        profile: false,
        max_depth: 2,
    };
    println!("{width}x{height}, 1 spp; reference: traced {REFERENCE} (seed 1), the others seed 0\n");
    println!("| scene | lit px | max abs err 1024 | RMSE 64 | RMSE 256 | RMSE 1024 | slope | seconds |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for path in &scenes {
        let start = Instant::now();
        let file = SceneFile::load(path).unwrap_or_else(|e| panic!("{e}"));
        let scene = Scene::load(&file, path).unwrap_or_else(|e| panic!("{e}"));
        let lit = run(&scene, &|| Box::new(Unshadowed {}), &settings(0));
        let traced = |n: u32, seed: u64| {
            run(&scene, &|| Box::new(Traced::new(TracedParams::CULLED, n)), &settings(seed))
        };
        let reference = traced(REFERENCE, 1);
        let mut rmse = Vec::new();
        let mut max_err = 0.0f64;
        let mut count = 0usize;
        for &n in &SAMPLES {
            let v = traced(n, 0);
            let (mut se, mut m, mut k) = (0.0f64, 0.0f64, 0usize);
            for ((&l, &r), &x) in lit.iter().zip(&reference).zip(&v) {
                if l > 0.0 {
                    let d = (x - r) as f64;
                    se += d * d;
                    m = m.max(d.abs());
                    k += 1;
                }
            }
            rmse.push((se / k.max(1) as f64).sqrt());
            if n == 1024 {
                max_err = m;
            }
            count = k;
        }
        // Least-squares slope of ln RMSE against ln N.
        let xs: Vec<f64> = SAMPLES.iter().map(|&n| (n as f64).ln()).collect();
        let ys: Vec<f64> = rmse.iter().map(|r| r.max(1e-12).ln()).collect();
        let (mx, my) = (xs.iter().sum::<f64>() / 3.0, ys.iter().sum::<f64>() / 3.0);
        let slope = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum::<f64>()
            / xs.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        println!(
            "| {name} | {count} | {max_err:.4} | {:.5} | {:.5} | {:.5} | {slope:.2} | {:.0} |",
            rmse[0],
            rmse[1],
            rmse[2],
            start.elapsed().as_secs_f64()
        );
    }
}
