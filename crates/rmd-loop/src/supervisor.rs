//! The supervisor: a thread beside the loop thread that makes the motors safe itself when the
//! loop thread does not.
//!
//! It runs while the loop ticks (from the first tick to the start of the loop's own safe stop),
//! with its own way onto every bus (a [`SafetyPort`]: its own SocketCAN socket, or a shared handle
//! to a simulated bus), and takes over:
//!
//! - when a tick does not complete within the stall bound (`loop.stall_bound_ms`, default ten
//!   periods and at least 50 ms): the controller or the bus I/O hangs; the run ends with
//!   [`Fault::TickStalled`];
//! - when an emergency stop is requested: at once, whatever the loop thread is doing;
//! - when a stop is requested and the loop thread has not begun its safe stop one and a half
//!   periods later (so every stop acts within two periods, even while the controller hangs).
//!
//! Taking over, it sends zero torque and motor-off on every bus with the same safe stop as the
//! loop; when the loop thread comes back it sends nothing more, and its report carries the
//! supervisor's safe stop.
//!
//! It runs off the loop's CPU when the loop is pinned (on the CPUs the loop was allowed before),
//! one `SCHED_FIFO` priority above the loop when the loop is real-time
//! ([`crate::os::supervisor_thread`]): a controller stuck in a busy loop at real-time priority
//! cannot keep it from running, and its looks never interrupt the loop's CPU.
//!
//! The supervisor never touches the loop thread's data: it reads a few atomics (the `watch`
//! module) and sleeps in real time between looks.

use core::time::Duration;
use std::sync::Arc;
use std::thread::JoinHandle;

use rmd_bus::{CanBus, Clock, Timestamp};
use rmd_protocol::MotorId;

use crate::bus_link::BusLink;
use crate::os::{SupervisorPlacement, SupervisorRequest, place_supervisor};
use crate::report::{Fault, SafeStopBy, StopReason};
use crate::robot::Robot;
use crate::safe_stop::make_safe;
use crate::shared::Shared;
use crate::stop::StopRequest;
use crate::watch::{Phase, Takeover};

/// A second way onto one bus, for the supervisor: its own SocketCAN socket on the interface, or
/// a shared handle to a simulated bus.
pub type SafetyPort = Box<dyn CanBus + Send>;

/// The supervisor of one run, before it starts.
pub(crate) struct Supervisor<C> {
    pub(crate) clock: C,
    pub(crate) shared: Arc<Shared>,
    pub(crate) links: Vec<BusLink<SafetyPort>>,
    pub(crate) ids: Vec<MotorId>,
    pub(crate) robot: Robot,
}

impl<C: Clock + 'static> Supervisor<C> {
    /// Starts the supervisor's thread, which first places itself as `placement` asks (off the
    /// loop's CPU, above its priority), and returns where it runs.
    pub(crate) fn spawn(
        self,
        placement: &SupervisorRequest,
    ) -> std::io::Result<(JoinHandle<()>, SupervisorPlacement)> {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        let placement = placement.clone();
        let handle = std::thread::Builder::new()
            .name("rmd-rt-supervisor".to_string())
            .spawn(move || {
                let _ = tx.send(place_supervisor(&placement));
                self.run()
            })?;
        // Start-up, not the real-time path: the loop thread waits for the placement once.
        let placed = rx.recv().unwrap_or_default();
        Ok((handle, placed))
    }

    fn run(mut self) {
        let settings = *self.robot.settings();
        let period = settings.period.get();
        let look_every = (period / 4).clamp(Duration::from_micros(50), Duration::from_millis(1));
        let grace = period + period / 2;
        let watch = &self.shared.watch;
        let mut stop_seen: Option<Timestamp> = None;
        loop {
            std::thread::sleep(look_every);
            match watch.phase() {
                Phase::Starting => continue,
                Phase::Running => {}
                Phase::Finishing | Phase::TakenOver | Phase::Finished => return,
            }
            // The clock first, then the loop's last sign of life: progress after the clock was
            // read is never mistaken for a stall.
            let now = self.clock.now();
            let (last, tick) = watch.last_progress();
            let reason = match self.shared.stop.pending() {
                Some(StopRequest::EmergencyStop) => Some(StopReason::EmergencyStop),
                Some(request) => {
                    let seen = *stop_seen.get_or_insert(now);
                    (now - seen >= grace).then(|| request.into())
                }
                None if now - last > settings.stall_bound => {
                    Some(StopReason::Fault(Fault::TickStalled {
                        tick,
                        bound: settings.stall_bound,
                    }))
                }
                None => None,
            };
            if let Some(reason) = reason {
                self.take_over(reason);
                return;
            }
        }
    }

    /// Makes every motor safe through the supervisor's own ports, if the loop thread has not
    /// begun to do it.
    fn take_over(&mut self, reason: StopReason) {
        let watch = &self.shared.watch;
        if !watch.swap_phase(Phase::Running, Phase::TakenOver) {
            return; // the loop thread got there first: it makes the motors safe itself
        }
        watch.wait_for_send();
        let mut report = make_safe(
            &self.clock,
            &mut self.links,
            &self.ids,
            &self.robot,
            self.robot.safe_stop(),
            || watch.set_motors_off_sent(),
        );
        report.by = SafeStopBy::Supervisor;
        watch.put_takeover(Takeover { reason, report });
    }
}
