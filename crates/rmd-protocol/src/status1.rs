//! Status 1 (the reply to 0x9A, and v1.61's 0x9B) in the layout of each family.

use crate::lk::LkStatus1;
use crate::status::{ErrorState, V161Status1};
use crate::v3::V3Status1;
use crate::values::Temperature;

/// Status 1 in the layout of the family that sent it.
///
/// | family | layout | source |
/// |---|---|---|
/// | v1.61 | [`V161Status1`]: DATA\[1\] temperature, DATA\[3..=4\] voltage (0.1 V), DATA\[7\] error state | gyems-can-v1.61, 0x9A |
/// | LK-TECH V2.3x | [`LkStatus1`]: voltage in DATA\[2..=3\] (0.01 V), bus current, motor state | LK-TECH CAN protocol V2.35 §二.1 |
/// | MyActuator V3 | [`V3Status1`]: MOS temperature, brake, voltage in DATA\[4..=5\] (0.1 V), u16 error flags | V4.3 §2.14, V4.4 §2.13 |
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Status1 {
    /// v1.61's layout.
    V161(V161Status1),
    /// LK-TECH V2.3x's layout.
    Lk(LkStatus1),
    /// MyActuator V3's layout.
    V3(V3Status1),
}

impl Status1 {
    /// Motor temperature.
    pub const fn temperature(&self) -> Temperature {
        match self {
            Self::V161(s) => s.temperature,
            Self::Lk(s) => s.temperature,
            Self::V3(s) => s.temperature,
        }
    }

    /// Supply voltage, V.
    pub fn volts(&self) -> f64 {
        match self {
            Self::V161(s) => s.voltage.volts(),
            Self::Lk(s) => s.voltage.volts(),
            Self::V3(s) => s.voltage.volts(),
        }
    }

    /// The v1.61 / LK-TECH error byte (`None` for V3, whose flags are a u16 of other bits:
    /// [`V3Status1::error_state`]).
    pub const fn error_state(&self) -> Option<ErrorState> {
        match self {
            Self::V161(s) => Some(s.error_state),
            Self::Lk(s) => Some(s.error_state),
            Self::V3(_) => None,
        }
    }

    /// Whether no error flag is set.
    pub const fn errors_clear(&self) -> bool {
        match self {
            Self::V161(s) => s.error_state.is_clear(),
            Self::Lk(s) => s.error_state.is_clear(),
            Self::V3(s) => s.error_state.is_clear(),
        }
    }
}
