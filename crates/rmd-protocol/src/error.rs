//! The one error type of the protocol layer: `Copy`, allocation-free, says exactly what was wrong.

use core::fmt;

use crate::command::Command;
use crate::scale::CurrentScale;

/// Everything that can be wrong with a frame or a value of the RMD protocol.
///
/// Every variant names what was wrong and the values involved, so that its `Display` text is a
/// complete one-line diagnosis (the CLI prints it as is).
///
/// ```
/// use rmd_protocol::{IqControl, ProtocolError, Field};
/// let err = IqControl::new(2500).unwrap_err();
/// assert_eq!(
///     err,
///     ProtocolError::ValueOutOfRange { field: Field::IqControl, value: 2500, min: -2000, max: 2000 }
/// );
/// assert_eq!(err.to_string(), "iq_control 2500 is out of range -2000..=2000");
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ProtocolError {
    /// The identifier does not fit in a standard 11-bit CAN ID.
    #[error("CAN ID 0x{can_id:X} is not a standard 11-bit identifier")]
    InvalidCanId {
        /// The identifier as given.
        can_id: u32,
    },
    /// The frame does not carry the 8 data bytes every RMD frame has.
    #[error("CAN ID 0x{can_id:03X}: DLC {dlc}, every RMD frame has DLC 8")]
    WrongDlc {
        /// Identifier of the offending frame.
        can_id: u16,
        /// Its data length code.
        dlc: u8,
    },
    /// The identifier is not one the RMD protocol uses where it was found.
    #[error("CAN ID 0x{can_id:03X} is not an RMD {expected}")]
    UnexpectedCanId {
        /// Identifier of the offending frame.
        can_id: u16,
        /// Which identifiers were acceptable.
        expected: ExpectedIds,
    },
    /// DATA\[0\] is not one of the 23 command bytes of the protocol.
    #[error("CAN ID 0x{can_id:03X}: unknown command byte 0x{code:02X}")]
    UnknownCommand {
        /// Identifier of the offending frame.
        can_id: u16,
        /// The command byte found in DATA\[0\].
        code: u8,
    },
    /// A reply that does not answer the request that is waiting for one.
    #[error(
        "CAN ID 0x{can_id:03X}: reply {got} (0x{got_code:02X}) does not match the pending request \
         {expected} (0x{expected_code:02X})",
        got_code = got.code(),
        expected_code = expected.code()
    )]
    ReplyMismatch {
        /// Identifier of the offending frame.
        can_id: u16,
        /// The command of the pending request.
        expected: Command,
        /// The command byte the reply carries.
        got: Command,
    },
    /// A raw value outside the range the protocol allows for its field.
    #[error("{field} {value} is out of range {min}..={max}")]
    ValueOutOfRange {
        /// Which field.
        field: Field,
        /// The value given (raw wire units, after rounding for physical inputs).
        value: i64,
        /// Smallest allowed raw value.
        min: i64,
        /// Largest allowed raw value.
        max: i64,
    },
    /// A physical value that is NaN or infinite.
    #[error("{field} must be a finite number")]
    NotFinite {
        /// Which field.
        field: Field,
    },
    /// A motor id outside 1..=32.
    #[error("invalid motor id {id}: must be 1..=32")]
    InvalidMotorId {
        /// The id as given.
        id: u8,
    },
    /// A current value built for another scale than the one the dialect uses for this field
    /// (e.g. a v1.61 `iqControl` sent to an LK-TECH MF motor).
    #[error(
        "{field} uses the scale {got}, but this dialect expects {expected}: convert the current in amperes with the dialect's scale"
    )]
    ScaleMismatch {
        /// The field.
        field: Field,
        /// The scale the dialect uses.
        expected: CurrentScale,
        /// The scale of the value given.
        got: CurrentScale,
    },
}

/// Which CAN identifiers were acceptable, in [`ProtocolError::UnexpectedCanId`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ExpectedIds {
    /// A single-motor identifier, 0x141..=0x160 (replies, single-motor requests, [`MotorId`](crate::MotorId)).
    Motor,
    /// A single-motor identifier or the multi-motor torque identifier 0x280 (requests).
    MotorOrMultiTorque,
    /// A MyActuator V3 reply identifier, 0x241..=0x260 (`0x240 + id`).
    MyActuatorV3Reply,
}

impl fmt::Display for ExpectedIds {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ExpectedIds::Motor => "motor ID (0x141..=0x160)",
            ExpectedIds::MotorOrMultiTorque => "ID (0x141..=0x160 or 0x280)",
            ExpectedIds::MyActuatorV3Reply => "MyActuator V3 reply ID (0x241..=0x260)",
        })
    }
}

/// A field of the protocol, named in errors after the spec's variable (in snake_case).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Field {
    /// `iqControl` of 0xA1 and 0x280.
    IqControl,
    /// `speedControl` of 0xA2.
    SpeedControl,
    /// `angleControl` of 0xA3 / 0xA4 (multi-turn, i32).
    AngleControl,
    /// `angleControl` of 0xA5 / 0xA6 (single-turn, 0..=35999).
    SingleTurnAngleControl,
    /// `maxSpeed` of 0xA4 / 0xA6.
    MaxSpeed,
    /// `spinDirection` of 0xA5 / 0xA6.
    SpinDirection,
    /// `Accel` of 0x33 / 0x34.
    Accel,
    /// An encoder value (`encoder`, `encoderRaw`, `encoderOffset`), checked against the width.
    EncoderValue,
    /// An encoder width in bits.
    EncoderWidth,
    /// `iq`, the torque current in replies.
    Iq,
    /// `speed`, the speed in replies.
    Speed,
    /// `temperature`.
    Temperature,
    /// `voltage`.
    Voltage,
    /// A phase current (`iA`, `iB`, `iC`).
    PhaseCurrent,
    /// `motorAngle` of the 0x92 reply.
    MotorAngle,
    /// `circleAngle` of the 0x94 reply.
    CircleAngle,
    /// `current`, the bus current of LK-TECH's 0x9A reply.
    BusCurrent,
}

impl Field {
    /// The field's name as used in messages and in the CLI's JSON (snake_case spec name).
    pub const fn name(self) -> &'static str {
        match self {
            Field::IqControl => "iq_control",
            Field::SpeedControl => "speed_control",
            Field::AngleControl | Field::SingleTurnAngleControl => "angle_control",
            Field::MaxSpeed => "max_speed",
            Field::SpinDirection => "spin_direction",
            Field::Accel => "accel",
            Field::EncoderValue => "encoder value",
            Field::EncoderWidth => "encoder width (bits)",
            Field::Iq => "iq",
            Field::Speed => "speed",
            Field::Temperature => "temperature",
            Field::Voltage => "voltage",
            Field::PhaseCurrent => "phase current",
            Field::MotorAngle => "motor_angle",
            Field::CircleAngle => "circle_angle",
            Field::BusCurrent => "bus_current",
        }
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is not one of the stable names rmd-rt accepts (protocol families, dialects, LK
/// motor series, motor models). `Copy` and allocation-free: the text lists the accepted names.
///
/// ```
/// use rmd_protocol::{NameError, ProtocolFamily};
/// let err = "v2".parse::<ProtocolFamily>().unwrap_err();
/// assert_eq!(err, NameError::Family);
/// assert_eq!(
///     err.to_string(),
///     "unknown protocol family: expected one of v1.61, lk-v2.3x, myactuator-v3, unknown"
/// );
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum NameError {
    /// Not a protocol family name.
    #[error("unknown protocol family: expected one of v1.61, lk-v2.3x, myactuator-v3, unknown")]
    Family,
    /// Not a dialect rmd-rt can speak.
    #[error("unknown protocol: expected v1.61 or lk-v2.3x")]
    Dialect,
    /// Not an LK-TECH motor series with a known current scale.
    #[error("unknown LK-TECH motor series: expected mf or mg")]
    LkSeries,
    /// `lk-v2.3x` without the motor series its current scale depends on.
    #[error(
        "protocol lk-v2.3x needs the LK-TECH motor series (mf or mg): its current scale depends on it"
    )]
    MissingLkSeries,
    /// Not a motor model of the table.
    #[error("unknown motor model: see rmd_protocol::models::MODELS for the known names")]
    Model,
}
