//! Which protocol family each motor speaks, as a live command learns it: named on the command
//! line (`--protocol`, or a robot description's `protocol`), or identified from the motor's
//! answers to read-only requests ([`rmd_protocol::identify`]). Never guessed: a command learns
//! it before it sends anything that moves or writes (see
//! [`Connection`](crate::live::connect::Connection)), and a command the family does not have
//! is refused with what to use instead ([`instead`]).

use rmd_protocol::{Command, Dialect, LkSeries, ProtocolFamily};

/// How the motors' protocol is known.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum ProtocolSource {
    /// Named (`--protocol` with its options): each motor is checked to answer in it.
    Named(Dialect),
    /// Not named: each motor is identified; LK-TECH motors are of `lk_series` (`--lk-series`).
    Identify {
        /// The series of the motors identified as LK-TECH, if given.
        lk_series: Option<LkSeries>,
    },
}

/// What a command knows of one motor's family.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum MotorFamily {
    /// Its dialect, with everything its layouts and scales depend on.
    Known(Dialect),
    /// LK-TECH V2.3x of an unknown series: the frames do not carry it, and the current scale
    /// depends on it. Only the commands without a current ([`carries_current`]) can be sent.
    LkSeriesUnknown,
}

impl MotorFamily {
    /// The family's name.
    pub(crate) fn family(self) -> ProtocolFamily {
        match self {
            MotorFamily::Known(dialect) => dialect.family(),
            MotorFamily::LkSeriesUnknown => ProtocolFamily::LkV23x,
        }
    }

    /// The dialect to send `command` in; `None` when the command carries a current whose
    /// scale is not known (LK-TECH of an unknown series).
    pub(crate) fn dialect_for(self, command: Command) -> Option<Dialect> {
        match self {
            MotorFamily::Known(dialect) => Some(dialect),
            // The series changes only the current scales: a command without a current, and
            // its reply, read the same in either.
            MotorFamily::LkSeriesUnknown if !carries_current(command) => {
                Some(Dialect::LkV23x(LkSeries::Mg))
            }
            MotorFamily::LkSeriesUnknown => None,
        }
    }
}

/// Whether a request of `command`, or its reply, carries a current in the family's scale:
/// 0xA1 (`iqControl`), and the status 2 of 0x9C and of every control command (`iq`).
pub(crate) fn carries_current(command: Command) -> bool {
    matches!(
        command,
        Command::Torque
            | Command::Speed
            | Command::Position1
            | Command::Position2
            | Command::Position3
            | Command::Position4
            | Command::ReadStatus2
    )
}

/// What to use instead of `command` on a motor of `family`, which does not have it (as rmd-rt
/// speaks it: [`Dialect::supports`]).
pub(crate) fn instead(family: ProtocolFamily, command: Command) -> &'static str {
    match (family, command) {
        (ProtocolFamily::MyActuatorV3, Command::ReadPid | Command::WritePidRam) => {
            "MyActuator V3 reads and writes its PID gains with other commands and layouts, which \
             rmd-rt does not implement: use MyActuator's configuration software"
        }
        (ProtocolFamily::MyActuatorV3, Command::WritePidRom) => {
            "MyActuator V3 writes its PID gains with other commands and layouts, which rmd-rt \
             does not implement: use MyActuator's configuration software"
        }
        (ProtocolFamily::MyActuatorV3, Command::ReadAccel | Command::WriteAccelRam) => {
            "MyActuator V3 sets its accelerations with other commands (0x42, 0x43), which rmd-rt \
             does not implement: use MyActuator's configuration software"
        }
        (ProtocolFamily::MyActuatorV3, Command::ReadEncoder) => {
            "MyActuator V3 reads its encoder with other commands (0x60..=0x62), which rmd-rt \
             does not implement: `rmd status` shows the output shaft's multi-turn (0x92) and \
             single-turn (0x94) angles"
        }
        (ProtocolFamily::MyActuatorV3, Command::WriteEncoderOffset | Command::WriteZeroRom) => {
            "MyActuator V3 sets its zero with 0x63 / 0x64 and a reset (0x76), which rmd-rt does \
             not implement: use MyActuator's configuration software"
        }
        (ProtocolFamily::MyActuatorV3, Command::ClearError) => {
            "MyActuator V3 has no clear-error command: its low- and over-voltage, \
             over-temperature and overspeed flags clear once their cause is gone, the others \
             need a reset or a power cycle"
        }
        (ProtocolFamily::MyActuatorV3, Command::ReadStatus3) => {
            "MyActuator V3 does not report its phase currents"
        }
        (ProtocolFamily::MyActuatorV3, Command::MotorRun) => {
            "MyActuator V3 has no motor run: its stop (0x81) holds the position in the same \
             mode; send the motion again (`rmd speed`, `rmd move`), or `rmd off`"
        }
        (
            ProtocolFamily::MyActuatorV3,
            Command::Position1 | Command::Position3 | Command::Position4,
        ) => {
            "MyActuator V3's position command is 0xA4 (the output shaft's absolute angle, with \
             a speed limit): use `rmd move ID --deg X --mode 2` (the default)"
        }
        (_, Command::SetWatchdog) => {
            "v1.61 and LK-TECH motors have no communication watchdog: drive them from the loop, \
             whose supervisor turns them off when anything fails"
        }
        (_, Command::ReadFirmwareDate | Command::ReadModel) => {
            "only MyActuator V3 motors report a firmware date and model: `rmd scan` shows what \
             each motor answers"
        }
        (_, Command::BrakeRelease | Command::BrakeLock) => {
            "only MyActuator V3 motors have brake commands"
        }
        (_, Command::FunctionControl | Command::Reset) => {
            "only MyActuator V3 motors have function control and reset commands"
        }
        _ => "`rmd encode --protocol` lists the commands of each protocol",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_protocol::{CanFrame, V3Firmware};

    #[test]
    fn an_lk_motor_of_unknown_series_takes_only_commands_without_a_current() {
        let lk = MotorFamily::LkSeriesUnknown;
        assert_eq!(lk.dialect_for(Command::Torque), None);
        assert_eq!(lk.dialect_for(Command::ReadStatus2), None);
        assert_eq!(
            lk.dialect_for(Command::ReadStatus1).map(Dialect::family),
            Some(ProtocolFamily::LkV23x)
        );
        assert_eq!(
            lk.dialect_for(Command::MotorOff).map(Dialect::family),
            Some(ProtocolFamily::LkV23x)
        );
        // A command carries a current exactly when its reply reads differently in MF and MG
        // (0xA1's request carries one too, and so does its reply).
        for command in Dialect::LkV23x(LkSeries::Mf).commands() {
            let frame =
                CanFrame::new(0x141, &[command.code(), 30, 0x00, 0x04, 0x10, 0, 0, 0]).unwrap();
            let read = |series| Dialect::LkV23x(series).decode_reply_to(&frame, *command);
            let differs = read(LkSeries::Mf) != read(LkSeries::Mg);
            assert_eq!(carries_current(*command), differs, "{command}");
        }
    }

    #[test]
    fn every_missing_command_has_advice() {
        let v3 = Dialect::MyActuatorV3(V3Firmware::default());
        for dialect in [Dialect::V161, v3] {
            for command in Command::ALL {
                if !dialect.supports(command) {
                    assert!(
                        !instead(dialect.family(), command).contains("lists the commands"),
                        "{dialect} {command}"
                    );
                }
            }
        }
    }
}
