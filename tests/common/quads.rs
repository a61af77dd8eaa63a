//! Scenes of rectangles for the rendering tests: small vector helpers, quads, boxes and a
//! light aimed at a point. Included with `#[path]` by the test files that build such scenes.
#![allow(dead_code)] // each test file uses its own subset

pub type V3 = [f64; 3];

pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn mul(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn cross(a: V3, b: V3) -> V3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
pub fn normalize(a: V3) -> V3 {
    mul(a, 1.0 / dot(a, a).sqrt())
}

/// A rectangle: corners `center +- u/2 +- v/2`, facing along u x v.
#[derive(Debug, Clone)]
pub struct Quad {
    pub center: V3,
    pub u: V3,
    pub v: V3,
}

/// A horizontal card facing up, half sizes `hx` x `hz`.
pub fn card(center: V3, hx: f64, hz: f64) -> Quad {
    Quad { center, u: [2.0 * hx, 0.0, 0.0], v: [0.0, 0.0, -2.0 * hz] }
}

/// A closed box without a bottom standing on y = 0, facing out: quads in the order top, +x,
/// -x, +z, -z.
pub fn box_on_floor(x: f64, z: f64, hx: f64, hz: f64, height: f64) -> Vec<Quad> {
    let h = 0.5 * height;
    vec![
        card([x, height, z], hx, hz),
        Quad { center: [x + hx, h, z], u: [0.0, 0.0, -2.0 * hz], v: [0.0, height, 0.0] },
        Quad { center: [x - hx, h, z], u: [0.0, 0.0, 2.0 * hz], v: [0.0, height, 0.0] },
        Quad { center: [x, h, z + hz], u: [2.0 * hx, 0.0, 0.0], v: [0.0, height, 0.0] },
        Quad { center: [x, h, z - hz], u: [-2.0 * hx, 0.0, 0.0], v: [0.0, height, 0.0] },
    ]
}

/// A closed box (six quads facing out) with its bottom at height `y0`.
pub fn closed_block(x: f64, y0: f64, z: f64, hx: f64, hz: f64, height: f64) -> Vec<Quad> {
    let mut quads = box_on_floor(x, z, hx, hz, height);
    for q in &mut quads {
        q.center[1] += y0;
    }
    quads.push(Quad { center: [x, y0, z], u: [2.0 * hx, 0.0, 0.0], v: [0.0, 0.0, 2.0 * hz] });
    quads
}

/// A square light of side `size` at `center`, emitting toward `target`.
pub fn light_toward(center: V3, target: V3, size: f64) -> Quad {
    let n = normalize(sub(target, center));
    let helper = if n[1].abs() < 0.9 { [0.0, 1.0, 0.0] } else { [1.0, 0.0, 0.0] };
    let u = normalize(cross(helper, n));
    let v = cross(n, u); // so that cross(u, v) = n
    Quad { center, u: mul(u, size), v: mul(v, size) }
}

/// Renders the scene file text `scene` (size x size pixels, 1 spp, pixel centres) with
/// `method` through `penumbra::run_render` into `dir`, and reads back its visibility AOV,
/// checking every pixel is -1 (a miss) or in [0, 1] (which NaN is not).
pub fn render_visibility(
    dir: &std::path::Path,
    tag: &str,
    scene: &str,
    method: &str,
    samples: u32,
    seed: u64,
    size: u32,
) -> Vec<f32> {
    render_visibility_with(dir, tag, scene, (method, None), samples, seed, size)
}

/// [`render_visibility`] with the method's settings given in code (code-only fields
/// included) when the pair's second half is set.
pub fn render_visibility_with(
    dir: &std::path::Path,
    tag: &str,
    scene: &str,
    (method, settings): (&str, Option<std::sync::Arc<dyn renderer::ShadowMethod>>),
    samples: u32,
    seed: u64,
    size: u32,
) -> Vec<f32> {
    let scene_path = dir.join(format!("{tag}.toml"));
    std::fs::write(&scene_path, scene).unwrap();
    let out = dir.join(format!("{tag}-{}-{samples}-{seed}.png", method));
    let args = penumbra::RenderArgs {
        scene: Some(scene_path),
        keys: penumbra::request::Overrides {
            shadows: Some(method.to_string()),
            method: settings,
            samples: Some(samples),
            width: Some(size),
            height: Some(size),
            spp: Some(1),
            // Direct light only: these renders hold the visibility of what the camera sees, and
            // the methods' counters are then those of the primary hits alone.
            max_depth: Some(2),
            shading: None,
        },
        seed,
        out: Some(out.clone()),
        aov: true,
        quiet: true,
        ..Default::default()
    };
    penumbra::run_render(&args).unwrap_or_else(|e| panic!("{tag} ({}): {e}", method));
    let img = image::open(out.with_extension("visibility.0.exr")).unwrap().into_rgb32f();
    assert_eq!((img.width(), img.height()), (size, size));
    let v: Vec<f32> = img.pixels().map(|p| p.0[0]).collect();
    for (i, &x) in v.iter().enumerate() {
        assert!(x == -1.0 || (0.0..=1.0).contains(&x), "{tag} ({}): pixel {i} has V = {x}", method);
    }
    v
}
