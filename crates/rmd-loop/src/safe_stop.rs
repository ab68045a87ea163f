//! Making the motors safe when the loop ends, whatever the reason: zero torque (one 0x280 frame
//! on a `multi-torque` bus; one zero 0xA1 request per motor, in its own family, on a
//! `per-motor` bus: never a 0x280 frame there), then motor-off (0x80) to every motor, confirmed
//! by each motor's echo; then, for MyActuator V3 motors with a brake, brake lock (0x78),
//! confirmed the same way.
//!
//! A stop that finishes, bus by bus, each on its own so that a fault on one never abandons the
//! others:
//!
//! - a full or stalled transmit queue is retried until the stop's deadline
//!   (`safe_stop.deadline_ms`);
//! - a bus that is bus-off is waited for (at most `safe_stop.bus_off_wait_ms`) until its
//!   controller restarts, then zero torque and motor-off go out;
//! - a motor that does not confirm motor-off is sent it again (every `safe_stop.retry_ms`)
//!   until the deadline.
//!
//! The report names every motor that did not confirm and says plainly that it may still be
//! energised, and why.

use core::fmt;
use core::time::Duration;

use rmd_bus::{BusError, BusEvent, BusMessage, CanBus, Clock, Timestamp};
use rmd_protocol::{Command, MULTI_TORQUE_MOTORS, MotorId, Request};
use serde::Serialize;

use crate::bus_link::BusLink;
use crate::exchange::frames::{ZERO_TORQUE, torque_frame, torque_request, zero_iq};
use crate::robot::{ExchangeKind, JointSpec, Robot, SafeStopSettings};

/// What the safe stop did for one motor.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct MotorSafeStop {
    /// The joint's name.
    pub joint: String,
    /// Bus index.
    pub bus: usize,
    /// Motor id.
    #[serde(serialize_with = "serialize_motor_id")]
    pub motor: MotorId,
    /// Whether the run ever commanded its bus (a 0x280 frame); if not, nothing was sent to it
    /// (the start stopped before any torque) and there is nothing to undo.
    pub commanded: bool,
    /// Zero torque was queued to it (its bus's 0x280 frame, or its own zero 0xA1 request).
    pub zero_torque_sent: bool,
    /// Motor-off (0x80) commands queued to it.
    pub off_attempts: u32,
    /// The motor answered the motor-off command.
    pub off_confirmed: bool,
    /// For a motor with a brake (MyActuator V3): whether it confirmed brake lock (0x78) after
    /// motor-off; `None` without a brake.
    pub brake_locked: Option<bool>,
}

fn serialize_motor_id<S: serde::Serializer>(id: &MotorId, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u8(id.get())
}

/// How the safe stop ended on one bus.
#[derive(Copy, Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "outcome", rename_all = "kebab-case")]
pub enum BusStopOutcome {
    /// Every motor of the bus confirmed motor-off.
    Confirmed {
        /// From the start of the safe stop, milliseconds.
        after_ms: f64,
    },
    /// The bus stayed bus-off longer than `safe_stop.bus_off_wait_ms`.
    BusOff {
        /// How long it was waited for, milliseconds.
        waited_ms: f64,
    },
    /// Nothing was ever commanded on the bus: nothing was sent to undo it.
    NotCommanded,
    /// The deadline passed with motors unconfirmed (their replies were lost, or the bus would not
    /// take the frames).
    Deadline {
        /// The last error the bus reported, if any.
        #[serde(serialize_with = "serialize_error")]
        last_error: Option<BusError>,
    },
}

fn serialize_error<S: serde::Serializer>(e: &Option<BusError>, s: S) -> Result<S::Ok, S::Error> {
    match e {
        Some(e) => s.collect_str(e),
        None => s.serialize_none(),
    }
}

/// What the safe stop did on one bus.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BusSafeStop {
    /// Bus index.
    pub bus: usize,
    /// The bus's name.
    pub name: String,
    /// How it ended.
    #[serde(flatten)]
    pub outcome: BusStopOutcome,
}

/// The outcome of the safe-stop sequence (zero torque, then motor off, to every motor).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SafeStopReport {
    /// Per motor.
    pub motors: Vec<MotorSafeStop>,
    /// Per bus.
    pub buses: Vec<BusSafeStop>,
    /// Who made the motors safe: the loop thread, or the supervisor beside it.
    pub by: SafeStopBy,
}

/// Who ran the safe stop.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SafeStopBy {
    /// The loop thread, at the end of the run.
    #[default]
    Loop,
    /// The supervisor thread, because the loop thread did not come back in time.
    Supervisor,
}

impl SafeStopReport {
    /// Whether every motor the run commanded confirmed motor-off.
    pub fn all_off_confirmed(&self) -> bool {
        self.unconfirmed().next().is_none()
    }

    /// The motors the run commanded that did not confirm motor-off (they may still be
    /// energised).
    pub fn unconfirmed(&self) -> impl Iterator<Item = &MotorSafeStop> {
        self.motors
            .iter()
            .filter(|m| m.commanded && !m.off_confirmed)
    }
}

impl fmt::Display for SafeStopReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let commanded = self.motors.iter().filter(|m| m.commanded).count();
        if commanded == 0 {
            return f.write_str(
                "safe stop: nothing to do: no torque was commanded (the run stopped before the \
                 first torque frame)",
            );
        }
        let confirmed = self.motors.iter().filter(|m| m.off_confirmed).count();
        write!(
            f,
            "safe stop{}: zero torque then motor off; {confirmed}/{commanded} motors confirmed off",
            match self.by {
                SafeStopBy::Loop => "",
                SafeStopBy::Supervisor => " (by the supervisor)",
            },
        )?;
        for m in self.unconfirmed() {
            let bus = self.buses.iter().find(|b| b.bus == m.bus);
            write!(
                f,
                "\n  joint {} (motor {} on bus {}) NOT CONFIRMED OFF: it may still be energised. {}",
                m.joint,
                m.motor.get(),
                m.bus,
                why(m, bus)
            )?;
        }
        for m in self
            .motors
            .iter()
            .filter(|m| m.off_confirmed && m.brake_locked == Some(false))
        {
            write!(
                f,
                "\n  joint {} (motor {} on bus {}): off, but its brake was NOT CONFIRMED LOCKED \
                 (0x78): `rmd off` locks it; hold the joint before cutting power",
                m.joint,
                m.motor.get(),
                m.bus
            )?;
        }
        Ok(())
    }
}

fn why(m: &MotorSafeStop, bus: Option<&BusSafeStop>) -> String {
    match bus.map(|b| (b.name.as_str(), b.outcome)) {
        Some((name, BusStopOutcome::BusOff { waited_ms })) => format!(
            "Bus {name} stayed bus-off for {waited_ms:.0} ms and nothing could be sent: make its \
             controller restart by itself (`ip link set <iface> type can restart-ms 100`) or raise \
             safe_stop.bus_off_wait_ms; cut the motor's power now if in doubt."
        ),
        Some((_, BusStopOutcome::Deadline { last_error })) if !m.zero_torque_sent => format!(
            "Not even zero torque could be sent before safe_stop.deadline_ms{}; cut the motor's \
             power now if in doubt.",
            last_error
                .map(|e| format!(" (last error: {e})"))
                .unwrap_or_default()
        ),
        _ => format!(
            "Zero torque and {} motor-off command(s) were sent, and no answer came; turn it off \
             with `rmd off` or cut its power.",
            m.off_attempts
        ),
    }
}

/// Progress of the safe stop on one bus.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum BusStopPhase {
    /// Zero torque to the bus's motors from this one (index in description order) on (on a
    /// `multi-torque` bus, the one 0x280 frame when `next` is the first).
    Zero { next: usize },
    /// Motor-off to the bus's motors from this one (index in description order) on.
    Off { next: usize },
    /// Waiting for confirmations since the last round was sent.
    Confirm { round_sent: Timestamp },
    /// Brake lock to the bus's braked motors from this one on (every motor confirmed off).
    Lock { next: usize },
    /// Waiting for brake-lock confirmations since the last round was sent.
    ConfirmLock { round_sent: Timestamp },
    /// Finished.
    Done,
}

/// The state of one bus during the safe stop.
struct BusStop {
    phase: BusStopPhase,
    bus_off_since: Option<Timestamp>,
    last_error: Option<BusError>,
}

/// Zero torque, then motor off, to every motor on every bus (`ids`: each joint's motor id in
/// description order); reports what was confirmed.
/// `on_off_sent` runs once, as soon as every bus has sent motor-off to each of its motors (or
/// has given up).
pub(crate) fn make_safe<B: CanBus, C: Clock>(
    clock: &C,
    links: &mut [BusLink<B>],
    ids: &[MotorId],
    robot: &Robot,
    settings: &SafeStopSettings,
    mut on_off_sent: impl FnMut(),
) -> SafeStopReport {
    let mut report = SafeStopReport {
        motors: robot
            .joints()
            .iter()
            .map(|j| MotorSafeStop {
                joint: j.name.clone(),
                bus: j.bus,
                motor: j.motor,
                commanded: links[j.bus].commanded,
                zero_torque_sent: false,
                off_attempts: 0,
                off_confirmed: false,
                brake_locked: j.brake.then_some(false),
            })
            .collect(),
        buses: Vec::with_capacity(links.len()),
        by: SafeStopBy::Loop,
    };
    let start = clock.now();
    let deadline = start + settings.deadline;
    let mut stops: Vec<BusStop> = links
        .iter()
        .map(|link| BusStop {
            phase: BusStopPhase::Zero {
                next: link.joints.start,
            },
            bus_off_since: None,
            last_error: None,
        })
        .collect();
    // A bus never commanded has nothing to undo: nothing is sent to it.
    let mut outcomes: Vec<Option<BusStopOutcome>> = links
        .iter()
        .map(|l| (!l.commanded).then_some(BusStopOutcome::NotCommanded))
        .collect();
    let mut off_sent_told = false;
    loop {
        let now = clock.now();
        for (b, (link, stop)) in links.iter_mut().zip(&mut stops).enumerate() {
            if outcomes[b].is_some() {
                continue;
            }
            step_bus(link, stop, ids, robot.joints(), &mut report, now, settings);
            outcomes[b] = match stop.phase {
                BusStopPhase::Done => Some(BusStopOutcome::Confirmed {
                    after_ms: ms(now - start),
                }),
                _ => match stop.bus_off_since {
                    Some(since) if now - since >= settings.bus_off_wait => {
                        Some(BusStopOutcome::BusOff {
                            waited_ms: ms(now - since),
                        })
                    }
                    _ => None,
                },
            };
        }
        if !off_sent_told
            && stops.iter().zip(&outcomes).all(|(s, o)| {
                o.is_some()
                    || matches!(
                        s.phase,
                        BusStopPhase::Confirm { .. }
                            | BusStopPhase::Lock { .. }
                            | BusStopPhase::ConfirmLock { .. }
                            | BusStopPhase::Done
                    )
            })
        {
            off_sent_told = true;
            on_off_sent();
        }
        if outcomes.iter().all(Option::is_some) {
            break;
        }
        if now >= deadline {
            for (outcome, stop) in outcomes.iter_mut().zip(&stops) {
                outcome.get_or_insert(BusStopOutcome::Deadline {
                    last_error: stop.last_error,
                });
            }
            break;
        }
        clock.sleep_until((now + POLL_EVERY).min(deadline));
    }
    if !off_sent_told {
        on_off_sent();
    }
    report.buses = robot
        .buses()
        .iter()
        .zip(outcomes)
        .enumerate()
        .map(|(bus, (spec, outcome))| BusSafeStop {
            bus,
            name: spec.name.clone(),
            outcome: outcome.unwrap_or(BusStopOutcome::Deadline { last_error: None }),
        })
        .collect();
    report
}

/// How long the safe stop waits between two rounds over the buses.
const POLL_EVERY: Duration = Duration::from_micros(200);

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

/// One round on one bus: take in what came (confirmations, bus events), then send what is next.
fn step_bus<B: CanBus>(
    link: &mut BusLink<B>,
    stop: &mut BusStop,
    ids: &[MotorId],
    joints: &[JointSpec],
    report: &mut SafeStopReport,
    now: Timestamp,
    settings: &SafeStopSettings,
) {
    receive(link, stop, ids, joints, report, now);
    loop {
        match stop.phase {
            BusStopPhase::Zero { next } if next >= link.joints.end => {
                stop.phase = BusStopPhase::Off {
                    next: link.joints.start,
                };
            }
            BusStopPhase::Zero { next } => {
                // One 0x280 frame for the bus's motors 1..=4 (sent for the first of them), each
                // other motor its own zero request, in its family's scale (on a `motion` bus
                // too: a V3 motor leaves motion mode for zero torque).
                let in_frame = match link.exchange {
                    ExchangeKind::MultiTorque => {
                        usize::from(ids[next].get()) <= MULTI_TORQUE_MOTORS
                    }
                    ExchangeKind::PerMotor | ExchangeKind::Motion => false,
                };
                if in_frame && report.motors[next].zero_torque_sent {
                    stop.phase = BusStopPhase::Zero { next: next + 1 };
                    continue;
                }
                let frame = if in_frame {
                    torque_frame(&ZERO_TORQUE)
                } else {
                    let d = joints[next].dialect;
                    torque_request(d, ids[next], zero_iq(d))
                };
                match link.bus.send(&frame) {
                    Ok(()) => {
                        for m in link.joints() {
                            let reached = m == next
                                || (in_frame && usize::from(ids[m].get()) <= MULTI_TORQUE_MOTORS);
                            if reached {
                                report.motors[m].zero_torque_sent = true;
                            }
                        }
                        stop.phase = BusStopPhase::Zero { next: next + 1 };
                    }
                    Err(e) => return note(stop, e, now),
                }
            }
            BusStopPhase::Off { next } if next >= link.joints.end => {
                stop.phase = BusStopPhase::Confirm { round_sent: now };
            }
            BusStopPhase::Off { next } => {
                if report.motors[next].off_confirmed {
                    stop.phase = BusStopPhase::Off { next: next + 1 };
                    continue;
                }
                // Motor-off is the same frame in every family (0x140 + id, 0x80).
                match link.bus.send(&joints[next].dialect.motor_off(ids[next])) {
                    Ok(()) => {
                        report.motors[next].off_attempts += 1;
                        stop.phase = BusStopPhase::Off { next: next + 1 };
                    }
                    Err(e) => return note(stop, e, now),
                }
            }
            BusStopPhase::Confirm { round_sent } => {
                if link.joints().all(|m| report.motors[m].off_confirmed) {
                    stop.phase = BusStopPhase::Lock {
                        next: link.joints.start,
                    };
                    continue;
                } else if now - round_sent >= settings.retry_every {
                    // Another round of motor-off for the unconfirmed (not zero torque again: a
                    // torque frame would put the motors already off back in torque mode).
                    stop.phase = BusStopPhase::Off {
                        next: link.joints.start,
                    };
                    continue;
                }
                return;
            }
            BusStopPhase::Lock { next } if next >= link.joints.end => {
                stop.phase = BusStopPhase::ConfirmLock { round_sent: now };
            }
            BusStopPhase::Lock { next } => {
                if report.motors[next].brake_locked != Some(false) {
                    stop.phase = BusStopPhase::Lock { next: next + 1 };
                    continue;
                }
                let lock = joints[next].dialect.encode(ids[next], &Request::BrakeLock);
                // Only V3 motors have a brake (checked with the description): `lock` is a frame.
                let Ok(frame) = lock else {
                    stop.phase = BusStopPhase::Lock { next: next + 1 };
                    continue;
                };
                match link.bus.send(&frame) {
                    Ok(()) => stop.phase = BusStopPhase::Lock { next: next + 1 },
                    Err(e) => return note(stop, e, now),
                }
            }
            BusStopPhase::ConfirmLock { round_sent } => {
                if link
                    .joints()
                    .all(|m| report.motors[m].brake_locked != Some(false))
                {
                    stop.phase = BusStopPhase::Done;
                } else if now - round_sent >= settings.retry_every {
                    stop.phase = BusStopPhase::Lock {
                        next: link.joints.start,
                    };
                    continue;
                }
                return;
            }
            BusStopPhase::Done => return,
        }
    }
}

/// Takes in everything the bus has received: motor-off and brake-lock echoes (each decoded in
/// its motor's family, on its reply id) confirm their motor; bus-off and restart events start
/// and end the wait for the controller.
fn receive<B: CanBus>(
    link: &mut BusLink<B>,
    stop: &mut BusStop,
    ids: &[MotorId],
    joints: &[JointSpec],
    report: &mut SafeStopReport,
    now: Timestamp,
) {
    loop {
        match link.bus.recv_until(now) {
            Ok(Some(received)) => match received.message {
                BusMessage::Frame(frame) => {
                    for m in link.joints() {
                        let d = joints[m].dialect;
                        if d.decode_answer(&frame, ids[m], Command::MotorOff).is_ok() {
                            report.motors[m].off_confirmed = true;
                        } else if report.motors[m].brake_locked.is_some()
                            && d.decode_answer(&frame, ids[m], Command::BrakeLock).is_ok()
                        {
                            report.motors[m].brake_locked = Some(true);
                        }
                    }
                    // Any frame received means the controller is on the bus again.
                    stop.bus_off_since = None;
                }
                BusMessage::Event(BusEvent::BusOff) => {
                    stop.bus_off_since.get_or_insert(received.at);
                }
                BusMessage::Event(
                    BusEvent::Restarted | BusEvent::ErrorActive | BusEvent::ErrorWarning,
                ) => stop.bus_off_since = None,
                BusMessage::Event(_) => {}
            },
            Ok(None) => return,
            Err(e) => return note(stop, e, now),
        }
    }
}

fn note(stop: &mut BusStop, error: BusError, now: Timestamp) {
    if error == BusError::BusOff {
        stop.bus_off_since.get_or_insert(now);
    }
    stop.last_error = Some(error);
}
