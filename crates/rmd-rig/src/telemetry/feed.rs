//! Feeding the sinks from a thread of their own, for programs whose own thread runs the loop
//! (`rmd_drill::run`) or has better things to do.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use super::{TelemetryError, TelemetryReport, TelemetrySinks};

/// How long the feed thread sleeps when the loop's mailbox is empty.
const IDLE: Duration = Duration::from_millis(2);

/// The feed thread of [`spawn_feed`]: stop it with [`FeedThread::finish`].
#[derive(Debug)]
pub struct FeedThread {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<TelemetrySinks>,
}

/// Starts a thread (`rmd-tlm-feed`, ordinary priority) that takes the loop's samples into
/// `sinks` as they come, until the loop has finished (its mailbox's sender is gone) or
/// [`FeedThread::finish`] is called.
///
/// # Errors
/// [`TelemetryError::Pipeline`] if the OS refuses the thread.
pub fn spawn_feed(sinks: TelemetrySinks) -> Result<FeedThread, TelemetryError> {
    let stop = Arc::new(AtomicBool::new(false));
    let stopping = Arc::clone(&stop);
    let thread = std::thread::Builder::new()
        .name("rmd-tlm-feed".to_owned())
        .spawn(move || {
            let mut sinks = sinks;
            // A panic here must not take the sinks (and their files' summaries) with it.
            let _ = catch_unwind(AssertUnwindSafe(|| {
                while !stopping.load(Ordering::Acquire) {
                    if sinks.pump(|_| {}) == 0 {
                        if !sinks.loop_alive() {
                            break;
                        }
                        std::thread::sleep(IDLE);
                    }
                }
            }));
            sinks
        })
        .map_err(|source| {
            TelemetryError::Pipeline(rmd_telemetry::PipelineError::Spawn {
                name: "rmd-tlm-feed".to_owned(),
                source,
            })
        })?;
    Ok(FeedThread { stop, thread })
}

impl FeedThread {
    /// Stops the thread once it has taken what is queued, closes the sinks and reports (see
    /// [`TelemetrySinks::finish`]). Call it after the loop has finished.
    pub fn finish(self, lost_in_loop: u64) -> TelemetryReport {
        self.stop.store(true, Ordering::Release);
        match self.thread.join() {
            Ok(sinks) => sinks.finish(lost_in_loop),
            // Unreachable: the thread catches its panics and returns the sinks.
            Err(_) => TelemetryReport {
                samples: 0,
                lost_in_loop,
                stats: rmd_telemetry::PipelineStats::default(),
            },
        }
    }
}
