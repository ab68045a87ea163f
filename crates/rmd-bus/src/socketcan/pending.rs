//! A small fixed-capacity FIFO of received items not yet handed out: the events of one error
//! frame beyond the first, or a frame held back behind a drop report. No allocation.

use crate::Received;

/// Capacity: every event one error frame can produce, plus a drop report, plus the frame
/// itself, with room to keep events received while draining.
pub(crate) const CAPACITY: usize = 32;

#[derive(Debug)]
pub(crate) struct Pending {
    items: [Option<Received>; CAPACITY],
    head: usize,
    len: usize,
}

impl Pending {
    pub(crate) const fn new() -> Self {
        Self {
            items: [None; CAPACITY],
            head: 0,
            len: 0,
        }
    }

    /// Appends `item`; returns `false` (and drops it) if full.
    pub(crate) fn push(&mut self, item: Received) -> bool {
        if self.len == CAPACITY {
            return false;
        }
        self.items[(self.head + self.len) % CAPACITY] = Some(item);
        self.len += 1;
        true
    }

    /// Whether nothing waits.
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Removes the oldest item.
    pub(crate) fn pop(&mut self) -> Option<Received> {
        if self.len == 0 {
            return None;
        }
        let item = self.items[self.head].take();
        self.head = (self.head + 1) % CAPACITY;
        self.len -= 1;
        item
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BusEvent, BusMessage, Timestamp};

    fn event(n: u64) -> Received {
        Received {
            at: Timestamp::from_nanos(n),
            message: BusMessage::Event(BusEvent::NoAck),
        }
    }

    #[test]
    fn items_come_out_in_order_and_a_full_queue_refuses_more() {
        let mut pending = Pending::new();
        assert_eq!(pending.pop(), None);
        assert!(pending.is_empty());
        for round in 0..3u64 {
            for n in 0..CAPACITY as u64 {
                assert!(pending.push(event(round * 100 + n)));
            }
            assert!(!pending.push(event(999)));
            for n in 0..CAPACITY as u64 {
                assert_eq!(pending.pop(), Some(event(round * 100 + n)));
            }
            assert_eq!(pending.pop(), None);
            // Leave the head somewhere in the middle for the next round.
            assert!(pending.push(event(7)));
            assert_eq!(pending.pop(), Some(event(7)));
        }
    }
}
