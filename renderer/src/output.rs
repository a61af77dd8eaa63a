//! Image and report files, written all-or-nothing: each goes to a temporary file beside its
//! destination, and only when every one is written are they renamed into place.

use glam::Vec3;
use image::{ImageBuffer, ImageFormat, Rgb};
use std::path::{Path, PathBuf};

/// Linear to sRGB-encoded 8-bit (clamped).
pub fn encode_srgb8(linear: f32) -> u8 {
    let c = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// Files staged for an all-or-nothing write.
#[derive(Debug, Default)]
pub struct StagedFiles {
    staged: Vec<(PathBuf, PathBuf)>,
}

impl StagedFiles {
    fn temp_for(path: &Path) -> PathBuf {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
    }

    fn stage(&mut self, path: &Path, write: impl FnOnce(&Path) -> Result<(), String>) -> Result<(), String> {
        let tmp = Self::temp_for(path);
        if let Err(e) = write(&tmp) {
            let _ = std::fs::remove_file(&tmp);
            return Err(format!("{}: {e}", path.display()));
        }
        self.staged.push((tmp, path.to_path_buf()));
        Ok(())
    }

    /// An sRGB 8-bit PNG of linear radiance.
    pub fn png(&mut self, path: &Path, width: u32, height: u32, linear: &[Vec3]) -> Result<(), String> {
        let bytes: Vec<u8> = linear.iter().flat_map(|c| c.to_array().map(encode_srgb8)).collect();
        self.stage(path, |tmp| {
            image::save_buffer_with_format(
                tmp,
                &bytes,
                width,
                height,
                image::ColorType::Rgb8,
                ImageFormat::Png,
            )
            .map_err(|e| e.to_string())
        })
    }

    /// An RGB f32 OpenEXR.
    pub fn exr(&mut self, path: &Path, width: u32, height: u32, rgb: &[Vec3]) -> Result<(), String> {
        let data: Vec<f32> = rgb.iter().flat_map(|c| c.to_array()).collect();
        let img: ImageBuffer<Rgb<f32>, Vec<f32>> =
            ImageBuffer::from_raw(width, height, data).ok_or("buffer size mismatch")?;
        self.stage(path, |tmp| img.save_with_format(tmp, ImageFormat::OpenExr).map_err(|e| e.to_string()))
    }

    /// Any bytes (the JSON report).
    pub fn bytes(&mut self, path: &Path, bytes: &[u8]) -> Result<(), String> {
        self.stage(path, |tmp| std::fs::write(tmp, bytes).map_err(|e| e.to_string()))
    }

    /// Renames every staged file into place.
    /// Renames every staged file into place. A destination that is a folder is refused
    /// before anything is renamed; if a rename still fails, the staged files not yet renamed
    /// are removed (by `Drop`).
    pub fn commit(mut self) -> Result<(), String> {
        if let Some((_, dst)) = self.staged.iter().find(|(_, dst)| dst.is_dir()) {
            return Err(format!("{}: is a folder", dst.display()));
        }
        while !self.staged.is_empty() {
            let (tmp, dst) = &self.staged[0];
            std::fs::rename(tmp, dst).map_err(|e| format!("{}: {e}", dst.display()))?;
            self.staged.remove(0);
        }
        Ok(())
    }
}

impl Drop for StagedFiles {
    /// Files staged but never committed (an error part-way) are removed.
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encoding_matches_the_standard() {
        assert_eq!(encode_srgb8(0.0), 0);
        assert_eq!(encode_srgb8(1.0), 255);
        assert_eq!(encode_srgb8(2.0), 255);
        assert_eq!(encode_srgb8(f32::NAN), 0);
        // Linear 0.2158605 is sRGB 128/255.
        assert_eq!(encode_srgb8(0.215_860_5), 128);
    }

    #[test]
    fn uncommitted_files_leave_nothing_behind() {
        let dir = std::env::temp_dir().join(format!("penumbra-staged-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = dir.join("a.json");
        {
            let mut s = StagedFiles::default();
            s.bytes(&a, b"{}").unwrap();
        }
        assert!(!a.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        let mut s = StagedFiles::default();
        s.bytes(&a, b"{}").unwrap();
        s.png(&dir.join("b.png"), 1, 1, &[Vec3::ONE]).unwrap();
        s.commit().unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"{}");
        assert_eq!(image::open(dir.join("b.png")).unwrap().to_rgb8().get_pixel(0, 0).0, [255, 255, 255]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
