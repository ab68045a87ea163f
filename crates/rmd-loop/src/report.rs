//! Why the loop stopped, what it did to make the motors safe, and the final report.

use core::fmt;
use core::time::Duration;

use rmd_bus::BusError;
use rmd_protocol::{Finding, MotorId, ProtocolFamily};
use serde::Serialize;

use crate::guard::LimitBreach;
use crate::health::MotorFlag;
use crate::joint::JointId;
use crate::os::RtStatus;
use crate::protection::{MotorProtection, ProtectionLine};
use crate::rejection::Rejection;
use crate::robot::Robot;
pub use crate::safe_stop::{
    BusSafeStop, BusStopOutcome, MotorSafeStop, SafeStopBy, SafeStopReport,
};
use crate::stall::StallCause;
use crate::stats::StatsSummary;

/// Which joint, on which bus, driven by which motor: how faults point at a motor.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct MotorRef {
    /// The joint.
    pub joint: JointId,
    /// Its bus (index in description order).
    pub bus: usize,
    /// Its motor's id.
    pub motor: MotorId,
}

impl MotorRef {
    /// `joint knee (motor 3 on bus 0)`, with the name from `robot`.
    pub fn describe(&self, robot: &Robot) -> String {
        match robot.joints().get(self.joint.index()) {
            Some(spec) => format!("joint {} ({self})", spec.name),
            None => self.to_string(),
        }
    }
}

impl fmt::Display for MotorRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "motor {} on bus {}", self.motor.get(), self.bus)
    }
}

/// A condition that stops the loop and makes every motor safe.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Fault {
    /// A motor gave no fresh feedback for `ticks` consecutive ticks: its replies were missing,
    /// or late (answering older frames).
    NoFreshFeedback {
        /// The motor.
        at: MotorRef,
        /// Consecutive ticks without fresh feedback.
        ticks: u32,
    },
    /// Not every motor answered during the start-up probe.
    StartupTimeout {
        /// The first motor that never answered.
        at: MotorRef,
        /// How many motors never answered.
        missing: usize,
    },
    /// A bus went bus-off.
    BusOff {
        /// Bus index.
        bus: usize,
    },
    /// A bus operation failed in a way the loop cannot ride through.
    Bus {
        /// Bus index.
        bus: usize,
        /// The error.
        error: BusError,
    },
    /// Too many consecutive deadline misses for the overrun policy.
    DeadlineMisses {
        /// Consecutive misses.
        consecutive: u32,
    },
    /// A motor reported a temperature at or above its configured limit.
    OverTemperature {
        /// The motor.
        at: MotorRef,
        /// The reported temperature.
        celsius: f64,
    },
    /// A motor raised an error flag in its status reply (the health rotation, 0x9A): its
    /// firmware protects itself (under-voltage, over-temperature, stall, ...).
    MotorError {
        /// The motor.
        at: MotorRef,
        /// The flag (the first, when it raised several).
        flag: MotorFlag,
        /// Its error flags as sent (v1.61 / LK-TECH: the error byte; V3: 16 bits).
        error_flags: u16,
    },
    /// The supervisor thread could not be started: the run did not begin.
    Supervisor,
    /// A motor answered at start-up on a bus but the description does not have it: the 0x280
    /// frame would command it. Nothing was sent but read-only requests.
    UndescribedMotor {
        /// Bus index.
        bus: usize,
        /// Its id.
        motor: MotorId,
        /// Its protocol family, as identified.
        family: ProtocolFamily,
    },
    /// A described motor's firmware is not what the loop can drive as described: MyActuator V3
    /// (its 0x280 frame is a command byte for every motor), another family than the described
    /// dialect's (the current scales would be wrong), or answers that identify no family.
    Firmware {
        /// The motor.
        at: MotorRef,
        /// Its family, as identified.
        family: ProtocolFamily,
        /// The described dialect's family.
        described: ProtocolFamily,
        /// What its answers showed.
        finding: Finding,
    },
    /// A motor on a `motion` bus runs firmware whose motion-mode ranges the loop cannot know
    /// (V4.4 firmware scales the torque field to the motor's maximum torque): nothing but
    /// read-only requests was sent.
    MotionRanges {
        /// The motor.
        at: MotorRef,
        /// Its firmware's version date (`YYYYMMDDNN`), as it reported it.
        firmware_date: Option<u32>,
    },
    /// A tick did not complete within the stall bound: the supervisor made every motor safe
    /// while the stall lasted (or the loop thread, when it came back and the supervisor had not
    /// been run either). The cause says whether the operating system did not run the loop
    /// thread, or the controller (or the bus I/O) spun or blocked.
    TickStalled {
        /// The tick that did not complete.
        tick: u64,
        /// The bound (`loop.stall_bound_ms`).
        bound: Duration,
        /// How long the loop thread had shown no sign of life when the stall was seen.
        stalled: Duration,
        /// Why.
        cause: StallCause,
    },
    /// A joint went further past one of its limits than its margin (`limit_margin_deg`,
    /// `velocity_margin_dps`): a load, its momentum, or torque the loop refused too late drove
    /// it there. Every motor made safe.
    JointLimit {
        /// The joint.
        at: MotorRef,
        /// Which limit, where the joint was, the limit and the margin.
        breach: LimitBreach,
    },
    /// The controller wrote a command the loop cannot send as given (with
    /// `loop.rejected_command = "fault"`, the default).
    RejectedCommand {
        /// The joint, when the command named one of the robot's.
        joint: Option<JointId>,
        /// Why it was rejected.
        reason: Rejection,
    },
}

/// What follows a joint-limit fault.
const JOINT_LIMIT_ADVICE: &str = ": every motor was made safe (what carried it there: a load, \
     its momentum or a controller pushing; check the joint's limits, its homing and the gains)";

fn firmware_problem(family: ProtocolFamily, described: ProtocolFamily, finding: Finding) -> String {
    match family {
        ProtocolFamily::MyActuatorV3 if described != ProtocolFamily::MyActuatorV3 => format!(
            "its firmware speaks MyActuator V3 (it answers on 0x240 + id) but the description \
             says {described}: describe it with protocol = \"myactuator-v3\" (its bus then \
             exchanges torque per motor); nothing was sent"
        ),
        ProtocolFamily::MyActuatorV3 => "its firmware speaks MyActuator V3 (it answers on \
             0x240 + id): a 0x280 frame is a command byte executed by every motor on the bus, not \
             per-motor torque, so its bus must use exchange = \"per-motor\"; nothing was sent"
            .to_string(),
        ProtocolFamily::Unknown => format!(
            "its answers identify no firmware family ({finding}), so what a 0x280 frame would \
             do to it is not known: nothing was sent (check its supply and wiring, and `rmd scan` \
             it)"
        ),
        other => format!(
            "its firmware speaks {other} but the description says {described} (the current \
             scales would be wrong): set protocol = \"{}\" (with lk_series for LK-TECH) or \
             model; nothing was sent",
            other.name()
        ),
    }
}

impl Fault {
    /// The fault in words, naming joints by their names in `robot`.
    pub fn describe(&self, robot: &Robot) -> String {
        match self {
            Fault::Firmware {
                at,
                family,
                described,
                finding,
            } => format!(
                "{}: {}",
                at.describe(robot),
                firmware_problem(*family, *described, *finding)
            ),
            Fault::NoFreshFeedback { at, ticks } => format!(
                "{} gave no fresh feedback for {ticks} consecutive ticks: its replies were missing \
                 or late (check its power, wiring and id, and the bus load)",
                at.describe(robot)
            ),
            Fault::StartupTimeout { at, missing } => format!(
                "{missing} motor(s) never answered at start, first: {} (check power, id and bit rate)",
                at.describe(robot)
            ),
            Fault::OverTemperature { at, celsius } => format!(
                "{} reports {celsius} degC, at or above its limit",
                at.describe(robot)
            ),
            Fault::MotorError {
                at,
                flag,
                error_flags,
            } => format!(
                "{} reports {flag} (error flags {error_flags:#06x}): {}",
                at.describe(robot),
                flag.advice()
            ),
            Fault::JointLimit { at, breach } => {
                format!("{} {breach}{JOINT_LIMIT_ADVICE}", at.describe(robot))
            }
            Fault::RejectedCommand {
                joint: Some(joint),
                reason,
            } => match robot.joints().get(joint.index()) {
                Some(spec) => format!("the controller's command for joint {}: {reason}", spec.name),
                None => self.to_string(),
            },
            _ => self.to_string(),
        }
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Fault::NoFreshFeedback { at, ticks } => write!(
                f,
                "{at} gave no fresh feedback for {ticks} consecutive ticks: its replies were \
                 missing or late (check its power, wiring and id, and the bus load)"
            ),
            Fault::StartupTimeout { at, missing } => write!(
                f,
                "{missing} motor(s) never answered at start, first: {at} (check power, id and bit rate)"
            ),
            Fault::BusOff { bus } => write!(
                f,
                "bus {bus} went bus-off (check wiring, termination and bit rate)"
            ),
            Fault::Bus { bus, error } => write!(f, "bus {bus}: {error}"),
            Fault::DeadlineMisses { consecutive } => write!(
                f,
                "{consecutive} consecutive deadline misses (lower the rate, pin the loop to an isolated CPU, use SCHED_FIFO)"
            ),
            Fault::OverTemperature { at, celsius } => {
                write!(f, "{at} reports {celsius} degC, at or above its limit")
            }
            Fault::MotorError {
                at,
                flag,
                error_flags,
            } => write!(
                f,
                "{at} reports {flag} (error flags {error_flags:#06x}): {}",
                flag.advice()
            ),
            Fault::UndescribedMotor { bus, motor, family } => write!(
                f,
                "motor {} answers on bus {bus} ({family}) but the robot description does not \
                 have it: the 0x280 frame would command it, so nothing was sent. Describe it \
                 (a [[bus.motor]] with id = {}), or list it in the bus's zero_torque_ids to let \
                 the loop command it zero torque",
                motor.get(),
                motor.get()
            ),
            Fault::Firmware {
                at,
                family,
                described,
                finding,
            } => write!(
                f,
                "{at}: {}",
                firmware_problem(*family, *described, *finding)
            ),
            Fault::MotionRanges { at, firmware_date } => write!(
                f,
                "{at}: its firmware (version date {}) packs motion-mode torque over the motor's \
                 maximum torque, which the description does not give: set the motor's model \
                 (model = \"...\", one whose maximum torque is known: `rmd models`) or use \
                 exchange = \"per-motor\"; nothing was sent",
                firmware_date.map_or_else(|| "unknown".to_string(), |d| d.to_string())
            ),
            Fault::Supervisor => f.write_str(
                "the supervisor thread could not be started (out of threads or memory?)",
            ),
            Fault::TickStalled {
                tick,
                bound,
                stalled,
                cause,
            } => {
                write!(
                    f,
                    "tick {tick} did not complete within {} ms: ",
                    bound.as_millis()
                )?;
                crate::stall::describe(f, *stalled, cause)
            }
            Fault::JointLimit { at, breach } => write!(f, "{at} {breach}{JOINT_LIMIT_ADVICE}"),
            Fault::RejectedCommand { joint, reason } => match joint {
                Some(joint) => write!(f, "the controller's command for {joint}: {reason}"),
                None => write!(
                    f,
                    "the controller commanded a joint this robot does not have"
                ),
            },
        }
    }
}

/// Why the loop ended.
#[derive(Clone, Debug, PartialEq)]
pub enum StopReason {
    /// A stop was requested ([`LoopHandle::stop`](crate::LoopHandle::stop), a
    /// [`Stopper`](crate::Stopper)).
    Requested,
    /// An emergency stop was requested.
    EmergencyStop,
    /// The [`LoopHandle`](crate::LoopHandle) was dropped while the loop ran.
    HandleDropped,
    /// The controller returned [`Flow::Stop`](crate::Flow::Stop).
    ControllerFinished,
    /// The controller returned [`Flow::Halt`](crate::Flow::Halt): a stop for its own safety.
    ControllerHalted(&'static str),
    /// The run reached its tick limit.
    TickLimit,
    /// A fault.
    Fault(Fault),
    /// The controller panicked (the message, if it was a string).
    ControllerPanic(String),
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StopReason::Requested => f.write_str("stop requested"),
            StopReason::EmergencyStop => f.write_str("EMERGENCY STOP"),
            StopReason::HandleDropped => f.write_str("loop handle dropped"),
            StopReason::ControllerFinished => f.write_str("controller finished"),
            StopReason::ControllerHalted(why) => write!(f, "HALTED by the controller: {why}"),
            StopReason::TickLimit => f.write_str("tick limit reached"),
            StopReason::Fault(fault) => write!(f, "FAULT: {fault}"),
            StopReason::ControllerPanic(msg) => write!(f, "controller panicked: {msg}"),
        }
    }
}

impl StopReason {
    /// Whether the loop ended as planned (not a fault, panic or emergency stop).
    pub fn is_normal(&self) -> bool {
        matches!(
            self,
            StopReason::Requested
                | StopReason::HandleDropped
                | StopReason::ControllerFinished
                | StopReason::TickLimit
        )
    }

    /// The reason in words, naming joints by their names in `robot`.
    pub fn describe(&self, robot: &Robot) -> String {
        match self {
            StopReason::Fault(fault) => format!("FAULT: {}", fault.describe(robot)),
            other => other.to_string(),
        }
    }
}

/// The final report of a run.
#[derive(Clone, Debug, Serialize)]
pub struct LoopReport {
    /// Why the loop ended.
    #[serde(skip)]
    pub stop_reason: StopReason,
    /// Why the loop ended, in words (joints named).
    #[serde(rename = "stop_reason")]
    pub stop_description: String,
    /// Whether that is a normal end.
    pub normal_stop: bool,
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// Buses.
    pub buses: usize,
    /// Motors.
    pub motors: usize,
    /// Time from the first tick's schedule to the end, seconds.
    pub duration_s: f64,
    /// Statistics.
    #[serde(flatten)]
    pub stats: StatsSummary,
    /// What the safe stop did.
    pub safe_stop: SafeStopReport,
    /// What the operating system granted.
    #[serde(serialize_with = "serialize_display")]
    pub realtime: RtStatus,
    /// Warnings about real-time privileges that were not granted.
    pub realtime_warnings: Vec<String>,
    /// The motors found at start-up and their firmware (empty when the start did not get that
    /// far).
    pub identified: Vec<IdentifiedMotor>,
    /// What turns each motor off if the host dies (its communication watchdog, as described).
    pub protection: Vec<MotorProtection>,
    /// Per bus: whether motor health (status 1, 0x9A) was read in rotation.
    pub health_rotation: Vec<bool>,
    /// Why motor health was not read on a bus, in words, one per such bus.
    pub health_notes: Vec<String>,
    /// The controller's panic, if it panicked: reported once the motors were safe.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub panic: Option<PanicReport>,
}

fn serialize_motor_id<S: serde::Serializer>(id: &MotorId, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u8(id.get())
}

/// A motor found on a bus at start-up, and what its firmware is.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct IdentifiedMotor {
    /// Bus index.
    pub bus: usize,
    /// Its id.
    #[serde(serialize_with = "serialize_motor_id")]
    pub motor: MotorId,
    /// Its joint, if described.
    pub joint: Option<String>,
    /// Its protocol family (`v1.61`, `lk-v2.3x`, `myactuator-v3`, `unknown`).
    #[serde(serialize_with = "serialize_display")]
    pub family: ProtocolFamily,
    /// What decided.
    pub finding: String,
    /// Its firmware's version date, `YYYYMMDDNN` (MyActuator V3's 0xB2; `None` for other
    /// families, or when it did not answer).
    pub firmware_date: Option<u32>,
    /// Its model (MyActuator V3's 0xB5; `None` as for the date).
    pub model: Option<String>,
}

/// A panic of the controller (or of the loop itself), as reported after the safe stop.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct PanicReport {
    /// The panic message.
    pub message: String,
    /// Where it happened (`file:line:column`).
    pub location: Option<String>,
    /// The backtrace, when `RUST_BACKTRACE` asked for one.
    pub backtrace: Option<String>,
}

fn serialize_display<T: fmt::Display, S: serde::Serializer>(
    v: &T,
    s: S,
) -> Result<S::Ok, S::Error> {
    s.collect_str(v)
}

impl LoopReport {
    /// The report as one JSON object.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }

    /// The run's duration.
    pub fn duration(&self) -> Duration {
        Duration::from_secs_f64(self.duration_s.max(0.0))
    }
}

impl fmt::Display for LoopReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "rmd-rt loop report: {} motor(s) on {} bus(es) at {} Hz for {:.3} s",
            self.motors, self.buses, self.rate_hz, self.duration_s
        )?;
        writeln!(f, "stopped: {}", self.stop_description)?;
        writeln!(f, "{}", self.safe_stop)?;
        writeln!(f, "{}", ProtectionLine(&self.protection))?;
        writeln!(f, "real-time: {}", self.realtime)?;
        for w in &self.realtime_warnings {
            writeln!(f, "  warning: {w}")?;
        }
        write!(f, "{}", self.stats)?;
        for note in &self.health_notes {
            writeln!(f, "motor health: {note}")?;
        }
        if let Some(panic) = &self.panic {
            writeln!(
                f,
                "panic: {} at {}",
                panic.message,
                panic.location.as_deref().unwrap_or("an unknown location")
            )?;
            match &panic.backtrace {
                Some(bt) => writeln!(f, "backtrace (resolved after the safe stop):\n{bt}")?,
                None => writeln!(f, "(run with RUST_BACKTRACE=1 for a backtrace)")?,
            }
        }
        Ok(())
    }
}
