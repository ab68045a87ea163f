//! Whether each motor stops by itself when the host goes silent: its communication watchdog
//! (MyActuator V3's 0xB3, kept in the motor's ROM). Software on the host cannot help after a
//! SIGKILL, a kernel hang or a power loss; only such a watchdog does. The firmware cannot report
//! its value (0xB3 is write-only), so a motor counts as protected when the robot description
//! says its watchdog is set (`watchdog_ms`, written by `rmd watchdog --robot FILE`).

use core::fmt;

use rmd_protocol::{MotorId, ProtocolFamily};
use serde::Serialize;

use crate::robot::Robot;

/// What protects one motor when the host goes silent.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Protection {
    /// Its communication watchdog is set to `millis`, as the description says (not read back:
    /// the firmware cannot report it).
    Watchdog {
        /// The timeout, milliseconds.
        millis: u32,
    },
    /// A MyActuator V3 motor whose description says its watchdog is off, or says nothing.
    WatchdogOff,
    /// Its family has no watchdog (v1.61, LK-TECH).
    NoWatchdog,
}

/// One motor's protection when the host goes silent.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct MotorProtection {
    /// The joint's name.
    pub joint: String,
    /// Its bus (index).
    pub bus: usize,
    /// Its motor id.
    #[serde(serialize_with = "serialize_motor_id")]
    pub motor: MotorId,
    /// What protects it.
    pub protection: Protection,
}

fn serialize_motor_id<S: serde::Serializer>(id: &MotorId, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u8(id.get())
}

impl MotorProtection {
    /// Whether the motor turns itself off when the host goes silent.
    pub fn protected(&self) -> bool {
        matches!(self.protection, Protection::Watchdog { .. })
    }

    /// Every joint's protection, as `robot` describes it.
    pub fn of(robot: &Robot) -> Vec<MotorProtection> {
        robot
            .joints()
            .iter()
            .map(|spec| MotorProtection {
                joint: spec.name.clone(),
                bus: spec.bus,
                motor: spec.motor,
                protection: match (spec.dialect.family(), spec.watchdog) {
                    (ProtocolFamily::MyActuatorV3, Some(w)) if !w.is_off() => {
                        Protection::Watchdog { millis: w.millis() }
                    }
                    (ProtocolFamily::MyActuatorV3, _) => Protection::WatchdogOff,
                    (
                        ProtocolFamily::V161 | ProtocolFamily::LkV23x | ProtocolFamily::Unknown,
                        _,
                    ) => Protection::NoWatchdog,
                },
            })
            .collect()
    }
}

/// The report's line: how many motors stop by themselves when the host goes silent, and what to
/// do about the others.
pub(crate) struct ProtectionLine<'a>(pub(crate) &'a [MotorProtection]);

impl fmt::Display for ProtectionLine<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let all = self.0;
        let protected: Vec<String> = all
            .iter()
            .filter_map(|m| match m.protection {
                Protection::Watchdog { millis } => Some(format!("{} {millis} ms", m.joint)),
                Protection::WatchdogOff | Protection::NoWatchdog => None,
            })
            .collect();
        write!(
            f,
            "motor watchdog: {}/{} motors turn off by themselves if the host dies",
            protected.len(),
            all.len()
        )?;
        if !protected.is_empty() {
            write!(
                f,
                " ({}; as described: the firmware cannot report it)",
                protected.join(", ")
            )?;
        }
        let off: Vec<&str> = all
            .iter()
            .filter(|m| m.protection == Protection::WatchdogOff)
            .map(|m| m.joint.as_str())
            .collect();
        if !off.is_empty() {
            write!(
                f,
                "; not set: {} (describe `watchdog_ms`, then `rmd watchdog --robot FILE`)",
                off.join(", ")
            )?;
        }
        let none = all
            .iter()
            .filter(|m| m.protection == Protection::NoWatchdog)
            .count();
        if none > 0 {
            write!(
                f,
                "; v1.61 and LK-TECH motors have none ({none} here: see docs/safety.md)"
            )?;
        }
        Ok(())
    }
}
