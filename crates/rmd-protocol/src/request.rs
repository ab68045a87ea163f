//! Requests: what the host sends to one motor (CAN ID 0x140 + id), in every family.

use crate::bytes::{i16_at, i32_at, put_i16, put_i32, put_u16, put_u32, u16_at, u32_at};
use crate::command::Command;
use crate::current::ScaledCurrent;
use crate::dialect::Dialect;
use crate::encoder::{EncoderValue, EncoderWidth};
use crate::error::ProtocolError;
use crate::ids::MotorId;
use crate::mit::MitCommand;
use crate::multi::MultiTorque;
use crate::status::{PidParams, SpinDirection};
use crate::v3::{
    FunctionControl, MaxTorquePercent, ModelIndex, ModelPart, V3Function, WatchdogTimeout,
};
use crate::values::{Accel, AngleControl, MaxSpeed, SingleTurnAngle, SpeedControl};

/// A request to one motor: one variant per command, carrying its typed fields, for every
/// family (a family takes the variants of its [`commands`](Dialect::commands); encoding
/// another is [`ProtocolError::UnsupportedCommand`]). Encode it with [`Dialect::encode`].
///
/// Where families share a command, its request layout is the same in each (only the current's
/// scale differs, and the current carries its scale). Reserved ("NULL") bytes are sent as 0
/// and ignored on decoding (see the crate docs).
///
/// ```
/// use rmd_protocol::{Dialect, IqControl, MotorId, Request};
/// let req = Request::Torque { iq_control: IqControl::new(100)?.into() };
/// let frame = Dialect::V161.encode(MotorId::new(1)?, &req)?;
/// assert_eq!(frame.to_string(), "141#A100000064000000");
/// # Ok::<(), rmd_protocol::ProtocolError>(())
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
    /// 0xA1: torque closed loop (V3: V4.3 §2.19, V4.4 §2.18; "this command cannot open the
    /// brake directly": release it with 0x77 first).
    Torque {
        /// `iqControl`, DATA\[4..=5\], in the family's scale.
        iq_control: ScaledCurrent,
    },
    /// 0xA2: speed closed loop (V3: the output shaft's speed, V4.3 §2.20, V4.4 §2.19).
    Speed {
        /// `speedControl`, DATA\[4..=7\], 0.01 dps/LSB.
        speed_control: SpeedControl,
        /// V3's `maxTorque`, DATA\[1\] (reserved in v1.61 and LK-TECH: must be
        /// [`MaxTorquePercent::NONE`] there).
        max_torque: MaxTorquePercent,
    },
    /// 0xA3: position closed loop 1 (multi-turn).
    Position1 {
        /// `angleControl`, DATA\[4..=7\] (the spec's "Data" column says DATA\[3..6\]: a slip).
        angle_control: AngleControl,
    },
    /// 0xA4: position closed loop 2 (multi-turn, speed limit); V3's absolute position command
    /// (the output shaft's, V4.3 §2.21, V4.4 §2.20).
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
    /// 0xB2 (V3): read the firmware version date.
    ReadFirmwareDate,
    /// 0xB5 (V3): read the motor model, whole (V4.3) or five characters at a time (V4.4).
    ReadModel {
        /// Which part: DATA\[1..=2\].
        part: ModelPart,
    },
    /// 0xB3 (V3): set the communication-interruption protection time (ROM).
    SetWatchdog {
        /// `CanRecvTime_MS`, DATA\[4..=7\].
        timeout: WatchdogTimeout,
    },
    /// 0x20 (V3): function control.
    FunctionControl(FunctionControl),
    /// 0x76 (V3): system reset (no reply).
    Reset,
    /// 0x77 (V3): release the brake.
    BrakeRelease,
    /// 0x78 (V3): lock the brake.
    BrakeLock,
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
            Request::ReadFirmwareDate => Command::ReadFirmwareDate,
            Request::ReadModel { .. } => Command::ReadModel,
            Request::SetWatchdog { .. } => Command::SetWatchdog,
            Request::FunctionControl(_) => Command::FunctionControl,
            Request::Reset => Command::Reset,
            Request::BrakeRelease => Command::BrakeRelease,
            Request::BrakeLock => Command::BrakeLock,
        }
    }

    /// Whether sending it writes the motor's flash (0x19, 0x32, V3's 0xB3, and V3's 0x20 for
    /// the functions that save to ROM): a user-facing tool must ask first.
    pub const fn writes_flash(&self) -> bool {
        match self {
            Request::FunctionControl(f) => f.function.writes_flash(),
            other => other.command().writes_flash(),
        }
    }

    /// The request of a command without fields (`read-*`, `clear-error`, `motor-*`,
    /// `write-zero-rom`, V3's `reset` and `brake-*`), or `None` for a command that carries
    /// fields.
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
            Command::ReadFirmwareDate => Request::ReadFirmwareDate,
            Command::Reset => Request::Reset,
            Command::BrakeRelease => Request::BrakeRelease,
            Command::BrakeLock => Request::BrakeLock,
            _ => return None,
        })
    }

    /// The 8 data bytes of this request (reserved bytes 0): the layout every family that has
    /// the command shares. [`Dialect::encode`] checks the family first.
    #[inline]
    pub(crate) const fn to_data(self) -> [u8; 8] {
        let mut d = [0u8; 8];
        d[0] = self.command().code();
        match self {
            Request::WritePidRam(p) | Request::WritePidRom(p) => p.write_to(&mut d),
            Request::WriteAccelRam { accel } => put_i32::<4>(&mut d, accel.raw()),
            Request::WriteEncoderOffset { encoder_offset } => {
                put_u16::<6>(&mut d, encoder_offset.raw())
            }
            Request::Torque { iq_control } => put_i16::<4>(&mut d, iq_control.raw()),
            Request::Speed {
                speed_control,
                max_torque,
            } => {
                d[1] = max_torque.raw();
                put_i32::<4>(&mut d, speed_control.raw());
            }
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
            Request::ReadModel {
                part: ModelPart::Chars(index),
            } => {
                d[1] = 0x01;
                d[2] = index.get();
            }
            Request::SetWatchdog { timeout } => put_u32::<4>(&mut d, timeout.millis()),
            Request::FunctionControl(f) => {
                d[1] = f.function.index();
                put_u32::<4>(&mut d, f.value);
            }
            _ => {}
        }
        d
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

    /// Decodes the request carried by `d` for `command` (DATA\[0\] already read, and a
    /// command of `dialect`). Reserved bytes are ignored.
    #[inline]
    pub(crate) fn from_data(
        command: Command,
        d: &[u8; 8],
        dialect: Dialect,
    ) -> Result<Self, ProtocolError> {
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
                iq_control: ScaledCurrent::new(i16_at::<4>(d).into(), dialect.iq_control_scale())?,
            },
            Command::Speed => Request::Speed {
                speed_control: SpeedControl::new(i32_at::<4>(d).into())?,
                max_torque: match dialect {
                    Dialect::MyActuatorV3(_) => MaxTorquePercent::new(d[1]),
                    Dialect::V161 | Dialect::LkV23x(_) => MaxTorquePercent::NONE,
                },
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
            Command::ReadFirmwareDate => Request::ReadFirmwareDate,
            Command::ReadModel => Request::ReadModel {
                part: if d[1] == 0x01 {
                    ModelPart::Chars(ModelIndex::new(d[2])?)
                } else {
                    ModelPart::Whole
                },
            },
            Command::SetWatchdog => Request::SetWatchdog {
                timeout: WatchdogTimeout::from_millis(u32_at::<4>(d)),
            },
            Command::FunctionControl => Request::FunctionControl(FunctionControl {
                function: V3Function::from_index(d[1])?,
                value: u32_at::<4>(d),
            }),
            Command::Reset => Request::Reset,
            Command::BrakeRelease => Request::BrakeRelease,
            Command::BrakeLock => Request::BrakeLock,
        })
    }
}

/// A decoded host frame: to one motor, or one of the frames that are not single-motor requests.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum DecodedRequest {
    /// A request on a single-motor ID (`0x140 + id`).
    Single {
        /// The motor addressed.
        motor: MotorId,
        /// The request.
        request: Request,
    },
    /// The v1.61 / LK-TECH 0x280 frame: a torque current for each of motors 1..=4.
    Multi(MultiTorque),
    /// The MyActuator V3 0x280 frame: one request every motor on the bus executes, each
    /// answering on its own `0x240 + id` (V4.3 §3, V4.4 §3).
    Broadcast(Request),
    /// A MyActuator V3 motion-mode command on `0x400 + id`.
    Mit {
        /// The motor addressed.
        motor: MotorId,
        /// The command.
        command: MitCommand,
    },
}
