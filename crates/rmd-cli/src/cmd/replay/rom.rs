//! The frames of a log that would write a motor's ROM (flash) if replayed: they wear the flash,
//! and a zero written to ROM takes effect only after a power cycle, so `rmd replay` asks before
//! sending them, as `rmd zero` and `rmd pid set --rom` do.
//!
//! A frame counts when it goes to a motor (`0x140 + id`, 0x141..=0x160) and its command byte
//! writes ROM on some firmware rmd-rt knows. Replies travel on the same identifiers in v1.61, so
//! a reply replayed (`--frames motors|all`) reaches the motors as that request. The commands:
//!
//! | byte | command | where it writes ROM |
//! |---|---|---|
//! | 0x19 | write the present position to ROM as the zero | v1.61 (gyems-can-v1.61), LK-TECH |
//! | 0x32 | write PID gains to ROM | v1.61, LK-TECH, MyActuator V3 |
//! | 0x91 | write encoder offset | LK-TECH V2.35 ("write encoder value to ROM as the motor zero"; v1.61 does not say it persists) |
//! | 0x63 | write an encoder value to ROM as the zero | MyActuator V3 |
//! | 0x64 | write the present position to ROM as the zero | MyActuator V3 |
//!
//! 0x280 frames are v1.61's multi-motor torque command (their first byte is a current, not a
//! command) and are not counted.

use rmd_bus::replay::LogRecord;
use rmd_protocol::MotorId;

/// One frame of a log that would write a motor's ROM.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct RomWrite {
    /// Its line in the log (1-based).
    pub(super) line: usize,
    /// The motor it goes to.
    pub(super) motor: MotorId,
    /// Its command byte.
    pub(super) command: u8,
}

/// Base of the identifiers of single-motor frames (`0x140 + id`).
const SINGLE_MOTOR_BASE: u16 = 0x140;

/// What command byte `byte` writes to ROM, if it does.
fn rom_command(byte: u8) -> Option<&'static str> {
    Some(match byte {
        0x19 => "write the position to ROM as the zero",
        0x32 => "write PID gains to ROM",
        0x91 => "write the encoder offset (to ROM on LK-TECH firmware)",
        0x63 => "write an encoder value to ROM as the zero (MyActuator V3)",
        0x64 => "write the position to ROM as the zero (MyActuator V3)",
        _ => return None,
    })
}

/// The ROM write `record` would be, if it is one.
pub(super) fn rom_write(record: &LogRecord) -> Option<RomWrite> {
    let id = record.frame.id().checked_sub(SINGLE_MOTOR_BASE)?;
    let motor = MotorId::new(u8::try_from(id).ok()?).ok()?;
    let command = *record.frame.data().first()?;
    rom_command(command)?;
    Some(RomWrite {
        line: record.line,
        motor,
        command,
    })
}

/// How many frames [`RomWrites::describe`] lists before summing up the rest.
const LISTED: usize = 8;

/// The ROM writes of a log read line by line: the first [`LISTED`] kept, the others counted.
#[derive(Debug, Default)]
pub(super) struct RomWrites {
    first: Vec<RomWrite>,
    count: usize,
}

impl RomWrites {
    /// Takes `record` into account.
    pub(super) fn note(&mut self, record: &LogRecord) {
        if let Some(write) = rom_write(record) {
            self.count += 1;
            if self.first.len() < LISTED {
                self.first.push(write);
            }
        }
    }

    /// How many frames write ROM.
    pub(super) fn count(&self) -> usize {
        self.count
    }

    /// Whether none does.
    pub(super) fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The frames in words: `line 3: 0x19 (write the position to ROM as the zero) to motor 1;
    /// ...`, the first [`LISTED`], then `and N more`.
    pub(super) fn describe(&self) -> String {
        let mut parts: Vec<String> = self
            .first
            .iter()
            .map(|w| {
                format!(
                    "line {}: 0x{:02X} ({}) to motor {}",
                    w.line,
                    w.command,
                    rom_command(w.command).unwrap_or("a ROM write"),
                    w.motor
                )
            })
            .collect();
        if self.count > LISTED {
            parts.push(format!("and {} more", self.count - LISTED));
        }
        parts.join("; ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::replay::read_log;

    #[test]
    fn rom_writing_frames_are_found_with_their_lines_and_motors() {
        let log = "\
(1.000000) can0 141#1900000000000000 T
(1.000100) can0 141#9C00000000000000 T
(1.000200) can0 142#3200640A64286432 T
(1.000300) can0 280#1900320091006400
(1.000400) can0 143#9100000000000010 T
(1.000500) can0 144#6400000000000000
(1.000600) can0 241#6300000000000000
(1.000700) can0 160#6300000000000000
(1.000800) can0 161#1900000000000000
";
        let records = read_log(log.as_bytes()).unwrap().records;
        let found: Vec<(usize, u8, u8)> = records
            .iter()
            .filter_map(rom_write)
            .map(|w| (w.line, w.motor.get(), w.command))
            .collect();
        // Not: the 0x9C read, the 0x280 torque frame, a V3 reply id (0x241), an id above 32.
        assert_eq!(
            found,
            [
                (1, 1, 0x19),
                (3, 2, 0x32),
                (5, 3, 0x91),
                (6, 4, 0x64),
                (8, 32, 0x63)
            ]
        );
        let mut writes = RomWrites::default();
        records.iter().for_each(|r| writes.note(r));
        let words = writes.describe();
        assert!(
            words.starts_with(
                "line 1: 0x19 (write the position to ROM as the zero) to motor 1; line 3: 0x32"
            ),
            "{words}"
        );
    }

    #[test]
    fn a_long_list_is_summed_up() {
        let log: String = (0..20)
            .map(|i| format!("({i}.000000) can0 141#3200000000000000\n"))
            .collect();
        let records = read_log(log.as_bytes()).unwrap().records;
        let mut writes = RomWrites::default();
        records.iter().for_each(|r| writes.note(r));
        let words = writes.describe();
        assert!(words.ends_with("; and 12 more"), "{words}");
        assert_eq!(words.matches("line ").count(), LISTED);
    }
}
