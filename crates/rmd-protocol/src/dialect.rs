//! Dialects: each protocol family rmd-rt speaks as one value.

use core::fmt;
use core::str::FromStr;

use crate::command::Command;
use crate::family::ProtocolFamily;
use crate::ids::{MotorId, SINGLE_MOTOR_BASE_ID, V3_REPLY_BASE_ID};
use crate::names::NameError;
use crate::scale::CurrentScale;
use crate::v3::V3Firmware;

/// An LK-TECH motor series whose current scale is known.
///
/// The series is part of the motor's model name (MF4005, MG4005E-i10, ...). LK-TECH CAN protocol
/// V2.35, torque closed-loop command (0xA1): "iqControl ... range -2048~2048, corresponding MF
/// motor actual torque current range is -16.5A~16.5A, corresponding MG motor actual torque current
/// range is -33A~33A" (quoted in github.com/aj3944/step-pyjoco `embedded/src/commands.py` and
/// github.com/Alliance-Algorithm/librmcs `librmcs/device/lk_motor.hpp`).
///
/// Not covered: MS motors (open-loop power control: their 0xA1 is not implemented and their
/// replies carry an output power instead of a current, same document), and MH motors (the
/// document allows 0xA1 on them but gives no scale).
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LkSeries {
    /// MF series: ±16.5 A over ±2048.
    Mf,
    /// MG series (geared): ±33 A over ±2048.
    Mg,
}

impl LkSeries {
    /// Every series.
    pub const ALL: [Self; 2] = [Self::Mf, Self::Mg];

    /// The stable name, `mf` or `mg`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Mf => "mf",
            Self::Mg => "mg",
        }
    }

    /// The series named `name` (`mf` or `mg`), else [`NameError::LkSeries`].
    pub fn from_name(name: &str) -> Result<Self, NameError> {
        Self::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or(NameError::LkSeries)
    }
}

impl fmt::Display for LkSeries {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Mf => "MF",
            Self::Mg => "MG",
        })
    }
}

impl FromStr for LkSeries {
    type Err = NameError;
    fn from_str(s: &str) -> Result<Self, NameError> {
        Self::from_name(s)
    }
}

/// Dialects: each protocol family rmd-rt speaks as one value, with what its layouts and scales
/// depend on (LK-TECH's motor series, MyActuator V3's firmware date and maximum torque).
///
/// v1.61 is the default everywhere. LK-TECH V2.3x keeps v1.61's identifiers, command bytes and
/// most layouts, but differs in the torque current scale of 0xA1, 0x280 and every status-2
/// reply (which depends on the motor series, [`LkSeries`]: MF ±16.5 A, MG ±33 A, over ±2048),
/// the 0x9A / 0x9B status-1 layout ([`LkStatus1`](crate::LkStatus1)) and the 0x94 single-turn
/// angle (u32 in DATA\[4..=7\]). MyActuator V3 replies on `0x240 + id`, scales currents at
/// 0.01 A, reports the output shaft, has its own commands and its own meaning of 0x280 (one
/// command for every motor), and a motion mode on `0x400 + id`; what depends on its firmware
/// date is [`V3Firmware`]. The codec itself (`encode`, `decode_*`) is `impl Dialect` in the
/// `codec` module.
///
/// ```
/// use rmd_protocol::{CurrentScale, Dialect, LkSeries, ProtocolFamily, V3Firmware};
/// let mf = Dialect::LkV23x(LkSeries::Mf);
/// assert_eq!(mf.family(), ProtocolFamily::LkV23x);
/// assert_eq!(mf.iq_control_scale(), CurrentScale::LK_MF_IQ_CONTROL);
/// assert_eq!(Dialect::default(), Dialect::V161);
/// assert_eq!(Dialect::from_names("lk-v2.3x", Some("mg")), Ok(Dialect::LkV23x(LkSeries::Mg)));
/// assert_eq!(Dialect::from_names("v1.61", None), Ok(Dialect::V161));
/// let v3 = Dialect::from_names("myactuator-v3", None)?;
/// assert_eq!(v3, Dialect::MyActuatorV3(V3Firmware::default()));
/// assert_eq!(v3.iq_control_scale(), CurrentScale::MYACTUATOR_V3_IQ_CONTROL);
/// # Ok::<(), rmd_protocol::NameError>(())
/// ```
///
/// A protocol family as rmd-rt speaks it, with what its layouts and scales depend on: the one
/// type of the codec (see the crate docs). [`Dialect::V161`] is the default.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// GYEMS / MyActuator RMD v1.61.
    #[default]
    V161,
    /// LK-TECH V2.3x for motors of the given series.
    LkV23x(LkSeries),
    /// MyActuator V3 (protocol manuals V4.2..=V4.4) of the given firmware.
    MyActuatorV3(V3Firmware),
}

/// The 23 commands of v1.61, which LK-TECH V2.3x shares.
const V161_COMMANDS: [Command; 23] = [
    Command::ReadPid,
    Command::WritePidRam,
    Command::WritePidRom,
    Command::ReadAccel,
    Command::WriteAccelRam,
    Command::ReadEncoder,
    Command::WriteEncoderOffset,
    Command::WriteZeroRom,
    Command::ReadMultiTurnAngle,
    Command::ReadSingleTurnAngle,
    Command::ReadStatus1,
    Command::ClearError,
    Command::ReadStatus2,
    Command::ReadStatus3,
    Command::MotorOff,
    Command::MotorStop,
    Command::MotorRun,
    Command::Torque,
    Command::Speed,
    Command::Position1,
    Command::Position2,
    Command::Position3,
    Command::Position4,
];

/// The MyActuator V3 commands rmd-rt implements (V4.3 / V4.4 §2; 0xA4 is V3's absolute
/// position command, the layout of v1.61's position 2).
const V3_COMMANDS: [Command; 16] = [
    Command::ReadMultiTurnAngle,
    Command::ReadSingleTurnAngle,
    Command::ReadStatus1,
    Command::ReadStatus2,
    Command::MotorOff,
    Command::MotorStop,
    Command::Torque,
    Command::Speed,
    Command::Position2,
    Command::ReadFirmwareDate,
    Command::ReadModel,
    Command::SetWatchdog,
    Command::FunctionControl,
    Command::Reset,
    Command::BrakeRelease,
    Command::BrakeLock,
];

impl Dialect {
    /// The family this dialect belongs to.
    pub const fn family(self) -> ProtocolFamily {
        match self {
            Self::V161 => ProtocolFamily::V161,
            Self::LkV23x(_) => ProtocolFamily::LkV23x,
            Self::MyActuatorV3(_) => ProtocolFamily::MyActuatorV3,
        }
    }

    /// The protocol's stable name, `v1.61`, `lk-v2.3x` or `myactuator-v3` (the series and
    /// the firmware are not part of it).
    pub const fn name(self) -> &'static str {
        self.family().name()
    }

    /// The LK-TECH motor series, for the LK dialect.
    pub const fn lk_series(self) -> Option<LkSeries> {
        match self {
            Self::LkV23x(s) => Some(s),
            Self::V161 | Self::MyActuatorV3(_) => None,
        }
    }

    /// The MyActuator V3 firmware, for the V3 dialect.
    pub const fn v3_firmware(self) -> Option<V3Firmware> {
        match self {
            Self::MyActuatorV3(f) => Some(f),
            Self::V161 | Self::LkV23x(_) => None,
        }
    }

    /// The dialect for a protocol name (`v1.61`, `lk-v2.3x`, `myactuator-v3`) and, for
    /// `lk-v2.3x`, the LK motor series (`mf`, `mg`); `myactuator-v3` has no firmware date yet
    /// (see [`V3Firmware`]). Errors: [`NameError::Dialect`] for another protocol name,
    /// [`NameError::MissingLkSeries`] for `lk-v2.3x` without a series, [`NameError::LkSeries`]
    /// for an unknown series. A series given with another protocol is ignored.
    pub fn from_names(protocol: &str, lk_series: Option<&str>) -> Result<Self, NameError> {
        match ProtocolFamily::from_name(protocol) {
            Ok(ProtocolFamily::V161) => Ok(Self::V161),
            Ok(ProtocolFamily::LkV23x) => match lk_series {
                Some(s) => Ok(Self::LkV23x(LkSeries::from_name(s)?)),
                None => Err(NameError::MissingLkSeries),
            },
            Ok(ProtocolFamily::MyActuatorV3) => Ok(Self::MyActuatorV3(V3Firmware::default())),
            _ => Err(NameError::Dialect),
        }
    }

    /// The scale of `iqControl` (0xA1, and the v1.61 / LK-TECH 0x280 frame) in this dialect.
    pub const fn iq_control_scale(self) -> CurrentScale {
        match self {
            Self::V161 => CurrentScale::V161_IQ_CONTROL,
            Self::LkV23x(LkSeries::Mf) => CurrentScale::LK_MF_IQ_CONTROL,
            Self::LkV23x(LkSeries::Mg) => CurrentScale::LK_MG_IQ_CONTROL,
            Self::MyActuatorV3(_) => CurrentScale::MYACTUATOR_V3_IQ_CONTROL,
        }
    }

    /// The scale of `iq` in the status-2 replies (0x9C, 0xA1..=0xA6) in this dialect.
    pub const fn iq_scale(self) -> CurrentScale {
        match self {
            Self::V161 => CurrentScale::V161_IQ,
            Self::LkV23x(LkSeries::Mf) => CurrentScale::LK_MF_IQ,
            Self::LkV23x(LkSeries::Mg) => CurrentScale::LK_MG_IQ,
            Self::MyActuatorV3(_) => CurrentScale::MYACTUATOR_V3_IQ,
        }
    }

    /// The single-motor commands of this dialect (as rmd-rt implements it).
    pub const fn commands(self) -> &'static [Command] {
        match self {
            Self::V161 | Self::LkV23x(_) => &V161_COMMANDS,
            Self::MyActuatorV3(_) => &V3_COMMANDS,
        }
    }

    /// Whether `command` is one of [`commands`](Self::commands).
    #[inline]
    pub const fn supports(self, command: Command) -> bool {
        let v3_only = matches!(
            command,
            Command::ReadFirmwareDate
                | Command::ReadModel
                | Command::SetWatchdog
                | Command::FunctionControl
                | Command::Reset
                | Command::BrakeRelease
                | Command::BrakeLock
        );
        match self {
            Self::V161 | Self::LkV23x(_) => !v3_only,
            Self::MyActuatorV3(_) => {
                v3_only
                    || matches!(
                        command,
                        Command::ReadMultiTurnAngle
                            | Command::ReadSingleTurnAngle
                            | Command::ReadStatus1
                            | Command::ReadStatus2
                            | Command::MotorOff
                            | Command::MotorStop
                            | Command::Torque
                            | Command::Speed
                            | Command::Position2
                    )
            }
        }
    }

    /// Whether a 0x280 frame is a per-motor torque frame in this dialect (v1.61, LK-TECH);
    /// `false` for MyActuator V3, where it is one command for every motor.
    pub const fn multi_torque_is_per_motor_torque(self) -> bool {
        self.family().multi_torque_is_per_motor_torque()
    }

    /// Whether the speeds and angles of status 2 are the output shaft's (MyActuator V3) rather
    /// than the motor's (v1.61, LK-TECH).
    pub const fn reports_output_shaft(self) -> bool {
        matches!(self, Self::MyActuatorV3(_))
    }

    /// The identifier `motor` replies on: `0x140 + id` (v1.61, LK-TECH) or `0x240 + id` (V3).
    pub const fn reply_id(self, motor: MotorId) -> u16 {
        match self {
            Self::V161 | Self::LkV23x(_) => SINGLE_MOTOR_BASE_ID + motor.get() as u16,
            Self::MyActuatorV3(_) => V3_REPLY_BASE_ID + motor.get() as u16,
        }
    }
}

impl ProtocolFamily {
    /// The identifier `motor` replies on in this family; `None` for an unknown family.
    pub const fn reply_can_id(self, motor: MotorId) -> Option<u16> {
        match self.reply_base_id() {
            Some(base) => Some(base + motor.get() as u16),
            None => None,
        }
    }
}

/// Formats as `v1.61`, `lk-v2.3x (MF)`, `myactuator-v3` or `myactuator-v3 (firmware
/// 2025070202)`.
impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::V161 => f.write_str("v1.61"),
            Self::LkV23x(s) => write!(f, "lk-v2.3x ({s})"),
            Self::MyActuatorV3(V3Firmware {
                date: Some(date), ..
            }) => write!(f, "myactuator-v3 (firmware {date})"),
            Self::MyActuatorV3(_) => f.write_str("myactuator-v3"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        assert_eq!(Dialect::from_names("v1.61", Some("mf")), Ok(Dialect::V161));
        assert_eq!(
            Dialect::from_names("lk-v2.3x", Some("mf")),
            Ok(Dialect::LkV23x(LkSeries::Mf))
        );
        assert_eq!(
            Dialect::from_names("lk-v2.3x", None),
            Err(NameError::MissingLkSeries)
        );
        assert_eq!(
            Dialect::from_names("lk-v2.3x", Some("ms")),
            Err(NameError::LkSeries)
        );
        assert_eq!(
            Dialect::from_names("myactuator-v3", None),
            Ok(Dialect::MyActuatorV3(V3Firmware::default()))
        );
        assert_eq!(
            Dialect::from_names("unknown", None),
            Err(NameError::Dialect)
        );
        assert_eq!(Dialect::LkV23x(LkSeries::Mg).name(), "lk-v2.3x");
        assert_eq!("mg".parse(), Ok(LkSeries::Mg));
    }

    #[test]
    fn scales_follow_the_series() {
        assert_eq!(Dialect::V161.iq_scale(), CurrentScale::V161_IQ);
        assert_eq!(
            Dialect::LkV23x(LkSeries::Mf).iq_scale(),
            CurrentScale::LK_MF_IQ
        );
        assert_eq!(
            Dialect::LkV23x(LkSeries::Mg).iq_control_scale(),
            CurrentScale::LK_MG_IQ_CONTROL
        );
    }
}

#[cfg(test)]
mod command_sets {
    use super::*;

    #[test]
    fn reply_ids() {
        let m = MotorId::new(3).unwrap();
        assert_eq!(ProtocolFamily::V161.reply_can_id(m), Some(0x143));
        assert_eq!(ProtocolFamily::LkV23x.reply_can_id(m), Some(0x143));
        assert_eq!(ProtocolFamily::MyActuatorV3.reply_can_id(m), Some(0x243));
        assert_eq!(ProtocolFamily::Unknown.reply_can_id(m), None);
    }

    #[test]
    fn every_command_belongs_to_a_family_and_bytes_are_unique() {
        for c in Command::ALL {
            assert!(
                Dialect::V161.supports(c)
                    || Dialect::MyActuatorV3(V3Firmware::default()).supports(c),
                "{c}"
            );
            assert_eq!(Command::from_code(c.code()), Some(c));
        }
        assert_eq!(Dialect::V161.commands(), &Command::ALL[..23]);
        assert!(!Dialect::V161.supports(Command::ReadFirmwareDate));
        assert!(!Dialect::MyActuatorV3(V3Firmware::default()).supports(Command::ClearError));
        for d in [Dialect::V161, Dialect::MyActuatorV3(V3Firmware::default())] {
            for c in Command::ALL {
                assert_eq!(d.supports(c), d.commands().contains(&c), "{d} {c}");
            }
        }
    }
}
