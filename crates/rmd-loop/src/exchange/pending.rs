//! Matching replies to requests, per motor: the requests a motor has not answered yet.
//!
//! Every 0x280 frame asks each motor on its bus for one 0xA1 reply, and all replies look alike.
//! The firmware answers a motor's requests in the order they came (first in, first out), so a
//! reply answers the motor's **oldest** outstanding request, as long as it could be that
//! request's reply: it arrived at least the shortest physical round trip after the request was
//! sent (the request and the reply each on the wire: two 8-byte frames at the bus's bit rate).
//! The reply's age (this tick minus that request's tick) is its true age: a reply held up
//! behind a late one is counted late, never taken for this tick's. A reply that could answer no
//! outstanding request (none outstanding, or too early for the oldest: a duplicate right after
//! the original, or an answer to somebody else's request) is unexpected. The bound is physical,
//! not statistical: on a host whose round trips vary widely (a loaded or emulated machine, a
//! USB adapter that delivers frames in batches) a genuinely fast reply is still taken.
//!
//! A reply lost on the way leaves one request outstanding that no reply will answer, so every
//! later reply would seem one tick old. The motor's link notices: when the newest reply of
//! [`RESYNC_AFTER`] consecutive ticks was late yet arrived just when (within the tolerance) a
//! newer request's reply was due, the requests before that newer one are declared lost and the reply taken as its answer
//! ([`PendingRequests::drop_through`]). Until then those replies count as late: when in doubt,
//! feedback is not called fresh.

use core::time::Duration;

use rmd_bus::Timestamp;

/// Outstanding requests kept per motor.
pub(crate) const PENDING_CAPACITY: usize = 8;

/// Consecutive ticks whose newest reply was late but timed like the next request's reply, after
/// which the oldest outstanding request is declared lost.
pub(crate) const RESYNC_AFTER: u32 = 2;

/// Bit times of an 8-byte standard data frame without stuff bits (SOF, identifier, control, data,
/// CRC, delimiters, ACK, EOF): the least one can take on the wire.
const MIN_FRAME_BITS: u32 = 108;

/// The shortest time in which a motor can answer a request on a bus at `bitrate`: the request
/// and the reply each on the wire, nothing else.
pub(crate) fn min_round_trip(bitrate: u32) -> Duration {
    rmd_bus::wire::bits_to_duration(2 * MIN_FRAME_BITS, bitrate)
}

/// How far from its tracked round trip a reply may come and still count as on time for a
/// request (when resynchronising after lost replies): a quarter of the round trip plus 20 us
/// (turnaround jitter, arbitration behind other motors).
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

    /// Takes the request that a reply received at `received_ns` (bus clock, ns) answers: the
    /// oldest outstanding, if the reply could be its reply (it came at least
    /// `min_round_trip_ns` after the request was sent); `None` (an unexpected reply) otherwise.
    pub(crate) fn answer(
        &mut self,
        received_ns: u64,
        min_round_trip_ns: u64,
    ) -> Option<(u64, Timestamp)> {
        let (tick, sent) = self.oldest()?;
        if received_ns < sent.as_nanos().saturating_add(min_round_trip_ns) {
            return None;
        }
        self.drop_oldest();
        Some((tick, sent))
    }

    /// The oldest outstanding request.
    pub(crate) fn oldest(&self) -> Option<(u64, Timestamp)> {
        (self.len > 0).then(|| self.get(0))
    }

    /// Whether a reply received at `received` came when the reply to a request sent at `sent` was
    /// due: within the tolerance around `sent + round trip`.
    pub(crate) fn on_time_for(sent: Timestamp, received: Timestamp, round_trip: Duration) -> bool {
        let due = sent + round_trip;
        let tolerance = early_tolerance(round_trip);
        received >= due.saturating_sub(tolerance) && received <= due + tolerance
    }

    /// The oldest outstanding request that a reply received at `received` came on time for.
    pub(crate) fn on_time(&self, received: Timestamp, round_trip: Duration) -> Option<usize> {
        (0..self.len).find(|&i| Self::on_time_for(self.get(i).1, received, round_trip))
    }

    /// Gives up every outstanding request up to and including the one a reply received at
    /// `received` came on time for (the reply answered that one; the older ones' replies were
    /// lost).
    pub(crate) fn drop_through(&mut self, received: Timestamp, round_trip: Option<Duration>) {
        let answerable = round_trip.and_then(|rtt| self.on_time(received, rtt));
        if let Some(i) = answerable {
            self.head = (self.head + i + 1) % PENDING_CAPACITY;
            self.len -= i + 1;
        }
    }

    /// Gives up the oldest outstanding request (its reply was lost).
    pub(crate) fn drop_oldest(&mut self) {
        if self.len > 0 {
            self.head = (self.head + 1) % PENDING_CAPACITY;
            self.len -= 1;
        }
    }

    /// Forgets everything outstanding.
    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    /// Whether no request is outstanding.
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Number of outstanding requests.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }
}
