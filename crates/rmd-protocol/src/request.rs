//! Requests: what the host sends to one motor (CAN ID 0x140 + id).

use crate::command::Command;
use crate::encoder::{EncoderValue, EncoderWidth};
use crate::error::ProtocolError;
use crate::frame::CanFrame;
use crate::ids::MotorId;
use crate::status::{PidParams, SpinDirection};
use crate::values::{Accel, AngleControl, IqControl, MaxSpeed, SingleTurnAngle, SpeedControl};
use crate::wire::{i16_at, i32_at, put_i16, put_i32, put_u16, u16_at};

/// A request to one motor: one variant per command, carrying its typed fields.
///
/// Reserved ("NULL") bytes are sent as 0 and ignored on decoding (see the crate docs).
///
/// ```
/// use rmd_protocol::{IqControl, MotorId, Request};
/// let req = Request::Torque { iq_control: IqControl::new(100).unwrap() };
/// let frame = req.encode(MotorId::new(1).unwrap());
/// assert_eq!(frame.to_string(), "141#A100000064000000");
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Request {
    /// 0x30: read the PID parameters.
    ReadPid,
    /// 0x31: write the PID parameters to RAM (DATA\[2..=7\]).
    WritePidRam(PidParams),
    /// 0x32: write the PID parameters to ROM (DATA\[2..=7\]). Wears the flash.
    WritePidRom(PidParams),
    /// 0x33: read the acceleration.
    ReadAccel,
    /// 0x34: write the acceleration to RAM.
    WriteAccelRam {
        /// `Accel`, DATA\[4..=7\] (the spec's field descriptions for 0x34 are slips; see [`Accel`]).
        accel: Accel,
    },
    /// 0x90: read the encoder.
    ReadEncoder,
    /// 0x91: write the encoder offset.
    WriteEncoderOffset {
        /// `encoderOffset`, DATA\[6..=7\].
        encoder_offset: EncoderValue,
    },
    /// 0x19: write the current position to ROM as the motor zero. Wears the flash; takes effect
    /// after a power cycle.
    WriteZeroRom,
    /// 0x92: read the multi-turn angle.
    ReadMultiTurnAngle,
    /// 0x94: read the single-turn angle.
    ReadSingleTurnAngle,
    /// 0x9A: read status 1 and the error flags.
    ReadStatus1,
    /// 0x9B: clear the error flags.
    ClearError,
    /// 0x9C: read status 2.
    ReadStatus2,
    /// 0x9D: read status 3.
    ReadStatus3,
    /// 0x80: motor off.
    MotorOff,
    /// 0x81: motor stop.
    MotorStop,
    /// 0x88: motor run.
    MotorRun,
    /// 0xA1: torque closed loop.
    Torque {
        /// `iqControl`, DATA\[4..=5\].
        iq_control: IqControl,
    },
    /// 0xA2: speed closed loop.
    Speed {
        /// `speedControl`, DATA\[4..=7\].
        speed_control: SpeedControl,
    },
    /// 0xA3: position closed loop 1 (multi-turn).
    Position1 {
        /// `angleControl`, DATA\[4..=7\] (the spec's "Data" column says DATA\[3..6\]: a slip).
        angle_control: AngleControl,
    },
    /// 0xA4: position closed loop 2 (multi-turn, speed limit).
    Position2 {
        /// `maxSpeed`, DATA\[2..=3\] (the spec's "Data" column says DATA\[3..4\]: a slip).
        max_speed: MaxSpeed,
        /// `angleControl`, DATA\[4..=7\] (the spec's "Data" column says DATA\[3..6\]: a slip).
        angle_control: AngleControl,
    },
    /// 0xA5: position closed loop 3 (single-turn, direction).
    Position3 {
        /// `spinDirection`, DATA\[1\].
        spin_direction: SpinDirection,
        /// `angleControl`, DATA\[4..=5\].
        angle_control: SingleTurnAngle,
    },
    /// 0xA6: position closed loop 4 (single-turn, direction, speed limit).
    Position4 {
        /// `spinDirection`, DATA\[1\].
        spin_direction: SpinDirection,
        /// `maxSpeed`, DATA\[2..=3\].
        max_speed: MaxSpeed,
        /// `angleControl`, DATA\[4..=5\].
        angle_control: SingleTurnAngle,
    },
}

impl Request {
    /// The command this request carries.
    #[inline]
    pub const fn command(&self) -> Command {
        match self {
            Request::ReadPid => Command::ReadPid,
            Request::WritePidRam(_) => Command::WritePidRam,
            Request::WritePidRom(_) => Command::WritePidRom,
            Request::ReadAccel => Command::ReadAccel,
            Request::WriteAccelRam { .. } => Command::WriteAccelRam,
            Request::ReadEncoder => Command::ReadEncoder,
            Request::WriteEncoderOffset { .. } => Command::WriteEncoderOffset,
            Request::WriteZeroRom => Command::WriteZeroRom,
            Request::ReadMultiTurnAngle => Command::ReadMultiTurnAngle,
            Request::ReadSingleTurnAngle => Command::ReadSingleTurnAngle,
            Request::ReadStatus1 => Command::ReadStatus1,
            Request::ClearError => Command::ClearError,
            Request::ReadStatus2 => Command::ReadStatus2,
            Request::ReadStatus3 => Command::ReadStatus3,
            Request::MotorOff => Command::MotorOff,
            Request::MotorStop => Command::MotorStop,
            Request::MotorRun => Command::MotorRun,
            Request::Torque { .. } => Command::Torque,
            Request::Speed { .. } => Command::Speed,
            Request::Position1 { .. } => Command::Position1,
            Request::Position2 { .. } => Command::Position2,
            Request::Position3 { .. } => Command::Position3,
            Request::Position4 { .. } => Command::Position4,
        }
    }

    /// The request of a command without fields (`read-*`, `clear-error`, `motor-*`,
    /// `write-zero-rom`), or `None` for a command that carries fields.
    pub const fn without_fields(command: Command) -> Option<Self> {
        Some(match command {
            Command::ReadPid => Request::ReadPid,
            Command::ReadAccel => Request::ReadAccel,
            Command::ReadEncoder => Request::ReadEncoder,
            Command::WriteZeroRom => Request::WriteZeroRom,
            Command::ReadMultiTurnAngle => Request::ReadMultiTurnAngle,
            Command::ReadSingleTurnAngle => Request::ReadSingleTurnAngle,
            Command::ReadStatus1 => Request::ReadStatus1,
            Command::ClearError => Request::ClearError,
            Command::ReadStatus2 => Request::ReadStatus2,
            Command::ReadStatus3 => Request::ReadStatus3,
            Command::MotorOff => Request::MotorOff,
            Command::MotorStop => Request::MotorStop,
            Command::MotorRun => Request::MotorRun,
            _ => return None,
        })
    }

    /// The 8 data bytes of this request (reserved bytes 0).
    #[inline]
    pub const fn to_data(&self) -> [u8; 8] {
        let mut d = [0u8; 8];
        d[0] = self.command().code();
        match *self {
            Request::WritePidRam(p) | Request::WritePidRom(p) => p.write_to(&mut d),
            Request::WriteAccelRam { accel } => put_i32::<4>(&mut d, accel.raw()),
            Request::WriteEncoderOffset { encoder_offset } => {
                put_u16::<6>(&mut d, encoder_offset.raw())
            }
            Request::Torque { iq_control } => put_i16::<4>(&mut d, iq_control.raw()),
            Request::Speed { speed_control } => put_i32::<4>(&mut d, speed_control.raw()),
            Request::Position1 { angle_control } => put_i32::<4>(&mut d, angle_control.raw()),
            Request::Position2 {
                max_speed,
                angle_control,
            } => {
                put_u16::<2>(&mut d, max_speed.raw());
                put_i32::<4>(&mut d, angle_control.raw());
            }
            Request::Position3 {
                spin_direction,
                angle_control,
            } => {
                d[1] = spin_direction.raw();
                put_u16::<4>(&mut d, angle_control.raw());
            }
            Request::Position4 {
                spin_direction,
                max_speed,
                angle_control,
            } => {
                d[1] = spin_direction.raw();
                put_u16::<2>(&mut d, max_speed.raw());
                put_u16::<4>(&mut d, angle_control.raw());
            }
            _ => {}
        }
        d
    }

    /// The frame that sends this request to `motor` (CAN ID 0x140 + id, DLC 8).
    #[inline]
    pub const fn encode(&self, motor: MotorId) -> CanFrame {
        CanFrame::rmd(motor.can_id(), self.to_data())
    }

    /// Checks the request's encoder value (`encoder_offset` of 0x91) against the motor's encoder
    /// width; requests without an encoder value always pass.
    pub const fn check_encoder_width(&self, width: EncoderWidth) -> Result<(), ProtocolError> {
        if let Request::WriteEncoderOffset { encoder_offset } = *self
            && let Err(e) = encoder_offset.check(width)
        {
            return Err(e);
        }
        Ok(())
    }

    /// Decodes the request carried by `d` for `command` (DATA\[0\] already read). Reserved
    /// bytes are ignored.
    #[inline]
    pub(crate) fn from_data(command: Command, d: &[u8; 8]) -> Result<Self, ProtocolError> {
        let pid = || PidParams::from_data(d);
        Ok(match command {
            Command::ReadPid => Request::ReadPid,
            Command::WritePidRam => Request::WritePidRam(pid()),
            Command::WritePidRom => Request::WritePidRom(pid()),
            Command::ReadAccel => Request::ReadAccel,
            Command::WriteAccelRam => Request::WriteAccelRam {
                accel: Accel::new(i32_at::<4>(d).into())?,
            },
            Command::ReadEncoder => Request::ReadEncoder,
            Command::WriteEncoderOffset => Request::WriteEncoderOffset {
                encoder_offset: EncoderValue::from_raw(u16_at::<6>(d)),
            },
            Command::WriteZeroRom => Request::WriteZeroRom,
            Command::ReadMultiTurnAngle => Request::ReadMultiTurnAngle,
            Command::ReadSingleTurnAngle => Request::ReadSingleTurnAngle,
            Command::ReadStatus1 => Request::ReadStatus1,
            Command::ClearError => Request::ClearError,
            Command::ReadStatus2 => Request::ReadStatus2,
            Command::ReadStatus3 => Request::ReadStatus3,
            Command::MotorOff => Request::MotorOff,
            Command::MotorStop => Request::MotorStop,
            Command::MotorRun => Request::MotorRun,
            Command::Torque => Request::Torque {
                iq_control: IqControl::new(i16_at::<4>(d).into())?,
            },
            Command::Speed => Request::Speed {
                speed_control: SpeedControl::new(i32_at::<4>(d).into())?,
            },
            Command::Position1 => Request::Position1 {
                angle_control: AngleControl::new(i32_at::<4>(d).into())?,
            },
            Command::Position2 => Request::Position2 {
                max_speed: MaxSpeed::new(u16_at::<2>(d).into())?,
                angle_control: AngleControl::new(i32_at::<4>(d).into())?,
            },
            Command::Position3 => Request::Position3 {
                spin_direction: SpinDirection::from_raw(d[1])?,
                angle_control: SingleTurnAngle::new(u16_at::<4>(d).into())?,
            },
            Command::Position4 => Request::Position4 {
                spin_direction: SpinDirection::from_raw(d[1])?,
                max_speed: MaxSpeed::new(u16_at::<2>(d).into())?,
                angle_control: SingleTurnAngle::new(u16_at::<4>(d).into())?,
            },
        })
    }
}
