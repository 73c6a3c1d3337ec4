//! Progress of a long run on stderr: on a terminal, a bar (indicatif) that
//! appears once a run has taken about a second; otherwise (a script's log,
//! a pipe) one line every few seconds once a run has taken that long, so
//! a log shows a long run is alive.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Delay before the bar is shown on a terminal.
const SHOW_AFTER: Duration = Duration::from_secs(1);
/// Interval of the progress lines when stderr is not a terminal (the
/// first comes after one interval).
pub const LINE_EVERY: Duration = Duration::from_secs(5);

/// Progress over simulated time.
pub struct Progress {
    bar: Option<ProgressBar>,
    start: Instant,
    shown: bool,
    next_line: Duration,
    t_end: f64,
}

impl Progress {
    /// Progress of a run to `t_end` \[s\]: a bar on a terminal, lines
    /// otherwise.
    pub fn new(t_end: f64) -> Option<Self> {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::hidden());
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {percent:>3}% t = {msg} s, {elapsed} elapsed, ~{eta} left")
                    .expect("static template"),
            );
            bar
        });
        Some(Self { bar, start: Instant::now(), shown: false, next_line: LINE_EVERY, t_end })
    }

    /// Reports the current simulated time \[s\].
    pub fn update(&mut self, t: f64) {
        let elapsed = self.start.elapsed();
        match &self.bar {
            Some(bar) => {
                if !self.shown && elapsed >= SHOW_AFTER {
                    bar.set_draw_target(ProgressDrawTarget::stderr());
                    self.shown = true;
                }
                bar.set_position(((t / self.t_end) * 1000.0) as u64);
                bar.set_message(format!("{t:.2}"));
            }
            None if elapsed >= self.next_line => {
                self.next_line = elapsed + LINE_EVERY;
                let _ = writeln!(
                    std::io::stderr().lock(),
                    "progress: t = {t:.6} s of {} s ({:.1} %), {:.0} s elapsed",
                    self.t_end,
                    100.0 * t / self.t_end,
                    elapsed.as_secs_f64()
                );
            }
            None => {}
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
