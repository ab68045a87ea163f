//! The status replies of v1.61 (0x9A/0x9B, 0x9D), status 2 of every family (0x9C and the
//! control replies), the error-state bitfield, the spin direction and the PID parameters.

use core::ops::BitOr;

use crate::current::ScaledCurrent;
use crate::encoder::EncoderValue;
use crate::error::ProtocolError;
use crate::field::Field;
use crate::v3::OutputAngle;
use crate::values::{PhaseCurrent, Speed, Temperature, Voltage};

/// The error-state byte of the 0x9A / 0x9B replies (DATA\[7\]).
///
/// Bit 0 is low-voltage protection and bit 3 over-temperature protection; the spec calls the
/// other bits "invalid": they are kept (see [`raw`](Self::raw), [`unknown_bits`](Self::unknown_bits))
/// but given no meaning.
///
/// ```
/// use rmd_protocol::ErrorState;
/// let e = ErrorState::from_raw(0b1000_1001);
/// assert!(e.low_voltage() && e.over_temperature());
/// assert_eq!(e.unknown_bits(), 0b1000_0000);
/// assert_eq!(e.raw(), 0b1000_1001);
/// assert!(ErrorState::NONE.is_clear());
/// assert_eq!(ErrorState::LOW_VOLTAGE | ErrorState::OVER_TEMPERATURE, ErrorState::from_raw(0b1001));
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct ErrorState(u8);

impl ErrorState {
    /// No flag set.
    pub const NONE: Self = Self(0);
    /// Bit 0: low-voltage protection.
    pub const LOW_VOLTAGE: Self = Self(1 << 0);
    /// Bit 3: over-temperature protection.
    pub const OVER_TEMPERATURE: Self = Self(1 << 3);
    /// The bits the spec gives a meaning to.
    const KNOWN: u8 = Self::LOW_VOLTAGE.0 | Self::OVER_TEMPERATURE.0;

    /// The state from its raw byte; every bit is kept.
    pub const fn from_raw(raw: u8) -> Self {
        Self(raw)
    }

    /// The raw byte, unknown bits included.
    pub const fn raw(self) -> u8 {
        self.0
    }

    /// Low-voltage protection is active (bit 0).
    pub const fn low_voltage(self) -> bool {
        self.0 & Self::LOW_VOLTAGE.0 != 0
    }

    /// Over-temperature protection is active (bit 3).
    pub const fn over_temperature(self) -> bool {
        self.0 & Self::OVER_TEMPERATURE.0 != 0
    }

    /// The bits the spec calls "invalid" (all but 0 and 3), as received.
    pub const fn unknown_bits(self) -> u8 {
        self.0 & !Self::KNOWN
    }

    /// Whether no bit at all is set.
    pub const fn is_clear(self) -> bool {
        self.0 == 0
    }

    /// Whether every bit of `other` is set in `self`.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }
}

impl BitOr for ErrorState {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        Self(self.0 | rhs.0)
    }
}

/// `spinDirection` of the position commands 0xA5 / 0xA6 (DATA\[1\]).
///
/// ```
/// use rmd_protocol::SpinDirection;
/// assert_eq!(SpinDirection::from_raw(1), Ok(SpinDirection::CounterClockwise));
/// assert_eq!(SpinDirection::Clockwise.raw(), 0);
/// assert!(SpinDirection::from_raw(2).is_err());
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SpinDirection {
    /// 0x00: clockwise.
    #[default]
    Clockwise = 0,
    /// 0x01: counterclockwise.
    CounterClockwise = 1,
}

impl SpinDirection {
    /// The direction from its raw byte; [`ProtocolError::ValueOutOfRange`] unless 0 or 1.
    pub const fn from_raw(raw: u8) -> Result<Self, ProtocolError> {
        match raw {
            0 => Ok(SpinDirection::Clockwise),
            1 => Ok(SpinDirection::CounterClockwise),
            _ => Err(ProtocolError::ValueOutOfRange {
                field: Field::SpinDirection,
                value: raw as i64,
                min: 0,
                max: 1,
            }),
        }
    }

    /// The raw byte (0 clockwise, 1 counterclockwise).
    pub const fn raw(self) -> u8 {
        self as u8
    }
}

/// The six PID gains of 0x30 (reply), 0x31 and 0x32 (request and reply), DATA\[2..=7\], raw u8
/// (the spec gives them no unit).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct PidParams {
    /// Position loop Kp (`anglePidKp`, DATA\[2\]).
    pub angle_pid_kp: u8,
    /// Position loop Ki (`anglePidKi`, DATA\[3\]).
    pub angle_pid_ki: u8,
    /// Speed loop Kp (`speedPidKp`, DATA\[4\]).
    pub speed_pid_kp: u8,
    /// Speed loop Ki (`speedPidKi`, DATA\[5\]).
    pub speed_pid_ki: u8,
    /// Torque loop Kp (`iqPidKp`, DATA\[6\]).
    pub iq_pid_kp: u8,
    /// Torque loop Ki (`iqPidKi`, DATA\[7\]).
    pub iq_pid_ki: u8,
}

impl PidParams {
    /// The gains from DATA\[2..=7\] of a 0x30, 0x31 or 0x32 frame.
    #[inline]
    pub(crate) const fn from_data(d: &[u8; 8]) -> Self {
        Self {
            angle_pid_kp: d[2],
            angle_pid_ki: d[3],
            speed_pid_kp: d[4],
            speed_pid_ki: d[5],
            iq_pid_kp: d[6],
            iq_pid_ki: d[7],
        }
    }

    /// Writes the gains into DATA\[2..=7\].
    #[inline]
    pub(crate) const fn write_to(&self, d: &mut [u8; 8]) {
        d[2] = self.angle_pid_kp;
        d[3] = self.angle_pid_ki;
        d[4] = self.speed_pid_kp;
        d[5] = self.speed_pid_ki;
        d[6] = self.iq_pid_kp;
        d[7] = self.iq_pid_ki;
    }
}

/// v1.61 status 1: the reply to 0x9A (read status 1) and 0x9B (clear error).
///
/// Layout: DATA\[1\] temperature, DATA\[3..=4\] voltage, DATA\[7\] error state.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct V161Status1 {
    /// Motor temperature (`temperature`, int8_t, 1 °C/LSB).
    pub temperature: Temperature,
    /// Supply voltage (`voltage`, 0.1 V/LSB).
    pub voltage: Voltage,
    /// Protection flags (`errorState`).
    pub error_state: ErrorState,
}

/// Status 2: the reply to 0x9C and to the control commands (0xA1..=0xA6; also each reply to a
/// v1.61 / LK-TECH 0x280 torque frame, which carries DATA\[0\] = 0xA1), in every family.
///
/// Layout: DATA\[1\] temperature (int8, 1 °C/LSB), DATA\[2..=3\] `iq` (int16, the family's
/// scale), DATA\[4..=5\] speed (int16, 1 dps/LSB), DATA\[6..=7\] a position whose meaning
/// depends on the family ([`StatusPosition`]).
///
/// v1.61 and LK-TECH report the motor's (rotor's) speed and encoder; MyActuator V3 reports the
/// output shaft's speed and angle ("motor output shaft speed", "motor output shaft angle",
/// V4.3 §2.15, V4.4 §2.14).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Status2 {
    /// Motor temperature (`temperature`, int8_t, 1 °C/LSB).
    pub temperature: Temperature,
    /// Torque current (`iq`): 33/2048 A/LSB in v1.61, the series' scale in LK-TECH, 0.01 A/LSB
    /// in MyActuator V3.
    pub iq: ScaledCurrent,
    /// Speed (`speed`, 1 dps/LSB): the motor's in v1.61 and LK-TECH, the output shaft's in V3.
    pub speed: Speed,
    /// The position in DATA\[6..=7\].
    pub position: StatusPosition,
}

impl Status2 {
    /// The encoder value, for v1.61 and LK-TECH (`None` for V3's output angle).
    pub const fn encoder(&self) -> Option<EncoderValue> {
        match self.position {
            StatusPosition::Encoder(e) => Some(e),
            StatusPosition::OutputDegrees(_) => None,
        }
    }
}

/// DATA\[6..=7\] of status 2.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum StatusPosition {
    /// v1.61 and LK-TECH: `encoder` (u16, the motor encoder with the offset applied).
    Encoder(EncoderValue),
    /// MyActuator V3: the output shaft's angle in whole degrees (int16).
    OutputDegrees(OutputAngle),
}

/// Status 3: the reply to 0x9D, the three phase currents (1 A / 64 LSB).
///
/// Layout: DATA\[2..=3\] iA, DATA\[4..=5\] iB, DATA\[6..=7\] iC.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Status3 {
    /// Phase A current (`iA`).
    pub i_a: PhaseCurrent,
    /// Phase B current (`iB`).
    pub i_b: PhaseCurrent,
    /// Phase C current (`iC`).
    pub i_c: PhaseCurrent,
}
