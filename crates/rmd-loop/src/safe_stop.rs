//! Making the motors safe when the loop ends, whatever the reason: a zero-torque 0x280 frame on
//! every bus, then motor-off (0x80) to every motor, then a bounded wait for each motor to
//! confirm. A fault on one bus does not stop the others from being made safe.

use core::time::Duration;

use rmd_bus::{BusError, BusMessage, CanBus, Clock, Timestamp};
use rmd_protocol::{CanFrame, Command, Reply, Request};

use crate::exchange::Exchange;
use crate::exchange::frames::{Incoming, ZERO_TORQUE, match_reply, torque_frame};
use crate::report::{MotorSafeStop, SafeStopReport};
use crate::robot::Robot;

/// How long to keep retrying a frame the transmit queue refuses.
const SEND_RETRY_FOR: Duration = Duration::from_millis(20);
/// Pause between retries.
const SEND_RETRY_EVERY: Duration = Duration::from_micros(200);
/// How long to wait for the motors to confirm motor-off.
const CONFIRM_WITHIN: Duration = Duration::from_millis(50);

/// Sends `frame`, retrying while the transmit queue is full; gives up on other errors.
fn send_with_retry<B: CanBus, C: Clock>(bus: &mut B, clock: &C, frame: &CanFrame) -> bool {
    let give_up = clock.now() + SEND_RETRY_FOR;
    loop {
        match bus.send(frame) {
            Ok(()) => return true,
            Err(BusError::TxQueueFull) if clock.now() < give_up => {
                let now = clock.now();
                clock.sleep_until(now + SEND_RETRY_EVERY);
            }
            Err(_) => return false,
        }
    }
}

/// Zero torque, then motor off, to every motor on every bus; reports what was confirmed.
pub(crate) fn make_safe<B: CanBus, C: Clock>(
    clock: &C,
    exchange: &mut Exchange<B>,
    robot: &Robot,
) -> SafeStopReport {
    let mut report = SafeStopReport {
        motors: robot
            .joints()
            .iter()
            .map(|j| MotorSafeStop {
                joint: j.name.clone(),
                bus: j.bus,
                motor: j.motor,
                zero_torque_sent: false,
                off_sent: false,
                off_confirmed: false,
            })
            .collect(),
    };
    let Exchange { links, motors, .. } = exchange;
    // 1. Zero torque on every bus first: the fastest way to remove torque everywhere.
    let zero = torque_frame(&ZERO_TORQUE);
    for link in links.iter_mut() {
        let sent = send_with_retry(&mut link.bus, clock, &zero);
        for m in link.joints() {
            report.motors[m].zero_torque_sent = sent;
        }
    }
    // 2. Motor off to each motor (clears its state and commands; it stays off until commanded).
    for link in links.iter_mut() {
        for m in link.joints() {
            let off = Request::MotorOff.encode(motors[m].id);
            report.motors[m].off_sent = send_with_retry(&mut link.bus, clock, &off);
        }
    }
    // 3. Wait for the echoes of motor-off (torque replies to the zero frame are skipped).
    let deadline: Timestamp = clock.now() + CONFIRM_WITHIN;
    for link in links.iter_mut() {
        let range = link.joints();
        while range
            .clone()
            .any(|m| report.motors[m].off_sent && !report.motors[m].off_confirmed)
        {
            match link.bus.recv_until(deadline) {
                Ok(Some(received)) => {
                    if let BusMessage::Frame(frame) = received.message
                        && let Incoming::Reply {
                            motor,
                            reply: Reply::MotorOff,
                        } = match_reply(&frame, Command::MotorOff, motors, range.clone())
                    {
                        report.motors[motor].off_confirmed = true;
                    }
                }
                Ok(None) | Err(_) => break,
            }
        }
    }
    report
}
