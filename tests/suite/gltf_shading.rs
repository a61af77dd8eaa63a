//! The glTF BRDF under area lights, end to end: a white furnace (a sphere of base colour 1
//! inside a closed box of six emitting rectangles of radiance 1, so that light arrives
//! equally from every direction) reflects, toward each view, the BRDF's directional albedo
//! `renderer::shading::quadrature::directional_albedo`: Appendix B's BRDF integrated by f64
//! quadrature. That is 1 only where the BRDF conserves energy: single-scattering GGX loses
//! some (a white metal of roughness 1 keeps about 0.7 head-on), and Appendix B's diffuse
//! weight 1 - F(V.H) lets a white dielectric return a little more than 1 at grazing views.

use crate::common;

use common::sphere::sphere;
use glam::{DVec3, Vec3};
use renderer::shading::brdf::GltfBrdf;
use renderer::shading::quadrature::directional_albedo;
use renderer::{Camera, LightShadowing, RectLight, RenderSettings, Scene, Traced, TracedParams, render};

/// The six faces of the cube [-1, 1]^3, each a light facing in, radiance 1.
fn furnace_lights() -> Vec<RectLight> {
    let mut lights = Vec::new();
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let mut c = Vec3::ZERO;
            c[axis] = side;
            let (mut u, mut v) = (Vec3::ZERO, Vec3::ZERO);
            u[(axis + 1) % 3] = 2.0;
            v[(axis + 2) % 3] = 2.0;
            // Facing the centre: u x v points along -c.
            let light = RectLight::new(c, u, v, Vec3::ONE);
            let light = if light.normal.dot(c) > 0.0 { RectLight::new(c, v, u, Vec3::ONE) } else { light };
            lights.push(light);
        }
    }
    lights
}

/// The furnace's image of a sphere of radius 0.5 (metallic `m`, roughness `r`) from 0.95 away
/// along +z, 64 x 64, `spp` samples, direct light only (a convex sphere sees nothing of
/// itself), each pixel's radiance with the cosine of its view.
fn furnace(m: f32, r: f32, spp: u32) -> Vec<(f32, Vec3)> {
    let mut g = sphere(0.5, 5, 1.0, true);
    g.materials[0].metallic = m;
    g.materials[0].roughness = r;
    let eye = Vec3::new(0.0, 0.0, 0.95);
    let camera = Camera::look_at(eye, Vec3::ZERO, Vec3::Y, 70.0);
    let scene = Scene::build(g, furnace_lights(), camera, DVec3::ZERO, Default::default());
    let settings = RenderSettings {
        width: 64,
        height: 64,
        spp,
        seed: 3,
        memory_budget_bytes: 1 << 30,
        profile: false,
        max_depth: 2,
    };
    let mut methods: Vec<Box<dyn LightShadowing>> =
        scene.lights.iter().map(|_| Box::new(Traced::new(TracedParams::CULLED, 16)) as _).collect();
    let frame = render(&scene, &mut methods, &settings, &|_| {}).unwrap();
    let mut out = Vec::new();
    for (i, &l) in frame.radiance.iter().enumerate() {
        let (x, y) = ((i % 64) as f32 + 0.5, (i / 64) as f32 + 0.5);
        let d = scene.camera.ray_direction(x, y, 64, 64).normalize();
        // The sphere's hit along d, if any: |eye + t d| = 0.5.
        let b = eye.dot(d);
        let disc = b * b - (eye.length_squared() - 0.25);
        if disc <= 0.0 {
            continue;
        }
        let p = eye + (-b - disc.sqrt()) * d;
        out.push((p.normalize().dot(-d), l));
    }
    out
}

/// Pixels whose view cosine lies in `band`: their mean radiance (grey: one channel), against
/// the directional albedo at the band's ends.
fn check(m: f32, r: f32, pixels: &[(f32, Vec3)], band: (f32, f32), tolerance: f32) {
    let brdf = GltfBrdf { base_color: Vec3::ONE, metallic: m, roughness: r };
    let chosen: Vec<f32> =
        pixels.iter().filter(|(c, _)| (band.0..=band.1).contains(c)).map(|(_, l)| l.x).collect();
    assert!(chosen.len() >= 20, "{} pixels in {band:?}", chosen.len());
    let measured = chosen.iter().sum::<f32>() / chosen.len() as f32;
    let (a, b) = (directional_albedo(&brdf, band.0).x, directional_albedo(&brdf, band.1).x);
    let (lo, hi) = (a.min(b) - tolerance, a.max(b) + tolerance);
    assert!(
        (lo..=hi).contains(&measured),
        "metallic {m} roughness {r}, view cos {band:?}: reflects {measured}, albedo {a}..{b} (+- {tolerance})"
    );
}

/// Every roughness the LTC fit covers, metal and dielectric, near the normal (cos 0.9-1)
/// and obliquely (cos 0.5-0.6), within the albedo's range over the band widened by 0.01 and
/// 0.015: the fit's error at those views (`renderer::shading::ltc`) and the diffuse part's
/// Fresnel read toward each light's mean direction. Measured: at most 0.0006 outside.
#[test]
fn a_white_furnace_reflects_the_brdfs_albedo() {
    for m in [0.0f32, 1.0] {
        for r in [0.1f32, 0.3, 0.6, 1.0] {
            let pixels = furnace(m, r, 1);
            check(m, r, &pixels, (0.9, 1.0), 0.01);
            check(m, r, &pixels, (0.5, 0.6), 0.015);
        }
    }
}

/// A lobe sharper than the fit (roughness 0.02: a near mirror) takes its light from BSDF
/// samples that hit the lights: the furnace's mean over 64 samples per pixel (16 outside CI,
/// `common::full_sweeps`), within 0.02 (noise; measured 0.0002 off at 64).
#[test]
fn a_white_furnace_reflects_the_albedo_of_a_near_mirror() {
    let spp = if common::full_sweeps() { 64 } else { 16 };
    for m in [0.0f32, 1.0] {
        let pixels = furnace(m, 0.02, spp);
        check(m, 0.02, &pixels, (0.9, 1.0), 0.02);
    }
}

/// An emissive rectangle made a light (its triangles in the scene, its rectangle a light) is
/// counted once: a near-mirror floor (metal, base colour 1, roughness 0.02) reflects it at
/// radiance L x its albedo (about 1; measured 1.000), not 2 L. Within 3% (the
/// mirror's reflections are BRDF samples: 16 per pixel over the pixels that see it).
#[test]
fn an_emissive_rectangle_made_a_light_is_counted_once() {
    let l = 5.0f32;
    let mut g = renderer::load::gltf_load::Geometry::default();
    g.add_quad(DVec3::ZERO, DVec3::X * 20.0, DVec3::NEG_Z * 20.0, [1.0; 3]);
    g.materials[0].metallic = 1.0;
    g.materials[0].roughness = 0.02;
    // The emitter: 1 x 1 at height 1, facing down; its triangles emit L.
    g.add_quad(DVec3::new(0.0, 1.0, 0.0), DVec3::X, DVec3::Z, [0.0; 3]);
    g.materials[1].emission = Vec3::splat(l);
    let light = RectLight::new(Vec3::new(0.0, 1.0, 0.0), Vec3::X, Vec3::Z, Vec3::splat(l));
    assert!(light.normal.y < 0.0, "the light faces the floor");
    // Seen from the side, low: the mirror shows the rectangle's image below the floor.
    let camera = Camera::look_at(Vec3::new(0.0, 0.5, 3.0), Vec3::new(0.0, -0.3, 0.0), Vec3::Y, 50.0);
    let scene = Scene::build(g, vec![light], camera, DVec3::ZERO, Default::default());
    let (w, h) = (48u32, 48u32);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 16,
        seed: 9,
        memory_budget_bytes: 1 << 30,
        profile: false,
        max_depth: 2,
    };
    let mut methods: Vec<Box<dyn LightShadowing>> = vec![Box::new(Traced::new(TracedParams::CULLED, 64))];
    let frame = render(&scene, &mut methods, &settings, &|_| {}).unwrap();
    // Pixels whose centre ray meets the floor where its mirror image meets the light.
    let (mut reflected, mut count) = (0.0f64, 0);
    for (i, c) in frame.radiance.iter().enumerate() {
        let d = scene
            .camera
            .ray_direction((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5, w, h)
            .normalize();
        let o = scene.camera.position;
        if d.y >= 0.0 {
            continue;
        }
        let p = o + (-o.y / d.y) * d;
        let r = Vec3::new(d.x, -d.y, d.z);
        let q = p + (1.0 / r.y) * r;
        // Well inside the rectangle's image (the pixel's samples spread over it).
        if q.x.abs() < 0.35 && q.z.abs() < 0.35 {
            reflected += c.x as f64;
            count += 1;
        }
    }
    assert!(count >= 10, "{count} pixels see the image");
    let measured = reflected / count as f64 / l as f64;
    let brdf = GltfBrdf { base_color: Vec3::ONE, metallic: 1.0, roughness: 0.02 };
    let albedo = directional_albedo(&brdf, 0.5).x as f64;
    assert!((measured - albedo).abs() < 0.03, "reflects {measured} L, albedo {albedo}");
}
