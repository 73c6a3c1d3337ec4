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
pub(crate) const LINE_EVERY: Duration = Duration::from_secs(5);

/// Progress over simulated time.
pub(crate) struct Progress {
    bar: Option<ProgressBar>,
    start: Instant,
    shown: bool,
    next_line: Duration,
    t_end: f64,
}

impl Progress {
    /// Progress of a run to `t_end` \[s\]: a bar on a terminal, lines
    /// otherwise.
    pub(crate) fn new(t_end: f64) -> Option<Self> {
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
    pub(crate) fn update(&mut self, t: f64) {
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

    /// Prints a line above the bar (on stderr).
    pub(crate) fn println(&self, line: &str) {
        match &self.bar {
            Some(bar) if self.shown => bar.println(line),
            _ => {
                let _ = writeln!(std::io::stderr().lock(), "{line}");
            }
        }
    }

    /// Removes the bar.
    pub(crate) fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

/// A line on stderr every [`LINE_EVERY`] while a long phase that has no
/// progress of its own runs (the setup of a family of a million links,
/// drawing thousands of figures, the runs of `ezy precision`, the states of
/// `ezy check`), so a log shows the program is alive and what it does:
/// `progress: drawing figure 12 of 9000 (f12.png), 10 s elapsed`. Nothing
/// is printed for a phase shorter than [`LINE_EVERY`]. A background
/// thread, stopped when the heartbeat is dropped.
pub(crate) struct Heartbeat {
    shared: std::sync::Arc<Beat>,
    thread: Option<std::thread::JoinHandle<()>>,
}

struct Beat {
    /// What is being done (`None`: another progress report has the floor),
    /// and whether the heartbeat is stopped.
    state: std::sync::Mutex<(Option<String>, bool)>,
    wake: std::sync::Condvar,
}

impl Heartbeat {
    /// Starts reporting `what` (elapsed time counts from now).
    pub(crate) fn start(what: impl Into<String>) -> Self {
        let shared = std::sync::Arc::new(Beat {
            state: std::sync::Mutex::new((Some(what.into()), false)),
            wake: std::sync::Condvar::new(),
        });
        let beat = std::sync::Arc::clone(&shared);
        let start = Instant::now();
        let thread = std::thread::spawn(move || {
            let mut state = beat.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            loop {
                let (next, timeout) = beat
                    .wake
                    .wait_timeout_while(state, LINE_EVERY, |s| !s.1)
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                state = next;
                if state.1 {
                    return;
                }
                if timeout.timed_out()
                    && let Some(what) = &state.0
                {
                    let _ = writeln!(
                        std::io::stderr().lock(),
                        "progress: {what}, {:.0} s elapsed",
                        start.elapsed().as_secs_f64()
                    );
                }
            }
        });
        Self { shared, thread: Some(thread) }
    }

    /// Reports `what` from now on on `beat`, started now if it is `None`
    /// (a phase that was too short for a heartbeat of its own).
    pub(crate) fn report(beat: &mut Option<Self>, what: impl Into<String>) {
        match beat {
            Some(b) => b.set(what),
            None => *beat = Some(Self::start(what)),
        }
    }

    /// Reports `what` from now on.
    pub(crate) fn set(&self, what: impl Into<String>) {
        self.shared.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner).0 = Some(what.into());
    }

    /// Stays silent while another report (a run's own progress) has the floor.
    pub(crate) fn quiet(&self) {
        self.shared.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner).0 = None;
    }
}

impl Drop for Heartbeat {
    fn drop(&mut self) {
        self.shared.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner).1 = true;
        self.shared.wake.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
