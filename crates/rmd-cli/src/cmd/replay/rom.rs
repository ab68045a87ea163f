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
//! | 0xB3 | communication watchdog (protection time, kept in ROM) | MyActuator V3 |
//! | 0x20 | function control with a function kept in ROM (index 1, 2, 4..=7: the CAN ID at 5) | MyActuator V3 |
//!
//! On a MyActuator V3 bus a 0x280 frame is one command for every motor, so a 0x280 frame that
//! is exactly V3's 0xB3 or ROM-writing 0x20 request (as rmd-protocol encodes it, reserved bytes
//! 0) writes the ROM of every motor, and counts. Other 0x280 frames are v1.61's multi-motor
//! torque command (their first byte is a current, not a command) and are not counted: V3's
//! 0x63, 0x64 and 0x32 as 0x280 frames have the same bytes as common torque frames (`280#64..`
//! is 1.6 A to motor 1), and rmd-rt does not encode them.

use rmd_bus::replay::LogRecord;
use rmd_protocol::{
    CanFrame, DecodedRequest, Dialect, MULTI_TORQUE_CAN_ID, MotorId, Request, V3Firmware,
};

/// One frame of a log that would write motors' ROM.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct RomWrite {
    /// Its line in the log (1-based).
    pub(super) line: usize,
    /// The motors it goes to.
    pub(super) to: Target,
    /// Its command byte.
    pub(super) command: u8,
    /// What it writes.
    pub(super) what: String,
}

/// Which motors a ROM write goes to.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(super) enum Target {
    /// One motor (`0x140 + id`).
    Motor(MotorId),
    /// Every MyActuator V3 motor of the bus (0x280).
    Every,
}

/// What command byte `byte` writes to ROM on a single-motor frame, if it does (the commands
/// of v1.61 and LK-TECH, and V3's that rmd-protocol does not encode).
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

/// A MyActuator V3 request that writes ROM, in words.
fn v3_rom_request(request: &Request) -> Option<String> {
    if !request.writes_flash() {
        return None;
    }
    Some(match request {
        Request::SetWatchdog { timeout } => format!(
            "set the communication watchdog to {} ms, kept in ROM (MyActuator V3)",
            timeout.millis()
        ),
        Request::FunctionControl(f) => format!(
            "function control {} = {}, kept in ROM (MyActuator V3)",
            f.function.name(),
            f.value
        ),
        other => format!("{} (MyActuator V3, ROM)", other.command()),
    })
}

/// The MyActuator V3 ROM write `frame` is, if it is one: on `0x140 + id`, or on 0x280 when it
/// is exactly V3's encoding of the request.
fn v3_rom_write(frame: &CanFrame) -> Option<(Target, String)> {
    let v3 = Dialect::MyActuatorV3(V3Firmware::default());
    match v3.decode_request(frame).ok()? {
        DecodedRequest::Single { motor, request } => {
            Some((Target::Motor(motor), v3_rom_request(&request)?))
        }
        DecodedRequest::Broadcast(request)
            if frame.id() == MULTI_TORQUE_CAN_ID
                && v3.encode_broadcast(&request).as_ref() == Ok(frame) =>
        {
            Some((Target::Every, v3_rom_request(&request)?))
        }
        _ => None,
    }
}

/// The ROM write `record` would be, if it is one.
pub(super) fn rom_write(record: &LogRecord) -> Option<RomWrite> {
    let frame = &record.frame;
    let command = *frame.data().first()?;
    let (to, what) = match (MotorId::from_can_id(frame.id()), rom_command(command)) {
        (Ok(motor), Some(what)) => (Target::Motor(motor), what.to_owned()),
        _ => v3_rom_write(frame)?,
    };
    Some(RomWrite {
        line: record.line,
        to,
        command,
        what,
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
                let to = match w.to {
                    Target::Motor(motor) => format!("motor {motor}"),
                    Target::Every => "every motor (0x280, MyActuator V3's broadcast)".to_owned(),
                };
                format!("line {}: 0x{:02X} ({}) to {to}", w.line, w.command, w.what)
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
(1.000900) can0 145#B3000000E8030000
(1.001000) can0 145#2005000007000000
(1.001100) can0 145#2003000001000000
(1.001200) can0 280#B300000064000000
(1.001300) can0 280#2005000003000000
(1.001400) can0 280#B301000064000000
(1.001500) can0 280#8000000000000000
";
        let records = read_log(log.as_bytes()).unwrap().records;
        let found: Vec<(usize, u8, u8)> = records
            .iter()
            .filter_map(rom_write)
            .map(|w| {
                let to = match w.to {
                    Target::Motor(m) => m.get(),
                    Target::Every => 0,
                };
                (w.line, to, w.command)
            })
            .collect();
        // Not: the 0x9C read, the 0x280 torque frame, a V3 reply id (0x241), an id above 32,
        // V3's error-status transmission (0x20 index 3, RAM), a 0x280 frame with a reserved
        // byte set (torque currents, not V3's 0xB3), V3's motor off to every motor.
        assert_eq!(
            found,
            [
                (1, 1, 0x19),
                (3, 2, 0x32),
                (5, 3, 0x91),
                (6, 4, 0x64),
                (8, 32, 0x63),
                (10, 5, 0xB3),
                (11, 5, 0x20),
                (13, 0, 0xB3),
                (14, 0, 0x20),
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
        let v3 = |line: &str| {
            let records = read_log(line.as_bytes()).unwrap().records;
            let mut writes = RomWrites::default();
            records.iter().for_each(|r| writes.note(r));
            writes.describe()
        };
        assert_eq!(
            v3("(1.0) can0 280#2005000003000000\n"),
            "line 1: 0x20 (function control set-can-id = 3, kept in ROM (MyActuator V3)) to every \
             motor (0x280, MyActuator V3's broadcast)"
        );
        assert_eq!(
            v3("(1.0) can0 141#B3000000E8030000\n"),
            "line 1: 0xB3 (set the communication watchdog to 1000 ms, kept in ROM (MyActuator \
             V3)) to motor 1"
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
