//! The supervisor: a thread beside the loop thread that makes the motors safe itself when the
//! loop thread does not.
//!
//! It runs while the loop ticks (from the first tick to the start of the loop's own safe stop),
//! with its own way onto every bus (a [`SafetyPort`]: its own SocketCAN socket, or a shared handle
//! to a simulated bus), and takes over:
//!
//! - when a tick does not complete within the stall bound (`loop.stall_bound_ms`, default ten
//!   periods and at least 50 ms): the run ends with [`Fault::TickStalled`], whose
//!   [`StallCause`] says why, from the loop thread's scheduler statistics over the stall
//!   (the `stall` module): the OS did not run the loop thread, or it spun, or it was blocked, and
//!   where (the controller, the bus I/O);
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
//! ([`crate::os::place_supervisor`]): a controller stuck in a busy loop at real-time priority
//! cannot keep it from running, and its looks never interrupt the loop's CPU.
//!
//! The supervisor never touches the loop thread's data: it reads a few atomics (the `vitals`
//! module) and sleeps in real time between looks.

use core::time::Duration;
use std::sync::Arc;
use std::thread::JoinHandle;

use rmd_bus::{CanBus, Clock, Timestamp};
use rmd_protocol::MotorId;

use crate::bus_link::BusLink;
use crate::loop_link::LoopLink;
use crate::os::thread_stats::{SchedSample, ThreadState, ThreadStats};
use crate::os::{SupervisorPlacement, SupervisorRequest, place_supervisor};
use crate::report::{Fault, SafeStopBy, StopReason};
use crate::robot::Robot;
use crate::safe_stop::make_safe;
use crate::stall::{StallCause, StallEvidence};
use crate::stop::StopRequest;
use crate::vitals::{LoopPhase, Takeover};

/// A second way onto one bus, for the supervisor: its own SocketCAN socket on the interface, or
/// a shared handle to a simulated bus.
pub type SafetyPort = Box<dyn CanBus + Send>;

/// The supervisor of one run, before it starts.
pub(crate) struct Supervisor<C> {
    pub(crate) clock: C,
    pub(crate) shared: Arc<LoopLink>,
    pub(crate) links: Vec<BusLink<SafetyPort>>,
    pub(crate) ids: Vec<MotorId>,
    pub(crate) robot: Robot,
    /// The loop thread's scheduler statistics, to tell why it stalled.
    pub(crate) stats: Option<ThreadStats>,
}

/// What the supervisor does.
enum Action {
    /// Stop for `reason` (an emergency stop, a stop the loop thread did not act on).
    Stop(StopReason),
    /// The loop thread stalled in `tick`.
    Stall {
        tick: u64,
        stalled: Duration,
        since: Option<Baseline>,
        now: Timestamp,
    },
}

/// The supervisor's first look after the loop thread's last sign of life: the start of the
/// window over which a stall is judged.
#[derive(Copy, Clone, Debug)]
struct Baseline {
    /// The sign of life it follows.
    progress: Timestamp,
    /// When.
    at: Timestamp,
    /// The loop thread's scheduler statistics then.
    sample: Option<SchedSample>,
    /// The supervisor's own then.
    own: Option<SchedSample>,
    /// How long the supervisor overslept since (waiting for a CPU, or stopped).
    supervisor_late: Duration,
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
        let mut stop_seen: Option<Timestamp> = None;
        let mut since: Option<Baseline> = None;
        let mut looked = self.clock.now();
        // Its own statistics tell its oversleeps under load (waiting for a CPU) from a stopped
        // process (not running, not waiting).
        let own = ThreadStats::of_current_thread();
        loop {
            std::thread::sleep(look_every);
            let vitals = &self.shared.vitals;
            match vitals.phase() {
                LoopPhase::Starting => continue,
                LoopPhase::Running => {}
                LoopPhase::Finishing | LoopPhase::TakenOver | LoopPhase::Finished => return,
            }
            // The clock first, then the loop's last sign of life: progress after the clock was
            // read is never mistaken for a stall.
            let now = self.clock.now();
            let (last, tick) = vitals.last_progress();
            // How much longer than asked the supervisor itself slept: time it was not run.
            let late = (now - looked).saturating_sub(look_every);
            looked = now;
            match &mut since {
                Some(b) if b.progress == last => b.supervisor_late += late,
                _ => {
                    since = Some(Baseline {
                        progress: last,
                        at: now,
                        sample: self.stats.as_ref().and_then(ThreadStats::sample),
                        own: own.as_ref().and_then(ThreadStats::sample),
                        // The part of this oversleep after the loop's last sign of life.
                        supervisor_late: late.min(now - last),
                    })
                }
            }
            let action = match self.shared.stop.pending() {
                Some(StopRequest::EmergencyStop) => Some(Action::Stop(StopReason::EmergencyStop)),
                Some(request) => {
                    let seen = *stop_seen.get_or_insert(now);
                    (now - seen >= grace).then(|| Action::Stop(request.into()))
                }
                None if now - last > settings.stall_bound => Some(Action::Stall {
                    tick,
                    stalled: now - last,
                    since: since.take().map(|mut b| {
                        // Oversleeps spent waiting for a CPU are load, not a stopped process.
                        let waited = b
                            .own
                            .zip(own.as_ref().and_then(ThreadStats::sample))
                            .map(|(then, now)| now.since(&then).waited);
                        b.supervisor_late =
                            b.supervisor_late.saturating_sub(waited.unwrap_or_default());
                        b
                    }),
                    now,
                }),
                None => None,
            };
            if let Some(action) = action {
                self.take_over(action);
                return;
            }
        }
    }

    /// Why the loop thread stalled, from its scheduler statistics since `since`.
    fn stall_cause(
        &self,
        stalled: Duration,
        since: Option<Baseline>,
        now: Timestamp,
    ) -> StallCause {
        let vitals = &self.shared.vitals;
        let stage = vitals.stage();
        let now_sample = self.stats.as_ref().and_then(ThreadStats::sample);
        let state = self.stats.as_ref().and_then(ThreadStats::state);
        let (window, over, supervisor_late) = match since {
            Some(b) => (
                now - b.at,
                b.sample.zip(now_sample).map(|(then, now)| now.since(&then)),
                b.supervisor_late,
            ),
            None => (Duration::ZERO, None, Duration::ZERO),
        };
        StallEvidence {
            stalled,
            window,
            ran: over.map(|o| o.ran),
            waited: over.map(|o| o.waited),
            supervisor_late,
            stopped: state == Some(ThreadState::Stopped),
            runnable: state == Some(ThreadState::Runnable),
            in_kernel: state == Some(ThreadState::Blocked),
            stage,
            period: self.robot.settings().period.get(),
        }
        .cause()
    }

    /// Makes every motor safe through the supervisor's own ports, if the loop thread has not
    /// begun to do it.
    fn take_over(&mut self, action: Action) {
        let vitals = &self.shared.vitals;
        if !vitals.swap_phase(LoopPhase::Running, LoopPhase::TakenOver) {
            return; // the loop thread got there first: it makes the motors safe itself
        }
        // Claimed first, judged after: the loop thread, coming back, defers to this reason.
        let reason = match action {
            Action::Stop(reason) => reason,
            Action::Stall {
                tick,
                stalled,
                since,
                now,
            } => StopReason::Fault(Fault::TickStalled {
                tick,
                bound: self.robot.settings().stall_bound,
                stalled,
                cause: self.stall_cause(stalled, since, now),
            }),
        };
        let vitals = &self.shared.vitals;
        vitals.wait_for_send();
        let mut report = make_safe(
            &self.clock,
            &mut self.links,
            &self.ids,
            &self.robot,
            self.robot.safe_stop(),
            || vitals.set_motors_off_sent(),
        );
        report.by = SafeStopBy::Supervisor;
        vitals.put_takeover(Takeover { reason, report });
    }
}
