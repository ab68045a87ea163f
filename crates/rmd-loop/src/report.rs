//! Why the loop stopped, what it did to make the motors safe, and the final report.

use core::fmt;
use core::time::Duration;

use rmd_bus::BusError;
use rmd_protocol::MotorId;
use serde::Serialize;

use crate::os::RtStatus;
use crate::stats::StatsSummary;

/// A condition that stops the loop and makes every motor safe.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Fault {
    /// A motor gave no fresh feedback for `ticks` consecutive ticks.
    MotorSilent {
        /// Bus index.
        bus: usize,
        /// Motor id.
        motor: MotorId,
        /// Consecutive ticks without fresh feedback.
        ticks: u32,
    },
    /// Not every motor answered during the start-up ticks.
    StartupTimeout {
        /// Bus of the first motor that never answered.
        bus: usize,
        /// The first motor that never answered.
        motor: MotorId,
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
        /// Bus index.
        bus: usize,
        /// Motor id.
        motor: MotorId,
        /// The reported temperature.
        celsius: f64,
    },
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Fault::MotorSilent { bus, motor, ticks } => write!(
                f,
                "motor {} on bus {bus} gave no feedback for {ticks} consecutive ticks (check its power, wiring and id)",
                motor.get()
            ),
            Fault::StartupTimeout {
                bus,
                motor,
                missing,
            } => write!(
                f,
                "{missing} motor(s) never answered at start, first: motor {} on bus {bus} (check power, id and bit rate)",
                motor.get()
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
            Fault::OverTemperature {
                bus,
                motor,
                celsius,
            } => write!(
                f,
                "motor {} on bus {bus} reports {celsius} degC, at or above its limit",
                motor.get()
            ),
        }
    }
}

/// Why the loop ended.
#[derive(Clone, Debug, PartialEq)]
pub enum StopReason {
    /// [`LoopHandle::stop`](crate::LoopHandle::stop) was called.
    Requested,
    /// [`LoopHandle::emergency_stop`](crate::LoopHandle::emergency_stop) was called.
    EmergencyStop,
    /// The [`LoopHandle`](crate::LoopHandle) was dropped while the loop ran.
    HandleDropped,
    /// The controller returned [`Flow::Stop`](crate::Flow::Stop).
    ControllerFinished,
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
}

/// What the safe stop did for one motor.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
pub struct MotorSafeStop {
    /// Bus index.
    pub bus: usize,
    /// Motor id.
    #[serde(serialize_with = "serialize_motor_id")]
    pub motor: MotorId,
    /// A zero-torque 0x280 frame was queued on its bus.
    pub zero_torque_sent: bool,
    /// A motor-off (0x80) command was queued.
    pub off_sent: bool,
    /// The motor answered the motor-off command.
    pub off_confirmed: bool,
}

fn serialize_motor_id<S: serde::Serializer>(id: &MotorId, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u8(id.get())
}

/// The outcome of the safe-stop sequence (zero torque, then motor off, to every motor).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SafeStopReport {
    /// Per motor.
    pub motors: Vec<MotorSafeStop>,
}

impl SafeStopReport {
    /// Whether every motor confirmed motor-off.
    pub fn all_off_confirmed(&self) -> bool {
        self.motors.iter().all(|m| m.off_confirmed)
    }
}

impl fmt::Display for SafeStopReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let confirmed = self.motors.iter().filter(|m| m.off_confirmed).count();
        write!(
            f,
            "safe stop: zero torque then motor off; {confirmed}/{} motors confirmed off",
            self.motors.len()
        )?;
        for m in self.motors.iter().filter(|m| !m.off_confirmed) {
            write!(
                f,
                "; motor {} on bus {}: {}",
                m.motor.get(),
                m.bus,
                if !m.zero_torque_sent {
                    "could not send zero torque"
                } else if !m.off_sent {
                    "zero torque sent, could not send motor-off"
                } else {
                    "zero torque and motor-off sent, no answer"
                }
            )?;
        }
        Ok(())
    }
}

/// The final report of a run.
#[derive(Clone, Debug, Serialize)]
pub struct LoopReport {
    /// Why the loop ended.
    #[serde(serialize_with = "serialize_display")]
    pub stop_reason: StopReason,
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
        writeln!(f, "stopped: {}", self.stop_reason)?;
        writeln!(f, "{}", self.safe_stop)?;
        writeln!(f, "real-time: {}", self.realtime)?;
        for w in &self.realtime_warnings {
            writeln!(f, "  warning: {w}")?;
        }
        write!(f, "{}", self.stats)
    }
}
