//! Running the loop on its own thread, and controlling it from others.

use core::time::Duration;
use std::sync::Arc;
use std::thread::JoinHandle;

use rmd_bus::{CanBus, Clock};

use crate::controller::Controller;
use crate::engine::{RtLoop, RunLimit};
use crate::finish::{LoopOutcome, panic_message};
use crate::loop_link::LoopLink;
use crate::stats::{LoopStats, StatsSummary};
use crate::stop::StopRequest;
use crate::stopper::Stopper;

/// Stack size of the loop thread; the start-up pre-faults part of it.
pub(crate) const LOOP_STACK_BYTES: usize = 8 * 1024 * 1024;

/// The loop thread ended without a report (a panic escaped the loop's own recovery, which
/// would be a bug in rmd-rt).
#[derive(Debug, thiserror::Error)]
#[error("the real-time loop thread died without a report: {0}")]
pub struct LoopThreadDied(pub String);

/// Why the loop thread could not be started.
#[derive(Debug, thiserror::Error)]
#[error("cannot start the real-time loop thread: {0}")]
pub struct SpawnError(#[from] std::io::Error);

impl<B, C, K> RtLoop<B, C, K>
where
    B: CanBus + Send + 'static,
    C: Clock + Clone + 'static,
    K: Controller + 'static,
{
    /// Starts the loop on a dedicated thread (named `rmd-rt-loop`, 8 MiB stack, pinned and
    /// prioritised as the robot description says) and returns its handle.
    pub fn spawn(self, limit: RunLimit) -> Result<LoopHandle<K>, SpawnError> {
        let shared = self.shared();
        let template = self.stats().clone();
        let thread = std::thread::Builder::new()
            .name("rmd-rt-loop".to_string())
            .stack_size(LOOP_STACK_BYTES)
            .spawn(move || self.run(limit))?;
        Ok(LoopHandle {
            shared,
            thread: Some(thread),
            template,
        })
    }
}

/// Controls a loop running on its own thread. Dropping it stops the loop (motors made safe).
#[derive(Debug)]
pub struct LoopHandle<K: Send + 'static> {
    shared: Arc<LoopLink>,
    thread: Option<JoinHandle<LoopOutcome<K>>>,
    template: LoopStats,
}

impl<K: Send + 'static> LoopHandle<K> {
    /// Whether the loop is still running (it may have stopped on its own: fault, limit).
    pub fn is_running(&self) -> bool {
        self.thread.as_ref().is_some_and(|t| !t.is_finished())
    }

    /// Emergency stop: zero torque and motor-off at the loop's next tick.
    /// Returns at once; `join` to wait for the report.
    pub fn emergency_stop(&self) {
        self.shared.stop.request(StopRequest::EmergencyStop);
    }

    /// A cheap, cloneable stopper usable from any thread (e.g. a signal handler thread).
    pub fn stopper(&self) -> Stopper {
        Stopper::new(Arc::clone(&self.shared))
    }

    /// Asks the loop to stop and waits for its report.
    pub fn stop(mut self) -> Result<LoopOutcome<K>, LoopThreadDied> {
        self.shared.stop.request(StopRequest::Stop);
        self.take_outcome()
    }

    /// Waits for the loop to end on its own (run limit, controller, fault) and returns its report.
    pub fn join(mut self) -> Result<LoopOutcome<K>, LoopThreadDied> {
        self.take_outcome()
    }

    fn take_outcome(&mut self) -> Result<LoopOutcome<K>, LoopThreadDied> {
        let thread = self
            .thread
            .take()
            .ok_or_else(|| LoopThreadDied("already joined".to_string()))?;
        thread
            .join()
            .map_err(|p| LoopThreadDied(panic_message(p.as_ref())))
    }

    /// The statistics so far, read without disturbing the loop: the loop thread copies them
    /// into a buffer this call allocates, between two ticks. `None` if the loop does not answer
    /// within `timeout` (e.g. it has stopped).
    pub fn snapshot(&self, timeout: Duration) -> Option<StatsSummary> {
        if !self.shared.is_running() && !self.is_running() {
            return None;
        }
        // Reclaim answers to earlier requests that timed out.
        while self.shared.snapshot_replies.pop().is_some() {}
        let buffer = Box::new(self.template.clone());
        if self.shared.snapshot_requests.push(buffer).is_err() {
            return None;
        }
        let give_up = std::time::Instant::now() + timeout;
        loop {
            if let Some(stats) = self.shared.snapshot_replies.pop() {
                return Some(stats.summary());
            }
            if std::time::Instant::now() >= give_up || !self.is_running() {
                // Take back our buffer if the loop never picked it up.
                let _ = self.shared.snapshot_requests.pop();
                return None;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
    }
}

impl<K: Send + 'static> Drop for LoopHandle<K> {
    fn drop(&mut self) {
        if let Some(thread) = self.thread.take() {
            self.shared.stop.request(StopRequest::HandleDropped);
            let _ = thread.join();
        }
    }
}
