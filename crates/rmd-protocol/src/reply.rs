//! Replies: what one motor answers (CAN ID 0x140 + id, DATA\[0\] = the command byte).

use crate::command::Command;
use crate::encoder::{EncoderValue, EncoderWidth};
use crate::error::ProtocolError;
use crate::frame::CanFrame;
use crate::ids::MotorId;
use crate::status::{ErrorState, PidParams, Status1, Status2, Status3};
use crate::values::{
    Accel, CircleAngle, Iq, MotorAngle, PhaseCurrent, Speed, Temperature, Voltage,
};
use crate::wire::{i16_at, i32_at, i56_at_1, put_i16, put_i32, put_i56_at_1, put_u16, u16_at};

/// A motor's reply: one variant per command, carrying its typed fields.
///
/// Several commands share a layout: 0x30/0x31/0x32 carry [`PidParams`]; 0x9A and 0x9B carry
/// [`Status1`]; 0x9C and the control commands 0xA1..=0xA6 carry [`Status2`] (the replies to a
/// 0x280 multi-motor frame are 0xA1 replies); 0x80/0x81/0x88 echo the command.
///
/// ```
/// use rmd_protocol::{decode_reply, Command, MotorId, Reply};
/// let frame = rmd_protocol::CanFrame::new(0x142, &[0xA1, 40, 0x00, 0x04, 0x2C, 0x01, 0x00, 0x20]).unwrap();
/// let (motor, reply) = decode_reply(&frame).unwrap();
/// assert_eq!(motor, MotorId::new(2).unwrap());
/// let s = reply.status2().unwrap();
/// assert_eq!((s.temperature.celsius(), s.iq.amps(), s.speed.dps()), (40.0, 16.5, 300.0));
/// assert_eq!(s.encoder.raw(), 0x2000);
/// assert_eq!(reply.encode(motor), frame);
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Reply {
    /// 0x30: the PID parameters.
    ReadPid(PidParams),
    /// 0x31: echo of the PID parameters written to RAM.
    WritePidRam(PidParams),
    /// 0x32: echo of the PID parameters written to ROM.
    WritePidRom(PidParams),
    /// 0x33: the acceleration.
    ReadAccel {
        /// `Accel`, DATA\[4..=7\] (the spec's field descriptions for 0x33 are slips; see [`Accel`]).
        accel: Accel,
    },
    /// 0x34: echo of the acceleration written.
    WriteAccelRam {
        /// `Accel`, DATA\[4..=7\].
        accel: Accel,
    },
    /// 0x90: the encoder values.
    ReadEncoder {
        /// `encoder`: position minus offset, DATA\[2..=3\].
        encoder: EncoderValue,
        /// `encoderRaw`: original position, DATA\[4..=5\].
        encoder_raw: EncoderValue,
        /// `encoderOffset`, DATA\[6..=7\].
        encoder_offset: EncoderValue,
    },
    /// 0x91: the new encoder offset.
    WriteEncoderOffset {
        /// `encoderOffset`, DATA\[6..=7\].
        encoder_offset: EncoderValue,
    },
    /// 0x19: the offset written to ROM as the zero.
    WriteZeroRom {
        /// `encoderOffset`, DATA\[6..=7\].
        encoder_offset: EncoderValue,
    },
    /// 0x92: the multi-turn angle.
    ReadMultiTurnAngle {
        /// `motorAngle`, DATA\[1..=7\], 56-bit signed (the spec's "int64_t" is a slip).
        motor_angle: MotorAngle,
    },
    /// 0x94: the single-turn angle.
    ReadSingleTurnAngle {
        /// `circleAngle`, DATA\[6..=7\].
        circle_angle: CircleAngle,
    },
    /// 0x9A: status 1.
    ReadStatus1(Status1),
    /// 0x9B: status 1 after clearing the error flags. Encoded with DATA\[0\] = 0x9B (the echo of
    /// the request); the spec's table shows 0x9A, which [`decode_reply_to`](crate::decode_reply_to)
    /// accepts as the reply to a pending 0x9B.
    ClearError(Status1),
    /// 0x9C: status 2.
    ReadStatus2(Status2),
    /// 0x9D: status 3 (phase currents).
    ReadStatus3(Status3),
    /// 0x80: echo of motor off.
    MotorOff,
    /// 0x81: echo of motor stop.
    MotorStop,
    /// 0x88: echo of motor run.
    MotorRun,
    /// 0xA1: status 2 after a torque command (also each reply to a 0x280 frame).
    Torque(Status2),
    /// 0xA2: status 2 after a speed command.
    Speed(Status2),
    /// 0xA3: status 2 after position command 1.
    Position1(Status2),
    /// 0xA4: status 2 after position command 2.
    Position2(Status2),
    /// 0xA5: status 2 after position command 3.
    Position3(Status2),
    /// 0xA6: status 2 after position command 4.
    Position4(Status2),
}

impl Reply {
    /// The command this reply answers.
    #[inline]
    pub const fn command(&self) -> Command {
        match self {
            Reply::ReadPid(_) => Command::ReadPid,
            Reply::WritePidRam(_) => Command::WritePidRam,
            Reply::WritePidRom(_) => Command::WritePidRom,
            Reply::ReadAccel { .. } => Command::ReadAccel,
            Reply::WriteAccelRam { .. } => Command::WriteAccelRam,
            Reply::ReadEncoder { .. } => Command::ReadEncoder,
            Reply::WriteEncoderOffset { .. } => Command::WriteEncoderOffset,
            Reply::WriteZeroRom { .. } => Command::WriteZeroRom,
            Reply::ReadMultiTurnAngle { .. } => Command::ReadMultiTurnAngle,
            Reply::ReadSingleTurnAngle { .. } => Command::ReadSingleTurnAngle,
            Reply::ReadStatus1(_) => Command::ReadStatus1,
            Reply::ClearError(_) => Command::ClearError,
            Reply::ReadStatus2(_) => Command::ReadStatus2,
            Reply::ReadStatus3(_) => Command::ReadStatus3,
            Reply::MotorOff => Command::MotorOff,
            Reply::MotorStop => Command::MotorStop,
            Reply::MotorRun => Command::MotorRun,
            Reply::Torque(_) => Command::Torque,
            Reply::Speed(_) => Command::Speed,
            Reply::Position1(_) => Command::Position1,
            Reply::Position2(_) => Command::Position2,
            Reply::Position3(_) => Command::Position3,
            Reply::Position4(_) => Command::Position4,
        }
    }

    /// The status-2 fields of a 0x9C or 0xA1..=0xA6 reply, else `None`.
    #[inline]
    pub const fn status2(&self) -> Option<Status2> {
        match *self {
            Reply::ReadStatus2(s)
            | Reply::Torque(s)
            | Reply::Speed(s)
            | Reply::Position1(s)
            | Reply::Position2(s)
            | Reply::Position3(s)
            | Reply::Position4(s) => Some(s),
            _ => None,
        }
    }

    /// The status-1 fields of a 0x9A or 0x9B reply, else `None`.
    pub const fn status1(&self) -> Option<Status1> {
        match *self {
            Reply::ReadStatus1(s) | Reply::ClearError(s) => Some(s),
            _ => None,
        }
    }

    /// The 8 data bytes of this reply (reserved bytes 0).
    #[inline]
    pub const fn to_data(&self) -> [u8; 8] {
        let mut d = [0u8; 8];
        d[0] = self.command().code();
        match *self {
            Reply::ReadPid(p) | Reply::WritePidRam(p) | Reply::WritePidRom(p) => p.write_to(&mut d),
            Reply::ReadAccel { accel } | Reply::WriteAccelRam { accel } => {
                put_i32::<4>(&mut d, accel.raw())
            }
            Reply::ReadEncoder {
                encoder,
                encoder_raw,
                encoder_offset,
            } => {
                put_u16::<2>(&mut d, encoder.raw());
                put_u16::<4>(&mut d, encoder_raw.raw());
                put_u16::<6>(&mut d, encoder_offset.raw());
            }
            Reply::WriteEncoderOffset { encoder_offset }
            | Reply::WriteZeroRom { encoder_offset } => put_u16::<6>(&mut d, encoder_offset.raw()),
            Reply::ReadMultiTurnAngle { motor_angle } => put_i56_at_1(&mut d, motor_angle.raw()),
            Reply::ReadSingleTurnAngle { circle_angle } => put_u16::<6>(&mut d, circle_angle.raw()),
            Reply::ReadStatus1(s) | Reply::ClearError(s) => {
                d[1] = s.temperature.raw() as u8;
                put_u16::<3>(&mut d, s.voltage.raw());
                d[7] = s.error_state.raw();
            }
            Reply::ReadStatus2(s)
            | Reply::Torque(s)
            | Reply::Speed(s)
            | Reply::Position1(s)
            | Reply::Position2(s)
            | Reply::Position3(s)
            | Reply::Position4(s) => {
                d[1] = s.temperature.raw() as u8;
                put_i16::<2>(&mut d, s.iq.raw());
                put_i16::<4>(&mut d, s.speed.raw());
                put_u16::<6>(&mut d, s.encoder.raw());
            }
            Reply::ReadStatus3(s) => {
                put_i16::<2>(&mut d, s.i_a.raw());
                put_i16::<4>(&mut d, s.i_b.raw());
                put_i16::<6>(&mut d, s.i_c.raw());
            }
            Reply::MotorOff | Reply::MotorStop | Reply::MotorRun => {}
        }
        d
    }

    /// The frame `motor` sends with this reply (CAN ID 0x140 + id, DLC 8). The simulator answers
    /// with it.
    #[inline]
    pub const fn encode(&self, motor: MotorId) -> CanFrame {
        CanFrame::rmd(motor.can_id(), self.to_data())
    }

    /// Checks every encoder value of the reply (`encoder`, `encoder_raw`, `encoder_offset`)
    /// against the motor's encoder width; replies without encoder values always pass.
    pub const fn check_encoder_width(&self, width: EncoderWidth) -> Result<(), ProtocolError> {
        let values: [Option<EncoderValue>; 3] = match *self {
            Reply::ReadEncoder {
                encoder,
                encoder_raw,
                encoder_offset,
            } => [Some(encoder), Some(encoder_raw), Some(encoder_offset)],
            Reply::WriteEncoderOffset { encoder_offset }
            | Reply::WriteZeroRom { encoder_offset } => [Some(encoder_offset), None, None],
            _ => match self.status2() {
                Some(s) => [Some(s.encoder), None, None],
                None => [None, None, None],
            },
        };
        let mut i = 0;
        while i < values.len() {
            if let Some(v) = values[i]
                && let Err(e) = v.check(width)
            {
                return Err(e);
            }
            i += 1;
        }
        Ok(())
    }

    /// Decodes the reply carried by `d` for `command` (DATA\[0\] already read and matched).
    /// Reserved bytes are ignored.
    #[inline]
    pub(crate) fn from_data(command: Command, d: &[u8; 8]) -> Result<Self, ProtocolError> {
        let pid = || PidParams::from_data(d);
        let status1 = || -> Result<Status1, ProtocolError> {
            Ok(Status1 {
                temperature: Temperature::new((d[1] as i8).into())?,
                voltage: Voltage::new(u16_at::<3>(d).into())?,
                error_state: ErrorState::from_raw(d[7]),
            })
        };
        let status2 = || -> Result<Status2, ProtocolError> {
            Ok(Status2 {
                temperature: Temperature::new((d[1] as i8).into())?,
                iq: Iq::new(i16_at::<2>(d).into())?,
                speed: Speed::new(i16_at::<4>(d).into())?,
                encoder: EncoderValue::from_raw(u16_at::<6>(d)),
            })
        };
        let accel = || Accel::new(i32_at::<4>(d).into());
        let offset = || EncoderValue::from_raw(u16_at::<6>(d));
        Ok(match command {
            Command::ReadPid => Reply::ReadPid(pid()),
            Command::WritePidRam => Reply::WritePidRam(pid()),
            Command::WritePidRom => Reply::WritePidRom(pid()),
            Command::ReadAccel => Reply::ReadAccel { accel: accel()? },
            Command::WriteAccelRam => Reply::WriteAccelRam { accel: accel()? },
            Command::ReadEncoder => Reply::ReadEncoder {
                encoder: EncoderValue::from_raw(u16_at::<2>(d)),
                encoder_raw: EncoderValue::from_raw(u16_at::<4>(d)),
                encoder_offset: offset(),
            },
            Command::WriteEncoderOffset => Reply::WriteEncoderOffset {
                encoder_offset: offset(),
            },
            Command::WriteZeroRom => Reply::WriteZeroRom {
                encoder_offset: offset(),
            },
            Command::ReadMultiTurnAngle => Reply::ReadMultiTurnAngle {
                motor_angle: MotorAngle::new(i56_at_1(d))?,
            },
            Command::ReadSingleTurnAngle => Reply::ReadSingleTurnAngle {
                circle_angle: CircleAngle::new(u16_at::<6>(d).into())?,
            },
            Command::ReadStatus1 => Reply::ReadStatus1(status1()?),
            Command::ClearError => Reply::ClearError(status1()?),
            Command::ReadStatus2 => Reply::ReadStatus2(status2()?),
            Command::ReadStatus3 => Reply::ReadStatus3(Status3 {
                i_a: PhaseCurrent::new(i16_at::<2>(d).into())?,
                i_b: PhaseCurrent::new(i16_at::<4>(d).into())?,
                i_c: PhaseCurrent::new(i16_at::<6>(d).into())?,
            }),
            Command::MotorOff => Reply::MotorOff,
            Command::MotorStop => Reply::MotorStop,
            Command::MotorRun => Reply::MotorRun,
            Command::Torque => Reply::Torque(status2()?),
            Command::Speed => Reply::Speed(status2()?),
            Command::Position1 => Reply::Position1(status2()?),
            Command::Position2 => Reply::Position2(status2()?),
            Command::Position3 => Reply::Position3(status2()?),
            Command::Position4 => Reply::Position4(status2()?),
        })
    }
}
