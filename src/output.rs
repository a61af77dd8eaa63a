//! Image and report files, written all-or-nothing: each goes to a temporary file beside its
//! destination, and only when every one is written are they renamed into place. Images with
//! a non-finite value are refused. Every temporary file of the process is listed in one
//! registry, so a signal handler can remove them ([`remove_staged_files`]).

use glam::Vec3;
use image::ImageFormat;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Every temporary file of this process not yet renamed or removed. Created (and renamed)
/// under its lock, so [`remove_staged_files`] leaves none behind.
static STAGED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn staged_registry() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    STAGED.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Removes every temporary file this process has staged and not yet renamed, then keeps the
/// registry locked for good so that no other thread can stage another: for a signal handler
/// about to exit the process. Returns how many files it removed.
pub fn remove_staged_files() -> usize {
    let registry = staged_registry();
    let mut removed = 0;
    for tmp in registry.iter() {
        removed += usize::from(std::fs::remove_file(tmp).is_ok());
    }
    std::mem::forget(registry); // the process exits next; nothing may stage after this
    removed
}

/// An error if any value of `rgb` is not finite ("N of M values are not finite"): a NaN or
/// an infinity never reaches an output file.
pub fn check_finite(rgb: &[Vec3]) -> Result<(), String> {
    let bad: usize = rgb.iter().map(|c| c.to_array().iter().filter(|v| !v.is_finite()).count()).sum();
    if bad == 0 {
        Ok(())
    } else {
        Err(format!("{bad} of {} values are not finite (inf or NaN); nothing written", 3 * rgb.len()))
    }
}

/// Linear to sRGB-encoded 8-bit (clamped).
pub fn encode_srgb8(linear: f32) -> u8 {
    let c = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// How every EXR is encoded: exr's fast lossless encoding (RLE, 64 x 64 tiles), with the
/// tiles in increasing order. Its default order is "unspecified", which writes tiles as the
/// parallel compressors finish them: the same image gave different bytes from run to run
/// (any image of more than one tile), against the contract's same-bytes rule.
pub const EXR_ENCODING: exr::prelude::Encoding = exr::prelude::Encoding {
    line_order: exr::prelude::LineOrder::Increasing,
    ..exr::prelude::Encoding::FAST_LOSSLESS
};

/// Checks, before any work is done, that files can be written in `dir` (created later when
/// it does not exist yet): a render that took an hour should not fail at its last step on a
/// read-only folder. Tried, not inferred from permission bits (root writes into a 0o555
/// folder; a read-only mount refuses everyone): a probe file is created in `dir`, or in its
/// nearest existing ancestor, and removed at once. Nothing else is created.
///
/// # Errors
/// One line: the folder (or the ancestor it would be created in) and why it is unwritable.
pub fn check_writable_folder(dir: &Path) -> Result<(), String> {
    let dir = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
    let existing = dir.ancestors().find(|a| a.as_os_str().is_empty() || a.exists()).unwrap_or(dir);
    let existing = if existing.as_os_str().is_empty() { Path::new(".") } else { existing };
    if !existing.is_dir() {
        return Err(format!("{} is not a folder", existing.display()));
    }
    // Unique per call, not only per process: renders on several threads of one process
    // (the tests) probe the same folder at once, and `create_new` refuses a name in use.
    static PROBES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = PROBES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let probe = existing.join(format!(".penumbra-write-check.{}.{n}.tmp", std::process::id()));
    let created = {
        // Registered like a staged file, so that a signal in between removes it too.
        let mut registry = staged_registry();
        let created = std::fs::OpenOptions::new().write(true).create_new(true).open(&probe);
        if created.is_ok() {
            registry.push(probe.clone());
        }
        created
    };
    match created {
        Ok(_) => {
            let mut registry = staged_registry();
            let _ = std::fs::remove_file(&probe);
            registry.retain(|t| *t != probe);
            Ok(())
        }
        Err(e) if existing == dir => Err(format!("cannot write in the folder {}: {e}", dir.display())),
        Err(e) => Err(format!("cannot create the folder {} in {}: {e}", dir.display(), existing.display())),
    }
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

    /// Creates the temporary file for `path` (registered, under the registry's lock) and
    /// writes it with `write`.
    fn stage(
        &mut self,
        path: &Path,
        write: impl FnOnce(&mut BufWriter<File>) -> Result<(), String>,
    ) -> Result<(), String> {
        let tmp = Self::temp_for(path);
        let file = {
            let mut registry = staged_registry();
            let file = File::create(&tmp).map_err(|e| format!("{}: {e}", path.display()))?;
            registry.push(tmp.clone());
            file
        };
        self.staged.push((tmp.clone(), path.to_path_buf()));
        let mut out = BufWriter::new(file);
        let written = write(&mut out).and_then(|()| out.flush().map_err(|e| e.to_string()));
        if let Err(e) = written {
            self.unstage_last();
            return Err(format!("{}: {e}", path.display()));
        }
        Ok(())
    }

    /// Removes the last staged file (its write failed).
    fn unstage_last(&mut self) {
        if let Some((tmp, _)) = self.staged.pop() {
            let mut registry = staged_registry();
            let _ = std::fs::remove_file(&tmp);
            registry.retain(|t| *t != tmp);
        }
    }

    /// An sRGB 8-bit PNG of linear radiance. Refused if a value is not finite.
    pub fn png(&mut self, path: &Path, width: u32, height: u32, linear: &[Vec3]) -> Result<(), String> {
        check_finite(linear).map_err(|e| format!("{}: {e}", path.display()))?;
        let bytes: Vec<u8> = linear.iter().flat_map(|c| c.to_array().map(encode_srgb8)).collect();
        self.stage(path, |out| {
            image::write_buffer_with_format(
                out,
                &bytes,
                width,
                height,
                image::ColorType::Rgb8,
                ImageFormat::Png,
            )
            .map_err(|e| e.to_string())
        })
    }

    /// An RGB f32 OpenEXR. Refused if a value is not finite.
    pub fn exr(&mut self, path: &Path, width: u32, height: u32, rgb: &[Vec3]) -> Result<(), String> {
        use exr::prelude::{Image, Layer, LayerAttributes, SpecificChannels, WritableImage};
        check_finite(rgb).map_err(|e| format!("{}: {e}", path.display()))?;
        assert_eq!(rgb.len(), (width * height) as usize, "an EXR of width x height pixels");
        let w = width as usize;
        let channels = SpecificChannels::rgb(|p: exr::math::Vec2<usize>| {
            let c = rgb[p.y() * w + p.x()];
            (c.x, c.y, c.z)
        });
        let layer = Layer::new((w, height as usize), LayerAttributes::default(), EXR_ENCODING, channels);
        self.stage(path, |out| Image::from_layer(layer).write().to_buffered(out).map_err(|e| e.to_string()))
    }

    /// Any bytes (the JSON report).
    pub fn bytes(&mut self, path: &Path, bytes: &[u8]) -> Result<(), String> {
        self.stage(path, |out| out.write_all(bytes).map_err(|e| e.to_string()))
    }

    /// Renames every staged file into place. A destination that is a folder is refused
    /// before anything is renamed; if a rename still fails, the staged files not yet renamed
    /// are removed (by `Drop`).
    pub fn commit(mut self) -> Result<(), String> {
        if let Some((_, dst)) = self.staged.iter().find(|(_, dst)| dst.is_dir()) {
            return Err(format!("{}: is a folder", dst.display()));
        }
        while !self.staged.is_empty() {
            let (tmp, dst) = &self.staged[0];
            {
                let mut registry = staged_registry();
                std::fs::rename(tmp, dst).map_err(|e| format!("{}: {e}", dst.display()))?;
                registry.retain(|t| t != tmp);
            }
            self.staged.remove(0);
        }
        Ok(())
    }
}

impl Drop for StagedFiles {
    /// Files staged but never committed (an error part-way) are removed.
    fn drop(&mut self) {
        let mut registry = staged_registry();
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
            registry.retain(|t| t != tmp);
        }
    }
}

/// Makes SIGINT and SIGTERM remove every staged temporary file (`StagedFiles`) before the
/// process exits with status 128 + the signal (130, 143), as a shell reports a signal.
/// Call once, early in `main`.
pub fn exit_cleanly_on_signals() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else {
        return; // without a handler the default action (exit, temp files left) stays
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            let removed = remove_staged_files();
            let name = if signal == SIGINT { "SIGINT" } else { "SIGTERM" };
            eprintln!("penumbra: interrupted by {name}; removed {removed} temporary file(s)");
            std::process::exit(128 + signal);
        }
    });
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
    fn a_writable_folder_passes_the_check_and_keeps_no_probe() {
        let dir = std::env::temp_dir().join(format!("penumbra-writable-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        check_writable_folder(&dir).unwrap();
        // A folder yet to be created is checked in its nearest existing ancestor, and not
        // created by the check.
        check_writable_folder(&dir.join("a/b")).unwrap();
        assert!(!dir.join("a").exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "the probe was left behind");
        std::fs::write(dir.join("file"), b"").unwrap();
        let e = check_writable_folder(&dir.join("file/sub")).unwrap_err();
        assert_eq!(e, format!("{} is not a folder", dir.join("file").display()));
        std::fs::remove_dir_all(&dir).unwrap();
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
