//! Receiving the replies until each motor has answered or the deadline passes: on every bus at
//! once when the buses can be waited on together (one `ppoll` over every SocketCAN socket or
//! simulator doorbell, see [`rmd_bus::ready`]), else bus after bus.

use core::time::Duration;

use rmd_bus::ready::wait_any;
use rmd_bus::{BusError, BusEvent, BusMessage, CanBus, Clock, Readiness, Timestamp, WaitOn};
use rmd_protocol::Command;

use super::Exchange;
use super::frames::{Incoming, match_reply};
use super::motor::ReplyClass;
use crate::report::Fault;
use crate::robot::MAX_BUSES;
use crate::stats::LoopStats;

/// The newest fresh reply of a collection: when it came, and its motor's round trip.
pub(crate) type NewestReply = Option<(Timestamp, Duration)>;

/// What a collection on every bus received: the newest fresh reply, and the longest round trip
/// among the newest replies of each bus.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Collected {
    /// When the newest fresh reply came.
    pub(crate) last_reply: Option<Timestamp>,
    /// The longest round trip of those replies' motors.
    pub(crate) rtt_max: Duration,
}

impl Collected {
    fn add(&mut self, newest: NewestReply) {
        if let Some((at, rtt)) = newest {
            self.last_reply = Some(self.last_reply.map_or(at, |l| l.max(at)));
            self.rtt_max = self.rtt_max.max(rtt);
        }
    }
}

impl<B: CanBus> Exchange<B> {
    /// Receives on every bus until each motor has fresh feedback or `deadline` passes. When
    /// every bus can be waited on together, takes what has arrived on each, then waits for the
    /// first of them ([`wait_any`]), and again; otherwise collects bus after bus.
    pub(crate) fn collect_all<C: Clock + ?Sized>(
        &mut self,
        clock: &C,
        tick: u64,
        deadline: Timestamp,
        max_age: u64,
        stats: &mut LoopStats,
    ) -> Result<Collected, Fault> {
        let n = self.links.len().min(MAX_BUSES);
        let mut collected = Collected::default();
        let together = self
            .links
            .iter_mut()
            .all(|link| !matches!(link.bus.readiness(), Readiness::Alone));
        if !together {
            for b in 0..n {
                collected.add(self.collect(b, tick, deadline, max_age, stats)?);
            }
            return Ok(collected);
        }
        loop {
            // Whatever has arrived, on every bus still waited for (a past deadline never waits).
            let mut waiting = [false; MAX_BUSES];
            for (b, waits) in waiting.iter_mut().enumerate().take(n) {
                if !self.bus_complete(b) {
                    collected.add(self.collect(b, tick, Timestamp::ZERO, max_age, stats)?);
                    *waits = !self.bus_complete(b);
                }
            }
            if !waiting.contains(&true) || clock.now() >= deadline {
                return Ok(collected);
            }
            let mut waits: [Option<WaitOn<'_>>; MAX_BUSES] = [None; MAX_BUSES];
            let (mut ready, mut alone) = (false, false);
            for ((link, wait), waits_for) in self.links.iter_mut().zip(&mut waits).zip(waiting) {
                if waits_for {
                    match link.bus.readiness() {
                        Readiness::Pending(on) => *wait = Some(on),
                        Readiness::Ready => ready = true,
                        Readiness::Alone => alone = true,
                    }
                }
            }
            if alone {
                // A bus that said it could wait with others no longer can: bus after bus.
                for (b, waits_for) in waiting.iter().enumerate().take(n) {
                    if *waits_for {
                        collected.add(self.collect(b, tick, deadline, max_age, stats)?);
                    }
                }
                return Ok(collected);
            }
            if ready {
                continue;
            }
            if wait_any(clock, waits.iter().flatten().copied(), deadline).is_err() {
                // The wait itself failed (a closed descriptor): count it, and collect what
                // remains bus after bus, each receive reporting its own errors.
                for (b, waits_for) in waiting.iter().enumerate().take(n) {
                    if *waits_for {
                        stats.buses[b].rx_errors += 1;
                        collected.add(self.collect(b, tick, deadline, max_age, stats)?);
                    }
                }
                return Ok(collected);
            }
        }
    }

    /// Receives from bus `b` until each of its motors has fresh feedback or `deadline` passes,
    /// accepting replies up to `max_age` ticks old as fresh in `tick`.
    pub(crate) fn collect(
        &mut self,
        b: usize,
        tick: u64,
        deadline: Timestamp,
        max_age: u64,
        stats: &mut LoopStats,
    ) -> Result<NewestReply, Fault> {
        let mut newest: NewestReply = None;
        while !self.bus_complete(b) {
            let received = match self.links[b].bus.recv_until(deadline) {
                Ok(None) => break,
                Ok(Some(received)) => received,
                Err(BusError::BusOff) => return Err(Fault::BusOff { bus: b }),
                Err(BusError::InterfaceDown) => {
                    return Err(Fault::Bus {
                        bus: b,
                        error: BusError::InterfaceDown,
                    });
                }
                Err(_) => {
                    // A transient receive error: count it and stop collecting on this bus for
                    // this tick rather than spin on it.
                    stats.buses[b].rx_errors += 1;
                    break;
                }
            };
            let frame = match received.message {
                BusMessage::Frame(frame) => frame,
                BusMessage::Event(event) => {
                    stats.buses[b].count_event(event);
                    if event == BusEvent::BusOff {
                        return Err(Fault::BusOff { bus: b });
                    }
                    continue;
                }
            };
            let joints = self.links[b].joints();
            let (m, status) = match match_reply(&frame, Command::Torque, &self.motors, joints) {
                Incoming::Foreign => {
                    stats.buses[b].unexpected_frames += 1;
                    continue;
                }
                Incoming::Bad { motor } => {
                    stats.motors[motor].bad_frames += 1;
                    continue;
                }
                Incoming::Reply { motor, reply } => match reply.status2() {
                    Some(status) => (motor, status),
                    None => {
                        stats.motors[motor].bad_frames += 1;
                        continue;
                    }
                },
            };
            let class = self.motors[m].on_reply(
                &status,
                received.at,
                tick,
                max_age,
                &mut self.feedback[m],
                &mut stats.motors[m],
            );
            if class == ReplyClass::Fresh
                && let Some(rtt) = self.motors[m].round_trip
                && newest.is_none_or(|(at, _)| received.at > at)
            {
                newest = Some((received.at, rtt));
            }
        }
        Ok(newest)
    }
}
