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
        // Every setter may draw a frame, so the order matters: the spinner's style, which
        // shows no count, first; then the message, the position and the length; the bar's
        // style last, once its numbers are the new phase's. (Message and length first drew
        // "480/0 rows": the finished bar's position with a spinner phase's length.)
        let style = |template: &str| {
            ProgressStyle::with_template(template).expect("a valid template").progress_chars("=> ")
        };
        self.bar.set_style(style("{spinner} {msg}, {elapsed}"));
        self.bar.set_message(name.to_string());
        self.bar.reset();
        if rows > 0 {
            self.bar.set_length(rows);
            self.bar.set_style(style("{spinner} {msg} [{bar:40}] {pos}/{len} rows, {elapsed} (eta {eta})"));
        } else {
            self.bar.unset_length();
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use indicatif::{ProgressDrawTarget, TermLike};
    use std::sync::{Arc, Mutex};

    /// A terminal that keeps every line drawn on it.
    #[derive(Debug, Clone, Default)]
    struct Recorder(Arc<Mutex<Vec<String>>>);

    impl TermLike for Recorder {
        fn width(&self) -> u16 {
            120
        }
        fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn write_line(&self, s: &str) -> std::io::Result<()> {
            self.write_str(s)
        }
        fn write_str(&self, s: &str) -> std::io::Result<()> {
            if !s.trim().is_empty() {
                self.0.lock().unwrap().push(s.to_string());
            }
            Ok(())
        }
        fn clear_line(&self) -> std::io::Result<()> {
            Ok(())
        }
        fn flush(&self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// Every frame drawn across the render's phase switches (a bar of 480 rows, run to the
    /// end, then a spinner phase, then a bar of 120 rows): none shows a length of 0, a
    /// position past its length or a count in a spinner phase. The switch once drew "480/0 rows": the finished bar's
    /// position with the spinner phase's length, in the bar's style.
    #[test]
    fn a_phase_switch_never_draws_a_stale_count() {
        let term = Recorder::default();
        let progress = PhaseProgress {
            // A refresh rate high enough that every setter's frame is drawn (the burst
            // allowance of indicatif's rate limiter covers the few frames here).
            bar: ProgressBar::with_draw_target(
                None,
                ProgressDrawTarget::term_like_with_hz(Box::new(term.clone()), 200),
            ),
        };
        progress.report(Progress::Phase { name: "primary rays", rows: 480 });
        progress.report(Progress::Rows(480));
        progress.report(Progress::Phase { name: "gathering visible points", rows: 0 });
        progress.report(Progress::Phase { name: "shading", rows: 120 });
        progress.report(Progress::Rows(8));
        progress.finish();
        let frames = term.0.lock().unwrap().clone();
        // The message setter draws at once (the steady tick draws the bars' counts later, so
        // they are not asserted here).
        for phase in ["primary rays", "gathering visible points", "shading"] {
            assert!(frames.iter().any(|f| f.contains(phase)), "{phase} never drawn: {frames:#?}");
        }
        for f in &frames {
            assert!(!f.contains("/0 rows"), "a bar of length 0: {f:?}");
            assert!(!f.contains("480/120"), "the last phase's position over this one's length: {f:?}");
            assert!(!(f.contains("gathering") && f.contains("rows")), "a spinner phase with a count: {f:?}");
        }
    }
}
