//! Progress of the long commands, drawn by `indicatif` on stderr: a bar over a count (ids
//! scanned, frames replayed, ticks run), a bar over time (a drive of a given duration), or a
//! spinner with a live message (a move, a recording, the simulator).
//!
//! Drawn only for a person watching: when stdout and stderr are both terminals and the output
//! is not JSON ([`shown`]). Otherwise every method is a no-op, apart from
//! [`Progress::println`], which then writes its line to stderr as a plain message. A progress
//! display is cleared when it is dropped, so that it never stays behind an error message.

use std::borrow::Cow;
use std::io::IsTerminal;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};

use crate::output::errln;

/// A bar over a count.
const COUNTER: &str = "{prefix}[{bar:20}] {pos}/{len} {what} {wide_msg}";
/// A bar over time.
const TIMER: &str = "{prefix}[{bar:20}] {seconds} {wide_msg}";
/// A spinner.
const SPINNER: &str = "{prefix}{spinner} {elapsed} {wide_msg}";

/// Redraws per second: enough to watch, little work on a machine that measures latency.
const REFRESH_HZ: u8 = 4;

/// Whether to draw progress: a person is watching (stdout and stderr are terminals) and the
/// output is for people (`json` is false).
pub(crate) fn shown(json: bool) -> bool {
    !json && std::io::stdout().is_terminal() && std::io::stderr().is_terminal()
}

/// A progress display on stderr (or nothing; see the module docs).
#[derive(Debug)]
pub(crate) struct Progress {
    bar: ProgressBar,
}

impl Progress {
    /// A bar over `total` things, `what` naming them (`ids`, `frames`, `ticks`).
    pub(crate) fn counter(total: u64, what: &'static str, show: bool) -> Self {
        let style = style(COUNTER).with_key(
            "what",
            move |_: &ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = w.write_str(what);
            },
        );
        Self::new(Some(total), style, show)
    }

    /// A bar over a duration, advanced with [`set_elapsed`](Self::set_elapsed).
    pub(crate) fn timer(total: Duration, show: bool) -> Self {
        let style = style(TIMER).with_key(
            "seconds",
            |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                let seconds = |ms: u64| ms as f64 / 1000.0;
                let _ = write!(
                    w,
                    "{:.1}/{:.1} s",
                    seconds(state.pos()),
                    seconds(state.len().unwrap_or(0))
                );
            },
        );
        Self::new(Some(millis(total)), style, show)
    }

    /// A spinner with a message and the time since it started, for work of unknown length.
    pub(crate) fn spinner(show: bool) -> Self {
        let progress = Self::new(None, style(SPINNER), show);
        progress
            .bar
            .enable_steady_tick(Duration::from_millis(1000 / u64::from(REFRESH_HZ)));
        progress
    }

    fn new(total: Option<u64>, style: ProgressStyle, show: bool) -> Self {
        let target = if show {
            ProgressDrawTarget::stderr_with_hz(REFRESH_HZ)
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(total, target).with_style(style);
        Progress { bar }
    }

    /// Whether the display is drawn.
    pub(crate) fn is_shown(&self) -> bool {
        !self.bar.is_hidden()
    }

    /// Text before the bar (e.g. `trial 3 `).
    pub(crate) fn set_prefix(&self, prefix: impl Into<Cow<'static, str>>) {
        self.bar.set_prefix(prefix);
    }

    /// The live message after the bar (e.g. the last reading).
    pub(crate) fn set_message(&self, message: impl Into<Cow<'static, str>>) {
        self.bar.set_message(message);
    }

    /// How many things are done.
    pub(crate) fn set_position(&self, done: u64) {
        self.bar.set_position(done);
    }

    /// How much of a [`timer`](Self::timer)'s duration has passed.
    pub(crate) fn set_elapsed(&self, elapsed: Duration) {
        self.bar.set_position(millis(elapsed));
    }

    /// Starts again from 0 with a new total (a [`timer`](Self::timer) for the next run).
    pub(crate) fn restart_timer(&self, total: Duration) {
        self.bar.reset();
        self.bar.set_length(millis(total));
    }

    /// Writes `line` to stderr: above the display when it is drawn, as a plain line otherwise.
    pub(crate) fn println(&self, line: impl AsRef<str>) {
        if self.bar.is_hidden() {
            errln!("{}", line.as_ref());
        } else {
            self.bar.println(line);
        }
    }

    /// Removes the display from the terminal (as dropping it does).
    pub(crate) fn clear(&self) {
        self.bar.finish_and_clear();
    }

    /// Runs `write` with the display cleared (for output on the same terminal).
    pub(crate) fn suspend<R>(&self, write: impl FnOnce() -> R) -> R {
        self.bar.suspend(write)
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}

/// The style of `template`, or indicatif's default if it does not parse (it always does:
/// see the tests).
fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ")
}

/// Whole milliseconds, saturating.
fn millis(duration: Duration) -> u64 {
    u64::try_from(duration.as_millis()).unwrap_or(u64::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_templates_parse() {
        for template in [COUNTER, TIMER, SPINNER] {
            assert!(ProgressStyle::with_template(template).is_ok(), "{template}");
        }
    }

    #[test]
    fn a_hidden_display_tracks_nothing_visible_and_never_fails() {
        let timer = Progress::timer(Duration::from_secs(2), false);
        timer.set_elapsed(Duration::from_millis(500));
        timer.set_message("speed 10 dps");
        timer.restart_timer(Duration::from_secs(1));
        assert_eq!(timer.suspend(|| 7), 7);
        let counter = Progress::counter(32, "ids", false);
        counter.set_position(40);
        counter.set_prefix("scan ");
        assert!(counter.bar.is_hidden());
        assert_eq!(millis(Duration::MAX), u64::MAX);
    }
}
