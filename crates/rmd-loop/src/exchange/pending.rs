//! Matching replies to requests, per motor: the requests a motor has not answered yet.
//!
//! Every 0x280 frame asks each motor on its bus for one 0xA1 reply, and all replies look alike,
//! so the loop keeps, per motor, the frames not answered yet and the motor's round-trip time
//! (measured in the start-up probe exchange, when only one request is outstanding, then tracked
//! with a moving average). A reply can be late but not (much) early: it can only answer a request
//! whose expected arrival (`sent + round trip - tolerance`) it has reached. Among those it answers
//! the newest; the firmware answers in order, so older outstanding requests are then known lost.
//! The reply's age (this tick minus that request's tick) says whether it is this tick's reply or
//! one that missed an earlier deadline (late). A reply with nothing outstanding is a duplicate or
//! an answer to somebody else's request (unexpected).
//!
//! Why not first-in-first-out: after one lost reply, FIFO would take every later reply as the
//! answer to the previous tick (all late, for ever). Why the round trip: a motor slower than the
//! period answers the previous tick's frame shortly after this tick's frame was sent, and a late
//! reply arrives before the next request's reply is due; only the round trip tells them apart
//! from fresh replies.

use core::time::Duration;

use rmd_bus::Timestamp;

/// Outstanding requests kept per motor.
pub(crate) const PENDING_CAPACITY: usize = 8;

/// How much earlier than its tracked round trip a reply may arrive: a quarter of the round trip
/// plus 20 us (turnaround jitter, arbitration behind other motors).
fn early_tolerance(round_trip: Duration) -> Duration {
    round_trip / 4 + Duration::from_micros(20)
}

/// The ticks (and send times) of the frames a motor has not answered yet, oldest first.
#[derive(Copy, Clone, Debug)]
pub(crate) struct PendingRequests {
    entries: [(u64, Timestamp); PENDING_CAPACITY],
    head: usize,
    len: usize,
}

impl PendingRequests {
    pub(crate) fn new() -> Self {
        Self {
            entries: [(0, Timestamp::ZERO); PENDING_CAPACITY],
            head: 0,
            len: 0,
        }
    }

    fn get(&self, i: usize) -> (u64, Timestamp) {
        self.entries[(self.head + i) % PENDING_CAPACITY]
    }

    /// Records a request sent in `tick` at `at`; the oldest is given up if the ring is full.
    pub(crate) fn push(&mut self, tick: u64, at: Timestamp) {
        if self.len == PENDING_CAPACITY {
            self.head = (self.head + 1) % PENDING_CAPACITY;
            self.len -= 1;
        }
        self.entries[(self.head + self.len) % PENDING_CAPACITY] = (tick, at);
        self.len += 1;
    }

    /// Takes the request that a reply received at `received` answers: the newest request whose
    /// expected arrival, `sent + round_trip - tolerance`, has passed (any request sent before
    /// the reply when the round trip is not known yet). If the reply came earlier than expected
    /// for every request, it answers the oldest one sent before it. Older outstanding requests
    /// are dropped as lost.
    pub(crate) fn answer(
        &mut self,
        received: Timestamp,
        round_trip: Option<Duration>,
    ) -> Option<(u64, Timestamp)> {
        let mut oldest_causal = None;
        let mut newest_plausible = None;
        for i in 0..self.len {
            let (_, sent) = self.get(i);
            if sent > received {
                break; // sent after the reply arrived: cannot be what it answers
            }
            oldest_causal.get_or_insert(i);
            let plausible = match round_trip {
                None => true,
                Some(rtt) => received >= (sent + rtt).saturating_sub(early_tolerance(rtt)),
            };
            if plausible {
                newest_plausible = Some(i);
            }
        }
        let i = newest_plausible.or(oldest_causal)?;
        let answered = self.get(i);
        self.head = (self.head + i + 1) % PENDING_CAPACITY;
        self.len -= i + 1;
        Some(answered)
    }

    /// Forgets everything outstanding.
    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    /// Number of outstanding requests.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }
}
