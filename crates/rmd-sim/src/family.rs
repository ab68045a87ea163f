//! Which firmware a simulated motor runs, and the firmware-state traps it can reproduce.
//!
//! Every motor runs v1.61 unless its [`FirmwareParams::family`](crate::FirmwareParams::family)
//! says otherwise. The other families are emulated far enough that identification
//! (`rmd_protocol::identify`) and a control loop's refusal of the wrong family can be tested end
//! to end; see the `firmware` module docs and `docs/simulator.md` for exactly what each answers.

use core::fmt;
use core::str::FromStr;
use core::time::Duration;

use rmd_protocol::{LkSeries, NameError, ProtocolFamily};

/// The protocol family a simulated motor's firmware speaks.
///
/// ```
/// use rmd_protocol::{LkSeries, ProtocolFamily};
/// use rmd_sim::FirmwareFamily;
/// assert_eq!(FirmwareFamily::default(), FirmwareFamily::V161);
/// assert_eq!("lk-v2.3x".parse(), Ok(FirmwareFamily::LkV23x(LkSeries::Mg)));
/// assert_eq!(FirmwareFamily::MyActuatorV3.family(), ProtocolFamily::MyActuatorV3);
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum FirmwareFamily {
    /// GYEMS / MyActuator RMD v1.61 (every command of the spec).
    #[default]
    V161,
    /// LK-TECH V2.3x for a motor of the given series (the LK status-1 layout, the series' current
    /// scale, LK's motor off / run states, the u32 single-turn angle).
    LkV23x(LkSeries),
    /// MyActuator V3: replies on `0x240 + id`, 0.01 A per LSB, the output shaft's speeds and
    /// angles, 0x280 as a command for every motor, the motion mode, the watchdog, the brake
    /// (see the `firmware` module; its firmware date and model are
    /// [`V3Params`](crate::V3Params)).
    MyActuatorV3,
}

impl FirmwareFamily {
    /// Every family the simulator emulates, LK-TECH as MG.
    pub const ALL: [Self; 3] = [Self::V161, Self::LkV23x(LkSeries::Mg), Self::MyActuatorV3];

    /// The protocol family.
    pub const fn family(self) -> ProtocolFamily {
        match self {
            Self::V161 => ProtocolFamily::V161,
            Self::LkV23x(_) => ProtocolFamily::LkV23x,
            Self::MyActuatorV3 => ProtocolFamily::MyActuatorV3,
        }
    }

    /// The stable name: `v1.61`, `lk-v2.3x` or `myactuator-v3`.
    pub const fn name(self) -> &'static str {
        self.family().name()
    }

    /// The family named `name` (`v1.61`, `lk-v2.3x`, `myactuator-v3`); `lk-v2.3x` is an MG
    /// motor (use `FirmwareFamily::LkV23x(LkSeries::Mf)` for an MF one). Else
    /// [`NameError::Family`].
    pub fn from_name(name: &str) -> Result<Self, NameError> {
        match ProtocolFamily::from_name(name)? {
            ProtocolFamily::V161 => Ok(Self::V161),
            ProtocolFamily::LkV23x => Ok(Self::LkV23x(LkSeries::Mg)),
            ProtocolFamily::MyActuatorV3 => Ok(Self::MyActuatorV3),
            ProtocolFamily::Unknown => Err(NameError::Family),
        }
    }
}

impl fmt::Display for FirmwareFamily {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::LkV23x(s) => write!(f, "lk-v2.3x ({s})"),
            other => f.write_str(other.name()),
        }
    }
}

impl FromStr for FirmwareFamily {
    type Err = NameError;
    fn from_str(s: &str) -> Result<Self, NameError> {
        Self::from_name(s)
    }
}

/// A set of command bytes (any of the 256).
///
/// ```
/// use rmd_sim::CommandSet;
/// let reads = CommandSet::of(&[0x9A, 0x9D]);
/// assert!(reads.contains(0x9A) && !reads.contains(0x9C));
/// assert!(CommandSet::NONE.is_empty());
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct CommandSet([u64; 4]);

impl CommandSet {
    /// The empty set.
    pub const NONE: Self = Self([0; 4]);

    /// The set of `codes`.
    pub const fn of(codes: &[u8]) -> Self {
        let mut set = Self::NONE;
        let mut i = 0;
        while i < codes.len() {
            set = set.with(codes[i]);
            i += 1;
        }
        set
    }

    /// This set and `code`.
    pub const fn with(mut self, code: u8) -> Self {
        self.0[(code / 64) as usize] |= 1 << (code % 64);
        self
    }

    /// Whether `code` is in the set.
    pub const fn contains(self, code: u8) -> bool {
        self.0[(code / 64) as usize] & (1 << (code % 64)) != 0
    }

    /// Whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0[0] | self.0[1] | self.0[2] | self.0[3] == 0
    }
}

/// Firmware-state traps reported from real motors, each off by default.
///
/// ```
/// use core::time::Duration;
/// use rmd_sim::{CommandSet, FirmwareTraps};
/// let traps = FirmwareTraps {
///     motor_off_clears_turns: true,
///     unanswered: CommandSet::of(&[0x9D]),
///     motion_ignored_after_run: Duration::from_millis(20),
///     stale_reply_to_unknown: true,
/// };
/// assert!(!FirmwareTraps::default().any());
/// assert!(traps.any());
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct FirmwareTraps {
    /// 0x80 (motor off) restarts the multi-turn count: afterwards the multi-turn angle (0x92,
    /// and the reference of the multi-turn position commands) is back within one turn of the
    /// encoder zero, as after a power cycle. LK-TECH CAN protocol V2.35, motor off command:
    /// "清除电机转动圈数及之前接收的控制指令" (clears the motor's turn count and the commands received
    /// before; also github.com/Alliance-Algorithm/librmcs `librmcs/device/lk_motor.hpp`,
    /// `generate_shutdown_command`: "clearing the motor's rotation count"). Default off.
    pub motor_off_clears_turns: bool,
    /// Command bytes the firmware executes but never answers. Meant for reads: MyActuator V3's
    /// "active reply" (Servo Motor Control Protocol V4.3 §2.34) makes a motor stop answering the
    /// configured read; LK-TECH's 0x9D has no effect on some of its motors (CAN protocol V2.35
    /// §4); issue 14 reports reads without replies on the bench. Default empty.
    pub unanswered: CommandSet,
    /// After 0x88 (motor run), motion commands (0xA1..=0xA6 and the 0x280 torque frame) received
    /// within this time are answered but not obeyed. Reported from real motors in issue 14; no
    /// public document describes it. Default zero (off).
    pub motion_ignored_after_run: Duration,
    /// MyActuator V3: a command byte the firmware does not know is answered with the motor's
    /// previous reply, as it was. github.com/2b-t/myactuator_rmd issue 24: an X4-64 on firmware
    /// 2025070202 answered a 0x79 request with a stale 0xB2 reply (a host must match the
    /// command byte, not only the identifier). Default off (the frame is ignored).
    pub stale_reply_to_unknown: bool,
}

impl FirmwareTraps {
    /// Whether any trap is set.
    pub fn any(&self) -> bool {
        self.motor_off_clears_turns
            || !self.unanswered.is_empty()
            || !self.motion_ignored_after_run.is_zero()
            || self.stale_reply_to_unknown
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        for f in FirmwareFamily::ALL {
            assert_eq!(FirmwareFamily::from_name(f.name()), Ok(f));
        }
        assert_eq!(FirmwareFamily::from_name("unknown"), Err(NameError::Family));
        assert_eq!(FirmwareFamily::from_name("v3"), Err(NameError::Family));
    }

    #[test]
    fn command_set_covers_every_byte() {
        let all = (0..=255u8).fold(CommandSet::NONE, CommandSet::with);
        assert!((0..=255u8).all(|c| all.contains(c)));
        let one = CommandSet::of(&[0xFF]);
        assert!((0..255u8).all(|c| !one.contains(c)) && one.contains(0xFF));
    }
}
