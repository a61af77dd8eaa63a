//! Materials: two-sided Lambertian albedo = baseColorFactor x sRGB-decoded base colour
//! texture, with the glTF alpha mode.

use glam::{Affine2, Vec2, Vec4};
use std::sync::OnceLock;

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

/// An 8-bit RGBA image whose RGB is sRGB-encoded and whose alpha is linear.
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
    #[inline]
    fn texel(&self, x: usize, y: usize) -> Vec4 {
        let t = srgb_table();
        let [r, g, b, a] = self.rgba8[y * self.width as usize + x];
        Vec4::new(t[r as usize], t[g as usize], t[b as usize], a as f32 / 255.0)
    }

    /// The lookup at texture coordinate `uv` in linear space: bilinear, or the texel `uv`
    /// falls in ([`Filter::Nearest`]).
    pub fn sample(&self, uv: Vec2, (wrap_s, wrap_t): (Wrap, Wrap), filter: Filter) -> Vec4 {
        if filter == Filter::Nearest {
            let (x, y) = (uv.x * self.width as f32, uv.y * self.height as f32);
            if !(x.is_finite() && y.is_finite()) {
                return self.texel(0, 0);
            }
            return self.texel(
                wrap_s.index(x.floor() as i64, self.width),
                wrap_t.index(y.floor() as i64, self.height),
            );
        }
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return self.texel(0, 0);
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let xs = [wrap_s.index(x0, self.width), wrap_s.index(x0 + 1, self.width)];
        let ys = [wrap_t.index(y0, self.height), wrap_t.index(y0 + 1, self.height)];
        let top = self.texel(xs[0], ys[0]).lerp(self.texel(xs[1], ys[0]), fx);
        let bottom = self.texel(xs[0], ys[1]).lerp(self.texel(xs[1], ys[1]), fx);
        top.lerp(bottom, fy)
    }
}

/// A reference from a material to its base colour texture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureRef {
    /// Index into `Scene::textures`.
    pub texture: u32,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    pub filter: Filter,
    /// KHR_texture_transform (identity when absent).
    pub transform: Affine2,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlphaMode {
    Opaque,
    /// Surfaces with alpha < cutoff are holes, for every ray (BLEND is read as MASK 0.5).
    Mask {
        cutoff: f32,
    },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Linear RGBA factor.
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub alpha: AlphaMode,
}

impl Material {
    pub fn diffuse(rgb: [f32; 3]) -> Self {
        Self {
            base_color: Vec4::new(rgb[0], rgb[1], rgb[2], 1.0),
            base_color_texture: None,
            alpha: AlphaMode::Opaque,
        }
    }

    /// Linear RGBA at texture coordinate `uv`.
    pub fn base_color_at(&self, uv: Vec2, textures: &[Texture]) -> Vec4 {
        match &self.base_color_texture {
            Some(t) => {
                let uv = t.transform.transform_point2(uv);
                self.base_color * textures[t.texture as usize].sample(uv, (t.wrap_s, t.wrap_t), t.filter)
            }
            None => self.base_color,
        }
    }

    /// Whether a hit at `uv` is a hole under the alpha test.
    #[inline]
    pub fn is_cutout(&self, uv: Vec2, textures: &[Texture]) -> bool {
        match self.alpha {
            AlphaMode::Opaque => false,
            AlphaMode::Mask { cutoff } => self.base_color_at(uv, textures).w < cutoff,
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
}
