//! The loop engine: one tick after another on one thread.
//!
//! Its life is two types. An [`RtLoop`] is built (everything allocated, nothing sent);
//! [`RtLoop::start`] prepares the thread, probes the motors and starts the controller, giving a
//! [`Running`] loop whose [`step`](Running::step) runs one tick; [`Running::finish`] makes the
//! motors safe and reports. [`RtLoop::run`] does all of it.
//!
//! A tick, in order (see docs/loop.md for the timing diagram):
//!
//! 1. wait for the tick's absolute deadline `t0 + k * period` (sleep, then the spin margin);
//! 2. check for a stop request;
//! 3. the exchange: one 0x280 frame on every bus (the commands of the previous tick), replies
//!    collected until all are in or the reply deadline passes, missing ones accounted;
//! 4. run the controller (panics caught); rejected commands counted (a fault by default);
//! 5. clamp its commands to the current limits and stage them for the next tick;
//! 6. publish telemetry, serve a statistics snapshot if one was asked for, record statistics.

use core::ops::ControlFlow;
use core::time::Duration;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::thread::JoinHandle;

use rmd_bus::{CanBus, Clock, MonotonicClock, Timestamp};
use rmd_protocol::ScaledCurrent;

use crate::bus_link::BusLink;
use crate::commands::{Commands, MAX_SIGNALS, MotionSlots, Rejections};
use crate::controller::{Controller, Flow, TickContext};
use crate::exchange::frames::set_torque_slot;
use crate::exchange::{Exchange, Torque};
use crate::feedback::Feedback;
use crate::finish::{self, LoopOutcome};
use crate::guard::LimitGuard;
use crate::loop_link::LoopLink;
use crate::loop_parts::LoopParts;
use crate::mapping::JointMap;
use crate::motion::{CommandKind, MotionMap};
use crate::os::{CpuLatencyHold, RtSetup, RtStatus};
use crate::report::{Fault, MotorRef, StopReason};
use crate::robot::{ExchangeKind, RejectedCommandPolicy, Robot};
use crate::schedule::{Scheduler, TickTiming};
use crate::stall::{StallCause, TickStage};
use crate::startup;
use crate::stats::LoopStats;
use crate::stopper::Stopper;
use crate::supervisor::{SafetyPort, Supervisor};
use crate::telemetry::{
    self, Published, TelemetryDelivery, TelemetryReceiver, TelemetrySample, TickTimes,
};
use crate::vitals::{LoopPhase, Takeover};

/// How long the loop sleeps between tries when it waits for room in the telemetry mailbox
/// ([`TelemetryDelivery::Wait`], virtual time only).
const TELEMETRY_WAIT: Duration = Duration::from_micros(50);

/// How long a run lasts.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum RunLimit {
    /// Until stopped (handle, controller, fault).
    Forever,
    /// At most this many ticks.
    Ticks(u64),
    /// At most this long on the loop's clock: the ticks due within `duration` of tick 0
    /// (`duration / period` of them, skipped ones included, so an overrunning loop still ends
    /// on time).
    Duration(Duration),
}

/// Why [`RtLoop::unsupervised`] refused its arguments.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The number of buses does not match the robot description.
    #[error("the robot description has {expected} bus(es) but {given} were given")]
    BusCount {
        /// Buses in the description.
        expected: usize,
        /// Buses given.
        given: usize,
    },
    /// The number of safety ports does not match the robot's buses.
    #[error("the supervisor needs one safety port per bus: {expected} expected, {given} given")]
    PortCount {
        /// Buses in the description.
        expected: usize,
        /// Ports given.
        given: usize,
    },
    /// The supervisor's thread could not be started.
    #[error("cannot start the supervisor thread: {0}")]
    Supervisor(String),
    /// The controller declares more user signals than a telemetry sample carries.
    #[error("the controller declares {declared} user signals, at most {MAX_SIGNALS} are supported")]
    TooManySignals {
        /// Signals declared.
        declared: usize,
    },
    /// The controller commands a joint in motion mode, but the joint's bus has none.
    #[error(
        "the controller commands joint `{joint}` in motion mode, but its bus exchanges {exchange}: describe the bus with exchange = \"motion\" (MyActuator V3 motors only) or command the joint with currents"
    )]
    NoMotionMode {
        /// The joint's name.
        joint: String,
        /// Its bus's exchange.
        exchange: ExchangeKind,
    },
}

/// The real-time loop: a robot, its buses, a clock and a controller, ready to start.
///
/// Run it on the current thread with [`run`](RtLoop::run), or on a dedicated thread with
/// [`spawn`](RtLoop::spawn). Buses are given in the order of the robot description.
///
/// ```
/// use rmd_bus::VirtualClock;
/// use rmd_loop::robot::{BusConfig, MotorConfig, Robot, RobotConfig};
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
/// let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(BusConfig::new("sim").with_motor(MotorConfig::new(1))))?;
/// let rt = RtLoop::unsupervised(robot, VirtualClock::new(), vec![NoMotors], Idle)?;
/// let outcome = rt.run(rmd_loop::RunLimit::Ticks(10));
/// // Nobody answered: the loop refuses to start and says why.
/// assert!(outcome.report.stop_description.contains("never answered"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct RtLoop<B, C, K> {
    parts: LoopParts<B, C>,
    controller: K,
    ports: Option<Vec<SafetyPort>>,
}

impl<B: core::fmt::Debug, C: core::fmt::Debug, K: core::fmt::Debug> core::fmt::Debug
    for RtLoop<B, C, K>
{
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("RtLoop")
            .field("parts", &self.parts)
            .field("controller", &self.controller)
            .field("supervised", &self.ports.is_some())
            .finish()
    }
}

/// A started loop: the motors answered, the controller started; [`step`](Running::step) runs
/// one tick, [`finish`](Running::finish) ends the run.
#[derive(Debug)]
pub struct Running<B, C, K> {
    parts: LoopParts<B, C>,
    controller: K,
    scheduler: Scheduler,
    start: Timestamp,
    realtime: RtStatus,
    /// The CPU latency request, held until the run is finished.
    cpu_latency: Option<CpuLatencyHold>,
    supervisor: Option<JoinHandle<()>>,
    identified: Vec<crate::report::IdentifiedMotor>,
    /// The loop thread's last sign of life (a tick began or ended), as the supervisor sees it,
    /// ns on the loop's clock.
    progress_ns: u64,
    /// A gap between two signs of life longer than this is a stall, ns: the stall bound beside
    /// a supervisor, never without one.
    stall_after_ns: u64,
}

impl<B: CanBus, C: Clock + Clone + 'static, K: Controller> RtLoop<B, C, K> {
    /// Prepares a loop of `robot` over `buses` (in description order) with `controller`,
    /// **without a supervisor**: nothing outside the loop's thread stops the motors if the
    /// controller or the bus I/O hangs. For tests, virtual time and buses without a thread of
    /// their own; a robot's program gets the supervised loop from `rmd_rig::Rig::into_loop`.
    /// Allocates everything the loop needs; running it allocates nothing more.
    pub fn unsupervised(
        robot: Robot,
        clock: C,
        buses: Vec<B>,
        controller: K,
    ) -> Result<Self, BuildError> {
        if buses.len() != robot.buses().len() {
            return Err(BuildError::BusCount {
                expected: robot.buses().len(),
                given: buses.len(),
            });
        }
        let signal_count = controller.signals().len();
        if signal_count > MAX_SIGNALS {
            return Err(BuildError::TooManySignals {
                declared: signal_count,
            });
        }
        for joint in robot.joints() {
            let exchange = robot.buses()[joint.bus].exchange;
            match (controller.command_kind(joint), exchange) {
                (CommandKind::Current, _) | (CommandKind::Motion, ExchangeKind::Motion) => {}
                (
                    CommandKind::Motion,
                    exchange @ (ExchangeKind::MultiTorque | ExchangeKind::PerMotor),
                ) => {
                    return Err(BuildError::NoMotionMode {
                        joint: joint.name.clone(),
                        exchange,
                    });
                }
            }
        }
        let joints = robot.joint_count();
        let exchange = Exchange::new(&robot, buses);
        let motion_maps: Vec<Option<MotionMap>> =
            if exchange.motors.iter().any(|m| m.motion.is_some()) {
                exchange
                    .motors
                    .iter()
                    .map(|m| m.motion.map(|motion| motion.map))
                    .collect()
            } else {
                Vec::new()
            };
        Ok(Self {
            parts: LoopParts {
                command_motion: vec![None; motion_maps.len()],
                motion_maps,
                exchange,
                stats: LoopStats::new(&robot),
                maps: robot.joints().iter().map(JointMap::from_spec).collect(),
                guards: robot.joints().iter().map(LimitGuard::from_spec).collect(),
                limits_on: robot.joints().iter().any(|j| j.limits.any()),
                command_amps: vec![0.0; joints],
                signals: [0.0; MAX_SIGNALS],
                signal_count,
                rejections: Rejections::NONE,
                telemetry: None,
                times: TickTimes::default(),
                shared: Arc::new(LoopLink::new()),
                clock,
                robot,
            },
            controller,
            ports: None,
        })
    }

    /// Puts a supervisor beside the loop thread, with its own way onto each bus (`ports`, in
    /// description order): see [`supervisor`](crate::supervisor). It watches the run from the
    /// first tick to the start of the loop's own safe stop.
    pub fn supervise(mut self, ports: Vec<SafetyPort>) -> Result<Self, BuildError> {
        if ports.len() != self.parts.robot.buses().len() {
            return Err(BuildError::PortCount {
                expected: self.parts.robot.buses().len(),
                given: ports.len(),
            });
        }
        self.ports = Some(ports);
        Ok(self)
    }

    /// A receiver of the per-tick telemetry (clone it freely; each sample is received once).
    /// The loop publishes only once this was called. When the receiver falls behind, the oldest
    /// samples are overwritten and counted ([`TelemetryDelivery::Overwrite`]).
    pub fn telemetry(&mut self) -> TelemetryReceiver {
        self.telemetry_with(TelemetryDelivery::Overwrite)
    }

    /// [`telemetry`](Self::telemetry) with the given behaviour when the mailbox is full:
    /// [`TelemetryDelivery::Wait`] (virtual time only) makes the loop wait for room, so the
    /// receiver gets every tick. Calling it again replaces the earlier receiver's mailbox.
    pub fn telemetry_with(&mut self, delivery: TelemetryDelivery) -> TelemetryReceiver {
        let capacity = self.parts.robot.settings().telemetry_capacity.get();
        let (tx, rx) = telemetry::channel(
            capacity,
            self.parts.robot.joint_count(),
            self.parts.signal_count,
        );
        self.parts.telemetry = Some((tx, delivery));
        rx
    }

    /// The robot the loop runs.
    pub fn robot(&self) -> &Robot {
        &self.parts.robot
    }

    /// The controller.
    pub fn controller(&self) -> &K {
        &self.controller
    }

    /// The clock.
    pub fn clock(&self) -> &C {
        &self.parts.clock
    }

    /// A handle that can stop this loop from another thread (e.g. a Ctrl-C handler).
    pub fn stopper(&self) -> Stopper {
        Stopper::new(Arc::clone(&self.parts.shared))
    }

    pub(crate) fn shared(&self) -> Arc<LoopLink> {
        Arc::clone(&self.parts.shared)
    }

    pub(crate) fn stats(&self) -> &LoopStats {
        &self.parts.stats
    }

    /// Runs the loop on the current thread until `limit`, a stop request, the controller's
    /// [`Flow::Stop`] or a fault; then makes every motor safe and reports.
    pub fn run(self, limit: RunLimit) -> LoopOutcome<K> {
        let mut running = match self.start() {
            Ok(running) => running,
            Err(outcome) => return *outcome,
        };
        // Ticks(n) counts the ticks run; Duration(d) the ticks due within d of tick 0, so
        // that ticks skipped after an overrun count too and the run lasts d, not longer.
        let (max_ticks, due_before) = match limit {
            RunLimit::Forever => (u64::MAX, u64::MAX),
            RunLimit::Ticks(n) => (n, u64::MAX),
            RunLimit::Duration(d) => (
                u64::MAX,
                (d.as_nanos() / running.scheduler.period().as_nanos()).min(u128::from(u64::MAX))
                    as u64,
            ),
        };
        let ran = catch_unwind(AssertUnwindSafe(|| {
            let mut ran = 0;
            // A tick past the end is never run: not the next one, and not one a skip after an
            // overrun would land on (the clock already past the end).
            let end = running.scheduler.scheduled(due_before);
            while ran < max_ticks
                && running.scheduler.next_index() < due_before
                && (due_before == u64::MAX || running.parts.clock.now() < end)
            {
                if let ControlFlow::Break(reason) = running.step() {
                    return reason;
                }
                ran += 1;
            }
            // The clock passed the end while the loop was late (an overrun, a stall): the slots
            // due before it that never ran were skipped.
            if due_before != u64::MAX {
                let missed = due_before.saturating_sub(running.scheduler.next_index());
                running.parts.stats.skipped_ticks += missed;
            }
            StopReason::TickLimit
        }));
        let reason = ran.unwrap_or_else(|payload| {
            StopReason::ControllerPanic(format!(
                "internal loop error: {}",
                finish::panic_message(payload.as_ref())
            ))
        });
        running.finish(reason)
    }

    /// Prepares the thread (CPU, priority, memory), runs the start-up probe (zero torque to
    /// every motor until each has answered once) and starts the controller. If that fails, the
    /// motors are made safe and the outcome says why.
    pub fn start(self) -> Result<Running<B, C, K>, Box<LoopOutcome<K>>> {
        let Self {
            mut parts,
            mut controller,
            ports,
        } = self;
        parts.shared.set_running(true);
        crate::panics::enter();
        // On every early return below the hold is dropped: the request ends with the start.
        let RtSetup {
            status: mut realtime,
            cpu_latency,
            supervisor: supervisor_placement,
            thread_stats,
        } = startup::prepare_thread(parts.robot.settings());
        let identified = match startup::identify_motors(&mut parts) {
            Ok(identified) => identified,
            Err(reason) => {
                return Err(Box::new(finish::finish(
                    parts,
                    controller,
                    reason,
                    realtime,
                    None,
                    None,
                    Vec::new(),
                )));
            }
        };
        // The identification read each `motion` bus motor's firmware, and with it its ranges.
        for (map, motor) in parts.motion_maps.iter_mut().zip(&parts.exchange.motors) {
            *map = motor.motion.map(|motion| motion.map);
        }
        if let Err(reason) =
            startup::release_brakes(&mut parts).and_then(|()| startup::probe(&mut parts))
        {
            return Err(Box::new(finish::finish(
                parts, controller, reason, realtime, None, None, identified,
            )));
        }
        let settings = *parts.robot.settings();
        let t0 = parts.clock.now() + settings.period.get();
        let ctx = TickContext {
            index: 0,
            scheduled: t0,
            woke: parts.clock.now(),
            period: settings.period.get(),
            start: t0,
        };
        let feedback = Feedback::new(&parts.exchange.feedback, parts.robot.joints());
        let started = catch_unwind(AssertUnwindSafe(|| controller.start(&ctx, &feedback)));
        if let Err(payload) = started {
            let reason = StopReason::ControllerPanic(finish::panic_message(payload.as_ref()));
            return Err(Box::new(finish::finish(
                parts, controller, reason, realtime, None, None, identified,
            )));
        }
        parts.shared.vitals.progress(parts.clock.now(), 0);
        parts.shared.vitals.set_phase(LoopPhase::Running);
        let supervisor = match ports {
            None => None,
            Some(ports) => {
                let supervisor = Supervisor {
                    clock: parts.clock.clone(),
                    shared: Arc::clone(&parts.shared),
                    links: ports
                        .into_iter()
                        .zip(parts.robot.buses())
                        .map(|(bus, spec)| BusLink {
                            // The supervisor acts while the loop ticks: torque was commanded.
                            // It only makes motors safe: no status requests.
                            commanded: true,
                            ..BusLink::new(bus, spec)
                        })
                        .collect(),
                    ids: parts.exchange.motors.iter().map(|m| m.id).collect(),
                    robot: parts.robot.clone(),
                    stats: thread_stats,
                };
                match supervisor.spawn(&supervisor_placement) {
                    Ok((handle, placed)) => {
                        realtime.supervisor = placed;
                        Some(handle)
                    }
                    Err(_) => {
                        let reason = StopReason::Fault(Fault::Supervisor);
                        return Err(Box::new(finish::finish(
                            parts, controller, reason, realtime, None, None, identified,
                        )));
                    }
                }
            }
        };
        // The supervisor's start (waited for above) is no stall of the loop's.
        let progress_at = parts.clock.now();
        parts.shared.vitals.progress(progress_at, 0);
        Ok(Running {
            identified,
            progress_ns: progress_at.as_nanos(),
            stall_after_ns: match supervisor {
                Some(_) => duration_ns(settings.stall_bound),
                None => u64::MAX,
            },
            supervisor,
            scheduler: Scheduler::new(settings.period, settings.spin_margin, settings.overrun, t0),
            start: t0,
            realtime,
            cpu_latency,
            parts,
            controller,
        })
    }
}

impl<B: CanBus, C: Clock + Clone + 'static, K: Controller> Running<B, C, K> {
    /// The statistics so far (on the loop's own thread; other threads use a handle's snapshot).
    pub fn stats(&self) -> &LoopStats {
        &self.parts.stats
    }

    /// The controller.
    pub fn controller(&self) -> &K {
        &self.controller
    }

    /// The clock.
    pub fn clock(&self) -> &C {
        &self.parts.clock
    }

    /// Runs one tick. Breaks with the reason the loop must stop, if it must.
    pub fn step(&mut self) -> ControlFlow<StopReason> {
        self.parts.shared.vitals.enter(TickStage::Waiting);
        let timing = self.scheduler.wait_next(&self.parts.clock);
        let vitals = &self.parts.shared.vitals;
        vitals.progress(timing.woke, timing.index);
        if vitals.phase() != LoopPhase::Running {
            return ControlFlow::Break(StopReason::EmergencyStop); // replaced by the supervisor's
        }
        // Overslept past the stall bound, and the supervisor did not see it.
        self.stalled(timing.index, timing.woke)?;
        if let Some(request) = self.parts.shared.stop.pending() {
            return ControlFlow::Break(request.into());
        }
        self.parts.shared.vitals.enter(TickStage::Exchange);
        let stats = &mut self.parts.stats;
        // Counted when it starts, so that a snapshot taken during the tick is consistent.
        stats.ticks += 1;
        stats.skipped_ticks += timing.skipped;
        stats
            .wake_latency
            .record_nanos(nanos_between(timing.scheduled, timing.woke));
        let last_reply = match self.exchange(&timing) {
            Ok(last_reply) => last_reply,
            Err(reason) => return ControlFlow::Break(reason),
        };
        if let Some(fault) = self.parts.limit_breach() {
            return ControlFlow::Break(StopReason::Fault(fault));
        }
        self.parts.shared.vitals.enter(TickStage::Controller);
        self.run_controller(&timing)?;
        self.parts.shared.vitals.enter(TickStage::Bookkeeping);
        self.parts.stage_commands();
        self.parts.publish(&timing, self.start);
        self.parts.shared.serve_snapshot(&self.parts.stats);
        let end = self.parts.clock.now();
        self.parts.shared.vitals.progress(end, timing.index);
        // A tick longer than the stall bound that the supervisor did not end.
        self.stalled(timing.index, end)?;
        let work_ns = nanos_between(timing.woke, end);
        let stats = &mut self.parts.stats;
        stats.work.record_nanos(work_ns);
        // The loop is ready for the next frame: what it added after the last reply.
        if let Some(last) = last_reply {
            stats.loop_added.record_nanos(nanos_between(last, end));
        }
        self.parts.times.previous_work_ns = work_ns;
        let tick_end = self.scheduler.end_tick(end);
        if tick_end.missed_deadline {
            stats.deadline_misses += 1;
        }
        if tick_end.missed_deadline || last_reply.is_none() {
            stats.missed_ticks += 1;
        }
        if tick_end.fault {
            return ControlFlow::Break(StopReason::Fault(Fault::DeadlineMisses {
                consecutive: tick_end.consecutive_misses,
            }));
        }
        ControlFlow::Continue(())
    }

    /// Records a sign of life at `now` in `tick`; in a supervised run, breaks with a stall when
    /// the one before was longer ago than the stall bound: the supervisor did not end it, so it
    /// was not run either (the process was stopped, or the machine starved it), and neither was
    /// this thread. (Without a supervisor the stall bound does not apply: benchmarks and tests
    /// count late ticks instead.)
    #[inline]
    fn stalled(&mut self, tick: u64, now: Timestamp) -> ControlFlow<StopReason> {
        let now_ns = now.as_nanos();
        let gap_ns = now_ns.saturating_sub(self.progress_ns);
        self.progress_ns = now_ns;
        if gap_ns <= self.stall_after_ns {
            return ControlFlow::Continue(());
        }
        ControlFlow::Break(stall_fault(
            tick,
            gap_ns,
            self.parts.robot.settings().stall_bound,
        ))
    }

    /// Send on every bus, then collect from every bus, then account for missing replies. Returns
    /// when the tick's last reply came, if every motor's did.
    fn exchange(&mut self, timing: &TickTiming) -> Result<Option<Timestamp>, StopReason> {
        let LoopParts {
            exchange,
            stats,
            clock,
            robot,
            times,
            shared,
            ..
        } = &mut self.parts;
        exchange.begin_tick();
        let sent_at = clock.now();
        for b in 0..exchange.links.len() {
            // Never after the supervisor took over (it may be sending motor-off right now).
            if !shared.vitals.begin_send() {
                return Err(StopReason::EmergencyStop); // replaced by the supervisor's reason
            }
            let sent = exchange.send(b, Torque::Staged, timing.index, sent_at, stats);
            shared.vitals.end_send();
            sent.map_err(StopReason::Fault)?;
        }
        let deadline = timing.scheduled + robot.settings().reply_deadline;
        let max_age = exchange.max_age;
        let collected = exchange
            .collect_all(clock, timing.index, deadline, max_age, stats)
            .map_err(StopReason::Fault)?;
        let fault_after = robot.settings().missing_reply_fault_after.get();
        let all_fresh = exchange
            .account(fault_after, stats)
            .map_err(StopReason::Fault)?;
        times.round_trip_ns = None;
        if !all_fresh {
            return Ok(None);
        }
        if let Some(last) = collected.last_reply() {
            // Same tick: from this tick's send to the last reply. Pipelined: the replies answer
            // the previous tick, so use the tracked round trip of the slowest motor.
            let rtt_ns = if max_age == 0 {
                nanos_between(sent_at, last)
            } else {
                collected.rtt_max_ns
            };
            stats.round_trip.record_nanos(rtt_ns);
            times.round_trip_ns = Some(rtt_ns);
        }
        Ok(collected.last_reply())
    }

    fn run_controller(&mut self, timing: &TickTiming) -> ControlFlow<StopReason> {
        let ctx = TickContext {
            index: timing.index,
            scheduled: timing.scheduled,
            woke: timing.woke,
            period: self.scheduler.period(),
            start: self.start,
        };
        let parts = &mut self.parts;
        parts.command_amps.fill(0.0);
        parts.command_motion.fill(None);
        parts.rejections = Rejections::NONE;
        let feedback = Feedback::new(&parts.exchange.feedback, parts.robot.joints());
        let motion = MotionSlots {
            maps: &parts.motion_maps,
            given: &mut parts.command_motion,
        };
        let mut commands = Commands::new(
            &mut parts.command_amps,
            &parts.maps,
            motion,
            &mut parts.signals[..parts.signal_count],
            &mut parts.rejections,
        );
        let controller = &mut self.controller;
        let cpu = MonotonicClock;
        let began = cpu.now();
        let result = catch_unwind(AssertUnwindSafe(|| {
            controller.update(&ctx, &feedback, &mut commands)
        }));
        let spent_ns = nanos_between(began, cpu.now());
        parts.stats.controller.record_nanos(spent_ns);
        parts.times.controller_ns = spent_ns;
        let flow = match result {
            Ok(flow) => flow,
            Err(payload) => {
                return ControlFlow::Break(StopReason::ControllerPanic(finish::panic_message(
                    payload.as_ref(),
                )));
            }
        };
        if let Some(fault) = parts.count_rejections() {
            return ControlFlow::Break(StopReason::Fault(fault));
        }
        match flow {
            Flow::Continue => ControlFlow::Continue(()),
            Flow::Stop => ControlFlow::Break(StopReason::ControllerFinished),
            Flow::Halt(why) => ControlFlow::Break(StopReason::ControllerHalted(why)),
        }
    }

    /// Makes every motor safe, tells the controller, and builds the report. If the supervisor
    /// took over, its safe stop and its reason are the run's.
    pub fn finish(self, reason: StopReason) -> LoopOutcome<K> {
        let vitals = &self.parts.shared.vitals;
        let takeover = if vitals.swap_phase(LoopPhase::Running, LoopPhase::Finishing) {
            None
        } else {
            wait_for_takeover(&self.parts.shared, self.supervisor)
        };
        let outcome = finish::finish(
            self.parts,
            self.controller,
            reason,
            self.realtime,
            Some(self.start),
            takeover,
            self.identified,
        );
        // The motors are safe: the CPUs may sleep deeply again.
        drop(self.cpu_latency);
        outcome
    }
}

/// Nanoseconds from `earlier` to `later` (0 if `later` is not later).
fn nanos_between(earlier: Timestamp, later: Timestamp) -> u64 {
    later.as_nanos().saturating_sub(earlier.as_nanos())
}

/// A stall of `gap_ns` past `bound` in `tick`, seen by the loop thread: the OS ran neither it
/// nor its supervisor.
#[cold]
fn stall_fault(tick: u64, gap_ns: u64, bound: Duration) -> StopReason {
    StopReason::Fault(Fault::TickStalled {
        tick,
        bound,
        stalled: Duration::from_nanos(gap_ns),
        cause: StallCause::NotRun {
            waited: None,
            stopped: false,
        },
    })
}

/// A duration in nanoseconds, saturating.
fn duration_ns(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

/// Waits for the supervisor that took over to finish its safe stop, and takes what it did.
fn wait_for_takeover(shared: &LoopLink, supervisor: Option<JoinHandle<()>>) -> Option<Takeover> {
    if let Some(handle) = supervisor {
        let _ = handle.join();
    }
    shared.vitals.take_takeover()
}

impl<B, C> LoopParts<B, C> {
    /// Adds this tick's rejected commands to the statistics; with the `fault` policy, the first
    /// one is the fault that ends the run.
    fn count_rejections(&mut self) -> Option<Fault> {
        let r = &self.rejections;
        // An undeclared signal index is counted on every tick it happens, but it is no command:
        // it neither sets `first` nor faults.
        self.stats.unknown_signals += u64::from(r.unknown_signal);
        let (joint, reason) = r.first?;
        for (counters, count) in self.stats.motors.iter_mut().zip(r.per_joint) {
            counters.rejected_commands += u64::from(count);
        }
        self.stats.unknown_joint_commands += u64::from(r.unknown_joint);
        match self.robot.settings().rejected_command {
            RejectedCommandPolicy::Fault => Some(Fault::RejectedCommand { joint, reason }),
            RejectedCommandPolicy::Zero => None,
        }
    }

    /// The first joint further past one of its limits than its margin, as a fault.
    #[inline]
    fn limit_breach(&self) -> Option<Fault> {
        if self.limits_on {
            self.find_breach()
        } else {
            None
        }
    }

    /// [`limit_breach`](Self::limit_breach) of a robot with limits (out of line: a robot
    /// without them keeps the tick as it was).
    #[inline(never)]
    fn find_breach(&self) -> Option<Fault> {
        let feedback = &self.exchange.feedback;
        let (joint, breach) = self
            .guards
            .iter()
            .zip(feedback)
            .enumerate()
            .find_map(|(j, (guard, fb))| guard.breach(&fb.joint).map(|b| (j, b)))?;
        let spec = &self.robot.joints()[joint];
        Some(Fault::JointLimit {
            at: MotorRef {
                joint: crate::joint::JointId::from_index(joint),
                bus: spec.bus,
                motor: spec.motor,
            },
            breach,
        })
    }

    /// Replaces the controller's commands that push a joint further past one of its limits by
    /// zero torque, counted.
    #[inline(never)]
    fn refuse_beyond_limits(&mut self) {
        let joints = self.guards.iter().zip(&self.exchange.feedback);
        let commands = self.command_amps.iter_mut().zip(&mut self.stats.motors);
        for ((guard, feedback), (amps, counters)) in joints.zip(commands) {
            if guard.refuses(&feedback.joint, *amps) {
                *amps = 0.0;
                counters.limited_commands += 1;
            }
        }
    }

    /// Refuses the controller's commands that push a joint further past a limit (zero torque,
    /// counted), clamps the rest to each joint's current limit, and stages them for the next
    /// tick's 0x280 frames.
    fn stage_commands(&mut self) {
        if self.limits_on {
            self.refuse_beyond_limits();
        }
        let exchange = &mut self.exchange;
        // Slots of no described motor keep the zero they were built with.
        for ((motor, amps), counters) in exchange
            .motors
            .iter_mut()
            .zip(&mut self.command_amps)
            .zip(&mut self.stats.motors)
        {
            let command = &motor.command;
            let (raw, clamped) = command.limited_raw(*amps);
            counters.clamped_commands += u64::from(clamped);
            let iq = ScaledCurrent::saturating(raw, command.scale);
            *amps = iq.amps();
            // Both forms, unconditionally (cheaper than asking which the bus sends): a
            // `per-motor` bus's staged 0x280 slots are never sent.
            motor.staged = iq.raw();
            if let Some(slots) = exchange.staged.get_mut(motor.at.bus) {
                set_torque_slot(slots, motor.slot, iq);
            }
        }
        if !self.command_motion.is_empty() {
            self.stage_motion();
        }
    }

    /// Stages each `motion` bus motor's next command: the controller's setpoint (its
    /// feed-forward torque limitation counted as a clamp), else its staged current as
    /// feed-forward torque with zero gains.
    #[inline(never)]
    fn stage_motion(&mut self) {
        let motors = self.exchange.motors.iter_mut().zip(&mut self.stats.motors);
        let commands = self.command_motion.iter().zip(&mut self.command_amps);
        for ((motor, counters), (given, amps)) in motors.zip(commands) {
            let Some(motion) = &mut motor.motion else {
                continue;
            };
            motion.staged = match given {
                Some(packed) => {
                    counters.clamped_commands += u64::from(packed.limited);
                    packed.command
                }
                None => motion.map.torque_command(*amps),
            };
            // What the telemetry shows as the command: the feed-forward torque's current.
            *amps = motion.map.feed_forward_amps(&motion.staged);
        }
    }
}

impl<B, C: Clock> LoopParts<B, C> {
    /// Publishes this tick's sample, if anything receives telemetry.
    fn publish(&mut self, timing: &TickTiming, start: Timestamp) {
        let Some((tx, delivery)) = &mut self.telemetry else {
            return;
        };
        let taken_at = self.clock.now();
        let fill = |sample: &mut TelemetrySample| {
            sample.tick = timing.index;
            sample.scheduled = timing.scheduled;
            sample.start = start;
            sample.taken_at = taken_at;
            sample.time_s = (timing.scheduled - start).as_secs_f64();
            sample.times = self.times;
            sample.times.wake_latency_ns = timing.wake_latency().as_nanos() as u64;
            sample.totals.ticks = self.stats.ticks;
            sample.totals.deadline_misses = self.stats.deadline_misses;
            sample.totals.missing_replies = self.stats.missing_total;
            sample.totals.late_replies = self.stats.late_total;
            for (slot, (feedback, amps)) in sample
                .joints_mut()
                .iter_mut()
                .zip(self.exchange.feedback.iter().zip(&self.command_amps))
            {
                slot.feedback = *feedback;
                slot.command_amps = *amps;
            }
            // (Without signals, no call to copy nothing.)
            if self.signal_count > 0 {
                sample
                    .signals_mut()
                    .copy_from_slice(&self.signals[..self.signal_count]);
            }
        };
        // Overwriting, one publish; waiting, until the sample is queued (`fill` is called only
        // then). One call site: `fill` inlines into it.
        let overwrite = *delivery == TelemetryDelivery::Overwrite;
        let delivered = loop {
            if tx.publish(overwrite, fill) == Published::Queued {
                break true;
            }
            // Nobody will make room, or the run is to end: stop waiting.
            if overwrite
                || !tx.has_receivers()
                || self.shared.stop.pending().is_some()
                || self.shared.vitals.phase() != LoopPhase::Running
            {
                break false;
            }
            std::thread::sleep(TELEMETRY_WAIT);
        };
        if !delivered {
            self.stats.telemetry_drops += 1;
        }
    }
}
