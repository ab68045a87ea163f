//! Dialects: the protocol variants rmd-rt can speak, with the scales each one uses.
//!
//! A [`Dialect`] is a [`ProtocolFamily`] rmd-rt can drive, plus whatever the scales depend on.
//! v1.61 is the default everywhere. LK-TECH V2.3x keeps v1.61's identifiers, command bytes and
//! most layouts, but differs in (each cited where it is implemented, in
//! [`dialect_frames`](crate::dialect_frames) and [`lk`](crate::lk)):
//!
//! - the torque current scale of 0xA1, 0x280 and every status-2 reply, which depends on the
//!   motor series ([`LkSeries`]): MF ±16.5 A, MG ±33 A, over ±2048;
//! - the 0x9A / 0x9B status-1 layout: voltage in DATA\[2..=3\] at 0.01 V, bus current in
//!   DATA\[4..=5\], motor state in DATA\[6\];
//! - the 0x94 single-turn angle: u32 in DATA\[4..=7\].
//!
//! MyActuator V3 is a family, not a dialect: rmd-rt identifies it (see
//! [`identify`](mod@crate::identify)) but does not drive it, because its 0x280 frame is not a torque
//! frame.
//!
//! ```
//! use rmd_protocol::{CurrentScale, Dialect, LkSeries, ProtocolFamily};
//! let mf = Dialect::LkV23x(LkSeries::Mf);
//! assert_eq!(mf.family(), ProtocolFamily::LkV23x);
//! assert_eq!(mf.iq_control_scale(), CurrentScale::LK_MF_IQ_CONTROL);
//! assert_eq!(Dialect::default(), Dialect::V161);
//! assert_eq!(Dialect::from_names("lk-v2.3x", Some("mg")), Ok(Dialect::LkV23x(LkSeries::Mg)));
//! assert_eq!(Dialect::from_names("v1.61", None), Ok(Dialect::V161));
//! ```

use core::fmt;
use core::str::FromStr;

use crate::error::NameError;
use crate::family::ProtocolFamily;
use crate::scale::CurrentScale;

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

/// A protocol dialect rmd-rt can encode and decode. [`Dialect::V161`] is the default.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// GYEMS / MyActuator RMD v1.61 (what the rest of this crate implements).
    #[default]
    V161,
    /// LK-TECH V2.3x for motors of the given series.
    LkV23x(LkSeries),
}

impl Dialect {
    /// The family this dialect belongs to.
    pub const fn family(self) -> ProtocolFamily {
        match self {
            Self::V161 => ProtocolFamily::V161,
            Self::LkV23x(_) => ProtocolFamily::LkV23x,
        }
    }

    /// The protocol's stable name, `v1.61` or `lk-v2.3x` (the series is not part of it).
    pub const fn name(self) -> &'static str {
        self.family().name()
    }

    /// The LK-TECH motor series, for the LK dialect.
    pub const fn lk_series(self) -> Option<LkSeries> {
        match self {
            Self::V161 => None,
            Self::LkV23x(s) => Some(s),
        }
    }

    /// The dialect for a protocol name (`v1.61`, `lk-v2.3x`) and, for `lk-v2.3x`, the LK motor
    /// series (`mf`, `mg`). Errors: [`NameError::Dialect`] for another protocol name,
    /// [`NameError::MissingLkSeries`] for `lk-v2.3x` without a series, [`NameError::LkSeries`]
    /// for an unknown series. A series given with `v1.61` is ignored.
    pub fn from_names(protocol: &str, lk_series: Option<&str>) -> Result<Self, NameError> {
        match ProtocolFamily::from_name(protocol) {
            Ok(ProtocolFamily::V161) => Ok(Self::V161),
            Ok(ProtocolFamily::LkV23x) => match lk_series {
                Some(s) => Ok(Self::LkV23x(LkSeries::from_name(s)?)),
                None => Err(NameError::MissingLkSeries),
            },
            _ => Err(NameError::Dialect),
        }
    }

    /// The scale of `iqControl` (0xA1 and the 0x280 frame) in this dialect.
    pub const fn iq_control_scale(self) -> CurrentScale {
        match self {
            Self::V161 => CurrentScale::V161_IQ_CONTROL,
            Self::LkV23x(LkSeries::Mf) => CurrentScale::LK_MF_IQ_CONTROL,
            Self::LkV23x(LkSeries::Mg) => CurrentScale::LK_MG_IQ_CONTROL,
        }
    }

    /// The scale of `iq` in the status-2 replies (0x9C, 0xA1..=0xA6) in this dialect.
    pub const fn iq_scale(self) -> CurrentScale {
        match self {
            Self::V161 => CurrentScale::V161_IQ,
            Self::LkV23x(LkSeries::Mf) => CurrentScale::LK_MF_IQ,
            Self::LkV23x(LkSeries::Mg) => CurrentScale::LK_MG_IQ,
        }
    }
}

/// Formats as `v1.61`, `lk-v2.3x (MF)` or `lk-v2.3x (MG)`.
impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::V161 => f.write_str("v1.61"),
            Self::LkV23x(s) => write!(f, "lk-v2.3x ({s})"),
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
            Err(NameError::Dialect)
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
