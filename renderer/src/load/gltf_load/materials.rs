//! glTF materials as the metallic-roughness model defines them: factors range-checked (one
//! line naming the key), every texture reference with its own set, sampler and transform,
//! image sources checked before decoding, every pixel format widened to RGBA8; and the
//! material extensions a file uses that are not honoured, named in one warning.

use super::files::decodable_uri;
use super::images;
use super::*;
use crate::geometry::material::NormalTexture;

/// What a material's textures are read from: the file (errors name it), its folder (where
/// relative image URIs start), its document and buffers.
#[derive(Clone, Copy)]
pub(super) struct Source<'a> {
    pub(super) path: &'a Path,
    pub(super) base: &'a Path,
    pub(super) doc: &'a gltf::Document,
    pub(super) buffers: &'a [gltf::buffer::Data],
}

/// A texture reference as the file gives it: the texture, its own `texCoord`, and
/// KHR_texture_transform's offset, rotation, scale and `texCoord` override.
struct TextureInfo<'a> {
    texture: gltf::Texture<'a>,
    tex_coord: u32,
    transform: Option<gltf::json::extensions::texture::TextureTransform>,
}

impl<'a> TextureInfo<'a> {
    fn of(info: &gltf::texture::Info<'a>) -> Self {
        let transform = info.texture_transform().map(|t| gltf::json::extensions::texture::TextureTransform {
            offset: gltf::json::extensions::texture::TextureTransformOffset(t.offset()),
            rotation: gltf::json::extensions::texture::TextureTransformRotation(t.rotation()),
            scale: gltf::json::extensions::texture::TextureTransformScale(t.scale()),
            tex_coord: t.tex_coord(),
            extras: Default::default(),
        });
        TextureInfo { texture: info.texture(), tex_coord: info.tex_coord(), transform }
    }

    /// gltf reads KHR_texture_transform on textureInfo only: a normalTexture's is read here
    /// from its raw extension (`fail` makes the error for a malformed one).
    fn of_normal(
        n: &gltf::material::NormalTexture<'a>,
        fail: impl Fn(String) -> SceneError,
    ) -> Result<Self, SceneError> {
        let transform = match n.extension_value("KHR_texture_transform") {
            None => None,
            Some(v) => Some(serde_json::from_value(v.clone()).map_err(|e| fail(e.to_string()))?),
        };
        Ok(TextureInfo { texture: n.texture(), tex_coord: n.tex_coord(), transform })
    }

    /// The set it reads: the transform's override first.
    fn set(&self) -> u32 {
        self.transform.as_ref().and_then(|t| t.tex_coord).unwrap_or(self.tex_coord)
    }
}

/// Appends the file's materials to `geometry`, their textures decoded once each.
pub(super) fn load_materials(src: Source, geometry: &mut Geometry) -> Result<(), SceneError> {
    // glTF image index -> slot in `geometry.textures`.
    let mut image_slots: HashMap<usize, u32> = HashMap::new();
    for m in src.doc.materials() {
        let material = load_material(src, &m, &mut image_slots, geometry)?;
        geometry.materials.push(material);
    }
    Ok(())
}

/// One material: its factors checked, its textures decoded into `geometry.textures` (the
/// first time any material uses each image: `image_slots` remembers where); under diffuse
/// shading its base colour texture alone.
fn load_material(
    src: Source,
    m: &gltf::Material,
    image_slots: &mut HashMap<usize, u32>,
    geometry: &mut Geometry,
) -> Result<Material, SceneError> {
    let key = format!("materials[{}]", m.index().unwrap_or(0));
    let fail = |k: &str, msg: String| SceneError::new(src.path, format!("{key}.{k}"), msg);
    let pbr = m.pbr_metallic_roughness();
    let base_color = Vec4::from(pbr.base_color_factor());
    if !base_color.to_array().iter().all(|c| (0.0..=1.0).contains(c)) {
        return Err(fail(
            "pbrMetallicRoughness.baseColorFactor",
            format!("each channel must be in [0, 1] (an albedo), got {:?}", base_color.to_array()),
        ));
    }
    let unit = |k: &str, v: f32| {
        if (0.0..=1.0).contains(&v) { Ok(v) } else { Err(fail(k, format!("must be in [0, 1], got {v}"))) }
    };
    let metallic = unit("pbrMetallicRoughness.metallicFactor", pbr.metallic_factor())?;
    let roughness = unit("pbrMetallicRoughness.roughnessFactor", pbr.roughness_factor())?;
    let emissive = m.emissive_factor();
    if !emissive.iter().all(|c| (0.0..=1.0).contains(c)) {
        return Err(fail("emissiveFactor", format!("each channel must be in [0, 1], got {emissive:?}")));
    }
    let strength = m.emissive_strength().unwrap_or(1.0);
    if !(strength.is_finite() && strength >= 0.0) {
        return Err(fail(
            "extensions.KHR_materials_emissive_strength.emissiveStrength",
            format!("must be finite and >= 0, got {strength}"),
        ));
    }
    // Diffuse shading reads the base colour alone: its other textures are not decoded (they
    // would cost it memory and time for nothing), as before materials were read.
    let gltf = geometry.shading == Shading::Gltf;
    let mut textures = Textures { src, image_slots, geometry, material: &key };
    let base_color_texture =
        textures.optional("pbrMetallicRoughness.baseColorTexture", pbr.base_color_texture())?;
    let metallic_roughness_texture = textures.optional(
        "pbrMetallicRoughness.metallicRoughnessTexture",
        pbr.metallic_roughness_texture().filter(|_| gltf),
    )?;
    let emissive_texture = textures.optional("emissiveTexture", m.emissive_texture().filter(|_| gltf))?;
    let normal_texture = match m.normal_texture() {
        None => None,
        Some(n) => {
            let scale = n.scale();
            if !scale.is_finite() {
                return Err(fail("normalTexture.scale", format!("must be finite, got {scale}")));
            }
            let info =
                TextureInfo::of_normal(&n, |e| fail("normalTexture.extensions.KHR_texture_transform", e))?;
            gltf.then(|| textures.reference("normalTexture", &info))
                .transpose()?
                .map(|texture| NormalTexture { texture, scale })
        }
    };
    let alpha = match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
        gltf::material::AlphaMode::Mask => AlphaMode::Mask { cutoff: m.alpha_cutoff().unwrap_or(0.5) },
        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
    };
    let material = Material {
        base_color,
        base_color_texture,
        alpha,
        metallic,
        roughness,
        metallic_roughness_texture,
        normal_texture,
        emission: Vec3::from(emissive) * strength,
        emissive_texture,
    };
    check_uv_sets(&material).map_err(|(k, msg)| fail(&format!("{k}.texCoord"), msg))?;
    Ok(material)
}

/// A triangle holds two texture-coordinate sets: the base colour texture's and one other.
/// A material whose other textures read two sets besides the base colour's is refused,
/// naming the texture that reads the third (its `texCoord`, or KHR_texture_transform's).
fn check_uv_sets(m: &Material) -> Result<(), (&'static str, String)> {
    let (base, second) = (m.base_uv_set(), m.second_uv_set());
    for (k, t) in m.other_textures() {
        if let Some(t) = t.filter(|t| t.tex_coord != base && Some(t.tex_coord) != second) {
            let (k, set) = (k, t.tex_coord);
            return Err((
                k,
                format!(
                    "reads TEXCOORD_{set}, a third set (the base colour texture reads TEXCOORD_{base}, \
                     another texture TEXCOORD_{}): at most two sets per material are read",
                    second.unwrap_or(base)
                ),
            ));
        }
    }
    Ok(())
}

/// One material's texture references, decoded into the scene's textures as they are met.
struct Textures<'s, 'g> {
    src: Source<'s>,
    image_slots: &'s mut HashMap<usize, u32>,
    geometry: &'g mut Geometry,
    /// The material's key (`materials[i]`), for errors naming what reads an image.
    material: &'s str,
}

impl Textures<'_, '_> {
    /// The reference `info` gives, if any (`key`: its key in the material).
    fn optional(
        &mut self,
        key: &str,
        info: Option<gltf::texture::Info>,
    ) -> Result<Option<TextureRef>, SceneError> {
        info.map(|i| self.reference(key, &TextureInfo::of(&i))).transpose()
    }

    /// A texture reference (`key` in the material): its image decoded into
    /// `geometry.textures` the first time any material uses it, with the sampler's wrap modes
    /// and filter, the KHR_texture_transform and the set it reads.
    fn reference(&mut self, key: &str, info: &TextureInfo) -> Result<TextureRef, SceneError> {
        let user = format!("textures[{}], {}.{key}", info.texture.index(), self.material);
        let slot = self.image_slot(&info.texture.source(), &user)?;
        let sampler = info.texture.sampler();
        let transform = info
            .transform
            .as_ref()
            .map_or(Affine2::IDENTITY, |t| uv_transform(t.offset.0, t.rotation.0, t.scale.0));
        Ok(TextureRef {
            texture: slot,
            wrap_s: wrap(sampler.wrap_s()),
            wrap_t: wrap(sampler.wrap_t()),
            filter: filter(sampler.mag_filter(), sampler.min_filter()),
            transform,
            tex_coord: info.set(),
        })
    }

    /// Where `image` is in `geometry.textures`, decoding it the first time (`user` names
    /// the reference that reads it, for its errors).
    fn image_slot(&mut self, image: &gltf::Image, user: &str) -> Result<u32, SceneError> {
        if let Some(&s) = self.image_slots.get(&image.index()) {
            return Ok(s);
        }
        let Source { path, doc, buffers, .. } = self.src;
        if let Some(msg) = image_source_problem(doc, image.index(), buffers) {
            return Err(SceneError::new(path, format!("images[{}]", image.index()), msg));
        }
        let held = self.geometry.textures.iter().map(|t| t.rgba8.len() as u64 * 4).sum();
        let room = images::Room { limit: self.geometry.memory_limit, held };
        let tex = images::decode(self.src, image, user, room)?;
        self.geometry.textures.push(tex);
        let s = self.geometry.textures.len() as u32 - 1;
        self.image_slots.insert(image.index(), s);
        Ok(s)
    }
}

/// The material extensions of `doc` not honoured (every one on a material but
/// KHR_materials_emissive_strength, and every KHR_materials_* the file lists as used, such
/// as KHR_materials_variants), sorted: their materials are read as metallic-roughness.
pub(super) fn unhonoured_extensions(doc: &gltf::Document) -> Vec<String> {
    const HONOURED: &[&str] = &["KHR_materials_emissive_strength"];
    let on_materials = doc
        .materials()
        .flat_map(|m| m.extensions().map(|e| e.keys().cloned().collect::<Vec<_>>()).unwrap_or_default());
    let listed = doc.extensions_used().filter(|e| e.starts_with("KHR_materials_")).map(String::from);
    let mut names: Vec<String> =
        on_materials.chain(listed).filter(|e| !HONOURED.contains(&e.as_str())).collect();
    names.sort();
    names.dedup();
    names
}

/// What gltf's `Image::source` and `image::Data::from_source` panic on and its validation
/// lets through: a bufferView without a mimeType and a bufferView outside its buffer (both
/// found by fuzzing), neither a uri nor a bufferView (the unwrap beside the first), and a
/// uri that gltf cannot decode ([`decodable_uri`]).
pub(super) fn image_source_problem(
    doc: &gltf::Document,
    index: usize,
    buffers: &[gltf::buffer::Data],
) -> Option<String> {
    let json = &doc.as_json().images[index];
    match (&json.buffer_view, &json.mime_type, &json.uri) {
        (Some(_), None, _) => Some("has a bufferView but no mimeType".into()),
        (None, _, None) => Some("has neither a uri nor a bufferView".into()),
        (None, _, Some(uri)) if !decodable_uri(uri) => {
            Some("uri: its %-escapes do not decode to UTF-8".into())
        }
        (Some(v), Some(_), _) => {
            let view = doc.views().nth(v.value())?; // the index is validated
            let len = buffers[view.buffer().index()].len();
            match view.offset().checked_add(view.length()) {
                Some(end) if end <= len => None,
                _ => Some(format!(
                    "bufferViews[{}] (offset {}, length {}) lies outside its buffer ({len} bytes)",
                    v.value(),
                    view.offset(),
                    view.length()
                )),
            }
        }
        (None, _, Some(_)) => None,
    }
}

/// The sampler's filter for a lookup at one point: its `magFilter`, else the base of its
/// `minFilter` (`NEAREST_MIPMAP_*` is nearest within a level), else linear (glTF leaves the
/// default to the renderer).
fn filter(mag: Option<gltf::texture::MagFilter>, min: Option<gltf::texture::MinFilter>) -> Filter {
    use gltf::texture::{MagFilter, MinFilter};
    match (mag, min) {
        (Some(MagFilter::Nearest), _) => Filter::Nearest,
        (Some(MagFilter::Linear), _) => Filter::Linear,
        (
            None,
            Some(MinFilter::Nearest | MinFilter::NearestMipmapNearest | MinFilter::NearestMipmapLinear),
        ) => Filter::Nearest,
        _ => Filter::Linear,
    }
}

pub(super) fn wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

/// KHR_texture_transform's matrix: scale, then rotation, then offset. The rotation turns the
/// glTF way (u right, v down: positive turns from +v towards +u), as the Khronos sample
/// viewer, three.js and Blender's importer read it, not as the extension README's GLSL listing
/// does (KhronosGroup/glTF#1563): that listing turns the README's own example the other way.
fn uv_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Affine2 {
    let (s, c) = rotation.sin_cos();
    let turn = Mat2::from_cols(Vec2::new(c, -s), Vec2::new(s, c));
    Affine2::from_mat2_translation(turn * Mat2::from_diagonal(Vec2::from(scale)), Vec2::from(offset))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The extension README's example: offset [0, 1], rotation pi/2, scale 0.5 shows the
    /// texture's lower-left quadrant (u < 0.5, v > 0.5 with v down) over the whole surface.
    #[test]
    fn texture_transform_turns_the_readme_example_to_the_lower_left_quadrant() {
        let t = uv_transform([0.0, 1.0], std::f32::consts::FRAC_PI_2, [0.5, 0.5]);
        for (u, v) in [(0.01, 0.01), (0.5, 0.5), (0.99, 0.01), (0.01, 0.99), (0.99, 0.99)] {
            let q = t.transform_point2(Vec2::new(u, v));
            // Repeat wrapping, as the sampler's default.
            let w = q - q.floor();
            assert!(w.x <= 0.5 + 1e-6 && w.y >= 0.5 - 1e-6, "uv ({u}, {v}) -> {q} (wrapped {w})");
        }
        let centre = t.transform_point2(Vec2::splat(0.5));
        assert!((centre - Vec2::new(0.25, 0.75)).length() < 1e-6, "centre -> {centre}");
    }
}
