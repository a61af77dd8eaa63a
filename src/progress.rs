//! The progress display of `render`: one line on stderr naming the phase under way, a bar
//! for the phases that report rows (primary rays, shading), a spinner for the others
//! (loading and the BVH, gathering the visible points, the shadow method's prepare, writing).
//! Hidden with `--quiet` or when stderr is not a terminal.

use indicatif::{ProgressBar, ProgressStyle};
use renderer::integrator::render::Progress;
use std::io::IsTerminal;
use std::time::Duration;

pub struct PhaseProgress {
    bar: ProgressBar,
}

impl PhaseProgress {
    pub fn new(quiet: bool) -> Self {
        let bar = if quiet || !std::io::stderr().is_terminal() {
            ProgressBar::hidden()
        } else {
            ProgressBar::new_spinner()
        };
        PhaseProgress { bar }
    }

    /// A phase begins: a bar over `rows`, or a spinner when it reports none.
    pub fn phase(&self, name: &str, rows: u64) {
        if self.bar.is_hidden() {
            return;
        }
        let template = if rows > 0 {
            "{spinner} {msg} [{bar:40}] {pos}/{len} rows, {elapsed} (eta {eta})"
        } else {
            "{spinner} {msg}, {elapsed}"
        };
        // Message and length before the style: every setter may draw, and a frame drawn
        // between them should not show the new style with the old phase's numbers.
        self.bar.set_message(name.to_string());
        self.bar.set_length(rows);
        self.bar.reset();
        self.bar.set_style(
            ProgressStyle::with_template(template).expect("a valid template").progress_chars("=> "),
        );
        // Phases that report nothing until they end still show they are alive.
        self.bar.enable_steady_tick(Duration::from_millis(100));
    }

    /// What the renderer reports, from any thread.
    pub fn report(&self, p: Progress) {
        match p {
            Progress::Phase { name, rows } => self.phase(name, rows),
            Progress::Rows(n) => self.bar.inc(n),
        }
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
