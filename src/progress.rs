//! A progress bar on stderr (indicatif) that appears only once a run has
//! taken about a second, and never when stderr is not a terminal.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Delay before the bar is shown.
const SHOW_AFTER: Duration = Duration::from_secs(1);

/// Progress over simulated time.
pub struct Progress {
    bar: ProgressBar,
    start: Instant,
    shown: bool,
    t_end: f64,
}

impl Progress {
    /// A bar for a run to `t_end` \[s\]; `None` if stderr is not a terminal.
    pub fn new(t_end: f64) -> Option<Self> {
        if !std::io::stderr().is_terminal() {
            return None;
        }
        let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {percent:>3}% t = {msg} s, {elapsed} elapsed, ~{eta} left")
                .expect("static template"),
        );
        Some(Self { bar, start: Instant::now(), shown: false, t_end })
    }

    /// Reports the current simulated time \[s\].
    pub fn update(&mut self, t: f64) {
        if !self.shown && self.start.elapsed() >= SHOW_AFTER {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
            self.shown = true;
        }
        self.bar.set_position(((t / self.t_end) * 1000.0) as u64);
        self.bar.set_message(format!("{t:.2}"));
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
