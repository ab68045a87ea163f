//! One request, its reply: the waiting of `Bus.request`, without Python.
//!
//! Whatever is queued is dropped first (stale replies), the request is sent, and replies are
//! awaited until the timeout: a reply of the motor to that command, on its family's reply
//! identifier (`0x140 + id` for v1.61 and LK-TECH, `0x240 + id` for MyActuator V3), ends the
//! wait; frames of other motors are ignored; a reply to another command, or a malformed one, is
//! remembered and reported if no good reply comes; an answer on the other families' identifier
//! is a motor of another family than the bus was opened for, its own error. After a timeout the
//! request is sent again, up to `retries` times. Bus-off ends the exchange at once, and so does
//! the caller's `interrupted` (asked at least every [`SIGNAL_CHECK`] of the bus clock while
//! waiting: Ctrl-C). A 0x280 frame is exchanged only where it is torque (v1.61, LK-TECH: the
//! codec refuses to build one for MyActuator V3).

use std::time::Duration;

use rmd_bus::{BusError, BusEvent, BusMessage, CanBus, CanFrame, Clock, Received, Timestamp};
use rmd_protocol::{
    Command, Dialect, FIRST_MOTOR_CAN_ID, MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS, MotorId, Reply,
    SINGLE_MOTOR_BASE_ID, V3_REPLY_BASE_ID,
};

use crate::wait::SIGNAL_CHECK;

/// How a `Bus.request` waits: how long, how often to try, which dialect to read.
#[derive(Copy, Clone, Debug)]
pub(crate) struct RequestPolicy {
    /// Wait for the reply after each send.
    pub(crate) timeout: Duration,
    /// Sends after the first one.
    pub(crate) retries: u32,
    /// The motors' protocol.
    pub(crate) dialect: Dialect,
}

/// Why a `Bus.request` failed.
#[derive(Debug, thiserror::Error)]
pub(crate) enum RequestError {
    /// The bus refused the frame or failed.
    #[error("{0}")]
    Bus(#[from] BusError),
    /// The bus went bus-off.
    #[error(
        "the CAN controller went bus-off while waiting for motor {motor}: check the wiring, \
         the 120 ohm termination and the bit rate"
    )]
    BusOff {
        /// The motor asked.
        motor: String,
    },
    /// No reply within the timeout, after every attempt.
    #[error(
        "motor {motor} did not answer {command} within {} ms ({attempts} attempt{}): {advice}{}",
        timeout.as_millis(),
        if *attempts == 1 { "" } else { "s" },
        last.as_ref().map(|l| format!(" (the last frame it sent could not be read: {l})")).unwrap_or_default()
    )]
    NoReply {
        /// The motor(s) asked.
        motor: String,
        /// The request's command.
        command: &'static str,
        /// The timeout of each attempt.
        timeout: Duration,
        /// How many times the request was sent.
        attempts: u32,
        /// What to check.
        advice: String,
        /// The last unreadable answer, if any.
        last: Option<String>,
    },
    /// A motor answered on another family's reply identifier.
    #[error(
        "motor {motor} answered on 0x{can_id:03X}, as {other} firmware does, but the bus speaks \
         {dialect}: open it with protocol=\"{other_name}\"{lk}",
        other = if *can_id >= V3_REPLY_BASE_ID { "MyActuator V3" } else { "v1.61 or LK-TECH" },
        other_name = if *can_id >= V3_REPLY_BASE_ID { "myactuator-v3" } else { "v1.61" },
        lk = if *can_id >= V3_REPLY_BASE_ID { "" } else { " (or \"lk-v2.3x\" with lk_series)" }
    )]
    OtherFamily {
        /// The motor.
        motor: MotorId,
        /// Where it answered.
        can_id: u16,
        /// The bus's dialect.
        dialect: Dialect,
    },
    /// The frame is not a request to a motor.
    #[error("0x{0:03X} is not a request to a motor (0x141..=0x160 or 0x280)")]
    NotARequest(u16),
    /// The caller's `interrupted` said to stop waiting (its own error says why).
    #[error("interrupted while waiting for the reply")]
    Interrupted,
}

/// The replies to one `Bus.request`: one motor's, or motors 1..=4 of a 0x280 frame (`None` for a
/// motor that did not answer).
#[derive(Debug)]
pub(crate) enum RequestReplies {
    /// The motor's reply.
    One(MotorId, Reply),
    /// Replies of motors 1..=4, in order.
    Multi([Option<Reply>; MULTI_TORQUE_MOTORS]),
}

/// The identifier `motor` would answer on in the other families than `dialect`'s: `0x240 + id`
/// for a v1.61 or LK-TECH bus, `0x140 + id` for a MyActuator V3 one.
fn other_family_reply_id(dialect: Dialect, motor: MotorId) -> u16 {
    match dialect {
        Dialect::V161 | Dialect::LkV23x(_) => V3_REPLY_BASE_ID + u16::from(motor.get()),
        Dialect::MyActuatorV3(_) => SINGLE_MOTOR_BASE_ID + u16::from(motor.get()),
    }
}

/// Drops whatever is queued.
fn drain(bus: &mut impl CanBus, clock: &impl Clock) -> Result<(), BusError> {
    let now = clock.now();
    while bus.recv_until(now)?.is_some() {}
    Ok(())
}

/// The next message until `deadline`, in waits of at most [`SIGNAL_CHECK`], asking
/// `interrupted` after each wait that ended with nothing.
fn recv(
    bus: &mut impl CanBus,
    clock: &impl Clock,
    deadline: Timestamp,
    interrupted: &mut impl FnMut() -> bool,
) -> Result<Option<Received>, RequestError> {
    loop {
        let slice_end = deadline.min(clock.now() + SIGNAL_CHECK);
        if let Some(received) = bus.recv_until(slice_end)? {
            return Ok(Some(received));
        }
        if interrupted() {
            return Err(RequestError::Interrupted);
        }
        if clock.now() >= deadline {
            return Ok(None);
        }
    }
}

/// Sends `frame` and waits for its reply (or, for a 0x280 frame, for motors 1..=4) as the
/// module docs say. `advice` says what to check when nobody answers; `interrupted` ends the
/// wait when it returns true.
pub(crate) fn exchange(
    bus: &mut impl CanBus,
    clock: &impl Clock,
    frame: &CanFrame,
    policy: &RequestPolicy,
    advice: &str,
    interrupted: &mut impl FnMut() -> bool,
) -> Result<RequestReplies, RequestError> {
    let attempts = policy.retries.saturating_add(1);
    if frame.id() == MULTI_TORQUE_CAN_ID {
        return exchange_multi(bus, clock, frame, policy, advice, attempts, interrupted);
    }
    let motor =
        MotorId::from_can_id(frame.id()).map_err(|_| RequestError::NotARequest(frame.id()))?;
    let command = frame
        .data()
        .first()
        .and_then(|&code| Command::from_code(code))
        .ok_or(RequestError::NotARequest(frame.id()))?;
    let mut last = None;
    for _ in 0..attempts {
        drain(bus, clock)?;
        bus.send(frame)?;
        let deadline = clock.now() + policy.timeout;
        while let Some(received) = recv(bus, clock, deadline, interrupted)? {
            let reply = match received.message {
                BusMessage::Frame(reply) => reply,
                BusMessage::Event(BusEvent::BusOff) => {
                    return Err(RequestError::BusOff {
                        motor: motor.to_string(),
                    });
                }
                BusMessage::Event(_) => continue,
            };
            if reply.id() == other_family_reply_id(policy.dialect, motor) {
                return Err(RequestError::OtherFamily {
                    motor,
                    can_id: reply.id(),
                    dialect: policy.dialect,
                });
            }
            if reply.id() != policy.dialect.reply_id(motor) {
                continue;
            }
            match policy.dialect.decode_reply_to(&reply, command) {
                Ok((_, decoded)) => return Ok(RequestReplies::One(motor, decoded)),
                Err(error) => last = Some(error.to_string()),
            }
        }
    }
    Err(RequestError::NoReply {
        motor: motor.to_string(),
        command: command.name(),
        timeout: policy.timeout,
        attempts,
        advice: advice.to_owned(),
        last,
    })
}

fn exchange_multi(
    bus: &mut impl CanBus,
    clock: &impl Clock,
    frame: &CanFrame,
    policy: &RequestPolicy,
    advice: &str,
    attempts: u32,
    interrupted: &mut impl FnMut() -> bool,
) -> Result<RequestReplies, RequestError> {
    let mut last = None;
    for _ in 0..attempts {
        let mut replies: [Option<Reply>; MULTI_TORQUE_MOTORS] = Default::default();
        drain(bus, clock)?;
        bus.send(frame)?;
        let deadline = clock.now() + policy.timeout;
        while replies.iter().any(Option::is_none) {
            let Some(received) = recv(bus, clock, deadline, interrupted)? else {
                break;
            };
            let reply = match received.message {
                BusMessage::Frame(reply) => reply,
                BusMessage::Event(BusEvent::BusOff) => {
                    return Err(RequestError::BusOff {
                        motor: "1..=4".to_owned(),
                    });
                }
                BusMessage::Event(_) => continue,
            };
            let slot = usize::from(reply.id().wrapping_sub(FIRST_MOTOR_CAN_ID));
            let Some(entry) = replies.get_mut(slot) else {
                continue;
            };
            match policy.dialect.decode_reply_to(&reply, Command::Torque) {
                Ok((_, decoded)) => *entry = Some(decoded),
                Err(error) => last = Some(error.to_string()),
            }
        }
        if replies.iter().any(Option::is_some) {
            return Ok(RequestReplies::Multi(replies));
        }
    }
    Err(RequestError::NoReply {
        motor: "1..=4".to_owned(),
        command: "multi-torque",
        timeout: policy.timeout,
        attempts,
        advice: advice.to_owned(),
        last,
    })
}
