//! Sending a bus's torque requests: its 0x280 frame (`multi-torque`), one 0xA1 request per
//! motor (`per-motor`), or one motion-mode command per motor (`motion`), all of them before any
//! reply is collected.

use rmd_bus::{BusError, CanBus, Timestamp};
use rmd_protocol::{MULTI_TORQUE_MOTORS, ScaledCurrent};

use super::Exchange;
use super::frames::{ZERO_TORQUE, torque_frame, torque_request, zero_iq};
use super::motor::MotorLink;
use crate::bus_link::Requests;
use crate::report::Fault;
use crate::stats::LoopStats;

/// What a send carries.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Torque {
    /// The commands staged in the previous tick.
    Staged,
    /// Zero for every motor (the start-up probe).
    Zero,
}

impl<B: CanBus> Exchange<B> {
    /// Sends `torque` on bus `b` (one 0x280 frame, or one request per motor) and records the
    /// request, sent at `at` in `tick`, for each motor it went to. A full transmit queue is
    /// counted and rides through (the motors not reached will miss this tick); bus-off and a
    /// lost interface are faults.
    // Inlined into the tick's send loop whatever else calls it (the start-up probe): a call per
    // bus cost about 25 instructions a tick per bus more (benches/tick-instructions.sh).
    #[inline(always)]
    pub(crate) fn send(
        &mut self,
        b: usize,
        torque: Torque,
        tick: u64,
        at: Timestamp,
        stats: &mut LoopStats,
    ) -> Result<(), Fault> {
        let link = &mut self.links[b];
        link.commanded = true;
        match link.requests {
            Requests::Frame => {
                let slots = match torque {
                    Torque::Staged => &self.staged[b],
                    Torque::Zero => &ZERO_TORQUE,
                };
                match link.bus.send(&torque_frame(slots)) {
                    Ok(()) => {
                        for m in link.joints() {
                            self.motors[m].pending.push(tick, at);
                        }
                    }
                    Err(error) => sent_error(b, error, stats)?,
                }
            }
            Requests::FrameAndBeyond => self.send_frame_and_beyond(b, torque, tick, at, stats)?,
            Requests::Motion => {
                for m in link.joints() {
                    let motor = &mut self.motors[m];
                    let Some(motion) = &motor.motion else {
                        continue;
                    };
                    let command = match torque {
                        Torque::Staged => motion.staged,
                        Torque::Zero => motion.map.zero_torque(),
                    };
                    match link.bus.send(&motion.request(motor.id, &command)) {
                        Ok(()) => motor.pending.push(tick, at),
                        Err(error) => sent_error(b, error, stats)?,
                    }
                }
            }
            Requests::PerMotor => {
                for m in link.joints() {
                    let sent =
                        send_own_request(&mut link.bus, &mut self.motors[m], torque, tick, at);
                    if let Err(error) = sent {
                        sent_error(b, error, stats)?;
                    }
                }
            }
        }
        // The start-up probe asks for torque replies only.
        if torque == Torque::Staged {
            self.send_status(b, tick, at, stats)?;
        }
        Ok(())
    }
}

impl<B: CanBus> Exchange<B> {
    /// Sends `multi-torque` bus `b`'s 0x280 frame of `torque` for its motors 1..=4, then each
    /// motor beyond id 4 its own 0xA1 request.
    #[inline(never)]
    fn send_frame_and_beyond(
        &mut self,
        b: usize,
        torque: Torque,
        tick: u64,
        at: Timestamp,
        stats: &mut LoopStats,
    ) -> Result<(), Fault> {
        let link = &mut self.links[b];
        let slots = match torque {
            Torque::Staged => &self.staged[b],
            Torque::Zero => &ZERO_TORQUE,
        };
        match link.bus.send(&torque_frame(slots)) {
            Ok(()) => {
                for m in link.joints() {
                    let motor = &mut self.motors[m];
                    if motor.slot < MULTI_TORQUE_MOTORS {
                        motor.pending.push(tick, at);
                    }
                }
            }
            Err(error) => sent_error(b, error, stats)?,
        }
        for m in link.joints() {
            let motor = &mut self.motors[m];
            if motor.slot < MULTI_TORQUE_MOTORS {
                continue;
            }
            if let Err(error) = send_own_request(&mut link.bus, motor, torque, tick, at) {
                sent_error(b, error, stats)?;
            }
        }
        Ok(())
    }
}

/// Sends `motor` its own 0xA1 request of `torque` (in its dialect's scale) on `bus` and records
/// it, sent at `at` in `tick`.
#[inline(always)]
fn send_own_request<B: CanBus>(
    bus: &mut B,
    motor: &mut MotorLink,
    torque: Torque,
    tick: u64,
    at: Timestamp,
) -> Result<(), BusError> {
    let iq = match torque {
        Torque::Staged => ScaledCurrent::saturating(i64::from(motor.staged), motor.command.scale),
        Torque::Zero => zero_iq(motor.dialect),
    };
    bus.send(&torque_request(motor.dialect, motor.id, iq))?;
    motor.pending.push(tick, at);
    Ok(())
}

/// A refused send: counted; a full queue or a transient error rides through, bus-off and a lost
/// interface are faults.
pub(super) fn sent_error(b: usize, error: BusError, stats: &mut LoopStats) -> Result<(), Fault> {
    stats.buses[b].tx_errors += 1;
    match error {
        BusError::TxQueueFull | BusError::Io(_) => Ok(()),
        BusError::BusOff => Err(Fault::BusOff { bus: b }),
        error => Err(Fault::Bus { bus: b, error }),
    }
}
