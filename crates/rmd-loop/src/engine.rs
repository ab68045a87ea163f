//! The loop engine: one tick after another on one thread.
//!
//! A tick, in order (see docs/loop.md for the timing diagram):
//!
//! 1. wait for the tick's absolute deadline `t0 + k * period` (sleep, then the spin margin);
//! 2. check the stop and emergency-stop flags;
//! 3. send one 0x280 frame on every bus, carrying the commands of the previous tick;
//! 4. collect replies from every bus until they are all in or the reply deadline passes,
//!    matching each to its request (see "Matching replies to requests" in docs/loop.md);
//! 5. count missing replies and check faults;
//! 6. run the controller (panics caught), clamp its commands to the current limits;
//! 7. publish telemetry, serve a statistics snapshot if one was asked for, record statistics.

use core::time::Duration;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

use crossbeam_queue::ArrayQueue;
use rmd_bus::{BusError, BusEvent, BusMessage, CanBus, Clock, MonotonicClock, Timestamp};
use rmd_protocol::{Command, IqControl, MULTI_TORQUE_MOTORS, MultiTorque, decode_reply_to};

use crate::config::{ConfigError, ReplyMode, RobotConfig};
use crate::controller::{Commands, Controller, Feedback, Flow, MotorFeedback, TickContext};
use crate::exchange::{MotorState, ReplyClass};
use crate::joint::JointMap;
use crate::mailbox::{Receiver, Sender, mailbox};
use crate::os::{self, RtRequest, RtStatus};
use crate::report::{Fault, LoopReport, StopReason};
use crate::safety;
use crate::schedule::{Period, Scheduler, TickTiming};
use crate::stats::LoopStats;
use crate::telemetry::{JointSample, TelemetrySample};

/// Stack size of the loop thread; the start-up pre-faults part of it.
pub(crate) const LOOP_STACK_BYTES: usize = 8 * 1024 * 1024;
/// Stack pre-faulted at start.
const PREFAULT_STACK_BYTES: usize = 512 * 1024;

/// Flags and queues shared between the loop thread and its handles.
#[derive(Debug)]
pub(crate) struct Shared {
    /// A stop request: one of the `STOP_*` values.
    pub(crate) stop: AtomicU8,
    /// Whether the loop is between start and end.
    pub(crate) running: AtomicBool,
    /// Empty statistics buffers sent by readers, filled by the loop thread.
    pub(crate) snapshot_requests: ArrayQueue<Box<LoopStats>>,
    /// Filled statistics buffers.
    pub(crate) snapshot_replies: ArrayQueue<Box<LoopStats>>,
}

pub(crate) const STOP_NONE: u8 = 0;
pub(crate) const STOP_REQUESTED: u8 = 1;
pub(crate) const STOP_EMERGENCY: u8 = 2;
pub(crate) const STOP_DROPPED: u8 = 3;

impl Shared {
    fn new() -> Self {
        Self {
            stop: AtomicU8::new(STOP_NONE),
            running: AtomicBool::new(false),
            snapshot_requests: ArrayQueue::new(4),
            snapshot_replies: ArrayQueue::new(4),
        }
    }

    /// Records a stop request; an emergency stop is never downgraded.
    pub(crate) fn request_stop(&self, kind: u8) {
        let _ = self
            .stop
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |current| {
                (current == STOP_NONE || kind == STOP_EMERGENCY).then_some(kind)
            });
    }
}

/// How long a run lasts.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum RunLimit {
    /// Until stopped (handle, controller, fault).
    Forever,
    /// At most this many ticks.
    Ticks(u64),
    /// At most this long (in ticks: `duration / period`).
    Duration(Duration),
}

/// The result of a run: the report, and the controller back.
#[derive(Debug)]
pub struct LoopOutcome<K> {
    /// The final report.
    pub report: LoopReport,
    /// The controller, as the loop left it.
    pub controller: K,
}

/// One bus and the range of motors on it.
#[derive(Debug)]
pub(crate) struct BusLink<B> {
    pub(crate) bus: B,
    pub(crate) first_motor: usize,
    pub(crate) motor_count: usize,
}

impl<B> BusLink<B> {
    pub(crate) fn motors(&self) -> core::ops::Range<usize> {
        self.first_motor..self.first_motor + self.motor_count
    }
}

/// The real-time loop: a robot description, its buses, a clock and a controller.
///
/// Run it on the current thread with [`run`](RtLoop::run), or on a dedicated thread with
/// [`spawn`](RtLoop::spawn). Buses are given in the order of the robot description.
///
/// ```
/// use rmd_bus::VirtualClock;
/// use rmd_loop::config::{BusConfig, MotorConfig, RobotConfig};
/// use rmd_loop::{Commands, Controller, Feedback, Flow, RtLoop, TickContext};
/// # use rmd_bus::{BusError, CanBus, Received, Timestamp};
/// # struct NoMotors;
/// # impl CanBus for NoMotors {
/// #     fn send(&mut self, _: &rmd_protocol::CanFrame) -> Result<(), BusError> { Ok(()) }
/// #     fn recv_until(&mut self, _: Timestamp) -> Result<Option<Received>, BusError> { Ok(None) }
/// # }
/// struct Idle;
/// impl Controller for Idle {
///     fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
///         Flow::Continue
///     }
/// }
/// let robot = RobotConfig::new(1000.0).with_bus(BusConfig::new("sim").with_motor(MotorConfig::new(1)));
/// let rt = RtLoop::new(robot, VirtualClock::new(), vec![NoMotors], Idle).unwrap();
/// let outcome = rt.run(rmd_loop::RunLimit::Ticks(10));
/// // Nobody answered: the loop refuses to start and says why.
/// assert!(outcome.report.stop_reason.to_string().contains("never answered"));
/// ```
#[derive(Debug)]
pub struct RtLoop<B, C, K> {
    config: RobotConfig,
    period: Period,
    reply_deadline: Duration,
    max_age: u64,
    clock: C,
    buses: Vec<BusLink<B>>,
    motors: Vec<MotorState>,
    feedback: Vec<MotorFeedback>,
    command_amps: Vec<f64>,
    maps: Vec<JointMap>,
    next_commands: Vec<[IqControl; MULTI_TORQUE_MOTORS]>,
    controller: K,
    stats: LoopStats,
    shared: Arc<Shared>,
    telemetry_tx: Sender<TelemetrySample>,
    telemetry_rx: Receiver<TelemetrySample>,
    scheduler: Option<Scheduler>,
    rt_status: Option<RtStatus>,
    started: bool,
    start_time: Timestamp,
    controller_started: bool,
}

/// Why [`RtLoop::new`] refused its arguments.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The robot description is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The number of buses does not match the robot description.
    #[error("the robot description has {expected} bus(es) but {given} were given")]
    BusCount {
        /// Buses in the description.
        expected: usize,
        /// Buses given.
        given: usize,
    },
    /// The robot has no motors.
    #[error("the robot description has no motors")]
    NoMotors,
}

impl<B: CanBus, C: Clock, K: Controller> RtLoop<B, C, K> {
    /// Validates `config` and prepares a loop over `buses` (in description order). Allocates
    /// everything the loop needs; running it allocates nothing more.
    pub fn new(
        config: RobotConfig,
        clock: C,
        buses: Vec<B>,
        controller: K,
    ) -> Result<Self, BuildError> {
        config.validate()?;
        if buses.len() != config.buses.len() {
            return Err(BuildError::BusCount {
                expected: config.buses.len(),
                given: buses.len(),
            });
        }
        if config.motor_count() == 0 {
            return Err(BuildError::NoMotors);
        }
        let period = config.period()?;
        let reply_deadline = config.reply_deadline()?;
        let mut motors = Vec::new();
        let mut links = Vec::new();
        for ((b, bus_config), bus) in config.buses.iter().enumerate().zip(buses) {
            links.push(BusLink {
                bus,
                first_motor: motors.len(),
                motor_count: bus_config.motors.len(),
            });
            for m in &bus_config.motors {
                motors.push(MotorState::new(b, m));
            }
        }
        let feedback = motors
            .iter()
            .map(|m| MotorFeedback::empty(m.bus, m.id))
            .collect();
        let maps = motors.iter().map(|m| m.map).collect();
        let stats = LoopStats::new(motors.iter().map(|m| (m.bus, m.id)), links.len());
        let (telemetry_tx, telemetry_rx) = mailbox(config.loop_config.telemetry_capacity);
        let max_age = match config.loop_config.reply_mode {
            ReplyMode::SameTick => 0,
            ReplyMode::Pipelined => 1,
        };
        Ok(Self {
            period,
            reply_deadline,
            max_age,
            clock,
            command_amps: vec![0.0; motors.len()],
            next_commands: vec![[IqControl::default(); MULTI_TORQUE_MOTORS]; links.len()],
            buses: links,
            motors,
            feedback,
            maps,
            controller,
            stats,
            shared: Arc::new(Shared::new()),
            telemetry_tx,
            telemetry_rx,
            scheduler: None,
            rt_status: None,
            started: false,
            start_time: Timestamp::ZERO,
            controller_started: false,
            config,
        })
    }

    /// A receiver of the per-tick telemetry (clone it freely; each sample is received once).
    pub fn telemetry(&self) -> Receiver<TelemetrySample> {
        self.telemetry_rx.clone()
    }

    /// The robot description the loop runs.
    pub fn config(&self) -> &RobotConfig {
        &self.config
    }

    /// The statistics so far (on the loop's own thread; other threads use a handle's snapshot).
    pub fn stats(&self) -> &LoopStats {
        &self.stats
    }

    /// The controller.
    pub fn controller(&self) -> &K {
        &self.controller
    }

    /// The clock.
    pub fn clock(&self) -> &C {
        &self.clock
    }

    /// A handle that can stop this loop from another thread (e.g. a Ctrl-C handler) while it
    /// runs on this one.
    pub fn stopper(&self) -> Stopper {
        Stopper {
            shared: Arc::clone(&self.shared),
        }
    }

    pub(crate) fn shared(&self) -> Arc<Shared> {
        Arc::clone(&self.shared)
    }

    /// Runs the loop on the current thread until `limit`, a stop request, the controller's
    /// [`Flow::Stop`] or a fault; then makes every motor safe and reports.
    pub fn run(mut self, limit: RunLimit) -> LoopOutcome<K> {
        let max_ticks = match limit {
            RunLimit::Forever => u64::MAX,
            RunLimit::Ticks(n) => n,
            RunLimit::Duration(d) => (d.as_nanos() / self.period.get().as_nanos()) as u64,
        };
        let reason = match catch_unwind(AssertUnwindSafe(|| self.run_ticks(max_ticks))) {
            Ok(reason) => reason,
            Err(payload) => StopReason::ControllerPanic(format!(
                "internal loop error: {}",
                panic_message(payload.as_ref())
            )),
        };
        self.finish(reason)
    }

    fn run_ticks(&mut self, max_ticks: u64) -> StopReason {
        if let Err(reason) = self.start() {
            return reason;
        }
        let mut ran = 0;
        while ran < max_ticks {
            if let Some(reason) = self.step() {
                return reason;
            }
            ran += 1;
        }
        StopReason::TickLimit
    }

    /// Prepares the thread (CPU, priority, memory) and runs the start-up probe: zero torque to
    /// every motor until each has answered once. Called by [`run`](RtLoop::run); call it yourself
    /// only to drive the loop tick by tick with [`step`](RtLoop::step).
    pub fn start(&mut self) -> Result<(), StopReason> {
        if self.started {
            return Ok(());
        }
        self.started = true;
        self.shared.running.store(true, Ordering::Release);
        let l = &self.config.loop_config;
        let status = os::apply_to_current_thread(&RtRequest {
            cpu: l.cpu,
            fifo_priority: l.fifo_priority,
            lock_memory: l.lock_memory,
            prefault_stack_bytes: PREFAULT_STACK_BYTES,
        });
        for warning in status.warnings() {
            eprintln!("rmd-rt: warning: {warning}");
        }
        self.rt_status = Some(status);
        self.probe()?;
        let spin = Duration::from_micros(self.config.loop_config.spin_margin_us);
        let t0 = self.clock.now() + self.period.get();
        self.start_time = t0;
        self.scheduler = Some(Scheduler::new(
            self.period,
            spin,
            self.config.loop_config.overrun,
            t0,
        ));
        Ok(())
    }

    /// The start-up probe: one zero-torque exchange at a time, waiting generously for replies,
    /// until every motor has answered (which also measures each motor's round trip).
    fn probe(&mut self) -> Result<(), StopReason> {
        let timeout = (self.period.get() * 4).max(Duration::from_millis(20));
        for _ in 0..self.config.loop_config.startup_probes {
            if let Some(reason) = self.stop_requested() {
                return Err(reason);
            }
            let sent_at = self.clock.now();
            for b in 0..self.buses.len() {
                if self.motors[self.buses[b].motors()]
                    .iter()
                    .all(|m| m.last_reply_at.is_some())
                {
                    continue;
                }
                self.send_exchange(b, 0, sent_at, true)?;
            }
            let deadline = sent_at + timeout;
            for b in 0..self.buses.len() {
                self.collect(b, 0, deadline, true)?;
            }
            if self.motors.iter().all(|m| m.last_reply_at.is_some()) {
                for m in &mut self.motors {
                    m.pending.clear();
                }
                return Ok(());
            }
        }
        let missing: Vec<_> = self
            .motors
            .iter()
            .filter(|m| m.last_reply_at.is_none())
            .collect();
        Err(StopReason::Fault(Fault::StartupTimeout {
            bus: missing[0].bus,
            motor: missing[0].id,
            missing: missing.len(),
        }))
    }

    fn stop_requested(&self) -> Option<StopReason> {
        match self.shared.stop.load(Ordering::Acquire) {
            STOP_NONE => None,
            STOP_EMERGENCY => Some(StopReason::EmergencyStop),
            STOP_DROPPED => Some(StopReason::HandleDropped),
            _ => Some(StopReason::Requested),
        }
    }

    /// Sends the staged commands as one 0x280 frame on bus `b` and records the request for each
    /// of its motors. A full transmit queue is counted and rides through (its motors will miss
    /// this tick); bus-off and a lost interface are faults.
    fn send_exchange(
        &mut self,
        b: usize,
        tick: u64,
        at: Timestamp,
        zero: bool,
    ) -> Result<(), StopReason> {
        let iq = if zero {
            [IqControl::default(); MULTI_TORQUE_MOTORS]
        } else {
            self.next_commands[b]
        };
        let frame = MultiTorque::new(iq).encode();
        match self.buses[b].bus.send(&frame) {
            Ok(()) => {
                for m in self.buses[b].motors() {
                    self.motors[m].pending.push(tick, at);
                }
                Ok(())
            }
            Err(BusError::TxQueueFull) | Err(BusError::Io(_)) => {
                self.stats.buses[b].tx_errors += 1;
                Ok(())
            }
            Err(BusError::BusOff) => {
                self.stats.buses[b].tx_errors += 1;
                Err(StopReason::Fault(Fault::BusOff { bus: b }))
            }
            Err(error) => {
                self.stats.buses[b].tx_errors += 1;
                Err(StopReason::Fault(Fault::Bus { bus: b, error }))
            }
        }
    }

    /// Receives from bus `b` until each of its motors has a fresh reply or `deadline` passes.
    /// Returns the latest receive time of a fresh reply, if any.
    fn collect(
        &mut self,
        b: usize,
        tick: u64,
        deadline: Timestamp,
        probing: bool,
    ) -> Result<Option<(Timestamp, Duration)>, StopReason> {
        let motors = self.buses[b].motors();
        let mut latest: Option<(Timestamp, Duration)> = None;
        loop {
            let done = if probing {
                self.motors[motors.clone()]
                    .iter()
                    .all(|m| m.last_reply_at.is_some())
            } else {
                self.feedback[motors.clone()].iter().all(|f| f.fresh)
            };
            if done {
                return Ok(latest);
            }
            let received = match self.buses[b].bus.recv_until(deadline) {
                Ok(None) => return Ok(latest),
                Ok(Some(received)) => received,
                Err(BusError::BusOff) => return Err(StopReason::Fault(Fault::BusOff { bus: b })),
                Err(BusError::InterfaceDown) => {
                    return Err(StopReason::Fault(Fault::Bus {
                        bus: b,
                        error: BusError::InterfaceDown,
                    }));
                }
                Err(_) => {
                    // A transient receive error: count it and stop collecting on this bus for
                    // this tick rather than spin on it.
                    self.stats.buses[b].rx_errors += 1;
                    return Ok(latest);
                }
            };
            let frame = match received.message {
                BusMessage::Frame(frame) => frame,
                BusMessage::Event(event) => {
                    self.stats.buses[b].count_event(event);
                    if event == BusEvent::BusOff {
                        return Err(StopReason::Fault(Fault::BusOff { bus: b }));
                    }
                    continue;
                }
            };
            let decoded = decode_reply_to(&frame, Command::Torque);
            let id = match decoded {
                Ok((id, _)) => Some(id),
                Err(_) => rmd_protocol::MotorId::from_can_id(frame.id()).ok(),
            };
            let Some(m) = id.and_then(|id| motors.clone().find(|&m| self.motors[m].id == id))
            else {
                self.stats.buses[b].unexpected_frames += 1;
                continue;
            };
            let status = match decoded.map(|(_, reply)| reply.status2()) {
                Ok(Some(status)) => status,
                _ => {
                    self.stats.motors[m].bad_frames += 1;
                    continue;
                }
            };
            let max_age = if probing { u64::MAX } else { self.max_age };
            let class = self.motors[m].on_reply(
                &status,
                received.at,
                tick,
                max_age,
                &mut self.feedback[m],
                &mut self.stats.motors[m],
            );
            if class == ReplyClass::Fresh
                && let Some(rtt) = self.motors[m].round_trip
            {
                latest = match latest {
                    Some((at, _)) if at >= received.at => latest,
                    _ => Some((received.at, rtt)),
                };
            }
        }
    }

    /// Runs one tick. Returns why the loop must stop, if it must.
    pub fn step(&mut self) -> Option<StopReason> {
        if !self.started
            && let Err(reason) = self.start()
        {
            return Some(reason);
        }
        let Some(scheduler) = self.scheduler.as_mut() else {
            return Some(StopReason::Requested);
        };
        let timing = scheduler.wait_next(&self.clock);
        if let Some(reason) = self.stop_requested() {
            return Some(reason);
        }
        // Counted when it starts, so that a snapshot taken during the tick is consistent.
        self.stats.ticks += 1;
        self.stats.skipped_ticks += timing.skipped;
        self.stats.wake_latency.record(timing.wake_latency());
        match self.exchange(&timing) {
            Ok(()) => {}
            Err(reason) => return Some(reason),
        }
        if let Some(reason) = self.run_controller(&timing) {
            return Some(reason);
        }
        self.stage_commands();
        self.publish(&timing);
        self.serve_snapshot();
        let end = self.clock.now();
        self.stats.work.record(end - timing.woke);
        let Some(scheduler) = self.scheduler.as_mut() else {
            return Some(StopReason::Requested);
        };
        let tick_end = scheduler.end_tick(end);
        if tick_end.missed_deadline {
            self.stats.deadline_misses += 1;
        }
        if tick_end.fault {
            return Some(StopReason::Fault(Fault::DeadlineMisses {
                consecutive: tick_end.consecutive_misses,
            }));
        }
        None
    }

    /// Send on every bus, then collect from every bus, then account for missing replies.
    fn exchange(&mut self, timing: &TickTiming) -> Result<(), StopReason> {
        for f in &mut self.feedback {
            f.fresh = false;
            f.ticks_since_reply = f.ticks_since_reply.saturating_add(1);
        }
        let sent_at = self.clock.now();
        for b in 0..self.buses.len() {
            self.send_exchange(b, timing.index, sent_at, false)?;
        }
        let deadline = timing.scheduled + self.reply_deadline;
        let mut last_reply: Option<Timestamp> = None;
        let mut rtt_max = Duration::ZERO;
        for b in 0..self.buses.len() {
            if let Some((at, rtt)) = self.collect(b, timing.index, deadline, false)? {
                last_reply = Some(last_reply.map_or(at, |l| l.max(at)));
                rtt_max = rtt_max.max(rtt);
            }
        }
        let mut all_fresh = true;
        for m in 0..self.motors.len() {
            let fb = &self.feedback[m];
            let motor = &mut self.motors[m];
            if fb.fresh {
                motor.consecutive_missing = 0;
            } else {
                all_fresh = false;
                motor.consecutive_missing = motor.consecutive_missing.saturating_add(1);
                let counters = &mut self.stats.motors[m];
                counters.missing_replies += 1;
                counters.max_consecutive_missing = counters
                    .max_consecutive_missing
                    .max(u64::from(motor.consecutive_missing));
                if motor.consecutive_missing >= self.config.loop_config.missing_reply_fault_after {
                    return Err(StopReason::Fault(Fault::MotorSilent {
                        bus: motor.bus,
                        motor: motor.id,
                        ticks: motor.consecutive_missing,
                    }));
                }
            }
            if let Some(limit) = motor.temperature_limit
                && fb.valid
                && fb.temperature_celsius >= limit
            {
                return Err(StopReason::Fault(Fault::OverTemperature {
                    bus: motor.bus,
                    motor: motor.id,
                    celsius: fb.temperature_celsius,
                }));
            }
        }
        if all_fresh && let Some(last) = last_reply {
            // Same tick: from this tick's send to the last reply. Pipelined: the replies answer
            // the previous tick, so use the tracked round trip of the slowest motor.
            let rtt = if self.max_age == 0 {
                last - sent_at
            } else {
                rtt_max
            };
            self.stats.round_trip.record(rtt);
        }
        Ok(())
    }

    fn run_controller(&mut self, timing: &TickTiming) -> Option<StopReason> {
        let ctx = TickContext {
            index: timing.index,
            scheduled: timing.scheduled,
            woke: timing.woke,
            period: self.period.get(),
            start: self.start_time,
        };
        self.command_amps.fill(0.0);
        let feedback = Feedback::new(&self.feedback);
        let mut commands = Commands::new(&mut self.command_amps, &self.maps);
        let controller = &mut self.controller;
        let first = !self.controller_started;
        self.controller_started = true;
        let cpu = MonotonicClock;
        let began = cpu.now();
        let result = catch_unwind(AssertUnwindSafe(|| {
            if first {
                controller.start(&ctx, &feedback);
            }
            controller.update(&ctx, &feedback, &mut commands)
        }));
        self.stats.controller.record(cpu.now() - began);
        match result {
            Ok(Flow::Continue) => None,
            Ok(Flow::Stop) => Some(StopReason::ControllerFinished),
            Err(payload) => Some(StopReason::ControllerPanic(panic_message(payload.as_ref()))),
        }
    }

    /// Clamps the controller's commands to each motor's limit and stages them for the next
    /// tick's 0x280 frames.
    fn stage_commands(&mut self) {
        for (b, link) in self.buses.iter().enumerate() {
            let mut frame = [IqControl::default(); MULTI_TORQUE_MOTORS];
            for m in link.motors() {
                let motor = &self.motors[m];
                let raw = IqControl::from_amps_saturating(self.command_amps[m]).raw();
                let limited = raw.clamp(-motor.limit_raw, motor.limit_raw);
                if limited != raw {
                    self.stats.motors[m].clamped_commands += 1;
                }
                let iq = IqControl::saturating(limited);
                self.command_amps[m] = iq.amps();
                frame[motor.slot] = iq;
            }
            self.next_commands[b] = frame;
        }
    }

    fn publish(&mut self, timing: &TickTiming) {
        let mut sample = TelemetrySample {
            tick: timing.index,
            scheduled: timing.scheduled,
            time_s: (timing.scheduled - self.start_time).as_secs_f64(),
            wake_latency_ns: timing.wake_latency().as_nanos() as u64,
            motors: self.feedback.len(),
            ..TelemetrySample::default()
        };
        for (slot, (fb, amps)) in sample
            .joints
            .iter_mut()
            .zip(self.feedback.iter().zip(&self.command_amps))
        {
            *slot = JointSample::new(fb, *amps);
        }
        if self.telemetry_tx.send_overwrite(sample).is_some() {
            self.stats.telemetry_drops += 1;
        }
    }

    fn serve_snapshot(&mut self) {
        if let Some(mut buffer) = self.shared.snapshot_requests.pop() {
            buffer.copy_from(&self.stats);
            // The reply queue has room for every request buffer; if a reader abandoned its
            // buffers, drop this one (the reader times out and retries).
            let _ = self.shared.snapshot_replies.push(buffer);
        }
    }

    /// Makes every motor safe, tells the controller, and builds the report.
    pub fn finish(mut self, reason: StopReason) -> LoopOutcome<K> {
        if let StopReason::Fault(fault) = &reason {
            let controller = &mut self.controller;
            let _ = catch_unwind(AssertUnwindSafe(|| controller.fault(fault)));
        }
        let safe_stop = safety::make_safe(&self.clock, &mut self.buses, &self.motors);
        {
            let controller = &mut self.controller;
            let _ = catch_unwind(AssertUnwindSafe(|| controller.stop(&reason)));
        }
        self.shared.running.store(false, Ordering::Release);
        let rt = self
            .rt_status
            .clone()
            .unwrap_or_else(|| os::apply_to_current_thread(&RtRequest::default()));
        let duration_s = if self.start_time == Timestamp::ZERO {
            0.0
        } else {
            (self.clock.now() - self.start_time).as_secs_f64()
        };
        let report = LoopReport {
            normal_stop: reason.is_normal(),
            stop_reason: reason,
            rate_hz: self.period.hz(),
            buses: self.buses.len(),
            motors: self.motors.len(),
            duration_s,
            stats: self.stats.summary(),
            safe_stop,
            realtime_warnings: rt.warnings().map(str::to_string).collect(),
            realtime: rt,
        };
        LoopOutcome {
            report,
            controller: self.controller,
        }
    }
}

/// Stops a loop running on another thread (cheap to clone, `Send + Sync`).
#[derive(Clone, Debug)]
pub struct Stopper {
    shared: Arc<Shared>,
}

impl Stopper {
    pub(crate) fn from_shared(shared: Arc<Shared>) -> Self {
        Self { shared }
    }

    /// Asks the loop to stop at its next tick (motors are made safe).
    pub fn stop(&self) {
        self.shared.request_stop(STOP_REQUESTED);
    }

    /// Emergency stop: takes effect at the loop's next tick (within one period).
    pub fn emergency_stop(&self) {
        self.shared.request_stop(STOP_EMERGENCY);
    }
}

pub(crate) fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "(non-string panic payload)".to_string()
    }
}
