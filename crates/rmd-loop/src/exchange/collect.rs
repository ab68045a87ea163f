//! Receiving the replies until each motor has answered or the deadline passes: on every bus at
//! once when the buses can be waited on together (one `ppoll` over every SocketCAN socket or
//! simulator doorbell, see [`rmd_bus::ready`]), else bus after bus.
//!
//! Together, the collection receives only from the buses that owe replies and may have one: one
//! wait over the buses still owed replies ([`wait_any`]; a bus that says it is ready ends it at
//! once), then one receive on each bus the wait woke ([`Woken`]), and again, until none is owed
//! or the deadline passes. One receive per wake: replies come one at a time on the wire, so a
//! second receive would almost always find nothing.

use core::time::Duration;

use rmd_bus::ready::{Woken, wait_any};
use rmd_bus::{BusError, BusEvent, BusMessage, CanBus, Clock, Readiness, Timestamp, WaitOn};

use super::Exchange;
use super::motor::ReplyClass;
use crate::report::Fault;
use crate::robot::MAX_BUSES;
use crate::stats::LoopStats;

/// What a collection received: when the newest fresh reply came, and the longest round trip of
/// the motors that answered fresh.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Collected {
    /// When the newest fresh reply came, ns (meaningful once `any` is set).
    last_reply_ns: u64,
    /// Whether a fresh reply came.
    any: bool,
    /// The longest tracked round trip of the motors that answered fresh, ns.
    pub(crate) rtt_max_ns: u64,
}

impl Collected {
    #[inline]
    pub(super) fn add(&mut self, at: Timestamp, round_trip_ns: u64) {
        self.last_reply_ns = self.last_reply_ns.max(at.as_nanos());
        self.any = true;
        self.rtt_max_ns = self.rtt_max_ns.max(round_trip_ns);
    }

    /// When the newest fresh reply came, if one did.
    #[inline]
    pub(crate) fn last_reply(&self) -> Option<Timestamp> {
        self.any.then(|| Timestamp::from_nanos(self.last_reply_ns))
    }
}

/// What one receive on a bus gave.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(super) enum Received {
    /// A frame or an event, handled.
    Item,
    /// Nothing by the deadline.
    Nothing,
    /// A transient receive error, counted: the bus is left alone for the rest of the tick
    /// rather than spun on.
    GaveUp,
}

impl<B: CanBus> Exchange<B> {
    /// Receives on every bus until each motor has fresh feedback or `deadline` passes, accepting
    /// replies up to `max_age` ticks old as fresh in `tick`. When every bus can be waited on
    /// together: one wait over the buses still owed replies ([`wait_any`]), then one receive on
    /// each bus the wait names, and again; otherwise bus after bus.
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
        // The buses to receive from without waiting, and those left alone after an error.
        let mut receive = Woken::NONE;
        let mut given_up = Woken::NONE;
        loop {
            for b in receive.iter().take_while(|&b| b < n) {
                if self.owed[b] > 0
                    && !given_up.contains(b)
                    && self.receive(b, tick, Timestamp::ZERO, max_age, stats, &mut collected)?
                        == Received::GaveUp
                {
                    given_up = given_up.with(b);
                }
            }
            if self.owed_total == 0
                || (!given_up.is_empty()
                    && (0..n).all(|b| self.owed[b] == 0 || given_up.contains(b)))
            {
                return Ok(collected);
            }
            if clock.now() >= deadline {
                // A last look, without waiting, at every bus still owed replies.
                for b in 0..n {
                    if self.owed[b] > 0 && !given_up.contains(b) {
                        self.collect(b, tick, Timestamp::ZERO, max_age, stats, &mut collected)?;
                    }
                }
                return Ok(collected);
            }
            // One wait over the buses still owed replies; a ready one is an arrival that has
            // come, so the wait returns at once and names it.
            let owed = &self.owed;
            let mut alone = false;
            let waits = self.links.iter_mut().take(n).enumerate().map(|(b, link)| {
                if owed[b] == 0 || given_up.contains(b) {
                    return WaitOn::default();
                }
                match link.bus.readiness() {
                    Readiness::Pending(on) => on,
                    Readiness::Ready => WaitOn::arrival(Timestamp::ZERO, Duration::ZERO),
                    Readiness::Alone => {
                        alone = true;
                        WaitOn::arrival(Timestamp::ZERO, Duration::ZERO)
                    }
                }
            });
            let waited = wait_any(clock, waits, deadline);
            if alone {
                // A bus that cannot be waited on with others: bus after bus, each until the
                // deadline.
                for b in 0..n {
                    if self.owed[b] > 0 && !given_up.contains(b) {
                        self.collect(b, tick, deadline, max_age, stats, &mut collected)?;
                    }
                }
                return Ok(collected);
            }
            match waited {
                Ok(woken) => receive = woken,
                Err(_) => {
                    // The wait itself failed (a closed descriptor): count it, and collect what
                    // remains bus after bus, each receive reporting its own errors.
                    for b in 0..n {
                        if self.owed[b] > 0 && !given_up.contains(b) {
                            stats.buses[b].rx_errors += 1;
                            self.collect(b, tick, deadline, max_age, stats, &mut collected)?;
                        }
                    }
                    return Ok(collected);
                }
            }
        }
    }

    /// Receives from bus `b` until each of its motors has fresh feedback, it has nothing more
    /// by `deadline` (a past one: nothing more now), or a receive fails; accepts replies up to
    /// `max_age` ticks old as fresh in `tick`, and adds the fresh ones to `collected`.
    pub(crate) fn collect(
        &mut self,
        b: usize,
        tick: u64,
        deadline: Timestamp,
        max_age: u64,
        stats: &mut LoopStats,
        collected: &mut Collected,
    ) -> Result<(), Fault> {
        while self.owed[b] > 0
            && self.receive(b, tick, deadline, max_age, stats, collected)? == Received::Item
        {
        }
        Ok(())
    }

    /// Receives from bus `b` (as the start-up probe, `tick` 0) until none of its motors has a
    /// request outstanding, it has nothing more by `deadline`, or a receive fails: after the
    /// probe asked again, the answers to every request it sent are taken as answers, each to
    /// the oldest outstanding request (first in, first out), and none is left to be taken for
    /// the first tick's or counted unexpected.
    pub(crate) fn settle(
        &mut self,
        b: usize,
        deadline: Timestamp,
        stats: &mut LoopStats,
    ) -> Result<(), Fault> {
        let mut collected = Collected::default();
        while self.bus_awaits_replies(b)
            && self.receive(b, 0, deadline, u64::MAX, stats, &mut collected)? == Received::Item
        {
        }
        Ok(())
    }

    /// Receives one frame or event from bus `b` by `deadline` and handles it: a reply matched to
    /// its motor and request (fresh ones added to `collected`), anything else counted.
    // Inlined into the tick's collections whatever else calls it (the start-up's settle): left
    // to the compiler, a second caller made it a call per frame, about 190 instructions a tick
    // more (benches/tick-instructions.sh); inlined, 4x4 and 8x4 cost 500 and 1,200 fewer.
    #[inline(always)]
    fn receive(
        &mut self,
        b: usize,
        tick: u64,
        deadline: Timestamp,
        max_age: u64,
        stats: &mut LoopStats,
        collected: &mut Collected,
    ) -> Result<Received, Fault> {
        let received = match self.links[b].bus.recv_until(deadline) {
            Ok(None) => return Ok(Received::Nothing),
            Ok(Some(received)) => received,
            Err(BusError::BusOff) => return Err(Fault::BusOff { bus: b }),
            Err(BusError::InterfaceDown) => {
                return Err(Fault::Bus {
                    bus: b,
                    error: BusError::InterfaceDown,
                });
            }
            Err(_) => {
                stats.buses[b].rx_errors += 1;
                return Ok(Received::GaveUp);
            }
        };
        let frame = match received.message {
            BusMessage::Frame(frame) => frame,
            BusMessage::Event(event) => {
                stats.buses[b].count_event(event);
                if event == BusEvent::BusOff {
                    return Err(Fault::BusOff { bus: b });
                }
                return Ok(Received::Item);
            }
        };
        // Which of the bus's motors sent it (by the CAN id its reply comes on).
        let Some(m) = self.reply_motor(b, frame.id()) else {
            // A `motion` bus motor's status reply, or nobody's frame.
            return match self.status_only_motor(b, frame.id()) {
                Some(m) => self.on_other_reply(m, &frame, received.at, stats),
                None => {
                    stats.buses[b].unexpected_frames += 1;
                    Ok(Received::Item)
                }
            };
        };
        let (motor, feedback, counters) = (
            &mut self.motors[m],
            &mut self.feedback[m],
            &mut stats.motors[m],
        );
        let Some(status) = motor.expect.decode(&frame) else {
            // Not a torque reply: a motion-mode reply on a `motion` bus, a status reply (the
            // health rotation), or a bad frame.
            if motor.motion.is_some() {
                let window = (tick, max_age);
                return Ok(self.on_motion_frame(m, &frame, received.at, window, stats, collected));
            }
            return self.on_other_reply(m, &frame, received.at, stats);
        };
        let was_fresh = feedback.freshness.is_fresh();
        match motor.on_reply(&status, received.at, tick, max_age, feedback, counters) {
            ReplyClass::Fresh => {
                collected.add(received.at, motor.round_trip_ns().unwrap_or(0));
                if !was_fresh {
                    self.became_fresh(b);
                }
            }
            ReplyClass::Late => stats.late_total += 1,
            ReplyClass::Unexpected => {}
        }
        Ok(Received::Item)
    }
}
