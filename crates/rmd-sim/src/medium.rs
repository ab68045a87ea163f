//! The event-driven model of one CAN wire: who transmits when, and for how long.
//!
//! - A frame occupies the wire for its exact stuffed length at the configured bit rate
//!   ([`rmd_bus::wire::frame_bits`], CRC-15 and stuff bits counted from the actual content).
//!   Receivers have it at the end of its end-of-frame field; the wire is free again after the
//!   3-bit intermission ([`rmd_bus::wire::INTERFRAME_BITS`]).
//! - When the wire is free, the frames ready to go arbitrate: the lowest identifier wins (on
//!   a tie of identifiers, which real controllers resolve with an error frame and a retry, the
//!   host goes first). A frame that becomes ready while the wire is busy waits for the
//!   intermission to end.
//! - The host has a FIFO transmit queue of a fixed depth (SocketCAN's default `txqueuelen` for
//!   CAN interfaces is 10); only its head takes part in arbitration, and a frame leaves the
//!   queue when its transmission starts.
//! - Each motor has a few transmit mailboxes (default 3, as on common MCU CAN controllers such
//!   as STM32 bxCAN); a reply that finds them all full is dropped by the firmware.
//! - "Instant" timing makes every frame take zero time: for overhead benchmarks of the loop.

use std::collections::VecDeque;

use rmd_bus::Timestamp;
use rmd_bus::wire::{INTERFRAME_BITS, bits_to_duration, frame_bits};
use rmd_protocol::CanFrame;

/// How long frames take on the wire.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum WireTiming {
    /// Real CAN timing at this bit rate (bit/s).
    Bitrate(u32),
    /// Frames take no time at all (benchmarks of the code around the bus).
    Instant,
}

/// A node on the wire.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// The host (the side a [`CanBus`](rmd_bus::CanBus) client sees).
    Host,
    /// A motor, by id (1..=32).
    Motor(u8),
}

/// One frame's passage over the wire.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Transmission {
    /// The frame.
    pub frame: CanFrame,
    /// Who sent it.
    pub from: Node,
    /// When its start-of-frame bit went out.
    pub start: Timestamp,
    /// When receivers have it (end of the end-of-frame field).
    pub delivered: Timestamp,
    /// When the wire is free again (after the intermission).
    pub end: Timestamp,
}

/// What happened when the wire model advanced by one event.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum WireStep {
    /// A transmission started.
    Started(Transmission),
    /// A transmission reached its receivers.
    Delivered(Transmission),
    /// The intermission after a transmission ended: the wire is free.
    Freed,
}

#[derive(Copy, Clone, Debug)]
struct Pending {
    ready: Timestamp,
    seq: u64,
    frame: CanFrame,
    motor: u8,
}

#[derive(Copy, Clone, Debug)]
struct OnWire {
    tx: Transmission,
    delivered: bool,
}

/// Why the wire refused a frame.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum QueueFull {
    /// The host's transmit queue is full.
    Host,
    /// The motor's mailboxes are full.
    Motor,
}

/// The wire and the transmit queues of its nodes.
#[derive(Debug)]
pub(crate) struct Wire {
    timing: WireTiming,
    host_queue: VecDeque<(Timestamp, CanFrame)>,
    host_queue_len: usize,
    /// The host cannot start a transmission before this time (a stalled controller).
    host_blocked_until: Timestamp,
    motor_queue: Vec<Pending>,
    motor_mailboxes: usize,
    on_wire: Option<OnWire>,
    /// When the wire became (or will become) free.
    free_at: Timestamp,
    seq: u64,
}

impl Wire {
    /// An idle wire. `motors` bounds the motor-side queue (`motors * motor_mailboxes` frames).
    pub(crate) fn new(
        timing: WireTiming,
        host_queue_len: usize,
        motors: usize,
        motor_mailboxes: usize,
        start: Timestamp,
    ) -> Self {
        Self {
            timing,
            host_queue: VecDeque::with_capacity(host_queue_len),
            host_queue_len,
            host_blocked_until: Timestamp::ZERO,
            motor_queue: Vec::with_capacity(motors * motor_mailboxes),
            motor_mailboxes,
            on_wire: None,
            free_at: start,
            seq: 0,
        }
    }

    /// Depth of the host's transmit queue.
    pub(crate) fn host_capacity(&self) -> usize {
        self.host_queue_len
    }

    /// Queues a host frame that became ready at `ready`.
    pub(crate) fn push_host(&mut self, ready: Timestamp, frame: CanFrame) -> Result<(), QueueFull> {
        if self.host_queue.len() >= self.host_queue_len {
            return Err(QueueFull::Host);
        }
        self.host_queue.push_back((ready, frame));
        Ok(())
    }

    /// Frames waiting in the host's transmit queue.
    pub(crate) fn host_queued(&self) -> usize {
        self.host_queue.len()
    }

    /// Queues a motor frame that becomes ready at `ready`.
    pub(crate) fn push_motor(
        &mut self,
        motor: u8,
        ready: Timestamp,
        frame: CanFrame,
    ) -> Result<(), QueueFull> {
        let queued = self.motor_queue.iter().filter(|p| p.motor == motor).count();
        if queued >= self.motor_mailboxes || self.motor_queue.len() == self.motor_queue.capacity() {
            return Err(QueueFull::Motor);
        }
        self.seq += 1;
        self.motor_queue.push(Pending {
            ready,
            seq: self.seq,
            frame,
            motor,
        });
        Ok(())
    }

    /// Keeps the host from starting any transmission before `until`.
    pub(crate) fn block_host_until(&mut self, until: Timestamp) {
        self.host_blocked_until = self.host_blocked_until.max(until);
    }

    /// Drops everything the host had queued, and aborts a host frame that is on the wire and
    /// not yet delivered (the wire is then free at `now`). Returns how many frames were lost.
    pub(crate) fn flush_host(&mut self, now: Timestamp) -> usize {
        let mut lost = self.host_queue.len();
        self.host_queue.clear();
        if let Some(w) = self.on_wire
            && w.tx.from == Node::Host
            && !w.delivered
        {
            self.on_wire = None;
            self.free_at = now;
            lost += 1;
        }
        lost
    }

    /// How long `frame` keeps receivers waiting (to its end of frame) and the wire busy.
    fn durations(&self, frame: &CanFrame) -> (core::time::Duration, core::time::Duration) {
        match self.timing {
            WireTiming::Instant => (core::time::Duration::ZERO, core::time::Duration::ZERO),
            WireTiming::Bitrate(bitrate) => {
                let bits = frame_bits(frame);
                (
                    bits_to_duration(bits - INTERFRAME_BITS, bitrate),
                    bits_to_duration(bits, bitrate),
                )
            }
        }
    }

    /// When the host's head frame can start, if there is one.
    fn host_ready(&self) -> Option<(Timestamp, CanFrame)> {
        self.host_queue
            .front()
            .map(|&(ready, frame)| (ready.max(self.host_blocked_until), frame))
    }

    /// The earliest time any queued frame is ready.
    fn earliest_ready(&self) -> Option<Timestamp> {
        let motor = self.motor_queue.iter().map(|p| p.ready).min();
        match (self.host_ready().map(|(t, _)| t), motor) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The time of the next event of the wire, if any.
    pub(crate) fn next_event(&self) -> Option<Timestamp> {
        match self.on_wire {
            Some(w) if !w.delivered => Some(w.tx.delivered),
            Some(w) => Some(w.tx.end),
            None => self.earliest_ready().map(|t| t.max(self.free_at)),
        }
    }

    /// Processes the next event. Returns it with its time, or `None` if nothing is pending.
    pub(crate) fn step(&mut self) -> Option<WireStep> {
        match self.on_wire {
            Some(mut w) if !w.delivered => {
                w.delivered = true;
                self.on_wire = Some(w);
                Some(WireStep::Delivered(w.tx))
            }
            Some(w) => {
                self.on_wire = None;
                self.free_at = w.tx.end;
                Some(WireStep::Freed)
            }
            None => {
                let start = self.earliest_ready()?.max(self.free_at);
                self.start_arbitrated(start).map(WireStep::Started)
            }
        }
    }

    /// Arbitration at `start` among the frames ready by then: lowest ID wins, the host first on
    /// a tie, then the motor frame queued first.
    fn start_arbitrated(&mut self, start: Timestamp) -> Option<Transmission> {
        let host = self.host_ready().filter(|&(t, _)| t <= start);
        let motor = self
            .motor_queue
            .iter()
            .enumerate()
            .filter(|(_, p)| p.ready <= start)
            .min_by_key(|(_, p)| (p.frame.id(), p.seq))
            .map(|(i, p)| (i, p.frame.id()));
        let host_wins = match (host, motor) {
            (Some((_, hf)), Some((_, mid))) => hf.id() <= mid,
            (Some(_), None) => true,
            _ => false,
        };
        let (frame, from) = if host_wins {
            let (_, frame) = self.host_queue.pop_front()?;
            (frame, Node::Host)
        } else {
            let (i, _) = motor?;
            let p = self.motor_queue.swap_remove(i);
            (p.frame, Node::Motor(p.motor))
        };
        let (to_eof, total) = self.durations(&frame);
        let tx = Transmission {
            frame,
            from,
            start,
            delivered: start + to_eof,
            end: start + total,
        };
        self.on_wire = Some(OnWire {
            tx,
            delivered: false,
        });
        Some(tx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::wire::frame_duration;

    fn f(id: u16, b: u8) -> CanFrame {
        CanFrame::with_data(id, [b; 8]).unwrap()
    }

    fn run(wire: &mut Wire) -> Vec<Transmission> {
        let mut out = Vec::new();
        while let Some(step) = wire.step() {
            if let WireStep::Delivered(tx) = step {
                out.push(tx);
            }
        }
        out
    }

    #[test]
    fn a_frame_takes_its_stuffed_length_and_the_next_waits_for_the_intermission() {
        let mut wire = Wire::new(WireTiming::Bitrate(1_000_000), 10, 4, 3, Timestamp::ZERO);
        let a = f(0x280, 0x00);
        let b = f(0x141, 0x55);
        wire.push_host(Timestamp::ZERO, a).unwrap();
        wire.push_host(Timestamp::ZERO, b).unwrap();
        let txs = run(&mut wire);
        let da = frame_duration(&a, 1_000_000);
        assert_eq!(txs[0].start, Timestamp::ZERO);
        assert_eq!(txs[0].end, Timestamp::ZERO + da);
        assert_eq!(
            txs[0].end - txs[0].delivered,
            bits_to_duration(3, 1_000_000)
        );
        // FIFO host queue: b starts when a's intermission ends.
        assert_eq!(txs[1].frame, b);
        assert_eq!(txs[1].start, txs[0].end);
    }

    #[test]
    fn lowest_id_wins_among_ready_frames() {
        let mut wire = Wire::new(WireTiming::Bitrate(500_000), 10, 4, 3, Timestamp::ZERO);
        let t = Timestamp::from_nanos(1_000);
        wire.push_motor(3, t, f(0x143, 1)).unwrap();
        wire.push_motor(1, t, f(0x141, 1)).unwrap();
        wire.push_host(t, f(0x280, 1)).unwrap();
        wire.push_motor(2, t + core::time::Duration::from_millis(5), f(0x142, 1))
            .unwrap();
        let ids: Vec<u16> = run(&mut wire).iter().map(|t| t.frame.id()).collect();
        // 0x141 and 0x143 beat 0x280; 0x142 was not ready yet.
        assert_eq!(ids, [0x141, 0x143, 0x280, 0x142]);
    }

    #[test]
    fn queues_have_fixed_depths() {
        let mut wire = Wire::new(WireTiming::Instant, 2, 1, 1, Timestamp::ZERO);
        wire.push_host(Timestamp::ZERO, f(1, 0)).unwrap();
        wire.push_host(Timestamp::ZERO, f(2, 0)).unwrap();
        assert_eq!(
            wire.push_host(Timestamp::ZERO, f(3, 0)),
            Err(QueueFull::Host)
        );
        wire.push_motor(1, Timestamp::ZERO, f(0x141, 0)).unwrap();
        assert_eq!(
            wire.push_motor(1, Timestamp::ZERO, f(0x141, 0)),
            Err(QueueFull::Motor)
        );
        // Instant timing: everything at time zero, in arbitration order.
        let txs = run(&mut wire);
        assert_eq!(txs.len(), 3);
        assert!(txs.iter().all(|t| t.end == Timestamp::ZERO));
    }

    #[test]
    fn a_blocked_host_waits_and_a_flush_aborts() {
        let mut wire = Wire::new(WireTiming::Bitrate(1_000_000), 10, 1, 3, Timestamp::ZERO);
        let until = Timestamp::from_nanos(1_000_000);
        wire.block_host_until(until);
        wire.push_host(Timestamp::ZERO, f(1, 0)).unwrap();
        assert_eq!(wire.next_event(), Some(until));
        let txs = run(&mut wire);
        assert_eq!(txs[0].start, until);

        wire.push_host(until, f(1, 0)).unwrap();
        wire.push_host(until, f(2, 0)).unwrap();
        assert!(matches!(wire.step(), Some(WireStep::Started(_))));
        assert_eq!(wire.flush_host(until), 2);
        assert_eq!(wire.next_event(), None);
    }
}
