//! The live display of a run: a progress bar with a status line on a terminal (indicatif), one
//! line per second in a log, or nothing.

use std::io::Write;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rmd_loop::stats::StatsSummary;

/// How a run shows its progress.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Display {
    /// A bar and a status line on standard error, updated in place (a terminal).
    Terminal,
    /// One status line per second of wall time on standard error (logs, CI).
    Lines,
    /// Nothing until the final report.
    Quiet,
}

/// The live display of a run's progress (see [`Display`]).
#[derive(Debug)]
pub(crate) struct RunProgress {
    display: Display,
    bar: Option<ProgressBar>,
    total_ticks: Option<u64>,
    rate_hz: f64,
    last_line: Option<Instant>,
}

impl RunProgress {
    pub(crate) fn new(display: Display, total_ticks: Option<u64>, rate_hz: f64) -> Self {
        let bar = (display == Display::Terminal).then(|| match total_ticks {
            Some(total) => {
                ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr_with_hz(10))
                    .with_style(
                        ProgressStyle::with_template("[{bar:20}] {percent:>3}%  {msg}")
                            .unwrap_or_else(|_| ProgressStyle::default_bar())
                            .progress_chars("#>."),
                    )
            }
            None => ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr_with_hz(10))
                .with_style(
                    ProgressStyle::with_template("{spinner} {msg}")
                        .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                ),
        });
        Self {
            display,
            bar,
            total_ticks,
            rate_hz,
            last_line: None,
        }
    }

    /// Whether a new line or redraw is due.
    pub(crate) fn due(&self) -> bool {
        match self.display {
            Display::Quiet => false,
            Display::Terminal => true,
            Display::Lines => self
                .last_line
                .is_none_or(|t| t.elapsed() >= Duration::from_secs(1)),
        }
    }

    /// Shows `stats` with the program's part of the status line.
    pub(crate) fn show(&mut self, stats: &StatsSummary, program: &str) {
        let t = stats.ticks as f64 / self.rate_hz;
        let time = match self.total_ticks {
            Some(total) => format!("{t:5.1} / {:.1} s", total as f64 / self.rate_hz),
            None => format!("{t:7.1} s"),
        };
        let program = if program.is_empty() {
            String::new()
        } else {
            format!(" | {program}")
        };
        let line = format!(
            "{time}{program} | misses {}  missing {}  wake p99 {:.0} us",
            stats.deadline_misses, stats.missing_replies, stats.wake_latency_us.p99
        );
        match (&self.bar, self.display) {
            (Some(bar), _) => {
                bar.set_position(stats.ticks);
                bar.set_message(line);
            }
            (None, Display::Lines) => {
                let progress = match self.total_ticks {
                    Some(total) if total > 0 => {
                        format!("{:3.0}%  ", 100.0 * stats.ticks as f64 / total as f64)
                    }
                    _ => String::new(),
                };
                let _ = writeln!(std::io::stderr(), "{progress}{line}");
            }
            _ => {}
        }
        self.last_line = Some(Instant::now());
    }

    /// Ends the display (the bar is cleared, the last line stays in logs).
    pub(crate) fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
