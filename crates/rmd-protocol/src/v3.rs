//! The few frames of MyActuator's "V3" firmware rmd-rt needs to recognise it, and the simulator
//! to emulate it. rmd-rt does not drive V3 motors (their 0x280 frame is not a torque frame: see
//! [`ProtocolFamily::MyActuatorV3`](crate::ProtocolFamily::MyActuatorV3)).
//!
//! Source of every layout below, unless said otherwise: MyActuator "Servo Motor Control Protocol",
//! version V4.3 (2025.05), applicable driver V3, a Markdown rendering of the manufacturer's PDF in
//! the public code index (the repository is not named by the index), cross-checked with the V4.2
//! rendering ("Motor Motion Protocol V4.2-250208.pdf") and with github.com/2b-t/myactuator_rmd
//! (`include/myactuator_rmd/driver/can_address_offset.hpp`, `src/protocol/requests.cpp`,
//! `src/protocol/responses.cpp`, `include/myactuator_rmd/protocol/responses.hpp`).
//!
//! - §1.1.2: requests on `0x140 + id`, the multi-motor command on 0x280, replies on `0x240 + id`.
//! - §2.14 (0x9A): DATA\[1\] motor temperature, DATA\[2\] MOS temperature, DATA\[3\] brake
//!   release state, DATA\[4..=5\] voltage (0.1 V), DATA\[6..=7\] error state (u16).
//! - §2.15 (0x9C; also the reply of 0xA1, §2.19): DATA\[1\] temperature, DATA\[2..=3\] iq (0.01 A),
//!   DATA\[4..=5\] output-shaft speed (1 dps), DATA\[6..=7\] output-shaft angle (1°, int16).
//! - §2.12 (0x92): `motorAngle`, int32 in DATA\[4..=7\], 0.01°.
//! - §2.17, §2.18 (0x80 shutdown, 0x81 stop): the reply echoes the request.
//! - §2.19 (0xA1): `iqControl`, int16 in DATA\[4..=5\], 0.01 A.
//! - §2.33 (0xB5): the motor model, 7 ASCII bytes in DATA\[1..=7\] (example: `X8S2V10`).
//! - §3: a frame on 0x280 carries an ordinary single-motor command that every motor on the bus
//!   executes; each replies on its own `0x240 + id` (example: `280#8000000000000000` shuts every
//!   motor down).
//!
//! ```
//! use rmd_protocol::{CanFrame, MotorId};
//! use rmd_protocol::v3::{V3Reply, V3Request};
//! // The document's 0x9C example reply: 50 °C, 1 A, 500 dps, 45°.
//! let frame = CanFrame::new(0x241, &[0x9C, 0x32, 0x64, 0x00, 0xF4, 0x01, 0x2D, 0x00])?;
//! let (motor, reply) = V3Reply::decode(&frame)?;
//! assert_eq!(motor, MotorId::new(1)?);
//! let V3Reply::Status2 { status, .. } = reply else { unreachable!() };
//! assert_eq!(status.iq.amps(), 1.0);
//! // "All motors off" on a V3 bus.
//! assert_eq!(V3Request::MotorOff.encode_broadcast().to_string(), "280#8000000000000000");
//! # Ok::<(), rmd_protocol::ProtocolError>(())
//! ```

use crate::error::{ExpectedIds, ProtocolError};
use crate::frame::CanFrame;
use crate::ids::{MULTI_TORQUE_CAN_ID, MotorId};
use crate::scale::{CurrentScale, ScaledCurrent};
use crate::values::{Speed, Temperature, Voltage};
use crate::wire::{i16_at, i32_at, put_i16, put_i32, put_u16, u16_at};

/// Base of the V3 reply identifiers: motor `n` replies on `0x240 + n` (§1.1.2).
pub const REPLY_BASE_ID: u16 = 0x240;

/// The identifier `motor` replies on under V3 firmware, `0x240 + id`.
pub const fn reply_can_id(motor: MotorId) -> u16 {
    REPLY_BASE_ID + motor.get() as u16
}

/// The motor whose V3 reply identifier is `can_id`; [`ProtocolError::UnexpectedCanId`] outside
/// 0x241..=0x260.
pub const fn motor_from_reply_id(can_id: u16) -> Result<MotorId, ProtocolError> {
    if can_id > REPLY_BASE_ID && can_id <= REPLY_BASE_ID + MotorId::MAX as u16 {
        MotorId::new((can_id - REPLY_BASE_ID) as u8)
    } else {
        Err(ProtocolError::UnexpectedCanId {
            can_id,
            expected: ExpectedIds::MyActuatorV3Reply,
        })
    }
}

/// The V3 command bytes rmd-rt knows (a small subset of the document's).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum V3Command {
    /// 0x9A: read status 1 and error flags (§2.14).
    ReadStatus1 = 0x9A,
    /// 0x9C: read status 2 (§2.15).
    ReadStatus2 = 0x9C,
    /// 0x92: read the multi-turn angle (§2.12).
    ReadMultiTurnAngle = 0x92,
    /// 0x80: motor shutdown (§2.17).
    MotorOff = 0x80,
    /// 0x81: motor stop (§2.18).
    MotorStop = 0x81,
    /// 0xA1: torque closed loop (§2.19).
    Torque = 0xA1,
    /// 0xB5: read the motor model (§2.33).
    ReadModel = 0xB5,
}

impl V3Command {
    /// The command byte.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The command with byte `code`, if rmd-rt knows it.
    pub const fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            0x9A => Self::ReadStatus1,
            0x9C => Self::ReadStatus2,
            0x92 => Self::ReadMultiTurnAngle,
            0x80 => Self::MotorOff,
            0x81 => Self::MotorStop,
            0xA1 => Self::Torque,
            0xB5 => Self::ReadModel,
            _ => return None,
        })
    }
}

/// V3 error state (u16, DATA\[6..=7\] of 0x9A): a bit mask (§2.14, "System_errorState").
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct V3ErrorState(u16);

impl V3ErrorState {
    /// 0x0002: motor stall.
    pub const STALL: Self = Self(0x0002);
    /// 0x0004: low voltage.
    pub const LOW_VOLTAGE: Self = Self(0x0004);
    /// 0x0008: over voltage.
    pub const OVER_VOLTAGE: Self = Self(0x0008);
    /// 0x0010: over current.
    pub const OVER_CURRENT: Self = Self(0x0010);
    /// 0x1000: motor over-temperature.
    pub const MOTOR_OVER_TEMPERATURE: Self = Self(0x1000);

    /// The state from its raw value (every bit kept).
    pub const fn from_raw(raw: u16) -> Self {
        Self(raw)
    }

    /// The raw value.
    pub const fn raw(self) -> u16 {
        self.0
    }

    /// Whether every bit of `other` is set.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }
}

/// V3 status 1 (§2.14).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct V3Status1 {
    /// Motor temperature, DATA\[1\].
    pub temperature: Temperature,
    /// Driver (MOS) temperature, DATA\[2\].
    pub mos_temperature: Temperature,
    /// Brake release state, DATA\[3\] (1: released).
    pub brake_released: bool,
    /// Supply voltage, DATA\[4..=5\], 0.1 V/LSB.
    pub voltage: Voltage,
    /// Error state, DATA\[6..=7\].
    pub error_state: V3ErrorState,
}

/// V3 status 2 (§2.15): note that speed and angle are the output shaft's.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct V3Status2 {
    /// Motor temperature, DATA\[1\].
    pub temperature: Temperature,
    /// Torque current, DATA\[2..=3\], 0.01 A/LSB.
    pub iq: ScaledCurrent,
    /// Output-shaft speed, DATA\[4..=5\], 1 dps/LSB.
    pub speed: Speed,
    /// Output-shaft angle, DATA\[6..=7\], 1°/LSB (int16).
    pub shaft_degrees: i16,
}

/// The V3 requests rmd-rt knows.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum V3Request {
    /// 0x9A.
    ReadStatus1,
    /// 0x9C.
    ReadStatus2,
    /// 0x92.
    ReadMultiTurnAngle,
    /// 0xB5.
    ReadModel,
    /// 0x80.
    MotorOff,
    /// 0x81.
    MotorStop,
    /// 0xA1 with `iqControl` (0.01 A/LSB).
    Torque {
        /// `iqControl`, DATA\[4..=5\].
        iq_control: ScaledCurrent,
    },
}

impl V3Request {
    /// The command byte.
    pub const fn command(&self) -> V3Command {
        match self {
            Self::ReadStatus1 => V3Command::ReadStatus1,
            Self::ReadStatus2 => V3Command::ReadStatus2,
            Self::ReadMultiTurnAngle => V3Command::ReadMultiTurnAngle,
            Self::ReadModel => V3Command::ReadModel,
            Self::MotorOff => V3Command::MotorOff,
            Self::MotorStop => V3Command::MotorStop,
            Self::Torque { .. } => V3Command::Torque,
        }
    }

    /// The 8 data bytes.
    pub const fn to_data(&self) -> [u8; 8] {
        let mut d = [0u8; 8];
        d[0] = self.command().code();
        if let Self::Torque { iq_control } = self {
            put_i16::<4>(&mut d, iq_control.raw());
        }
        d
    }

    /// The frame to one motor, on `0x140 + id`.
    pub const fn encode(&self, motor: MotorId) -> CanFrame {
        CanFrame::rmd(motor.can_id(), self.to_data())
    }

    /// The frame to every motor of the bus, on 0x280 (§3).
    pub const fn encode_broadcast(&self) -> CanFrame {
        CanFrame::rmd(MULTI_TORQUE_CAN_ID, self.to_data())
    }

    /// The request carried by 8 data bytes, or `None` for a command rmd-rt does not know.
    /// Reserved bytes are ignored.
    pub const fn from_data(d: &[u8; 8]) -> Option<Self> {
        Some(match V3Command::from_code(d[0]) {
            Some(V3Command::ReadStatus1) => Self::ReadStatus1,
            Some(V3Command::ReadStatus2) => Self::ReadStatus2,
            Some(V3Command::ReadMultiTurnAngle) => Self::ReadMultiTurnAngle,
            Some(V3Command::ReadModel) => Self::ReadModel,
            Some(V3Command::MotorOff) => Self::MotorOff,
            Some(V3Command::MotorStop) => Self::MotorStop,
            Some(V3Command::Torque) => Self::Torque {
                iq_control: match ScaledCurrent::new(
                    i16_at::<4>(d) as i64,
                    CurrentScale::MYACTUATOR_V3_IQ_CONTROL,
                ) {
                    Ok(v) => v,
                    Err(_) => return None,
                },
            },
            None => return None,
        })
    }
}

/// The V3 replies rmd-rt knows.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum V3Reply {
    /// 0x9A.
    Status1(V3Status1),
    /// 0x9C or 0xA1.
    Status2 {
        /// [`V3Command::ReadStatus2`] or [`V3Command::Torque`].
        command: V3Command,
        /// The status.
        status: V3Status2,
    },
    /// 0x92: the multi-turn angle, 0.01°/LSB.
    MultiTurnAngle {
        /// `motorAngle`, DATA\[4..=7\].
        centidegrees: i32,
    },
    /// 0xB5: the model, 7 ASCII bytes.
    Model([u8; 7]),
    /// 0x80 echo.
    MotorOff,
    /// 0x81 echo.
    MotorStop,
}

impl V3Reply {
    /// The command this reply answers.
    pub const fn command(&self) -> V3Command {
        match self {
            Self::Status1(_) => V3Command::ReadStatus1,
            Self::Status2 { command, .. } => *command,
            Self::MultiTurnAngle { .. } => V3Command::ReadMultiTurnAngle,
            Self::Model(_) => V3Command::ReadModel,
            Self::MotorOff => V3Command::MotorOff,
            Self::MotorStop => V3Command::MotorStop,
        }
    }

    /// The 8 data bytes.
    pub const fn to_data(&self) -> [u8; 8] {
        let mut d = [0u8; 8];
        d[0] = self.command().code();
        match *self {
            Self::Status1(s) => {
                d[1] = s.temperature.raw() as u8;
                d[2] = s.mos_temperature.raw() as u8;
                d[3] = s.brake_released as u8;
                put_u16::<4>(&mut d, s.voltage.raw());
                put_u16::<6>(&mut d, s.error_state.raw());
            }
            Self::Status2 { status, .. } => {
                d[1] = status.temperature.raw() as u8;
                put_i16::<2>(&mut d, status.iq.raw());
                put_i16::<4>(&mut d, status.speed.raw());
                put_i16::<6>(&mut d, status.shaft_degrees);
            }
            Self::MultiTurnAngle { centidegrees } => put_i32::<4>(&mut d, centidegrees),
            Self::Model(m) => {
                let mut i = 0;
                while i < 7 {
                    d[1 + i] = m[i];
                    i += 1;
                }
            }
            Self::MotorOff | Self::MotorStop => {}
        }
        d
    }

    /// The frame `motor` sends with this reply, on `0x240 + id`.
    pub const fn encode(&self, motor: MotorId) -> CanFrame {
        CanFrame::rmd(reply_can_id(motor), self.to_data())
    }

    /// Decodes a V3 reply: the identifier (0x241..=0x260), DLC 8, a known command byte.
    pub fn decode(frame: &CanFrame) -> Result<(MotorId, Self), ProtocolError> {
        let motor = motor_from_reply_id(frame.id())?;
        let d = frame.data8().ok_or(ProtocolError::WrongDlc {
            can_id: frame.id(),
            dlc: frame.dlc(),
        })?;
        let unknown = ProtocolError::UnknownCommand {
            can_id: frame.id(),
            code: d[0],
        };
        let temperature = |i: usize| Temperature::new(i64::from(d[i] as i8));
        let reply = match V3Command::from_code(d[0]).ok_or(unknown)? {
            V3Command::ReadStatus1 => Self::Status1(V3Status1 {
                temperature: temperature(1)?,
                mos_temperature: temperature(2)?,
                brake_released: d[3] != 0,
                voltage: Voltage::new(i64::from(u16_at::<4>(d)))?,
                error_state: V3ErrorState::from_raw(u16_at::<6>(d)),
            }),
            command @ (V3Command::ReadStatus2 | V3Command::Torque) => Self::Status2 {
                command,
                status: V3Status2 {
                    temperature: temperature(1)?,
                    iq: ScaledCurrent::new(
                        i64::from(i16_at::<2>(d)),
                        CurrentScale::MYACTUATOR_V3_IQ,
                    )?,
                    speed: Speed::new(i64::from(i16_at::<4>(d)))?,
                    shaft_degrees: i16_at::<6>(d),
                },
            },
            V3Command::ReadMultiTurnAngle => Self::MultiTurnAngle {
                centidegrees: i32_at::<4>(d),
            },
            V3Command::ReadModel => {
                let mut m = [0u8; 7];
                m.copy_from_slice(&d[1..]);
                Self::Model(m)
            }
            V3Command::MotorOff => Self::MotorOff,
            V3Command::MotorStop => Self::MotorStop,
        };
        Ok((motor, reply))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(id: u16, d: [u8; 8]) -> CanFrame {
        CanFrame::new(id, &d).unwrap()
    }

    /// The communication examples of the V4.3 document, both ways.
    #[test]
    fn document_examples() {
        let m1 = MotorId::new(1).unwrap();
        // §2.14: 50 °C, brake released, 48.5 V, low voltage.
        let f = frame(0x241, [0x9A, 0x32, 0x00, 0x01, 0xE5, 0x01, 0x04, 0x00]);
        let (m, r) = V3Reply::decode(&f).unwrap();
        let V3Reply::Status1(s) = r else {
            panic!("{r:?}")
        };
        assert_eq!(
            (m, s.temperature.celsius(), s.voltage.volts()),
            (m1, 50.0, 48.5)
        );
        assert!(s.brake_released && s.error_state.contains(V3ErrorState::LOW_VOLTAGE));
        assert_eq!(r.encode(m1), f);
        // §2.19: 0xA1 request of 1 A and its reply (-1 A example too).
        let iq = ScaledCurrent::new(100, CurrentScale::MYACTUATOR_V3_IQ_CONTROL).unwrap();
        let req = V3Request::Torque { iq_control: iq };
        assert_eq!(req.encode(m1), frame(0x141, [0xA1, 0, 0, 0, 0x64, 0, 0, 0]));
        assert_eq!(V3Request::from_data(&req.to_data()), Some(req));
        let f = frame(0x241, [0xA1, 0x32, 0x9C, 0xFF, 0x0C, 0xFE, 0xD3, 0xFF]);
        let (_, r) = V3Reply::decode(&f).unwrap();
        let V3Reply::Status2 { status, .. } = r else {
            panic!("{r:?}")
        };
        assert_eq!(
            (status.iq.amps(), status.speed.dps(), status.shaft_degrees),
            (-1.0, -500.0, -45)
        );
        assert_eq!(r.encode(m1), f);
        // §2.12: 360°.
        let f = frame(0x241, [0x92, 0, 0, 0, 0xA0, 0x8C, 0, 0]);
        assert_eq!(
            V3Reply::decode(&f).unwrap().1,
            V3Reply::MultiTurnAngle {
                centidegrees: 36_000
            }
        );
        // §2.33: "X8S2V10".
        let f = frame(0x241, [0xB5, 0x58, 0x38, 0x53, 0x32, 0x56, 0x31, 0x30]);
        assert_eq!(V3Reply::decode(&f).unwrap().1, V3Reply::Model(*b"X8S2V10"));
        // §3: broadcast shutdown.
        assert_eq!(
            V3Request::MotorOff.encode_broadcast(),
            frame(0x280, [0x80, 0, 0, 0, 0, 0, 0, 0])
        );
    }

    #[test]
    fn rejects_other_ids_and_commands() {
        let f = frame(0x141, [0x9A, 0, 0, 0, 0, 0, 0, 0]);
        assert!(matches!(
            V3Reply::decode(&f),
            Err(ProtocolError::UnexpectedCanId { .. })
        ));
        let f = frame(0x241, [0x33, 0, 0, 0, 0, 0, 0, 0]);
        assert!(matches!(
            V3Reply::decode(&f),
            Err(ProtocolError::UnknownCommand { code: 0x33, .. })
        ));
        assert!(motor_from_reply_id(0x240).is_err());
        assert!(motor_from_reply_id(0x261).is_err());
        assert_eq!(motor_from_reply_id(0x260).unwrap().get(), 32);
        assert_eq!(V3Request::from_data(&[0x30, 0, 0, 0, 0, 0, 0, 0]), None);
    }
}
