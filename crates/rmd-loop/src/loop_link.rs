//! What the loop thread shares with the threads that control and watch it: the stop request,
//! whether it runs, and the statistics snapshot exchange. Everything here is lock-free.

use std::sync::atomic::{AtomicBool, Ordering};

use crossbeam_queue::ArrayQueue;

use crate::stats::LoopStats;
use crate::stop::StopSignal;
use crate::vitals::LoopVitals;

/// The loop thread's link to its handles, stoppers and supervisor: the stop request, the
/// running flag, the statistics snapshot exchange and what the supervisor watches.
#[derive(Debug)]
pub(crate) struct LoopLink {
    /// The pending stop request.
    pub(crate) stop: StopSignal,
    running: AtomicBool,
    /// Empty statistics buffers sent by readers, filled by the loop thread.
    pub(crate) snapshot_requests: ArrayQueue<Box<LoopStats>>,
    /// Filled statistics buffers.
    pub(crate) snapshot_replies: ArrayQueue<Box<LoopStats>>,
    /// What the supervisor watches.
    pub(crate) vitals: LoopVitals,
}

impl LoopLink {
    pub(crate) fn new() -> Self {
        Self {
            stop: StopSignal::default(),
            running: AtomicBool::new(false),
            snapshot_requests: ArrayQueue::new(4),
            snapshot_replies: ArrayQueue::new(4),
            vitals: LoopVitals::new(),
        }
    }

    /// Whether the loop is between its start and its end.
    pub(crate) fn is_running(&self) -> bool {
        self.running.load(Ordering::Acquire)
    }

    pub(crate) fn set_running(&self, running: bool) {
        self.running.store(running, Ordering::Release);
    }

    /// Fills one waiting snapshot buffer with `stats` (on the loop thread, between ticks).
    #[inline]
    pub(crate) fn serve_snapshot(&self, stats: &LoopStats) {
        // Most ticks nobody asked: two loads rather than a pop's compare-and-swap attempt.
        if !self.snapshot_requests.is_empty() {
            self.fill_snapshot(stats);
        }
    }

    /// [`serve_snapshot`](Self::serve_snapshot) once a request is waiting (out of line: most
    /// ticks have none).
    #[inline(never)]
    fn fill_snapshot(&self, stats: &LoopStats) {
        if let Some(mut buffer) = self.snapshot_requests.pop() {
            buffer.copy_from(stats);
            // The reply queue has room for every request buffer; if a reader abandoned its
            // buffers, drop this one (the reader times out and retries).
            let _ = self.snapshot_replies.push(buffer);
        }
    }
}
