//! The wire format of RMD motors: every command and reply of protocol v1.61, LK-TECH V2.3x and
//! MyActuator V3, typed, with units; `no_std`, no allocation. The bottom of rmd-rt: imports
//! nothing.
//!
//! One codec for every family: a [`Dialect`] is a protocol family with what its layouts and
//! scales depend on, and it encodes requests and decodes replies:
//!
//! | | v1.61 | LK-TECH V2.3x | MyActuator V3 |
//! |---|---|---|---|
//! | value | `Dialect::V161` | `Dialect::LkV23x(LkSeries)` | `Dialect::MyActuatorV3(V3Firmware)` |
//! | requests | `0x140 + id` | `0x140 + id` | `0x140 + id` |
//! | replies | `0x140 + id` | `0x140 + id` | `0x240 + id` |
//! | 0x280 | four torque currents ([`MultiTorque`]) | the same, LK scale | one command for every motor ([`Dialect::encode_broadcast`]) |
//! | currents | 32/2000 A (`iqControl`), 33/2048 A (`iq`) | MF 16.5/2048 A, MG 33/2048 A | 0.01 A |
//! | also | | | motion mode on `0x400 + id` / `0x500 + id` ([`MitCommand`]) |
//!
//! - **Encoding** ([`Dialect::encode`], [`Dialect::encode_multi_torque`],
//!   [`Dialect::encode_broadcast`], [`Dialect::encode_mit`]) checks the frame belongs to the
//!   family first: the command is one of its [`commands`](Dialect::commands), every current
//!   ([`ScaledCurrent`], a raw value that carries its [`CurrentScale`]) is in its scale, every
//!   motion-mode value packed with its firmware's [`MitRanges`]. No frame leaves scaled for
//!   another family.
//! - **Decoding** ([`Dialect::decode_reply`], [`Dialect::decode_reply_to`],
//!   [`Dialect::decode_answer`], [`Dialect::decode_mit_reply`], [`Dialect::decode_request`])
//!   reads the family's layouts into one [`Reply`] / [`Request`] type for every family.
//! - **Conversion** between families, exact or nearest, is [`Dialect::convert_reply`].
//!
//! ```
//! use rmd_protocol::{CanFrame, Command, Dialect, IqControl, MotorId, MultiTorque, Request};
//!
//! // A torque request to motor 1: 1.6 A in v1.61.
//! let request = Request::Torque { iq_control: IqControl::from_amps(1.6)?.into() };
//! assert_eq!(Dialect::V161.encode(MotorId::new(1)?, &request)?.to_string(), "141#A100000064000000");
//!
//! // One 0x280 frame for four motors, and the reply of motor 2.
//! let frame = Dialect::V161.encode_multi_torque(&MultiTorque::new([IqControl::saturating(100).into(); 4]))?;
//! assert_eq!(frame.id(), 0x280);
//! let reply = CanFrame::new(0x142, &[0xA1, 35, 0x3E, 0x00, 0x0A, 0x00, 0x00, 0x10])?;
//! let (motor, reply) = Dialect::V161.decode_reply_to(&reply, Command::Torque)?;
//! let status = reply.status2().unwrap();
//! assert_eq!(motor.get(), 2);
//! assert_eq!(status.temperature.celsius(), 35.0);
//! assert_eq!(status.speed.dps(), 10.0);
//! assert!((status.iq.amps() - 62.0 * 33.0 / 2048.0).abs() < 1e-12);
//! # Ok::<(), rmd_protocol::ProtocolError>(())
//! ```
//!
//! # Frames
//!
//! Every frame is a standard 11-bit data frame with DLC 8; multi-byte fields are little-endian
//! (the motion-mode frames are big-endian bit fields). In v1.61 and LK-TECH, requests and
//! replies use the same ID, `0x140 + motor id` (1..=32), so a frame alone does not say its
//! direction: [`Dialect::decode_request`] and [`Dialect::decode_reply`] are chosen by who sent
//! it (or, in a log, by pairing a reply with the preceding request with the same command byte
//! on the same ID). MyActuator V3 replies on `0x240 + id`.
//!
//! # Units
//!
//! One approach everywhere: **raw wire values are validated newtypes; physical values are plain
//! `f64` with unit-suffixed names.** Each field with a range or a unit is a newtype around its
//! wire integer ([`IqControl`], [`SpeedControl`], [`AngleControl`], [`SingleTurnAngle`],
//! [`MaxSpeed`], [`Accel`], [`Iq`], [`Speed`], [`Temperature`], [`Voltage`], [`PhaseCurrent`],
//! [`MotorAngle`], [`CircleAngle`], [`EncoderValue`], and the LK-TECH and V3 ones). `new(raw)`
//! checks the range the spec gives and returns [`ProtocolError::ValueOutOfRange`] naming field,
//! value and range; `saturating(raw)` clamps; `raw()` returns the wire integer. Physical values
//! convert with `amps()`, `degrees()`, `dps()`, `dps_per_s()`, `volts()`, `celsius()` and back
//! with `from_amps(..)` (checked; NaN and infinities are [`ProtocolError::NotFinite`]) or
//! `from_amps_saturating(..)`, rounding half away from zero to the nearest raw step. The scales
//! of v1.61 are the spec's, including the ones that differ on purpose:
//!
//! | field | raw | scale |
//! |---|---|---|
//! | `iqControl` (0xA1, 0x280) | i16, -2000..=2000 | 32/2000 A/LSB (±32 A) |
//! | `iq` (replies) | i16, -2048..=2048 | 33/2048 A/LSB (±33 A) |
//! | `iA`, `iB`, `iC` (0x9D) | i16 | 1/64 A/LSB |
//! | `voltage` | u16 | 0.1 V/LSB |
//! | `temperature` | i8 | 1 °C/LSB |
//! | `speed` (replies) | i16 | 1 dps/LSB |
//! | `speedControl` (0xA2) | i32 | 0.01 dps/LSB |
//! | `maxSpeed` | u16 | 1 dps/LSB |
//! | `Accel` | i32 | 1 dps/s per LSB |
//! | `angleControl` (0xA3, 0xA4) | i32 | 0.01 °/LSB |
//! | `angleControl` (0xA5, 0xA6) | u16, 0..=35999 | 0.01 °/LSB |
//! | `motorAngle` (0x92) | 56-bit signed | 0.01 °/LSB |
//! | `circleAngle` (0x94) | u16, 0..=35999 | 0.01 °/LSB |
//! | encoder values | u16, 0..2^width | one turn = 2^min(width, 16) counts |
//!
//! The currents of the other families are [`CurrentScale`]s; V3's own fields are documented
//! where they are defined, each with the manual section it comes from.
//!
//! # Decoding policy
//!
//! - Decoding never panics, whatever the frame.
//! - Wrong ID, DLC other than 8, a command byte the family does not have, a reply to another
//!   command than the one pending, and values outside the spec's range (in requests and replies
//!   alike: an `iq` of 3000 means a corrupt frame or a different firmware, not something to hand
//!   to a controller) are each a typed [`ProtocolError`].
//! - **Reserved ("NULL") bytes are ignored on decoding and sent as 0 by the encoders**, in
//!   requests and replies alike. Real firmware versions put data in some of them, and the motor
//!   itself ignores them in requests, so rejecting them would drop valid traffic. Consequently a
//!   round trip is exact at the typed level (`decode(encode(x)) == x`), while re-encoding a decoded
//!   frame zeroes its reserved bytes.
//! - Encoder values are not checked on decoding (the motor's encoder width is a per-motor setting
//!   a frame does not carry); see [`EncoderWidth`] and `check_encoder_width`.
//!
//! # Families, identification, models
//!
//! [`ProtocolFamily`] names the families (and `unknown`) with their stable names and says whether
//! a family's 0x280 frame is a per-motor torque frame; [`identify`] tells the family from a
//! motor's answers to two read requests; [`MODELS`] is a table of known motors with sourced
//! values.
//!
//! # Slips in the spec document
//!
//! The v1.61 spec (converted from a PDF) has copy-paste slips; the reading notes give the
//! intended reading, which this crate implements. Each is documented where its field is defined:
//! `Accel` of 0x33/0x34 ([`Accel`]), the 0x9A command byte in the 0x9B reply table
//! ([`Reply::ClearError`], [`Dialect::decode_reply_to`]), the DATA offsets of `angleControl` and
//! `maxSpeed` in 0xA3/0xA4 ([`AngleControl`], [`MaxSpeed`], [`Request::Position2`]), the
//! "int64_t" `motorAngle` sent in 7 bytes ([`MotorAngle`]), and the signed `temperature`
//! ([`Temperature`]). The MyActuator manuals' own slips are noted where they matter ([`MitRanges`],
//! [`Reply::SetWatchdog`]).
#![no_std]

mod bytes;
mod codec;
mod command;
mod convert;
mod current;
mod dialect;
mod encoder;
mod error;
mod family;
mod field;
mod frame;
mod identify;
mod ids;
mod lk;
mod milli;
mod mit;
mod mit_ranges;
mod models;
mod multi;
mod names;
mod reply;
mod request;
mod round;
mod scale;
mod status;
mod status1;
mod v3;
mod values;

pub use command::Command;
pub use convert::Conversion;
pub use current::ScaledCurrent;
pub use dialect::{Dialect, LkSeries};
pub use encoder::{EncoderValue, EncoderWidth};
pub use error::{ExpectedIds, FrameKind, ProtocolError};
pub use family::ProtocolFamily;
pub use field::Field;
pub use frame::{CanFrame, MAX_STANDARD_ID};
pub use identify::{
    Evidence, Finding, Identification, MAX_SUPPLY_VOLTS, MIN_SUPPLY_VOLTS, ProbeAnswers,
    Status1Readings, identify, model_request, probe_requests,
};
pub use ids::{
    FIRST_MOTOR_CAN_ID, LAST_MOTOR_CAN_ID, MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS, MotorId,
    SINGLE_MOTOR_BASE_ID, V3_MOTION_BASE_ID, V3_MOTION_REPLY_BASE_ID, V3_REPLY_BASE_ID,
};
pub use lk::{LkBusCurrent, LkCircleAngle, LkMotorState, LkStatus1, LkVoltage};
pub use mit::{MitCommand, MitFeedback};
pub use mit_ranges::{MitRanges, MotorMaxTorque};
pub use models::{MODELS, MotorModel, Sourced, find_model};
pub use multi::MultiTorque;
pub use names::NameError;
pub use reply::Reply;
pub use request::{DecodedRequest, Request};
pub use scale::CurrentScale;
pub use status::{
    ErrorState, PidParams, SpinDirection, Status2, Status3, StatusPosition, V161Status1,
};
pub use status1::Status1;
pub use v3::{
    BrakeState, FirmwareDate, FunctionControl, MaxTorquePercent, ModelIndex, ModelPart, ModelText,
    OutputAngle, V3CircleAngle, V3ErrorState, V3Firmware, V3Function, V3Revision, V3Status1,
    WatchdogTimeout,
};
pub use values::{
    Accel, AngleControl, CircleAngle, Iq, IqControl, MaxSpeed, MotorAngle, PhaseCurrent,
    SingleTurnAngle, Speed, SpeedControl, Temperature, Voltage,
};
