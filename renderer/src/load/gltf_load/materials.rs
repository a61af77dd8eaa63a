//! glTF materials and their base-colour textures: image sources checked before decoding,
//! every pixel format widened to RGBA8.

use super::files::{decodable_uri, uri_path};
use super::*;

/// Appends the file's materials to `geometry` (only what shading and the alpha test need),
/// with their base colour textures decoded once each. `base` is the folder of `path`, which
/// relative image URIs start from.
pub(super) fn load_materials(
    path: &Path,
    base: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    geometry: &mut Geometry,
) -> Result<(), SceneError> {
    let fail = |key: &str, msg: String| SceneError::new(path, key, msg);
    // glTF image index -> slot in `geometry.textures`.
    let mut image_slots: HashMap<usize, u32> = HashMap::new();
    for m in doc.materials() {
        let key = format!("materials[{}]", m.index().unwrap_or(0));
        let pbr = m.pbr_metallic_roughness();
        let base_color = Vec4::from(pbr.base_color_factor());
        if !base_color.to_array().iter().all(|c| (0.0..=1.0).contains(c)) {
            return Err(fail(
                &format!("{key}.pbrMetallicRoughness.baseColorFactor"),
                format!("each channel must be in [0, 1] (an albedo), got {:?}", base_color.to_array()),
            ));
        }
        let base_color_texture = match pbr.base_color_texture() {
            None => None,
            Some(info) => Some(texture_ref(path, base, doc, &info, buffers, &mut image_slots, geometry)?),
        };
        let alpha = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask { cutoff: m.alpha_cutoff().unwrap_or(0.5) },
            gltf::material::AlphaMode::Blend => AlphaMode::Mask { cutoff: 0.5 },
        };
        geometry.materials.push(Material { base_color, base_color_texture, alpha });
    }
    Ok(())
}

/// A material's base colour texture: its image decoded into `geometry.textures` the first
/// time any material uses it (`image_slots` remembers where), with the sampler's wrap modes
/// and the KHR_texture_transform, if any.
pub(super) fn texture_ref(
    path: &Path,
    base: &Path,
    doc: &gltf::Document,
    info: &gltf::texture::Info,
    buffers: &[gltf::buffer::Data],
    image_slots: &mut HashMap<usize, u32>,
    geometry: &mut Geometry,
) -> Result<TextureRef, SceneError> {
    let fail = |key: &str, msg: String| SceneError::new(path, key, msg);
    let texture = info.texture();
    let image = texture.source();
    let slot = match image_slots.get(&image.index()) {
        Some(&s) => s,
        None => {
            if let Some(msg) = image_source_problem(doc, image.index(), buffers) {
                return Err(fail(&format!("images[{}]", image.index()), msg));
            }
            let data = gltf::image::Data::from_source(image.source(), Some(base), buffers).map_err(|e| {
                let (key, what) = match image.source() {
                    gltf::image::Source::Uri { uri, .. } => match uri_path(base, uri) {
                        Some(p) => (format!("images[{}].uri", image.index()), p.display().to_string()),
                        None => (format!("images[{}].uri", image.index()), "the data URI".into()),
                    },
                    gltf::image::Source::View { view, .. } => (
                        format!("images[{}].bufferView", image.index()),
                        format!("bufferViews[{}]", view.index()),
                    ),
                };
                fail(&key, format!("cannot read or decode {what}: {e}"))
            })?;
            let tex = to_rgba8(&data).ok_or_else(|| {
                fail(
                    &format!("images[{}]", image.index()),
                    format!("unsupported pixel format {:?}", data.format),
                )
            })?;
            geometry.textures.push(tex);
            let s = geometry.textures.len() as u32 - 1;
            image_slots.insert(image.index(), s);
            s
        }
    };
    let sampler = texture.sampler();
    let transform = info
        .texture_transform()
        .map_or(Affine2::IDENTITY, |t| uv_transform(t.offset(), t.rotation(), t.scale()));
    Ok(TextureRef {
        texture: slot,
        wrap_s: wrap(sampler.wrap_s()),
        wrap_t: wrap(sampler.wrap_t()),
        filter: filter(sampler.mag_filter(), sampler.min_filter()),
        transform,
    })
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

pub(super) fn to_rgba8(data: &gltf::image::Data) -> Option<Texture> {
    use gltf::image::Format;
    let px = &data.pixels;
    let (channels, bytes) = match data.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        _ => return None,
    };
    let stride = channels * bytes;
    let count = (data.width * data.height) as usize;
    if px.len() < count * stride {
        return None;
    }
    // 16-bit channels are little-endian in gltf's decoded data: keep the high byte.
    let get = |i: usize, ch: usize| px[i * stride + ch * bytes + bytes - 1];
    let rgba8 = (0..count)
        .map(|i| match channels {
            1 => {
                let g = get(i, 0);
                [g, g, g, 255]
            }
            2 => {
                let g = get(i, 0);
                [g, g, g, get(i, 1)]
            }
            3 => [get(i, 0), get(i, 1), get(i, 2), 255],
            _ => [get(i, 0), get(i, 1), get(i, 2), get(i, 3)],
        })
        .collect();
    Some(Texture { width: data.width, height: data.height, rgba8 })
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
