//! `render --profile`: the run's trace (Chrome trace-event JSON, from the `tracing` spans of
//! every crate through `tracing-chrome`), the per-pixel cost EXR and its heat map.

use crate::heat;
use renderer::util::pixel_cost::PixelCost;
use std::io::Write;
use std::sync::{Arc, Mutex};
use tracing_chrome::{ChromeLayerBuilder, FlushGuard};
use tracing_subscriber::layer::SubscriberExt;

/// The trace being recorded: a dispatcher to install on every thread of the run, and the
/// buffer the Chrome layer writes (staged with the other outputs once the run is done, so a
/// failed run leaves no half-written trace).
pub struct Trace {
    pub dispatch: tracing::Dispatch,
    guard: FlushGuard,
    buffer: SharedBuffer,
}

/// A `Write` into memory that the Chrome layer's writer thread and the run share.
#[derive(Clone, Default)]
struct SharedBuffer(Arc<Mutex<Vec<u8>>>);

impl Write for SharedBuffer {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).extend_from_slice(bytes);
        Ok(bytes.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Trace {
    /// Starts recording: spans become trace events once `dispatch` is installed on a thread.
    pub fn start() -> Self {
        let buffer = SharedBuffer::default();
        let (layer, guard) = ChromeLayerBuilder::new().writer(buffer.clone()).include_args(true).build();
        let subscriber = tracing_subscriber::registry().with(layer);
        Trace { dispatch: tracing::Dispatch::new(subscriber), guard, buffer }
    }

    /// Ends the trace (every span closed by now) and returns its JSON.
    pub fn finish(self) -> Vec<u8> {
        let Trace { dispatch, guard, buffer } = self;
        drop(dispatch);
        drop(guard); // flushes and closes the JSON array
        std::mem::take(&mut *buffer.0.lock().unwrap_or_else(|p| p.into_inner()))
    }
}

/// The cost EXR: one-channel layers `time.Y` (seconds of shading, f32) and `rays.Y`,
/// `shafts.Y`, `lookups.Y` (counts, u32), per pixel; a tile's also `missed.Y` (1 where no
/// primary ray hits), for the merged heat map.
pub fn cost_exr(
    width: u32,
    height: u32,
    costs: &[PixelCost],
    missed: Option<&[bool]>,
) -> Result<Vec<u8>, String> {
    use exr::prelude::*;
    let count = |f: fn(&PixelCost) -> u64| {
        FlatSamples::U32(costs.iter().map(|c| f(c).min(u32::MAX as u64) as u32).collect())
    };
    let mut layers = vec![
        AnyChannel::new("time.Y", FlatSamples::F32(costs.iter().map(|c| c.time_s).collect())),
        AnyChannel::new("rays.Y", count(|c| c.work.rays)),
        AnyChannel::new("shafts.Y", count(|c| c.work.shafts)),
        AnyChannel::new("lookups.Y", count(|c| c.work.lookups)),
    ];
    if let Some(missed) = missed {
        layers
            .push(AnyChannel::new("missed.Y", FlatSamples::U32(missed.iter().map(|&m| m as u32).collect())));
    }
    let channels = AnyChannels::sort(SmallVec::from_vec(layers));
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        crate::output::EXR_ENCODING,
        channels,
    );
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut out).map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

/// The cost heat map as a PNG: each pixel's shading time on a log scale (`heat`), misses
/// (no primary hit: `missed[i]`) in the marked colour, with a legend.
pub fn cost_png(width: u32, height: u32, costs: &[PixelCost], missed: &[bool]) -> Result<Vec<u8>, String> {
    let times: Vec<Option<f64>> =
        costs.iter().zip(missed).map(|(c, &m)| (!m).then_some(c.time_s as f64)).collect();
    heat::log_heat_map_png(width, height, &times, "shading time per pixel")
}
