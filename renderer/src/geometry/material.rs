//! Materials as glTF's metallic-roughness model defines them: base colour (factor x sRGB
//! texture), metallic and roughness (factors x a linear texture's B and G), a normal texture
//! with its scale, emission (factor x strength x sRGB texture) and the alpha mode (MASK's
//! cutoff, or BLEND's coverage: [`crate::geometry::coverage`]). Every
//! texture reference keeps its own texture-coordinate set, sampler and transform. What the
//! renderer shades with today is the base colour (two-sided Lambertian); the rest is read by
//! [`crate::geometry::surface`].

use crate::geometry::coverage::{COVERAGE_MAX, COVERAGE_MIN, CoveragePoint};
use glam::{Affine2, Vec2, Vec3, Vec4};
use serde::Deserialize;
use std::sync::OnceLock;

/// How a scene's materials are shaded (`[materials] shading`, `--shading`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Shading {
    /// As the files define them: normal textures bend the shading normal.
    #[default]
    Gltf,
    /// Every surface a two-sided Lambertian of its base colour with its interpolated normal:
    /// the renders of before materials were read (the same bytes).
    Diffuse,
}

impl Shading {
    /// Its name in the scene file and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Shading::Gltf => "gltf",
            Shading::Diffuse => "diffuse",
        }
    }
}

/// How a texture coordinate outside [0, 1] is mapped back (glTF sampler wrap modes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

impl Wrap {
    /// The texel index for an integer index `i` of a `size`-texel axis. Public so that
    /// classifications of what a lookup can read (silhouette's alpha classes) wrap exactly
    /// as [`Texture::sample`] does.
    #[inline]
    pub fn index(self, i: i64, size: u32) -> usize {
        let n = size as i64;
        let j = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
        };
        j as usize
    }
}

/// How a lookup between texel centres reads (the glTF sampler's filter): blended from the
/// four nearest texels, or the one texel the coordinate falls in (pixel art, masks, lookup
/// tables). There are no mipmaps: every lookup is at one point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Filter {
    #[default]
    Linear,
    Nearest,
}

/// An 8-bit RGBA image as the file holds it. How its RGB is read is the reference's to say:
/// sRGB for colours (base colour, emission: [`Texture::sample`]), linear for data
/// (metallic-roughness, normals: [`Texture::sample_linear`]). Alpha is always linear.
#[derive(Debug, Clone)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first (glTF's UV (0, 0) is the top-left texel).
    pub rgba8: Vec<[u8; 4]>,
}

/// sRGB to linear, per 8-bit code (IEC 61966-2-1).
fn srgb_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [0.0f32; 256];
        for (i, v) in t.iter_mut().enumerate() {
            let c = i as f64 / 255.0;
            *v = if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) } as f32;
        }
        t
    })
}

impl Texture {
    /// The texel at (x, y), its RGB sRGB-decoded.
    #[inline]
    fn texel(&self, x: usize, y: usize) -> Vec4 {
        let t = srgb_table();
        let [r, g, b, a] = self.rgba8[y * self.width as usize + x];
        Vec4::new(t[r as usize], t[g as usize], t[b as usize], a as f32 / 255.0)
    }

    /// The texel at (x, y), every channel code / 255 (data, not colour).
    #[inline]
    fn texel_linear(&self, x: usize, y: usize) -> Vec4 {
        Vec4::from_array(self.rgba8[y * self.width as usize + x].map(|c| c as f32 / 255.0))
    }

    /// The lookup at texture coordinate `uv` in linear space, its RGB sRGB-decoded per texel
    /// before the filter blends them: bilinear, or the texel `uv` falls in
    /// ([`Filter::Nearest`]).
    pub fn sample(&self, uv: Vec2, wrap: (Wrap, Wrap), filter: Filter) -> Vec4 {
        self.lookup(uv, wrap, filter, Self::texel)
    }

    /// [`Self::sample`] of a data texture (metallic-roughness, normals): each channel its code
    /// / 255, no sRGB decoding.
    pub fn sample_linear(&self, uv: Vec2, wrap: (Wrap, Wrap), filter: Filter) -> Vec4 {
        self.lookup(uv, wrap, filter, Self::texel_linear)
    }

    /// The filtered lookup with `texel` reading one texel. Inlined into both callers, so the
    /// sRGB path does the arithmetic it did before the linear one existed.
    #[inline(always)]
    fn lookup(
        &self,
        uv: Vec2,
        (wrap_s, wrap_t): (Wrap, Wrap),
        filter: Filter,
        texel: impl Fn(&Self, usize, usize) -> Vec4,
    ) -> Vec4 {
        if filter == Filter::Nearest {
            let (x, y) = (uv.x * self.width as f32, uv.y * self.height as f32);
            if !(x.is_finite() && y.is_finite()) {
                return texel(self, 0, 0);
            }
            return texel(
                self,
                wrap_s.index(x.floor() as i64, self.width),
                wrap_t.index(y.floor() as i64, self.height),
            );
        }
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return texel(self, 0, 0);
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let xs = [wrap_s.index(x0, self.width), wrap_s.index(x0 + 1, self.width)];
        let ys = [wrap_t.index(y0, self.height), wrap_t.index(y0 + 1, self.height)];
        let top = texel(self, xs[0], ys[0]).lerp(texel(self, xs[1], ys[0]), fx);
        let bottom = texel(self, xs[0], ys[1]).lerp(texel(self, xs[1], ys[1]), fx);
        top.lerp(bottom, fy)
    }
}

/// A reference from a material to one of its textures: which image, read how, through which
/// texture-coordinate set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureRef {
    /// Index into `Scene::textures`.
    pub texture: u32,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    pub filter: Filter,
    /// KHR_texture_transform (identity when absent).
    pub transform: Affine2,
    /// The `TEXCOORD_<n>` set it reads (KHR_texture_transform's `texCoord` over the
    /// reference's own).
    pub tex_coord: u32,
}

impl TextureRef {
    /// The colour (RGB sRGB-decoded) at texture coordinates `uv` of its set, before its
    /// transform.
    #[inline]
    pub fn color(&self, uv: Vec2, textures: &[Texture]) -> Vec4 {
        let uv = self.transform.transform_point2(uv);
        textures[self.texture as usize].sample(uv, (self.wrap_s, self.wrap_t), self.filter)
    }

    /// [`Self::color`] of a data texture: every channel linear.
    #[inline]
    pub fn data(&self, uv: Vec2, textures: &[Texture]) -> Vec4 {
        let uv = self.transform.transform_point2(uv);
        textures[self.texture as usize].sample_linear(uv, (self.wrap_s, self.wrap_t), self.filter)
    }
}

/// A material's normal texture: tangent-space normals in RGB (linear, `2 c - 1`), their x and
/// y scaled by `scale` (glTF's `normalTexture.scale`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalTexture {
    pub texture: TextureRef,
    pub scale: f32,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlphaMode {
    Opaque,
    /// Surfaces with alpha < cutoff are holes, for every ray.
    Mask {
        cutoff: f32,
    },
    /// glTF's BLEND as coverage: a surface of alpha a stops a share a of what crosses it.
    /// Each point is a hole where its alpha (x COLOR_0's) is under a threshold of its own,
    /// white noise keyed by the point ([`crate::geometry::coverage`]).
    Blend,
}

impl AlphaMode {
    /// The lowest and highest cutoff the test compares a point's alpha with: an alpha under
    /// the first is a hole wherever it is read, one at or over the second never is. `None`
    /// without a test.
    pub fn cutoffs(self) -> Option<(f32, f32)> {
        match self {
            AlphaMode::Opaque => None,
            AlphaMode::Mask { cutoff } => Some((cutoff, cutoff)),
            AlphaMode::Blend => Some((COVERAGE_MIN, COVERAGE_MAX)),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Linear RGBA factor.
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub alpha: AlphaMode,
    /// `metallicFactor` and `roughnessFactor`, each in [0, 1].
    pub metallic: f32,
    pub roughness: f32,
    /// `metallicRoughnessTexture`: roughness in G, metallic in B, both linear, scaling the
    /// factors.
    pub metallic_roughness_texture: Option<TextureRef>,
    pub normal_texture: Option<NormalTexture>,
    /// `emissiveFactor` x `KHR_materials_emissive_strength` (linear radiance).
    pub emission: Vec3,
    /// `emissiveTexture` (sRGB), scaling `emission`.
    pub emissive_texture: Option<TextureRef>,
}

impl Material {
    /// A two-sided Lambertian of linear albedo `rgb` (a scene file's quad): not metallic,
    /// fully rough, no texture.
    pub fn diffuse(rgb: [f32; 3]) -> Self {
        Self {
            base_color: Vec4::new(rgb[0], rgb[1], rgb[2], 1.0),
            base_color_texture: None,
            alpha: AlphaMode::Opaque,
            metallic: 0.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            emission: Vec3::ZERO,
            emissive_texture: None,
        }
    }

    /// The glTF default material, for primitives without one: every property at the spec's
    /// default (white, metallic 1, roughness 1).
    pub fn gltf_default() -> Self {
        Self { metallic: 1.0, ..Self::diffuse([1.0; 3]) }
    }

    /// The texture-coordinate set the base colour texture reads (0 without one): the set a
    /// triangle's first coordinates hold, which the alpha test reads.
    pub fn base_uv_set(&self) -> u32 {
        self.base_color_texture.map_or(0, |t| t.tex_coord)
    }

    /// The other textures' references, each with its glTF key (for errors).
    pub fn other_textures(&self) -> [(&'static str, Option<TextureRef>); 3] {
        [
            ("pbrMetallicRoughness.metallicRoughnessTexture", self.metallic_roughness_texture),
            ("normalTexture", self.normal_texture.map(|n| n.texture)),
            ("emissiveTexture", self.emissive_texture),
        ]
    }

    /// The one set other than [`Self::base_uv_set`] that another texture reads, if any: a
    /// triangle's second coordinates (the loader refuses a material that needs a third).
    pub fn second_uv_set(&self) -> Option<u32> {
        let base = self.base_uv_set();
        self.other_textures().into_iter().find_map(|(_, t)| t.map(|t| t.tex_coord).filter(|&s| s != base))
    }

    /// Linear RGBA at texture coordinate `uv`.
    pub fn base_color_at(&self, uv: Vec2, textures: &[Texture]) -> Vec4 {
        match &self.base_color_texture {
            Some(t) => self.base_color * t.color(uv, textures),
            None => self.base_color,
        }
    }

    /// Whether a hit at `uv` is a hole under the alpha test. `point` says where the hit
    /// lies, asked only of a BLEND material (its coverage is keyed by the point).
    #[inline]
    pub fn is_cutout(&self, uv: Vec2, textures: &[Texture], point: impl FnOnce() -> CoveragePoint) -> bool {
        match self.alpha {
            AlphaMode::Opaque => false,
            AlphaMode::Mask { cutoff } => self.base_color_at(uv, textures).w < cutoff,
            AlphaMode::Blend => point().is_hole(self.base_color_at(uv, textures).w),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> Texture {
        // 2x2: white, black / black, white (sRGB 255 and 0), alpha 255 / 0 per column.
        Texture {
            width: 2,
            height: 2,
            rgba8: vec![[255, 255, 255, 255], [0, 0, 0, 0], [0, 0, 0, 255], [255, 255, 255, 0]],
        }
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        let t = srgb_table();
        assert_eq!(t[0], 0.0);
        assert_eq!(t[255], 1.0);
        // sRGB 128 is linear 0.21586 (IEC 61966-2-1).
        assert!((t[128] - 0.215861).abs() < 1e-5, "{}", t[128]);
    }

    #[test]
    fn wrap_modes_map_outside_coordinates() {
        assert_eq!(Wrap::Repeat.index(-1, 4), 3);
        assert_eq!(Wrap::Repeat.index(5, 4), 1);
        assert_eq!(Wrap::ClampToEdge.index(-3, 4), 0);
        assert_eq!(Wrap::ClampToEdge.index(9, 4), 3);
        assert_eq!(Wrap::MirroredRepeat.index(4, 4), 3);
        assert_eq!(Wrap::MirroredRepeat.index(-1, 4), 0);
        assert_eq!(Wrap::MirroredRepeat.index(9, 4), 1);
    }

    #[test]
    fn texel_centres_are_exact_and_repeat_wraps() {
        let t = checker();
        let s = |u, v| t.sample(Vec2::new(u, v), (Wrap::Repeat, Wrap::Repeat), Filter::Linear);
        assert_eq!(s(0.25, 0.25), Vec4::new(1.0, 1.0, 1.0, 1.0));
        assert_eq!(s(0.75, 0.25), Vec4::new(0.0, 0.0, 0.0, 0.0));
        assert_eq!(s(1.25, -0.75), Vec4::new(1.0, 1.0, 1.0, 1.0));
        // Halfway between texel centres: the average of linear values.
        let mid = s(0.5, 0.25);
        assert!((mid.x - 0.5).abs() < 1e-6 && (mid.w - 0.5).abs() < 1e-6);
    }

    /// Data textures are read as they are stored: every code c gives exactly c / 255 (the
    /// truth: the division in f64, rounded) at the texel's centre and anywhere with the
    /// nearest filter; between centres the bilinear blend of equal texels is within 1 ulp
    /// (glam's lerp, a (1 - s) + a s). The sRGB path decodes the same code.
    #[test]
    fn linear_lookups_give_code_over_255_exactly() {
        for code in [0u8, 1, 37, 128, 200, 254, 255] {
            let t = Texture { width: 1, height: 1, rgba8: vec![[code, code, 255 - code, code]] };
            let want = (code as f64 / 255.0) as f32;
            let wrap = (Wrap::Repeat, Wrap::ClampToEdge);
            let centre = t.sample_linear(Vec2::splat(0.5), wrap, Filter::Linear);
            assert_eq!(centre.to_array(), [want, want, ((255 - code) as f64 / 255.0) as f32, want]);
            for uv in [Vec2::new(0.13, 0.77), Vec2::new(-3.2, 9.9)] {
                let v = t.sample_linear(uv, wrap, Filter::Nearest);
                assert_eq!(v, centre, "code {code}, nearest, {uv}");
                let v = t.sample_linear(uv, wrap, Filter::Linear);
                assert!((v - centre).abs().max_element() <= f32::EPSILON, "code {code}, linear, {uv}: {v}");
            }
            let srgb = t.sample(Vec2::splat(0.5), wrap, Filter::Nearest);
            assert_eq!(srgb.x, srgb_table()[code as usize]);
        }
    }
}
