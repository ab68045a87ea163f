//! The wire format of RMD motors: every command and reply of protocol v1.61 (and the LK-TECH
//! dialect), typed, with units; `no_std`, no allocation. The bottom of rmd-rt: imports nothing.
//!
//! A typed, allocation-free model of every command and reply.
//!
//! # Frames
//!
//! Every frame is a standard 11-bit data frame with DLC 8; multi-byte fields are little-endian.
//! Host→motor requests and motor→host replies use the same ID, `0x140 + motor id` (1..=32), so
//! a frame alone does not say its direction: [`decode_request`] and [`decode_reply`] are chosen by
//! who sent it (or, in a log, by pairing a reply with the preceding request with the same
//! command byte on the same ID). The 0x280 [`MultiTorque`] frame drives motors 1..=4 at once;
//! they answer with [`Reply::Torque`] on 0x141..=0x144.
//!
//! ```
//! use rmd_protocol::{decode_reply_to, Command, IqControl, MotorId, MultiTorque, Request};
//!
//! // A torque request to motor 1: 1.6 A.
//! let request = Request::Torque { iq_control: IqControl::from_amps(1.6)? };
//! assert_eq!(request.encode(MotorId::new(1)?).to_string(), "141#A100000064000000");
//!
//! // One 0x280 frame for four motors, and the reply of motor 2.
//! let frame = MultiTorque::new([IqControl::saturating(100); 4]).encode();
//! assert_eq!(frame.id(), 0x280);
//! let reply = rmd_protocol::CanFrame::new(0x142, &[0xA1, 35, 0x3E, 0x00, 0x0A, 0x00, 0x00, 0x10])?;
//! let (motor, reply) = decode_reply_to(&reply, Command::Torque)?;
//! let status = reply.status2().unwrap();
//! assert_eq!(motor.get(), 2);
//! assert_eq!(status.temperature.celsius(), 35.0);
//! assert_eq!(status.speed.dps(), 10.0);
//! assert!((status.iq.amps() - 62.0 * 33.0 / 2048.0).abs() < 1e-12);
//! # Ok::<(), rmd_protocol::ProtocolError>(())
//! ```
//!
//! # Units
//!
//! One approach everywhere: **raw wire values are validated newtypes; physical values are plain
//! `f64` with unit-suffixed names.** Each field with a range or a unit is a newtype around its
//! wire integer ([`IqControl`], [`SpeedControl`], [`AngleControl`], [`SingleTurnAngle`],
//! [`MaxSpeed`], [`Accel`], [`Iq`], [`Speed`], [`Temperature`], [`Voltage`], [`PhaseCurrent`],
//! [`MotorAngle`], [`CircleAngle`], [`EncoderValue`]). `new(raw)` checks the range the spec gives
//! and returns [`ProtocolError::ValueOutOfRange`] naming field, value and range; `saturating(raw)`
//! clamps; `raw()` returns the wire integer. Physical values convert with `amps()`, `degrees()`,
//! `dps()`, `dps_per_s()`, `volts()`, `celsius()` and back with `from_amps(..)` (checked; NaN and
//! infinities are [`ProtocolError::NotFinite`]) or `from_amps_saturating(..)`, rounding half away
//! from zero to the nearest raw step. The scales are the spec's, including the ones that differ
//! on purpose:
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
//! # Decoding policy
//!
//! - Decoding never panics, whatever the frame.
//! - Wrong ID, DLC other than 8, unknown command byte, a reply to another command than the one
//!   pending, and values outside the spec's range (in requests and replies alike: an `iq` of 3000
//!   means a corrupt frame or a different firmware, not something to hand to a controller) are
//!   each a typed [`ProtocolError`].
//! - **Reserved ("NULL") bytes are ignored on decoding and sent as 0 by the encoders**, in
//!   requests and replies alike. Real firmware versions put data in some of them, and the motor
//!   itself ignores them in requests, so rejecting them would drop valid traffic. Consequently a
//!   round trip is exact at the typed level (`decode(encode(x)) == x`), while re-encoding a decoded
//!   frame zeroes its reserved bytes.
//! - Encoder values are not checked on decoding (the motor's encoder width is a per-motor setting
//!   a frame does not carry); see the [`encoder`] module and `check_encoder_width`.
//!
//! # Other firmware: families, dialects, models
//!
//! Not every "RMD" motor speaks v1.61. [`ProtocolFamily`] names the families rmd-rt knows
//! (v1.61, LK-TECH V2.3x, MyActuator V3) and says whether a family's 0x280 frame is a per-motor
//! torque frame; [`identify`](mod@identify) tells the family from a motor's answers to two read
//! requests. [`Dialect`] is what rmd-rt can drive (v1.61, the default, and LK-TECH V2.3x with its
//! motor series), with [`decode_reply_with`], [`decode_request_with`] and [`DialectRequest`]
//! for the layouts and current scales ([`CurrentScale`], [`ScaledCurrent`]) that differ.
//! [`models`] is a table of known motors with sourced values; [`v3`] the few MyActuator V3 frames
//! needed to recognise (and simulate) that firmware. The v1.61 functions above are unchanged.
//!
//! # Slips in the spec document
//!
//! The spec (v1.61, converted from a PDF) has copy-paste slips; the reading notes give the
//! intended reading, which this crate implements. Each is documented where its field is defined:
//! `Accel` of 0x33/0x34 ([`Accel`]), the 0x9A command byte in the 0x9B reply table
//! ([`Reply::ClearError`], [`decode_reply_to`]), the DATA offsets of `angleControl` and `maxSpeed`
//! in 0xA3/0xA4 ([`AngleControl`], [`MaxSpeed`], [`Request::Position2`]), the "int64_t"
//! `motorAngle` sent in 7 bytes ([`MotorAngle`]), and the signed `temperature` ([`Temperature`]).
#![no_std]

pub mod command;
pub mod decode;
pub mod dialect;
pub mod dialect_frames;
pub mod encoder;
pub mod error;
pub mod family;
pub mod frame;
pub mod identify;
pub mod ids;
pub mod lk;
pub mod models;
pub mod multi;
pub mod reply;
pub mod request;
mod round;
pub mod scale;
pub mod status;
pub mod v3;
pub mod values;
mod wire;

pub use command::Command;
pub use decode::{DecodedRequest, decode_reply, decode_reply_to, decode_request};
pub use dialect::{Dialect, LkSeries};
pub use dialect_frames::{
    DialectReply, DialectRequest, DialectStatus1, ScaledMultiTorque, ScaledStatus2,
    decode_reply_to_with, decode_reply_with, decode_request_with, encode_request_with,
};
pub use encoder::{EncoderValue, EncoderWidth};
pub use error::{ExpectedIds, Field, NameError, ProtocolError};
pub use family::ProtocolFamily;
pub use frame::CanFrame;
pub use identify::{Identification, ProbeAnswers, identify};
pub use ids::{
    FIRST_MOTOR_CAN_ID, LAST_MOTOR_CAN_ID, MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS, MotorId,
    SINGLE_MOTOR_BASE_ID,
};
pub use lk::{LkBusCurrent, LkCircleAngle, LkMotorState, LkStatus1, LkVoltage};
pub use models::{MotorModel, Sourced, find_model};
pub use multi::MultiTorque;
pub use reply::Reply;
pub use request::Request;
pub use scale::{CurrentScale, ScaledCurrent};
pub use status::{ErrorState, PidParams, SpinDirection, Status1, Status2, Status3};
pub use values::{
    Accel, AngleControl, CircleAngle, Iq, IqControl, MaxSpeed, MotorAngle, PhaseCurrent,
    SingleTurnAngle, Speed, SpeedControl, Temperature, Voltage,
};
