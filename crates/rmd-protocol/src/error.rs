//! The one error type of the protocol layer: `Copy`, allocation-free, says exactly what was wrong.

use core::fmt;

use crate::command::Command;
use crate::family::ProtocolFamily;
use crate::field::Field;
use crate::milli::Milli;
use crate::mit_ranges::MitRanges;
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
    /// DATA\[0\] is not a command byte of the protocol (as rmd-rt implements it).
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
    /// A physical value outside the range of its field (given in thousandths: milli-rad,
    /// milli-N·m, ...).
    #[error(
        "{field} {} is out of range {}..={}",
        Milli(*value_milli),
        Milli(*min_milli),
        Milli(*max_milli)
    )]
    OutOfRangeMilli {
        /// Which field.
        field: Field,
        /// The value given, in thousandths of its unit (rounded).
        value_milli: i64,
        /// The smallest allowed value, in thousandths.
        min_milli: i64,
        /// The largest allowed value, in thousandths.
        max_milli: i64,
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
    /// A request of a command the protocol family does not have (or rmd-rt does not implement
    /// for it): e.g. v1.61's 0x9B clear-error to a MyActuator V3 motor, V3's 0xB2 to a v1.61
    /// motor.
    #[error(
        "{command} (0x{code:02X}) is not a command of protocol {family} as rmd-rt speaks it",
        code = command.code()
    )]
    UnsupportedCommand {
        /// The command.
        command: Command,
        /// The family the frame was for.
        family: ProtocolFamily,
    },
    /// A kind of frame the protocol family does not have: the 0x280 torque frame on MyActuator
    /// V3 (where 0x280 carries one command for every motor), a V3 broadcast or motion-mode
    /// frame on v1.61 or LK-TECH.
    #[error("{kind} is not part of protocol {family}")]
    UnsupportedFrame {
        /// The kind of frame.
        kind: FrameKind,
        /// The family the frame was for.
        family: ProtocolFamily,
    },
    /// A field another family has, given a value here (e.g. V3's `maxTorque` of 0xA2 to a
    /// v1.61 motor, where DATA\[1\] is reserved).
    #[error("{field} is not a field of protocol {family}: leave it unset")]
    UnsupportedField {
        /// The field.
        field: Field,
        /// The family the frame was for.
        family: ProtocolFamily,
    },
    /// A motion-mode (MIT) value scaled with other ranges than the firmware's: the ranges of
    /// V4.3 and V4.4 firmware differ (kd, t_ff, p_des), and a value packed for one reads as
    /// another on the other (a t_ff for ±24 N·m reads 2.5 times larger on ±60 N·m).
    #[error(
        "the motion-mode value was scaled for {got}, but this motor's firmware uses {expected}: \
         scale it with the motor's own ranges"
    )]
    MitRangesMismatch {
        /// The ranges the dialect uses.
        expected: MitRanges,
        /// The ranges of the value given.
        got: MitRanges,
    },
    /// V4.4 firmware scales the motion-mode torque by the motor's maximum torque, which is not
    /// known.
    #[error(
        "MyActuator V3 firmware of protocol V4.4 scales the motion-mode torque by the motor's \
         maximum torque: give it (the motor model's value, or set it)"
    )]
    MissingMaxTorque,
    /// A reply that another family can carry only with a loss, asked for exactly.
    #[error(
        "a {command} reply of protocol {from} has no exact form in protocol {to}: use the \
         nearest form, or keep it in {from}"
    )]
    NotRepresentable {
        /// The reply's command.
        command: Command,
        /// The family it was decoded in.
        from: ProtocolFamily,
        /// The family asked for.
        to: ProtocolFamily,
    },
    /// A motion-mode reply on `0x500 + id` whose DATA\[0\] names another motor.
    #[error("CAN ID 0x{can_id:03X}: DATA[0] names motor {data_id}, not the sender")]
    MotorIdMismatch {
        /// Identifier of the offending frame.
        can_id: u16,
        /// The motor id in DATA\[0\].
        data_id: u8,
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
    /// A MyActuator V3 request identifier: 0x141..=0x160, 0x280 or 0x401..=0x420.
    MyActuatorV3Request,
    /// A MyActuator V3 motion-mode reply identifier, 0x501..=0x520 (`0x500 + id`).
    MyActuatorV3MotionReply,
    /// The reply identifier of the motor asked.
    ReplyOf(u16),
}

impl fmt::Display for ExpectedIds {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let ExpectedIds::ReplyOf(id) = self {
            return write!(f, "reply of the motor asked (0x{id:03X})");
        }
        f.write_str(match self {
            ExpectedIds::Motor => "motor ID (0x141..=0x160)",
            ExpectedIds::MotorOrMultiTorque => "ID (0x141..=0x160 or 0x280)",
            ExpectedIds::MyActuatorV3Reply => "MyActuator V3 reply ID (0x241..=0x260)",
            ExpectedIds::MyActuatorV3Request => {
                "MyActuator V3 request ID (0x141..=0x160, 0x280 or 0x401..=0x420)"
            }
            ExpectedIds::MyActuatorV3MotionReply => {
                "MyActuator V3 motion-mode reply ID (0x501..=0x520)"
            }
            ExpectedIds::ReplyOf(_) => "reply of the motor asked",
        })
    }
}

/// A kind of frame that is not a single-motor request or reply, in
/// [`ProtocolError::UnsupportedFrame`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum FrameKind {
    /// The v1.61 / LK-TECH 0x280 frame of four torque currents.
    MultiTorque,
    /// A MyActuator V3 0x280 frame: one command for every motor.
    Broadcast,
    /// A MyActuator V3 motion-mode (MIT) frame on `0x400 + id` / `0x500 + id`.
    Motion,
}

impl fmt::Display for FrameKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FrameKind::MultiTorque => "the 0x280 frame of four torque currents",
            FrameKind::Broadcast => "the 0x280 frame of one command for every motor",
            FrameKind::Motion => "the motion-mode (MIT) frame on 0x400 + id",
        })
    }
}
