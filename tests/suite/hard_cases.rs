//! The `edge_table` shadow method on hard cases, against the traced truth: a light very close
//! to its receiver, a tiny light (the hard-shadow limit), a light larger than the scene,
//! receivers lit at a grazing angle, contact shadows, and the scene moved far from the origin
//! or scaled by 10^-3 and 10^3.
//!
//! Each case is a small scene of quads written as a scene file, rendered through
//! [`penumbra::run_render`] three times with the same primary rays (one per pixel centre):
//! `none` (which pixels the light reaches at all), `traced` and `edge_table` (its default
//! parameters: each scene's `[shadows.edge_table]` is empty, except the two grazing cases,
//! which also read the map alone with `grazing_cos = 0`, since by default their grazed
//! receivers are traced), both with [`SAMPLES`] samples. The
//! visibility AOVs are compared over the pixels the light reaches: no NaN, every value in
//! [0, 1], the traced image really has shadows in it (so no case passes vacuously), and the
//! error metrics stay within bounds measured on these scenes. Each bound's comment gives the
//! measured value; bounds are about 1.5-2x it, so a regression shows while sample noise and
//! small changes of the method's parameters do not.
//!
//! `cargo test --test suite hard_cases:: -- --nocapture` prints every case's metrics.
//!
//! The measured values quoted in the bounds' comments were taken with infinitely thin
//! plates (`slab_thickness = 0`). With the current default (slabs 2 pixels thick) the same
//! command prints: close light RMSE 0.049, p99 0.13, 0.16% off by > 0.5; grazing floor RMSE
//! 0.072, p99 0.25, max 0.35; contact feet: box max 0.06, bar max 0; moved/scaled base RMSE
//! 0.024, p99 0.10; large light RMSE 0.023, p99 0.078, max 0.20; tiny light unchanged. All
//! within the same bounds. With the grazing normal offset (0.5, the default since) the
//! close light's RMSE is 0.045, the contact scene has 0.31% of pixels off by > 0.5 (bound
//! raised to 0.5%, see there), and the grazing wall has no false shadow.
//!
//! Later defaults (depth levels at receiver-depth quantiles, closed volumes, normal offset
//! 1.0) printed: close light RMSE 0.019, p99 0.066; grazing floor RMSE 0.037, p99 0.12, max
//! 0.32; contact RMSE 0.053, p99 0.18, 0.38% off by > 0.5; moved/scaled base RMSE 0.0074,
//! p99 0.035; large light RMSE 0.024, p99 0.078, max 0.21; thick block RMSE 0.017, p99
//! 0.066. The bounds were kept: each still catches a regression to the older numbers.
//!
//! With grazed receivers traced (`grazing_cos` 0.2) and hierarchical culling, the command
//! prints: close light RMSE 0.012, p99 0.059; grazing floor (the map alone) RMSE 0.036, p99
//! 0.11, max 0.32, and with the policy 0.0066 / 0.020 / 0.20; contact RMSE 0.053, p99 0.18,
//! 0.38% off by > 0.5, foot max 0.039 (box) and 0 (bar); moved/scaled base RMSE 0.0074;
//! large light RMSE 0.025, p99 0.078, max 0.36; hidden block RMSE 0.038, p99 0.23; thick
//! block RMSE 0.016; grazing wall (the map alone) RMSE 0.022, no wall pixel off.
//!
//! The defaults now (2 x 2 x 8 masks, normal offset 0.5, grazing cosine 0.5, map fitted to
//! the shadowed receivers) give the values in the bounds' comments below. With the previous
//! grid, 4 x 4 x 4, every case was within 0.002 RMSE of them and the tiny light identical.

use crate::common::folders;
use folders::temp_dir;
use shadow_plugin::{EdgeTableParams, PublishedParams, Reading};
use std::path::Path;
use std::sync::Arc;

use crate::common::quads;
use quads::*;

/// Light samples per shading point, for both methods (edge_table: rays per mask).
const SAMPLES: u32 = 256;
/// Image side in pixels.
const SIZE: u32 = 80;

#[derive(Debug, Clone)]
struct Camera {
    position: V3,
    look_at: V3,
    up: V3,
    yfov_deg: f64,
}

#[derive(Debug, Clone)]
struct Scene {
    quads: Vec<Quad>,
    /// A rectangular light emitting toward normalize(cross(u, v)).
    light: Quad,
    camera: Camera,
    /// Extra `[shadows.edge_table]` lines ("" for the defaults).
    edge_table: &'static str,
}

impl Scene {
    fn toml(&self) -> String {
        let v = |a: V3| format!("[{:?}, {:?}, {:?}]", a[0], a[1], a[2]);
        let c = &self.camera;
        let mut s = format!(
            "[camera]\nposition = {}\nlook_at = {}\nup = {}\nyfov_deg = {:?}\n\n\
             [image]\nwidth = {SIZE}\nheight = {SIZE}\nspp = 1\n\n",
            v(c.position),
            v(c.look_at),
            v(c.up),
            c.yfov_deg
        );
        for q in &self.quads {
            s += &format!(
                "[[quad]]\ncenter = {}\nu = {}\nv = {}\ncolor = [0.7, 0.7, 0.7]\n\n",
                v(q.center),
                v(q.u),
                v(q.v)
            );
        }
        let l = &self.light;
        s += &format!(
            "[[light]]\ncenter = {}\nu = {}\nv = {}\nradiance = [4.0, 4.0, 4.0]\n\n",
            v(l.center),
            v(l.u),
            v(l.v)
        );
        s + &format!(
            "[shadows]\nmethod = \"edge_table\"\nsamples = {SAMPLES}\n[shadows.edge_table]\n{}\n",
            self.edge_table
        )
    }

    /// The same scene under p -> scale * p + offset (camera included).
    fn transformed(&self, scale: f64, offset: V3) -> Self {
        let q = |q: &Quad| Quad {
            center: add(mul(q.center, scale), offset),
            u: mul(q.u, scale),
            v: mul(q.v, scale),
        };
        Scene {
            quads: self.quads.iter().map(q).collect(),
            light: q(&self.light),
            camera: Camera {
                position: add(mul(self.camera.position, scale), offset),
                look_at: add(mul(self.camera.look_at, scale), offset),
                ..self.camera.clone()
            },
            edge_table: self.edge_table,
        }
    }

    /// Cosine between the normal (on the camera's side) of the point seen at pixel (x, y)
    /// and the direction from it to the light's centre.
    fn facing_light(&self, x: u32, y: u32) -> Option<f64> {
        let (i, p) = self.hit(x, y)?;
        let q = &self.quads[i];
        let mut n = normalize(cross(q.u, q.v));
        if dot(n, sub(self.camera.position, p)) < 0.0 {
            n = mul(n, -1.0);
        }
        Some(dot(n, normalize(sub(self.light.center, p))))
    }

    /// The quad that the ray through the centre of pixel (x, y) hits first, and where: the
    /// renderer's pinhole camera, in f64.
    fn hit(&self, x: u32, y: u32) -> Option<(usize, V3)> {
        let c = &self.camera;
        let forward = normalize(sub(c.look_at, c.position));
        let right = normalize(cross(forward, c.up));
        let up = cross(right, forward);
        let t = (0.5 * c.yfov_deg.to_radians()).tan();
        let ndc_x = 2.0 * (x as f64 + 0.5) / SIZE as f64 - 1.0;
        let ndc_y = 1.0 - 2.0 * (y as f64 + 0.5) / SIZE as f64;
        let d = add(forward, add(mul(right, ndc_x * t), mul(up, ndc_y * t)));
        let mut best: Option<(f64, usize, V3)> = None;
        for (i, q) in self.quads.iter().enumerate() {
            let n = cross(q.u, q.v);
            let s = dot(n, sub(q.center, c.position)) / dot(n, d);
            // Parallel rays give s = +-inf or NaN: skipped like hits behind the camera.
            if !s.is_finite() || s <= 0.0 || best.is_some_and(|b| b.0 <= s) {
                continue;
            }
            let p = add(c.position, mul(d, s));
            let r = sub(p, q.center);
            if (dot(r, q.u) / dot(q.u, q.u)).abs() <= 0.5 && (dot(r, q.v) / dot(q.v, q.v)).abs() <= 0.5 {
                best = Some((s, i, p));
            }
        }
        best.map(|b| (b.1, b.2))
    }
}

/// The floor: y = 0, half sizes `hx` x `hz`, facing up.
fn floor(hx: f64, hz: f64) -> Quad {
    card([0.0; 3], hx, hz)
}

fn camera(position: V3, look_at: V3) -> Camera {
    Camera { position, look_at, up: [0.0, 1.0, 0.0], yfov_deg: 40.0 }
}

/// A visibility AOV, row-major: -1 where the primary ray misses.
struct Vis(Vec<f32>);

impl Vis {
    fn at(&self, x: u32, y: u32) -> f32 {
        self.0[(y * SIZE + x) as usize]
    }
}

/// Renders `scene` with `method` and reads back its visibility AOV, checking every pixel is
/// -1 (a miss) or in [0, 1] (which NaN is not).
fn render(dir: &Path, tag: &str, scene: &Scene, method: &str) -> Vis {
    Vis(render_visibility(dir, tag, &scene.toml(), method, SAMPLES, 0, SIZE))
}

/// A scene's renders: `none` (1 where the light reaches the pixel's point, 0 where it does
/// not, -1 on a miss), the truth and the method under test.
struct Renders {
    reach: Vis,
    traced: Vis,
    edge: Vis,
}

impl Renders {
    fn new(dir: &Path, tag: &str, scene: &Scene) -> Self {
        Self {
            reach: render(dir, tag, scene, "none"),
            traced: render(dir, tag, scene, "traced"),
            edge: render(dir, tag, scene, "edge_table"),
        }
    }

    /// Whether the light reaches the point seen at pixel (x, y).
    fn lit(&self, x: u32, y: u32) -> bool {
        self.reach.at(x, y) == 1.0
    }
}

/// The error of one visibility image against another over the pixels the light reaches.
#[derive(Debug, Clone, Copy)]
struct Metrics {
    /// Pixels compared.
    pixels: usize,
    /// Share of them in shadow (V < 0.5) in the reference.
    shadowed: f64,
    rmse: f64,
    /// 99th percentile of |error|.
    p99: f64,
    max: f64,
    /// Share of pixels with |error| > 0.5.
    over_half: f64,
    /// Mean signed error (test - reference): > 0 is too bright.
    bias: f64,
}

fn compare(reach: &Vis, reference: &Vis, test: &Vis) -> Metrics {
    let mut errors = Vec::new();
    let (mut shadowed, mut sum) = (0, 0.0);
    for ((&r, &a), &b) in reach.0.iter().zip(&reference.0).zip(&test.0) {
        assert!((r == -1.0) == (a == -1.0) && (r == -1.0) == (b == -1.0), "different primary hits");
        if r != 1.0 {
            continue; // a miss, or a point the light does not reach (V = 0 for every method)
        }
        shadowed += (a < 0.5) as usize;
        let d = b as f64 - a as f64;
        sum += d;
        errors.push(d.abs());
    }
    let n = errors.len();
    assert!(n > 0, "no pixel the light reaches");
    errors.sort_by(f64::total_cmp);
    Metrics {
        pixels: n,
        shadowed: shadowed as f64 / n as f64,
        rmse: (errors.iter().map(|d| d * d).sum::<f64>() / n as f64).sqrt(),
        p99: errors[(n - 1) * 99 / 100],
        max: errors[n - 1],
        over_half: errors.iter().filter(|&&d| d > 0.5).count() as f64 / n as f64,
        bias: sum / n as f64,
    }
}

/// Renders a case, checks that it is worth testing (the light reaches at least a quarter of
/// the frame, and at least 5% of those pixels have V < 0.5 in truth) and returns the renders
/// and edge_table's error.
fn run_case(dir: &Path, name: &str, scene: &Scene) -> (Renders, Metrics) {
    let r = Renders::new(dir, name, scene);
    let m = compare(&r.reach, &r.traced, &r.edge);
    eprintln!("{name}: {m:?}");
    assert!(m.pixels > (SIZE * SIZE / 4) as usize, "{name}: too few lit pixels: {m:?}");
    assert!(m.shadowed > 0.05, "{name}: too little shadow in frame to test: {m:?}");
    (r, m)
}

/// Floor, a box standing on it and a floating card, lit by a 0.8 x 0.8 light from above and
/// to the side (no surface is lit at a grazing angle).
fn standard_scene(light_size: f64) -> Scene {
    let mut quads = vec![floor(2.0, 2.0)];
    quads.extend(box_on_floor(-0.5, -0.2, 0.25, 0.25, 0.5));
    quads.push(card([0.6, 0.6, 0.3], 0.3, 0.3));
    Scene {
        quads,
        light: light_toward([1.2, 2.5, 1.2], [0.0, 0.0, 0.0], light_size),
        camera: camera([0.0, 3.2, 3.2], [0.0, 0.0, 0.0]),
        edge_table: "",
    }
}

#[test]
fn light_very_close_to_the_receiver() {
    let dir = temp_dir("close");
    // A 0.2 x 0.2 light 0.1 above the floor (half its size), a card halfway between them and
    // a low box beside it: receivers from straight below the light to ~80 deg off its axis.
    let mut quads = vec![floor(2.0, 2.0)];
    quads.push(card([0.1, 0.05, 0.05], 0.05, 0.05));
    quads.extend(box_on_floor(-0.17, -0.05, 0.03, 0.08, 0.05));
    let scene = Scene {
        quads,
        light: light_toward([0.0, 0.1, 0.0], [0.0, 0.0, 0.0], 0.2),
        camera: camera([0.0, 1.0, 0.5], [0.0, 0.0, 0.0]),
        edge_table: "",
    };
    let (_, m) = run_case(&dir, "close", &scene);
    // Measured: RMSE 0.0066, p99 0, max 0.28 (0.012, 0.062, 0.12 with grazed receivers
    // traced only below the cosine 0.2). (Before the map was fitted to the shadowed
    // receivers: RMSE 0.053, p99 0.23, mostly the box's shadow, up to ~0.4 too bright near
    // its foot, where a ray passing under the box's top and out of its side was not blocked.)
    assert!(m.rmse < 0.08, "{m:?}");
    assert!(m.p99 < 0.35, "{m:?}");
    // Measured: no pixel off by more than 0.5 (before the fitted map: 6, all on the top row
    // of the box's +z wall, which the light grazes: the defect
    // `wall_lit_at_a_grazing_angle_has_no_false_shadow` isolates). Bounded so that it does
    // not spread.
    assert!(m.over_half < 0.003, "{m:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn tiny_light_gives_a_hard_shadow_wrong_only_along_its_edge() {
    let dir = temp_dir("tiny");
    // The standard scene under a 0.004 x 0.004 light: shadows with a penumbra of a few
    // thousandths, well under a pixel.
    let scene = standard_scene(0.004);
    let (r, m) = run_case(&dir, "tiny", &scene);
    // Every pixel that is off by more than 0.5 must lie on the hard edge: within one pixel
    // of a traced pixel on the other side of V = 0.5.
    let mut off_edge = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (t, e) = (r.traced.at(x, y), r.edge.at(x, y));
            if !r.lit(x, y) || (e - t).abs() <= 0.5 {
                continue;
            }
            let near_edge = (y.saturating_sub(1)..(y + 2).min(SIZE)).any(|j| {
                (x.saturating_sub(1)..(x + 2).min(SIZE)).any(|i| {
                    let n = r.traced.at(i, j);
                    n >= 0.0 && (n < 0.5) != (t < 0.5)
                })
            });
            if !near_edge {
                off_edge.push((x, y, t, e, scene.hit(x, y)));
            }
        }
    }
    assert!(
        off_edge.is_empty(),
        "wrong pixels away from the shadow edge (x, y, traced, edge_table, hit): {off_edge:?}"
    );
    // Measured: 6 pixels (0.11%) off by more than 0.5, RMSE 0.034 (those pixels), p99 0
    // (everything off the edge is exact: V is 0 or 1 in both).
    assert!(m.over_half < 0.005, "{m:?}");
    assert!(m.rmse < 0.08, "{m:?}");
    assert!(m.p99 < 0.05, "{m:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn light_larger_than_the_scene() {
    let dir = temp_dir("large");
    // A 6 x 6 light 1.2 above a 3 x 3 floor with a low table (a 1.2 x 1.2 card 0.25 up) and
    // a box in a corner: broad, very soft shadows, the deepest (V ~ 0.1) under the table,
    // which the camera looks under.
    let mut quads = vec![floor(1.5, 1.5)];
    quads.push(card([0.0, 0.25, 0.0], 0.6, 0.6));
    quads.extend(box_on_floor(0.9, -0.9, 0.25, 0.25, 0.5));
    let scene = Scene {
        quads,
        light: light_toward([0.0, 1.2, 0.0], [0.0, 0.0, 0.0], 6.0),
        camera: camera([0.3, 0.9, 3.0], [0.0, 0.1, 0.0]),
        edge_table: "",
    };
    let (_, m) = run_case(&dir, "large", &scene);
    // Measured: RMSE 0.019, p99 0.066, max 0.38 (beside the box), mean error -0.006.
    assert!(m.rmse < 0.045, "{m:?}");
    assert!(m.bias.abs() < 0.015, "{m:?}");
    assert!(m.p99 < 0.15, "{m:?}");
    assert!(m.max < 0.6, "{m:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The floor lit at 73-85 deg: read through the map alone (`grazing_cos = 0`), and with the
/// default grazing policy, under which the points lit beyond 78 deg are traced.
#[test]
fn floor_lit_at_a_grazing_angle() {
    let dir = temp_dir("grazing_floor");
    // A 0.5 x 0.5 light 0.6 above the floor and 3.5 to the side of the frame's centre, facing
    // it: the floor is lit at 73-85 deg from its normal; a box and a card cast long shadows.
    let mut quads = vec![floor(3.0, 2.0)];
    quads.extend(box_on_floor(-1.5, 0.0, 0.15, 0.3, 0.3));
    quads.push(card([-1.0, 0.25, 1.0], 0.2, 0.2));
    let scene = Scene {
        quads,
        light: light_toward([-3.5, 0.6, 0.0], [0.0, 0.0, 0.0], 0.5),
        camera: camera([0.5, 3.5, 3.5], [0.0, 0.0, 0.0]),
        // The published reading (its grazing policy is what this case measures).
        edge_table: "reading = \"published\"\ngrazing_cos = 0.0",
    };
    let (map_alone, m) = run_case(&dir, "grazing_floor", &scene);
    // Measured: RMSE 0.016, p99 0.066, max 0.094 with eight depth levels (0.016, 0.063, 0.12
    // with four; 0.020, 0.078, 0.19 with two; 0.065, 0.21, 0.30 before depth levels at
    // receiver-depth quantiles): the penumbrae are banded and shifted along the light's
    // direction, because the receivers span 3x in depth. No pixel is off by half.
    assert!(m.rmse < 0.1, "{m:?}");
    assert!(m.p99 < 0.32, "{m:?}");
    assert!(m.max < 0.5, "{m:?}");

    // The default policy: pixels whose point faces the light's centre at a cosine below
    // DEFAULT_GRAZING_COS are the traced truth to the bit (the fallback draws the same
    // samples from the same seed), and the report counts exactly them.
    let policy = Scene { edge_table: "reading = \"published\"", ..scene.clone() };
    let edge = render(&dir, "grazing_floor_policy", &policy, "edge_table");
    let limit = f64::from(shadow_plugin::depth_map::DEFAULT_GRAZING_COS);
    let (mut grazed, mut borderline) = (0u64, 0u64);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let Some(cos) = policy.facing_light(x, y).filter(|_| map_alone.lit(x, y)) else { continue };
            if (cos - limit).abs() < 1e-4 {
                borderline += 1;
            } else if cos < limit {
                grazed += 1;
                assert_eq!(edge.at(x, y), map_alone.traced.at(x, y), "pixel ({x}, {y}), cos {cos}");
            }
        }
    }
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join(format!("grazing_floor_policy-edge_table-{SAMPLES}-0.json")))
            .unwrap(),
    )
    .unwrap();
    let counted = report["counters"]["fallbacks_grazing"].as_u64().unwrap();
    eprintln!("grazing floor, default policy: {grazed} grazed pixels, {counted} counted");
    assert!(grazed > (SIZE * SIZE / 10) as u64, "only {grazed} grazed pixels: the case tests nothing");
    assert!((grazed..=grazed + borderline).contains(&counted), "{counted} counted, {grazed} grazed");
    let with_policy = compare(&map_alone.reach, &map_alone.traced, &edge);
    eprintln!("grazing floor, default policy: {with_policy:?}");
    // Measured: all 5,074 lit pixels grazed at the default cosine 0.5 (the floor is lit at
    // 73-85 deg), so the policy reads the truth: RMSE 0. (At 0.2: 4,018 grazed, RMSE
    // 0.0018, p99 0.008, max 0.05, the rest of the floor through the map.)
    assert!(with_policy.rmse < m.rmse, "{with_policy:?} vs the map alone {m:?}");
    assert!(with_policy.max < 0.5, "{with_policy:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn thick_closed_occluder_blocks_rays_passing_under_its_top() {
    let dir = temp_dir("thick_block");
    // A closed block 0.4 thick floating 0.2 above the floor, lit from 45 deg: many shadow rays
    // from the floor enter it through its bottom and leave through its side, under its top
    // surface (the only one the depth map sees). Its interior is solid in the map from the
    // top face down to the bottom face (the closed-volume second layer).
    let mut quads = vec![floor(2.0, 2.0)];
    quads.extend(closed_block(0.0, 0.15, 0.0, 0.3, 0.3, 0.6));
    let scene = Scene {
        quads,
        light: light_toward([1.8, 1.3, 0.3], [0.0, 0.0, 0.0], 0.6),
        camera: camera([0.0, 3.0, 3.0], [0.2, 0.0, 0.0]),
        edge_table: "",
    };
    let (_, m) = run_case(&dir, "thick_block", &scene);
    // Measured: RMSE 0.0064, p99 0, max 0.46, no pixel off by 0.5. Reading the block as a
    // thin top plate (`closed_volumes = false`) gave RMSE 0.095 and 3.4% of the pixels off
    // by more than 0.5 (measured before the fitted map): the leak under the top surface.
    assert!(m.rmse < 0.05, "{m:?}");
    assert!(m.p99 < 0.2, "{m:?}");
    assert!(m.over_half < 0.003, "{m:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn occluder_hidden_under_a_card_still_casts_its_shadow() {
    let dir = temp_dir("hidden");
    // A 1.6 m light 2.5 m up, a 0.6 m card at 1.5 m and under it a closed block (0.4 x 0.3 x
    // 0.4 at 0.6-0.9 m) that the card hides from the light's centre: the depth map's first
    // layer sees only the card. Rays from the floor beside it to the light's far side pass
    // under the card and through the block; only the hidden layer holds the block.
    let mut quads = vec![floor(2.0, 2.0)];
    quads.push(card([0.0, 1.5, 0.0], 0.3, 0.3));
    quads.extend(closed_block(0.0, 0.6, 0.0, 0.2, 0.2, 0.3));
    let scene = Scene {
        quads,
        light: light_toward([0.0, 2.5, 0.0], [0.0, 0.0, 0.0], 1.6),
        camera: camera([0.0, 2.2, 2.2], [0.0, 0.3, 0.0]),
        edge_table: "",
    };
    let (_, m) = run_case(&dir, "hidden", &scene);
    // Measured: RMSE 0.038, p99 0.23, no pixel off by more than 0.5 (before the fitted map:
    // RMSE 0.079, 2 pixels; and without the hidden layer then, RMSE 0.100, 9 pixels). Most
    // of the remaining error is on the card's top, too dark, with or without the layer: not
    // explained yet.
    assert!(m.rmse < 0.09, "{m:?}");
    assert!(m.over_half < 0.001, "{m:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn contact_shadows_have_no_gap() {
    let dir = temp_dir("contact");
    // A 0.5 box and a thin bar (0.1 wide, 0.04 tall) standing on the floor, lit from 37 deg
    // above the horizon: their shadows fall toward -x (and a little -z), and the camera looks
    // at the -x side of both, where the shadow starts at the foot.
    let mut quads = vec![floor(2.0, 2.0)];
    quads.extend(box_on_floor(0.0, 0.0, 0.25, 0.25, 0.5));
    quads.extend(box_on_floor(-0.35, 0.9, 0.05, 0.4, 0.04));
    let scene = Scene {
        quads,
        light: light_toward([2.0, 1.6, 1.0], [0.0, 0.0, 0.3], 0.5),
        camera: camera([-1.4, 1.1, 1.5], [-0.3, 0.0, 0.5]),
        edge_table: "",
    };
    let (r, m) = run_case(&dir, "contact", &scene);
    // Floor points right at the -x foot of each occluder, away from its ends: umbra in truth.
    // (x of the -x side, z range, how far out from the foot)
    for (name, x_side, z_range, reach) in
        [("box", -0.25, [-0.2, 0.2], 0.04), ("bar", -0.4, [0.55, 1.25], 0.02)]
    {
        let mut foot = Vec::new();
        for y in 0..SIZE {
            for x in 0..SIZE {
                if let Some((0, p)) = scene.hit(x, y)
                    && (x_side - reach..x_side).contains(&p[0])
                    && (z_range[0]..z_range[1]).contains(&p[2])
                {
                    foot.push((r.traced.at(x, y), r.edge.at(x, y)));
                }
            }
        }
        let traced_max = foot.iter().map(|f| f.0).fold(0.0f32, f32::max);
        let edge_max = foot.iter().map(|f| f.1).fold(0.0f32, f32::max);
        let edge_mean = foot.iter().map(|f| f.1).sum::<f32>() / foot.len().max(1) as f32;
        eprintln!(
            "contact {name}: {} foot pixels, traced max {traced_max}, edge_table max {edge_max} mean {edge_mean}",
            foot.len()
        );
        assert!(foot.len() >= 10, "{name}: only {} floor pixels at the foot", foot.len());
        assert!(traced_max < 0.1, "{name}: the foot is not in umbra in truth: {foot:?}");
        // Measured: the box's foot (23 pixels) and the bar's (50 pixels) read 0, as the
        // truth does (before the fitted map: max 0.12 and 0.11, means 0.055 and 0.034). No
        // gap (a gap would read ~1 there), but the umbra of a solid occluder can leak a
        // little (rays that leave through the side of its depth-map image);
        // `heightfield = "solid"` gives 0.
        assert!(edge_max < 0.25, "{name}: light gap at the foot: {foot:?}");
        assert!(edge_mean < 0.1, "{name}: light at the foot: {foot:?}");
    }
    // Measured: RMSE 0.021, p99 0.070, no pixel off by more than 0.5 (at the offset 1.0:
    // RMSE 0.026 and 1 pixel, the thin bar's penumbra, narrower than a depth-map pixel,
    // coming out as 0 or 1).
    assert!(m.rmse < 0.065, "{m:?}");
    assert!(m.p99 < 0.22, "{m:?}");
    // Measured: mean error +0.001 (the leaky umbra).
    assert!(m.bias.abs() < 0.012, "{m:?}");
    // With the grazing normal offset (0.5 pixel footprints, which fixed the false shadow on
    // grazing walls below) 18 pixels (0.31%) are off by more than 0.5, against 6 to 11
    // without it: the bar's sub-pixel penumbra moves by the offset; 22 (0.38%) at 1.0.
    // (Both before the fitted map; the default is 0.5 again, see ARCHITECTURE.md.)
    assert!(m.over_half < 0.005, "{m:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Was a defect (19 of 667 wall pixels off by up to 1.0 without the grazing normal offset:
/// the wall lay under the floor of the box's top in the map); 0 with it.
#[test]
fn wall_lit_at_a_grazing_angle_has_no_false_shadow() {
    let dir = temp_dir("grazing_wall");
    // A 0.5 box lit from 25 deg above the horizon, from nearly straight along +x: its +z wall
    // is lit at 84 deg from its normal and nothing stands between it and the light, so its
    // truth is V = 1 throughout. Seen from the light the wall is almost edge-on, just
    // below the silhouette of the box's top.
    let mut quads = vec![floor(2.0, 2.0)];
    quads.extend(box_on_floor(0.0, 0.0, 0.25, 0.25, 0.5));
    let (elevation, azimuth) = (25f64.to_radians(), 83f64.to_radians());
    let toward_light = [azimuth.sin() * elevation.cos(), elevation.sin(), azimuth.cos() * elevation.cos()];
    let wall_centre = [0.0, 0.25, 0.25];
    let scene = Scene {
        quads,
        light: light_toward(add(wall_centre, mul(toward_light, 2.5)), wall_centre, 0.5),
        camera: camera([-0.6, 1.0, 2.0], wall_centre),
        // The published reading's map alone: its default policy would trace the wall.
        edge_table: "reading = \"published\"\ngrazing_cos = 0.0",
    };
    let (r, m) = run_case(&dir, "grazing_wall", &scene);
    let mut wall = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            if r.lit(x, y) && scene.hit(x, y).is_some_and(|h| h.0 == 4) {
                wall.push((x, y, r.traced.at(x, y), r.edge.at(x, y)));
            }
        }
    }
    let wrong: Vec<_> = wall.iter().filter(|w| (w.3 - w.2).abs() > 0.1).collect();
    eprintln!("grazing wall: {} wall pixels, {} off by > 0.1: {wrong:?}", wall.len(), wrong.len());
    assert!(wall.len() > 300, "only {} wall pixels", wall.len());
    assert!(wall.iter().all(|w| w.2 > 0.99), "the wall is not fully lit in truth");
    // Measured: none of the 667 wall pixels off by more than 0.1 (a false shadow would read
    // up to 1.0 off: V = 0 on a fully lit wall).
    assert!(wrong.is_empty(), "{} of {} wall pixels wrong: {wrong:?}", wrong.len(), wall.len());
    // Measured: RMSE 0.0035, p99 0.008.
    assert!(m.rmse < 0.045, "{m:?}");
    assert!(m.p99 < 0.15, "{m:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Renders the standard scene and copies of it under p -> scale * p + offset: each copy's
/// edge_table image must match the original's (the method has no absolute length or
/// position in it) and, like it, the truth.
fn check_transformed(name: &str, transforms: &[(f64, V3)]) {
    let dir = temp_dir(name);
    let scene = standard_scene(0.8);
    let (base, m0) = run_case(&dir, &format!("{name}-base"), &scene);
    for (k, &(scale, offset)) in transforms.iter().enumerate() {
        let tag = format!("{name}-{k}");
        let (r, m) = run_case(&dir, &tag, &scene.transformed(scale, offset));
        let same = compare(&base.reach, &base.edge, &r.edge);
        let same_truth = compare(&base.reach, &base.traced, &r.traced);
        eprintln!(
            "{tag} (scale {scale}, offset {offset:?}) vs the original: edge_table {same:?}, traced {same_truth:?}"
        );
        // Measured: bit-identical images, edge_table's and traced's (the renderer recentres
        // the scene in f64 and every epsilon is relative). The bounds leave room for f32
        // rounding to flip a few rays or a mask choice (~0.1 at a pixel), not for acne or a
        // shifted shadow (method error here: RMSE 0.026).
        assert!(same.rmse < 0.005, "{tag}: edge_table changed: {same:?}");
        assert!(same.p99 < 0.01, "{tag}: edge_table changed: {same:?}");
        assert!(same.max < 0.25, "{tag}: edge_table changed: {same:?}");
        assert!(same_truth.rmse < 0.005, "{tag}: traced changed: {same_truth:?}");
        // As in the original scene.
        assert!(m.rmse < 0.04, "{tag}: {m:?}");
        assert!(m.p99 < 0.2, "{tag}: {m:?}");
    }
    // Measured: RMSE 0.0043, p99 0.020, max 0.11, mean error -0.0003 (before the map was
    // fitted to the shadowed receivers: RMSE 0.026, p99 0.125).
    assert!(m0.rmse < 0.04, "{m0:?}");
    assert!(m0.bias.abs() < 0.01, "{m0:?}");
    assert!(m0.p99 < 0.2, "{m0:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn scene_moved_far_from_the_origin() {
    check_transformed("moved", &[(1.0, [1e4, 1e4, 1e4])]);
}

#[test]
fn scene_scaled_by_a_thousandth_and_by_a_thousand() {
    check_transformed("scaled", &[(1e-3, [0.0; 3]), (1e3, [0.0; 3])]);
}

/// The published reading. A small box and card on a wide floor that fills the frame: fitting the map only to the
/// receivers something may shadow (`fit_shadowed`, the default) puts its pixels on the
/// shadows, while the floor far from them is answered exactly (its shafts are clear) by the
/// traced fallback.
#[test]
fn map_fitted_to_the_shadowed_receivers_is_finer_and_exact_elsewhere() {
    let dir = temp_dir("fit_shadowed");
    let mut quads = vec![floor(6.0, 6.0)];
    quads.extend(box_on_floor(-0.5, 0.0, 0.3, 0.3, 0.6));
    quads.push(card([0.6, 0.6, 0.2], 0.3, 0.3));
    let fitted = Scene {
        quads,
        light: light_toward([0.5, 2.0, 0.8], [0.0, 0.0, 0.0], 0.8),
        camera: camera([0.0, 2.6, 3.2], [0.0, 0.0, -0.3]),
        edge_table: "reading = \"published\"",
    };
    let (r, m_fitted) = run_case(&dir, "fitted", &fitted);
    // The whole lit frame fitted: a code-only switch (the scene file cannot turn it off).
    let mut all_lit = EdgeTableParams {
        reading: Reading::Published(PublishedParams::DEFAULT),
        ..EdgeTableParams::default()
    };
    all_lit.switches.map.fit_shadowed = false;
    let all_lit = Arc::new(all_lit);
    let edge = Vis(render_visibility_with(
        &dir,
        "all_lit",
        &fitted.toml(),
        ("edge_table", Some(all_lit)),
        SAMPLES,
        0,
        SIZE,
    ));
    let m_all = compare(&r.reach, &r.traced, &edge);
    // Measured: RMSE 0.0054 against 0.0073, the largest error 0.19 against 0.34 (both
    // near the 256-sample noise; the map's pitch is tested in shadow_plugin's depth_map).
    assert!(m_fitted.rmse <= m_all.rmse, "fitted {m_fitted:?}, all lit {m_all:?}");
    assert!(m_fitted.max < 0.7 * m_all.max, "fitted {m_fitted:?}, all lit {m_all:?}");
    assert!(m_fitted.rmse < 0.02, "{m_fitted:?}");
    // Where nothing is near, the fallback's clear shaft answers 1 exactly: most pixels
    // whose truth is 1 read exactly 1 (the rest are inside the map, near a shadow).
    let (mut open, mut exact) = (0, 0);
    for y in 0..SIZE {
        for x in 0..SIZE {
            if r.lit(x, y) && r.traced.at(x, y) == 1.0 {
                open += 1;
                exact += usize::from(r.edge.at(x, y) == 1.0);
            }
        }
    }
    assert!(open > (SIZE * SIZE / 4) as usize && exact * 10 > open * 9, "{exact} of {open}");
    let _ = std::fs::remove_dir_all(&dir);
}
