//! Alpha-masked triangles classified by every alpha the intersector's test can read on them
//! (`Scene::hit_distance`: `Material::is_cutout` at the hit's interpolated UV), so that only
//! the ones whose test can go either way are left out of the counting.
//!
//! A ray meeting a triangle reads the alpha at `uv = b0 uv0 + b1 uv1 + b2 uv2` (f32, the
//! barycentrics of the f32 ray test), through the material's texture transform, bilinear
//! over the texels around it with the sampler's wrap modes, times `base_color.w`. So every
//! value it can read lies between the lowest and highest texel alpha of the texels a lookup
//! can touch over the triangle's UV footprint (its transformed UVs, grown by a texel and by
//! a bound on the f32 rounding; row by row, so that a thin diagonal triangle is not charged
//! for its bounding box), widened by the filter's rounding (`lerp` is `a (1 - s) + b s`:
//! between two texels of alpha `a` it may read just under `a`).
//! Every texel alpha at or above the cutoff with that margin: the test never cuts a hole,
//! the triangle is opaque. Every one below it with that margin: the test always cuts a
//! hole, no ray ever stops on it, and it is dropped. Otherwise it is mixed.
//!
//! BLEND's coverage compares each point's alpha (x COLOR_0's) with a threshold of its own
//! in [`COVERAGE_MIN`, `COVERAGE_MAX`] ([`renderer::geometry::coverage`]): the same
//! classes against that range, so a pane of alpha 1 is opaque, of alpha 0 clear, and
//! anything between mixed (sampled point by point, as `traced` meets it). COLOR_0 may
//! scale the alpha of a triangle: one whose corners' alphas are not all 1 stays opaque only
//! if they are all at least 1, clear only if all at most 1, and is mixed otherwise.

use glam::{DVec2, Vec2};
use rayon::prelude::*;
use renderer::Scene;
use renderer::geometry::material::{AlphaMode, Material, Texture, TextureRef, Wrap};

/// What a triangle's alpha test does to the rays that meet it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlphaClass {
    /// Its material has no alpha test.
    NoTest,
    /// The test never cuts a hole in it: it blocks like an opaque triangle.
    Opaque,
    /// The test always cuts a hole: no ray ever stops on it.
    Clear,
    /// Either, depending on where the ray meets it.
    Mixed,
}

/// A footprint of more texels than this is classified by the texture's whole range of
/// alphas instead (a superset: still exact, coarser), which bounds the work per triangle.
/// 2^16 reads are ~30 us; real foliage triangles cover a few hundred texels.
const MAX_FOOTPRINT_TEXELS: usize = 1 << 16;

/// The bilinear filter's rounding on values in [0, 1]: two `lerp`s, each within about 4
/// ulps of 1.0 (2.4e-7: `1 - s`, two products and a sum), bounded with a fourfold margin.
const FILTER_ERROR: f64 = 2e-6;

/// Relative bound on the f32 rounding of the interpolated, transformed and scaled UV, per
/// axis, against the magnitudes the evaluation goes through: the barycentrics (b0 = 1 - b1 -
/// b2 may be a rounding under 0; their sum within ~2^-23 of 1) and the ~8 roundings of 2^-24
/// come to about 1e-6; bounded with a tenfold margin (and a whole texel more beside it).
const UV_ERROR: f64 = 1e-5;

/// Beyond this magnitude (in texels) a footprint is not computed (its integer texel indices
/// would overflow): the texture's whole range is used.
const MAX_TEXEL_COORDINATE: f64 = (1u64 << 40) as f64;

/// Bits of a texel alpha's class for one material: every value the filter can make near it
/// passes the test (`SOLID`), or every one fails it (`HOLE`); 0 if neither is certain.
const SOLID: u8 = 1;
const HOLE: u8 = 2;

/// Relative bound on what BLEND's COLOR_0 factor does to an alpha where the corners' alphas
/// are all 1 (or all at least, or at most, 1): their interpolation is within ~6 ulps of the
/// bound (weights summing to 1 within rounding), and the product rounds once more; bounded
/// with a twofold margin.
const COLOR_ERROR: f64 = 1e-6;

/// The class of every triangle slot of `scene` (BVH order). Parallel over the triangles;
/// the answer does not depend on the thread count.
pub fn classify(scene: &Scene) -> Vec<AlphaClass> {
    let mut ranges: Vec<Option<[bool; 256]>> = vec![None; scene.textures.len()];
    let materials: Vec<MaterialAlpha> =
        scene.materials.iter().map(|m| MaterialAlpha::new(m, &scene.textures, &mut ranges)).collect();
    (0..scene.triangles.len())
        .into_par_iter()
        .with_min_len(1024)
        .map_init(Footprint::default, |footprint, slot| {
            let shading = &scene.shading[slot];
            let class = materials[shading.material as usize].classify(shading.uv, &scene.textures, footprint);
            match scene.materials[shading.material as usize].alpha {
                AlphaMode::Blend => with_colors(class, scene.extras.color.get(slot)),
                _ => class,
            }
        })
        .collect()
}

/// A BLEND triangle's class with its COLOR_0 (corners' RGBA, if any), which scales its alpha:
/// opaque stays so where every corner's alpha is at least 1, clear where every one is at
/// most 1 ([`COLOR_ERROR`] covers the interpolation's rounding); otherwise either may change.
pub fn with_colors(class: AlphaClass, colors: Option<[glam::Vec4; 3]>) -> AlphaClass {
    let Some(c) = colors else { return class };
    let alphas = c.map(|c| c.w);
    match class {
        AlphaClass::Opaque if alphas.iter().all(|&a| a >= 1.0) => class,
        AlphaClass::Clear if alphas.iter().all(|&a| a <= 1.0) => class,
        AlphaClass::Opaque | AlphaClass::Clear => AlphaClass::Mixed,
        AlphaClass::NoTest | AlphaClass::Mixed => class,
    }
}

/// The alphas a material's test compares with a point's: under `hole_below` a hole wherever
/// read, at or over `solid_at` never a hole. MASK's cutoff twice; BLEND's range of
/// thresholds moved out by [`COLOR_ERROR`].
#[derive(Debug, Clone, Copy)]
struct Cutoffs {
    hole_below: f64,
    solid_at: f64,
    /// MASK's one cutoff: what is not under it is opaque, as the renderer's test reads it
    /// (NaN included).
    single: bool,
}

impl Cutoffs {
    fn of(alpha: AlphaMode) -> Option<Cutoffs> {
        let (lo, hi) = alpha.cutoffs()?;
        let (lo, hi) = (lo as f64, hi as f64);
        Some(match alpha {
            AlphaMode::Blend => Cutoffs {
                hole_below: lo / (1.0 + COLOR_ERROR),
                solid_at: hi / (1.0 - COLOR_ERROR),
                single: false,
            },
            _ => Cutoffs { hole_below: lo, solid_at: hi, single: true },
        })
    }

    /// The class of a triangle that reads the one alpha `alpha` (MASK: the renderer's own
    /// comparison, `alpha < cutoff`).
    fn class(self, alpha: f32) -> AlphaClass {
        let a = alpha as f64;
        if a < self.hole_below {
            AlphaClass::Clear
        } else if self.single || a >= self.solid_at {
            AlphaClass::Opaque
        } else {
            AlphaClass::Mixed
        }
    }
}

/// One material's alpha test, ready to classify triangles.
#[derive(Debug)]
pub enum MaterialAlpha {
    /// The same class on every triangle: no test, a constant alpha (no texture), or a
    /// texture whose every texel has one class.
    Uniform(AlphaClass),
    /// Classified triangle by triangle, over its footprint.
    Textured(Box<TexturedAlpha>),
}

/// A textured alpha test: its texture reference, and each 8-bit texel alpha's class bits.
#[derive(Debug)]
pub struct TexturedAlpha {
    material: Material,
    cutoffs: Cutoffs,
    texture: TextureRef,
    classes: [u8; 256],
    /// The class of a lookup that may read any texel (a footprint too large to scan).
    whole: AlphaClass,
}

impl MaterialAlpha {
    /// The test of `material`; `ranges` caches, per texture, which alpha codes it holds.
    pub fn new(material: &Material, textures: &[Texture], ranges: &mut [Option<[bool; 256]>]) -> Self {
        let Some(cutoffs) = Cutoffs::of(material.alpha) else { return Self::Uniform(AlphaClass::NoTest) };
        let Some(texture) = material.base_color_texture else {
            // A constant alpha: the renderer's own comparison of it, at any UV, is the answer.
            return Self::Uniform(cutoffs.class(material.base_color_at(Vec2::ZERO, textures).w));
        };
        let image = &textures[texture.texture as usize];
        if image.width == 0 || image.height == 0 {
            return Self::Uniform(AlphaClass::Mixed);
        }
        let classes = std::array::from_fn(|code| texel_class(material.base_color.w, cutoffs, code as u8));
        let present = ranges[texture.texture as usize].get_or_insert_with(|| {
            let mut present = [false; 256];
            for texel in &image.rgba8 {
                present[texel[3] as usize] = true;
            }
            present
        });
        let all = (0..256).filter(|&c| present[c]).fold(SOLID | HOLE, |acc, c| acc & classes[c]);
        let whole = class_of(all);
        if whole != AlphaClass::Mixed {
            return Self::Uniform(whole);
        }
        Self::Textured(Box::new(TexturedAlpha { material: *material, cutoffs, texture, classes, whole }))
    }

    /// The class of a triangle with texture coordinates `uv`.
    pub fn classify(&self, uv: [Vec2; 3], textures: &[Texture], footprint: &mut Footprint) -> AlphaClass {
        match self {
            Self::Uniform(class) => *class,
            Self::Textured(t) => t.classify(uv, textures, footprint),
        }
    }
}

impl TexturedAlpha {
    fn classify(&self, uv: [Vec2; 3], textures: &[Texture], footprint: &mut Footprint) -> AlphaClass {
        let image = &textures[self.texture.texture as usize];
        match footprint.fill(&self.texture, image, uv) {
            Reads::TexelZero => self.cutoffs.class(self.material.base_color_at(Vec2::NAN, textures).w),
            Reads::Any => self.whole,
            Reads::Texels => {
                let width = image.width as usize;
                let mut acc = SOLID | HOLE;
                for &(y, x0, x1) in &footprint.runs {
                    for texel in &image.rgba8[y * width + x0..=y * width + x1] {
                        acc &= self.classes[texel[3] as usize];
                    }
                    if acc == 0 {
                        return AlphaClass::Mixed;
                    }
                }
                class_of(acc)
            }
        }
    }
}

fn class_of(bits: u8) -> AlphaClass {
    match bits {
        SOLID => AlphaClass::Opaque,
        HOLE => AlphaClass::Clear,
        _ => AlphaClass::Mixed,
    }
}

/// The class bits of the 8-bit texel alpha `code` (read as `code as f32 / 255.0`) under
/// `alpha = w * filtered` against `cutoffs`: the filtered value is within [`FILTER_ERROR`]
/// of the texels' range, and the product rounds once more (relative 2^-24).
fn texel_class(w: f32, cutoffs: Cutoffs, code: u8) -> u8 {
    let Cutoffs { hole_below, solid_at, .. } = cutoffs;
    if !(w.is_finite() && hole_below.is_finite() && solid_at.is_finite()) {
        return 0;
    }
    let w = w as f64;
    let s = code as f64 / 255.0;
    let (a, b) = (w * (s - FILTER_ERROR), w * (s + FILTER_ERROR));
    let margin = FILTER_ERROR * w.abs();
    if a.min(b) - margin >= solid_at {
        SOLID
    } else if a.max(b) + margin < hole_below {
        HOLE
    } else {
        0
    }
}

/// What a triangle's lookups can read.
enum Reads {
    /// Texel (0, 0) only: non-finite coordinates (or transform) make every lookup's
    /// coordinate non-finite, and `Texture::sample` then reads that texel alone.
    TexelZero,
    /// The texels of `Footprint::runs`.
    Texels,
    /// Possibly any texel.
    Any,
}

/// The texels a triangle's lookups can touch (scratch, reused).
#[derive(Default)]
pub struct Footprint {
    /// Runs of texels (row, first column, last column), up to three per row met (wrapped
    /// around the texture's edges); a texel may be met twice.
    runs: Vec<(usize, usize, usize)>,
}

impl Footprint {
    fn fill(&mut self, texture: &TextureRef, image: &Texture, uv: [Vec2; 3]) -> Reads {
        let m = texture.transform.matrix2;
        let t = texture.transform.translation;
        let finite =
            uv.iter().all(|p| p.is_finite()) && m.x_axis.is_finite() && m.y_axis.is_finite() && t.is_finite();
        if !finite {
            return Reads::TexelZero;
        }
        let uv = uv.map(|p| p.as_dvec2());
        let (m, t) = ([m.x_axis.as_dvec2(), m.y_axis.as_dvec2()], t.as_dvec2());
        let magnitude = uv.iter().fold(DVec2::ZERO, |acc, p| acc.max(p.abs()));
        // Texel coordinates `uv' * size - 0.5` of the corners (in f64), and a bound on the
        // magnitudes the f32 evaluation goes through.
        let size = DVec2::new(image.width as f64, image.height as f64);
        let corners = uv.map(|p| (m[0] * p.x + m[1] * p.y + t) * size - 0.5);
        let scale = (m[0].abs() * magnitude.x + m[1].abs() * magnitude.y + t.abs()) * size + 0.5;
        // (Finite: f32 inputs cannot overflow these f64 products.)
        if scale.max_element() >= MAX_TEXEL_COORDINATE {
            return Reads::Any;
        }
        // Every f32 lookup lies within `grow` of the triangle (the rounding bound, and a
        // texel more to spare).
        let grow = 1.0 + UV_ERROR * scale;
        let lo = corners.iter().fold(f64::INFINITY, |acc, c| acc.min(c.y)) - grow.y;
        let hi = corners.iter().fold(f64::NEG_INFINITY, |acc, c| acc.max(c.y)) + grow.y;
        let (first, last) = (lo.floor() as i64, hi.floor() as i64 + 1);
        if last - first >= MAX_FOOTPRINT_TEXELS as i64 {
            return Reads::Any;
        }
        self.runs.clear();
        let mut texels = 0;
        for j in first..=last {
            // Lookups touch row j from texel heights in [j - 1, j + 1] (`floor(y)` and the
            // next): the grown triangle's span over that slab.
            let slab = (j as f64 - 1.0 - grow.y, j as f64 + 1.0 + grow.y);
            let Some((x0, x1)) = span(&corners, slab) else { continue };
            let y = texture.wrap_t.index(j, image.height);
            let (x0, x1) = ((x0 - grow.x).floor() as i64, (x1 + grow.x).floor() as i64 + 1);
            for (a, b) in runs(x0, x1, image.width, texture.wrap_s) {
                texels += b - a + 1;
                self.runs.push((y, a, b));
            }
            if texels > MAX_FOOTPRINT_TEXELS {
                return Reads::Any;
            }
        }
        Reads::Texels
    }
}

/// The x extent of the triangle `c` between heights `slab.0` and `slab.1` (a convex
/// polygon's extent there is reached at its corners inside or where its sides cross).
fn span(c: &[DVec2; 3], (y0, y1): (f64, f64)) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..3 {
        let (a, b) = (c[k], c[(k + 1) % 3]);
        if (y0..=y1).contains(&a.y) {
            (lo, hi) = (lo.min(a.x), hi.max(a.x));
        }
        for y in [y0, y1] {
            if (a.y < y) != (b.y < y) {
                let x = a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x);
                (lo, hi) = (lo.min(x), hi.max(x));
            }
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// The texel indices `wrap` maps the integers `first..=last` to (`floor(x)` and the next of
/// every lookup's coordinate x), as up to three runs of consecutive indices: every wrap mode
/// is monotonic over each tile of `size` integers, so each tile's piece maps to the run
/// between its ends' indices. Reading runs rather than index lists matters: wrapping each texel's index
/// (a division) was most of the classification's time.
fn runs(first: i64, last: i64, size: u32, wrap: Wrap) -> impl Iterator<Item = (usize, usize)> {
    let n = size as i64;
    let (first, last, period) = match wrap {
        // (Clamped first: the tiles beyond the texture's edges all map to the edge texel.)
        Wrap::ClampToEdge => (first.clamp(0, n - 1), last.clamp(0, n - 1), n),
        Wrap::Repeat => (first, last, n),
        Wrap::MirroredRepeat => (first, last, 2 * n),
    };
    // A whole period reads every texel.
    let (first, last) = if last - first + 1 >= period { (0, n - 1) } else { (first, last) };
    let mut i = first;
    std::iter::from_fn(move || {
        (i <= last).then(|| {
            let end = last.min((i.div_euclid(n) + 1) * n - 1);
            let (a, b) = (wrap.index(i, size), wrap.index(end, size));
            i = end + 1;
            (a.min(b), a.max(b))
        })
    })
}

#[cfg(test)]
#[path = "alpha_tests.rs"]
mod tests;
