//! Probing one motor id for its protocol family (the bus side of `rmd_protocol::identify`),
//! for `rmd scan` and for every live command that learns a motor's family
//! ([`Connection::identify`](crate::live::connect::Connection::identify)).
//!
//! For each id: discard stale frames, send the two probe requests (0x9A and 0x9C on
//! `0x140 + id`), and offer every frame received on `0x140 + id` or `0x240 + id` until the
//! timeout to [`ProbeAnswers`] (the whole timeout, so that a second device answering on the
//! other identifier is seen too). Nothing answered: send again, up to `retries` times. A motor
//! that answered on `0x240 + id` (MyActuator V3) is then asked its model (0xB5, a V3 read
//! command) for another timeout. Both probes are read-only in every family; 0xB5 is sent only
//! to a motor that answers as V3.

use std::time::Duration;

use rmd_bus::{BusError, BusEvent, BusMessage, CanBus, CanFrame, Clock};
use rmd_protocol::{
    Command, MotorId, ProbeAnswers, V3_REPLY_BASE_ID, model_request, probe_requests,
};

use crate::live::exchange::{self, ExchangeError};

/// A motor identified ([`Connection::identify`](crate::live::connect::Connection::identify)).
#[derive(Copy, Clone, Debug)]
pub(crate) struct Identified {
    /// Its family, and the evidence.
    pub(crate) identification: rmd_protocol::Identification,
    /// What it answered to the probes.
    pub(crate) answers: ProbeAnswers,
    /// A MyActuator V3 motor's firmware date (0xB2), if it answered.
    pub(crate) firmware_date: Option<rmd_protocol::FirmwareDate>,
}

/// How long to listen and how often to send again.
#[derive(Copy, Clone, Debug)]
pub(crate) struct ProbeTiming {
    /// How long to collect answers after sending the probes (and the model request).
    pub(crate) timeout: Duration,
    /// How many times to send the probes again when nothing answered.
    pub(crate) retries: u32,
}

/// Probes `motor` on `bus` and returns what it answered (see the module docs). Errors: the bus
/// failed (send, receive, bus-off).
pub(crate) fn probe(
    bus: &mut dyn CanBus,
    clock: &dyn Clock,
    timing: ProbeTiming,
    motor: MotorId,
) -> Result<ProbeAnswers, ExchangeError> {
    let mut answers = ProbeAnswers::new();
    for _ in 0..=timing.retries {
        exchange::drain(bus, &mut Default::default())
            .map_err(|error| receive_error(motor, Command::ReadStatus1, error))?;
        for frame in probe_requests(motor) {
            send(bus, clock, &frame, timing.timeout, motor)?;
        }
        collect(bus, clock, timing.timeout, motor, &mut answers, |a| {
            a.status1().is_some() && a.status2().is_some()
        })?;
        if answers.status1().is_some() || answers.status2().is_some() {
            break;
        }
    }
    let v3_id = V3_REPLY_BASE_ID + u16::from(motor.get());
    let answered_as_v3 = [answers.status1(), answers.status2()]
        .into_iter()
        .flatten()
        .any(|f| f.id() == v3_id);
    if answered_as_v3 && answers.model().is_none() {
        send(bus, clock, &model_request(motor), timing.timeout, motor)?;
        collect(bus, clock, timing.timeout, motor, &mut answers, |a| {
            a.model().is_some()
        })?;
    }
    Ok(answers)
}

/// How long the bus must stay quiet after the answers came for the collection to end early (at
/// least; as long as the slowest answer took, if longer): an answer of a second family on the
/// other reply id comes as soon as the first.
const QUIET: Duration = Duration::from_millis(3);

/// Offers every frame received within `timeout` to `answers`; once `complete` says they are, only
/// until the bus has been quiet for [`QUIET`] or as long as the answers took, whichever is longer
/// (a motor answering on both reply ids is still heard; a long timeout is not waited out).
fn collect(
    bus: &mut dyn CanBus,
    clock: &dyn Clock,
    timeout: Duration,
    motor: MotorId,
    answers: &mut ProbeAnswers,
    complete: fn(&ProbeAnswers) -> bool,
) -> Result<(), ExchangeError> {
    let started = clock.now();
    let deadline = started + timeout;
    let mut until = deadline;
    while let Some(received) = bus
        .recv_until(until)
        .map_err(|error| receive_error(motor, Command::ReadStatus1, error))?
    {
        match received.message {
            BusMessage::Frame(frame) => {
                if answers.offer(motor, &frame) && complete(answers) {
                    let took = received
                        .at
                        .checked_duration_since(started)
                        .unwrap_or_default();
                    until = (received.at + took.max(QUIET)).min(deadline);
                }
            }
            BusMessage::Event(BusEvent::BusOff) => {
                return Err(receive_error(motor, Command::ReadStatus1, BusError::BusOff));
            }
            BusMessage::Event(_) => {}
        }
    }
    Ok(())
}

fn send(
    bus: &mut dyn CanBus,
    clock: &dyn Clock,
    frame: &CanFrame,
    patience: Duration,
    motor: MotorId,
) -> Result<(), ExchangeError> {
    exchange::send(bus, clock, frame, patience).map_err(|error| ExchangeError::Send {
        motor,
        command: Command::from_code(frame.data()[0]).unwrap_or(Command::ReadStatus1),
        error,
    })
}

fn receive_error(motor: MotorId, command: Command, error: BusError) -> ExchangeError {
    ExchangeError::Receive {
        motor,
        command,
        error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::VirtualClock;
    use rmd_protocol::{Finding, LkSeries, ProtocolFamily, identify};
    use rmd_sim::{FaultRule, FirmwareFamily, ReplyFault, SimBus, SimConfig, SimMotorConfig};

    fn id(n: u8) -> MotorId {
        MotorId::new(n).unwrap()
    }

    const TIMING: ProbeTiming = ProbeTiming {
        timeout: Duration::from_millis(10),
        retries: 0,
    };

    /// A simulated bus in virtual time with one motor of each family given, ids 1, 2, ...
    fn sim_bus(
        families: &[FirmwareFamily],
        faults: &[FaultRule],
    ) -> (VirtualClock, SimBus<VirtualClock>) {
        let clock = VirtualClock::new();
        let mut config = SimConfig::with_motors(0);
        config.motors = families
            .iter()
            .enumerate()
            .map(|(k, &family)| {
                let mut motor = SimMotorConfig::new(id(k as u8 + 1));
                motor.firmware.family = family;
                motor
            })
            .collect();
        config.faults.extend_from_slice(faults);
        (clock.clone(), SimBus::new(clock, config).unwrap())
    }

    #[test]
    fn a_mixed_bus_identifies_each_motor_and_absent_ids() {
        let (clock, mut bus) = sim_bus(
            &[
                FirmwareFamily::V161,
                FirmwareFamily::LkV23x(LkSeries::Mg),
                FirmwareFamily::LkV23x(LkSeries::Mf),
                FirmwareFamily::MyActuatorV3,
            ],
            &[],
        );
        let family = |bus: &mut SimBus<VirtualClock>, n: u8| {
            let answers = probe(bus, &clock, TIMING, id(n)).unwrap();
            identify(id(n), &answers)
        };
        assert_eq!(family(&mut bus, 1).family, ProtocolFamily::V161);
        assert_eq!(family(&mut bus, 2).family, ProtocolFamily::LkV23x);
        assert_eq!(family(&mut bus, 3).family, ProtocolFamily::LkV23x);
        let v3 = family(&mut bus, 4);
        assert_eq!(v3.family, ProtocolFamily::MyActuatorV3);
        assert_eq!(v3.evidence.reply_id, Some(0x244));
        assert_eq!(v3.evidence.model_str(), Some("RMD-SIM"));
        let absent = family(&mut bus, 5);
        assert_eq!(
            (absent.family, absent.evidence.finding),
            (ProtocolFamily::Unknown, Finding::NoAnswer)
        );
    }

    #[test]
    fn a_long_timeout_is_not_waited_out_once_the_answers_came() {
        let (clock, mut bus) = sim_bus(&[FirmwareFamily::V161, FirmwareFamily::MyActuatorV3], &[]);
        let minute = ProbeTiming {
            timeout: Duration::from_secs(60),
            retries: 0,
        };
        for n in [1, 2] {
            let before = clock.now();
            let answers = probe(&mut bus, &clock, minute, id(n)).unwrap();
            assert_ne!(identify(id(n), &answers).family, ProtocolFamily::Unknown);
            // The answers, then the bus quiet for as long as they took (a few ms), not a minute.
            let waited = clock.now() - before;
            assert!(waited < Duration::from_millis(50), "motor {n}: {waited:?}");
        }
        // An absent motor is waited for the whole timeout.
        let before = clock.now();
        probe(&mut bus, &clock, minute, id(3)).unwrap();
        assert!(clock.now() - before >= Duration::from_secs(60));
    }

    #[test]
    fn nothing_answered_is_sent_again() {
        // The replies to motor 1's first two frames (the first pair of probes) are lost.
        let drop_two = FaultRule::new(ReplyFault::DropReply)
            .motor(id(1))
            .frames_window(0, 2);
        let (clock, mut bus) = sim_bus(&[FirmwareFamily::V161], &[drop_two]);
        let answers = probe(&mut bus, &clock, TIMING, id(1)).unwrap();
        assert!(answers.status1().is_none() && answers.status2().is_none());
        let (clock, mut bus) = sim_bus(&[FirmwareFamily::V161], &[drop_two]);
        let timing = ProbeTiming {
            retries: 1,
            ..TIMING
        };
        let answers = probe(&mut bus, &clock, timing, id(1)).unwrap();
        assert_eq!(identify(id(1), &answers).family, ProtocolFamily::V161);
    }
}
