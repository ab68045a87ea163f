//! Replies: what one motor answers (DATA\[0\] = the command byte), in every family.

use crate::bytes::{
    i16_at, i32_at, i56_at_1, put_i16, put_i32, put_i56_at_1, put_u16, put_u32, u16_at, u32_at,
};
use crate::command::Command;
use crate::current::ScaledCurrent;
use crate::dialect::Dialect;
use crate::encoder::{EncoderValue, EncoderWidth};
use crate::error::ProtocolError;
use crate::lk::{LkCircleAngle, LkStatus1};
use crate::status::{ErrorState, PidParams, Status2, Status3, StatusPosition, V161Status1};
use crate::status1::Status1;
use crate::v3::{
    BrakeState, FirmwareDate, FunctionControl, ModelIndex, ModelText, OutputAngle, V3CircleAngle,
    V3ErrorState, V3Function, V3Revision, V3Status1, WatchdogTimeout,
};
use crate::values::{Accel, CircleAngle, MotorAngle, PhaseCurrent, Speed, Temperature, Voltage};

/// A motor's reply: one variant per command, carrying its typed fields, for every family.
/// Decode it with [`Dialect::decode_reply`] or [`Dialect::decode_reply_to`], encode it (the
/// simulator's side) with [`Dialect::encode_reply`].
///
/// Several commands share a layout: 0x30/0x31/0x32 carry [`PidParams`]; 0x9A and 0x9B carry
/// [`Status1`] (in the family's layout); 0x9C and the control commands 0xA1..=0xA6 carry
/// [`Status2`] (the replies to a 0x280 torque frame are 0xA1 replies); 0x80/0x81/0x88 and V3's
/// 0x77/0x78 echo the command. The single-turn angle has one variant per layout.
///
/// ```
/// use rmd_protocol::{Dialect, MotorId, Reply};
/// let frame = rmd_protocol::CanFrame::new(0x142, &[0xA1, 40, 0x00, 0x04, 0x2C, 0x01, 0x00, 0x20])?;
/// let (motor, reply) = Dialect::V161.decode_reply(&frame)?;
/// assert_eq!(motor, MotorId::new(2)?);
/// let s = reply.status2().unwrap();
/// assert_eq!((s.temperature.celsius(), s.iq.amps(), s.speed.dps()), (40.0, 16.5, 300.0));
/// assert_eq!(s.encoder().unwrap().raw(), 0x2000);
/// assert_eq!(Dialect::V161.encode_reply(motor, &reply)?, frame);
/// # Ok::<(), rmd_protocol::ProtocolError>(())
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
        /// `motorAngle`, 0.01°/LSB. v1.61 and LK-TECH: DATA\[1..=7\], 56-bit signed (the spec's
        /// "int64_t" is a slip), the motor's. MyActuator V3: int32 in DATA\[4..=7\], the output
        /// shaft's (V4.3 §2.12, V4.4 §2.11).
        motor_angle: MotorAngle,
    },
    /// 0x94: the single-turn angle, as v1.61 and V4.3 firmware send it.
    ReadSingleTurnAngle {
        /// `circleAngle`, DATA\[6..=7\], u16, 0..=35999 (V4.3 §2.13 for V3).
        circle_angle: CircleAngle,
    },
    /// 0x94 in the LK-TECH layout (u32 in DATA\[4..=7\]; see [`LkCircleAngle`]).
    LkSingleTurnAngle {
        /// `circleAngle`.
        circle_angle: LkCircleAngle,
    },
    /// 0x94 as V4.4 firmware sends it (i32 in DATA\[4..=7\], ±180°; see [`V3CircleAngle`]).
    V3SingleTurnAngle {
        /// The output shaft's single-turn angle.
        circle_angle: V3CircleAngle,
    },
    /// 0x9A: status 1.
    ReadStatus1(Status1),
    /// 0x9B (v1.61, LK-TECH): status 1 after clearing the error flags. Encoded with DATA\[0\]
    /// = 0x9B (the echo of the request); the spec's table shows 0x9A, which
    /// [`Dialect::decode_reply_to`] accepts as the reply to a pending 0x9B.
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
    /// 0xB2 (V3): the firmware version date.
    ReadFirmwareDate(FirmwareDate),
    /// 0xB5 (V3): the motor model, in either manual's form.
    ReadModel(ModelText),
    /// 0xB3 (V3): echo of the protection time set ("the reply frame data is identical to the
    /// command sent", V4.4 §2.32; its example 2 shows zeros instead, a slip of the manual).
    SetWatchdog {
        /// `CanRecvTime_MS`, DATA\[4..=7\].
        timeout: WatchdogTimeout,
    },
    /// 0x20 (V3): echo of the function control command.
    FunctionControl(FunctionControl),
    /// 0x77 (V3): echo of brake release.
    BrakeRelease,
    /// 0x78 (V3): echo of brake lock.
    BrakeLock,
}

impl Status2 {
    /// Reads the status 2 in DATA\[1..=7\] of a reply in `dialect` (DATA\[0\], the command
    /// byte, is the caller's to check): the `iq` in the dialect's scale, the position as the
    /// family reports it. [`ProtocolError::ValueOutOfRange`] for a field outside its range.
    ///
    /// This is the whole decode of a reply a caller has already matched by id and command byte
    /// (the control loop's per-motor fast path); [`Dialect::decode_answer`] does both.
    #[inline]
    pub fn from_data(d: &[u8; 8], dialect: Dialect) -> Result<Self, ProtocolError> {
        Ok(Self {
            temperature: Temperature::new((d[1] as i8).into())?,
            iq: ScaledCurrent::new(i16_at::<2>(d).into(), dialect.iq_scale())?,
            speed: Speed::new(i16_at::<4>(d).into())?,
            position: match dialect {
                Dialect::MyActuatorV3(_) => {
                    StatusPosition::OutputDegrees(OutputAngle::new(i16_at::<6>(d).into())?)
                }
                Dialect::V161 | Dialect::LkV23x(_) => {
                    StatusPosition::Encoder(EncoderValue::from_raw(u16_at::<6>(d)))
                }
            },
        })
    }
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
            Reply::ReadSingleTurnAngle { .. }
            | Reply::LkSingleTurnAngle { .. }
            | Reply::V3SingleTurnAngle { .. } => Command::ReadSingleTurnAngle,
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
            Reply::ReadFirmwareDate(_) => Command::ReadFirmwareDate,
            Reply::ReadModel(_) => Command::ReadModel,
            Reply::SetWatchdog { .. } => Command::SetWatchdog,
            Reply::FunctionControl(_) => Command::FunctionControl,
            Reply::BrakeRelease => Command::BrakeRelease,
            Reply::BrakeLock => Command::BrakeLock,
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

    /// The 8 data bytes of this reply in `dialect`'s layout (reserved bytes 0). The multi-turn
    /// angle must fit `dialect`'s field (checked by [`Dialect::encode_reply`]).
    #[inline]
    pub(crate) fn to_data(self, dialect: Dialect) -> [u8; 8] {
        let mut d = [0u8; 8];
        d[0] = self.command().code();
        match self {
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
            Reply::ReadMultiTurnAngle { motor_angle } => match dialect {
                Dialect::MyActuatorV3(_) => put_i32::<4>(&mut d, motor_angle.raw() as i32),
                Dialect::V161 | Dialect::LkV23x(_) => put_i56_at_1(&mut d, motor_angle.raw()),
            },
            Reply::ReadSingleTurnAngle { circle_angle } => put_u16::<6>(&mut d, circle_angle.raw()),
            Reply::LkSingleTurnAngle { circle_angle } => put_u32::<4>(&mut d, circle_angle.raw()),
            Reply::V3SingleTurnAngle { circle_angle } => put_i32::<4>(&mut d, circle_angle.raw()),
            Reply::ReadStatus1(s) | Reply::ClearError(s) => match s {
                Status1::V161(s) => {
                    d[1] = s.temperature.raw() as u8;
                    put_u16::<3>(&mut d, s.voltage.raw());
                    d[7] = s.error_state.raw();
                }
                Status1::Lk(s) => s.write_to(&mut d),
                Status1::V3(s) => {
                    d[1] = s.temperature.raw() as u8;
                    d[2] = s.mos_temperature.raw() as u8;
                    d[3] = s.brake.raw();
                    put_u16::<4>(&mut d, s.voltage.raw());
                    put_u16::<6>(&mut d, s.error_state.raw());
                }
            },
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
                match s.position {
                    StatusPosition::Encoder(e) => put_u16::<6>(&mut d, e.raw()),
                    StatusPosition::OutputDegrees(a) => put_i16::<6>(&mut d, a.raw()),
                }
            }
            Reply::ReadStatus3(s) => {
                put_i16::<2>(&mut d, s.i_a.raw());
                put_i16::<4>(&mut d, s.i_b.raw());
                put_i16::<6>(&mut d, s.i_c.raw());
            }
            Reply::ReadFirmwareDate(date) => put_u32::<4>(&mut d, date.raw()),
            Reply::ReadModel(ModelText::Whole(chars)) => {
                let mut i = 0;
                while i < 7 {
                    d[1 + i] = chars[i];
                    i += 1;
                }
            }
            Reply::ReadModel(ModelText::Chars { index, chars }) => {
                d[1] = 0x01;
                d[2] = index.get();
                let mut i = 0;
                while i < 5 {
                    d[3 + i] = chars[i];
                    i += 1;
                }
            }
            Reply::SetWatchdog { timeout } => put_u32::<4>(&mut d, timeout.millis()),
            Reply::FunctionControl(f) => {
                d[1] = f.function.index();
                put_u32::<4>(&mut d, f.value);
            }
            Reply::MotorOff
            | Reply::MotorStop
            | Reply::MotorRun
            | Reply::BrakeRelease
            | Reply::BrakeLock => {}
        }
        d
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
                Some(s) => [s.encoder(), None, None],
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

    /// Decodes the reply carried by `d` for `command` in `dialect` (DATA\[0\] already read and
    /// matched; `command` is one of the dialect's and has a reply). Reserved bytes are ignored.
    #[inline]
    pub(crate) fn from_data(
        command: Command,
        d: &[u8; 8],
        dialect: Dialect,
    ) -> Result<Self, ProtocolError> {
        let pid = || PidParams::from_data(d);
        let temperature = |at: usize| Temperature::new((d[at] as i8).into());
        let status1 = || -> Result<Status1, ProtocolError> {
            Ok(match dialect {
                Dialect::V161 => Status1::V161(V161Status1 {
                    temperature: temperature(1)?,
                    voltage: Voltage::new(u16_at::<3>(d).into())?,
                    error_state: ErrorState::from_raw(d[7]),
                }),
                Dialect::LkV23x(_) => Status1::Lk(LkStatus1::from_data(d)?),
                Dialect::MyActuatorV3(_) => Status1::V3(V3Status1 {
                    temperature: temperature(1)?,
                    mos_temperature: temperature(2)?,
                    brake: BrakeState::from_raw(d[3]),
                    voltage: Voltage::new(u16_at::<4>(d).into())?,
                    error_state: V3ErrorState::from_raw(u16_at::<6>(d)),
                }),
            })
        };
        let status2 = || Status2::from_data(d, dialect);
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
                motor_angle: match dialect {
                    Dialect::MyActuatorV3(_) => MotorAngle::new(i32_at::<4>(d).into())?,
                    Dialect::V161 | Dialect::LkV23x(_) => MotorAngle::new(i56_at_1(d))?,
                },
            },
            Command::ReadSingleTurnAngle => match dialect {
                Dialect::LkV23x(_) => Reply::LkSingleTurnAngle {
                    circle_angle: LkCircleAngle::new(u32_at::<4>(d).into())?,
                },
                Dialect::MyActuatorV3(firmware) if firmware.revision() == V3Revision::V4_4 => {
                    Reply::V3SingleTurnAngle {
                        circle_angle: V3CircleAngle::new(i32_at::<4>(d).into())?,
                    }
                }
                Dialect::V161 | Dialect::MyActuatorV3(_) => Reply::ReadSingleTurnAngle {
                    circle_angle: CircleAngle::new(u16_at::<6>(d).into())?,
                },
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
            Command::ReadFirmwareDate => {
                Reply::ReadFirmwareDate(FirmwareDate::from_raw(u32_at::<4>(d)))
            }
            Command::ReadModel => Reply::ReadModel(if d[1] == 0x01 {
                let mut chars = [0u8; 5];
                chars.copy_from_slice(&d[3..]);
                ModelText::Chars {
                    index: ModelIndex::new(d[2])?,
                    chars,
                }
            } else {
                let mut chars = [0u8; 7];
                chars.copy_from_slice(&d[1..]);
                ModelText::Whole(chars)
            }),
            Command::SetWatchdog => Reply::SetWatchdog {
                timeout: WatchdogTimeout::from_millis(u32_at::<4>(d)),
            },
            Command::FunctionControl => Reply::FunctionControl(FunctionControl {
                function: V3Function::from_index(d[1])?,
                value: u32_at::<4>(d),
            }),
            Command::BrakeRelease => Reply::BrakeRelease,
            Command::BrakeLock => Reply::BrakeLock,
            // 0x76 has no reply (V4.3 §2.26, V4.4 §2.27).
            Command::Reset => {
                return Err(ProtocolError::UnsupportedCommand {
                    command,
                    family: dialect.family(),
                });
            }
        })
    }
}
