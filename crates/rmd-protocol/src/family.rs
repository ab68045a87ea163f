//! Protocol families: which firmware a motor runs, as far as the bus can tell.

use core::fmt;
use core::str::FromStr;

use crate::names::NameError;

/// Protocol families: which firmware a motor runs, as far as the bus can tell.
///
/// Motors sold as "RMD" or under the LK-TECH name run one of three firmware families that share
/// command bytes but not layouts, scales or identifiers. The differences that matter before any
/// torque is sent:
///
/// | family | requests | replies | 0x280 frame | source |
/// |---|---|---|---|---|
/// | [`V161`](ProtocolFamily::V161) (GYEMS / MyActuator RMD v1.61, v1.62) | `0x140 + id` | `0x140 + id` | four `iqControl` values: per-motor torque for ids 1..=4 | gyems-can-v1.61, "multi motor torque closed loop control" |
/// | [`LkV23x`](ProtocolFamily::LkV23x) (LK-TECH MF/MG/MS, protocol V2.3x) | `0x140 + id` | `0x140 + id` | four `iqControl` values (LK scale): per-motor torque for ids 1..=4 | drivers of LK-built motors, e.g. github.com/Jason0-0/logging_car_pro_plus `Core/Bsp/RMD_L_Motor/RMD_protocol.h` (0x280, replies 0xA1 on 0x141..0x144, "-2048~2048 -> -33A~33A"); the LK V2.35 document's multi-motor section was not available as text |
/// | [`MyActuatorV3`](ProtocolFamily::MyActuatorV3) (RMD-X V3, protocol V3.x / V4.x) | `0x140 + id` | **`0x240 + id`** | **a command byte in DATA\[0\], executed by every motor on the bus** (`280#80..` = all motors off) | MyActuator "Servo Motor Control Protocol" V4.3 (applicable driver V3), §1.1.2 and §3; github.com/2b-t/myactuator_rmd `include/myactuator_rmd/driver/can_address_offset.hpp` (request 0x140, response 0x240) |
///
/// rmd-rt's control loop drives motors with 0x280 frames, so it must know a motor's family before
/// its first torque frame: see [`ProtocolFamily::multi_torque_is_per_motor_torque`] and the
/// [`identify`](crate::identify()) module for how the family is told from a motor's answers.
///
/// The firmware family a motor speaks, with the stable names rmd-rt uses in its CLI and JSON.
///
/// ```
/// use rmd_protocol::ProtocolFamily;
/// assert_eq!(ProtocolFamily::MyActuatorV3.name(), "myactuator-v3");
/// assert_eq!("lk-v2.3x".parse(), Ok(ProtocolFamily::LkV23x));
/// assert!(ProtocolFamily::V161.multi_torque_is_per_motor_torque());
/// assert!(!ProtocolFamily::MyActuatorV3.multi_torque_is_per_motor_torque());
/// assert!(!ProtocolFamily::Unknown.multi_torque_is_per_motor_torque());
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ProtocolFamily {
    /// GYEMS / MyActuator RMD protocol v1.61 (and v1.62, which the bus cannot tell apart from
    /// it): replies on `0x140 + id`, status 1 with the voltage in DATA\[3..=4\] at 0.1 V.
    #[default]
    V161,
    /// LK-TECH protocol V2.3x (MF / MG / MS motors and LK-built RMD motors): replies on
    /// `0x140 + id`, status 1 with the voltage in DATA\[2..=3\] at 0.01 V, current scales that
    /// depend on the motor series (see [`Dialect`](crate::Dialect)).
    LkV23x,
    /// MyActuator firmware "V3" (RMD-X V3, protocol V3.x / V4.x): replies on `0x240 + id`, 0.01 A
    /// per LSB, and a 0x280 frame that is a command byte for every motor on the bus.
    MyActuatorV3,
    /// None of the above, or not enough evidence to tell (no answer, contradictory answers).
    Unknown,
}

impl ProtocolFamily {
    /// Every family, in a fixed order.
    pub const ALL: [Self; 4] = [Self::V161, Self::LkV23x, Self::MyActuatorV3, Self::Unknown];

    /// The stable name: `v1.61`, `lk-v2.3x`, `myactuator-v3` or `unknown`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::V161 => "v1.61",
            Self::LkV23x => "lk-v2.3x",
            Self::MyActuatorV3 => "myactuator-v3",
            Self::Unknown => "unknown",
        }
    }

    /// The family named `name` (as [`name`](Self::name) returns it), else [`NameError::Family`].
    pub fn from_name(name: &str) -> Result<Self, NameError> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or(NameError::Family)
    }

    /// Whether a 0x280 frame means "one torque current per motor, motors 1..=4" to this family.
    ///
    /// `true` for v1.61 (gyems-can-v1.61, multi-motor torque command) and LK-TECH V2.3x (as LK
    /// drivers use it; see the table above). `false` for MyActuator V3, where DATA\[0\]
    /// of a 0x280 frame is a command byte executed by every motor on the bus (MyActuator Servo
    /// Motor Control Protocol V4.3, §3: "Sending to ID 0x280 addresses all motors on the bus
    /// simultaneously with the same command"; its example `280#80..` shuts every motor down), and
    /// `false` for an unknown family, whose meaning of 0x280 is not known. A control loop must
    /// not send 0x280 torque frames on a bus with a motor for which this is `false`.
    pub const fn multi_torque_is_per_motor_torque(self) -> bool {
        matches!(self, Self::V161 | Self::LkV23x)
    }

    /// Base of the identifiers this family's motors reply on: 0x140 (v1.61, LK-TECH) or 0x240
    /// (MyActuator V3); `None` for an unknown family.
    pub const fn reply_base_id(self) -> Option<u16> {
        match self {
            Self::V161 | Self::LkV23x => Some(0x140),
            Self::MyActuatorV3 => Some(0x240),
            Self::Unknown => None,
        }
    }
}

impl fmt::Display for ProtocolFamily {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ProtocolFamily {
    type Err = NameError;
    fn from_str(s: &str) -> Result<Self, NameError> {
        Self::from_name(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_are_stable() {
        let names: [&str; 4] = ProtocolFamily::ALL.map(ProtocolFamily::name);
        assert_eq!(names, ["v1.61", "lk-v2.3x", "myactuator-v3", "unknown"]);
        for f in ProtocolFamily::ALL {
            assert_eq!(ProtocolFamily::from_name(f.name()), Ok(f));
        }
        assert_eq!(ProtocolFamily::from_name("V1.61"), Err(NameError::Family));
        assert_eq!(ProtocolFamily::from_name(""), Err(NameError::Family));
    }
}
