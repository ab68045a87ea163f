//! Encoding and decoding in a [`Dialect`]: the requests and replies whose layout or scale
//! differs between dialects, and the v1.61 types for everything else.
//!
//! The v1.61 functions ([`decode_reply`](crate::decode_reply),
//! [`decode_request`](crate::decode_request), ...) are unchanged; the `_with` functions here take
//! the dialect. What differs, and where the LK-TECH facts come from:
//!
//! | command | v1.61 | LK-TECH V2.3x | source of the LK column |
//! |---|---|---|---|
//! | 0xA1 request, 0x280 | `iqControl` ±2000, 32/2000 A | ±2048, MF 16.5/2048 A, MG 33/2048 A | LK CAN protocol V2.35, torque closed-loop command; 0x280: see [`ScaledMultiTorque`] |
//! | 0x9C, 0xA1..=0xA6 replies | `iq` 33/2048 A | MF 16.5/2048 A, MG 33/2048 A | same, reply of the torque command ("iq ... MF ... -16.5A~16.5A, MG ... -33A~33A") |
//! | 0x9A, 0x9B replies | [`Status1`] | [`LkStatus1`] | see [`lk`](crate::lk) |
//! | 0x94 reply | u16 in DATA\[6..=7\] | u32 in DATA\[4..=7\] | see [`LkCircleAngle`] |
//!
//! Every other command has the same layout and scale in both dialects and is carried as the v1.61
//! [`Reply`] / [`DecodedRequest`] (the `Common` variants).
//!
//! ```
//! use rmd_protocol::*;
//! let mg = Dialect::LkV23x(LkSeries::Mg);
//! let m1 = MotorId::new(1)?;
//! // 16.5 A on an MG motor is raw 1024 (33 A over 2048).
//! let request = DialectRequest::torque(mg, m1, 16.5)?;
//! assert_eq!(request.encode().to_string(), "141#A100000000040000");
//! // Its reply, read with the MG scale.
//! let frame = CanFrame::new(0x141, &[0xA1, 30, 0x00, 0x04, 0x2C, 0x01, 0x00, 0x80])?;
//! let (_, reply) = decode_reply_with(mg, &frame)?;
//! assert_eq!(reply.status2().unwrap().iq.amps(), 16.5);
//! // The same bytes read as an MF motor: half the current.
//! let (_, mf) = decode_reply_with(Dialect::LkV23x(LkSeries::Mf), &frame)?;
//! assert_eq!(mf.status2().unwrap().iq.amps(), 8.25);
//! # Ok::<(), rmd_protocol::ProtocolError>(())
//! ```

use crate::command::Command;
use crate::decode::{DecodedRequest, answered_command, command_of, data8};
use crate::dialect::Dialect;
use crate::encoder::EncoderValue;
use crate::error::{ExpectedIds, ProtocolError};
use crate::frame::CanFrame;
use crate::ids::{MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS, MotorId};
use crate::lk::{LkCircleAngle, LkStatus1};
use crate::multi::MultiTorque;
use crate::reply::Reply;
use crate::request::Request;
use crate::scale::{CurrentScale, ScaledCurrent};
use crate::status::{ErrorState, Status1, Status2};
use crate::values::{Speed, Temperature};
use crate::wire::{i16_at, put_i16, put_u16, put_u32, u16_at, u32_at};

/// Status 2 with the dialect's current scale: the reply to 0x9C and to every control command
/// 0xA1..=0xA6 (and to a 0x280 frame).
///
/// Layout (both dialects): DATA\[1\] temperature, DATA\[2..=3\] iq, DATA\[4..=5\] speed (1 dps),
/// DATA\[6..=7\] encoder.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct ScaledStatus2 {
    /// Motor temperature (int8_t, 1 °C/LSB).
    pub temperature: Temperature,
    /// Torque current, with the dialect's `iq` scale.
    pub iq: ScaledCurrent,
    /// Motor speed (1 dps/LSB).
    pub speed: Speed,
    /// Encoder position (offset applied).
    pub encoder: EncoderValue,
}

impl ScaledStatus2 {
    /// Reads DATA\[1..=7\] with the `iq` scale `scale`; [`ProtocolError::ValueOutOfRange`] for
    /// an `iq` outside the scale's range.
    pub fn from_data(d: &[u8; 8], scale: CurrentScale) -> Result<Self, ProtocolError> {
        Ok(Self {
            temperature: Temperature::new(i64::from(d[1] as i8))?,
            iq: ScaledCurrent::new(i64::from(i16_at::<2>(d)), scale)?,
            speed: Speed::new(i64::from(i16_at::<4>(d)))?,
            encoder: EncoderValue::from_raw(u16_at::<6>(d)),
        })
    }

    /// Writes DATA\[1..=7\] (DATA\[0\] is left as it is).
    pub fn write_to(&self, d: &mut [u8; 8]) {
        d[1] = self.temperature.raw() as u8;
        put_i16::<2>(d, self.iq.raw());
        put_i16::<4>(d, self.speed.raw());
        put_u16::<6>(d, self.encoder.raw());
    }

    /// The v1.61 [`Status2`], if `iq` uses v1.61's scale; else [`ProtocolError::ScaleMismatch`].
    pub fn to_v161(self) -> Result<Status2, ProtocolError> {
        Ok(Status2 {
            temperature: self.temperature,
            iq: self.iq.try_into()?,
            speed: self.speed,
            encoder: self.encoder,
        })
    }
}

impl From<Status2> for ScaledStatus2 {
    fn from(s: Status2) -> Self {
        Self {
            temperature: s.temperature,
            iq: s.iq.into(),
            speed: s.speed,
            encoder: s.encoder,
        }
    }
}

/// Status 1 in either dialect's layout.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum DialectStatus1 {
    /// v1.61: DATA\[1\] temperature, DATA\[3..=4\] voltage (0.1 V), DATA\[7\] error state.
    V161(Status1),
    /// LK-TECH V2.3x: see [`LkStatus1`].
    Lk(LkStatus1),
}

impl DialectStatus1 {
    /// Motor temperature.
    pub const fn temperature(&self) -> Temperature {
        match self {
            Self::V161(s) => s.temperature,
            Self::Lk(s) => s.temperature,
        }
    }

    /// Supply voltage, V.
    pub fn volts(&self) -> f64 {
        match self {
            Self::V161(s) => s.voltage.volts(),
            Self::Lk(s) => s.voltage.volts(),
        }
    }

    /// Protection flags.
    pub const fn error_state(&self) -> ErrorState {
        match self {
            Self::V161(s) => s.error_state,
            Self::Lk(s) => s.error_state,
        }
    }

    fn write_to(&self, d: &mut [u8; 8]) {
        match self {
            Self::V161(s) => {
                // The v1.61 layout, written by the v1.61 encoder.
                let v = Reply::ReadStatus1(*s).to_data();
                d[1..].copy_from_slice(&v[1..]);
            }
            Self::Lk(s) => s.write_to(d),
        }
    }
}

/// A motor's reply decoded in a dialect.
///
/// The replies whose layout or scale depends on the dialect have their own variants (for v1.61
/// too, so that a caller handles every dialect the same way); every other reply is `Common`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum DialectReply {
    /// 0x9A or 0x9B (the `command`) with the dialect's status-1 layout.
    Status1 {
        /// [`Command::ReadStatus1`] or [`Command::ClearError`].
        command: Command,
        /// The status.
        status: DialectStatus1,
    },
    /// 0x9C or 0xA1..=0xA6 (the `command`) with the dialect's `iq` scale.
    Status2 {
        /// [`Command::ReadStatus2`] or one of the control commands.
        command: Command,
        /// The status.
        status: ScaledStatus2,
    },
    /// 0x94 in the LK-TECH layout (u32 in DATA\[4..=7\]).
    LkSingleTurnAngle {
        /// `circleAngle`.
        circle_angle: LkCircleAngle,
    },
    /// Any reply with the same layout and scales in every dialect.
    Common(Reply),
}

impl DialectReply {
    /// The command this reply answers.
    pub const fn command(&self) -> Command {
        match self {
            Self::Status1 { command, .. } | Self::Status2 { command, .. } => *command,
            Self::LkSingleTurnAngle { .. } => Command::ReadSingleTurnAngle,
            Self::Common(r) => r.command(),
        }
    }

    /// The status-2 fields of a 0x9C or 0xA1..=0xA6 reply.
    pub const fn status2(&self) -> Option<ScaledStatus2> {
        match self {
            Self::Status2 { status, .. } => Some(*status),
            _ => None,
        }
    }

    /// The status-1 fields of a 0x9A or 0x9B reply.
    pub const fn status1(&self) -> Option<DialectStatus1> {
        match self {
            Self::Status1 { status, .. } => Some(*status),
            _ => None,
        }
    }

    /// The reply as v1.61 carries it, in the v1.61 shape: `Status2` replies become their v1.61
    /// variant, status 1 of the v1.61 layout too; `Common` replies as they are. Fails with
    /// [`ProtocolError::ScaleMismatch`] for a current in another scale; `None` for a reply v1.61
    /// cannot represent (an LK status 1 or single-turn angle).
    pub fn to_v161(&self) -> Option<Result<Reply, ProtocolError>> {
        Some(match *self {
            Self::Common(r) => Ok(r),
            Self::Status1 {
                command,
                status: DialectStatus1::V161(s),
            } => Ok(if command == Command::ClearError {
                Reply::ClearError(s)
            } else {
                Reply::ReadStatus1(s)
            }),
            Self::Status1 { .. } | Self::LkSingleTurnAngle { .. } => return None,
            Self::Status2 { command, status } => status
                .to_v161()
                .map(|s| status2_reply(command, s).unwrap_or(Reply::ReadStatus2(s))),
        })
    }

    /// The 8 data bytes (reserved bytes 0).
    pub fn to_data(&self) -> [u8; 8] {
        let mut d = [0u8; 8];
        d[0] = self.command().code();
        match self {
            Self::Status1 { status, .. } => status.write_to(&mut d),
            Self::Status2 { status, .. } => status.write_to(&mut d),
            Self::LkSingleTurnAngle { circle_angle } => put_u32::<4>(&mut d, circle_angle.raw()),
            Self::Common(r) => d = r.to_data(),
        }
        d
    }

    /// The frame `motor` sends with this reply (CAN ID 0x140 + id, DLC 8).
    pub fn encode(&self, motor: MotorId) -> CanFrame {
        CanFrame::rmd(motor.can_id(), self.to_data())
    }

    /// Decodes DATA\[0..=7\] for `command` (DATA\[0\] already read and matched).
    fn from_data(dialect: Dialect, command: Command, d: &[u8; 8]) -> Result<Self, ProtocolError> {
        Ok(match command {
            Command::ReadStatus1 | Command::ClearError => Self::Status1 {
                command,
                status: match dialect {
                    Dialect::V161 => match Reply::from_data(command, d)? {
                        Reply::ReadStatus1(s) | Reply::ClearError(s) => DialectStatus1::V161(s),
                        // Not reached: v1.61 decodes both commands as status 1.
                        other => return Ok(Self::Common(other)),
                    },
                    Dialect::LkV23x(_) => DialectStatus1::Lk(LkStatus1::from_data(d)?),
                },
            },
            Command::ReadStatus2
            | Command::Torque
            | Command::Speed
            | Command::Position1
            | Command::Position2
            | Command::Position3
            | Command::Position4 => Self::Status2 {
                command,
                status: ScaledStatus2::from_data(d, dialect.iq_scale())?,
            },
            Command::ReadSingleTurnAngle if matches!(dialect, Dialect::LkV23x(_)) => {
                Self::LkSingleTurnAngle {
                    circle_angle: LkCircleAngle::new(i64::from(u32_at::<4>(d)))?,
                }
            }
            _ => Self::Common(Reply::from_data(command, d)?),
        })
    }
}

/// The v1.61 reply variant carrying status 2 for `command`.
const fn status2_reply(command: Command, s: Status2) -> Option<Reply> {
    Some(match command {
        Command::ReadStatus2 => Reply::ReadStatus2(s),
        Command::Torque => Reply::Torque(s),
        Command::Speed => Reply::Speed(s),
        Command::Position1 => Reply::Position1(s),
        Command::Position2 => Reply::Position2(s),
        Command::Position3 => Reply::Position3(s),
        Command::Position4 => Reply::Position4(s),
        _ => return None,
    })
}

impl From<Reply> for DialectReply {
    /// The v1.61 reply in dialect form (status 1 and status 2 in their own variants).
    fn from(r: Reply) -> Self {
        if let Some(status) = r.status2() {
            return Self::Status2 {
                command: r.command(),
                status: status.into(),
            };
        }
        match r.status1() {
            Some(s) => Self::Status1 {
                command: r.command(),
                status: DialectStatus1::V161(s),
            },
            None => Self::Common(r),
        }
    }
}

/// Decodes a frame sent by a motor in `dialect`, whatever request it answers.
///
/// Checks, in order, as [`decode_reply`](crate::decode_reply): the CAN ID (0x141..=0x160), DLC 8,
/// the command byte, the field ranges (with the dialect's ranges: `iq` up to ±2048 in every
/// dialect). Reserved bytes are ignored. With [`Dialect::V161`] it accepts and rejects exactly
/// the frames [`decode_reply`](crate::decode_reply) does.
#[inline]
pub fn decode_reply_with(
    dialect: Dialect,
    frame: &CanFrame,
) -> Result<(MotorId, DialectReply), ProtocolError> {
    let motor = MotorId::from_can_id(frame.id())?;
    let d = data8(frame)?;
    let command = command_of(frame, d)?;
    Ok((motor, DialectReply::from_data(dialect, command, d)?))
}

/// Decodes a frame sent by a motor in `dialect` as the reply to the pending request `pending`
/// (for a 0x280 frame, [`Command::Torque`]); like [`decode_reply_to`](crate::decode_reply_to),
/// including accepting DATA\[0\] = 0x9A as the reply to a pending 0x9B.
#[inline]
pub fn decode_reply_to_with(
    dialect: Dialect,
    frame: &CanFrame,
    pending: Command,
) -> Result<(MotorId, DialectReply), ProtocolError> {
    let motor = MotorId::from_can_id(frame.id())?;
    let d = data8(frame)?;
    let got = command_of(frame, d)?;
    let command = answered_command(frame, got, pending)?;
    Ok((motor, DialectReply::from_data(dialect, command, d)?))
}

/// The 0x280 multi-motor torque frame with a dialect's `iqControl` scale: one value per motor
/// 1..=4 in DATA\[0..=7\] (little-endian i16 each, no command byte).
///
/// The layout is v1.61's [`MultiTorque`]; LK-TECH firmware keeps it with the scale of its 0xA1
/// (±2048; MF ±16.5 A, MG ±33 A). The LK V2.35 document's multi-motor section was not available
/// as text; this follows drivers of LK motors: github.com/Jason0-0/logging_car_pro_plus
/// `Core/Bsp/RMD_L_Motor/RMD_protocol.h` (0x280, replies 0xA1 on 0x141..=0x144,
/// "-2048~2048 -> -33A~33A") and MG4005 / MG6012 drivers in the public code index that fill
/// DATA\[2k..=2k+1\] with motor k+1's `iqControl`, low byte first. Each motor 1..=4 answers with
/// a 0xA1 reply.
///
/// ```
/// use rmd_protocol::{CurrentScale, ScaledCurrent, ScaledMultiTorque};
/// let s = CurrentScale::LK_MF_IQ_CONTROL;
/// let frame = ScaledMultiTorque::from_amps([16.5, -16.5, 0.0, 8.25], s)?.encode();
/// assert_eq!(frame.to_string(), "280#000800F800000004");
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct ScaledMultiTorque {
    /// `iqControl_1` ..= `iqControl_4`: index 0 drives motor 1.
    pub iq_control: [ScaledCurrent; MULTI_TORQUE_MOTORS],
}

impl ScaledMultiTorque {
    /// The frame driving motors 1..=4 with `iq_control[0..=3]`.
    pub const fn new(iq_control: [ScaledCurrent; MULTI_TORQUE_MOTORS]) -> Self {
        Self { iq_control }
    }

    /// The frame for four currents in amperes with the scale `scale` (checked: see
    /// [`ScaledCurrent::from_amps`]).
    pub fn from_amps(
        amps: [f64; MULTI_TORQUE_MOTORS],
        scale: CurrentScale,
    ) -> Result<Self, ProtocolError> {
        let mut out = [ScaledCurrent::saturating(0, scale); MULTI_TORQUE_MOTORS];
        for (slot, a) in out.iter_mut().zip(amps) {
            *slot = ScaledCurrent::from_amps(a, scale)?;
        }
        Ok(Self::new(out))
    }

    /// The current command for `motor`, or `None` if it is not one of motors 1..=4.
    pub const fn iq_control_for(&self, motor: MotorId) -> Option<ScaledCurrent> {
        match motor.multi_torque_slot() {
            Some(slot) => Some(self.iq_control[slot]),
            None => None,
        }
    }

    /// The 8 data bytes.
    pub fn to_data(&self) -> [u8; 8] {
        let mut d = [0u8; 8];
        put_i16::<0>(&mut d, self.iq_control[0].raw());
        put_i16::<2>(&mut d, self.iq_control[1].raw());
        put_i16::<4>(&mut d, self.iq_control[2].raw());
        put_i16::<6>(&mut d, self.iq_control[3].raw());
        d
    }

    /// The frame: CAN ID 0x280, DLC 8.
    pub fn encode(&self) -> CanFrame {
        CanFrame::rmd(MULTI_TORQUE_CAN_ID, self.to_data())
    }

    /// Decodes the 8 data bytes with `scale`; every value must be in the scale's range.
    pub fn from_data(d: &[u8; 8], scale: CurrentScale) -> Result<Self, ProtocolError> {
        let at = |v: i16| ScaledCurrent::new(i64::from(v), scale);
        Ok(Self::new([
            at(i16_at::<0>(d))?,
            at(i16_at::<2>(d))?,
            at(i16_at::<4>(d))?,
            at(i16_at::<6>(d))?,
        ]))
    }
}

impl From<MultiTorque> for ScaledMultiTorque {
    fn from(m: MultiTorque) -> Self {
        Self::new(m.iq_control.map(ScaledCurrent::from))
    }
}

/// A request decoded in a dialect. The torque requests, whose scale depends on the dialect, have
/// their own variants; every other request is `Common`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum DialectRequest {
    /// 0xA1 to one motor with the dialect's `iqControl` scale.
    Torque {
        /// The motor addressed.
        motor: MotorId,
        /// `iqControl`, DATA\[4..=5\].
        iq_control: ScaledCurrent,
    },
    /// The 0x280 frame with the dialect's `iqControl` scale.
    MultiTorque(ScaledMultiTorque),
    /// Any request with the same layout in every dialect.
    Common(DecodedRequest),
}

impl DialectRequest {
    /// A torque request of `amps` to `motor` in `dialect` (checked against the dialect's range).
    pub fn torque(dialect: Dialect, motor: MotorId, amps: f64) -> Result<Self, ProtocolError> {
        Ok(Self::Torque {
            motor,
            iq_control: ScaledCurrent::from_amps(amps, dialect.iq_control_scale())?,
        })
    }

    /// A 0x280 frame for motors 1..=4 with `amps` in `dialect` (checked).
    pub fn multi_torque(
        dialect: Dialect,
        amps: [f64; MULTI_TORQUE_MOTORS],
    ) -> Result<Self, ProtocolError> {
        Ok(Self::MultiTorque(ScaledMultiTorque::from_amps(
            amps,
            dialect.iq_control_scale(),
        )?))
    }

    /// The frame, with the raw values as they are (see [`encode_request_with`] for the checked
    /// form).
    pub fn encode(&self) -> CanFrame {
        match self {
            Self::Torque { motor, iq_control } => {
                let mut d = [0u8; 8];
                d[0] = Command::Torque.code();
                put_i16::<4>(&mut d, iq_control.raw());
                CanFrame::rmd(motor.can_id(), d)
            }
            Self::MultiTorque(m) => m.encode(),
            Self::Common(r) => r.encode(),
        }
    }

    /// Checks that every current of the request uses `dialect`'s `iqControl` scale
    /// ([`ProtocolError::ScaleMismatch`] otherwise).
    pub fn check_dialect(&self, dialect: Dialect) -> Result<(), ProtocolError> {
        let expected = dialect.iq_control_scale();
        match self {
            Self::Torque { iq_control, .. } => iq_control.expect_scale(expected).map(|_| ()),
            Self::MultiTorque(m) => m
                .iq_control
                .iter()
                .try_for_each(|v| v.expect_scale(expected).map(|_| ())),
            Self::Common(DecodedRequest::Single {
                request: Request::Torque { iq_control },
                ..
            }) => ScaledCurrent::from(*iq_control)
                .expect_scale(expected)
                .map(|_| ()),
            Self::Common(DecodedRequest::Multi(m)) => ScaledMultiTorque::from(*m)
                .iq_control
                .iter()
                .try_for_each(|v| v.expect_scale(expected).map(|_| ())),
            Self::Common(_) => Ok(()),
        }
    }
}

/// Encodes `request` for a motor speaking `dialect`, after checking that its currents use the
/// dialect's `iqControl` scale ([`ProtocolError::ScaleMismatch`]: e.g. a v1.61 `iqControl` sent
/// to an LK-TECH MF motor, which would run it at about half the current meant).
pub fn encode_request_with(
    dialect: Dialect,
    request: &DialectRequest,
) -> Result<CanFrame, ProtocolError> {
    request.check_dialect(dialect)?;
    Ok(request.encode())
}

/// Decodes a frame sent by the host, in `dialect`: a single-motor request (0x141..=0x160) or
/// the 0x280 frame. Same checks as [`decode_request`](crate::decode_request), with the dialect's
/// `iqControl` range; with [`Dialect::V161`] it accepts and rejects exactly the frames
/// [`decode_request`](crate::decode_request) does.
pub fn decode_request_with(
    dialect: Dialect,
    frame: &CanFrame,
) -> Result<DialectRequest, ProtocolError> {
    let scale = dialect.iq_control_scale();
    if frame.id() == MULTI_TORQUE_CAN_ID {
        let d = data8(frame)?;
        return Ok(DialectRequest::MultiTorque(ScaledMultiTorque::from_data(
            d, scale,
        )?));
    }
    let motor = MotorId::from_can_id(frame.id()).map_err(|_| ProtocolError::UnexpectedCanId {
        can_id: frame.id(),
        expected: ExpectedIds::MotorOrMultiTorque,
    })?;
    let d = data8(frame)?;
    let command = command_of(frame, d)?;
    if command == Command::Torque {
        return Ok(DialectRequest::Torque {
            motor,
            iq_control: ScaledCurrent::new(i64::from(i16_at::<4>(d)), scale)?,
        });
    }
    Ok(DialectRequest::Common(DecodedRequest::Single {
        motor,
        request: Request::from_data(command, d)?,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect::LkSeries;

    #[test]
    fn v161_dialect_matches_the_v161_decoder() {
        let status2 =
            CanFrame::new(0x142, &[0xA1, 40, 0x00, 0x04, 0x2C, 0x01, 0x00, 0x20]).unwrap();
        let (m, r) = decode_reply_with(Dialect::V161, &status2).unwrap();
        let (m0, r0) = crate::decode_reply(&status2).unwrap();
        assert_eq!(m, m0);
        assert_eq!(r.to_v161(), Some(Ok(r0)));
        assert_eq!(DialectReply::from(r0), r);
        assert_eq!(r.encode(m), status2);
    }

    #[test]
    fn lk_single_turn_angle_is_u32() {
        let mg = Dialect::LkV23x(LkSeries::Mg);
        let f = CanFrame::new(0x141, &[0x94, 0, 0, 0, 0x90, 0x5F, 0x01, 0x00]).unwrap();
        let (_, r) = decode_reply_with(mg, &f).unwrap();
        assert_eq!(
            r,
            DialectReply::LkSingleTurnAngle {
                circle_angle: LkCircleAngle::new(90_000).unwrap()
            }
        );
        assert_eq!(r.to_v161(), None);
        assert_eq!(r.encode(MotorId::new(1).unwrap()), f);
    }

    #[test]
    fn scale_checks_on_encoding() {
        let mf = Dialect::LkV23x(LkSeries::Mf);
        let m = MotorId::new(2).unwrap();
        let v161 = DialectRequest::Common(DecodedRequest::Single {
            motor: m,
            request: Request::Torque {
                iq_control: crate::IqControl::new(100).unwrap(),
            },
        });
        assert!(matches!(
            encode_request_with(mf, &v161),
            Err(ProtocolError::ScaleMismatch { .. })
        ));
        assert!(encode_request_with(Dialect::V161, &v161).is_ok());
        let lk = DialectRequest::torque(mf, m, 1.0).unwrap();
        assert!(encode_request_with(mf, &lk).is_ok());
        assert!(encode_request_with(Dialect::LkV23x(LkSeries::Mg), &lk).is_err());
        let read = DialectRequest::Common(DecodedRequest::Single {
            motor: m,
            request: Request::ReadStatus1,
        });
        assert!(encode_request_with(mf, &read).is_ok());
    }
}
