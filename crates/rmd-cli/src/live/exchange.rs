//! One request to one motor, one reply: the timeout, the retries and the typed errors every
//! live command shares.
//!
//! [`request`] drops whatever is already queued (stale replies), sends the request, and waits
//! up to the timeout for a reply from that motor to that command; it sends again up to
//! `retries` times. Frames from other motors are ignored; a reply to another command, or a
//! malformed one, is remembered and reported if no good reply comes. Bus events seen meanwhile
//! (no acknowledgement, error-passive) sharpen the advice of a timeout; bus-off ends the
//! exchange at once.
//!
//! Requests are encoded and replies decoded in the motor's [`Dialect`] (learned by the
//! [`Connection`](crate::live::connect::Connection)), with rmd-protocol's codec alone: a request
//! is sent only if it belongs to the dialect (its command, its current's scale), and a reply is
//! taken only from the dialect's reply identifier with the pending command's byte
//! (`Dialect::decode_answer`), in the dialect's own layouts and scales. A motor answering on the
//! other families' identifier (`0x240 + id` for a v1.61 or LK-TECH request, `0x140 + id` for a
//! MyActuator V3 one) speaks another protocol: that is its own error. [`motor_off_any_family`]
//! is the one exchange without a dialect: 0x80 and its echo are the same bytes in every family.

use std::fmt;
use std::time::Duration;

use rmd_bus::{BusError, BusEvent, BusMessage, CanBus, CanFrame, Clock, Timestamp};
use rmd_protocol::{
    Command, Dialect, Finding, MotorId, ProtocolError, Reply, Request, SINGLE_MOTOR_BASE_ID,
    V3_REPLY_BASE_ID, V3Firmware,
};

use crate::args::ids::IdList;
use crate::live::family::instead;
use crate::output::report::CliError;

/// Timeout and retries of each exchange, and what the bus is (for the advice in errors).
#[derive(Clone, Debug)]
pub(crate) struct Policy {
    /// How long to wait for the reply after each send.
    pub(crate) timeout: Duration,
    /// How many times to send again after a timeout.
    pub(crate) retries: u32,
    /// What the motors are on.
    pub(crate) setup: Setup,
}

/// What the motors are on, for advice in error messages.
#[derive(Clone, Debug)]
pub(crate) enum Setup {
    /// A SocketCAN interface.
    Interface(String),
    /// The in-process simulator with these motors.
    Simulator(IdList),
    /// The in-process simulated motors of a robot description's bus (`--robot FILE --sim`).
    Robot(String),
}

impl Setup {
    /// A short name for messages (`can0`, `the simulator`).
    pub(crate) fn name(&self) -> String {
        match self {
            Setup::Interface(iface) => iface.clone(),
            Setup::Simulator(_) | Setup::Robot(_) => "the simulated bus".to_owned(),
        }
    }

    /// What to check when `motor` does not answer.
    fn no_reply_advice(&self, motor: MotorId) -> String {
        match self {
            Setup::Interface(iface) => format!(
                "check that motor {motor} is powered and wired to {iface}, that its CAN id is \
                 {motor}, and that {iface} runs at the motor's bit rate (1 Mbit/s by default; \
                 `ip -details link show {iface}`); `rmd scan --iface {iface}` lists the motors \
                 that answer and their firmware"
            ),
            Setup::Simulator(ids) => {
                format!("the simulated motors are {ids} (choose them with --sim-ids)")
            }
            Setup::Robot(file) => {
                format!("the simulated motors are the ones {file} describes")
            }
        }
    }

    /// Where to learn each motor's firmware: `rmd scan` on the interface, or the option that
    /// chose the simulated motors' firmware.
    fn firmware_advice(&self) -> String {
        match self {
            Setup::Interface(iface) => {
                format!("`rmd scan --iface {iface}` identifies each motor's firmware")
            }
            Setup::Simulator(_) => "--sim-firmware chose the simulated motors' firmware".to_owned(),
            Setup::Robot(file) => format!("the simulated motors run the firmware {file} describes"),
        }
    }
}

/// Signs of trouble the bus reported during an exchange.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct BusSigns {
    /// Nobody acknowledged a frame (or a transmission timed out).
    pub(crate) no_ack: bool,
    /// The controller went error-passive or reached the warning level.
    pub(crate) errors: bool,
}

impl BusSigns {
    fn note(&mut self, event: BusEvent) {
        match event {
            BusEvent::NoAck | BusEvent::TxTimeout => self.no_ack = true,
            BusEvent::ErrorPassive | BusEvent::ErrorWarning | BusEvent::ProtocolViolation => {
                self.errors = true
            }
            _ => {}
        }
    }
}

impl fmt::Display for BusSigns {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.no_ack {
            f.write_str(
                ". The CAN controller reported that no node acknowledges the frames: check that \
                 the motors are powered, the wiring and 120 ohm termination, and the bit rate",
            )?;
        } else if self.errors {
            f.write_str(
                ". The CAN controller reported bus errors (error-passive or warning level): \
                 check wiring, termination and bit rate",
            )?;
        }
        Ok(())
    }
}

/// Why an exchange failed. Every message names the motor and says what to do.
#[derive(Debug, thiserror::Error)]
pub(crate) enum ExchangeError {
    /// No reply within the timeout, after every attempt.
    #[error(
        "motor {motor} did not answer {command} within {} ms ({attempts} attempt{}): {}{signs}",
        timeout.as_millis(), if *attempts == 1 { "" } else { "s" }, setup.no_reply_advice(*motor)
    )]
    NoReply {
        /// The motor asked.
        motor: MotorId,
        /// The request's command.
        command: Command,
        /// The timeout of each attempt.
        timeout: Duration,
        /// How many times the request was sent.
        attempts: u32,
        /// What the bus is.
        setup: Setup,
        /// What the bus reported meanwhile.
        signs: BusSigns,
    },
    /// The motor's id answered, but to another command.
    #[error(
        "motor {motor} answered {command} with a {got} reply: another program is probably \
         talking to motor {motor} on the same bus; stop it and try again"
    )]
    Mismatch {
        /// The motor asked.
        motor: MotorId,
        /// The request's command.
        command: Command,
        /// The command byte of the reply.
        got: Command,
    },
    /// A reply that cannot be decoded.
    #[error(
        "motor {motor} sent an invalid reply to {command}: {error}; try again, and if it \
         persists check the wiring (corrupted frames) and the motor's firmware (protocol \
         {} expected, --protocol chooses; {})",
        dialect.map_or("of any family".to_owned(), |d| d.to_string()), setup.firmware_advice()
    )]
    BadReply {
        /// The motor asked.
        motor: MotorId,
        /// The request's command.
        command: Command,
        /// What is wrong with the reply.
        error: ProtocolError,
        /// The protocol spoken (`None`: motor off, the same in every family).
        dialect: Option<Dialect>,
        /// What the bus is.
        setup: Setup,
    },
    /// The motor answered on the other families' reply identifier: it speaks another protocol.
    #[error("{}", other_firmware(*motor, *command, *can_id, *expected, setup))]
    OtherFirmware {
        /// The motor asked.
        motor: MotorId,
        /// The request's command.
        command: Command,
        /// The identifier it answered on.
        can_id: u16,
        /// The protocol the request was sent in.
        expected: Dialect,
        /// What the bus is.
        setup: Setup,
    },
    /// The motor's family does not have the command (as rmd-rt speaks it): nothing was sent.
    #[error(
        "motor {motor} speaks {dialect}, which has no {command} (0x{:02X}): {}; {command} was \
         not sent",
        command.code(), instead(dialect.family(), *command)
    )]
    NotInFamily {
        /// The motor.
        motor: MotorId,
        /// The command refused.
        command: Command,
        /// The motor's protocol.
        dialect: Dialect,
    },
    /// An LK-TECH motor of unknown series, asked a command with a current: nothing was sent.
    #[error(
        "motor {motor} answers as LK-TECH V2.3x firmware, whose current scale depends on the \
         motor series, which its frames do not carry: add --lk-series mf (MF motors, ±16.5 A) \
         or --lk-series mg (MG, ±33 A); {command} was not sent"
    )]
    LkSeriesNeeded {
        /// The motor.
        motor: MotorId,
        /// The command refused.
        command: Command,
    },
    /// The motor answered the identifying requests, but its family cannot be told from them.
    #[error(
        "cannot tell which protocol motor {motor} speaks: it {finding}; name it with --protocol \
         (v1.61, lk-v2.3x with --lk-series, or myactuator-v3); `rmd scan` shows what each motor \
         answers"
    )]
    Unidentified {
        /// The motor.
        motor: MotorId,
        /// What its answers showed.
        finding: Finding,
    },
    /// The request cannot be expressed in the protocol spoken (a current beyond its range).
    #[error("cannot send {command} to motor {motor} in protocol {dialect}: {error}")]
    Unencodable {
        /// The motor.
        motor: MotorId,
        /// The request's command.
        command: Command,
        /// The protocol spoken.
        dialect: Dialect,
        /// What does not fit.
        error: ProtocolError,
    },
    /// The request could not be sent.
    #[error("cannot send {command} to motor {motor}: {error}")]
    Send {
        /// The motor.
        motor: MotorId,
        /// The request's command.
        command: Command,
        /// The bus's error (its message says how to fix it).
        error: BusError,
    },
    /// Receiving failed.
    #[error("waiting for the reply of motor {motor} to {command} failed: {error}")]
    Receive {
        /// The motor.
        motor: MotorId,
        /// The request's command.
        command: Command,
        /// The bus's error (its message says how to fix it).
        error: BusError,
    },
}

impl ExchangeError {
    /// Whether the bus itself failed (nothing else will work on it either).
    pub(crate) fn is_bus_failure(&self) -> bool {
        matches!(
            self,
            ExchangeError::Send { .. } | ExchangeError::Receive { .. }
        )
    }

    /// Whether the request cannot go to this motor at all as the command stands (its family
    /// lacks it, or is not known well enough): asking again will not help, the command line
    /// must change.
    pub(crate) fn is_refusal(&self) -> bool {
        matches!(
            self,
            ExchangeError::NotInFamily { .. }
                | ExchangeError::LkSeriesNeeded { .. }
                | ExchangeError::Unidentified { .. }
                | ExchangeError::Unencodable { .. }
        )
    }
}

/// Pause between two sends refused because the transmit queue is full.
const TX_FULL_PAUSE: Duration = Duration::from_micros(200);

impl From<ExchangeError> for CliError {
    fn from(error: ExchangeError) -> Self {
        CliError::Failed(error.to_string())
    }
}

/// Why a motor answered on the other families' identifier, and what to do.
fn other_firmware(
    motor: MotorId,
    command: Command,
    can_id: u16,
    expected: Dialect,
    setup: &Setup,
) -> String {
    let (base, speaks) = if can_id >= V3_REPLY_BASE_ID {
        ("0x240", "MyActuator V3 firmware does")
    } else {
        ("0x140", "v1.61 and LK-TECH firmware do")
    };
    format!(
        "motor {motor} answered {command} on 0x{can_id:03X} ({base} + id), as {speaks}, not \
         protocol {expected}: nothing else was sent to it; name its protocol rightly \
         (--protocol, or the robot description's `protocol`), or leave --protocol out to have \
         each motor identified ({})",
        setup.firmware_advice()
    )
}

/// What a received frame is to an exchange with one motor.
enum Heard {
    /// The answer.
    Answer(Reply),
    /// The motor's answer to another command.
    Mismatch(Command),
    /// The motor's answer, malformed.
    Bad(ProtocolError),
    /// An answer on the other families' identifier (a motor of another protocol).
    OtherFamily(u16),
    /// Not from this motor, or not an answer.
    NotOurs,
}

/// Sends `request` to `motor` in `dialect` and returns its reply (see the module docs).
/// Refused before anything is sent: a command the dialect does not have
/// ([`ExchangeError::NotInFamily`]), a value it cannot carry ([`ExchangeError::Unencodable`]).
pub(crate) fn request(
    bus: &mut dyn CanBus,
    clock: &dyn Clock,
    policy: &Policy,
    dialect: Dialect,
    motor: MotorId,
    request: &Request,
) -> Result<Reply, ExchangeError> {
    let command = request.command();
    let frame = dialect
        .encode(motor, request)
        .map_err(|error| match error {
            ProtocolError::UnsupportedCommand { .. } => ExchangeError::NotInFamily {
                motor,
                command,
                dialect,
            },
            error => ExchangeError::Unencodable {
                motor,
                command,
                dialect,
                error,
            },
        })?;
    // The other families' reply identifier, and what a frame on it says.
    let (other_id, other_is_request_echo) = match dialect {
        Dialect::MyActuatorV3(_) => (SINGLE_MOTOR_BASE_ID + u16::from(motor.get()), true),
        Dialect::V161 | Dialect::LkV23x(_) => (V3_REPLY_BASE_ID + u16::from(motor.get()), false),
    };
    let hear = |reply: &CanFrame| {
        if reply.id() == dialect.reply_id(motor) {
            match dialect.decode_answer(reply, motor, command) {
                Ok(answer) => Heard::Answer(answer),
                Err(ProtocolError::ReplyMismatch { got, .. }) => Heard::Mismatch(got),
                Err(error) => Heard::Bad(error),
            }
        } else if reply.id() == other_id
            && reply.data().first() == Some(&command.code())
            // On 0x140 + id, the request itself (another program's, or our own looped back)
            // is not an answer.
            && !(other_is_request_echo && *reply == frame)
        {
            Heard::OtherFamily(reply.id())
        } else {
            Heard::NotOurs
        }
    };
    let asked = Asked {
        motor,
        command,
        dialect: Some(dialect),
    };
    exchange(bus, clock, policy, asked, &frame, hear)
}

/// Turns `motor` off (0x80) whatever its family: the request and its echo are the same bytes
/// in every family, and the echo comes back on `0x140 + id` (v1.61, LK-TECH) or `0x240 + id`
/// (MyActuator V3). What a safe stop sends to a motor whose family it has not learned. Returns
/// the echo and the family whose identifier it came on (v1.61 for `0x140 + id`; a V3 dialect
/// without a firmware date, which no command after motor off depends on).
pub(crate) fn motor_off_any_family(
    bus: &mut dyn CanBus,
    clock: &dyn Clock,
    policy: &Policy,
    motor: MotorId,
) -> Result<(Reply, Dialect), ExchangeError> {
    let frame = Dialect::V161.motor_off(motor);
    let v3 = Dialect::MyActuatorV3(V3Firmware::default());
    let answered_on = std::cell::Cell::new(Dialect::V161);
    let hear = |reply: &CanFrame| {
        let dialect = if reply.id() == v3.reply_id(motor) {
            v3
        } else if reply.id() == Dialect::V161.reply_id(motor) {
            Dialect::V161
        } else {
            return Heard::NotOurs;
        };
        match dialect.decode_answer(reply, motor, Command::MotorOff) {
            Ok(answer) => {
                answered_on.set(dialect);
                Heard::Answer(answer)
            }
            Err(ProtocolError::ReplyMismatch { got, .. }) => Heard::Mismatch(got),
            Err(error) => Heard::Bad(error),
        }
    };
    let asked = Asked {
        motor,
        command: Command::MotorOff,
        dialect: None,
    };
    let reply = exchange(bus, clock, policy, asked, &frame, hear)?;
    Ok((reply, answered_on.get()))
}

/// Who is asked what, in which protocol (`None`: a frame the same in every family).
#[derive(Copy, Clone, Debug)]
struct Asked {
    motor: MotorId,
    command: Command,
    dialect: Option<Dialect>,
}

/// Sends `frame` (the request `asked` describes) and waits for what `hear` takes as its
/// answer, with the policy's timeout and retries.
fn exchange(
    bus: &mut dyn CanBus,
    clock: &dyn Clock,
    policy: &Policy,
    asked: Asked,
    frame: &CanFrame,
    hear: impl Fn(&CanFrame) -> Heard,
) -> Result<Reply, ExchangeError> {
    let Asked {
        motor,
        command,
        dialect,
    } = asked;
    let attempts = policy.retries.saturating_add(1);
    let mut signs = BusSigns::default();
    let mut mismatch = None;
    let mut bad = None;
    let mut other_family = None;
    let receive_error = |error| ExchangeError::Receive {
        motor,
        command,
        error,
    };
    for _ in 0..attempts {
        drain(bus, &mut signs).map_err(receive_error)?;
        send(bus, clock, frame, policy.timeout).map_err(|error| ExchangeError::Send {
            motor,
            command,
            error,
        })?;
        let deadline = clock.now() + policy.timeout;
        while let Some(received) = bus.recv_until(deadline).map_err(receive_error)? {
            match received.message {
                BusMessage::Event(BusEvent::BusOff) => {
                    return Err(receive_error(BusError::BusOff));
                }
                BusMessage::Event(event) => signs.note(event),
                BusMessage::Frame(reply) => match hear(&reply) {
                    Heard::Answer(answer) => return Ok(answer),
                    Heard::Mismatch(got) => mismatch = Some(got),
                    Heard::Bad(error) => bad = Some(error),
                    Heard::OtherFamily(can_id) => other_family = Some(can_id),
                    Heard::NotOurs => {}
                },
            }
        }
    }
    Err(match (bad, other_family, mismatch, dialect) {
        (Some(error), _, _, _) => ExchangeError::BadReply {
            motor,
            command,
            error,
            dialect,
            setup: policy.setup.clone(),
        },
        (None, Some(can_id), _, Some(expected)) => ExchangeError::OtherFirmware {
            motor,
            command,
            can_id,
            expected,
            setup: policy.setup.clone(),
        },
        (None, _, Some(got), _) => ExchangeError::Mismatch {
            motor,
            command,
            got,
        },
        _ => ExchangeError::NoReply {
            motor,
            command,
            timeout: policy.timeout,
            attempts,
            setup: policy.setup.clone(),
            signs,
        },
    })
}

/// Discards what is already received (stale replies), keeping note of bus events.
pub(crate) fn drain(bus: &mut dyn CanBus, signs: &mut BusSigns) -> Result<(), BusError> {
    while let Some(received) = bus.recv_until(Timestamp::ZERO)? {
        match received.message {
            BusMessage::Event(BusEvent::BusOff) => return Err(BusError::BusOff),
            BusMessage::Event(event) => signs.note(event),
            BusMessage::Frame(_) => {}
        }
    }
    Ok(())
}

/// Sends `frame`, trying again while the transmit queue is full, for at most `patience`.
pub(crate) fn send(
    bus: &mut dyn CanBus,
    clock: &dyn Clock,
    frame: &CanFrame,
    patience: Duration,
) -> Result<(), BusError> {
    let give_up = clock.now() + patience;
    loop {
        match bus.send(frame) {
            Err(BusError::TxQueueFull) if clock.now() < give_up => {
                clock.sleep_until(clock.now() + TX_FULL_PAUSE);
            }
            other => return other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::{Received, VirtualClock};
    use rmd_protocol::ProtocolFamily;
    use rmd_sim::{FaultRule, ReplyFault, SimBus, SimConfig};

    fn id(n: u8) -> MotorId {
        MotorId::new(n).unwrap()
    }

    fn policy(retries: u32) -> Policy {
        Policy {
            timeout: Duration::from_millis(10),
            retries,
            setup: Setup::Simulator(crate::args::ids::parse("1-4").unwrap()),
        }
    }

    fn sim(faults: &[FaultRule]) -> (VirtualClock, SimBus<VirtualClock>) {
        let clock = VirtualClock::new();
        let mut config = SimConfig::with_motors(4).seed(3);
        config.faults.extend_from_slice(faults);
        (clock.clone(), SimBus::new(clock, config).unwrap())
    }

    /// Motors 1 (v1.61), 2 (LK-TECH MF) and 3 (MyActuator V3) on one simulated bus.
    fn mixed() -> (VirtualClock, SimBus<VirtualClock>) {
        use rmd_protocol::LkSeries;
        use rmd_sim::FirmwareFamily;
        let clock = VirtualClock::new();
        let mut config = SimConfig::with_motors(3).seed(3);
        let families = [
            FirmwareFamily::V161,
            FirmwareFamily::LkV23x(LkSeries::Mf),
            FirmwareFamily::MyActuatorV3,
        ];
        for (motor, family) in config.motors.iter_mut().zip(families) {
            motor.firmware.family = family;
        }
        (clock.clone(), SimBus::new(clock, config).unwrap())
    }

    const V3: Dialect = Dialect::MyActuatorV3(V3Firmware {
        date: None,
        max_torque: None,
    });

    #[test]
    fn each_family_is_spoken_in_its_own_layout_and_a_wrong_one_is_named() {
        let (clock, mut bus) = mixed();
        let p = policy(0);
        // V3 answers on 0x243, in its layout (status 1 with the brake byte).
        let reply = request(&mut bus, &clock, &p, V3, id(3), &Request::ReadStatus1).unwrap();
        assert!(matches!(
            reply.status1(),
            Some(rmd_protocol::Status1::V3(_))
        ));
        // v1.61 spoken to the V3 motor: it answers on 0x243, and is named for it.
        let error = request(
            &mut bus,
            &clock,
            &p,
            Dialect::V161,
            id(3),
            &Request::ReadStatus1,
        )
        .unwrap_err();
        assert!(
            matches!(error, ExchangeError::OtherFirmware { can_id: 0x243, .. }),
            "{error}"
        );
        assert!(error.to_string().contains("as MyActuator V3 firmware does"));
        // V3 spoken to the v1.61 motor: it answers on 0x141.
        let error = request(&mut bus, &clock, &p, V3, id(1), &Request::ReadStatus1).unwrap_err();
        assert!(
            matches!(error, ExchangeError::OtherFirmware { can_id: 0x141, .. }),
            "{error}"
        );
        // A command V3 lacks is refused before anything is sent.
        let before = bus.stats();
        let error = request(&mut bus, &clock, &p, V3, id(3), &Request::ReadPid).unwrap_err();
        assert!(
            matches!(error, ExchangeError::NotInFamily { .. }),
            "{error}"
        );
        assert_eq!(bus.stats(), before);
        // A current in another family's scale too: the codec refuses it.
        let v161_amp = Request::Torque {
            iq_control: rmd_protocol::IqControl::from_amps(1.0).unwrap().into(),
        };
        let error = request(&mut bus, &clock, &p, V3, id(3), &v161_amp).unwrap_err();
        assert!(
            matches!(
                error,
                ExchangeError::Unencodable {
                    error: ProtocolError::ScaleMismatch { .. },
                    ..
                }
            ),
            "{error}"
        );
        assert_eq!(bus.stats(), before);
    }

    #[test]
    fn motor_off_reaches_every_family_and_says_which_answered() {
        let (clock, mut bus) = mixed();
        for (motor, family) in [
            (1, ProtocolFamily::V161),
            (2, ProtocolFamily::V161),
            (3, ProtocolFamily::MyActuatorV3),
        ] {
            let (reply, dialect) =
                motor_off_any_family(&mut bus, &clock, &policy(0), id(motor)).unwrap();
            assert_eq!(reply, Reply::MotorOff);
            // LK-TECH answers on 0x140 + id, as v1.61 does.
            assert_eq!(dialect.family(), family, "motor {motor}");
        }
        let error = motor_off_any_family(&mut bus, &clock, &policy(0), id(4)).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("motor 4 did not answer motor-off"),
            "{error}"
        );
    }

    #[test]
    fn a_stale_v3_reply_is_not_an_answer() {
        // A V3 motor answers a command it does not know with its previous reply
        // (github.com/2b-t/myactuator_rmd issue 24): a 0xB2 reply to a 0x9A request is no
        // status 1.
        let stale = CanFrame::new(0x241, &[0xB2, 0, 0, 0, 0x7A, 0x1E, 0xB4, 0x78]).unwrap();
        let mut bus = scripted(vec![BusMessage::Frame(stale)], None);
        let clock = bus.clock.clone();
        let error = request(
            &mut bus,
            &clock,
            &policy(0),
            V3,
            id(1),
            &Request::ReadStatus1,
        )
        .unwrap_err();
        assert!(
            matches!(
                error,
                ExchangeError::Mismatch {
                    got: Command::ReadFirmwareDate,
                    ..
                }
            ),
            "{error}"
        );
    }

    #[test]
    fn a_reply_comes_back_typed() {
        let (clock, mut bus) = sim(&[]);
        let reply = request(
            &mut bus,
            &clock,
            &policy(0),
            Dialect::V161,
            id(2),
            &Request::ReadStatus1,
        )
        .unwrap();
        let status = reply.status1().unwrap();
        assert_eq!(status.temperature().celsius(), 25.0);
        // One exchange on a 1 Mbit/s bus: well under the timeout.
        assert!(clock.now() < Timestamp::ZERO + Duration::from_millis(2));
    }

    #[test]
    fn lost_replies_are_retried() {
        let drop_two = FaultRule::new(ReplyFault::DropReply)
            .motor(id(1))
            .frames_window(0, 2);
        let (clock, mut bus) = sim(&[drop_two]);
        let reply = request(
            &mut bus,
            &clock,
            &policy(2),
            Dialect::V161,
            id(1),
            &Request::ReadPid,
        )
        .unwrap();
        assert_eq!(reply.command(), Command::ReadPid);
        // Two timeouts were waited out first.
        assert!(clock.now() >= Timestamp::ZERO + Duration::from_millis(20));

        let (clock, mut bus) = sim(&[drop_two]);
        let error = request(
            &mut bus,
            &clock,
            &policy(1),
            Dialect::V161,
            id(1),
            &Request::ReadPid,
        )
        .unwrap_err();
        assert!(matches!(error, ExchangeError::NoReply { .. }), "{error}");
        assert_eq!(
            error.to_string(),
            "motor 1 did not answer read-pid within 10 ms (2 attempts): the simulated motors \
             are 1-4 (choose them with --sim-ids)"
        );
    }

    #[test]
    fn a_missing_motor_on_an_interface_gets_wiring_advice() {
        let (clock, mut bus) = sim(&[]);
        let policy = Policy {
            setup: Setup::Interface("can0".into()),
            ..policy(0)
        };
        let error = request(
            &mut bus,
            &clock,
            &policy,
            Dialect::V161,
            id(9),
            &Request::ReadStatus1,
        )
        .unwrap_err();
        let text = error.to_string();
        assert!(text.starts_with("motor 9 did not answer read-status-1 within 10 ms (1 attempt)"));
        assert!(text.contains("that its CAN id is 9"), "{text}");
        assert!(text.contains("rmd scan --iface can0"), "{text}");
    }

    #[test]
    fn a_malformed_reply_is_reported_when_no_good_one_comes() {
        let short = FaultRule::new(ReplyFault::WrongDlc { dlc: 4 }).motor(id(3));
        let (clock, mut bus) = sim(&[short]);
        let error = request(
            &mut bus,
            &clock,
            &policy(1),
            Dialect::V161,
            id(3),
            &Request::ReadAccel,
        )
        .unwrap_err();
        assert!(
            matches!(
                error,
                ExchangeError::BadReply {
                    error: ProtocolError::WrongDlc { dlc: 4, .. },
                    ..
                }
            ),
            "{error}"
        );
        assert!(
            error
                .to_string()
                .starts_with("motor 3 sent an invalid reply to read-accel")
        );
    }

    /// A bus whose only traffic is scripted: every send gets the scripted answers.
    struct Scripted {
        clock: VirtualClock,
        answers: Vec<BusMessage>,
        queue: Vec<Received>,
        send_error: Option<BusError>,
        sent: usize,
    }

    impl CanBus for Scripted {
        fn send(&mut self, _: &CanFrame) -> Result<(), BusError> {
            if let Some(error) = self.send_error {
                return Err(error);
            }
            self.sent += 1;
            let at = self.clock.now() + Duration::from_micros(300);
            self.queue
                .extend(self.answers.iter().map(|&message| Received { at, message }));
            Ok(())
        }
        fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
            match self.queue.first() {
                Some(r) if r.at <= deadline => {
                    self.clock.sleep_until(r.at);
                    Ok(Some(self.queue.remove(0)))
                }
                _ => {
                    self.clock.sleep_until(deadline);
                    Ok(None)
                }
            }
        }
    }

    fn scripted(answers: Vec<BusMessage>, send_error: Option<BusError>) -> Scripted {
        Scripted {
            clock: VirtualClock::new(),
            answers,
            queue: Vec::new(),
            send_error,
            sent: 0,
        }
    }

    #[test]
    fn a_reply_to_another_command_is_a_mismatch_and_other_motors_are_ignored() {
        let other_motor = Dialect::V161.encode_reply(id(2), &Reply::MotorOff).unwrap();
        let wrong_command = Dialect::V161
            .encode_reply(id(1), &Reply::MotorStop)
            .unwrap();
        let mut bus = scripted(
            vec![
                BusMessage::Frame(other_motor),
                BusMessage::Frame(wrong_command),
            ],
            None,
        );
        let clock = bus.clock.clone();
        let error = request(
            &mut bus,
            &clock,
            &policy(2),
            Dialect::V161,
            id(1),
            &Request::MotorOff,
        )
        .unwrap_err();
        assert_eq!(bus.sent, 3);
        assert!(
            matches!(
                error,
                ExchangeError::Mismatch {
                    got: Command::MotorStop,
                    ..
                }
            ),
            "{error}"
        );
        assert!(
            error
                .to_string()
                .contains("another program is probably talking to motor 1")
        );
    }

    #[test]
    fn bus_trouble_is_named_in_the_advice_and_bus_off_ends_at_once() {
        let mut bus = scripted(vec![BusMessage::Event(BusEvent::NoAck)], None);
        let clock = bus.clock.clone();
        let error = request(
            &mut bus,
            &clock,
            &policy(0),
            Dialect::V161,
            id(1),
            &Request::ReadStatus2,
        )
        .unwrap_err();
        assert!(
            error.to_string().contains("no node acknowledges"),
            "{error}"
        );

        let mut bus = scripted(vec![BusMessage::Event(BusEvent::BusOff)], None);
        let clock = bus.clock.clone();
        let error = request(
            &mut bus,
            &clock,
            &policy(5),
            Dialect::V161,
            id(1),
            &Request::ReadStatus2,
        )
        .unwrap_err();
        assert_eq!(bus.sent, 1);
        assert!(error.is_bus_failure());
        assert!(error.to_string().contains("bus-off"), "{error}");
    }

    #[test]
    fn a_full_transmit_queue_is_retried_then_reported() {
        let mut bus = scripted(vec![], Some(BusError::TxQueueFull));
        let clock = bus.clock.clone();
        let error = request(
            &mut bus,
            &clock,
            &policy(0),
            Dialect::V161,
            id(4),
            &Request::ReadStatus1,
        )
        .unwrap_err();
        assert!(matches!(
            error,
            ExchangeError::Send {
                error: BusError::TxQueueFull,
                ..
            }
        ));
        // It kept trying for the timeout before giving up.
        assert!(clock.now() >= Timestamp::ZERO + Duration::from_millis(10));
        assert!(
            error
                .to_string()
                .starts_with("cannot send read-status-1 to motor 4")
        );
    }
}
