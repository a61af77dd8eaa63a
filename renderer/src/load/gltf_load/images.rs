//! Texture images read and decoded here rather than by gltf's `image::Data::from_source`:
//! that decodes under the image crate's default limit (512 MiB decoded), so a 16384^2 PNG was
//! refused as "Memory limit exceeded", naming neither the image, nor its size, nor the limit,
//! whatever the machine held. Here the limit is the load's own (the memory available, as for
//! triangles), the size is read from the image's header before anything is decoded, and a
//! refusal names the image, its size in pixels and bytes, the limit and what to change.

use super::files::uri_path;
use super::materials::Source;
use crate::geometry::material::Texture;
use crate::util::error::SceneError;
use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader, Limits};
use std::borrow::Cow;

/// The memory a load may use where the memory available is not known: what `penumbra`'s
/// memory budget assumes there.
const UNKNOWN_LIMIT: u64 = 4 << 30;

/// The memory textures may take: the load's limit (`None`: not known) and the bytes the
/// scene's textures already hold.
#[derive(Clone, Copy)]
pub(super) struct Room {
    pub(super) limit: Option<u64>,
    pub(super) held: u64,
}

/// `image` of the file `src` decoded to RGBA8. `user` names what reads it (`textures[0],
/// materials[0].pbrMetallicRoughness.baseColorTexture`). Errors name the image's key: one
/// too large for `room` is refused from its header, before it is decoded.
pub(super) fn decode(
    src: Source,
    image: &gltf::Image,
    user: &str,
    room: Room,
) -> Result<Texture, SceneError> {
    let i = image.index();
    let json = &src.doc.as_json().images[i];
    let (key, what) = match (&json.uri, &json.buffer_view) {
        (Some(uri), _) => (
            format!("images[{i}].uri"),
            uri_path(src.base, uri).map_or_else(|| "the data URI".into(), |p| p.display().to_string()),
        ),
        (None, view) => {
            (format!("images[{i}].bufferView"), format!("bufferViews[{}]", view.map_or(0, |v| v.value())))
        }
    };
    let fail = |msg: String| SceneError::new(src.path, &key, msg);
    let unreadable = |e: &dyn std::fmt::Display| fail(format!("cannot read or decode {what}: {e}"));
    let bytes = encoded(src, image).map_err(|e| unreadable(&e))?;
    let format = format_of(json.mime_type.as_ref().map(|m| m.0.as_str()), json.uri.as_deref(), &bytes)
        .ok_or_else(|| unreadable(&"not a PNG or JPEG image (the encodings glTF allows)"))?;
    let limit = room.limit.unwrap_or(UNKNOWN_LIMIT);
    let free = limit.saturating_sub(room.held);
    let mut reader = ImageReader::with_format(std::io::Cursor::new(&bytes[..]), format);
    let mut limits = Limits::default();
    limits.max_alloc = Some(free);
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(|e| unreadable(&e))?;
    let (width, height) = decoder.dimensions();
    let decoded = decoder.total_bytes();
    let need = decoded.saturating_add(u64::from(width) * u64::from(height) * 4);
    let too_large = || {
        let held = if room.held > 0 {
            format!(", less {} the scene's other textures hold", size(room.held))
        } else {
            String::new()
        };
        let available = match room.limit {
            Some(_) => {
                "the memory available when the load began: the least of MemAvailable, the \
                        cgroup's headroom under memory.max and ulimit -v's"
            }
            None => "the memory available is not known here, so 4 GiB is assumed",
        };
        fail(format!(
            "{what} ({user}) is {width} x {height} pixels: {} decoded and {} as an RGBA8 texture, \
             over the {} of memory the load may use ({available}{held}); free memory or raise \
             those limits, or downscale the image",
            size(decoded),
            size(need - decoded),
            size(free),
        ))
    };
    if need > free {
        return Err(too_large());
    }
    let decoded = DynamicImage::from_decoder(decoder).map_err(|e| match e {
        image::ImageError::Limits(_) => too_large(),
        e => unreadable(&e),
    })?;
    to_texture(decoded)
        .ok_or_else(|| SceneError::new(src.path, format!("images[{i}]"), "unsupported pixel format"))
}

/// The encoded bytes of `image`: its bufferView's (checked to lie inside its buffer before),
/// or its URI's, read as gltf reads a buffer's (a file, or a base64 `data:` URI).
fn encoded<'a>(src: Source<'a>, image: &gltf::Image<'a>) -> Result<Cow<'a, [u8]>, gltf::Error> {
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let buffer = &src.buffers[view.buffer().index()];
            Ok(Cow::Borrowed(&buffer[view.offset()..view.offset() + view.length()]))
        }
        gltf::image::Source::Uri { uri, .. } => {
            let source = gltf::buffer::Source::Uri(uri);
            let data = gltf::buffer::Data::from_source_and_blob(source, Some(src.base), &mut None)?;
            Ok(Cow::Owned(data.0))
        }
    }
}

/// PNG or JPEG, as gltf chooses: the mimeType (a `data:` URI's own first), else a URI's
/// extension, else the bytes' signature.
fn format_of(mime: Option<&str>, uri: Option<&str>, bytes: &[u8]) -> Option<ImageFormat> {
    let data_mime = uri.and_then(|u| u.strip_prefix("data:")).and_then(|r| r.split([';', ',']).next());
    let extension = uri.filter(|u| !u.starts_with("data:")).and_then(|u| u.rsplit('.').next());
    let named = match data_mime.or(mime) {
        Some("image/png") => Some(ImageFormat::Png),
        Some("image/jpeg") => Some(ImageFormat::Jpeg),
        _ => match extension {
            Some("png") => Some(ImageFormat::Png),
            Some("jpg" | "jpeg") => Some(ImageFormat::Jpeg),
            _ => None,
        },
    };
    named.or_else(|| {
        image::guess_format(bytes).ok().filter(|f| matches!(f, ImageFormat::Png | ImageFormat::Jpeg))
    })
}

/// `b` bytes for a reader: MiB below a GiB, else GiB.
fn size(b: u64) -> String {
    if b < 1 << 30 {
        format!("{} MiB", b.div_ceil(1 << 20))
    } else {
        format!("{:.1} GiB", b as f64 / (1u64 << 30) as f64)
    }
}

/// Every pixel format PNG and JPEG decode to, widened to RGBA8; 16-bit channels keep their
/// high byte. `None` for a float format (neither decodes to one).
fn to_texture(image: DynamicImage) -> Option<Texture> {
    let (width, height) = (image.width(), image.height());
    let high = |v: u16| (v >> 8) as u8;
    let rgba8 = match image {
        DynamicImage::ImageLuma8(b) => widen(b.as_raw(), 1, |v| v),
        DynamicImage::ImageLumaA8(b) => widen(b.as_raw(), 2, |v| v),
        DynamicImage::ImageRgb8(b) => widen(b.as_raw(), 3, |v| v),
        DynamicImage::ImageRgba8(b) => widen(b.as_raw(), 4, |v| v),
        DynamicImage::ImageLuma16(b) => widen(b.as_raw(), 1, high),
        DynamicImage::ImageLumaA16(b) => widen(b.as_raw(), 2, high),
        DynamicImage::ImageRgb16(b) => widen(b.as_raw(), 3, high),
        DynamicImage::ImageRgba16(b) => widen(b.as_raw(), 4, high),
        _ => return None,
    };
    Some(Texture { width, height, rgba8 })
}

/// Pixels of `channels` channels (grey, grey + alpha, RGB, RGBA) as RGBA8, each channel
/// narrowed by `to8`.
fn widen<T: Copy>(px: &[T], channels: usize, to8: impl Fn(T) -> u8) -> Vec<[u8; 4]> {
    px.chunks_exact(channels)
        .map(|c| match *c {
            [g] => [to8(g), to8(g), to8(g), 255],
            [g, a] => [to8(g), to8(g), to8(g), to8(a)],
            [r, g, b] => [to8(r), to8(g), to8(b), 255],
            [r, g, b, a, ..] => [to8(r), to8(g), to8(b), to8(a)],
            [] => [0; 4],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_channel_layout_widens_to_rgba8_keeping_16_bits_high_byte() {
        assert_eq!(widen(&[7u8], 1, |v| v), [[7, 7, 7, 255]]);
        assert_eq!(widen(&[7u8, 9], 2, |v| v), [[7, 7, 7, 9]]);
        assert_eq!(widen(&[1u8, 2, 3], 3, |v| v), [[1, 2, 3, 255]]);
        assert_eq!(
            widen(&[0x1234u16, 0xff00, 0x00ff, 0xabcd], 4, |v| (v >> 8) as u8),
            [[0x12, 0xff, 0, 0xab]]
        );
    }

    #[test]
    fn the_format_follows_the_mime_type_then_the_extension_then_the_bytes() {
        let png = b"\x89PNG\r\n\x1a\n";
        assert_eq!(format_of(Some("image/jpeg"), Some("a.png"), png), Some(ImageFormat::Jpeg));
        assert_eq!(format_of(None, Some("data:image/png;base64,AAAA"), &[]), Some(ImageFormat::Png));
        assert_eq!(format_of(None, Some("a.jpeg"), &[]), Some(ImageFormat::Jpeg));
        assert_eq!(format_of(None, Some("a.bin"), png), Some(ImageFormat::Png));
        assert_eq!(format_of(None, None, b"GIF89a"), None);
    }
}
