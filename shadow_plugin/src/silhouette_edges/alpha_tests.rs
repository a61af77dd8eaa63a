//! The alpha classes against the renderer's own test (`Material::is_cutout`).

use super::*;
use glam::{Affine2, Vec4};
use renderer::geometry::coverage::{COVERAGE_MAX, COVERAGE_MIN, CoveragePoint};
use renderer::geometry::instances::TriangleOrigin;
use renderer::util::random::Rng;

/// The renderer's test of a MASK material at `uv` (it reads no point).
fn mask_cut(m: &Material, uv: Vec2, t: &[Texture]) -> bool {
    m.is_cutout(uv, t, || unreachable!("a MASK test reads no point"))
}

/// Points of BLEND's lowest and highest thresholds (the first found among 2^20 positions):
/// the test at them is the test under every threshold.
fn extreme_points() -> (CoveragePoint, CoveragePoint) {
    static POINTS: std::sync::OnceLock<(CoveragePoint, CoveragePoint)> = std::sync::OnceLock::new();
    *POINTS.get_or_init(|| {
        let at = |k: u32| CoveragePoint {
            triangle: TriangleOrigin { instance: 0, local: 0 },
            b1: k as f32 * 1e-7,
            b2: 0.0,
            color_alpha: 1.0,
        };
        let find = |t: f32| (0..1 << 20).map(at).find(|p| p.threshold() == t).expect("found");
        (find(COVERAGE_MIN), find(COVERAGE_MAX))
    })
}

/// The renderer's test at `uv` wherever on a triangle the hit lies: `Some(cut)` if every
/// point there reads the same (BLEND: whatever its threshold), `None` if the point decides.
fn cut_anywhere(m: &Material, uv: Vec2, t: &[Texture]) -> Option<bool> {
    match m.alpha {
        AlphaMode::Blend => {
            let (lo, hi) = extreme_points();
            let (under_lo, under_hi) = (m.is_cutout(uv, t, || lo), m.is_cutout(uv, t, || hi));
            (under_lo == under_hi).then_some(under_lo)
        }
        _ => Some(mask_cut(m, uv, t)),
    }
}

/// 64 x 64: alpha 0 for the columns x < 32 (u < 0.5), 255 for the others.
fn half() -> Texture {
    let rgba8 = (0..64 * 64).map(|i| if i % 64 < 32 { [255, 255, 255, 0] } else { [255; 4] }).collect();
    Texture { width: 64, height: 64, rgba8 }
}

fn masked(wrap: Wrap, transform: Affine2, w: f32, cutoff: f32) -> Material {
    Material {
        base_color: Vec4::new(1.0, 1.0, 1.0, w),
        base_color_texture: Some(TextureRef {
            texture: 0,
            wrap_s: wrap,
            wrap_t: wrap,
            filter: Default::default(),
            transform,
            tex_coord: 0,
        }),
        alpha: AlphaMode::Mask { cutoff },
        ..Material::diffuse([1.0; 3])
    }
}

/// A triangle spanning u in [u0, u1] (and v in [0.2, 0.8]).
fn tri(u0: f32, u1: f32) -> [Vec2; 3] {
    [Vec2::new(u0, 0.2), Vec2::new(u1, 0.3), Vec2::new(0.5 * (u0 + u1), 0.8)]
}

fn class(material: &Material, textures: &[Texture], uv: [Vec2; 3]) -> AlphaClass {
    let mut ranges = vec![None; textures.len()];
    MaterialAlpha::new(material, textures, &mut ranges).classify(uv, textures, &mut Footprint::default())
}

/// The intersector's UV at barycentrics (b1, b2) (`Scene::uv_at`).
fn uv_at(uv: [Vec2; 3], b1: f32, b2: f32) -> Vec2 {
    (1.0 - b1 - b2) * uv[0] + b1 * uv[1] + b2 * uv[2]
}

#[test]
fn triangles_in_each_half_and_across() {
    let t = [half()];
    let m = masked(Wrap::Repeat, Affine2::IDENTITY, 1.0, 0.5);
    assert_eq!(class(&m, &t, tri(0.05, 0.4)), AlphaClass::Clear);
    assert_eq!(class(&m, &t, tri(0.6, 0.95)), AlphaClass::Opaque);
    assert_eq!(class(&m, &t, tri(0.3, 0.7)), AlphaClass::Mixed);
    // Clear of the alpha edge by less than the grown footprint (a texel and the filter's).
    assert_eq!(class(&m, &t, tri(0.505, 0.9)), AlphaClass::Mixed);
}

/// Clear below the diagonal (column < row), opaque above it: a thin triangle along the
/// diagonal on the opaque side is opaque, though its bounding box holds clear texels.
#[test]
fn the_footprint_follows_the_triangle_not_its_bounding_box() {
    let rgba8 = (0..64 * 64).map(|i| if i % 64 < i / 64 { [0; 4] } else { [255; 4] }).collect();
    let t = [Texture { width: 64, height: 64, rgba8 }];
    let m = masked(Wrap::ClampToEdge, Affine2::IDENTITY, 1.0, 0.5);
    let thin = [Vec2::new(0.22, 0.02), Vec2::new(0.98, 0.78), Vec2::new(0.98, 0.02)];
    assert_eq!(class(&m, &t, thin), AlphaClass::Opaque);
    let across = [Vec2::new(0.1, 0.02), Vec2::new(0.98, 0.9), Vec2::new(0.5, 0.6)];
    assert_eq!(class(&m, &t, across), AlphaClass::Mixed);
    let under = [Vec2::new(0.02, 0.22), Vec2::new(0.78, 0.98), Vec2::new(0.02, 0.98)];
    assert_eq!(class(&m, &t, under), AlphaClass::Clear);
}

#[test]
fn wrap_modes_map_the_footprint() {
    let t = [half()];
    let id = Affine2::IDENTITY;
    let repeat = masked(Wrap::Repeat, id, 1.0, 0.5);
    assert_eq!(class(&repeat, &t, tri(1.6, 1.9)), AlphaClass::Opaque);
    assert_eq!(class(&repeat, &t, tri(-0.9, -0.6)), AlphaClass::Clear);
    // Across u = 1: the filter reads column 0 (clear) beside column 63 (opaque).
    assert_eq!(class(&repeat, &t, tri(0.8, 0.995)), AlphaClass::Mixed);
    let clamp = masked(Wrap::ClampToEdge, id, 1.0, 0.5);
    assert_eq!(class(&clamp, &t, tri(1.2, 3.5)), AlphaClass::Opaque);
    assert_eq!(class(&clamp, &t, tri(-3.0, -1.0)), AlphaClass::Clear);
    // Under clamping, u = 0.8..0.995 stays in the opaque half.
    assert_eq!(class(&clamp, &t, tri(0.8, 0.995)), AlphaClass::Opaque);
    let mirrored = masked(Wrap::MirroredRepeat, id, 1.0, 0.5);
    assert_eq!(class(&mirrored, &t, tri(1.1, 1.4)), AlphaClass::Opaque);
    assert_eq!(class(&mirrored, &t, tri(1.6, 1.9)), AlphaClass::Clear);
    // Many repeats: every column, so mixed.
    assert_eq!(class(&repeat, &t, tri(0.6, 40.0)), AlphaClass::Mixed);
}

#[test]
fn the_texture_transform_moves_the_footprint() {
    let t = [half()];
    let shifted = masked(Wrap::ClampToEdge, Affine2::from_translation(Vec2::new(0.5, 0.0)), 1.0, 0.5);
    assert_eq!(class(&shifted, &t, tri(0.1, 0.4)), AlphaClass::Opaque);
    let mirrored = masked(Wrap::ClampToEdge, Affine2::from_scale(Vec2::new(-1.0, 1.0)), 1.0, 0.5);
    assert_eq!(class(&mirrored, &t, tri(-0.95, -0.6)), AlphaClass::Opaque);
}

#[test]
fn constant_alpha_is_classified_by_the_test_itself() {
    let constant = |w: f32, cutoff: f32| Material {
        base_color: Vec4::new(0.15, 0.15, 0.15, w),
        base_color_texture: None,
        alpha: AlphaMode::Mask { cutoff },
        ..Material::diffuse([1.0; 3])
    };
    let uv = tri(0.0, 1.0);
    assert_eq!(class(&constant(0.3, 0.5), &[], uv), AlphaClass::Clear);
    assert_eq!(class(&constant(0.5, 0.5), &[], uv), AlphaClass::Opaque); // alpha < cutoff cuts
    assert_eq!(class(&constant(1.0, 0.5), &[], uv), AlphaClass::Opaque);
    assert_eq!(class(&Material::diffuse([0.5; 3]), &[], uv), AlphaClass::NoTest);
    // The base factor scales the texture's alpha: 0.4 x 1.0 < 0.5 everywhere.
    let t = [half()];
    assert_eq!(
        class(&masked(Wrap::Repeat, Affine2::IDENTITY, 0.4, 0.5), &t, tri(0.6, 0.9)),
        AlphaClass::Clear
    );
}

#[test]
fn non_finite_coordinates_read_texel_zero() {
    let t = [half()]; // texel (0, 0) is clear
    let m = masked(Wrap::Repeat, Affine2::IDENTITY, 1.0, 0.5);
    let mut uv = tri(0.6, 0.9);
    uv[1].y = f32::INFINITY;
    assert_eq!(class(&m, &t, uv), AlphaClass::Clear);
    assert!(mask_cut(&m, uv_at(uv, 0.0, 0.5), &t));
    uv[1].y = f32::NAN;
    assert_eq!(class(&m, &t, uv), AlphaClass::Clear);
}

/// A texture of one alpha against a cutoff of exactly that alpha: the filter's
/// `a (1 - s) + a s` can read just under `a`, so such triangles are mixed, not opaque.
#[test]
fn the_filters_rounding_keeps_a_cutoff_at_the_texel_value_mixed() {
    let mut rounded_under = 0;
    for code in 1..=255u8 {
        let t = [Texture { width: 4, height: 4, rgba8: vec![[255, 255, 255, code]; 16] }];
        let m = masked(Wrap::Repeat, Affine2::IDENTITY, 1.0, code as f32 / 255.0);
        assert_eq!(class(&m, &t, tri(0.1, 0.9)), AlphaClass::Mixed, "alpha {code}");
        let probes = (1..2000).map(|k| Vec2::new(k as f32 * 0.000_731, 0.3));
        rounded_under += probes.filter(|&uv| mask_cut(&m, uv, &t)).count();
        // Half a code under it: opaque.
        let m = masked(Wrap::Repeat, Affine2::IDENTITY, 1.0, (code as f32 - 0.5) / 255.0);
        assert_eq!(class(&m, &t, tri(0.1, 0.9)), AlphaClass::Opaque, "alpha {code}");
    }
    assert!(rounded_under > 0, "no lookup read under its texels' alpha: the margin would be needless");
}

/// A footprint beyond the cap reads the texture's whole range (mixed here), where a
/// smaller one in the same opaque region is opaque.
#[test]
fn footprints_beyond_the_cap_use_the_whole_texture() {
    let size = 512u32;
    let rgba8 = (0..size * size).map(|i| if i % size == 0 { [0; 4] } else { [255; 4] }).collect();
    let t = [Texture { width: size, height: size, rgba8 }];
    let m = masked(Wrap::ClampToEdge, Affine2::IDENTITY, 1.0, 0.5);
    assert_eq!(class(&m, &t, tri(0.3, 0.5)), AlphaClass::Opaque);
    let big = [Vec2::new(0.1, 0.0), Vec2::new(0.99, 0.0), Vec2::new(0.5, 1.0)];
    assert_eq!(class(&m, &t, big), AlphaClass::Mixed);
    // A texture of one class is classified whole, whatever the footprint.
    let opaque = [Texture { width: 8, height: 8, rgba8: vec![[9, 9, 9, 200]; 64] }];
    assert_eq!(class(&m, &opaque, [Vec2::splat(-1e30), Vec2::splat(1e30), Vec2::ZERO]), AlphaClass::Opaque);
}

/// Random small textures, materials (MASK, and one case in five BLEND), wrap modes and
/// triangles: no lookup the intersector can make on an opaque triangle cuts a hole, and every
/// one on a clear triangle does (BLEND: at every threshold).
#[test]
fn classes_agree_with_the_test_at_every_probed_hit() {
    let mut rng = Rng::new(7);
    let mut r = move || rng.next_f32();
    let codes = [0u8, 60, 127, 128, 129, 200, 255];
    let mut seen = [0u32; 2];
    for case in 0..800 {
        let t = [if case % 2 == 0 {
            // Blocks of one alpha, so that small footprints are often of one class.
            let (w, h) = (1 + (r() * 9.0) as u32, 1 + (r() * 9.0) as u32);
            let block = codes[(r() * 7.0) as usize];
            let rgba8 = (0..w * h)
                .map(|i| [0, 0, 0, if (i % w) < w / 2 { block } else { codes[(r() * 7.0) as usize] }])
                .collect();
            Texture { width: w, height: h, rgba8 }
        } else {
            // Clear on one side of a random line, opaque on the other: triangles along it
            // test the footprint's rows.
            let (a, b, c) = (r() - 0.5, r() - 0.5, 16.0 * (r() - 0.5));
            let rgba8 = (0..32 * 32)
                .map(|i| {
                    let (x, y) = ((i % 32) as f32 - 16.0, (i / 32) as f32 - 16.0);
                    [0, 0, 0, if a * x + b * y < c { 0 } else { 255 }]
                })
                .collect();
            Texture { width: 32, height: 32, rgba8 }
        }];
        let wrap = [Wrap::Repeat, Wrap::MirroredRepeat, Wrap::ClampToEdge][case % 3];
        let transform = if case % 4 == 0 { Affine2::from_angle(r() * 6.0) } else { Affine2::IDENTITY };
        let mut m = masked(wrap, transform, [1.0, 0.8, 0.5][case % 3], [0.5, 0.25, 0.5, 0.0][case % 4]);
        if case % 5 == 4 {
            m.alpha = AlphaMode::Blend;
        }
        let c = Vec2::new(r() * 3.0 - 1.5, r() * 3.0 - 1.5);
        let s = [0.02, 0.2, 1.0][case % 3] * r();
        let uv = [c, c + s * Vec2::new(r(), r()), c + s * Vec2::new(r(), -r())];
        let got = class(&m, &t, uv);
        let expect_cut = match got {
            AlphaClass::Opaque => false,
            AlphaClass::Clear => true,
            _ => continue,
        };
        seen[(got == AlphaClass::Clear) as usize] += 1;
        for i in 0..=64 {
            for j in 0..=64 - i {
                let (b1, b2) = (i as f32 / 64.0, j as f32 / 64.0);
                let p = uv_at(uv, b1, b2);
                assert_eq!(
                    cut_anywhere(&m, p, &t),
                    Some(expect_cut),
                    "case {case}: {got:?} at {p} of {uv:?}"
                );
            }
        }
    }
    assert!(seen[0] > 100 && seen[1] > 100, "too few opaque ({}) or clear ({}) cases", seen[0], seen[1]);
}

fn blend(w: f32, texture: bool) -> Material {
    let m = masked(Wrap::Repeat, Affine2::IDENTITY, w, 0.5);
    Material { alpha: AlphaMode::Blend, base_color_texture: m.base_color_texture.filter(|_| texture), ..m }
}

/// A BLEND pane is opaque at alpha 1, clear at alpha 0 and mixed between, however close to
/// either (the thresholds reach within 2^-17 of both); over a texture, by the texels its
/// footprint reads, a wholly opaque (255) texture opaque through the filter's rounding.
#[test]
fn blend_panes_are_classed_by_their_alpha() {
    let uv = tri(0.0, 1.0);
    assert_eq!(class(&blend(1.0, false), &[], uv), AlphaClass::Opaque);
    assert_eq!(class(&blend(0.0, false), &[], uv), AlphaClass::Clear);
    for w in [0.3, 1e-4, 0.9999] {
        assert_eq!(class(&blend(w, false), &[], uv), AlphaClass::Mixed, "alpha {w}");
    }
    let t = [half()];
    assert_eq!(class(&blend(1.0, true), &t, tri(0.6, 0.95)), AlphaClass::Opaque);
    assert_eq!(class(&blend(1.0, true), &t, tri(0.05, 0.4)), AlphaClass::Clear);
    assert_eq!(class(&blend(1.0, true), &t, tri(0.3, 0.7)), AlphaClass::Mixed);
    // The opaque half at factor 0.5: every point reads 0.5, a hole or not by its threshold.
    assert_eq!(class(&blend(0.5, true), &t, tri(0.6, 0.95)), AlphaClass::Mixed);
    let white = [Texture { width: 4, height: 4, rgba8: vec![[255; 4]; 16] }];
    assert_eq!(class(&blend(1.0, true), &white, tri(-3.0, 7.0)), AlphaClass::Opaque);
    // One code under 255 is a share 1/255 of holes: mixed.
    let nearly = [Texture { width: 4, height: 4, rgba8: vec![[255, 255, 255, 254]; 16] }];
    assert_eq!(class(&blend(1.0, true), &nearly, tri(0.1, 0.9)), AlphaClass::Mixed);
}

/// COLOR_0 scales a BLEND triangle's alpha: corners' alphas all at least 1 keep it opaque,
/// all at most 1 keep it clear; any other mixes; a mixed or untested one stays as it is.
#[test]
fn colors_keep_a_class_only_where_they_cannot_change_it() {
    let c = |a: [f32; 3]| Some(a.map(|w| Vec4::new(0.2, 0.3, 0.4, w)));
    use AlphaClass::*;
    let cases = [
        (Opaque, None, Opaque),
        (Opaque, c([1.0; 3]), Opaque),
        (Opaque, c([1.0, 2.0, 1.5]), Opaque),
        (Opaque, c([1.0, 0.999, 1.0]), Mixed),
        (Clear, c([1.0, 0.2, 0.0]), Clear),
        (Clear, c([1.0, 1.001, 0.0]), Mixed),
        (Mixed, c([1.0; 3]), Mixed),
        (NoTest, c([0.0; 3]), NoTest),
    ];
    for (class, colors, want) in cases {
        assert_eq!(with_colors(class, colors), want, "{class:?} with {colors:?}");
    }
}
