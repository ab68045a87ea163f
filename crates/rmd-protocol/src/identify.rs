//! Telling a motor's protocol family from its answers to two read requests.

use core::fmt;

use crate::bytes::u16_at;
use crate::command::Command;
use crate::family::ProtocolFamily;
use crate::frame::CanFrame;
use crate::ids::{MotorId, V3_REPLY_BASE_ID};

/// Lowest supply voltage a plausible status-1 reading may show, V. Below every motor's
/// low-voltage protection (LK's smallest drivers take 7.4 V; RMD motors 24 V or 48 V).
pub const MIN_SUPPLY_VOLTS: f64 = 6.0;
/// Highest supply voltage a plausible status-1 reading may show, V. Above every supply these
/// motors take (48 V nominal, drivers rated to about 60 V).
pub const MAX_SUPPLY_VOLTS: f64 = 80.0;

/// A request without fields: `code` in DATA\[0\], zeros after, on `0x140 + id`. The same bytes
/// in every family.
const fn bare(motor: MotorId, command: Command) -> CanFrame {
    CanFrame::rmd(motor.can_id(), [command.code(), 0, 0, 0, 0, 0, 0, 0])
}

/// The identifier a V3 motor replies on.
const fn v3_reply_id(motor: MotorId) -> u16 {
    V3_REPLY_BASE_ID + motor.get() as u16
}

/// The two probe requests for `motor`: 0x9A then 0x9C on `0x140 + id`.
pub const fn probe_requests(motor: MotorId) -> [CanFrame; 2] {
    [
        bare(motor, Command::ReadStatus1),
        bare(motor, Command::ReadStatus2),
    ]
}

/// The V3 model request (0xB5, in the V4.3 form `B5 00 ..`, V4.3 §2.33) for `motor`. Send it
/// only to a motor [`identify`] found to be MyActuator V3: 0xB5 is not a command of v1.61 or
/// LK-TECH. A V4.4 motor may answer in its own form (index and five characters, V4.4 §2.34):
/// both are read.
pub const fn model_request(motor: MotorId) -> CanFrame {
    bare(motor, Command::ReadModel)
}

/// Which probe a frame answers.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
enum Slot {
    Status1,
    Status2,
    Model,
}

/// What a motor sent back to the probes, collected by [`offer`](Self::offer).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct ProbeAnswers {
    status1: Option<CanFrame>,
    status2: Option<CanFrame>,
    model: Option<CanFrame>,
    /// A probe was answered on both reply identifiers.
    conflict: bool,
}

impl ProbeAnswers {
    /// No answers yet.
    pub const fn new() -> Self {
        Self {
            status1: None,
            status2: None,
            model: None,
            conflict: false,
        }
    }

    /// Offers a frame received while probing `motor`; returns whether it was taken as an answer.
    ///
    /// Taken: a frame on `0x140 + id` or `0x240 + id` whose DATA\[0\] is 0x9A, 0x9C or 0xB5, except
    /// a frame on `0x140 + id` equal to the probe request itself (the request, not an answer).
    /// The first answer to each probe is kept; a later answer to the same probe on the other
    /// identifier marks the answers as conflicting.
    pub fn offer(&mut self, motor: MotorId, frame: &CanFrame) -> bool {
        let single = motor.can_id();
        let v3_id = v3_reply_id(motor);
        if frame.id() != single && frame.id() != v3_id {
            return false;
        }
        let slot = match frame.data().first() {
            Some(&0x9A) => Slot::Status1,
            Some(&0x9C) => Slot::Status2,
            Some(&0xB5) => Slot::Model,
            _ => return false,
        };
        if frame.id() == single
            && frame.dlc() == 8
            && frame.data()[1..].iter().all(|&b| b == 0)
            && slot != Slot::Model
        {
            return false;
        }
        let kept = match slot {
            Slot::Status1 => &mut self.status1,
            Slot::Status2 => &mut self.status2,
            Slot::Model => &mut self.model,
        };
        match kept {
            None => *kept = Some(*frame),
            Some(first) if first.id() != frame.id() => self.conflict = true,
            Some(_) => return false,
        }
        true
    }

    /// The answer to 0x9A, if any.
    pub const fn status1(&self) -> Option<CanFrame> {
        self.status1
    }

    /// The answer to 0x9C, if any.
    pub const fn status2(&self) -> Option<CanFrame> {
        self.status2
    }

    /// The answer to 0xB5, if any.
    pub const fn model(&self) -> Option<CanFrame> {
        self.model
    }

    fn answers(&self) -> impl Iterator<Item = CanFrame> {
        [self.status1, self.status2, self.model]
            .into_iter()
            .flatten()
    }
}

/// A 0x9A answer read both ways.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Status1Readings {
    /// The voltage in v1.61's layout (DATA\[3..=4\] × 0.1 V).
    pub v161_volts: f64,
    /// The voltage in LK-TECH's layout (DATA\[2..=3\] × 0.01 V).
    pub lk_volts: f64,
    /// DATA\[2\]: reserved (0) in v1.61, the voltage's low byte in LK-TECH's layout.
    pub data2: u8,
    /// DATA\[6\]: reserved in v1.61, the motor state (0x00 / 0x10) in LK-TECH's layout.
    pub data6: u8,
}

impl Status1Readings {
    /// Reads a 0x9A answer's data both ways.
    pub fn of(d: &[u8; 8]) -> Self {
        Self {
            v161_volts: f64::from(u16_at::<3>(d)) / 10.0,
            lk_volts: f64::from(u16_at::<2>(d)) / 100.0,
            data2: d[2],
            data6: d[6],
        }
    }

    /// Whether the v1.61 reading is a plausible supply voltage.
    pub fn v161_plausible(&self) -> bool {
        plausible(self.v161_volts)
    }

    /// Whether the LK-TECH reading is a plausible supply voltage with a valid motor state.
    pub fn lk_plausible(&self) -> bool {
        plausible(self.lk_volts) && matches!(self.data6, 0x00 | 0x10)
    }
}

fn plausible(volts: f64) -> bool {
    (MIN_SUPPLY_VOLTS..=MAX_SUPPLY_VOLTS).contains(&volts)
}

/// The observation that decided the family.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Finding {
    /// Nothing answered the probes.
    NoAnswer,
    /// Probes were answered on both `0x140 + id` and `0x240 + id`.
    AnsweredOnBothIds,
    /// An answer did not have 8 data bytes.
    MalformedAnswer {
        /// Its identifier.
        can_id: u16,
        /// Its DLC.
        dlc: u8,
    },
    /// The motor answers on `0x240 + id`: MyActuator V3.
    V3ReplyId,
    /// The motor answered on `0x140 + id` but not to 0x9A, which alone tells v1.61 from LK-TECH.
    NoStatus1,
    /// Only the v1.61 reading of 0x9A is plausible.
    V161Status1,
    /// Only the LK-TECH reading of 0x9A is plausible.
    LkStatus1,
    /// Both readings are plausible; DATA\[2\] chose `chose`.
    BothReadingsPlausible {
        /// The family chosen.
        chose: ProtocolFamily,
    },
    /// Neither reading is plausible.
    NoReadingPlausible,
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoAnswer => f.write_str("no answer to 0x9A or 0x9C"),
            Self::AnsweredOnBothIds => f.write_str(
                "answers on both 0x140 + id and 0x240 + id (two devices, or unknown firmware)",
            ),
            Self::MalformedAnswer { can_id, dlc } => {
                write!(f, "answer on 0x{can_id:03X} with DLC {dlc}, not 8")
            }
            Self::V3ReplyId => f.write_str("answers on 0x240 + id (MyActuator V3)"),
            Self::NoStatus1 => f.write_str("no answer to 0x9A, which tells v1.61 from LK-TECH"),
            Self::V161Status1 => {
                f.write_str("0x9A has the v1.61 layout (voltage in DATA[3..=4] at 0.1 V)")
            }
            Self::LkStatus1 => {
                f.write_str("0x9A has the LK-TECH layout (voltage in DATA[2..=3] at 0.01 V)")
            }
            Self::BothReadingsPlausible { chose } => write!(
                f,
                "0x9A reads plausibly in both layouts; DATA[2] chose {chose} (ambiguous)"
            ),
            Self::NoReadingPlausible => {
                f.write_str("0x9A reads as a plausible supply voltage in neither layout")
            }
        }
    }
}

/// Everything [`identify`] looked at.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Evidence {
    /// The identifier the motor answered on (the first answer's), if any.
    pub reply_id: Option<u16>,
    /// Whether 0x9A was answered.
    pub answered_status1: bool,
    /// Whether 0x9C was answered.
    pub answered_status2: bool,
    /// The 0x9A answer read both ways (answers on `0x140 + id` only).
    pub status1: Option<Status1Readings>,
    /// The V3 model string (0xB5 answer): 7 ASCII bytes (V4.3 form), or 5 and two NULs (the
    /// first part of the V4.4 form).
    pub model: Option<[u8; 7]>,
    /// What decided.
    pub finding: Finding,
}

impl Evidence {
    /// The model string, if the motor sent one in ASCII.
    pub fn model_str(&self) -> Option<&str> {
        self.model
            .as_ref()
            .and_then(|m| core::str::from_utf8(m).ok())
            .map(|s| s.trim_end_matches(['\0', ' ']))
    }
}

/// A motor's family and the evidence for it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Identification {
    /// The motor probed.
    pub motor: MotorId,
    /// Its family.
    pub family: ProtocolFamily,
    /// Why.
    pub evidence: Evidence,
}

/// Formats as `motor 1: lk-v2.3x (0x9A has the LK-TECH layout ...)`.
impl fmt::Display for Identification {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "motor {}: {} ({})",
            self.motor, self.family, self.evidence.finding
        )
    }
}

/// Decides `motor`'s family from its answers to two read requests. Pure: no I/O.
///
/// # How
///
/// 1. Send the two [`probe_requests`] to the motor: 0x9A (read status 1) and 0x9C (read status 2)
///    on `0x140 + id`. Both are read-only in all three families (gyems-can-v1.61; LK-TECH CAN
///    protocol V2.35 §1 and §3; MyActuator Servo Motor Control Protocol V4.3 §2.14 and §2.15),
///    so probing cannot move or reconfigure a motor of any of them.
/// 2. Collect what comes back on `0x140 + id` **and** `0x240 + id` for a while (a motor answers
///    within 0.25 ms per LK's document; allow a few ms), offering every received frame to
///    [`ProbeAnswers::offer`].
/// 3. If the motor answered on `0x240 + id` it is MyActuator V3: optionally send
///    [`model_request`] (0xB5, a V3 read command, §2.33) and offer its answer too, to learn the
///    model string.
/// 4. [`identify`] decides:
///    - no answer at all: [`ProtocolFamily::Unknown`];
///    - answers on both `0x140 + id` and `0x240 + id`: `Unknown` (two devices share the id, or
///      firmware this module does not know);
///    - answers on `0x240 + id` only: [`ProtocolFamily::MyActuatorV3`] (V4.3 §1.1.2: "Reply:
///      0x240 + ID"; v1.61 and LK-TECH reply on `0x140 + id`);
///    - answers on `0x140 + id`: the 0x9A answer decides between v1.61 and LK-TECH. It is read
///      both ways: v1.61 puts the voltage in DATA\[3..=4\] at 0.1 V and leaves DATA\[2\], DATA\[5\]
///      and DATA\[6\] reserved; LK-TECH V2.3x puts it in DATA\[2..=3\] at 0.01 V and the motor state
///      (0x00 on, 0x10 off) in DATA\[6\] (see [`LkStatus1`](crate::LkStatus1)). A reading is *plausible* when
///      its voltage is within [`MIN_SUPPLY_VOLTS`]..=[`MAX_SUPPLY_VOLTS`] (and, for LK, DATA\[6\]
///      is 0x00 or 0x10). Exactly one plausible reading names the family. If both are plausible,
///      DATA\[2\] decides: 0 (reserved in v1.61) means v1.61, anything else LK-TECH; the
///      [`Finding`] records the ambiguity. Neither plausible, or no 0x9A answer: `Unknown`.
///
/// Example: issue 14's LK capture of 48.7 V has DATA\[2..=3\] = `06 13`; the LK reading is 48.7 V
/// (plausible), the v1.61 reading 1.9 V (not): LK-TECH.
///
/// # What it cannot tell
///
/// - **v1.61 from v1.62**: their frames are the same; both are reported as `v1.61`.
/// - **LK-TECH firmware that answers 0x9A in the v1.61 layout** (older LK firmware: e.g.
///   github.com/offisaac/23_Balance_Second, MF9025 v2 driver, reads DATA\[3..=4\] at 0.1 V) is
///   reported as `v1.61`, and its current scale is then wrong (an MF motor runs v1.61's
///   `iqControl` at about half the current). Name the protocol and model in the robot
///   description for such motors.
/// - **The LK-TECH motor series** (MF or MG): the frames do not carry it; it comes from the model.
/// - **Hybrid firmware** (LK-built motors sold under other names with mixed layouts): reported by
///   what their 0x9A answer looks like, which may not hold for other commands.
/// - **Ambiguous voltages**: a v1.61 motor at 25.9..=28.7 V (or 51.5..=54.3, 77.1..=79.9 V) also
///   has a plausible LK reading; DATA\[2\] = 0 resolves it to v1.61. An LK motor with a non-zero
///   low byte of bus current can have a plausible v1.61 reading; a voltage whose low byte is 0
///   (1 in 256) then resolves it wrongly to v1.61. Probing while the motors are off (bus current
///   0, as at start-up) avoids this case: with a zero bus current an LK answer never has a
///   plausible v1.61 reading.
/// - **Motors that do not answer 0x9A** (some firmware, a V3 motor with "active reply" set for
///   0x9A (V4.3 §2.34), a busy bus): `Unknown` even if 0x9C was answered.
/// - **An all-zero 0x9A / 0x9C answer** on `0x140 + id` is indistinguishable from the request
///   itself (another program's, or our own looped back) and is ignored; such an answer (0 °C,
///   0 V) would be implausible anyway.
///
/// ```
/// use rmd_protocol::{CanFrame, MotorId, ProbeAnswers, ProtocolFamily, identify, probe_requests};
/// let m1 = MotorId::new(1)?;
/// assert_eq!(probe_requests(m1).map(|f| f.to_string()), ["141#9A00000000000000", "141#9C00000000000000"]);
/// let mut answers = ProbeAnswers::new();
/// // A v1.61 motor at 24 V, 30 °C.
/// answers.offer(m1, &CanFrame::new(0x141, &[0x9A, 30, 0, 0xF0, 0, 0, 0, 0])?);
/// answers.offer(m1, &CanFrame::new(0x141, &[0x9C, 30, 0, 0, 0, 0, 0x34, 0x12])?);
/// let id = identify(m1, &answers);
/// assert_eq!(id.family, ProtocolFamily::V161);
/// assert_eq!(id.evidence.reply_id, Some(0x141));
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
pub fn identify(motor: MotorId, answers: &ProbeAnswers) -> Identification {
    let mut evidence = Evidence {
        reply_id: answers.answers().next().map(|f| f.id()),
        answered_status1: answers.status1.is_some(),
        answered_status2: answers.status2.is_some(),
        status1: None,
        model: None,
        finding: Finding::NoAnswer,
    };
    let (family, finding) = decide(motor, answers, &mut evidence);
    evidence.finding = finding;
    Identification {
        motor,
        family,
        evidence,
    }
}

fn decide(
    motor: MotorId,
    answers: &ProbeAnswers,
    evidence: &mut Evidence,
) -> (ProtocolFamily, Finding) {
    let unknown = ProtocolFamily::Unknown;
    let Some(first) = answers.answers().next() else {
        return (unknown, Finding::NoAnswer);
    };
    if answers.conflict || answers.answers().any(|f| f.id() != first.id()) {
        return (unknown, Finding::AnsweredOnBothIds);
    }
    if let Some(bad) = answers.answers().find(|f| f.dlc() != 8) {
        return (
            unknown,
            Finding::MalformedAnswer {
                can_id: bad.id(),
                dlc: bad.dlc(),
            },
        );
    }
    if first.id() == v3_reply_id(motor) {
        evidence.model = answers
            .model
            .and_then(|f| f.data8().copied())
            .filter(|d| d[0] == Command::ReadModel.code())
            .map(|d| {
                let mut m = [0u8; 7];
                if d[1] == 0x01 {
                    m[..5].copy_from_slice(&d[3..]);
                } else {
                    m.copy_from_slice(&d[1..]);
                }
                m
            });
        return (ProtocolFamily::MyActuatorV3, Finding::V3ReplyId);
    }
    let Some(d) = answers.status1.and_then(|f| f.data8().copied()) else {
        return (unknown, Finding::NoStatus1);
    };
    let readings = Status1Readings::of(&d);
    evidence.status1 = Some(readings);
    match (readings.v161_plausible(), readings.lk_plausible()) {
        (true, false) => (ProtocolFamily::V161, Finding::V161Status1),
        (false, true) => (ProtocolFamily::LkV23x, Finding::LkStatus1),
        (true, true) => {
            let chose = if readings.data2 == 0 {
                ProtocolFamily::V161
            } else {
                ProtocolFamily::LkV23x
            };
            (chose, Finding::BothReadingsPlausible { chose })
        }
        (false, false) => (unknown, Finding::NoReadingPlausible),
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;

    fn m(id: u8) -> MotorId {
        MotorId::new(id).unwrap()
    }

    fn f(id: u16, d: [u8; 8]) -> CanFrame {
        CanFrame::new(id, &d).unwrap()
    }

    fn family_of(frames: &[CanFrame]) -> Identification {
        let mut a = ProbeAnswers::new();
        for fr in frames {
            a.offer(m(1), fr);
        }
        identify(m(1), &a)
    }

    #[test]
    fn requests_and_foreign_frames_are_not_answers() {
        let mut a = ProbeAnswers::new();
        for req in probe_requests(m(1)) {
            assert!(!a.offer(m(1), &req));
        }
        assert!(!a.offer(m(1), &f(0x142, [0x9A, 30, 0, 0xF0, 0, 0, 0, 0])));
        assert!(!a.offer(m(1), &f(0x141, [0xA1, 30, 0, 0xF0, 0, 0, 0, 0])));
        assert_eq!(identify(m(1), &a).family, ProtocolFamily::Unknown);
        assert_eq!(identify(m(1), &a).evidence.finding, Finding::NoAnswer);
    }

    #[test]
    fn the_issue_capture_is_lk() {
        // 48.7 V in DATA[2..=3]: v1.61 reads 1.9 V.
        let id = family_of(&[f(0x141, [0x9A, 30, 0x06, 0x13, 0, 0, 0, 0])]);
        assert_eq!(id.family, ProtocolFamily::LkV23x);
        let r = id.evidence.status1.unwrap();
        assert!((r.v161_volts - 1.9).abs() < 1e-9 && (r.lk_volts - 48.7).abs() < 1e-9);
        assert_eq!(id.evidence.finding, Finding::LkStatus1);
    }

    #[test]
    fn ambiguous_voltages_use_data2() {
        // v1.61 at 26.0 V = 0x0104: the LK reading is 0x0400 = 10.24 V, plausible too.
        let id = family_of(&[f(0x141, [0x9A, 30, 0, 0x04, 0x01, 0, 0, 0])]);
        assert_eq!(id.family, ProtocolFamily::V161);
        assert_eq!(
            id.evidence.finding,
            Finding::BothReadingsPlausible {
                chose: ProtocolFamily::V161
            }
        );
        // LK at 10.25 V with 0.01 A bus current: the v1.61 reading (0x0104 = 26.0 V) is
        // plausible; DATA[2] = 0x01 chooses LK.
        let id = family_of(&[f(0x141, [0x9A, 30, 0x01, 0x04, 0x01, 0x00, 0x00, 0])]);
        assert_eq!(id.family, ProtocolFamily::LkV23x);
    }

    #[test]
    fn conflicting_and_incomplete_answers_are_unknown() {
        let id = family_of(&[
            f(0x141, [0x9A, 30, 0, 0xF0, 0, 0, 0, 0]),
            f(0x241, [0x9A, 30, 30, 1, 0xF0, 0, 0, 0]),
        ]);
        assert_eq!(
            (id.family, id.evidence.finding),
            (ProtocolFamily::Unknown, Finding::AnsweredOnBothIds)
        );
        let id = family_of(&[f(0x141, [0x9C, 30, 0, 0, 0, 0, 1, 0])]);
        assert_eq!(
            (id.family, id.evidence.finding),
            (ProtocolFamily::Unknown, Finding::NoStatus1)
        );
        let short = CanFrame::new(0x141, &[0x9A, 30, 0]).unwrap();
        assert!(matches!(
            family_of(&[short]).evidence.finding,
            Finding::MalformedAnswer { dlc: 3, .. }
        ));
        let id = family_of(&[f(0x141, [0x9A, 30, 0, 0, 0, 0, 0x55, 0xFF])]);
        assert_eq!(
            (id.family, id.evidence.finding),
            (ProtocolFamily::Unknown, Finding::NoReadingPlausible)
        );
    }

    #[test]
    fn v3_with_model() {
        let id = family_of(&[
            f(0x241, [0x9A, 0x32, 0, 1, 0xE5, 1, 0, 0]),
            f(0x241, [0xB5, b'X', b'8', b'S', b'2', b'V', b'1', b'0']),
        ]);
        assert_eq!(id.family, ProtocolFamily::MyActuatorV3);
        assert_eq!(id.evidence.model_str(), Some("X8S2V10"));
        assert_eq!(id.evidence.reply_id, Some(0x241));
        assert_eq!(
            id.to_string(),
            "motor 1: myactuator-v3 (answers on 0x240 + id (MyActuator V3))"
        );
    }
}
